// CVODE (SUNDIALS 6.4): variable-order, variable-step BDF (or Adams) with Newton–Krylov
// (SPGMR or PCG), behind the Integrator interface. Same equations as Euler (integrator.hpp).
//
// ODE state. y = [u (3N, SoA like State::pos), w (1, only with a piston)] with
//   u = (h(t) / l) (s - s_ref),   w = V / V_ref - 1,   l = V^(1/3).
// u is the non-affine displacement since the last (re)initialisation in real-space
// directions, in units of the box length; s_ref, V_ref are the state at that time. The shear
// (strain0 + gdot (t - t0)) is a known function of t, so it is not part of y. Then
//   du/dt = F / (l xi_s) + gdot u_y e_x,    dw/dt = ensemble.volume_rate(P_hat) / V_ref,
// and the piston is part of the ODE system. Because u is measured in box lengths along
// real-space axes, an isotropic dilation does not move u, and the particle block of the
// Jacobian is  -H / xi_s + gdot e_x e_y^T  with H the real-space energy Hessian: symmetric
// up to O(gdot), which PCG needs. (Scaled coordinates would give -h^-1 H h / xi_s, which is
// not symmetric in a tilted cell.) Starting y at zero keeps |y| of the order of the motion,
// so rtol acts on displacements and volume changes, never on where the origin happens to be.
//
// Neighbour lists. Every right-hand side writes y into the Model's State and calls
// Model::evaluate(), which rebuilds the list whenever its validity bound fails, so forces
// are never computed from a stale list. A rebuild wraps State::pos by integers; the wrap is
// folded into s_ref, so y stays continuous and the next write agrees with the list.
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

// The ODE system of the header comment over a Model, without SUNDIALS types (the CVODE
// callbacks forward here; tests call it directly). The reference is the Model's state at
// construction. Methods that take y write it into the Model's State and evaluate forces;
// physically impossible y (non-finite, V <= 0, runaway displacement) raise IntegrationError.
class CvodeSystem {
 public:
  CvodeSystem(Model& model, const Ensemble& ensemble, bool symmetric_jacobian);

  std::size_t size() const { return 3 * n_ + (piston_ ? 1 : 0); }
  bool has_piston() const { return piston_; }
  double reference_time() const { return t_ref_; }

  // Cell at time t and volume v (reference cell with the strain of time t, dilated to v).
  Box box_at(double t, double v) const;
  // Writes y at time t into the Model (positions, cell, time) and evaluates forces.
  void apply(double t, const double* y);
  // ydot = f(t, y).
  void rhs(double t, const double* y, double* ydot);
  // Jacobian data at (t, y) for jacobian_times and the preconditioner.
  void jacobian_setup(double t, const double* y);
  bool jacobian_ready() const { return jacobian_ready_; }
  // jv = J v with the data of the last jacobian_setup.
  void jacobian_times(const double* v, double* jv) const;
  // Block-diagonal preconditioner P ~ I - gamma J (needs jacobian_setup first); z = P^-1 r.
  void preconditioner_setup(double gamma);
  void preconditioner_solve(const double* r, double* z) const;

 private:
  struct Contact {
    std::uint32_t i, j;
    double nx, ny, nz;  // unit vector along r_ij
    double k_par;       // U'' / xi_s
    double k_perp;      // (f / r) / xi_s: the tension term -(f/r)(I - n n^T) of the Hessian
  };
  template <class Pair>
  void collect_contacts(const Pair& pair);

  Model& model_;
  const Ensemble& ensemble_;
  std::size_t n_;
  bool piston_;
  bool symmetric_;
  double gdot_;
  double rate_slope_ = 0.0;  // d volume_rate / d P_hat
  Box box_ref_;
  double t_ref_, strain_ref_, v_ref_, l_ref_;
  std::vector<double> s_ref_;  // scaled positions at the reference, with wraps folded in
  std::vector<double> ds_;     // scratch: s - s_ref of the last write
  std::vector<double> y_last_;
  double t_last_ = 0.0;
  bool have_last_ = false;

  bool jacobian_ready_ = false;
  bool jacobian_at_last_ = false;  // the data belong to the last point written
  std::vector<Contact> contacts_;
  std::vector<double> normal_block_;  // 6 per particle: sum_j U'' n n^T / xi_s (xx yy zz xy xz yz)
  std::vector<double> col_uw_;        // d(du/dt)/dw, 3N
  std::vector<double> row_wu_;        // d(dw/dt)/du, 3N
  double j_ww_ = 0.0;
  std::vector<double> inv_block_;  // 9 per particle
  double inv_ww_ = 1.0;
};

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
