// The equation of motion (motion.hpp).
#include "integrators/motion.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "integrators/integrator.hpp"
#include "lib/potential.hpp"

namespace jamflow {

namespace {
// |s - s_ref| beyond this many box lengths is a runaway trial iterate, not a displacement.
constexpr double kMaxShift = 1e6;

}  // namespace

double typical_overlap(double pressure, double alpha) {
  double delta = 0.0;
  if (pressure > 0.0 && std::isfinite(pressure))
    delta = std::pow(pressure, 1.0 / (alpha - 1.0));
  if (!std::isfinite(delta))
    delta = 1.0;
  return std::clamp(delta, 1e-9, 1.0);
}

double contact_stiffness_factor(double pressure, double alpha) {
  if (!(alpha < 2.0))
    return 1.0;
  return std::min(std::pow(typical_overlap(pressure, alpha), alpha - 2.0), 1e3);
}

CellRates StateEquation::cell_rates(double p_hat) const {
  CellRates r;
  r.strain = ensemble_.shear_rate();
  if (ensemble_.has_piston())
    r.volume = ensemble_.volume_rate(p_hat);
  return r;
}

CellRates StateEquation::cell_rates(Model& model) const {
  return ensemble_.has_piston() ? cell_rates(model.evaluate().pressure) : cell_rates(0.0);
}

double StateEquation::volume_rate_slope(double p_hat) const {
  return ensemble_.has_piston() ? ensemble_.volume_rate_slope(p_hat) : 0.0;
}

void StateEquation::advance_cell(Box& box, const CellRates& rates, double h) {
  box.strain += rates.strain * h;
  const double v0 = box.volume();
  const double v = v0 + h * rates.volume;
  if (v != v0)
    box.set_volume(v);
}

void StateEquation::euler_step(Model& model, double h) const {
  if (!ensemble_.has_piston()) {
    Box next = model.state().box;
    advance_cell(next, cell_rates(0.0), h);
    model.evaluate_and_drift(Drift::of(next.h_inv(), h / kXiS), next);
    return;
  }
  const Evaluation& ev = model.evaluate();
  const CellRates rates = cell_rates(ev.pressure);
  model.modify([&](State& s) {
    advance_cell(s.box, rates, h);
    // Forces of the old configuration, displacement mapped with the new cell: r advances by
    // exactly h F / xi_s on top of the affine flow.
    drift_particles(s, ev.forces.force, h, model.force_field().threads());
  });
}

void StateEquation::particle_step(Model& model, StepScheme scheme, double h,
                                  std::vector<double>& scratch) const {
  const int threads = model.force_field().threads();
  const Evaluation& ev0 = model.evaluate();
  if (scheme == StepScheme::kEuler) {
    model.modify([&](State& s) { drift_particles(s, ev0.forces.force, h, threads); });
    return;
  }
  // Heun: predictor s* = s + h F0, corrector s + h/2 (F0 + F1) = s* + h/2 (F1 - F0). Applied as
  // an increment so that a neighbour-list rebuild (which wraps s) between the two is harmless.
  scratch = ev0.forces.force;
  model.modify([&](State& s) { drift_particles(s, scratch, h, threads); });
  const Evaluation& ev1 = model.evaluate();
  const std::vector<double>& f1 = ev1.forces.force;
  for (std::size_t k = 0; k < scratch.size(); ++k)
    scratch[k] = f1[k] - scratch[k];
  model.modify([&](State& s) { drift_particles(s, scratch, 0.5 * h, threads); });
}

void StateEquation::cell_step(Model& model, StepScheme scheme, double h) const {
  const double v0 = model.state().box.volume();
  const CellRates r0 = cell_rates(model);
  model.modify([&](State& s) { advance_cell(s.box, r0, h); });
  if (scheme == StepScheme::kEuler || !ensemble_.has_piston())
    return;
  const CellRates r1 = cell_rates(model);
  // Corrector V0 + h/2 (f0 + f1); the strain rate is constant, so the predictor's strain is
  // already the corrector's.
  const double v1 = v0 + h * (0.5 * (r0.volume + r1.volume));
  model.modify([&](State& s) {
    if (v1 != s.box.volume())
      s.box.set_volume(v1);
  });
}

EquationOfMotion::EquationOfMotion(Model& model, const Ensemble& ensemble, bool symmetric_jacobian)
    : model_(model),
      ensemble_(ensemble),
      n_(model.state().size()),
      piston_(ensemble.has_piston()),
      symmetric_(symmetric_jacobian),
      rates_(ensemble),
      gdot_(rates_.cell_rates(0.0).strain) {
  const State& st = model.state();
  box_ref_ = st.box;
  t_ref_ = st.time;
  strain_ref_ = st.box.strain;
  v_ref_ = st.box.volume();
  l_ref_ = std::cbrt(v_ref_);
  s_ref_ = st.pos;
  ds_.assign(3 * n_, 0.0);
}

Box EquationOfMotion::box_at(double t, double v) const {
  Box b = box_ref_;
  b.strain = strain_ref_ + gdot_ * (t - t_ref_);
  if (v != v_ref_) {
    const double c = std::cbrt(v / v_ref_);
    b.lx *= c;
    b.ly *= c;
    b.lz *= c;
  }
  return b;
}

double EquationOfMotion::remap_time(double t_now, double v) const {
  const Box b = box_at(t_now, v);
  const double half = 0.5 * b.lx / b.ly;
  double t = t_now + ((gdot_ > 0.0 ? half : -half) - b.tilt()) / gdot_;
  double bump = std::max(std::abs(t), 1.0) * std::numeric_limits<double>::epsilon();
  for (int k = 0; k < 200; ++k) {
    if (t > t_now && box_at(t, v).remap_direction() != 0)
      break;
    t += bump;
    bump *= 2.0;
  }
  return t;
}

void EquationOfMotion::apply(double t, const double* y) {
  double v = v_ref_;
  if (piston_) {
    const double w = y[3 * n_];
    v = v_ref_ * (1.0 + w);
    if (!(1.0 + w > 0.0) || !std::isfinite(v)) {
      throw IntegrationError("trial cell volume " + fmt(v) + " at t = " + fmt(t) + " (reference " +
                             fmt(v_ref_) + ")");
    }
  }
  // s = s_ref + l_ref h_ref(t)^-1 u, with h_ref(t) the reference cell sheared to time t.
  const double tilt = box_at(t, v_ref_).tilt();
  const double ax = l_ref_ / box_ref_.lx, ay = l_ref_ / box_ref_.ly, az = l_ref_ / box_ref_.lz;
  const double* ux = y;
  const double* uy = y + n_;
  const double* uz = y + 2 * n_;
  double* dx = ds_.data();
  double* dy = dx + n_;
  double* dz = dx + 2 * n_;
  const std::size_t n = n_;
#pragma omp simd
  for (std::size_t i = 0; i < n; ++i) {
    dx[i] = ax * (ux[i] - tilt * uy[i]);
    dy[i] = ay * uy[i];
    dz[i] = az * uz[i];
  }
  // The largest |ds|, and the sum of all |ds|, which is finite only if every ds is (NaN never
  // wins a max, but it poisons a sum). Vectorised reductions over eight lanes each, so that no
  // single add chain sets the pace: with a branchy max over three values per particle, this
  // check cost a fifth of an RKC stage at N = 1000.
  constexpr std::size_t kLanes = 8;
  double lane_max[kLanes] = {}, lane_sum[kLanes] = {};
  const double* d = ds_.data();
  const std::size_t m = 3 * n, whole = m - m % kLanes;
  for (std::size_t k = 0; k < whole; k += kLanes) {
#pragma omp simd
    for (std::size_t l = 0; l < kLanes; ++l) {
      const double a = std::abs(d[k + l]);
      lane_max[l] = lane_max[l] > a ? lane_max[l] : a;
      lane_sum[l] += a;
    }
  }
  for (std::size_t k = whole; k < m; ++k) {
    const double a = std::abs(d[k]);
    lane_max[0] = lane_max[0] > a ? lane_max[0] : a;
    lane_sum[0] += a;
  }
  double worst = 0.0, total = 0.0;
  for (std::size_t l = 0; l < kLanes; ++l) {
    worst = std::max(worst, lane_max[l]);
    total += lane_sum[l];
  }
  if (!(worst < kMaxShift) || !std::isfinite(total)) {
    throw IntegrationError("trial particle displacement is non-finite or runaway (" + fmt(worst) +
                           " box lengths) at t = " + fmt(t));
  }

  model_.modify([&](State& w) {
    for (std::size_t k = 0; k < 3 * n_; ++k)
      w.pos[k] = s_ref_[k] + ds_[k];
    w.box = box_at(t, v);
    w.time = t;
  });
  const State& st = model_.state();
  have_last_ = false;
  jacobian_at_last_ = false;

  // A list rebuild wraps the state's scaled coordinates by integers; fold them into s_ref so
  // that the next write continues from the wrapped state (forces are periodic, y unchanged).
  const std::size_t builds = model_.list_builds();
  const auto fold = [&] {
    if (model_.list_builds() == builds)
      return;
    for (std::size_t k = 0; k < 3 * n_; ++k) {
      const double shift = std::nearbyint(s_ref_[k] + ds_[k] - st.pos[k]);
      if (shift != 0.0)
        s_ref_[k] -= shift;
    }
  };
  try {
    model_.evaluate();
  } catch (const ConfigError& e) {
    fold();
    throw CellCollapse("cell volume " + fmt(st.box.volume()) + " at t = " + fmt(t) +
                       " is too small for the neighbour list: " + e.what());
  } catch (...) {
    fold();
    throw;
  }
  fold();
  y_last_.assign(y, y + size());
  t_last_ = t;
  have_last_ = true;
}

void EquationOfMotion::rhs(double t, const double* y, double* ydot) {
  apply(t, y);
  const Evaluation& ev = model_.evaluate();  // cached by apply()
  const double scale = 1.0 / (std::cbrt(ev.volume) * kXiS);
  Eigen::Map<Eigen::VectorXd> du(ydot, 3 * n_);
  du = scale * Eigen::Map<const Eigen::VectorXd>(ev.forces.force.data(), 3 * n_);
  const CellRates cell = rates_.cell_rates(ev.pressure);
  // The sheared frame of u: d/dt (h(t)/l) = gdot e_x e_y^T (h/l).
  du.head(n_) += cell.strain * Eigen::Map<const Eigen::VectorXd>(y + n_, n_);
  if (piston_)
    ydot[3 * n_] = cell.volume / v_ref_;
}

void EquationOfMotion::rhs_at_reference(double* ydot) {
  const Evaluation& ev = model_.evaluate();
  const double scale = 1.0 / (std::cbrt(ev.volume) * kXiS);
  Eigen::Map<Eigen::VectorXd>(ydot, 3 * n_) =
      scale * Eigen::Map<const Eigen::VectorXd>(ev.forces.force.data(), 3 * n_);
  if (piston_)
    ydot[3 * n_] = rates_.cell_rates(ev.pressure).volume / v_ref_;
}

void EquationOfMotion::collect_contacts() {
  const State& st = model_.state();
  const Evaluation& ev = model_.evaluate();
  const std::size_t n = n_;
  const double alpha = model_.force_field().alpha();
  if (alpha == 2.0) {
    kernels::collect_contacts(HarmonicPair{}, st, model_.neighbour_list(), kXiS, piston_,
                              stiffness_);
  } else {
    kernels::collect_contacts(PowerPair{alpha}, st, model_.neighbour_list(), kXiS, piston_,
                              stiffness_);
  }
  const std::vector<double>& g = stiffness_.g;
  const double virial = stiffness_.virial, curvature = stiffness_.curvature;

  if (piston_) {
    // u fixed, w -> w + dw: every pair vector dilates by eps = dl/l = V_ref dw / (3 V).
    //   d(du/dt)/dw = -(V_ref / 3V) (g + F) / (l xi_s)       (forces and the 1/l prefactor)
    // w fixed, u -> u + du: dr_ij = l (du_i - du_j), d(r.f) = (f - U'' r).dr, dP = dW / 3V:
    //   d(dw/dt)/du = slope l (F - g) / (3 V V_ref),  slope = d(dV/dt)/dP_hat at this P_hat
    // Affine dilation of the virial: dW/dV = (W - Q)/(3V), so dP/dV = -(2W + Q) / (9 V^2).
    const double slope = rates_.volume_rate_slope(ev.pressure);
    const double v = st.box.volume();
    const double l = std::cbrt(v);
    const double* f = ev.forces.force.data();
    col_uw_.resize(3 * n);
    row_wu_.resize(3 * n);
    for (std::size_t k = 0; k < 3 * n; ++k) {
      col_uw_[k] = -(v_ref_ / (3.0 * v)) * (g[k] + f[k]) / (l * kXiS);
      row_wu_[k] = slope * l * (f[k] - g[k]) / (3.0 * v * v_ref_);
    }
    j_ww_ = -slope * (2.0 * virial + curvature) / (9.0 * v * v);
  }
}

void EquationOfMotion::jacobian_setup(double t, const double* y) {
  const bool at_last = have_last_ && t == t_last_ && std::equal(y, y + size(), y_last_.begin());
  if (jacobian_ready_ && at_last && jacobian_at_last_)
    return;  // psetup and the first jtsetup of a step come at the same point
  if (!at_last)
    apply(t, y);
  collect_contacts();
  jacobian_ready_ = true;
  jacobian_at_last_ = true;
}

void EquationOfMotion::jacobian_times(const double* v, double* jv) const {
  const std::size_t n = n_;
  // -H v / xi_s over the contacts (lib/kernels/contacts.hpp).
  kernels::contact_hessian_product(stiffness_, n, v, jv);
  if (piston_)
    jv[3 * n] = 0.0;
  if (!symmetric_ && gdot_ != 0.0) {
    for (std::size_t i = 0; i < n; ++i)
      jv[i] += gdot_ * v[n + i];
  }
  if (piston_) {
    const double vw = v[3 * n];
    double coupling = 0.0;
    if (!symmetric_) {
      for (std::size_t k = 0; k < 3 * n; ++k) {
        jv[k] += col_uw_[k] * vw;
        coupling += row_wu_[k] * v[k];
      }
    }
    jv[3 * n] = coupling + j_ww_ * vw;
  }
}

void EquationOfMotion::preconditioner_setup(double gamma) {
  inv_block_.resize(9 * n_);
  for (std::size_t i = 0; i < n_; ++i) {
    const double* b = &stiffness_.normal_block[6 * i];
    Eigen::Matrix3d m;
    m << 1.0 + gamma * b[0], gamma * b[3], gamma * b[4],  //
        gamma * b[3], 1.0 + gamma * b[1], gamma * b[5],   //
        gamma * b[4], gamma * b[5], 1.0 + gamma * b[2];
    // I + gamma (positive semidefinite): symmetric positive definite, so invertible.
    Eigen::Map<Eigen::Matrix3d> inv(&inv_block_[9 * i]);
    inv = m.inverse();
  }
  const double p_ww = 1.0 - gamma * j_ww_;  // j_ww <= 0 for repulsive contacts
  inv_ww_ = p_ww > 0.0 ? 1.0 / p_ww : 1.0;
}

void EquationOfMotion::preconditioner_solve(const double* r, double* z) const {
  const std::size_t n = n_;
#pragma omp simd
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Map<const Eigen::Matrix3d> inv(&inv_block_[9 * i]);
    const Eigen::Vector3d ri(r[i], r[n + i], r[2 * n + i]);
    const Eigen::Vector3d zi = inv * ri;
    z[i] = zi[0];
    z[n + i] = zi[1];
    z[2 * n + i] = zi[2];
  }
  if (piston_)
    z[3 * n] = inv_ww_ * r[3 * n];
}

}  // namespace jamflow
