// Flow-curve and viscosity-divergence fits (see flow_curve.hpp).
#include "analysis/flow_curve.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <string_view>
#include <tuple>

#include "analysis/errors.hpp"
#include "analysis/format.hpp"

namespace jamflow::analysis {

namespace {

FitData curve_data(const std::vector<ShearPoint>& curve) {
  FitData d;
  for (const auto& p : curve) {
    d.x.push_back(p.shear_rate);
    d.y.push_back(p.sigma);
    d.sigma.push_back(p.sigma_err);
  }
  return d;
}

// Weighted straight line y = a + b x; returns chi2 (infinity when x does not vary).
double weighted_line(const std::vector<double>& x, const std::vector<double>& y,
                     const std::vector<double>& e, double& a, double& b) {
  double s = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double w = 1.0 / (e[i] * e[i]);
    s += w;
    sx += w * x[i];
    sy += w * y[i];
    sxx += w * x[i] * x[i];
    sxy += w * x[i] * y[i];
  }
  const double det = s * sxx - sx * sx;
  if (!(std::fabs(det) > 1e-12 * s * sxx))
    return std::numeric_limits<double>::infinity();
  b = (s * sxy - sx * sy) / det;
  a = (sy - b * sx) / s;
  double chi2 = 0;
  for (std::size_t i = 0; i < x.size(); ++i)
    chi2 += std::pow((y[i] - a - b * x[i]) / e[i], 2);
  return chi2;
}

void require_points(std::size_t n, std::size_t params, const std::string& label) {
  if (n < params + 1) {
    throw InsufficientDataError(label + ": needs at least " + std::to_string(params + 1) +
                                " points for " + std::to_string(params) + " parameters, got " +
                                std::to_string(n));
  }
}

// Runs one fit into `out`: kFit, kSkipped (too few points) or kFailed (recorded in failures).
template <class Fit>
void run_fit(FlowFit& out, const std::string& what, const std::vector<ParameterBound>& bounds,
             std::vector<std::string>& failures, const Fit& fit) {
  try {
    out.fit = fit();
    out.errors = statistical_error_model(out.fit, bounds);
    out.status = FlowFit::Status::kFit;
  } catch (const InsufficientDataError& e) {
    out.status = FlowFit::Status::kSkipped;
    out.reason = e.what();
  } catch (const FitError& e) {
    out.status = FlowFit::Status::kFailed;
    out.reason = e.what();
    failures.push_back(what + ": " + e.what());
  }
}

// The imposed pressure of a constant-pressure curve, from its label "N=..,imposed_pressure=..".
constexpr std::string_view kPressureLabel = ",imposed_pressure=";
double pressure_of(const std::string& set) {
  const auto at = set.find(kPressureLabel);
  return at == std::string::npos ? 0.0 : std::stod(set.substr(at + kPressureLabel.size()));
}

}  // namespace

FitResult fit_flow_power_law(const std::vector<ShearPoint>& curve, const FitOptions& options) {
  require_points(curve.size(), 2, options.label);
  FitData d = curve_data(curve);
  // Start: the straight line in ln sigma against ln gdot, weighted by the relative errors.
  std::vector<double> lx, ly, le;
  for (std::size_t i = 0; i < d.size(); ++i) {
    lx.push_back(std::log(d.x[i]));
    ly.push_back(std::log(d.y[i]));
    le.push_back(d.sigma[i] / d.y[i]);
  }
  double ln_a = 0, n = 0;
  if (!std::isfinite(weighted_line(lx, ly, le, ln_a, n)))
    throw InsufficientDataError(options.label + ": all points are at one shear rate");
  ModelFunction model = [](double x, std::span<const double> p, std::span<double> grad) {
    const double xn = std::pow(x, p[1]);
    if (!grad.empty()) {
      grad[0] = xn;
      grad[1] = p[0] * xn * std::log(x);
    }
    return p[0] * xn;
  };
  return fit_least_squares(d, model, {std::exp(ln_a), n}, {"A", "n"}, options);
}

FitResult fit_herschel_bulkley(const std::vector<ShearPoint>& curve, const FitOptions& options) {
  require_points(curve.size(), 3, options.label);
  PowerLawForm form;
  form.sign = 1.0;
  form.exponent_sign = 1.0;
  form.a_name = "sigma_y";
  form.c_name = "K";
  form.b_name = "n";
  return fit_power_law_offset(curve_data(curve), form, options);
}

FitResult fit_divergence(const std::vector<double>& phi, const std::vector<double>& eta,
                         const std::vector<double>& eta_err, const FitOptions& options) {
  require_points(phi.size(), 3, options.label);
  FitData d;
  d.x = phi;
  for (std::size_t i = 0; i < phi.size(); ++i) {
    d.y.push_back(std::log(eta[i]));
    d.sigma.push_back(eta_err[i] / eta[i]);
  }
  const double phi_max = *std::max_element(phi.begin(), phi.end());
  const double phi_min = *std::min_element(phi.begin(), phi.end());
  if (!(phi_max > phi_min))
    throw InsufficientDataError(options.label + ": all points are at one phi");
  // Start: for phi_c fixed, ln eta is linear in (ln eta_0, beta); the minimum of that profile
  // over phi_c = phi_max + delta, delta on a logarithmic grid from 1e-4 to 10 times the range.
  double best = std::numeric_limits<double>::infinity(), best_a = 0, best_b = 0, best_c = 0;
  const double range = phi_max - phi_min;
  const int steps = 200;
  for (int k = 0; k <= steps; ++k) {
    const double delta = range * std::pow(10.0, -4.0 + 5.0 * k / steps);
    const double phi_c = phi_max + delta;
    std::vector<double> u;
    for (double p : phi)
      u.push_back(-std::log(phi_c - p));
    double a = 0, b = 0;
    const double chi2 = weighted_line(u, d.y, d.sigma, a, b);
    if (chi2 < best && b > 0) {
      best = chi2;
      best_a = a;
      best_b = b;
      best_c = phi_c;
    }
  }
  if (!std::isfinite(best)) {
    throw FitError(options.label +
                   ": eta does not grow with phi (no divergence at phi_c above the data)");
  }
  ModelFunction model = [](double x, std::span<const double> p, std::span<double> grad) {
    const double gap = p[2] - x;
    if (!(gap > 0))
      return std::numeric_limits<double>::quiet_NaN();  // rejected by the trust region
    if (!grad.empty()) {
      grad[0] = 1.0;
      grad[1] = -std::log(gap);
      grad[2] = -p[1] / gap;
    }
    return p[0] - p[1] * std::log(gap);
  };
  return fit_least_squares(d, model, {best_a, best_b, best_c}, {"ln_eta0", "beta", "phi_c"},
                           options);
}

FlowCurveResult analyze_flow_curves(const std::vector<ShearPoint>& points,
                                    const FlowCurveOptions& options) {
  if (points.empty())
    throw InsufficientDataError("no data points");
  FlowCurveResult r;
  r.point_errors = point_errors_of(points);
  std::map<std::string, std::vector<ShearPoint>> sets;
  for (const auto& p : points)
    sets[p.set].push_back(p);
  FitOptions fo;
  fo.scale_errors_by_chi2 = options.scale_errors;

  for (auto& entry : sets) {
    // Named references, not a structured binding: clang before 16 cannot capture a binding in
    // the lambdas below (the fuzz build is clang's).
    const auto& set = entry.first;
    auto& pts = entry.second;
    std::sort(pts.begin(), pts.end(),
              [](const ShearPoint& a, const ShearPoint& b) { return a.shear_rate < b.shear_rate; });
    FlowCurve c;
    c.set = set;
    c.n = pts.front().n;
    c.constant_pressure = set.find(kPressureLabel) != std::string::npos;
    c.state = c.constant_pressure ? pressure_of(set) : pts.front().phi;
    c.points = pts;
    std::vector<std::string> failed;
    for (const auto& p : pts) {
      if (!p.failed_verdicts.empty())
        failed.push_back(p.source + " (" + p.failed_verdicts + ")");
    }
    for (FlowFit* f : {&c.power_law, &c.herschel_bulkley}) {
      f->points_used = pts.size();
      f->failed_included = failed;
    }
    c.power_law.formula = "sigma_xy = A gdot^n";
    fo.label = "power law (" + set + ")";
    run_fit(c.power_law, fo.label, {{"A", 0.0, {}}, {"n", 0.0, {}}}, r.failures,
            [&] { return fit_flow_power_law(pts, fo); });
    c.herschel_bulkley.formula = "sigma_xy = sigma_y + K gdot^n";
    fo.label = "Herschel-Bulkley (" + set + ")";
    run_fit(c.herschel_bulkley, fo.label, {{"K", 0.0, {}}, {"n", 0.0, {}}}, r.failures,
            [&] { return fit_herschel_bulkley(pts, fo); });
    r.curves.push_back(std::move(c));
  }

  // Divergence groups: constant volume by (N, gdot) over the curves, constant pressure by curve.
  struct Group {
    std::int64_t n;
    bool constant_pressure;
    std::string label;
    std::vector<ShearPoint> pts;
    std::vector<LeftOutRow> left_out;
  };
  std::map<std::tuple<int, std::int64_t, double, std::string>, Group> groups;
  for (const auto& c : r.curves) {
    std::string jammed;
    if (!c.constant_pressure && c.herschel_bulkley.status == FlowFit::Status::kFit) {
      const Measured y = c.herschel_bulkley.fit["sigma_y"];
      if (y.value > options.yield_z * y.error) {
        jammed = "curve " + c.set + " has a yield stress sigma_y = " + fmt(y.value) + " +- " +
                 fmt(y.error) + " (above zero by more than " + fmt(options.yield_z) +
                 " sigma): jammed, its eta does not diverge at phi_c";
      }
    }
    for (const auto& p : c.points) {
      const auto key = c.constant_pressure ? std::make_tuple(1, c.n, 0.0, c.set)
                                           : std::make_tuple(0, c.n, p.shear_rate, std::string());
      Group& g = groups[key];
      g.n = c.n;
      g.constant_pressure = c.constant_pressure;
      g.label = c.constant_pressure
                    ? c.set
                    : "N=" + std::to_string(c.n) + ",shear_rate=" + format_key(p.shear_rate);
      if (!jammed.empty())
        g.left_out.push_back({p.source, jammed});
      else
        g.pts.push_back(p);
    }
  }
  for (auto& [key, g] : groups) {
    std::sort(g.pts.begin(), g.pts.end(),
              [](const ShearPoint& a, const ShearPoint& b) { return a.phi < b.phi; });
    Divergence d;
    d.group = g.label;
    d.n = g.n;
    d.constant_pressure = g.constant_pressure;
    d.fit.formula = "eta = eta_0 (phi_c - phi)^(-beta), eta = sigma_xy / gdot";
    d.fit.left_out = g.left_out;
    d.fit.points_used = g.pts.size();
    for (const auto& p : g.pts) {
      d.phi.push_back(p.phi);
      d.eta.push_back(p.sigma / p.shear_rate);
      d.eta_err.push_back(p.sigma_err / p.shear_rate);
      if (!p.failed_verdicts.empty())
        d.fit.failed_included.push_back(p.source + " (" + p.failed_verdicts + ")");
    }
    fo.label = "eta(phi) divergence (" + g.label + ")";
    run_fit(d.fit, fo.label, {{"beta", 0.0, {}}}, r.failures,
            [&] { return fit_divergence(d.phi, d.eta, d.eta_err, fo); });
    if (d.fit.status == FlowFit::Status::kFit) {
      const Measured ln_eta0 = d.fit.fit["ln_eta0"];
      const double eta0 = std::exp(ln_eta0.value);
      d.fit.derived.push_back({"eta_0", {eta0, eta0 * ln_eta0.error}});
    }
    r.divergences.push_back(std::move(d));
  }

  // Not one fit could be done for lack of points: the data cannot support the analysis.
  std::size_t fitted = 0, failed = 0;
  std::string why;
  auto count = [&](const FlowFit& f) {
    fitted += f.status == FlowFit::Status::kFit;
    failed += f.status == FlowFit::Status::kFailed;
    if (f.status == FlowFit::Status::kSkipped && why.empty())
      why = f.reason;
  };
  for (const auto& c : r.curves) {
    count(c.power_law);
    count(c.herschel_bulkley);
  }
  for (const auto& d : r.divergences)
    count(d.fit);
  if (fitted == 0 && failed == 0) {
    throw InsufficientDataError("no fit could be done (" + std::to_string(points.size()) +
                                " points on " + std::to_string(r.curves.size()) +
                                " curves); first: " + why);
  }
  for (const auto& c : r.curves) {
    if (c.herschel_bulkley.status == FlowFit::Status::kSkipped)
      r.warnings.push_back(c.herschel_bulkley.reason);
  }
  return r;
}

}  // namespace jamflow::analysis
