// Soft granular rheology: per-pressure collapse, pressure dependence of
// phi_J and mu_J, yield-stress law (see soft.hpp).
#include "analysis/soft.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "analysis/errors.hpp"
#include "analysis/json.hpp"

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
  auto groups = group_by_size(points);
  if (groups.empty())
    throw InsufficientDataError("no data points");
  for (const auto& [n, pts] : groups) {
    SoftSize s;
    s.n = n;
    s.points = pts;
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
    r.sizes.push_back(std::move(s));
  }
  return r;
}

}  // namespace jamflow::analysis
