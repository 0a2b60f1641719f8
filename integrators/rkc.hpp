// RKC: an adaptive, second-order, stabilized explicit Runge–Kutta–Chebyshev method (Sommeijer,
// Shampine & Verwer, J. Comput. Appl. Math. 88, 315 (1998); Verwer, Hundsdorfer & Sommeijer,
// Numer. Math. 57, 157 (1990)), behind the Integrator interface. Same equations as every
// integrator (integrator.hpp), taken from the one equation of motion (motion.hpp).
//
// Why. Near jamming the dynamics is stiff: the contact stiffness bounds explicit Euler's step to
// dt < 2 / rho (rho, the spectral radius of the force Jacobian, is about 5 in a dense packing),
// while the motion it resolves (shear at gdot = 1e-6, slow rearrangements) changes on times of
// 10-1000 tau_0. An s-stage RKC step is stable for dt rho <= beta(s) ~ 0.65 s^2, so its cost per
// unit time grows like sqrt(rho / dt) instead of rho: with s = 20 stages a step of ~250 tau_0 is
// stable. The step is then chosen by the error, not by the stiffness.
//
// The method. Damped second-order RKC (damping eps = 2/13): with w0 = 1 + eps / s^2, T_j the
// Chebyshev polynomials of the first kind and w1 = T_s'(w0) / T_s''(w0), b_j = T_j'' / T_j'^2
// (j >= 2, b_0 = b_1 = b_2), a_j = 1 - b_j T_j(w0), one step of size h from y_n is
//   Y_0 = y_n,  Y_1 = Y_0 + mu~_1 h F_0,
//   Y_j = (1 - mu_j - nu_j) Y_0 + mu_j Y_{j-1} + nu_j Y_{j-2} + mu~_j h F_{j-1} + gamma~_j h F_0,
//   y_{n+1} = Y_s,      F_j = f(t_n + c_j h, Y_j),
// with mu~_1 = b_1 w1, mu_j = 2 b_j w0 / b_{j-1}, nu_j = -b_j / b_{j-2}, mu~_j = 2 b_j w1 /
// b_{j-1}, gamma~_j = -a_{j-1} mu~_j, and stage times c_j = w1 T_j'' / T_j' (c_1 = c_2 / T_2',
// c_s = 1). Each stage is evaluated with the cell of its own time, so the Lees–Edwards shift of
// a stage is that of t_n + c_j h (with the shift of the step's start, errors were 56-73
// overlaps). The ODE state is the equation of motion's y, re-referenced at the start of every
// step (y_n = 0), so the stages are displacements from the step's start.
//
// Error and step control. The embedded estimate of Sommeijer et al.'s RKC code,
//   est = (12 (y_n - y_{n+1}) + 6 h (F(y_n) + F(y_{n+1}))) / 15,
// needs F(y_{n+1}), which is the next step's F_0 (first same as last): a step costs s force
// passes. err = RMS(est_i / (atol_i + rtol |y_{n+1,i}|)) with atol_i the atol length in box
// lengths for a particle, 3 atol / l for the relative volume (as CVODE, cvode.hpp). A step with
// err > 1 is rejected; the next step is 0.7 err^(-1/2) h, by at most 10x either way (the error
// near jamming grows about as h, not h^3, because contacts open and close within a step; see
// kSafety in rkc.cpp for the measurements behind this choice).
//
// Stiffness. rho is estimated by nonlinear power iteration on force differences, (f(y + dv) -
// f(y)) / |dv|, from a fixed pseudo-random start vector (so that the estimate depends only on
// the state: a resumed run repeats it bit for bit), and used times dom_eig_safety (1.2: power
// iteration underestimates rho by a few per cent, and at 1.0 runs were partly unstable). It
// is re-estimated every dom_eig_frequency steps, after a second rejection in a row and after
// every discrete event (a remap, a reset, a state this integrator did not leave). The piston's mode
// is part of y, so it counts in rho. The stage count is s = 1 + floor(sqrt(1 + 1.54 h rho))
// (beta(s) ~ 0.653 (s^2 - 1)), at least 2; above max_stages the step is cut to fit.
//
// Steps end exactly at the time advance() is asked for (the run's sample times) and at every
// Lees–Edwards remap, which Model::prepare_step() applies between steps; the neighbour list is
// valid at every stage (the equation of motion rebuilds it when its bound fails). A step cut
// short by such an end keeps the controller's proposal for the step after it.
//
// Interface. Debian 12's SUNDIALS (6.4) has no ARKODE LSRKStep (added in 7.2), so the method is
// written here. Its settings mirror LSRKStep's: ARKODE_LSRK_RKC_2, SStolerances (rtol, atol),
// SetMaxNumStages (max_stages), SetDomEigSafetyFactor (dom_eig_safety), SetDomEigFrequency
// (dom_eig_frequency), with the dominant-eigenvalue estimate supplied by power iteration as
// LSRKStep's SetDomEigFn would take it; so it can be swapped for LSRKStep once the distribution
// ships it.
//
// Checkpoints. Everything RKC carries between steps is a handful of numbers (the proposed step,
// rho and the steps since its estimate), kept in statistics(), so a
// resumed run continues bit for bit (has_solver_history() is false).
//
// Scene keys ([integrator] kind = "rkc"):
//   rtol               relative tolerance on a step's displacements (in (0, 1); default 1e-2)
//   atol               absolute tolerance, a length in units of a (> 0; default 1e-2 delta,
//                      delta = (P / eps)^(1 / (alpha_r - 1)) a the typical overlap, as CVODE's
//                      default with 1e-2 for 1e-3)
//   max_stages         the most stages per step (integer in [2, 10000]; default 200)
//   dom_eig_safety     factor on the estimated spectral radius (>= 1; default 1.2)
//   dom_eig_frequency  steps between spectral-radius estimates (integer >= 1; default 25)
//
// statistics(): steps, rejected_steps, stage_evaluations, dom_eig_estimates,
// dom_eig_evaluations, max_stages_used, and the carried state: spectral_radius, step_next,
// step_last, error_last, steps_since_dom_eig, need_dom_eig.
#pragma once
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "integrators/integrator.hpp"

namespace jamflow {

struct RkcOptions {
  double rtol = 1e-2;
  std::optional<double> atol;  // units of a; default from the overlap scale
  int max_stages = 200;
  double dom_eig_safety = 1.2;
  int dom_eig_frequency = 25;

  void validate() const;  // ConfigError naming the key
};

// Default atol (units of a) for a pressure scale p and pair exponent alpha: 1e-2 of the overlap.
double rkc_default_atol(double pressure, double alpha);

// The coefficients of one damped second-order RKC step with s stages (index j = 0..s).
struct RkcCoefficients {
  std::vector<double> mu, nu, mu_tilde, gamma_tilde, c;
  // The real stability interval: the step is stable for h rho <= beta.
  double beta = 0.0;
};
RkcCoefficients rkc_coefficients(int stages);

// The spectral radius of the equation of motion's Jacobian at the Model's current state, by
// nonlinear power iteration on force differences (as RKC estimates it), without the safety
// factor; `evaluations` is incremented by the force passes it took. Exposed for tests.
double rkc_spectral_radius(Model& model, const Ensemble& ensemble, long long* evaluations);

class Rkc final : public Integrator {
 public:
  explicit Rkc(const RkcOptions& options);
  ~Rkc() override;
  Rkc(const Rkc&) = delete;
  Rkc& operator=(const Rkc&) = delete;

  std::string name() const override { return "rkc"; }
  int order() const override { return 2; }
  // Adaptive: the cost per unit time is known only once it ran (NaN).
  double force_passes_per_time(const Ensemble& ensemble) const override;
  // Measured (rkc.cpp): grows with the pressure and as atol / delta falls.
  double cpu_seconds_per_particle_time(const Ensemble& ensemble,
                                       const CostPoint& at) const override;
  void advance(Model& model, const Ensemble& ensemble, double t_end) override;
  void reset() override;
  std::vector<std::pair<std::string, double>> statistics() const override;
  void restore_statistics(const std::vector<std::pair<std::string, double>>& stats) override;

  const RkcOptions& options() const { return options_; }

 private:
  struct Work;
  RkcOptions options_;
  std::unique_ptr<Work> work_;
  // Counters.
  long long steps_ = 0, rejected_ = 0, stage_evaluations_ = 0, dom_eig_estimates_ = 0,
            dom_eig_evaluations_ = 0, max_stages_used_ = 0;
  // The state carried between steps (all of it: a checkpoint keeps it exactly).
  double rho_ = 0.0;        // the last estimate, without the safety factor (0: none yet)
  double step_next_ = 0.0;  // the controller's proposal (0: choose from rho)
  double step_last_ = 0.0, error_last_ = 0.0;  // the last accepted step and its error
  long long since_dom_eig_ = 0;
  bool need_dom_eig_ = true;
  // The state this integrator left behind (a different one is a discrete event).
  bool left_valid_ = false;
  double left_time_ = 0.0;
};

}  // namespace jamflow
