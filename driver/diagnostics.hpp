// Stability diagnostics of a run, beside its verdicts (driver/verdicts.hpp: the energy-balance
// residual, SPEC §3-4, and the step-to-step oscillation detector): a lane order parameter (the
// seed's N = 100 lanes, sec. "Model and numerical methods"), a diagnostic window (the time loop
// continued from a run's final state and sampled at every step), and a classification of a run as
// stable / oscillating / diverged. Criteria and thresholds are documented in
// studies/stability/README.md; the comparison engine and the methodology studies report them.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "driver/run.hpp"
#include "driver/run_status.hpp"
#include "driver/verdicts.hpp"

namespace jamflow::diagnostics {

// ---- Scalar series ------------------------------------------------------------------------

// Lag-1 autocorrelation coefficient of a series (0 for fewer than 3 points or no variance).
double lag1_autocorrelation(const std::vector<double>& x);

// x[k+1] - x[k].
std::vector<double> increments(const std::vector<double>& x);

// Error of the mean difference a - b over the averaging window (samples with time > t_eq),
// from block averages of the paired difference series. Runs that share the start state, the
// seed and the sampling grid have correlated fluctuations as long as their trajectories stay
// close, so this floor can be far below the combined block errors. NaN if the sample times
// differ or there are fewer than `blocks` samples.
double paired_error(const Series& a, const Series& b, double t_eq, double Sample::*field,
                    std::size_t blocks);

// ---- Lanes ----------------------------------------------------------------------------------

// Lane order parameter: lanes (strings along the flow, stacked in the gradient-vorticity
// plane) show as Bragg-like peaks of the density projected on that plane. With scaled
// coordinates s, S(m) = |sum_j exp(2 pi i (m_y s_y + m_z s_z))|^2 / N for integer
// (m_y, m_z) != 0, |m| <= m_max (k_x = 0 is compatible with the Lees-Edwards cell).
// order = max_m <S(m)>_snapshots / N: O(1/N) x a few for a homogeneous liquid, O(1) for lanes.
// The non-affine velocity profile v_x(y) = <F_x / xi_s> in n_bins slabs across y is reported
// as amplitude = rms over slabs of v_x divided by gdot L_y (0 for homogeneous flow).
class LaneAccumulator {
 public:
  // m_max: largest |m| component (0: chosen from the box so that spacings down to 0.7 a
  // are resolved); n_bins: slabs for the velocity profile.
  explicit LaneAccumulator(int m_max = 0, int n_bins = 8) : m_max_(m_max), n_bins_(n_bins) {}
  void add(const State& state);                                             // density snapshot
  void add_velocity(const State& state, const std::vector<double>& force);  // SoA forces
  std::size_t snapshots() const { return snapshots_; }
  double order() const;  // max_m <S(m)> / N, 0 without snapshots
  int peak_my() const;
  int peak_mz() const;
  // rms over slabs of <F_x / xi_s>(y), divided by gdot * L_y (NaN if gdot == 0 or no data).
  double velocity_amplitude(double gdot) const;
  std::vector<double> velocity_profile() const;

 private:
  std::size_t peak_index() const;
  int m_max_;
  int n_bins_;
  std::size_t n_ = 0;
  std::size_t snapshots_ = 0;
  std::vector<double> s_sum_;  // accumulated S(m), (2 m_max + 1) x (m_max + 1) half plane
  std::vector<double> v_sum_;
  std::vector<double> v_count_;
  double ly_sum_ = 0.0;
  std::size_t v_snapshots_ = 0;
};

// ---- Diagnostic window and classification --------------------------------------------------

struct WindowOptions {
  int steps = 256;          // integrator steps sampled one by one
  int lane_snapshots = 16;  // density snapshots over the window (plus the run's final state)
  // Adaptive integrators (no nominal dt): the sampling interval; 0: the run's sample_every / 16.
  // The step-correlation test then measures how smooth the forces are over that interval, so
  // it must be short next to the contacts' relaxation time to mean anything.
  double adaptive_step = 0.0;
};

struct WindowResult {
  RunStatus status;       // or failed, with the IntegrationError message
  double step = 0.0;      // sampling interval (the integrator's nominal dt)
  bool adaptive = false;  // no nominal dt (CVODE): no step-to-step oscillation
  std::size_t steps_done = 0;
  double force_correlation = 1.0;  // StepCorrelation::correlation
  double alternating_share = 0.0;
  double reversed_fraction = 0.0;
  double dsigma_lag1 = 0.0;  // lag-1 autocorrelation of sigma_xy increments
  double dpressure_lag1 = 0.0;
  double mean_dissipation = 0.0;
  double lane_order = 0.0;
  int lane_my = 0, lane_mz = 0;
  double velocity_amplitude = 0.0;
  std::vector<double> sigma_xy, pressure, dissipation;  // per step
  bool finite = true;
};

// Continues `spec` from `start` for options.steps steps of the integrator's nominal dt (or, for
// adaptive integrators, options.adaptive_step, by default spec.sample_every / 16), sampling
// every step.
WindowResult diagnostic_window(const RunSpec& spec, const State& start,
                               const WindowOptions& options);

// kIncomplete: stopped by the study's budget for one run ([run] max_force_evaluations: too slow
// to finish). kNotSteady: stable, but the run's own steady verdict (driver/verdicts.hpp) failed:
// its averaging window still drifts. kCorrelated: stable and steady, but its decorrelated
// verdict failed (blocks shorter than 2 tau) and it has a single replica, so its block errors
// are too small and there is no replica scatter to take instead (the rule of the sweep's
// collect and of analysis/data.cpp). Like every verdict but kStable, each keeps the point out of
// a study's conclusions, and the report says why.
enum class Verdict {
  kStable,
  kOscillating,
  kDiverged,
  kNotAvailable,
  kIncomplete,
  kNotSteady,
  kCorrelated
};
std::string verdict_name(Verdict v);

struct Thresholds {
  double force_correlation_min = 0.9;  // below: period-2 share of the force power > 5 %
  double balance_tolerance = 0.05;     // |ratio - 1| above max(this, balance_sigmas * error)
  double balance_sigmas = 3.0;
  double lane_order_min = 0.3;  // laned at or above
};

struct Classification {
  Verdict verdict = Verdict::kStable;
  std::string reason;  // what triggered the verdict, or what was checked
  bool laned = false;
  // The run's decorrelated verdict failed (blocks shorter than 2 tau): its block errors are too
  // small. With one replica the verdict is kCorrelated (excluded); with several, the replica
  // scatter bounds the error and the point is kept.
  bool correlated = false;
};

Classification classify(const ReplicaResult& result, const EnergyBalance& balance,
                        const WindowResult* window, const Thresholds& thresholds);

}  // namespace jamflow::diagnostics
