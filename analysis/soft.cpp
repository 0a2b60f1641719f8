// Soft granular rheology: per-pressure collapse, pressure dependence of
// phi_J and mu_J, yield-stress law (see soft.hpp).
#include "analysis/soft.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <random>

#include <gsl/gsl_errno.h>
#include <gsl/gsl_multimin.h>
#include <gsl/gsl_vector.h>

#include "analysis/errors.hpp"
#include "analysis/json.hpp"
#include "analysis/seed.hpp"

namespace jamflow::analysis {

std::vector<PressureCollapse> collapse_pressures(const std::vector<GranularPoint>& points,
                                                 const HardSphereShape& shape) {
  std::map<double, std::vector<const GranularPoint*>> by_p;
  for (const auto& p : points)
    by_p[p.pressure].push_back(&p);
  std::vector<PressureCollapse> out;
  for (const auto& [pressure, pts] : by_p) {
    PressureCollapse c;
    c.pressure = pressure;
    c.points = pts.size();
    double sw_phi = 0, su_phi = 0, sgc_phi = 0, sgb_phi = 0;
    double sw_mu = 0, su_mu = 0, sgc_mu = 0, sgb_mu = 0;
    for (const GranularPoint* p : pts) {
      const double jb_phi = std::pow(p->j, shape.b_phi);
      const double jb_mu = std::pow(p->j, shape.b_mu);
      const double w_phi = 1.0 / (p->phi_err * p->phi_err);
      const double w_mu = 1.0 / (p->mu_err * p->mu_err);
      sw_phi += w_phi;
      su_phi += w_phi * (p->phi + shape.c_phi * jb_phi);
      sgc_phi += w_phi * jb_phi;
      sgb_phi += w_phi * shape.c_phi * jb_phi * std::log(p->j);
      sw_mu += w_mu;
      su_mu += w_mu * (p->mu - shape.c_mu * jb_mu);
      sgc_mu += -w_mu * jb_mu;
      sgb_mu += -w_mu * shape.c_mu * jb_mu * std::log(p->j);
    }
    const double phi_j = su_phi / sw_phi, mu_j = su_mu / sw_mu;
    c.phi_j_stat = 1.0 / std::sqrt(sw_phi);
    c.mu_j_stat = 1.0 / std::sqrt(sw_mu);
    c.grad_phi[0] = sgc_phi / sw_phi;
    c.grad_phi[1] = sgb_phi / sw_phi;
    c.grad_mu[0] = sgc_mu / sw_mu;
    c.grad_mu[1] = sgb_mu / sw_mu;
    for (const GranularPoint* p : pts) {
      c.chi2_phi +=
          std::pow((p->phi + shape.c_phi * std::pow(p->j, shape.b_phi) - phi_j) / p->phi_err, 2);
      c.chi2_mu +=
          std::pow((p->mu - shape.c_mu * std::pow(p->j, shape.b_mu) - mu_j) / p->mu_err, 2);
    }
    auto shape_var = [](const double g[2], const std::vector<double>& cov) {
      return g[0] * g[0] * cov[0] + 2 * g[0] * g[1] * cov[1] + g[1] * g[1] * cov[3];
    };
    c.phi_j = {phi_j,
               std::sqrt(c.phi_j_stat * c.phi_j_stat + shape_var(c.grad_phi, shape.cov_phi))};
    c.mu_j = {mu_j, std::sqrt(c.mu_j_stat * c.mu_j_stat + shape_var(c.grad_mu, shape.cov_mu))};
    if (!std::isfinite(phi_j) || !std::isfinite(mu_j) || !std::isfinite(c.phi_j.error) ||
        !std::isfinite(c.mu_j.error)) {
      throw FitError("collapse at P = " + format_key(pressure) +
                     " gives a non-finite phi_J(P) or mu_J(P)");
    }
    out.push_back(c);
  }
  return out;
}

namespace {

// Data covariance of phi_J(P) (or mu_J(P)) across pressures: statistical
// (diagonal) plus the common shape part g_P^T Sigma g_P'.
std::vector<double> collapse_covariance(const std::vector<PressureCollapse>& cs, bool phi,
                                        const std::vector<double>& shape_cov) {
  const std::size_t n = cs.size();
  std::vector<double> cov(n * n);
  for (std::size_t a = 0; a < n; ++a) {
    const double* ga = phi ? cs[a].grad_phi : cs[a].grad_mu;
    for (std::size_t b = 0; b < n; ++b) {
      const double* gb = phi ? cs[b].grad_phi : cs[b].grad_mu;
      double v = ga[0] * gb[0] * shape_cov[0] + ga[0] * gb[1] * shape_cov[1] +
                 ga[1] * gb[0] * shape_cov[2] + ga[1] * gb[1] * shape_cov[3];
      if (a == b) {
        const double s = phi ? cs[a].phi_j_stat : cs[a].mu_j_stat;
        v += s * s;
      }
      cov[a * n + b] = v;
    }
  }
  return cov;
}

HardSphereShape shape_from_fit(const SizeFit& s) {
  HardSphereShape h;
  const std::size_t ic = s.phi.index("C_phi"), ib = s.phi.index("b_phi");
  const std::size_t jc = s.mu.index("C_mu"), jb = s.mu.index("b_mu");
  h.c_phi = s.phi.params[ic];
  h.b_phi = s.phi.params[ib];
  h.c_mu = s.mu.params[jc];
  h.b_mu = s.mu.params[jb];
  h.cov_phi = {s.phi.cov(ic, ic), s.phi.cov(ic, ib), s.phi.cov(ib, ic), s.phi.cov(ib, ib)};
  h.cov_mu = {s.mu.cov(jc, jc), s.mu.cov(jc, jb), s.mu.cov(jb, jc), s.mu.cov(jb, jb)};
  h.source = "hard-sphere envelope fit (N=" + std::to_string(s.n) + ")";
  return h;
}

}  // namespace

void fit_pressure_dependence(SoftSize& size, const SoftOptions& options) {
  const std::string label_n = "(N=" + std::to_string(size.n) + ")";
  if (size.pressures.size() < 4) {
    throw InsufficientDataError("N=" + std::to_string(size.n) + ": data at " +
                                std::to_string(size.pressures.size()) +
                                " pressures; phi_J(P) = phi_J(0) + c_phi P^x and mu_J(P) = "
                                "mu_J(0) - c_mu P^y need at least 4");
  }
  FitData phi_data, mu_data;
  for (const auto& c : size.pressures) {
    phi_data.x.push_back(c.pressure);
    phi_data.y.push_back(c.phi_j.value);
    mu_data.x.push_back(c.pressure);
    mu_data.y.push_back(c.mu_j.value);
  }
  phi_data.covariance = collapse_covariance(size.pressures, true, size.shape.cov_phi);
  mu_data.covariance = collapse_covariance(size.pressures, false, size.shape.cov_mu);
  FitOptions fo;
  fo.scale_errors_by_chi2 = options.scale_errors;
  fo.label = "phi_J(P) = phi_J(0) + c_phi P^x " + label_n;
  size.phi_fit =
      fit_power_law_offset(phi_data, PowerLawForm{1.0, 1.0, 0.05, 3.0, "phi_J0", "c_phi", "x"}, fo);
  fo.label = "mu_J(P) = mu_J(0) - c_mu P^y " + label_n;
  size.mu_fit =
      fit_power_law_offset(mu_data, PowerLawForm{-1.0, 1.0, 0.05, 3.0, "mu_J0", "c_mu", "y"}, fo);
}

double YieldLaw::sigma_y(double phi) const {
  const double d = phi - params[0];
  if (d <= 0.0)
    return 0.0;
  const double p = std::pow(d / params[1], 1.0 / params[2]);  // pressure at J -> 0
  return p * (params[3] - params[4] * std::pow(p, params[5]));
}

YieldLaw yield_law(const FitResult& phi_fit, const FitResult& mu_fit) {
  YieldLaw y;
  y.params = {phi_fit.params[0], phi_fit.params[1], phi_fit.params[2],
              mu_fit.params[0],  mu_fit.params[1],  mu_fit.params[2]};
  const std::vector<double> cov = block_diagonal({phi_fit.covariance, mu_fit.covariance}, {3, 3});
  using P = std::span<const double>;
  y.amplitude_1 = propagate([](P p) { return p[3] * std::pow(p[1], -1.0 / p[2]); }, y.params, cov,
                            "yield-stress amplitude mu_J(0) c_phi^(-1/x)");
  y.exponent_1 =
      propagate([](P p) { return 1.0 / p[2]; }, y.params, cov, "yield-stress exponent 1/x");
  y.amplitude_2 = propagate([](P p) { return p[4] * std::pow(p[1], -(1.0 + p[5]) / p[2]); },
                            y.params, cov, "yield-stress amplitude c_mu c_phi^(-(1+y)/x)");
  y.exponent_2 = propagate([](P p) { return (1.0 + p[5]) / p[2]; }, y.params, cov,
                           "yield-stress exponent (1+y)/x");
  return y;
}

SoftResult analyze_soft(const std::vector<GranularPoint>& points, const SoftOptions& options) {
  SoftResult r;
  r.point_errors = point_errors_of(points);
  auto groups = group_by_size(points);
  if (groups.empty())
    throw InsufficientDataError("no data points");
  for (const auto& [n, pts] : groups) {
    SoftSize s;
    s.n = n;
    s.points = pts;
    try {
      s.joint = fit_soft_joint(pts, options.joint);
      soft_window_systematics(*s.joint, pts);
      soft_form_systematics(*s.joint, pts);
      soft_local_exponents(*s.joint, pts);
      for (const auto& note : s.joint->resolution_notes)
        r.warnings.push_back("N=" + std::to_string(n) + ": " + note);
    } catch (const AnalysisError& e) {
      s.joint_skipped = e.what();
      r.warnings.push_back("N=" + std::to_string(n) + ": joint fit not done: " + e.what());
    }
    if (s.joint && !options.yield_data.empty()) {
      std::vector<ShearPoint> cv;
      for (const auto& q : options.yield_data) {
        if (q.n == n)
          cv.push_back(q);
      }
      s.yield_data = compare_yield(*s.joint, cv);
    }
    try {
      if (options.fixed_shape) {
        s.shape = *options.fixed_shape;
      } else {
        s.shape = shape_from_fit(fit_size(n, pts, options.hard_sphere));
      }
      s.pressures = collapse_pressures(pts, s.shape);
      for (const auto& c : s.pressures) {
        if (c.points < 2) {
          throw InsufficientDataError("N=" + std::to_string(n) + ", P=" + format_key(c.pressure) +
                                      ": a single point cannot test the collapse; each pressure "
                                      "needs at least 2 shear rates");
        }
      }
      fit_pressure_dependence(s, options);
      s.yield = yield_law(s.phi_fit, s.mu_fit);
    } catch (const AnalysisError& e) {
      if (options.require_collapse)
        throw;
      if (!s.joint) {
        throw InsufficientDataError("N=" + std::to_string(n) +
                                    ": neither description could be fitted; joint fit: " +
                                    s.joint_skipped + "; per-pressure collapse: " + e.what());
      }
      s.collapse_skipped = e.what();
      s.pressures.clear();
      s.phi_fit = {};
      s.mu_fit = {};
      r.warnings.push_back("N=" + std::to_string(n) +
                           ": per-pressure collapse not done: " + e.what());
    }
    r.sizes.push_back(std::move(s));
  }
  return r;
}

}  // namespace jamflow::analysis

// --- the joint fit -------------------------------------------------------------

namespace jamflow::analysis {

const std::array<const char*, 10>& SoftLaw::names() {
  static const std::array<const char*, 10> n = {"phi_J0", "c_phi", "x", "C_phi", "b_phi",
                                                "mu_J0",  "c_mu",  "y", "C_mu",  "b_mu"};
  return n;
}

std::array<double, 10> SoftLaw::values() const {
  return {phi_j0, c_phi, x, big_c_phi, b_phi, mu_j0, c_mu, y, big_c_mu, b_mu};
}

SoftLaw SoftLaw::from(const std::array<double, 10>& v) {
  SoftLaw l;
  l.phi_j0 = v[0];
  l.c_phi = v[1];
  l.x = v[2];
  l.big_c_phi = v[3];
  l.b_phi = v[4];
  l.mu_j0 = v[5];
  l.c_mu = v[6];
  l.y = v[7];
  l.big_c_mu = v[8];
  l.b_mu = v[9];
  return l;
}

double SoftLaw::phi(double p, double j) const {
  return phi_j0 + c_phi * std::pow(p, x) - big_c_phi * std::pow(j, b_phi);
}

double SoftLaw::mu(double p, double j) const {
  return mu_j0 - c_mu * std::pow(p, y) + big_c_mu * std::pow(j, b_mu);
}

double SoftLaw::dphi_dlnp(double p, double gdot) const {
  return c_phi * x * std::pow(p, x) + big_c_phi * b_phi * std::pow(gdot / p, b_phi);
}

double SoftLaw::pressure_at(double phi_target, double gdot) const {
  auto f = [&](double lp) {
    const double p = std::exp(lp);
    return phi(p, gdot / p) - phi_target;
  };
  double lo = std::log(1e-14), hi = std::log(1e3);
  const double flo = f(lo), fhi = f(hi);
  if (!(flo < 0.0) || !(fhi > 0.0))
    return std::nan("");
  for (int it = 0; it < 80; ++it) {
    const double mid = 0.5 * (lo + hi);
    (f(mid) > 0.0 ? hi : lo) = mid;
  }
  return std::exp(0.5 * (lo + hi));
}

double SoftLaw::sigma_at(double phi_target, double gdot) const {
  const double p = pressure_at(phi_target, gdot);
  if (!std::isfinite(p))
    return std::nan("");
  const double m = mu(p, gdot / p);
  return m > 0.0 ? m * p : std::nan("");
}

double SoftLaw::sigma_yield(double phi_target) const {
  const double d = phi_target - phi_j0;
  if (!(d > 0.0))
    return 0.0;
  const double p = std::pow(d / c_phi, 1.0 / x);
  return p * (mu_j0 - c_mu * std::pow(p, y));
}

double JointSoftFit::spread(const std::function<double(const SoftLaw&)>& f) const {
  std::vector<double> v;
  for (const auto& s : samples) {
    const double x = f(SoftLaw::from(s));
    if (std::isfinite(x))
      v.push_back(x);
  }
  if (v.size() < 2)
    return 0.0;
  double mean = 0.0, var = 0.0;
  for (double x : v)
    mean += x;
  mean /= static_cast<double>(v.size());
  for (double x : v)
    var += (x - mean) * (x - mean);
  return std::sqrt(var / static_cast<double>(v.size() - 1));
}

namespace {

// One half of the law: value = a + sp c1 P^e1 + sj c2 J^e2, parameters (a, c1, e1, c2, e2);
// phi: sp = +1, sj = -1; mu: sp = -1, sj = +1.
struct Half {
  double sp, sj;
  const std::vector<double>* p;
  const std::vector<double>* j;
  double value(std::size_t i, std::span<const double> q) const {
    return q[0] + sp * q[1] * std::pow((*p)[i], q[2]) + sj * q[3] * std::pow((*j)[i], q[4]);
  }
  ModelFunction model() const {
    return [h = *this](double xi, std::span<const double> q, std::span<double> grad) {
      const std::size_t i = static_cast<std::size_t>(xi);
      const double pe = std::pow((*h.p)[i], q[2]), je = std::pow((*h.j)[i], q[4]);
      if (!grad.empty()) {
        grad[0] = 1.0;
        grad[1] = h.sp * pe;
        grad[2] = h.sp * q[1] * pe * std::log((*h.p)[i]);
        grad[3] = h.sj * je;
        grad[4] = h.sj * q[3] * je * std::log((*h.j)[i]);
      }
      return q[0] + h.sp * q[1] * pe + h.sj * q[3] * je;
    };
  }
};

// Weighted linear least squares for (a, c1, c2) at fixed exponents; returns chi2 (inf if
// singular). A 3 x 3 system by Gaussian elimination.
double linear_at(const Half& h, const std::vector<double>& y, const std::vector<double>& err,
                 double e1, double e2, std::array<double, 3>& coef) {
  double m[3][4] = {};
  for (std::size_t i = 0; i < y.size(); ++i) {
    const double w = 1.0 / (err[i] * err[i]);
    const double row[3] = {1.0, h.sp * std::pow((*h.p)[i], e1), h.sj * std::pow((*h.j)[i], e2)};
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b)
        m[a][b] += w * row[a] * row[b];
      m[a][3] += w * row[a] * y[i];
    }
  }
  for (int c = 0; c < 3; ++c) {
    int piv = c;
    for (int r = c + 1; r < 3; ++r) {
      if (std::fabs(m[r][c]) > std::fabs(m[piv][c]))
        piv = r;
    }
    if (std::fabs(m[piv][c]) < 1e-300)
      return std::numeric_limits<double>::infinity();
    std::swap(m[c], m[piv]);
    for (int r = 0; r < 3; ++r) {
      if (r == c)
        continue;
      const double f = m[r][c] / m[c][c];
      for (int k = c; k < 4; ++k)
        m[r][k] -= f * m[c][k];
    }
  }
  for (int a = 0; a < 3; ++a)
    coef[static_cast<std::size_t>(a)] = m[a][3] / m[a][a];
  double chi2 = 0.0;
  for (std::size_t i = 0; i < y.size(); ++i) {
    const double f = coef[0] + coef[1] * h.sp * std::pow((*h.p)[i], e1) +
                     coef[2] * h.sj * std::pow((*h.j)[i], e2);
    chi2 += std::pow((f - y[i]) / err[i], 2);
  }
  return std::isfinite(chi2) ? chi2 : std::numeric_limits<double>::infinity();
}

// The start: the best (e1, e2) on a grid with both amplitudes positive (the law's signs),
// the amplitudes solved linearly.
std::vector<double> grid_start(const Half& h, const std::vector<double>& y,
                               const std::vector<double>& err) {
  double best = std::numeric_limits<double>::infinity();
  std::vector<double> start;
  for (int a = 0; a < 24; ++a) {
    const double e1 = 0.1 + 0.08 * a;  // 0.1 .. 1.94
    for (int b = 0; b < 24; ++b) {
      const double e2 = 0.05 + 0.06 * b;  // 0.05 .. 1.43
      std::array<double, 3> c{};
      const double chi2 = linear_at(h, y, err, e1, e2, c);
      if (chi2 < best && c[1] > 0.0 && c[2] > 0.0) {
        best = chi2;
        start = {c[0], c[1], e1, c[2], e2};
      }
    }
  }
  if (start.empty())
    throw FitError("joint soft fit: no exponents on the grid give positive amplitudes");
  return start;
}

struct NmDeleter {
  void operator()(gsl_multimin_fminimizer* m) const { gsl_multimin_fminimizer_free(m); }
};
struct GslVectorDeleter {
  void operator()(gsl_vector* v) const { gsl_vector_free(v); }
};

struct ProfileContext {
  const Half* h;
  const std::vector<double>* y;
  const std::vector<double>* err;
};

double profile_chi2(const gsl_vector* v, void* params) {
  const auto* c = static_cast<const ProfileContext*>(params);
  const double e1 = gsl_vector_get(v, 0), e2 = gsl_vector_get(v, 1);
  if (!(e1 > 0.005 && e1 < 6.0 && e2 > 0.005 && e2 < 6.0))
    return 1e300;
  std::array<double, 3> coef{};
  const double chi2 = linear_at(*c->h, *c->y, *c->err, e1, e2, coef);
  return std::isfinite(chi2) ? chi2 : 1e300;
}

// Variable projection: for each pair of exponents the amplitudes are solved linearly, and
// Nelder–Mead moves the exponents. Robust where Levenberg–Marquardt on all five parameters
// creeps along the flat valley of a narrow pressure range. Returns (a, c1, e1, c2, e2).
std::vector<double> profile_optimum(const Half& h, const std::vector<double>& y,
                                    const std::vector<double>& err, double e1, double e2,
                                    double& chi2) {
  gsl_set_error_handler_off();
  ProfileContext ctx{&h, &y, &err};
  gsl_multimin_function func{profile_chi2, 2, &ctx};
  double step = 0.1;
  for (int round = 0; round < 3; ++round) {
    std::unique_ptr<gsl_multimin_fminimizer, NmDeleter> m(
        gsl_multimin_fminimizer_alloc(gsl_multimin_fminimizer_nmsimplex2, 2));
    std::unique_ptr<gsl_vector, GslVectorDeleter> x(gsl_vector_alloc(2)), st(gsl_vector_alloc(2));
    gsl_vector_set(x.get(), 0, e1);
    gsl_vector_set(x.get(), 1, e2);
    gsl_vector_set_all(st.get(), step);
    if (gsl_multimin_fminimizer_set(m.get(), &func, x.get(), st.get()) != GSL_SUCCESS)
      throw FitError("joint soft fit: cannot start the exponent search");
    for (int it = 0; it < 2000; ++it) {
      if (gsl_multimin_fminimizer_iterate(m.get()) != GSL_SUCCESS)
        break;
      if (gsl_multimin_test_size(gsl_multimin_fminimizer_size(m.get()), 1e-9) == GSL_SUCCESS)
        break;
    }
    e1 = gsl_vector_get(m->x, 0);
    e2 = gsl_vector_get(m->x, 1);
    step *= 0.3;
  }
  std::array<double, 3> coef{};
  chi2 = linear_at(h, y, err, e1, e2, coef);
  if (!std::isfinite(chi2))
    throw FitError("joint soft fit: no finite chi2 at the exponents found");
  return {coef[0], coef[1], e1, coef[2], e2};
}

// (J^T W J)^-1 at p, by Gauss–Jordan; throws FitError when it is singular.
std::vector<double> curvature_covariance(const Half& h, const std::vector<double>& err,
                                         const std::vector<double>& p, const std::string& label) {
  constexpr std::size_t np = 5;
  double a[np][2 * np] = {};
  const ModelFunction model = h.model();
  std::vector<double> grad(np);
  for (std::size_t i = 0; i < err.size(); ++i) {
    model(static_cast<double>(i), p, grad);
    const double w = 1.0 / (err[i] * err[i]);
    for (std::size_t r = 0; r < np; ++r) {
      for (std::size_t c = 0; c < np; ++c)
        a[r][c] += w * grad[r] * grad[c];
    }
  }
  for (std::size_t r = 0; r < np; ++r)
    a[r][np + r] = 1.0;
  for (std::size_t c = 0; c < np; ++c) {
    std::size_t piv = c;
    for (std::size_t r = c + 1; r < np; ++r) {
      if (std::fabs(a[r][c]) > std::fabs(a[piv][c]))
        piv = r;
    }
    if (!(std::fabs(a[piv][c]) > 1e-300))
      throw FitError(label +
                     ": the curvature of chi2 is singular (a parameter is not "
                     "constrained by the data)");
    for (std::size_t k = 0; k < 2 * np; ++k)
      std::swap(a[c][k], a[piv][k]);
    const double d = a[c][c];
    for (std::size_t k = 0; k < 2 * np; ++k)
      a[c][k] /= d;
    for (std::size_t r = 0; r < np; ++r) {
      if (r == c)
        continue;
      const double f = a[r][c];
      for (std::size_t k = 0; k < 2 * np; ++k)
        a[r][k] -= f * a[c][k];
    }
  }
  std::vector<double> cov(np * np);
  for (std::size_t r = 0; r < np; ++r) {
    for (std::size_t c = 0; c < np; ++c)
      cov[r * np + c] = a[r][np + c];
  }
  for (std::size_t k = 0; k < np; ++k) {
    if (!(cov[k * np + k] > 0.0) || !std::isfinite(cov[k * np + k]))
      throw FitError(label +
                     ": the curvature of chi2 is singular (a parameter is not "
                     "constrained by the data)");
  }
  return cov;
}

double correlation(const std::vector<std::array<double, 10>>& s, std::size_t a, std::size_t b) {
  if (s.size() < 3)
    return std::nan("");
  double ma = 0, mb = 0;
  for (const auto& v : s) {
    ma += v[a];
    mb += v[b];
  }
  ma /= double(s.size());
  mb /= double(s.size());
  double sab = 0, saa = 0, sbb = 0;
  for (const auto& v : s) {
    sab += (v[a] - ma) * (v[b] - mb);
    saa += (v[a] - ma) * (v[a] - ma);
    sbb += (v[b] - mb) * (v[b] - mb);
  }
  return sab / std::sqrt(saa * sbb);
}

std::string g3(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

// Why an exponent is not resolved: the decades of P, the size of its term against the errors,
// and its correlation with the P -> 0 limit and the amplitude over the resamples.
std::string resolution_note(const JointSoftFit& f, bool is_y, const std::vector<double>& errs,
                            double target) {
  const std::size_t k = is_y ? 7 : 2, limit = is_y ? 5 : 0, amp = is_y ? 6 : 1;
  const char* name = is_y ? "y" : "x";
  const double pmin = f.pressures.front(), pmax = f.pressures.back();
  const double amp_v = f.params[amp].value, e = f.params[k].value;
  const double change = std::fabs(amp_v * (std::pow(pmax, e) - std::pow(pmin, e)));
  std::vector<double> sorted = errs;
  std::sort(sorted.begin(), sorted.end());
  const double median = sorted[sorted.size() / 2];
  std::string s = std::string(name) + " = " + g3(f.params[k].value) + " +- " +
                  g3(f.params[k].error) + " is not resolved to +-" + g3(target) + ": the " +
                  std::to_string(f.pressures.size()) + " pressures span " +
                  g3(std::log10(pmax / pmin)) + " decades (P = " + g3(pmin) + " to " + g3(pmax) +
                  "), over which the term " + (is_y ? "c_mu P^y" : "c_phi P^x") + " changes by " +
                  g3(change) + ", " + g3(change / median) + " times the median error of " +
                  (is_y ? "mu" : "phi") + " (" + g3(median) + ")";
  const double r_limit = correlation(f.samples, k, limit), r_amp = correlation(f.samples, k, amp);
  if (std::isfinite(r_limit)) {
    s += "; over the resamples " + std::string(name) + " correlates with " +
         (is_y ? "mu_J0" : "phi_J0") + " at r = " + g3(r_limit) + " and with " +
         (is_y ? "c_mu" : "c_phi") + " at r = " + g3(r_amp);
    if (std::fabs(r_limit) > 0.8 || std::fabs(r_amp) > 0.8)
      s += std::string(": the data trade ") + name + " against " +
           (std::fabs(r_limit) >= std::fabs(r_amp) ? "the P -> 0 limit" : "the amplitude") +
           ", which a longer lever arm in P (lower or higher pressures) or smaller errors "
           "would separate";
  }
  const double chi2 = is_y ? f.mu_fit.reduced_chi2() : f.phi_fit.reduced_chi2();
  if (chi2 > 2.0)
    s += "; chi2/dof = " + g3(chi2) +
         ": the law misses the data by more than their errors, and the resamples' noise is "
         "scaled up accordingly";
  return s;
}

}  // namespace

void soft_window_systematics(JointSoftFit& f, const std::vector<GranularPoint>& points) {
  auto fmt = [](double x) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", x);
    return std::string(buf);
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  f.pressure_window.fill(nan);
  f.j_window.fill(nan);
  f.window_refits.clear();
  const auto best = f.law.values();
  JointSoftOptions no_bootstrap;
  no_bootstrap.bootstrap = 0;
  auto refit = [&](bool by_pressure, bool highest, std::array<double, 10>& window) {
    double edge = highest ? -std::numeric_limits<double>::infinity()
                          : std::numeric_limits<double>::infinity();
    for (const auto& g : points) {
      const double v = by_pressure ? g.pressure : g.j;
      edge = highest ? std::max(edge, v) : std::min(edge, v);
    }
    std::vector<GranularPoint> kept;
    for (const auto& g : points) {
      const double v = by_pressure ? g.pressure : g.j;
      if (!(std::fabs(v - edge) <= 1e-9 * std::fabs(edge)))
        kept.push_back(g);
    }
    const std::string label = std::string("without ") + (by_pressure ? "P = " : "J = ") +
                              fmt(edge) + " (the " + (highest ? "largest" : "smallest") +
                              (by_pressure ? " pressure" : " J") + ")";
    try {
      const JointSoftFit g = fit_soft_joint(kept, no_bootstrap, f.law);
      const auto v = g.law.values();
      f.window_refits.push_back({label, v});
      for (std::size_t k = 0; k < 10; ++k) {
        const double s = std::fabs(v[k] - best[k]);
        window[k] = std::isfinite(window[k]) ? std::max(window[k], s) : s;
      }
    } catch (const AnalysisError& e) {
      f.window_notes.push_back("refit " + label + " not done: " + e.what());
    }
  };
  for (bool highest : {true, false})
    refit(true, highest, f.pressure_window);
  for (bool highest : {true, false})
    refit(false, highest, f.j_window);
}

void soft_form_systematics(JointSoftFit& f, const std::vector<GranularPoint>& points) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  f.form.fill(nan);
  f.form_refit.fill(nan);
  f.form_notes.clear();
  const double n = static_cast<double>(f.n);
  const double c_phi = seed::table2("C_phi").at(n), b_phi = seed::table2("b_phi").at(n);
  const double c_mu = seed::table2("C_mu").at(n), b_mu = seed::table2("b_mu").at(n);
  const auto best = f.law.values();
  f.form_refit[3] = c_phi;
  f.form_refit[4] = b_phi;
  f.form_refit[8] = c_mu;
  f.form_refit[9] = b_mu;
  // With the J-shape fixed, each half is a power law with offset in P.
  auto refit = [&](bool mu_half) {
    FitData d;
    for (const auto& g : points) {
      d.x.push_back(g.pressure);
      d.y.push_back(mu_half ? g.mu - c_mu * std::pow(g.j, b_mu)
                            : g.phi + c_phi * std::pow(g.j, b_phi));
      d.sigma.push_back(mu_half ? g.mu_err : g.phi_err);
    }
    PowerLawForm form;
    form.sign = mu_half ? -1.0 : 1.0;
    form.a_name = mu_half ? "mu_J0" : "phi_J0";
    form.c_name = mu_half ? "c_mu" : "c_phi";
    form.b_name = mu_half ? "y" : "x";
    FitOptions fo;
    fo.label = std::string(mu_half ? "mu_J(P)" : "phi_J(P)") +
               " with the paper's J-shape at N = " + std::to_string(f.n);
    const std::size_t off = mu_half ? 5 : 0;
    try {
      const FitResult r = fit_power_law_offset(d, form, fo);
      for (std::size_t k = 0; k < 3; ++k) {
        f.form_refit[off + k] = r.params[k];
        f.form[off + k] = std::fabs(r.params[k] - best[off + k]);
      }
    } catch (const AnalysisError& e) {
      f.form_notes.push_back("refit " + fo.label + " not done: " + e.what());
    }
  };
  refit(false);
  refit(true);
}

double JointSoftFit::LocalExponent::total_error() const {
  return std::hypot(exponent.error, offset_shift);
}

void soft_local_exponents(JointSoftFit& f, const std::vector<GranularPoint>& points) {
  f.local_x.clear();
  f.local_y.clear();
  f.local_notes.clear();
  const SoftLaw& law = f.law;
  const ModelFunction power = [](double p, std::span<const double> q, std::span<double> grad) {
    const double v = std::pow(p, q[1]);
    if (!grad.empty()) {
      grad[0] = v;
      grad[1] = q[0] * v * std::log(p);
    }
    return q[0] * v;
  };
  auto window_fit = [&](bool mu_half, double p_min, double p_max, double offset) {
    FitData d;
    for (const auto& g : points) {
      if (g.pressure < p_min * (1 - 1e-9) || g.pressure > p_max * (1 + 1e-9))
        continue;
      d.x.push_back(g.pressure);
      d.y.push_back(mu_half ? offset + law.big_c_mu * std::pow(g.j, law.b_mu) - g.mu
                            : g.phi + law.big_c_phi * std::pow(g.j, law.b_phi) - offset);
      d.sigma.push_back(mu_half ? g.mu_err : g.phi_err);
    }
    FitOptions fo;
    fo.label = std::string("local ") + (mu_half ? "y" : "x") + " over P = " + g3(p_min) + " to " +
               g3(p_max);
    const std::vector<double> start = {mu_half ? law.c_mu : law.c_phi, mu_half ? law.y : law.x};
    return fit_least_squares(d, power, start, {mu_half ? "c_mu" : "c_phi", mu_half ? "y" : "x"},
                             fo);
  };
  const auto& ps = f.pressures;  // ascending
  for (bool mu_half : {false, true}) {
    const double offset = mu_half ? law.mu_j0 : law.phi_j0;
    const double offset_err = f.params[mu_half ? 5 : 0].error;
    auto& out = mu_half ? f.local_y : f.local_x;
    for (std::size_t i = 0; i + 3 <= ps.size(); ++i) {
      JointSoftFit::LocalExponent e;
      e.p_min = ps[i];
      e.p_max = ps[i + 2];
      try {
        const FitResult r = window_fit(mu_half, e.p_min, e.p_max, offset);
        e.points = static_cast<std::size_t>(r.dof) + 2;
        e.exponent = r.at(1);
        for (double s : {-1.0, 1.0}) {
          try {
            const FitResult m = window_fit(mu_half, e.p_min, e.p_max, offset + s * offset_err);
            e.offset_shift = std::max(e.offset_shift, std::fabs(m.params[1] - r.params[1]));
          } catch (const AnalysisError&) {
            // Not computable: the window's error is then unknown, and the drift leaves it out.
            e.offset_shift = std::numeric_limits<double>::quiet_NaN();
          }
        }
        out.push_back(e);
      } catch (const AnalysisError& err) {
        f.local_notes.push_back(std::string("local ") + (mu_half ? "y" : "x") + " over P = " +
                                g3(e.p_min) + " to " + g3(e.p_max) + " not fitted: " + err.what());
      }
    }
  }
}

ExponentDrift exponent_drift(const std::vector<JointSoftFit::LocalExponent>& all) {
  ExponentDrift d;
  std::vector<JointSoftFit::LocalExponent> local;  // the windows with a finite error
  for (const auto& e : all) {
    if (std::isfinite(e.exponent.value) && std::isfinite(e.total_error()) && e.total_error() > 0)
      local.push_back(e);
  }
  if (local.size() < 2)
    return d;
  d.defined = true;
  d.low = local.front().exponent.value;
  d.low_err = local.front().total_error();
  d.high = local.back().exponent.value;
  d.high_err = local.back().total_error();
  d.sigma = (d.low - d.high) / std::hypot(d.low_err, d.high_err);
  d.from_one_sigma = (d.low - 1.0) / d.low_err;
  d.resolved = std::fabs(d.sigma) > 2.0;
  return d;
}

JointSoftFit fit_soft_joint(const std::vector<GranularPoint>& points,
                            const JointSoftOptions& options, const std::optional<SoftLaw>& start) {
  if (options.bootstrap < 0 || (options.bootstrap > 0 && options.bootstrap < 10)) {
    throw InputError("--bootstrap " + std::to_string(options.bootstrap) +
                     " (allowed: 0, or at least 10 resamples)");
  }
  JointSoftFit f;
  f.points = points.size();
  f.bootstrap_requested = options.bootstrap;
  std::vector<double> p, j, phi, phi_err, mu, mu_err;
  for (const auto& g : points) {
    f.n = g.n;
    p.push_back(g.pressure);
    j.push_back(g.j);
    phi.push_back(g.phi);
    phi_err.push_back(g.phi_err);
    mu.push_back(g.mu);
    mu_err.push_back(g.mu_err);
    if (std::find(f.pressures.begin(), f.pressures.end(), g.pressure) == f.pressures.end())
      f.pressures.push_back(g.pressure);
  }
  std::sort(f.pressures.begin(), f.pressures.end());
  const std::string label_n = "(N=" + std::to_string(f.n) + ")";
  if (f.pressures.size() < 3 || points.size() < 8) {
    throw InsufficientDataError("joint soft fit " + label_n + ": " + std::to_string(points.size()) +
                                " points at " + std::to_string(f.pressures.size()) +
                                " pressures; the five parameters of phi(P,J) (and of mu(P,J)) "
                                "need at least 3 pressures and 8 points (3 degrees of freedom)");
  }
  const Half hphi{1.0, -1.0, &p, &j}, hmu{-1.0, 1.0, &p, &j};
  std::vector<double> xs(points.size());
  for (std::size_t i = 0; i < xs.size(); ++i)
    xs[i] = static_cast<double>(i);
  std::vector<double> s_phi, s_mu;
  if (start) {
    const auto v = start->values();
    s_phi.assign(v.begin(), v.begin() + 5);
    s_mu.assign(v.begin() + 5, v.end());
  } else {
    s_phi = grid_start(hphi, phi, phi_err);
    s_mu = grid_start(hmu, mu, mu_err);
  }
  // The optimum by variable projection, polished by Levenberg–Marquardt (whose covariance
  // is the curvature error); where LM does not converge the covariance is (J^T W J)^-1 at the
  // projection's optimum.
  auto fit_half = [&](const Half& h, const std::vector<double>& y, const std::vector<double>& err,
                      const std::vector<double>& s0, const std::array<const char*, 10>& names,
                      std::size_t off, const std::string& label) {
    double chi2 = 0.0;
    const std::vector<double> vp = profile_optimum(h, y, err, s0[2], s0[4], chi2);
    const std::vector<std::string> pn = {names[off], names[off + 1], names[off + 2], names[off + 3],
                                         names[off + 4]};
    FitData d;
    d.x = xs;
    d.y = y;
    d.sigma = err;
    FitOptions fo;
    fo.label = label;
    try {
      FitResult r = fit_least_squares(d, h.model(), vp, pn, fo);
      if (r.chi2 <= chi2 * (1.0 + 1e-9) + 1e-12)
        return r;
    } catch (const AnalysisError&) {
      // the projection's optimum stands; its covariance follows
    }
    FitResult r;
    r.names = pn;
    r.params = vp;
    r.chi2 = chi2;
    r.dof = static_cast<int>(y.size()) - 5;
    r.covariance = curvature_covariance(h, err, vp, label);
    return r;
  };
  // A resample needs only the optimum.
  auto resample_half = [&](const Half& h, const std::vector<double>& y,
                           const std::vector<double>& err, const std::vector<double>& s0) {
    double chi2 = 0.0;
    return profile_optimum(h, y, err, s0[2], s0[4], chi2);
  };
  const auto& names = SoftLaw::names();
  f.phi_fit = fit_half(hphi, phi, phi_err, s_phi, names, 0,
                       "phi(P,J) = phi_J0 + c_phi P^x - C_phi J^b_phi " + label_n);
  f.mu_fit = fit_half(hmu, mu, mu_err, s_mu, names, 5,
                      "mu(P,J) = mu_J0 - c_mu P^y + C_mu J^b_mu " + label_n);
  std::array<double, 10> best{};
  for (std::size_t k = 0; k < 5; ++k) {
    best[k] = f.phi_fit.params[k];
    best[k + 5] = f.mu_fit.params[k];
    f.params[k] = f.phi_fit.at(k);
    f.params[k + 5] = f.mu_fit.at(k);
  }
  f.law = SoftLaw::from(best);
  f.noise_scale_phi = std::sqrt(std::max(1.0, f.phi_fit.reduced_chi2()));
  f.noise_scale_mu = std::sqrt(std::max(1.0, f.mu_fit.reduced_chi2()));

  if (options.bootstrap > 0) {
    std::mt19937_64 rng(options.seed);
    std::normal_distribution<double> normal(0.0, 1.0);
    std::vector<double> yp(points.size()), ym(points.size());
    const std::vector<double> b_phi(best.begin(), best.begin() + 5),
        b_mu(best.begin() + 5, best.end());
    for (int b = 0; b < options.bootstrap; ++b) {
      for (std::size_t i = 0; i < points.size(); ++i) {
        yp[i] = hphi.value(i, b_phi) + f.noise_scale_phi * phi_err[i] * normal(rng);
        ym[i] = hmu.value(i, b_mu) + f.noise_scale_mu * mu_err[i] * normal(rng);
      }
      try {
        const std::vector<double> a = resample_half(hphi, yp, phi_err, b_phi);
        const std::vector<double> c = resample_half(hmu, ym, mu_err, b_mu);
        std::array<double, 10> s{};
        for (std::size_t k = 0; k < 5; ++k) {
          s[k] = a[k];
          s[k + 5] = c[k];
        }
        f.samples.push_back(s);
      } catch (const AnalysisError&) {
        // a resample without a converged fit is left out and counted
      }
    }
    const std::size_t needed =
        std::max<std::size_t>(10, static_cast<std::size_t>(options.bootstrap) / 2);
    if (f.samples.size() < needed) {
      f.resolution_notes.push_back(
          "bootstrap: only " + std::to_string(f.samples.size()) + " of " +
          std::to_string(options.bootstrap) +
          " resamples converged; the errors are the curvature errors of chi2");
      f.samples.clear();
    } else {
      for (std::size_t k = 0; k < 10; ++k)
        f.params[k].error = f.spread([k](const SoftLaw& l) { return l.values()[k]; });
    }
  }
  f.alpha = {1.0 / f.law.x, f.samples.empty()
                                ? f.params[2].error / (f.law.x * f.law.x)
                                : f.spread([](const SoftLaw& l) { return 1.0 / l.x; })};
  for (auto& note : explain_resolution(f, points, options.y_target))
    f.resolution_notes.push_back(std::move(note));
  return f;
}

std::vector<std::string> explain_resolution(const JointSoftFit& f,
                                            const std::vector<GranularPoint>& points,
                                            double target) {
  std::vector<double> phi_err, mu_err;
  for (const auto& g : points) {
    phi_err.push_back(g.phi_err);
    mu_err.push_back(g.mu_err);
  }
  std::vector<std::string> notes;
  if (f.params[2].error > target)
    notes.push_back(resolution_note(f, false, phi_err, target));
  if (f.params[7].error > target)
    notes.push_back(resolution_note(f, true, mu_err, target));
  return notes;
}

YieldComparison compare_yield(const JointSoftFit& fit, const std::vector<ShearPoint>& cv) {
  YieldComparison c;
  double sum = 0.0;
  for (const auto& s : cv) {
    if (!(s.phi > fit.law.phi_j0)) {
      ++c.below;
      continue;
    }
    YieldPoint y;
    y.phi = s.phi;
    y.gdot = s.shear_rate;
    y.sigma = {s.sigma, s.sigma_err};
    const double phi = s.phi, gdot = s.shear_rate;
    y.sigma_law = {fit.law.sigma_at(phi, gdot),
                   fit.spread([&](const SoftLaw& l) { return l.sigma_at(phi, gdot); })};
    y.sigma_yield = {fit.law.sigma_yield(phi),
                     fit.spread([&](const SoftLaw& l) { return l.sigma_yield(phi); })};
    if (!std::isfinite(y.sigma_law.value) || !std::isfinite(y.sigma_yield.value))
      continue;
    y.pull = (y.sigma.value - y.sigma_law.value) / std::hypot(y.sigma.error, y.sigma_law.error);
    sum += y.pull * y.pull;
    c.points.push_back(y);
  }
  std::sort(c.points.begin(), c.points.end(), [](const YieldPoint& a, const YieldPoint& b) {
    return a.phi != b.phi ? a.phi < b.phi : a.gdot < b.gdot;
  });
  c.mean_square_pull = c.points.empty() ? 0.0 : sum / static_cast<double>(c.points.size());
  return c;
}

}  // namespace jamflow::analysis
