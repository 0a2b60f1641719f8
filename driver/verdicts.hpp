// What every run is judged by (the verdicts of its summary): is it steady, stable and
// decorrelated? The numerics here are shared with the methodology studies.
//
// - steady: no significant trend of the block means of phi, sigma_xy and P_hat across the
//   averaging window. The test: the least-squares slope of the block means against the block
//   index, divided by its standard error from the residual scatter (inflated by (1 + r) /
//   (1 - r) for a lag-1 autocorrelation r of the residuals, as blocks shorter than tau are
//   correlated), is a Student t with blocks - 2 degrees of freedom for independent blocks
//   without a trend; |t| > 4 fails (p < 0.001 per observable at 20 blocks, so a healthy run
//   fails by chance about once in 300). An observable that is constant (phi at constant
//   volume) passes.
// - stable: the energy balance (below) within max(0.05, 3 sigma) of 1, and no step-to-step
//   oscillation of the forces (StepCorrelation over consecutive integrator steps at each sample
//   of the window: correlation below 0.9, a period-2 share of the force power above 5%, fails).
// - decorrelated: every block at least 2 integrated autocorrelation times of sigma_xy,
//   P_hat and phi long.
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "driver/run.hpp"

namespace jamflow {

// ---- Step-to-step oscillation ---------------------------------------------------------------

// Correlation of consecutive force vectors F_n (one per integrator step, particles in id
// order): c = sum_n F_n . F_{n+1} / sum_n (|F_n|^2 + |F_{n+1}|^2) / 2. Smooth dynamics gives
// c -> 1; a period-2 mode F_n = A (-1)^n gives -1. Writing F = F_smooth + (-1)^n F_alt,
// the alternating share of the force power is (1 - c) / 2. Also counts the fraction of
// particles (groups of `group` components) whose force reverses from one step to the next.
class StepCorrelation {
 public:
  explicit StepCorrelation(std::size_t group = 3) : group_(group) {}
  void add(const std::vector<double>& v);
  std::size_t pairs() const { return pairs_; }
  double correlation() const;        // c; 1 with fewer than 2 vectors
  double alternating_share() const;  // (1 - c) / 2
  double reversed_fraction() const;  // mean fraction of groups with F_n . F_{n+1} < 0
  bool finite() const { return finite_; }

 private:
  std::size_t group_;
  std::vector<double> prev_;
  double cross_ = 0.0, norm_ = 0.0, reversed_ = 0.0;
  std::size_t pairs_ = 0;
  bool finite_ = true;
};

// ---- Energy balance -------------------------------------------------------------------------

// Steady-state energy balance over the averaging window (samples with time > t_eq), SPEC §3:
//   <sigma_xy gdot V> = <D> + xi_V <(dV/dt)^2> + (Delta U + P Delta V) / T_window,
// the last term (zero in a true steady state) removing the drift of the enthalpy U + P V over
// a window that is not yet stationary. ratio = <W> / (<D + D_piston> + drift), its error from
// the block scatter of the per-block ratios, residual = |ratio - 1|.
struct EnergyBalance {
  double ratio = 0.0;
  double error = 0.0;
  double residual = 0.0;
  double drift = 0.0;      // (Delta U + P Delta V) / T, in units of power
  double raw_ratio = 0.0;  // <W> / <D + D_piston> without the drift term (the engine's value)
  bool valid = false;
};
EnergyBalance energy_balance(const std::vector<Sample>& samples, double t_eq, double gdot,
                             std::optional<double> imposed_pressure, std::size_t blocks);

// The t statistic of a linear trend in `means` (block means, in order): slope / standard error
// of the slope, from ordinary least squares against the index. 0 for a constant series, NaN for
// fewer than 3 means.
double trend_t(const std::vector<double>& means);

// Thresholds of the verdicts (see above).
struct VerdictThresholds {
  double trend_t_max = 4.0;
  double balance_tolerance = 0.05;  // |ratio - 1| above max(this, balance_sigmas * error) fails
  double balance_sigmas = 3.0;
  double force_correlation_min = 0.9;
  double decorrelation_blocks = 2.0;  // block length / tau at least this
};

}  // namespace jamflow
