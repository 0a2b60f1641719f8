// The equation of motion (SPEC §2), written once: particles, the sheared cell and, at constant
// pressure, the piston. Two forms of the same equation:
//
// StateEquation: in the Model's own coordinates (s, strain, V), for the integrators that step
// the state directly. The particle field moves s with the cell fixed, the cell field moves the
// cell with s fixed (particles follow affinely):
//   ds/dt = h^-1 F / xi_s,      d(strain)/dt = gdot,   dV/dt = ensemble.volume_rate(P_hat).
// Euler takes one step of their sum (euler_step); RESPA composes steps of each field
// (particle_step, cell_step). These are the only places where Euler's and RESPA's rates are
// written into a state.
//
// EquationOfMotion: the ODE system of the integrators that see the dynamics as one vector y
// (CVODE, RKC), with its analytic Jacobian-vector product. Its piston rate and shear term are
// StateEquation's cell rates.
//
// ODE state. y = [u (3N, SoA like State::pos), w (1, only with a piston)] with
//   u = (h(t) / l) (s - s_ref),   w = V / V_ref - 1,   l = V^(1/3).
// u is the non-affine displacement since the reference (the Model's state when the system was
// made) in real-space directions, in units of the box length; s_ref, V_ref are the state
// there. The shear (strain0 + gdot (t - t0)) is a known function of t, so it is not part of y.
// Then
//   du/dt = F / (l xi_s) + gdot u_y e_x,    dw/dt = ensemble.volume_rate(P_hat) / V_ref.
// Because u is measured in box lengths along real-space axes, an isotropic dilation does not
// move u, and the particle block of the Jacobian is  -H / xi_s + gdot e_x e_y^T  with H the
// real-space energy Hessian: symmetric up to O(gdot), which PCG needs. (Scaled coordinates
// would give -h^-1 H h / xi_s, which is not symmetric in a tilted cell.) Starting y at zero
// keeps |y| of the order of the motion, so a relative tolerance acts on displacements and
// volume changes, never on where the origin happens to be. Each evaluation uses the cell of
// its own time t: the Lees–Edwards shift of a stage is that of the stage's time.
//
// Neighbour lists. Every right-hand side writes y into the Model's State and calls
// Model::evaluate(), which rebuilds the list whenever its validity bound fails, so forces are
// never computed from a stale list. A rebuild wraps State::pos by integers; the wrap is folded
// into s_ref, so y stays continuous and the next write agrees with the list.
//
// Jacobian. Matrix-free, analytic: J v over the contacts (pair stiffness U'' along the contact
// normal, -f/r across it), with the exact couplings to the piston: the affine dilation of the
// contacts (dF/dw) and the change of the virial (dP_hat/du, dP_hat/dw). With a symmetric
// Jacobian only the symmetric part is used (no gdot term, no particle-piston coupling). The
// block-diagonal preconditioner is per particle I + gamma sum_j U''_ij n n^T / xi_s (the
// positive semidefinite normal part of the 3x3 diagonal Hessian block, always invertible), and
// 1 - gamma J_ww for the piston.
#pragma once
#include <cstdint>
#include <vector>

#include "ensembles/ensemble.hpp"
#include "lib/error.hpp"
#include "lib/kernels/contacts.hpp"
#include "lib/model.hpp"

namespace jamflow {

// The overlap at which one contact carries a force of order P a^2, delta = (P / eps)^(1 /
// (alpha_r - 1)) a, clamped to [1e-9, 1] a (1 a for a pressure that is not positive and finite):
// the length scale of the adaptive integrators' default tolerances.
double typical_overlap(double pressure, double alpha);

// How much stiffer a contact at the typical overlap is than a harmonic one, delta^(alpha_r - 2)
// below alpha_r = 2 (1 above it), at most 1e3, the largest the adaptive integrators' cost
// models were measured at (cvode.cpp): what those models multiply their harmonic cost by.
double contact_stiffness_factor(double pressure, double alpha);

// The piston shrank the cell below what the neighbour list supports. Only the piston moves V,
// and a cell this small stays too small for every smaller step, so a solver must not retry
// with a smaller step: unrecoverable, unlike its base.
class CellCollapse : public IntegrationError {
 public:
  using IntegrationError::IntegrationError;
};

// The rates of the cell: d(strain)/dt and dV/dt (0 without a piston).
struct CellRates {
  double strain = 0.0;
  double volume = 0.0;
};

// One-step schemes for a field: euler y <- y + h f(y); heun y* = y + h f(y),
// y <- y + h/2 (f(y) + f(y*)).
enum class StepScheme { kEuler, kHeun };

// The equation of motion in the Model's own coordinates (see the top of this file). Holds only
// a reference to the ensemble: cheap to make per advance().
class StateEquation {
 public:
  explicit StateEquation(const Ensemble& ensemble) : ensemble_(ensemble) {}

  // The cell's rates at instantaneous pressure p_hat.
  CellRates cell_rates(double p_hat) const;
  // The cell's rates at the Model's state: with a piston they need P_hat (a force pass unless
  // cached); without one, nothing is evaluated.
  CellRates cell_rates(Model& model) const;
  // d(dV/dt)/dP_hat at p_hat: the piston's entry of the Jacobian (0 without a piston).
  double volume_rate_slope(double p_hat) const;

  // One explicit Euler step of the whole equation over h, with the forces and P_hat of the
  // state at the step's start. Without a piston the cell does not depend on the forces, so the
  // particle drift is asked of the force backend as part of its pass (Model::
  // evaluate_and_drift: the same bits as evaluate(), the cell step, then the drift).
  void euler_step(Model& model, double h) const;
  // One step of the particle field over h with the cell fixed. `scratch` holds Heun's forces.
  void particle_step(Model& model, StepScheme scheme, double h, std::vector<double>& scratch) const;
  // One step of the cell field over h with s fixed. Without a piston the field is the affine
  // shear alone, linear in time: exact with either scheme, and no force pass.
  void cell_step(Model& model, StepScheme scheme, double h) const;

  // The cell after h at `rates`: strain += h rates.strain, V += h rates.volume (IntegrationError
  // on V <= 0 or non-finite).
  static void advance_cell(Box& box, const CellRates& rates, double h);

 private:
  const Ensemble& ensemble_;
};

// The equation of motion over a Model, without any solver's types (the CVODE callbacks and
// RKC's stages call it; tests call it directly). The reference is the Model's state at
// construction. Methods that take y write it into the Model's State and evaluate forces;
// physically impossible y (non-finite, V <= 0, runaway displacement) raise IntegrationError.
class EquationOfMotion {
 public:
  EquationOfMotion(Model& model, const Ensemble& ensemble, bool symmetric_jacobian);

  std::size_t size() const { return 3 * n_ + (piston_ ? 1 : 0); }
  bool has_piston() const { return piston_; }
  double reference_time() const { return t_ref_; }

  // Cell at time t and volume v (reference cell with the strain of time t, dilated to v).
  Box box_at(double t, double v) const;
  // The first time after t_now at which the cell of volume v is due a Lees–Edwards remap
  // (|tilt| just past 1/2, so that Model::prepare_step() remaps there). Needs gdot != 0.
  double remap_time(double t_now, double v) const;
  // Writes y at time t into the Model (positions, cell, time) and evaluates forces.
  void apply(double t, const double* y);
  // ydot = f(t, y).
  void rhs(double t, const double* y, double* ydot);
  // ydot = f(t_ref, 0), the rates at the reference itself, from the Model's evaluation of it:
  // no write, so an evaluation cached before the system was made is used as it is (make the
  // system after Model::evaluate(), so that no list rebuild wraps the reference later).
  void rhs_at_reference(double* ydot);
  // Jacobian data at (t, y) for jacobian_times and the preconditioner.
  void jacobian_setup(double t, const double* y);
  bool jacobian_ready() const { return jacobian_ready_; }
  // jv = J v with the data of the last jacobian_setup.
  void jacobian_times(const double* v, double* jv) const;
  // Block-diagonal preconditioner P ~ I - gamma J (needs jacobian_setup first); z = P^-1 r.
  void preconditioner_setup(double gamma);
  void preconditioner_solve(const double* r, double* z) const;

 private:
  // The contact data and the piston couplings of the Model's current state.
  void collect_contacts();

  Model& model_;
  const Ensemble& ensemble_;
  std::size_t n_;
  bool piston_;
  bool symmetric_;
  StateEquation rates_;
  double gdot_;
  Box box_ref_;
  double t_ref_, strain_ref_, v_ref_, l_ref_;
  std::vector<double> s_ref_;  // scaled positions at the reference, with wraps folded in
  std::vector<double> ds_;     // scratch: s - s_ref of the last write
  std::vector<double> y_last_;
  double t_last_ = 0.0;
  bool have_last_ = false;

  bool jacobian_ready_ = false;
  bool jacobian_at_last_ = false;        // the data belong to the last point written
  kernels::ContactStiffness stiffness_;  // the contacts (lib/kernels/contacts.hpp), over xi_s
  std::vector<double> col_uw_;           // d(du/dt)/dw, 3N
  std::vector<double> row_wu_;           // d(dw/dt)/du, 3N
  double j_ww_ = 0.0;
  std::vector<double> inv_block_;  // 9 per particle
  double inv_ww_ = 1.0;
};

}  // namespace jamflow
