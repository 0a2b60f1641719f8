// CVODE (SUNDIALS 6.4): variable-order, variable-step BDF (or Adams) with Newton–Krylov
// (SPGMR or PCG), behind the Integrator interface. Same equations as Euler (integrator.hpp).
//
// ODE system. The equation of motion of integrators/motion.hpp (EquationOfMotion): y is the
// non-affine displacement since the last (re)initialisation plus, with a piston, the relative
// volume; the piston is part of the ODE system, and every right-hand side keeps the neighbour
// list valid.
//
// Discrete changes. advance() integrates in stretches and calls Model::prepare_step() before
// each; it re-initialises CVODE (dropping its history, y = 0 at the current state) whenever
// that returns true (Lees–Edwards remap or particle reordering), when reset() was called, or
// when the Model's state is not the one this integrator left behind (another integrator, a
// restart, an edited state). The tilt is linear in t, so each stretch stops exactly where
// |tilt| passes 1/2 (CVodeSetStopTime); the remap and re-initialisation follow. Every call
// ends exactly at t_end, with the Model's forces evaluated at the final y.
//
// Interruption. A stretch is taken one internal step per CVode call (CV_ONE_STEP up to the
// stop time: the same steps and bits as one CV_NORMAL call), and the interrupt flag is polled
// after each, so a stop waits for one internal step, not for the rest of a stretch. The Model
// is then left at that step's time and solution, with forces evaluated. advance() to the same
// t_end continues the stretch with the solver's history, bit for bit as if never stopped; a
// checkpoint of the stopped state resumes with a fresh history (has_solver_history()).
//
// Jacobian. Matrix-free, analytic: J v over the contacts (pair stiffness U'' along the
// contact normal, -f/r across it), with the exact couplings to the piston: the affine
// dilation of the contacts (dF/dw) and the change of the virial (dP_hat/du, dP_hat/dw). The
// contact data are refreshed at every Newton iterate (CVODE's jtsetup): exact Newton. A
// Jacobian lagged to the preconditioner setups cost 53 nonlinear convergence failures per
// 200 tau_0 on N = 1000, phi = 0.62, gdot = 1e-3 at rtol = atol = 1e-4, and none when current.
// With linear_solver = "pcg" only the symmetric part is used (no gdot term, no
// particle-piston coupling): I - gamma J must be SPD, which fails if gamma exceeds
// 1 / |most negative Hessian eigenvalue| (tensile contacts); SPGMR has no such limit.
// The "jacobi" preconditioner (default) is block-diagonal: per particle I + gamma sum_j U''_ij
// n n^T / xi_s (the positive semidefinite normal part of the 3x3 diagonal Hessian block, always
// invertible), and 1 - gamma J_ww for the piston. It pays modestly: 15-30 % fewer force
// evaluations than "none" on the state point above.
//
// Tolerances. rtol (default 1e-6) is CVODE's relative tolerance on y. atol is a length in
// units of a: the accepted local error of a particle displacement (atol / l in u), and of
// the volume as its effect on contact lengths (dV/V = 3 dl/l, so 3 atol in w). The default
//   atol = 1e-3 delta,  delta = (P / eps)^(1 / (alpha_r - 1)) a, clamped to [1e-9, 1] a,
// is a thousandth of the typical overlap at pressure P (harmonic: delta ~ P): errors stay
// small against the contacts that carry the stress, at any distance from jamming. P is the
// imposed pressure at constant pressure, else the measured P_hat. CVODE 6.4 takes new
// tolerances only at a (re)initialisation, so the default atol is re-evaluated there and at
// the start of each advance(), where a drift by more than 10x (an initial configuration
// relaxing, say) forces a re-initialisation. The floor, 1e-12 a, is a few hundred times the
// round-off of positions in a box of tens of a (alpha_r = 1.2 reaches it below P ~ 1e-2).
//
// Vector kernels. Debian's SUNDIALS 6.4.1 is compiled without optimisation (N_VDotProd_Serial
// runs at ~9 ns per element); the adapter installs Eigen / OpenMP-SIMD kernels in the
// N_Vector operation table (cvode_kernel_discrepancy checks them against the library's own),
// which made CVODE ~4x faster on N = 1000.
//
// Scene keys ([integrator] kind = "cvode"): rtol, atol, method = "bdf" | "adams",
// linear_solver = "spgmr" | "pcg", preconditioner = "jacobi" | "none", max_steps (CVODE
// steps per advance() call, an IntegrationError beyond).
//
// statistics(): steps, rhs_evaluations, nonlinear_iterations, linear_iterations,
// jtimes_evaluations, error_test_failures, nonlinear_convergence_failures,
// linear_convergence_failures, preconditioner_setups, preconditioner_solves, jtimes_setups,
// rhs_recoverable_failures, reinits (accumulated over re-initialisations), atol (current).
#pragma once
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "integrators/integrator.hpp"
#include "integrators/motion.hpp"

namespace jamflow {

struct CvodeOptions {
  enum class Method { kBdf, kAdams };
  enum class LinearSolver { kSpgmr, kPcg };
  enum class Preconditioner { kNone, kJacobi };

  double rtol = 1e-6;
  std::optional<double> atol;  // units of a; default from the overlap scale (see above)
  Method method = Method::kBdf;
  LinearSolver linear_solver = LinearSolver::kSpgmr;
  Preconditioner preconditioner = Preconditioner::kJacobi;
  long max_steps = 1000000;  // per advance() call

  void validate() const;  // ConfigError naming the key
};

// Default atol (units of a) for a pressure scale p (units eps / a^3) and pair exponent alpha.
double cvode_default_atol(double pressure, double alpha);

// Self-check for tests: the largest relative difference between this adapter's vector kernels
// (Eigen replacements for Debian's unoptimised nvector_serial, see cvode.cpp) and the
// library's own, over random vectors of length n, aliasing cases included.
double cvode_kernel_discrepancy(std::size_t n, unsigned seed);

class Cvode final : public Integrator {
 public:
  explicit Cvode(const CvodeOptions& options);
  ~Cvode() override;
  Cvode(const Cvode&) = delete;
  Cvode& operator=(const Cvode&) = delete;

  std::string name() const override { return "cvode"; }
  // Adaptive: the global error is proportional to the tolerance, so the declared order is 1
  // in rtol (tests measure it); nominal_dt() = 0 marks it adaptive.
  using Integrator::order;
  int order() const override { return 1; }
  // Adaptive: the cost per unit time is known only once it ran (NaN).
  double force_passes_per_time(const Ensemble& ensemble) const override;
  // Measured (cvode.cpp): grows with the pressure, hardly with the tolerance.
  double cpu_seconds_per_particle_time(const Ensemble& ensemble,
                                       const CostPoint& at) const override;
  // The model's force evaluations plus the Jacobian work weighted by its measured cost against
  // one force pass (cvode.cpp: the contact data of each Jacobian setup, the Jacobian-vector
  // products, the preconditioner setups and solves).
  double force_pass_equivalents(const Model& model) const override;
  void advance(Model& model, const Ensemble& ensemble, double t_end) override;
  void reset() override;
  std::vector<std::pair<std::string, double>> statistics() const override;
  // The counters continue; the solver's step-size and order history does not.
  void restore_statistics(const std::vector<std::pair<std::string, double>>& stats) override;
  bool has_solver_history() const override { return true; }

  const CvodeOptions& options() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace jamflow
