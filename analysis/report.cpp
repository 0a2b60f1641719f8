// JSON, markdown and plot-sidecar outputs of the analyses (see report.hpp).
#include "analysis/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <stdexcept>

#include "analysis/format.hpp"
#include "analysis/seed.hpp"
#include "lib/statistics.hpp"

namespace jamflow::analysis {

namespace {

Json fit_summary(const FitResult& f) {
  Json j = Json::object();
  j["chi2"] = f.chi2;
  j["dof"] = f.dof;
  j["errors_scaled_by_chi2"] = f.errors_scaled;
  // Correlation matrix: the parameters of one fit are strongly correlated
  // (phi_J with b_phi, ...), which matters for anyone combining them.
  Json corr = Json::array();
  for (std::size_t a = 0; a < f.size(); ++a) {
    std::vector<double> row;
    for (std::size_t b = 0; b < f.size(); ++b) {
      row.push_back(f.cov(a, b) / std::sqrt(f.cov(a, a) * f.cov(b, b)));
    }
    corr.push_back(Json(row));
  }
  Json names = Json::array();
  for (const auto& n : f.names)
    names.push_back(n);
  j["parameters"] = names;
  j["correlation"] = corr;
  return j;
}

Json strings_json(const std::vector<std::string>& xs);

// A number that may be NaN (not computable) as a JSON number or null.
Json number_or_null(double x) {
  return std::isfinite(x) ? Json(x) : Json();
}

}  // namespace

Json error_model_json(const ErrorModel& m) {
  Json j = Json::object();
  j["reduced_chi2"] = m.reduced_chi2;
  j["dof"] = m.dof;
  j["errors_scaled_by_sqrt_chi2_dof"] = m.errors_scaled;
  j["degenerate"] = m.degenerate;
  if (m.degenerate)
    j["degenerate_reason"] = m.degenerate_reason;
  Json params = Json::object();
  for (const auto& p : m.parameters) {
    Json jp = Json::object();
    jp["value"] = p.value;
    jp["statistical"] = p.statistical;
    jp["window"] = number_or_null(p.window);
    jp["form"] = number_or_null(p.form);
    jp["systematic"] = number_or_null(p.systematic());
    params[p.name] = jp;
  }
  j["parameters"] = params;
  j["notes"] = strings_json(m.notes);
  j["meaning"] =
      "statistical: covariance error, times sqrt(chi2/dof) when chi2/dof > 1; window: largest "
      "shift when the points at the largest or at the smallest x are dropped; form: shift with "
      "the exponent fixed at the reference; systematic: window and form in quadrature; "
      "degenerate: a parameter outside its physical range or with error >= |value|";
  return j;
}

namespace {

Json strings_json(const std::vector<std::string>& xs) {
  Json a = Json::array();
  for (const auto& x : xs)
    a.push_back(x);
  return a;
}

Json quality_json(const CollapseQuality& q) {
  Json j = Json::object();
  if (q.used == 0) {
    // Explicitly undefined, never a silent NaN: no point had a neighbour.
    j["value"] = Json();
    j["error"] = Json();
    j["undefined_reason"] = "no point has a bracketing neighbour on another curve";
  } else {
    j["value"] = q.s;
    j["error"] = q.error();
  }
  j["acceptable"] = q.acceptable();
  if (q.used > 0)
    j["threshold"] = q.threshold();
  j["points_used"] = static_cast<std::int64_t>(q.used);
  j["points_total"] = static_cast<std::int64_t>(q.total);
  return j;
}

std::string quality_md(const CollapseQuality& q) {
  if (q.used == 0)
    return "undefined (no overlap)";
  return format_measured({q.s, q.error()}) + " (" + std::to_string(q.used) + "/" +
         std::to_string(q.total) + " pts)";
}

std::string pull_md(double value, double error, double ref) {
  if (!(error > 0))
    return "";
  return fmt((value - ref) / error, "%+.1f");
}

void inputs_md(std::ostringstream& md, const std::vector<std::string>& inputs) {
  md << "Inputs (" << inputs.size() << " file" << (inputs.size() == 1 ? "" : "s") << "): ";
  for (std::size_t i = 0; i < inputs.size() && i < 8; ++i)
    md << (i ? ", " : "") << "`" << inputs[i] << "`";
  if (inputs.size() > 8)
    md << ", ...";
  md << "\n\n";
}

void notes_md(std::ostringstream& md, const std::vector<std::string>& warnings,
              const std::vector<std::string>& failures) {
  if (warnings.empty() && failures.empty())
    return;
  md << "## Notes\n\n";
  for (const auto& w : warnings)
    md << "- warning: " << w << "\n";
  for (const auto& f : failures)
    md << "- **failed**: " << f << "\n";
  md << "\n";
}

}  // namespace

Json measured_json(const Measured& m) {
  Json j = Json::object();
  j["value"] = m.value;
  j["error"] = m.error;
  return j;
}

// What the points' errors are made of (data.hpp ErrorBasis), for every analysis' JSON.
Json point_errors_json(const PointErrors& e) {
  Json j = Json::object();
  j["points"] = static_cast<std::int64_t>(e.points);
  Json counts = Json::object();
  for (const auto& [basis, n] : e.counts)
    counts[error_basis_name(basis)] = static_cast<std::int64_t>(n);
  j["counts"] = counts;
  j["replica_scatter_from_replicas"] = kMinReplicasForScatter;
  j["description"] = describe(e);
  return j;
}

std::string format_measured(const Measured& m) {
  const double v = m.value, e = m.error;
  if (!std::isfinite(v) || !std::isfinite(e))
    return fmt(v) + " ± " + fmt(e);
  const double av = std::fabs(v);
  if (e > 0 && e < 1e5 && (av == 0 || (av >= 1e-4 && av < 1e6)) &&
      e >= 1e-10 * std::max(av, 1e-300)) {
    int decimals = 1 - static_cast<int>(std::floor(std::log10(e)));
    decimals = std::clamp(decimals, 0, 12);
    char buf[96];
    std::snprintf(buf, sizeof buf, "%.*f ± %.*f", decimals, v, decimals, e);
    return buf;
  }
  if (e == 0)
    return fmt(v) + " (exact)";
  return fmt(v, "%.4e") + " ± " + fmt(e, "%.2e");
}

std::string markdown_cell(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t k = 0; k < text.size(); ++k) {
    if (text[k] == '|' && (k == 0 || text[k - 1] != '\\'))
      out += '\\';
    out += text[k];
  }
  return out;
}

// --- hard sphere -------------------------------------------------------------

namespace {

Measured size_param(const SizeFit& s, const std::string& name) {
  if (name == "phi_J" || name == "b_phi" || name == "C_phi")
    return s.phi[name];
  return s.mu[name];
}

// How many points of a size have each envelope status.
Json envelope_counts_json(const std::vector<EnvelopePoint>& points) {
  std::map<std::string, std::int64_t> counts;
  for (const auto& e : points)
    ++counts[to_string(e.status)];
  Json j = Json::object();
  for (const auto& [status, count] : counts)
    j[status] = count;
  return j;
}

Json viscosity_json(const ViscosityLaw& v) {
  Json j = Json::object();
  j["source"] = v.source;
  Json params = Json::object();
  const auto& names = hard_sphere_parameters();
  for (std::size_t i = 0; i < names.size(); ++i) {
    params[names[i]] = measured_json({v.params[i], std::sqrt(v.covariance[i * names.size() + i])});
  }
  j["parameters"] = params;
  j["formula"] =
      "eta/eta_0 = amplitude_1 (phi_J - phi)^-exponent_1 + amplitude_2 (phi_J - phi)^-exponent_2";
  j["amplitude_1"] = measured_json(v.amplitude_1);
  // The exponents' "error" is statistical; "systematic" is the parameters' systematic errors
  // propagated (analysis/hard_sphere.hpp ViscosityLaw).
  j["exponent_1"] = measured_json(v.exponent_1);
  j["exponent_1"]["systematic"] = v.exponent_1_systematic;
  j["amplitude_2"] = measured_json(v.amplitude_2);
  j["exponent_2"] = measured_json(v.exponent_2);
  j["exponent_2"]["systematic"] = v.exponent_2_systematic;
  j["crossover_delta_phi"] = measured_json(v.crossover_delta_phi);
  j["window"] = Json(std::vector<double>{v.window_min, v.window_max});
  j["effective_exponent"] = measured_json(v.effective_exponent);
  j["effective_exponent"]["systematic"] = v.effective_exponent_systematic;
  j["local_exponent_at_phimin"] = measured_json(v.local_exponent_at_min);
  j["local_exponent_at_phimax"] = measured_json(v.local_exponent_at_max);
  // The seed's trade-off (Sec. IV C): an effective exponent anywhere between the subleading
  // (1 - b_mu)/b_phi and the asymptotic 1/b_phi.
  j["beta_interval"] = Json(std::vector<double>{v.exponent_2.value, v.exponent_1.value});
  return j;
}

}  // namespace

Json hard_sphere_json(const HardSphereResult& r, const HardSphereOptions& o,
                      const std::vector<std::string>& inputs) {
  Json j = Json::object();
  j["analysis"] = "hard-sphere";
  j["inputs"] = strings_json(inputs);
  j["point_errors"] = point_errors_json(r.point_errors);
  Json opts = Json::object();
  opts["envelope_z"] = o.envelope.z;
  opts["min_sizes_for_extrapolation"] = static_cast<std::int64_t>(o.min_sizes_for_extrapolation);
  opts["resolved_amplitude_sigma"] = o.resolved_amplitude_sigma;
  opts["scale_errors"] = o.scale_errors;
  opts["dimension"] = o.dimension;
  j["options"] = opts;
  Json sizes = Json::object();
  for (const auto& s : r.sizes) {
    Json js = Json::object();
    for (const auto& name : hard_sphere_parameters()) {
      Json m = measured_json(size_param(s, name));
      const ErrorModel& em =
          name == "phi_J" || name == "b_phi" || name == "C_phi" ? s.phi_errors : s.mu_errors;
      for (const auto& p : em.parameters) {
        if (p.name == name)
          m["systematic"] = number_or_null(p.systematic());
      }
      js[name] = m;
    }
    js["errors_phi"] = error_model_json(s.phi_errors);
    js["errors_mu"] = error_model_json(s.mu_errors);
    js["degenerate"] = s.phi_errors.degenerate || s.mu_errors.degenerate;
    {
      // The viscosity eta/eta_0 = mu/J the envelope points reach (Fig. 7), over which J, and how
      // many decades the seed's Table 2 law at this N spans over the same J: the measure of the
      // range that does not depend on how far the seed's own runs went.
      double lo = 0.0, hi = 0.0, j_lo = 0.0, j_hi = 0.0;
      for (const auto& e : s.points) {
        const double eta = e.point.mu / e.point.j;
        if (!in_envelope(e.status) || !(eta > 0.0) || !std::isfinite(eta))
          continue;
        lo = lo > 0.0 ? std::min(lo, eta) : eta;
        hi = std::max(hi, eta);
        j_lo = j_lo > 0.0 ? std::min(j_lo, e.point.j) : e.point.j;
        j_hi = std::max(j_hi, e.point.j);
      }
      if (hi > 0.0) {
        Json je = Json::object();
        je["min"] = lo;
        je["max"] = hi;
        je["decades"] = std::log10(hi / lo);
        je["J_min"] = j_lo;
        je["J_max"] = j_hi;
        je["seed_decades"] = std::log10(seed::hard_sphere_viscosity(j_lo, double(s.n)) /
                                        seed::hard_sphere_viscosity(j_hi, double(s.n)));
        js["envelope_eta"] = je;
      }
    }
    js["points_used"] = static_cast<std::int64_t>(s.points_used);
    js["points_total"] = static_cast<std::int64_t>(s.points.size());
    js["J_range"] = Json(std::vector<double>{s.j_min, s.j_max});
    js["fit_phi"] = fit_summary(s.phi);
    js["fit_mu"] = fit_summary(s.mu);
    js["fitted"] = true;
    js["envelope"] = envelope_counts_json(s.points);
    sizes[std::to_string(s.n)] = js;
  }
  for (const auto& u : r.unfitted) {
    Json js = Json::object();
    js["fitted"] = false;
    js["reason"] = u.reason;
    std::int64_t in = 0;
    for (const auto& e : u.points)
      in += in_envelope(e.status) ? 1 : 0;
    js["points_used"] = in;
    js["points_total"] = static_cast<std::int64_t>(u.points.size());
    js["envelope"] = envelope_counts_json(u.points);
    sizes[std::to_string(u.n)] = js;
  }
  j["sizes"] = sizes;
  Json collapse = Json::object();
  for (const FiniteSizeCollapse* c : {&r.collapse_phi, &r.collapse_mu}) {
    Json jc = Json::object();
    if (!c->unavailable.empty()) {
      jc["unavailable"] = c->unavailable;
    } else {
      jc["quality"] = quality_json(c->quality);
      jc["scaling"] = Json(std::vector<double>{c->inf, c->a, c->alpha, c->b});
      jc["scaling_names"] = strings_json({"O_inf", "A_O", "alpha_O", "b"});
    }
    collapse[c->parameter] = jc;
  }
  collapse["measure"] =
      "Houdayer-Hartmann S of y = (O - O_inf)/(A_O N^-alpha_O) against x = J N^(alpha_O/b), "
      "sizes as curves; S ~ 1: collapse within the errors";
  j["finite_size_collapse"] = collapse;
  Json ex = Json::object();
  if (!r.extrapolation_skipped.empty()) {
    ex["skipped"] = r.extrapolation_skipped;
  }
  for (const auto& e : r.extrapolations) {
    Json je = Json::object();
    switch (e.status) {
      case Extrapolation::Status::kFit:
        je["status"] = "fit";
        je["inf"] = measured_json(e.fit->at(0));
        je["A"] = measured_json(e.fit->at(1));
        je["alpha"] = measured_json(e.fit->at(2));
        je["fit"] = fit_summary(*e.fit);
        je["reduced_chi2"] = e.fit->reduced_chi2();
        break;
      case Extrapolation::Status::kExponentUnbounded: {
        je["status"] = "alpha_unbounded";
        je["inf"] = measured_json(e.inf);
        Json alpha = Json::object();
        alpha["lower_bound"] = e.alpha_lower_bound;
        je["alpha"] = alpha;
        je["chi2"] = e.chi2;
        je["dof"] = e.dof;
        je["note"] = e.message;
        break;
      }
      case Extrapolation::Status::kConstant:
        je["status"] = "constant";
        je["inf"] = measured_json(e.inf);
        je["chi2"] = e.chi2;
        je["dof"] = e.dof;
        je["note"] = e.message;
        break;
      case Extrapolation::Status::kNotResolved:
        je["status"] = "not_resolved";
        je["note"] = e.message;
        break;
      case Extrapolation::Status::kFailed:
        je["status"] = "failed";
        je["failed"] = e.message;
        break;
    }
    if (je.contains("inf"))
      je["inf"]["systematic"] = number_or_null(e.systematic);
    je["resolved"] = e.resolved;
    je["resolution"] = e.resolution;
    if (const auto u = unit_free_reading(e)) {
      // Readings that do not depend on the unit of N (analysis/README.md). They decide nothing.
      Json ju = Json::object();
      ju["chi2_constant"] = e.chi2_constant;
      ju["dof_constant"] = e.dof_constant;
      ju["chi2_power_law"] = e.chi2_power_law;
      ju["delta_chi2"] = u->delta_chi2;
      ju["p_constant"] = u->p_constant;
      if (std::isfinite(u->alpha_relative_error))
        ju["alpha_relative_error"] = u->alpha_relative_error;
      ju["note"] =
          "likelihood ratio of O_inf + A_O N^-alpha_O (alpha_O profiled) against a constant: "
          "delta_chi2 on unscaled errors, p_constant from chi2 with 2 dof (approximate: alpha_O "
          "is not defined under a constant); alpha_relative_error from the fit's (scaled) "
          "covariance. Neither depends on the unit of N; the resolution rule does not use them";
      je["unit_free"] = ju;
    }
    if (e.sensitivity) {
      const SizeSensitivity& sv = *e.sensitivity;
      Json js = Json::object();
      js["law"] = "seed Table 2";
      js["A"] = sv.a;
      js["alpha"] = sv.alpha;
      js["sigma_A"] = number_or_null(sv.sigma_a);
      js["sigma_alpha"] = number_or_null(sv.sigma_alpha);
      js["A_over_sigma"] = number_or_null(sv.z);
      js["chance_resolved"] = number_or_null(sv.power);
      js["error_scale_for_target"] = number_or_null(sv.error_scale);
      js["target_chance"] = SizeSensitivity::kTargetPower;
      js["threshold_sigma"] = o.resolved_amplitude_sigma;
      js["note"] =
          "Fisher (linearized) errors of A and alpha were the sizes to follow the law exactly, "
          "with the errors the fit used; chance of |A| > threshold sigma in the normal "
          "approximation; error_scale_for_target: the factor on every size's error that gives "
          "that chance target_chance (replicas: its inverse square)";
      je["sensitivity"] = js;
    }
    ex[e.parameter] = je;
  }
  j["extrapolated"] = ex;
  Json nu = Json::object();
  if (r.nu_phi) {
    nu["from_phi"] = measured_json(*r.nu_phi);
    nu["from_phi"]["systematic"] = number_or_null(r.nu_phi_systematic);
  }
  if (r.nu_mu) {
    nu["from_mu"] = measured_json(*r.nu_mu);
    nu["from_mu"]["systematic"] = number_or_null(r.nu_mu_systematic);
  }
  nu["dimension"] = o.dimension;
  nu["formula"] = "nu = b_inf / (alpha_O d), O = phi_J (from_phi) or mu_J (from_mu)";
  j["nu"] = nu;
  if (r.viscosity)
    j["viscosity"] = viscosity_json(*r.viscosity);
  j["warnings"] = strings_json(r.warnings);
  j["failures"] = strings_json(r.failures);
  return j;
}

namespace {

// What these sizes could resolve, were the parameters to follow the seed's Table 2 laws.
std::string sensitivity_markdown(const HardSphereResult& r, const HardSphereOptions& o) {
  std::ostringstream md;
  bool any = false;
  for (const auto& e : r.extrapolations)
    any = any || (e.sensitivity && std::isfinite(e.sensitivity->sigma_a));
  if (!any)
    return {};
  md << "What these sizes could resolve: were each parameter to follow Table 2's law exactly, "
        "at these sizes with the errors the fits used (Fisher errors; chance in the normal "
        "approximation):\n\n";
  md << "| O | paper A_O | sigma_A | A_O/sigma_A | chance A_O resolved (> "
     << fmt(o.resolved_amplitude_sigma) << " sigma) | errors x for "
     << fmt(SizeSensitivity::kTargetPower) << " | sigma_alpha (paper alpha_O) |\n";
  md << "|---|---|---|---|---|---|---|\n";
  for (const auto& e : r.extrapolations) {
    if (!e.sensitivity || !std::isfinite(e.sensitivity->sigma_a))
      continue;
    const SizeSensitivity& s = *e.sensitivity;
    md << "| " << e.parameter << " | " << fmt(s.a) << " | " << fmt(s.sigma_a, "%.2g") << " | "
       << fmt(s.z, "%.2g") << " | " << fmt(s.power, "%.2f") << " | " << fmt(s.error_scale, "%.2g")
       << " | " << fmt(s.sigma_alpha, "%.2g") << " (" << fmt(s.alpha) << ") |\n";
  }
  md << "\n";
  return md.str();
}

// The readings that do not depend on the unit of N (JSON `unit_free`); they decide nothing.
std::string unit_free_markdown(const std::vector<Extrapolation>& extrapolations) {
  std::ostringstream md;
  bool any = false;
  for (const auto& e : extrapolations) {
    const auto u = unit_free_reading(e);
    if (!u)
      continue;
    if (!any)
      md << "Unit-free readings (the rule's z of A depends on the unit of N; these do not, and "
            "decide nothing): the power law against a constant, delta chi2 (unscaled errors) "
            "and its approximate chi2(2) p, and sigma_alpha / alpha:\n\n"
            "| O | delta chi2 | p (constant) | sigma_alpha / alpha |\n|---|---|---|---|\n";
    any = true;
    md << "| " << e.parameter << " | " << fmt(u->delta_chi2, "%.3g") << " | "
       << fmt(u->p_constant, "%.2g") << " | "
       << (std::isfinite(u->alpha_relative_error) ? fmt(u->alpha_relative_error, "%.2g") : "-")
       << " |\n";
  }
  if (any)
    md << "\n";
  return md.str();
}

}  // namespace

std::string hard_sphere_markdown(const HardSphereResult& r, const HardSphereOptions& o,
                                 const std::vector<std::string>& inputs) {
  std::ostringstream md;
  md << "# Granular rheology: hard-sphere and large-N limits\n\n";
  inputs_md(md, inputs);
  md << describe(r.point_errors) << "\n\n";
  md << "Hard-sphere envelope: a point is kept when its phi and mu agree within "
     << fmt(o.envelope.z)
     << " sigma with the next lower pressure at the same J (or, where no lower pressure "
        "reaches that J, with the next higher one); the first disagreement with a lower "
        "pressure ends that pressure's envelope. Errors are 1 sigma from the fit covariance"
     << (o.scale_errors ? ", scaled by sqrt(chi2/dof) where chi2/dof > 1"
                        : " (not scaled by chi2/dof)")
     << "; the second number of each parameter is its systematic error (J window and fit form "
        "in quadrature, JSON `errors_phi`, `errors_mu`).\n\n";
  md << "## Per-size fits: phi = phi_J - C_phi J^b_phi, mu = mu_J + C_mu J^b_mu\n\n";
  md << "| N | points | J range | phi_J | b_phi | C_phi | mu_J | b_mu | C_mu | chi2/dof phi | "
        "chi2/dof mu |\n";
  md << "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& s : r.sizes) {
    md << "| " << s.n << " | " << s.points_used << "/" << s.points.size() << " | "
       << fmt(s.j_min, "%.2g") << "–" << fmt(s.j_max, "%.2g");
    for (const auto& name : hard_sphere_parameters()) {
      const ErrorModel& em =
          name == "phi_J" || name == "b_phi" || name == "C_phi" ? s.phi_errors : s.mu_errors;
      const double sys = em[name].systematic();
      md << " | " << format_measured(size_param(s, name)) << " ± "
         << (std::isfinite(sys) ? fmt(sys, "%.2g") : std::string("n/a")) << " (sys)";
    }
    md << " | " << fmt(s.phi.reduced_chi2(), "%.2f") << (s.phi.errors_scaled ? " (scaled)" : "")
       << " | " << fmt(s.mu.reduced_chi2(), "%.2f") << (s.mu.errors_scaled ? " (scaled)" : "")
       << " |\n";
  }
  for (const auto& s : r.sizes) {
    for (const ErrorModel* em : {&s.phi_errors, &s.mu_errors}) {
      if (em->degenerate)
        md << "\nN = " << s.n
           << ": degenerate fit, not compared with the paper: " << em->degenerate_reason << ".\n";
    }
  }
  for (const auto& u : r.unfitted) {
    md << "| " << u.n << " | not fitted | | | | | | | | | |\n";
  }
  for (const auto& u : r.unfitted) {
    md << "\nN = " << u.n << " is not fitted: " << u.reason << ".\n";
  }
  md << "\n## Large-N extrapolation O(N) = O_inf + A_O N^-alpha_O, compared with Table 2\n\n";
  if (!r.extrapolation_skipped.empty()) {
    md << "Skipped: " << r.extrapolation_skipped << ".\n\n";
  } else {
    md << "| O | O_inf | paper | pull | A_O | paper | alpha_O | paper | chi2/dof |\n";
    md << "|---|---|---|---|---|---|---|---|---|\n";
    for (const auto& e : r.extrapolations) {
      const auto& t = seed::table2(e.parameter);
      if (e.status == Extrapolation::Status::kFailed ||
          e.status == Extrapolation::Status::kNotResolved) {
        md << "| " << e.parameter << " | "
           << (e.status == Extrapolation::Status::kFailed ? "failed" : "not resolved") << " | "
           << fmt(t.inf) << " | | | " << fmt(t.a) << " | | " << fmt(t.alpha) << " | |\n";
        continue;
      }
      // Only a resolved extrapolation is an N -> infinity value to compare in sigma, with its
      // statistical and systematic errors in quadrature.
      const bool has_sys = std::isfinite(e.systematic);
      md << "| " << e.parameter << " | " << format_measured(e.inf)
         << (has_sys ? " ± " + fmt(e.systematic, "%.2g") + " (sys)" : std::string()) << " | "
         << fmt(t.inf) << " | "
         << (e.resolved ? pull_md(e.inf.value,
                                  std::hypot(e.inf.error, has_sys ? e.systematic : 0.0), t.inf)
                        : std::string("not resolved"))
         << " | ";
      if (e.status == Extrapolation::Status::kFit) {
        md << format_measured(e.fit->at(1)) << " | " << fmt(t.a) << " | "
           << format_measured(e.fit->at(2)) << " | " << fmt(t.alpha) << " | "
           << fmt(e.fit->reduced_chi2(), "%.2f") << " |\n";
      } else if (e.status == Extrapolation::Status::kConstant) {
        md << "no significant N-dependence | " << fmt(t.a) << " | | " << fmt(t.alpha) << " | "
           << fmt(e.chi2 / std::max(e.dof, 1), "%.2f") << " |\n";
      } else {
        md << "not resolved | " << fmt(t.a) << " | > " << fmt(e.alpha_lower_bound, "%.3g") << " | "
           << fmt(t.alpha) << " | " << fmt(e.chi2 / std::max(e.dof, 1), "%.2f") << " |\n";
      }
    }
    md << "\n(O_inf's systematic error (sys) is the largest of the sizes' (J window and fit "
          "form): the same choices at every size shift them alike, and O_inf by as much. pull = "
          "(ours - paper)/our error, statistical and systematic in quadrature, only for a resolved "
          "extrapolation: a power-law fit whose A_O differs from 0 by more than "
       << fmt(o.resolved_amplitude_sigma)
       << " sigma. A_O 'not resolved': chi2 keeps decreasing as "
          "alpha grows, only the smallest size deviates; O_inf then has a profile-likelihood "
          "error and alpha only a lower bound. 'no significant N-dependence': a constant fits; "
          "O_inf is the weighted mean. O_inf 'not resolved': no convergence with N, O_inf "
          "undetermined.)\n\n";
    md << sensitivity_markdown(r, o);
    md << unit_free_markdown(r.extrapolations);
  }
  md << "## Correlation-length exponent nu = b / (alpha_O d), d = " << o.dimension << "\n\n";
  md << "| from | nu | paper |\n|---|---|---|\n";
  const auto nu_md = [](const std::optional<Measured>& nu, double sys) {
    if (!nu)
      return std::string("n/a");
    return format_measured(*nu) +
           (std::isfinite(sys) ? " ± " + fmt(sys, "%.2g") + " (sys)" : std::string());
  };
  md << "| phi | " << nu_md(r.nu_phi, r.nu_phi_systematic) << " | " << fmt(seed::kNuPhi) << " |\n";
  md << "| mu | " << nu_md(r.nu_mu, r.nu_mu_systematic) << " | " << fmt(seed::kNuMu)
     << " |\n\n(systematic: that of b_inf; a shift common to every size leaves alpha_O.)\n\n";
  md << "## Finite-size collapse (Fig. 6)\n\n";
  md << "y = (O(J, N) - O_inf) / (A_O N^-alpha_O) against x = J N^(alpha_O/b), from the "
        "N -> infinity fits above. Quality: Houdayer-Hartmann S over the sizes as curves "
        "(S ~ 1: the sizes collapse within their errors; acceptable: S <= 1 + 3 sqrt(2/N_used))."
        "\n\n";
  md << "| O | S (points used/total) | acceptable |\n|---|---|---|\n";
  for (const FiniteSizeCollapse* c : {&r.collapse_phi, &r.collapse_mu}) {
    if (!c->unavailable.empty())
      md << "| " << c->parameter << " | not computed: " << c->unavailable << " | |\n";
    else
      md << "| " << c->parameter << " | " << quality_md(c->quality) << " | "
         << (c->quality.acceptable() ? "yes" : "no") << " |\n";
  }
  md << "\n";
  if (r.viscosity) {
    const auto& v = *r.viscosity;
    md << "## Viscosity law eta(phi) (" << v.source << ")\n\n";
    md << "eta/eta_0 = a1 (phi_J - phi)^-e1 + a2 (phi_J - phi)^-e2\n\n";
    md << "| quantity | value | paper |\n|---|---|---|\n";
    md << "| a1 = mu_J C_phi^(1/b_phi) | " << format_measured(v.amplitude_1) << " | |\n";
    // (The exponents' second number is their systematic error.)
    auto with_sys = [](const Measured& m, double sys) {
      return format_measured(m) + " ± " + fmt(sys) + " (systematic)";
    };
    md << "| e1 = 1/b_phi (asymptotic) | " << with_sys(v.exponent_1, v.exponent_1_systematic)
       << " | " << fmt(seed::kViscosityExponentHigh) << " |\n";
    md << "| a2 = C_mu C_phi^((1-b_mu)/b_phi) | " << format_measured(v.amplitude_2) << " | |\n";
    md << "| e2 = (1-b_mu)/b_phi | " << with_sys(v.exponent_2, v.exponent_2_systematic) << " | "
       << fmt(seed::kViscosityExponentLow) << " |\n";
    md << "| crossover phi_J - phi | " << format_measured(v.crossover_delta_phi)
       << " | about 0.02 |\n";
    md << "| effective exponent over phi in [" << fmt(v.window_min) << ", " << fmt(v.window_max)
       << "] | " << with_sys(v.effective_exponent, v.effective_exponent_systematic) << " | in ["
       << fmt(seed::kViscosityExponentLow) << ", " << fmt(seed::kViscosityExponentHigh) << "] |\n";
    md << "| local exponent at phi = " << fmt(v.window_min) << " | "
       << format_measured(v.local_exponent_at_min) << " | |\n";
    md << "| local exponent at phi = " << fmt(v.window_max) << " | "
       << format_measured(v.local_exponent_at_max) << " | |\n\n";
  }
  notes_md(md, r.warnings, r.failures);
  return md.str();
}

namespace {

// One size's points for the plots: P, J, phi, mu with errors, and envelope statuses.
void envelope_points_json(Json& js, const std::vector<EnvelopePoint>& points) {
  std::vector<double> p, jj, phi, phi_err, mu, mu_err;
  Json status = Json::array();
  for (const auto& e : points) {
    p.push_back(e.point.pressure);
    jj.push_back(e.point.j);
    phi.push_back(e.point.phi);
    phi_err.push_back(e.point.phi_err);
    mu.push_back(e.point.mu);
    mu_err.push_back(e.point.mu_err);
    status.push_back(to_string(e.status));
  }
  js["imposed_pressure"] = Json(p);
  js["J"] = Json(jj);
  js["phi"] = Json(phi);
  js["phi_err"] = Json(phi_err);
  js["mu"] = Json(mu);
  js["mu_err"] = Json(mu_err);
  js["status"] = status;
}

}  // namespace

Json hard_sphere_plot_data(const HardSphereResult& r) {
  Json j = Json::object();
  Json sizes = Json::array();
  for (const auto& s : r.sizes) {
    Json js = Json::object();
    js["N"] = static_cast<std::int64_t>(s.n);
    envelope_points_json(js, s.points);
    Json params = Json::object();
    for (const auto& name : hard_sphere_parameters()) {
      Measured m = size_param(s, name);
      params[name] = Json(std::vector<double>{m.value, m.error});
    }
    js["params"] = params;
    js["J_range"] = Json(std::vector<double>{s.j_min, s.j_max});
    sizes.push_back(js);
  }
  j["sizes"] = sizes;
  Json unfitted = Json::array();
  for (const auto& u : r.unfitted) {
    Json js = Json::object();
    js["N"] = static_cast<std::int64_t>(u.n);
    envelope_points_json(js, u.points);
    unfitted.push_back(js);
  }
  j["unfitted"] = unfitted;
  Json collapse = Json::object();
  for (const FiniteSizeCollapse* c : {&r.collapse_phi, &r.collapse_mu}) {
    if (!c->unavailable.empty())
      continue;
    Json jc = Json::object();
    std::vector<double> x, y, dy, n;
    for (const auto& q : c->scaled) {
      x.push_back(q.x);
      y.push_back(q.y);
      dy.push_back(q.dy);
      n.push_back(static_cast<double>(r.sizes[q.curve].n));
    }
    jc["x"] = Json(x);
    jc["y"] = Json(y);
    jc["dy"] = Json(dy);
    jc["N"] = Json(n);
    jc["S"] = Json(std::vector<double>{c->quality.s, c->quality.error()});
    collapse[c->parameter] = jc;
  }
  j["collapse"] = collapse;
  Json ex = Json::object();
  for (const auto& e : r.extrapolations) {
    if (e.status == Extrapolation::Status::kFit) {
      ex[e.parameter] = Json(e.fit->params);  // inf, A, alpha
    } else if (e.status == Extrapolation::Status::kExponentUnbounded ||
               e.status == Extrapolation::Status::kConstant) {
      ex[e.parameter] = Json(std::vector<double>{e.inf.value});  // inf only
    }
  }
  j["extrapolated"] = ex;
  // Which of them are N -> infinity results (hard_sphere.cpp: a fit whose A_O differs from 0
  // by more than the rule's sigmas); the plots say so rather than draw an unresolved fit as one.
  Json resolved = Json::object();
  for (const auto& e : r.extrapolations)
    resolved[e.parameter] = e.resolved;
  j["extrapolation_resolved"] = resolved;
  Json table = Json::object();
  for (const auto& name : hard_sphere_parameters()) {
    const auto& t = seed::table2(name);
    table[name] = Json(std::vector<double>{t.inf, t.a, t.alpha});
  }
  j["table2"] = table;
  if (r.viscosity) {
    Json v = Json::object();
    v["source"] = r.viscosity->source;
    v["params"] = Json(r.viscosity->params);
    v["window"] = Json(std::vector<double>{r.viscosity->window_min, r.viscosity->window_max});
    j["viscosity"] = v;
  }
  return j;
}

// --- soft ----------------------------------------------------------------------

namespace {

// The paper's values for the joint law: x, y (Sec. V A), and the hard-sphere parameters from
// Table 2's size law at the fit's N, the same values the soft-rheology study's report uses
// (NaN: the paper gives no number).
double paper_joint(std::size_t k, std::int64_t n) {
  switch (k) {
    case 2:
      return seed::kX;
    case 7:
      return seed::kY;
    case 1:
    case 6:
      return std::nan("");
    default: {
      static const char* const hs[10] = {"phi_J", "", "", "C_phi", "b_phi",
                                         "mu_J",  "", "", "C_mu",  "b_mu"};
      return seed::table2(hs[k]).at(static_cast<double>(n));
    }
  }
}

double quadrature_systematic(const JointSoftFit& f, std::size_t k) {
  double s2 = 0.0;
  for (double s : {f.pressure_window[k], f.j_window[k], f.form[k]})
    s2 += std::isfinite(s) ? s * s : 0.0;
  return std::sqrt(s2);
}

}  // namespace

Json joint_soft_json(const JointSoftFit& f, const YieldComparison* yield) {
  Json j = Json::object();
  j["formula"] =
      "phi = phi_J0 + c_phi P^x - C_phi J^b_phi, mu = mu_J0 - c_mu P^y + C_mu J^b_mu, fitted "
      "over every pressure and J at once";
  for (std::size_t k = 0; k < 10; ++k) {
    Json m = measured_json(f.params[k]);
    m["pressure_window"] = number_or_null(f.pressure_window[k]);
    m["J_window"] = number_or_null(f.j_window[k]);
    m["fit_form"] = number_or_null(f.form[k]);
    m["systematic"] = quadrature_systematic(f, k);
    const double ref = paper_joint(k, f.n);
    if (std::isfinite(ref)) {
      m["paper"] = ref;
      m["paper_source"] =
          k == 2 || k == 7 ? "Sec. V A" : "Table 2 size law at N = " + std::to_string(f.n);
    }
    j[SoftLaw::names()[k]] = m;
  }
  {
    Json refits = Json::array();
    for (const auto& r : f.window_refits) {
      Json jr = Json::object();
      jr["label"] = r.label;
      for (std::size_t k = 0; k < 10; ++k)
        jr[SoftLaw::names()[k]] = r.params[k];
      refits.push_back(jr);
    }
    j["window_refits"] = refits;
    j["window_notes"] = strings_json(f.window_notes);
    j["systematics_meaning"] =
        "pressure_window (J_window): the largest shift of the parameter when the points at the "
        "largest or at the smallest pressure (J) are dropped and the law refitted; fit_form: the "
        "shift when C_phi, b_phi, C_mu and b_mu are fixed at the paper's Table 2 law at this N "
        "and the rest refitted; systematic: all three in quadrature";
    Json fr = Json::object();
    for (std::size_t k = 0; k < 10; ++k)
      fr[SoftLaw::names()[k]] = number_or_null(f.form_refit[k]);
    j["form_refit"] = fr;
    j["form_notes"] = strings_json(f.form_notes);
  }
  {
    auto local_json = [](const std::vector<JointSoftFit::LocalExponent>& local) {
      Json a = Json::array();
      for (const auto& e : local) {
        Json je = Json::object();
        je["value"] = number_or_null(e.exponent.value);
        je["error"] = number_or_null(e.exponent.error);
        je["P_min"] = e.p_min;
        je["P_max"] = e.p_max;
        je["points"] = static_cast<std::int64_t>(e.points);
        je["offset_shift"] = number_or_null(e.offset_shift);
        je["total_error"] = number_or_null(e.total_error());
        a.push_back(je);
      }
      return a;
    };
    auto drift_json = [](const ExponentDrift& d) {
      Json jd = Json::object();
      jd["defined"] = d.defined;
      if (d.defined) {
        jd["lowest_window"] = number_or_null(d.low);
        jd["lowest_window_error"] = number_or_null(d.low_err);
        jd["highest_window"] = number_or_null(d.high);
        jd["highest_window_error"] = number_or_null(d.high_err);
        jd["difference_sigma"] = number_or_null(d.sigma);
        jd["lowest_window_minus_1_sigma"] = number_or_null(d.from_one_sigma);
        jd["resolved"] = d.resolved;
      }
      return jd;
    };
    Json lj = Json::object();
    lj["x"] = local_json(f.local_x);
    lj["y"] = local_json(f.local_y);
    lj["drift_x"] = drift_json(exponent_drift(f.local_x));
    lj["drift_y"] = drift_json(exponent_drift(f.local_y));
    lj["notes"] = strings_json(f.local_notes);
    lj["meaning"] =
        "the exponent fitted over three adjacent pressures at a time, with phi_J0 (mu_J0) and "
        "the J-shape held at the joint optimum; error: statistical (scaled by sqrt(chi2/dof) "
        "above 1) and offset_shift (the change when phi_J0 or mu_J0 moves by its error) in "
        "quadrature; drift: lowest against highest window, resolved beyond 2 sigma";
    j["local_exponents"] = lj;
  }
  {
    // alpha = 1/x: each systematic of x propagated, |d alpha / d x| = 1/x^2.
    Json a = measured_json(f.alpha);
    const double d = 1.0 / (f.law.x * f.law.x);
    a["pressure_window"] = number_or_null(d * f.pressure_window[2]);
    a["J_window"] = number_or_null(d * f.j_window[2]);
    a["fit_form"] = number_or_null(d * f.form[2]);
    a["systematic"] = d * quadrature_systematic(f, 2);
    a["paper"] = seed::kYieldExponent;
    a["paper_source"] = "Sec. V A";
    j["alpha"] = a;
  }
  {
    // The bootstrap draws each point with its error times sqrt(max(1, chi2/dof)) of its half.
    Json sc = Json::object();
    sc["reduced_chi2_phi"] = f.phi_fit.reduced_chi2();
    sc["reduced_chi2_mu"] = f.mu_fit.reduced_chi2();
    sc["errors_scaled_phi"] = f.noise_scale_phi > 1.0;
    sc["errors_scaled_mu"] = f.noise_scale_mu > 1.0;
    j["error_scaling"] = sc;
  }
  j["fit_phi"] = fit_summary(f.phi_fit);
  j["fit_mu"] = fit_summary(f.mu_fit);
  Json b = Json::object();
  b["requested"] = f.bootstrap_requested;
  b["used"] = static_cast<std::int64_t>(f.samples.size());
  b["noise_scale_phi"] = f.noise_scale_phi;
  b["noise_scale_mu"] = f.noise_scale_mu;
  j["bootstrap"] = b;
  j["points"] = static_cast<std::int64_t>(f.points);
  j["pressures"] = Json(f.pressures);
  j["resolution_notes"] = strings_json(f.resolution_notes);
  if (yield) {
    Json y = Json::object();
    std::vector<double> phi, gdot, sig, sige, law, lawe, sy, sye, pull;
    for (const auto& p : yield->points) {
      phi.push_back(p.phi);
      gdot.push_back(p.gdot);
      sig.push_back(p.sigma.value);
      sige.push_back(p.sigma.error);
      law.push_back(p.sigma_law.value);
      lawe.push_back(p.sigma_law.error);
      sy.push_back(p.sigma_yield.value);
      sye.push_back(p.sigma_yield.error);
      pull.push_back(p.pull);
    }
    y["phi"] = Json(phi);
    y["shear_rate"] = Json(gdot);
    y["sigma_xy"] = Json(sig);
    y["sigma_xy_err"] = Json(sige);
    y["sigma_law"] = Json(law);
    y["sigma_law_err"] = Json(lawe);
    y["sigma_yield"] = Json(sy);
    y["sigma_yield_err"] = Json(sye);
    y["pull"] = Json(pull);
    y["points_at_or_below_phi_J0"] = static_cast<std::int64_t>(yield->below);
    y["mean_square_pull"] = yield->mean_square_pull;
    j["yield_data"] = y;
  }
  return j;
}

std::string joint_soft_markdown(const JointSoftFit& f, const YieldComparison* yield) {
  std::ostringstream md;
  md << "Joint fit over " << f.points << " points at " << f.pressures.size()
     << " pressures: phi = phi_J0 + c_phi P^x - C_phi J^b_phi, mu = mu_J0 - c_mu P^y + C_mu "
        "J^b_mu. Errors: standard deviation over "
     << f.samples.size() << " of " << f.bootstrap_requested
     << " parametric-bootstrap resamples (noise scaled by sqrt(max(1, chi2/dof)) = "
     << fmt(f.noise_scale_phi, "%.2f") << " for phi, " << fmt(f.noise_scale_mu, "%.2f")
     << " for mu). chi2/dof: phi " << fmt(f.phi_fit.reduced_chi2(), "%.2f") << " (" << f.phi_fit.dof
     << " dof), mu " << fmt(f.mu_fit.reduced_chi2(), "%.2f") << ".\n\n";
  md << "| parameter | joint fit (statistical) | pressure window | J window | fit form | paper | "
        "difference (sigma, statistical) | difference (sigma, statistical and systematic) |\n"
        "|---|---|---|---|---|---|---|---|\n";
  auto sys_md = [](double s) { return std::isfinite(s) ? fmt(s, "%.2g") : std::string("-"); };
  for (std::size_t k = 0; k < 10; ++k) {
    const double ref = paper_joint(k, f.n);
    const double total = std::hypot(f.params[k].error, quadrature_systematic(f, k));
    md << "| " << SoftLaw::names()[k] << " | " << format_measured(f.params[k]) << " | "
       << sys_md(f.pressure_window[k]) << " | " << sys_md(f.j_window[k]) << " | "
       << sys_md(f.form[k]) << " | " << (std::isfinite(ref) ? fmt(ref) : "-") << " | "
       << (std::isfinite(ref) ? pull_md(f.params[k].value, f.params[k].error, ref) : "") << " | "
       << (std::isfinite(ref) ? pull_md(f.params[k].value, total, ref) : "") << " |\n";
  }
  {
    const double d = 1.0 / (f.law.x * f.law.x);
    const double total = std::hypot(f.alpha.error, d * quadrature_systematic(f, 2));
    md << "| alpha = 1/x (yield stress) | " << format_measured(f.alpha) << " | "
       << sys_md(d * f.pressure_window[2]) << " | " << sys_md(d * f.j_window[2]) << " | "
       << sys_md(d * f.form[2]) << " | " << fmt(seed::kYieldExponent) << " | "
       << pull_md(f.alpha.value, f.alpha.error, seed::kYieldExponent) << " | "
       << pull_md(f.alpha.value, total, seed::kYieldExponent) << " |\n\n";
  }
  md << "Paper values: x and y from Sec. V A; phi_J0, C_phi, b_phi, mu_J0, C_mu, b_mu from Table "
        "2's size law at N = "
     << f.n
     << " (the data's N, not N -> infinity). Systematics: the largest shift when the points at "
        "the largest or smallest P (J) are dropped and the law refitted; fit form: the shift "
        "when the J-shape (C_phi, b_phi, C_mu, b_mu) is fixed at the paper's values at this N "
        "and the rest refitted.\n\n";
  for (const auto& n : f.form_notes)
    md << "- " << n << "\n";
  auto local_md = [&](const char* name, const std::vector<JointSoftFit::LocalExponent>& local) {
    if (local.empty())
      return;
    md << "Local " << name << " over successive windows of three adjacent pressures (offset and "
       << "J-shape held at the joint optimum; error: statistical and the offset's error in "
          "quadrature):\n\n| P window | points | local "
       << name << " |\n|---|---|---|\n";
    for (const auto& e : local)
      md << "| " << fmt(e.p_min, "%.3g") << " - " << fmt(e.p_max, "%.3g") << " | " << e.points
         << " | " << format_measured({e.exponent.value, e.total_error()}) << " |\n";
    md << "\n";
  };
  local_md("x", f.local_x);
  local_md("y", f.local_y);
  for (const auto& n : f.local_notes)
    md << "- " << n << "\n";
  if (!f.window_refits.empty()) {
    md << "| refit | x | y | phi_J0 | mu_J0 |\n|---|---|---|---|---|\n";
    for (const auto& r : f.window_refits)
      md << "| " << r.label << " | " << fmt(r.params[2], "%.4g") << " | "
         << fmt(r.params[7], "%.4g") << " | " << fmt(r.params[0], "%.5g") << " | "
         << fmt(r.params[5], "%.4g") << " |\n";
    md << "\n";
  }
  for (const auto& n : f.window_notes)
    md << "- " << n << "\n";
  for (const auto& n : f.resolution_notes)
    md << "- " << n << "\n";
  if (!f.resolution_notes.empty())
    md << "\n";
  if (yield) {
    md << "Yield stress: " << yield->points.size()
       << " constant-volume points above phi_J0 against the law at the same (phi, gdot), and "
          "the law's sigma_Y(phi) (gdot -> 0); "
       << yield->below << " points at or below phi_J0 not compared. Mean squared pull "
       << fmt(yield->mean_square_pull, "%.3g") << ".\n\n";
    if (!yield->points.empty()) {
      md << "| phi | gdot | sigma_xy | law at (phi, gdot) | pull | sigma_Y(phi) |\n"
            "|---|---|---|---|---|---|\n";
      for (const auto& p : yield->points) {
        md << "| " << fmt(p.phi) << " | " << fmt(p.gdot, "%.3g") << " | "
           << format_measured(p.sigma) << " | " << format_measured(p.sigma_law) << " | "
           << fmt(p.pull, "%+.1f") << " | " << format_measured(p.sigma_yield) << " |\n";
      }
      md << "\n";
    }
  }
  return md.str();
}

Json joint_soft_plot_data(const JointSoftFit& f, const YieldComparison* yield) {
  Json j = Json::object();
  const auto v = f.law.values();
  j["law"] = Json(std::vector<double>(v.begin(), v.end()));
  std::vector<double> err;
  for (const auto& m : f.params)
    err.push_back(m.error);
  j["law_err"] = Json(err);
  if (yield)
    j["yield"] = joint_soft_json(f, yield).at("yield_data");
  // The law's sigma_Y on a grid above phi_J0, with its bootstrap band.
  std::vector<double> dphi, sy, sye;
  for (int k = 0; k <= 40; ++k) {
    const double d = 1e-4 * std::pow(10.0, 3.0 * k / 40.0);  // 1e-4 .. 1e-1
    const double phi = f.law.phi_j0 + d;
    const double v = f.law.sigma_yield(phi);
    const double e = f.spread([phi](const SoftLaw& l) { return l.sigma_yield(phi); });
    if (!std::isfinite(v) || !std::isfinite(e))
      continue;  // e.g. a negative c_phi: no yield stress to draw
    dphi.push_back(d);
    sy.push_back(v);
    sye.push_back(e);
  }
  j["yield_curve_dphi"] = Json(dphi);
  j["yield_curve_sigma"] = Json(sy);
  j["yield_curve_sigma_err"] = Json(sye);
  return j;
}

Json soft_json(const SoftResult& r, const SoftOptions& o, const std::vector<std::string>& inputs) {
  Json j = Json::object();
  j["analysis"] = "soft";
  j["inputs"] = strings_json(inputs);
  j["point_errors"] = point_errors_json(r.point_errors);
  Json opts = Json::object();
  opts["envelope_z"] = o.hard_sphere.envelope.z;
  opts["scale_errors"] = o.scale_errors;
  opts["fixed_shape"] = o.fixed_shape.has_value();
  j["options"] = opts;
  Json sizes = Json::object();
  for (const auto& s : r.sizes) {
    Json js = Json::object();
    if (s.joint)
      js["joint"] = joint_soft_json(*s.joint, s.yield_data ? &*s.yield_data : nullptr);
    else
      js["joint_skipped"] = s.joint_skipped;
    if (!s.collapse_skipped.empty()) {
      js["collapse_skipped"] = s.collapse_skipped;
      sizes[std::to_string(s.n)] = js;
      continue;
    }
    js["phi_J0"] = measured_json(s.phi_fit.at(0));
    js["c_phi"] = measured_json(s.phi_fit.at(1));
    js["x"] = measured_json(s.phi_fit.at(2));
    js["mu_J0"] = measured_json(s.mu_fit.at(0));
    js["c_mu"] = measured_json(s.mu_fit.at(1));
    js["y"] = measured_json(s.mu_fit.at(2));
    js["fit_phi_J"] = fit_summary(s.phi_fit);
    js["fit_mu_J"] = fit_summary(s.mu_fit);
    Json shape = Json::object();
    shape["source"] = s.shape.source;
    shape["C_phi"] = measured_json({s.shape.c_phi, std::sqrt(s.shape.cov_phi[0])});
    shape["b_phi"] = measured_json({s.shape.b_phi, std::sqrt(s.shape.cov_phi[3])});
    shape["C_mu"] = measured_json({s.shape.c_mu, std::sqrt(s.shape.cov_mu[0])});
    shape["b_mu"] = measured_json({s.shape.b_mu, std::sqrt(s.shape.cov_mu[3])});
    js["hard_sphere_shape"] = shape;
    Json pressures = Json::object();
    for (const auto& c : s.pressures) {
      Json jp = Json::object();
      jp["phi_J"] = measured_json(c.phi_j);
      jp["mu_J"] = measured_json(c.mu_j);
      jp["phi_J_stat_error"] = c.phi_j_stat;
      jp["mu_J_stat_error"] = c.mu_j_stat;
      jp["points"] = static_cast<std::int64_t>(c.points);
      jp["collapse_chi2_phi"] = c.chi2_phi;
      jp["collapse_chi2_mu"] = c.chi2_mu;
      jp["collapse_dof"] = static_cast<std::int64_t>(c.points - 1);
      pressures[format_key(c.pressure)] = jp;
    }
    js["pressures"] = pressures;
    Json y = Json::object();
    y["formula"] =
        "sigma_Y = amplitude_1 (phi - phi_J0)^exponent_1 - amplitude_2 (phi - phi_J0)^exponent_2";
    y["amplitude_1"] = measured_json(s.yield.amplitude_1);
    y["exponent_1"] = measured_json(s.yield.exponent_1);
    y["amplitude_2"] = measured_json(s.yield.amplitude_2);
    y["exponent_2"] = measured_json(s.yield.exponent_2);
    js["yield"] = y;
    sizes[std::to_string(s.n)] = js;
  }
  j["sizes"] = sizes;
  j["warnings"] = strings_json(r.warnings);
  return j;
}

std::string soft_markdown(const SoftResult& r, const SoftOptions& o,
                          const std::vector<std::string>& inputs) {
  std::ostringstream md;
  md << "# Soft granular rheology\n\n";
  inputs_md(md, inputs);
  md << describe(r.point_errors) << "\n\n";
  md << "phi(P,J) = phi_J(P) - C_phi J^b_phi, mu(P,J) = mu_J(P) + C_mu J^b_mu; phi_J(P), "
        "mu_J(P) are the weighted-mean collapse of each pressure onto the P -> 0 shape "
     << (o.fixed_shape ? "given by --hs-params" : "of the same N's hard-sphere fit")
     << ". Errors of phi_J(P), mu_J(P) include the shape's uncertainty, which is common to "
        "all pressures and enters the fits below as correlations.\n\n";
  for (const auto& s : r.sizes) {
    md << "## N = " << s.n << "\n\n";
    md << "### Joint fit over every pressure and J\n\n";
    if (s.joint)
      md << joint_soft_markdown(*s.joint, s.yield_data ? &*s.yield_data : nullptr);
    else
      md << "Not done: " << s.joint_skipped << "\n\n";
    md << "### Per-pressure collapse (the paper's route)\n\n";
    if (!s.collapse_skipped.empty()) {
      md << "Not done: " << s.collapse_skipped << "\n\n";
      continue;
    }
    md << "Shape (" << s.shape.source
       << "): C_phi = " << format_measured({s.shape.c_phi, std::sqrt(s.shape.cov_phi[0])})
       << ", b_phi = " << format_measured({s.shape.b_phi, std::sqrt(s.shape.cov_phi[3])})
       << ", C_mu = " << format_measured({s.shape.c_mu, std::sqrt(s.shape.cov_mu[0])})
       << ", b_mu = " << format_measured({s.shape.b_mu, std::sqrt(s.shape.cov_mu[3])}) << "\n\n";
    md << "| P | points | phi_J(P) | chi2/dof | mu_J(P) | chi2/dof |\n|---|---|---|---|---|---|\n";
    for (const auto& c : s.pressures) {
      const double dof = static_cast<double>(c.points - 1);
      md << "| " << format_key(c.pressure) << " | " << c.points << " | " << format_measured(c.phi_j)
         << " | " << fmt(c.chi2_phi / dof, "%.2f") << " | " << format_measured(c.mu_j) << " | "
         << fmt(c.chi2_mu / dof, "%.2f") << " |\n";
    }
    md << "\n| parameter | value | paper |\n|---|---|---|\n";
    md << "| phi_J(0) | " << format_measured(s.phi_fit.at(0)) << " | |\n";
    md << "| c_phi | " << format_measured(s.phi_fit.at(1)) << " | |\n";
    md << "| x | " << format_measured(s.phi_fit.at(2)) << " | " << fmt(seed::kX) << " |\n";
    md << "| mu_J(0) | " << format_measured(s.mu_fit.at(0)) << " | |\n";
    md << "| c_mu | " << format_measured(s.mu_fit.at(1)) << " | |\n";
    md << "| y | " << format_measured(s.mu_fit.at(2)) << " | " << fmt(seed::kY) << " |\n";
    md << "| chi2/dof phi_J(P), mu_J(P) | " << fmt(s.phi_fit.reduced_chi2(), "%.2f") << ", "
       << fmt(s.mu_fit.reduced_chi2(), "%.2f") << " | |\n\n";
    md << "Yield stress sigma_Y = a1 (phi - phi_J0)^e1 - a2 (phi - phi_J0)^e2:\n\n";
    md << "| quantity | value | paper |\n|---|---|---|\n";
    md << "| a1 = mu_J(0) c_phi^(-1/x) | " << format_measured(s.yield.amplitude_1) << " | |\n";
    md << "| e1 = 1/x | " << format_measured(s.yield.exponent_1) << " | "
       << fmt(seed::kYieldExponent) << " |\n";
    md << "| a2 = c_mu c_phi^(-(1+y)/x) | " << format_measured(s.yield.amplitude_2) << " | |\n";
    md << "| e2 = (1+y)/x | " << format_measured(s.yield.exponent_2) << " | "
       << fmt((1.0 + seed::kY) / seed::kX) << " |\n\n";
  }
  notes_md(md, r.warnings, {});
  return md.str();
}

Json soft_plot_data(const SoftResult& r) {
  Json j = Json::object();
  Json sizes = Json::array();
  for (const auto& s : r.sizes) {
    Json js = Json::object();
    js["N"] = static_cast<std::int64_t>(s.n);
    std::vector<double> p, jj, phi, phi_err, mu, mu_err;
    for (const auto& g : s.points) {
      p.push_back(g.pressure);
      jj.push_back(g.j);
      phi.push_back(g.phi);
      phi_err.push_back(g.phi_err);
      mu.push_back(g.mu);
      mu_err.push_back(g.mu_err);
    }
    js["imposed_pressure"] = Json(p);
    js["J"] = Json(jj);
    js["phi"] = Json(phi);
    js["phi_err"] = Json(phi_err);
    js["mu"] = Json(mu);
    js["mu_err"] = Json(mu_err);
    if (s.joint)
      js["joint"] = joint_soft_plot_data(*s.joint, s.yield_data ? &*s.yield_data : nullptr);
    if (!s.collapse_skipped.empty()) {
      sizes.push_back(js);
      continue;
    }
    js["shape"] =
        Json(std::vector<double>{s.shape.c_phi, s.shape.b_phi, s.shape.c_mu, s.shape.b_mu});
    std::vector<double> pp, pj, pje, mj, mje;
    for (const auto& c : s.pressures) {
      pp.push_back(c.pressure);
      pj.push_back(c.phi_j.value);
      pje.push_back(c.phi_j.error);
      mj.push_back(c.mu_j.value);
      mje.push_back(c.mu_j.error);
    }
    js["pressures"] = Json(pp);
    js["phi_J"] = Json(pj);
    js["phi_J_err"] = Json(pje);
    js["mu_J"] = Json(mj);
    js["mu_J_err"] = Json(mje);
    js["phi_fit"] = Json(s.phi_fit.params);
    js["mu_fit"] = Json(s.mu_fit.params);
    sizes.push_back(js);
  }
  j["sizes"] = sizes;
  return j;
}

// --- Olsson–Teitel -------------------------------------------------------------

namespace {

Json params_json(const CollapseParams& p) {
  Json j = Json::object();
  j["phi_J"] = p.phi_j;
  j["alpha"] = p.alpha;
  j["beta"] = p.beta;
  return j;
}

Json collapse_fit_json(const CollapseFit& f) {
  Json j = Json::object();
  j["phi_J"] = measured_json(f.phi_j);
  j["alpha"] = measured_json(f.alpha);
  j["beta"] = measured_json(f.beta);
  j["quality"] = quality_json(f.quality);
  j["bootstrap_resamples"] = f.bootstrap_used;
  j["quality_bootstrap_spread"] = f.s_spread;
  return j;
}

Json soft_comparison_json(const SoftComparison& c) {
  Json j = joint_soft_json(c.fit, nullptr);
  Json q = Json::object();
  q["value"] = c.s;
  q["error"] = c.s_spread;
  q["acceptable"] = c.acceptable();
  q["points_used"] = static_cast<std::int64_t>(c.used);
  q["points_total"] = static_cast<std::int64_t>(c.total);
  q["bootstrap_resamples"] = c.bootstrap_used;
  q["measure"] = "mean over points of ((ln sigma - ln sigma_law(phi, gdot)) / dln sigma)^2";
  j["quality"] = q;
  return j;
}

}  // namespace

Json olsson_teitel_json(const OlssonTeitelResult& r, const OlssonTeitelOptions& o,
                        const std::vector<std::string>& inputs) {
  Json j = Json::object();
  j["analysis"] = "olsson-teitel";
  j["inputs"] = strings_json(inputs);
  j["point_errors"] = point_errors_json(r.point_errors);
  j["measure"] = "Houdayer-Hartmann S (Phys. Rev. B 70, 014418 (2004)) in ln-ln scaled variables";
  j["N"] = static_cast<std::int64_t>(r.n);
  j["points"] = static_cast<std::int64_t>(r.points);
  j["curves"] = static_cast<std::int64_t>(r.sets);
  Json opts = Json::object();
  opts["bootstrap"] = o.bootstrap;
  opts["seed"] = static_cast<std::int64_t>(o.seed);
  opts["min_overlap"] = o.min_overlap;
  j["options"] = opts;
  Json at = params_json(r.at);
  at["quality"] = quality_json(r.at_quality);
  j["at"] = at;
  j["best"] = collapse_fit_json(r.best);
  Json subsets = Json::object();
  for (const auto& s : r.subsets) {
    Json js = Json::object();
    js["description"] = s.description;
    js["points"] = static_cast<std::int64_t>(s.indices.size());
    if (s.fit) {
      Json f = collapse_fit_json(*s.fit);
      for (const auto& [k, v] : f.members())
        js[k] = v;
      js["quality_at_global_best"] = quality_json(s.at_global_best);
      js["complement_quality_at_subset_best"] = quality_json(s.complement_at_own_best);
      js["complement_quality_at_global_best"] = quality_json(s.complement_at_global_best);
      js["trade_off"] = s.trade_off;
    } else {
      js["skipped"] = s.skipped;
    }
    subsets[s.name] = js;
  }
  Json splits = Json::object();
  splits["delta_phi"] = r.split_delta;
  splits["shear_rate"] = r.split_gdot;
  j["subset_splits"] = splits;
  j["subsets"] = subsets;
  {
    Json ms = Json::array();
    for (const auto& m : r.measures) {
      Json jm = Json::object();
      jm["label"] = m.label;
      jm["phi_J"] = m.params.phi_j;
      jm["alpha"] = m.params.alpha;
      jm["beta"] = m.params.beta;
      jm["houdayer_hartmann"] = quality_json(m.houdayer_hartmann);
      jm["pairwise_interpolation"] = quality_json(m.pairwise);
      ms.push_back(jm);
    }
    j["measures"] = ms;
    j["measures_meaning"] =
        "the collapse quality under two estimators of the master curve (analysis/collapse.hpp): "
        "Houdayer-Hartmann (one weighted line through the bracketing points of all other "
        "curves) and pairwise interpolation (each other curve separately); acceptable: S <= 1 + "
        "3 sqrt(2/N_used) under either";
  }
  if (r.soft)
    j["soft"] = soft_comparison_json(*r.soft);
  else
    j["soft_skipped"] = r.soft_skipped;
  j["warnings"] = strings_json(r.warnings);
  return j;
}

std::string olsson_teitel_markdown(const OlssonTeitelResult& r, const OlssonTeitelOptions& o,
                                   const std::vector<std::string>& inputs) {
  std::ostringstream md;
  md << "# Olsson–Teitel scaling: collapse quality\n\n";
  inputs_md(md, inputs);
  md << describe(r.point_errors) << "\n\n";
  md << "sigma = |phi - phi_J|^alpha G_pm(gdot / |phi - phi_J|^(alpha+beta)), N = " << r.n << ", "
     << r.points << " points on " << r.sets << " curves. Quality: Houdayer–Hartmann S (S ~ 1: "
     << "collapse consistent with the errors; S >> 1: no collapse). Parameter errors: "
     << "standard deviation over " << o.bootstrap << " parametric-bootstrap resamples.\n\n";
  md << "| | phi_J | alpha | beta | S |\n|---|---|---|---|---|\n";
  md << "| given (--at) | " << fmt(r.at.phi_j) << " | " << fmt(r.at.alpha) << " | "
     << fmt(r.at.beta) << " | " << quality_md(r.at_quality) << " |\n";
  md << "| optimum | " << format_measured(r.best.phi_j) << " | " << format_measured(r.best.alpha)
     << " | " << format_measured(r.best.beta) << " | " << quality_md(r.best.quality) << " |\n";
  md << "| paper (Fig. 9) | " << fmt(seed::kTeitelPhiJ) << " | " << fmt(seed::kTeitelAlpha) << " | "
     << fmt(seed::kTeitelBeta) << " | no acceptable collapse |\n\n";
  md << "Bootstrap spread of S at the resamples' optima: " << fmt(r.best.s_spread, "%.3g")
     << ".\n\n";
  if (!r.measures.empty()) {
    md << "The same collapse under a second measure (pairwise interpolation: each other curve "
          "separately, analysis/collapse.hpp), so that a verdict does not rest on one "
          "estimator; acceptable: S <= 1 + 3 sqrt(2/points used) under each.\n\n"
       << "| at | phi_J | alpha | beta | Houdayer–Hartmann S | pairwise S "
          "|\n|---|---|---|---|---|---|\n";
    auto cell = [](const CollapseQuality& q) {
      if (q.used == 0)
        return std::string("undefined");
      return quality_md(q) + ", threshold " + fmt(q.threshold(), "%.3g");
    };
    for (const auto& m : r.measures)
      md << "| " << m.label << " | " << fmt(m.params.phi_j) << " | " << fmt(m.params.alpha, "%.3g")
         << " | " << fmt(m.params.beta, "%.3g") << " | " << cell(m.houdayer_hartmann) << " | "
         << cell(m.pairwise) << " |\n";
    md << "\n";
  }
  md << "## Soft granular rheology on the same points\n\n";
  if (r.soft) {
    const SoftComparison& c = *r.soft;
    md << "Each point's measured P and sigma_xy give (P, J = gdot/P, phi, mu); the ten "
          "parameters are fitted jointly (phi's error from P's error through the law's slope). "
          "Quality: mean squared pull of ln sigma_xy against the law's sigma_xy(phi, gdot), "
          "the same kind of number as S: "
       << fmt(c.s, "%.4g") << " ± " << fmt(c.s_spread, "%.2g") << " (bootstrap, "
       << c.bootstrap_used << " resamples; " << c.used << "/" << c.total << " points), "
       << (c.acceptable() ? "consistent with the errors" : "not consistent with the errors")
       << ".\n\n";
    md << joint_soft_markdown(c.fit, nullptr);
  } else {
    md << "Not fitted: " << r.soft_skipped << "\n\n";
  }
  md << "## Sub-ranges\n\n";
  md << "Each subset is optimised on its own; 'rest' is the complement. A trade-off means the "
        "subset's optimum improves the subset but worsens the rest, leaving it with an "
        "unacceptable collapse (S > 1 + 3 sqrt(2/N_used)): the paper's claim.\n\n";
  md << "| subset | points | phi_J | alpha | beta | S subset (own opt.) | S subset (global opt.) "
        "| S rest (subset opt.) | S rest (global opt.) | trade-off |\n";
  md << "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& s : r.subsets) {
    md << "| " << s.name << " (" << markdown_cell(s.description) << ") | " << s.indices.size();
    if (!s.fit) {
      md << " | skipped: " << s.skipped << " | | | | | | | |\n";
      continue;
    }
    md << " | " << format_measured(s.fit->phi_j) << " | " << format_measured(s.fit->alpha) << " | "
       << format_measured(s.fit->beta) << " | " << quality_md(s.fit->quality) << " | "
       << quality_md(s.at_global_best) << " | " << quality_md(s.complement_at_own_best) << " | "
       << quality_md(s.complement_at_global_best) << " | " << (s.trade_off ? "yes" : "no")
       << " |\n";
  }
  md << "\n";
  notes_md(md, r.warnings, {});
  return md.str();
}

Json olsson_teitel_plot_data(const OlssonTeitelResult& r, const std::vector<ShearPoint>& points) {
  HoudayerHartmann hh(points);
  Json j = Json::object();
  j["N"] = static_cast<std::int64_t>(r.n);
  j["sets"] = strings_json(hh.set_names());
  auto scaled_json = [&](const CollapseParams& p, const CollapseQuality& q) {
    Json s = params_json(p);
    if (q.used > 0)
      s["quality"] = q.s;
    std::vector<double> x, y, dy, branch, set;
    for (const auto& v : hh.scaled(p)) {
      x.push_back(v.x);
      y.push_back(v.y);
      dy.push_back(v.dy_rel);
      branch.push_back(v.branch);
      set.push_back(static_cast<double>(v.set));
    }
    s["x"] = Json(x);
    s["y"] = Json(y);
    s["dy_rel"] = Json(dy);
    s["branch"] = Json(branch);
    s["set"] = Json(set);
    return s;
  };
  j["at"] = scaled_json(r.at, r.at_quality);
  j["best"] = scaled_json(r.best.best, r.best.quality);
  // Flow curves sigma(gdot) per curve with the soft law's prediction (when fitted).
  std::vector<double> phi, gdot, sigma, sigma_err, law;
  for (std::size_t i = 0; i < points.size(); ++i) {
    phi.push_back(points[i].phi);
    gdot.push_back(points[i].shear_rate);
    sigma.push_back(points[i].sigma);
    sigma_err.push_back(points[i].sigma_err);
    law.push_back(r.soft && i < r.soft->sigma_law.size() && std::isfinite(r.soft->sigma_law[i])
                      ? r.soft->sigma_law[i]
                      : -1.0);
  }
  Json flow = Json::object();
  flow["phi"] = Json(phi);
  flow["shear_rate"] = Json(gdot);
  flow["sigma_xy"] = Json(sigma);
  flow["sigma_xy_err"] = Json(sigma_err);
  if (r.soft) {
    flow["sigma_law"] = Json(law);
    flow["soft_quality"] = r.soft->s;
    // The law along each curve, on a fine grid of gdot.
    Json curves = Json::array();
    std::map<double, std::pair<double, double>> range;
    for (const auto& p : points) {
      auto [it, inserted] = range.emplace(p.phi, std::make_pair(p.shear_rate, p.shear_rate));
      it->second.first = std::min(it->second.first, p.shear_rate);
      it->second.second = std::max(it->second.second, p.shear_rate);
    }
    for (const auto& [ph, gr] : range) {
      std::vector<double> g, sg;
      for (int k = 0; k <= 30; ++k) {
        const double gd = gr.first * std::pow(gr.second / gr.first, k / 30.0);
        const double sv = r.soft->fit.law.sigma_at(ph, gd);
        if (std::isfinite(sv)) {
          g.push_back(gd);
          sg.push_back(sv);
        }
      }
      Json c = Json::object();
      c["phi"] = ph;
      c["shear_rate"] = Json(g);
      c["sigma"] = Json(sg);
      curves.push_back(c);
    }
    flow["law_curves"] = curves;
  }
  j["flow"] = flow;
  return j;
}

}  // namespace jamflow::analysis
