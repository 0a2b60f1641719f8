// JSON, markdown and plot sidecar of `jamflow analyze flow-curve` (see flow_curve.hpp).
#include <cmath>
#include <cstdio>
#include <sstream>

#include "analysis/flow_curve.hpp"
#include "analysis/report.hpp"

namespace jamflow::analysis {

namespace {

const char* status_name(FlowFit::Status s) {
  switch (s) {
    case FlowFit::Status::kFit:
      return "fit";
    case FlowFit::Status::kSkipped:
      return "skipped";
    case FlowFit::Status::kFailed:
      return "failed";
  }
  return "unknown";
}

Json strings(const std::vector<std::string>& xs) {
  Json j = Json::array();
  for (const auto& x : xs)
    j.push_back(x);
  return j;
}

Json fit_json(const FlowFit& f) {
  Json j = Json::object();
  j["status"] = status_name(f.status);
  j["formula"] = f.formula;
  if (f.status != FlowFit::Status::kFit)
    j["reason"] = f.reason;
  if (f.status == FlowFit::Status::kFit) {
    Json params = Json::object();
    for (std::size_t k = 0; k < f.fit.size(); ++k)
      params[f.fit.names[k]] = measured_json(f.fit.at(k));
    for (const auto& [name, m] : f.derived)
      params[name] = measured_json(m);
    j["parameters"] = params;
    j["chi2"] = f.fit.chi2;
    j["dof"] = f.fit.dof;
    j["reduced_chi2"] = f.fit.reduced_chi2();
    j["errors_scaled_by_sqrt_chi2_dof"] = f.fit.errors_scaled;
    j["degenerate"] = f.errors.degenerate;
    if (f.errors.degenerate)
      j["degenerate_reason"] = f.errors.degenerate_reason;
  }
  j["points_used"] = static_cast<std::int64_t>(f.points_used);
  j["failed_verdicts_included"] = strings(f.failed_included);
  Json left = Json::array();
  for (const auto& l : f.left_out) {
    Json o = Json::object();
    o["row"] = l.source;
    o["why"] = l.why;
    left.push_back(o);
  }
  j["left_out"] = left;
  return j;
}

std::string fit_line(const FlowFit& f) {
  std::ostringstream os;
  if (f.status != FlowFit::Status::kFit) {
    os << status_name(f.status) << ": " << f.reason;
    return os.str();
  }
  for (std::size_t k = 0; k < f.fit.size(); ++k)
    os << (k ? ", " : "") << f.fit.names[k] << " = " << format_measured(f.fit.at(k));
  for (const auto& [name, m] : f.derived)
    os << ", " << name << " = " << format_measured(m);
  char buf[96];
  std::snprintf(buf, sizeof buf, "; chi2/dof = %.3g (%d dof)%s", f.fit.reduced_chi2(), f.fit.dof,
                f.fit.errors_scaled ? ", errors scaled by sqrt(chi2/dof)" : "");
  os << buf;
  if (f.errors.degenerate)
    os << "; degenerate: " << f.errors.degenerate_reason;
  return os.str();
}

void fit_md(std::ostringstream& md, const std::string& title, const FlowFit& f) {
  md << "- **" << title << "** (`" << f.formula << "`, " << f.points_used
     << " points): " << fit_line(f) << "\n";
  for (const auto& s : f.failed_included)
    md << "  - included although its verdicts failed: " << s << "\n";
  for (const auto& l : f.left_out)
    md << "  - left out: " << l.source << ": " << l.why << "\n";
}

// Evaluates a fitted model on a logarithmic grid for the plots.
Json model_curve(const FlowFit& f, double lo, double hi, bool hb) {
  Json j = Json::object();
  std::vector<double> x, y;
  for (int k = 0; k <= 60; ++k) {
    const double g = lo * std::pow(hi / lo, k / 60.0);
    x.push_back(g);
    y.push_back(hb ? f.fit.params[0] + f.fit.params[1] * std::pow(g, f.fit.params[2])
                   : f.fit.params[0] * std::pow(g, f.fit.params[1]));
  }
  j["shear_rate"] = Json(x);
  j["sigma_xy"] = Json(y);
  return j;
}

}  // namespace

Json flow_curve_json(const FlowCurveResult& r, const std::vector<std::string>& inputs,
                     const std::vector<std::string>& left_out, bool include_failed) {
  Json j = Json::object();
  j["analysis"] = "flow-curve";
  j["inputs"] = strings(inputs);
  j["include_failed"] = include_failed;
  j["errors"] =
      "statistical errors from the fit covariance, multiplied by sqrt(chi2/dof) where chi2/dof > 1 "
      "(errors_scaled_by_sqrt_chi2_dof)";
  j["point_errors"] = point_errors_json(r.point_errors);
  j["left_out_for_verdicts"] = strings(left_out);
  Json curves = Json::array();
  for (const auto& c : r.curves) {
    Json o = Json::object();
    o["curve"] = c.set;
    o["N"] = c.n;
    o["ensemble"] = c.constant_pressure ? "constant_pressure" : "constant_volume";
    o[c.constant_pressure ? "imposed_pressure" : "phi"] = c.state;
    Json pts = Json::array();
    for (const auto& p : c.points) {
      Json q = Json::object();
      q["shear_rate"] = p.shear_rate;
      q["sigma_xy"] = p.sigma;
      q["sigma_xy_err"] = p.sigma_err;
      q["phi"] = p.phi;
      q["source"] = p.source;
      q["verdicts_failed"] = !p.failed_verdicts.empty();
      if (!p.failed_verdicts.empty())
        q["failed_verdicts"] = p.failed_verdicts;
      pts.push_back(q);
    }
    o["points"] = pts;
    o["power_law"] = fit_json(c.power_law);
    o["herschel_bulkley"] = fit_json(c.herschel_bulkley);
    curves.push_back(o);
  }
  j["curves"] = curves;
  Json divs = Json::array();
  for (const auto& d : r.divergences) {
    Json o = fit_json(d.fit);
    o["group"] = d.group;
    o["N"] = d.n;
    o["ensemble"] = d.constant_pressure ? "constant_pressure" : "constant_volume";
    if (d.constant_pressure)
      o["note"] = "phi is the measured phi of each row; its error is neglected";
    divs.push_back(o);
  }
  j["divergences"] = divs;
  j["warnings"] = strings(r.warnings);
  j["failures"] = strings(r.failures);
  return j;
}

std::string flow_curve_markdown(const FlowCurveResult& r, const std::vector<std::string>& inputs,
                                const std::vector<std::string>& left_out, bool include_failed) {
  std::ostringstream md;
  md << "# Flow curves\n\nInputs:";
  for (const auto& i : inputs)
    md << " `" << i << "`";
  md << "\n\nErrors: statistical, from the fit covariance, multiplied by sqrt(chi2/dof) where "
        "chi2/dof > 1 (said on each such fit). "
     << describe(r.point_errors) << "\n";
  if (include_failed) {
    md << "\nRuns whose verdicts failed are **included** (`--include-failed`) and marked below.\n";
  } else if (!left_out.empty()) {
    md << "\nRows left out, their verdicts failed (`--include-failed` keeps them):\n\n";
    for (const auto& l : left_out)
      md << "- " << l << "\n";
  }
  md << "\n## sigma_xy(gdot) on each curve\n\n";
  for (const auto& c : r.curves) {
    md << "### " << c.set << " (" << c.points.size() << " points)\n\n";
    fit_md(md, "power law", c.power_law);
    fit_md(md, "Herschel-Bulkley", c.herschel_bulkley);
    md << "\n";
  }
  md << "## eta(phi) divergence\n\n";
  // Groups with too few points for the fit are counted, not listed (the JSON has each).
  std::size_t skipped = 0;
  for (const auto& d : r.divergences) {
    if (d.fit.status == FlowFit::Status::kSkipped) {
      ++skipped;
      continue;
    }
    fit_md(md, d.group, d.fit);
  }
  if (skipped > 0) {
    md << "- " << skipped << " of " << r.divergences.size()
       << " groups skipped: fewer than 4 points (values of phi) left for eta_0, beta and phi_c"
       << " (`divergences` in the JSON lists each, with the rows left out)\n";
  }
  if (!r.warnings.empty() || !r.failures.empty()) {
    md << "\n## Notes\n\n";
    for (const auto& w : r.warnings)
      md << "- warning: " << w << "\n";
    for (const auto& f : r.failures)
      md << "- failed: " << f << "\n";
  }
  return md.str();
}

Json flow_curve_plot_data(const FlowCurveResult& r) {
  Json j = Json::object();
  Json curves = Json::array();
  for (const auto& c : r.curves) {
    Json o = Json::object();
    o["curve"] = c.set;
    std::vector<double> g, s, e, failed;
    for (const auto& p : c.points) {
      g.push_back(p.shear_rate);
      s.push_back(p.sigma);
      e.push_back(p.sigma_err);
      failed.push_back(p.failed_verdicts.empty() ? 0.0 : 1.0);
    }
    o["shear_rate"] = Json(g);
    o["sigma_xy"] = Json(s);
    o["sigma_xy_err"] = Json(e);
    o["failed"] = Json(failed);
    const double lo = g.front(), hi = g.back();
    if (c.power_law.status == FlowFit::Status::kFit)
      o["power_law"] = model_curve(c.power_law, lo, hi, false);
    if (c.herschel_bulkley.status == FlowFit::Status::kFit)
      o["herschel_bulkley"] = model_curve(c.herschel_bulkley, lo, hi, true);
    curves.push_back(o);
  }
  j["curves"] = curves;
  Json divs = Json::array();
  for (const auto& d : r.divergences) {
    if (d.fit.status != FlowFit::Status::kFit)
      continue;
    Json o = Json::object();
    o["group"] = d.group;
    o["phi"] = Json(d.phi);
    o["eta"] = Json(d.eta);
    o["eta_err"] = Json(d.eta_err);
    o["ln_eta0"] = d.fit.fit.params[0];
    o["beta"] = d.fit.fit.params[1];
    o["phi_c"] = d.fit.fit.params[2];
    divs.push_back(o);
  }
  j["divergences"] = divs;
  return j;
}

}  // namespace jamflow::analysis
