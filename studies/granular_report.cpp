#include "studies/granular_report.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

#include "analysis/analyze_cli.hpp"
#include "analysis/hard_sphere.hpp"
#include "analysis/json.hpp"
#include "analysis/seed.hpp"
#include "framework/table_report.hpp"
#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "studies/common.hpp"
#include "sweep/engine.hpp"
#include "sweep/plan.hpp"

namespace jamflow::studies::granular {
namespace fs = std::filesystem;

namespace {

// The cost section (framework/table_report.hpp), and what the paper preset would need at the
// measured rate.
std::string cost_section(const std::string& study, const Table& table, const SweepStudy& run) {
  bool has_cost = false;
  std::ostringstream md;
  md << sweep_cost_markdown(table, run, integrator_label, &has_cost);
  if (!has_cost)
    return md.str();
  try {
    const GridPreset paper =
        study == "finite-size" ? finite_size_preset("paper") : grid_preset("paper");
    const sweep::Plan plan =
        sweep::parse_plan(pressure_sweep_text(paper), "<paper preset>", ".", "paper");
    const sweep::CostEstimate est = sweep::estimate_cost(plan);
    md << "\nThe paper preset (" << plan.points.size() << " points x " << plan.replicas
       << " replicas) is estimated at " << num(est.cpu_hours, 3)
       << " CPU-hours by the same model (`jamflow study " << study
       << " --preset paper --dry-run`; `jamflow study paper --preset paper --dry-run` sums every "
          "study's).\n";
  } catch (const std::exception& e) {
    md << "\n(The paper preset could not be estimated: " << e.what() << ")\n";
  }
  return md.str();
}

// What the sizes could resolve (analysis.json `extrapolated.<O>.sensitivity`): the chance that
// the resolution rule is met were every parameter to follow the seed's Table 2 law, and nu's
// best precision from alpha_O's error.
std::string sensitivity_markdown(const analysis::Json& ex) {
  std::vector<std::vector<std::string>> rows;
  std::vector<std::string> nu;
  double threshold = std::numeric_limits<double>::quiet_NaN();
  double target = threshold;
  for (const seed::SizeLaw& law : seed::kTable2) {
    const std::string p(law.name);
    if (!ex.contains(p) || !ex.at(p).contains("sensitivity"))
      continue;
    const auto& sv = ex.at(p).at("sensitivity");
    const double z = number_of(sv, "A_over_sigma"), chance = number_of(sv, "chance_resolved");
    const double scale = number_of(sv, "error_scale_for_target");
    const double sa = number_of(sv, "sigma_alpha"), alpha = number_of(sv, "alpha");
    if (!std::isfinite(z) || !std::isfinite(chance) || !std::isfinite(scale))
      continue;
    threshold = number_of(sv, "threshold_sigma");
    target = number_of(sv, "target_chance");
    rows.push_back(
        {p, num(number_of(sv, "A"), 3), num(z, 2), num(chance, 2),
         scale >= 1.0 ? std::string("-")
                      : num(1.0 / scale, 2) + " (replicas x " + num(1.0 / (scale * scale), 2) + ")",
         num(sa, 2) + " (" + num(alpha, 3) + ")"});
    if ((p == "phi_J" || p == "mu_J") && std::isfinite(sa) && alpha > 0.0) {
      const std::string from = "from " + p.substr(0, p.size() - 2);
      nu.push_back(sa < alpha ? "±" + num(100.0 * sa / alpha, 2) + "% " + from
                              : "not at all " + from + " (sigma_alpha_O " + num(sa, 2) +
                                    " exceeds alpha_O)");
    }
  }
  if (rows.empty())
    return {};
  std::ostringstream md;
  md << "\nWhat these sizes could resolve: were every parameter to follow the seed's Table 2 law "
        "exactly, at these sizes with the errors the fits used, the rule (|A_O| > "
     << num(threshold, 2)
     << " sigma) would be met with the chances below (Fisher errors of the fit, normal "
        "approximation, which leaves out the test for a constant and the chi2 scaling of the "
        "errors, both of which lower the chance; analysis.json `sensitivity`). The last but one "
        "column is how much smaller every size's error would have to be for a chance of "
     << num(target, 2) << ".\n\n"
     << markdown_table({"parameter", "seed A_O", "seed A_O / sigma_A", "chance of resolving",
                        "errors smaller by", "sigma_alpha_O (seed alpha_O)"},
                       rows);
  if (!nu.empty()) {
    md << "\nEven resolved, these sizes would give nu = b / (alpha_O d) no better than ";
    for (std::size_t k = 0; k < nu.size(); ++k)
      md << (k ? "; " : "") << nu[k];
    md << ". That is alpha_O's relative error alone.\n";
  }
  return md.str();
}

// The same extrapolations read without a unit of N (analysis.json `extrapolated.<O>.unit_free`):
// the rule's z of A_O depends on the unit N is counted in, these do not (analysis/README.md).
std::string unit_free_markdown(const analysis::Json& ex) {
  std::vector<std::vector<std::string>> rows;
  for (const seed::SizeLaw& law : seed::kTable2) {
    const std::string p(law.name);
    if (!ex.contains(p) || !ex.at(p).contains("unit_free"))
      continue;
    const auto& u = ex.at(p).at("unit_free");
    const double delta = number_of(u, "delta_chi2"), pc = number_of(u, "p_constant");
    if (!std::isfinite(delta) || !std::isfinite(pc))
      continue;
    const double rel = number_of(u, "alpha_relative_error");
    rows.push_back(
        {p, num(delta, 3), num(pc, 2), std::isfinite(rel) ? num(rel, 2) : std::string("-")});
  }
  if (rows.empty())
    return {};
  std::ostringstream md;
  md << "\nThe rule's z of A_O depends on the unit N is counted in (here: particles; "
        "analysis/README.md). Two readings of the same fits do not: the likelihood ratio of the "
        "power law against a constant (delta chi2 on the unscaled errors; p from chi2 with 2 dof, "
        "approximate because alpha_O is undefined under a constant) and alpha_O's relative "
        "error, which bounds nu's. They decide nothing in this report.\n\n"
     << markdown_table({"parameter", "delta chi2 (power law vs constant)", "p (constant)",
                        "sigma_alpha_O / alpha_O"},
                       rows);
  return md.str();
}

}  // namespace

int run_grid_study(const std::string& study, const GridPreset& grid, const StudyOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  if (options.report_only)
    return analyze_and_report(study, grid, existing_sweep(options.out_dir), options, 0.0);
  SweepStudy points;
  if (auto status = run_sweep_study(study, pressure_sweep_text(grid), options, points))
    return *status;
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return analyze_and_report(study, grid, points, options, wall);
}

int analyze_and_report(const std::string& study, const GridPreset& grid, const SweepStudy& run,
                       const StudyOptions& options, double wall_seconds) {
  const std::string out = options.out_dir;
  const std::string json_path = (fs::path(out) / "analysis.json").string();
  // 1. The analysis, as `jamflow analyze hard-sphere TABLE -o analysis.json` runs it.
  const int analysis_status = analysis::analyze_hard_sphere_files(
      {run.table}, analysis::HardSphereOptions{}, {json_path, !options.no_plots});
  const analysis::Json result = read_analysis(study, json_path);

  // 2. The flow curves and mu(J), phi(J) (the seed's Figs. 2-3) from the table.
  run_plot("hard-sphere/plot.py", {run.table, (fs::path(out) / "flow_curves.png").string()},
           options);

  // 3. The table and the fitted parameters as HDF5.
  const Table table = read_table(run.table);
  {
    H5Writer w((fs::path(out) / (study + ".h5")).string());
    w.attr("/", "study", study);
    w.attr("/", "preset", grid.name);
    w.attr("/", "analysis_status", static_cast<std::int64_t>(analysis_status));
    write_h5_table(w, "/points", table.header, table.rows);
    if (result.is_object() && result.contains("sizes")) {
      for (const auto& [n, fit] : result.at("sizes").members()) {
        const std::string g = "/fits/N" + n;
        w.group(g);
        for (const seed::SizeLaw& law : seed::kTable2) {
          const std::string p(law.name);
          double v = 0.0, e = 0.0;
          if (measured(fit, p, v, e)) {
            w.attr(g, p, v);
            w.attr(g, std::string(p) + "_err", e);
          }
        }
      }
    }
    w.commit();
  }

  // 4. The report.
  write_text((fs::path(out) / "report.md").string(),
             report_markdown(study, grid, run, table, result, analysis_status, wall_seconds));
  if (!options.quiet)
    std::printf("%s: %s\n", study.c_str(), (fs::path(out) / "report.md").c_str());
  return analysis_status == 0 ? 0 : 1;
}

std::string report_markdown(const std::string& study, const GridPreset& grid, const SweepStudy& run,
                            const Table& table, const analysis::Json& result, int analysis_status,
                            double wall_seconds) {
  std::ostringstream md;
  md << "# " << study << " study, preset `" << grid.name << "`\n\n";
  {
    // What the table holds, from the table (a report rebuilt from an older table describes
    // that table, not the current preset).
    std::set<std::int64_t> ns;
    std::set<double> ps, reps;
    double jmin = 1e300, jmax = 0.0;
    for (std::size_t r = 0; r < table.rows.size(); ++r) {
      ns.insert(std::int64_t(table.number(r, "N")));
      ps.insert(table.number(r, "imposed_pressure"));
      reps.insert(table.number(r, "replicas"));
      jmin = std::min(jmin, table.number(r, "J"));
      jmax = std::max(jmax, table.number(r, "J"));
    }
    auto list = [](const auto& xs) {
      std::string t;
      for (const auto& x : xs)
        t += (t.empty() ? "" : ", ") + num(double(x), 6);
      return t;
    };
    md << "Constant pressure, harmonic spheres (alpha_r = 2). The table: N = " << list(ns)
       << "; P = " << list(ps) << "; J from " << num(jmin, 3) << " to " << num(jmax, 3)
       << "; replicas per point: " << list(reps)
       << "; integrators (points): " << integrators_line(table)
       << ". Run lengths per point: table.csv (run.t_eq, run.t_av).\n\n";
    // What the errors the fits use are made of, as the analysis read them.
    if (result.is_object() && result.contains("point_errors"))
      md << result.at("point_errors").at("description").as_string() << "\n\n";
  }
  md << "- Points: " << run.plan.points.size() << " x " << run.plan.replicas << " replicas, "
     << run.finished << " finished in every replica (table.csv); the sweep is in runs/ "
     << "(`jamflow sweep sweep.toml --out runs`).\n";
  md << "- Cost: estimated " << num(run.cpu_hours_estimate, 3)
     << " CPU-hours (each integrator's measured CPU time per particle and tau_0); this "
        "invocation took "
     << num(wall_seconds / 60.0, 3)
     << " min of wall time (points finished earlier are not rerun).\n";

  // Verdicts: what analyze leaves out.
  const std::vector<std::vector<std::string>> flagged = flagged_rows(table);
  md << "\n## Verdicts\n\n";
  if (flagged.empty()) {
    md << "Every point is steady, stable and decorrelated in every replica.\n";
  } else {
    md << "`jamflow analyze` leaves out points that are not steady or not stable in some "
          "replica; a point whose blocks are shorter than 2 tau (not decorrelated) is kept "
          "when it has several replicas: from 3 its error bars include the scatter of "
          "independent replicas; with 2 they are the block errors, which such short blocks "
          "understate (a table collected before the block error and the scatter were separate "
          "columns holds the scatter of 2; analysis/README.md).\n\n";
    md << markdown_table({"point", "verdict", "used"}, flagged);
  }

  // The data behind the envelope: phi and mu at each J and P, and how far the two lowest
  // pressures at each J are apart (the hard-sphere limit needs them to agree).
  md << "\n## phi and mu at each J and P\n\n";
  {
    std::map<std::int64_t, std::map<double, std::map<double, std::size_t, std::greater<>>,
                                    std::greater<>>>
        grid_rows;  // N -> J -> P -> row (J and P from the table, to 3 digits)
    auto key = [](double x) { return std::stod(num(x, 3)); };
    for (std::size_t r = 0; r < table.rows.size(); ++r) {
      if (table.number(r, "steady") == 0.0 || table.number(r, "stable") == 0.0)
        continue;
      grid_rows[std::int64_t(table.number(r, "N"))][key(table.number(r, "J"))]
               [key(table.number(r, "imposed_pressure"))] = r;
    }
    for (const auto& [n, by_j] : grid_rows) {
      std::set<double, std::greater<>> pressures;
      for (const auto& [j, by_p] : by_j) {
        for (const auto& [p, r] : by_p)
          pressures.insert(p);
      }
      std::vector<std::string> header = {"J"};
      for (double p : pressures)
        header.push_back("P = " + num(p, 3));
      header.push_back("two lowest P: Delta phi, Delta mu (sigma)");
      std::vector<std::vector<std::string>> rows;
      int compared = 0, apart = 0;
      for (const auto& [j, by_p] : by_j) {
        std::vector<std::string> row = {num(j, 3)};
        for (double p : pressures) {
          const auto it = by_p.find(p);
          row.push_back(
              it == by_p.end()
                  ? "-"
                  : pm(table.number(it->second, "phi"), table.number(it->second, "phi_err"), 4) +
                        "; " +
                        pm(table.number(it->second, "mu"), table.number(it->second, "mu_err"), 3));
        }
        if (by_p.size() >= 2) {
          auto lo = by_p.rbegin();
          auto lo2 = std::next(lo);
          const std::size_t a = lo->second, b = lo2->second;
          const double dphi = table.number(b, "phi") - table.number(a, "phi");
          const double sphi = std::hypot(table.number(a, "phi_err"), table.number(b, "phi_err"));
          const double dmu = table.number(b, "mu") - table.number(a, "mu");
          const double smu = std::hypot(table.number(a, "mu_err"), table.number(b, "mu_err"));
          char buf[128];
          std::snprintf(buf, sizeof buf, "%+.4f (%.1f), %+.3f (%.1f)", dphi, dphi / sphi, dmu,
                        dmu / smu);
          row.push_back(buf);
          ++compared;
          if (std::fabs(dphi / sphi) > 2.0 || std::fabs(dmu / smu) > 2.0)
            ++apart;
        } else {
          row.push_back("-");
        }
        rows.push_back(row);
      }
      md << "N = " << n << " (phi; mu, each +- its error; points that are not steady or not "
         << "stable left out):\n\n"
         << markdown_table(header, rows) << "\n";
      // Two tests per J at 2 sigma: if every pair agreed, a J value would still be flagged
      // with probability 1 - (1 - 0.0455)^2 = 0.089 (independent Gaussian differences).
      const double chance = 1.0 - std::pow(1.0 - 0.0455, 2.0);
      const double expected = chance * compared;
      const double spread = std::sqrt(compared * chance * (1.0 - chance));
      md << "At " << apart << " of " << compared
         << " J values the two lowest pressures differ by more than 2 sigma in phi or mu; "
         << num(expected, 2) << " would by chance if every pair agreed. ";
      if (apart > expected + 2.0 * spread)
        md << "That is more than chance: at those J the data have not reached the hard-sphere "
              "(P -> 0) limit at the lowest pressure measured.";
      else
        md << "That is no more than chance gives: the data do not show that the two lowest "
              "pressures differ.";
      md << "\n\n";
    }
  }

  md << "\n## Fits per N (phi = phi_J - C_phi J^b_phi, mu = mu_J + C_mu J^b_mu)\n\n";
  if (analysis_status != 0)
    md << "`jamflow analyze hard-sphere` exited with status " << analysis_status
       << " (see analysis.md and the messages above): what it could not fit is missing here.\n\n";
  md << "Statistical errors from the fit covariance, multiplied by sqrt(chi2/dof) where chi2/dof "
        "> 1; systematic: the largest shift when the highest or the lowest J is dropped, and the "
        "shift with b fixed at the seed's law at this N, in quadrature (analysis.json "
        "`errors_phi`, `errors_mu`). The difference from the seed's law at the same N uses both "
        "in quadrature; a degenerate fit is not compared.\n\n";
  if (result.is_object() && result.contains("sizes")) {
    for (const auto& [n, fit] : result.at("sizes").members()) {
      const double nn = std::stod(n);
      double used = fit.contains("points_used") ? fit.at("points_used").as_number() : 0.0;
      md << "### N = " << n << " (" << num(used, 3) << " points in the P -> 0 envelope)\n\n";
      if (fit.contains("fitted") && !fit.at("fitted").as_bool()) {
        md << "Not fitted: " << fit.at("reason").as_string() << ".\n\n";
        continue;
      }
      std::vector<std::vector<std::string>> rows;
      for (const seed::SizeLaw& law : seed::kTable2) {
        const std::string p(law.name);
        double v = 0.0, e = 0.0;
        if (!measured(fit, p, v, e))
          continue;
        const auto& em = fit.at(std::string(p) == "phi_J" || std::string(p) == "b_phi" ||
                                        std::string(p) == "C_phi"
                                    ? "errors_phi"
                                    : "errors_mu");
        // null: no systematic could be computed (too few points for the refits).
        const bool has_sys =
            fit.at(p).contains("systematic") && fit.at(p).at("systematic").is_number();
        const double sys = has_sys ? fit.at(p).at("systematic").as_number() : 0.0;
        const double paper = seed::table2(p).at(nn);
        const bool degenerate = em.contains("degenerate") && em.at("degenerate").as_bool();
        rows.push_back({p, pm(v, e), has_sys ? num(sys, 2) : "not computable", num(paper, 4),
                        degenerate ? "degenerate fit: not compared"
                                   : sigma_text(v, std::hypot(e, sys), paper)});
      }
      md << markdown_table({"parameter", "jamflow (statistical)", "systematic",
                            "seed at this N (Table 2 law)", "difference"},
                           rows);
      for (const char* which : {"errors_phi", "errors_mu"}) {
        if (!fit.contains(which))
          continue;
        const auto& em = fit.at(which);
        const double chi = em.at("reduced_chi2").as_number();
        md << "\n"
           << (std::string(which) == "errors_phi" ? "phi" : "mu")
           << " fit: chi2/dof = " << num(chi, 3) << " (" << num(em.at("dof").as_number(), 3)
           << " dof)"
           << (em.at("errors_scaled_by_sqrt_chi2_dof").as_bool()
                   ? ", statistical errors multiplied by sqrt(chi2/dof) = " + num(std::sqrt(chi), 3)
                   : ", errors not scaled");
        if (em.at("degenerate").as_bool())
          md << "; **degenerate**: " << em.at("degenerate_reason").as_string();
        md << ".\n";
      }
      md << "\n";
    }
  } else {
    md << "No size could be fitted.\n";
  }
  if (result.is_object() && result.contains("extrapolated")) {
    const auto& ex = result.at("extrapolated");
    md << "## N -> infinity\n\n";
    if (ex.contains("skipped")) {
      std::string why = ex.at("skipped").as_string();
      if (!why.empty() && why.back() != '.')
        why += '.';
      int fitted = 0;
      if (result.contains("sizes")) {
        for (const auto& [n, fit] : result.at("sizes").members())
          fitted += !(fit.contains("fitted") && !fit.at("fitted").as_bool());
      }
      md << "Not extrapolated: " << why
         << (fitted > 0 ? " The per-N values above, beside the seed's law at the same N, are the "
                          "results; they are not N -> infinity values.\n\n"
                        : " No size was fitted either: there are no per-N values of the laws' "
                          "parameters.\n\n");
    } else {
      std::vector<std::vector<std::string>> rows;
      int resolved = 0;
      for (const seed::SizeLaw& law : seed::kTable2) {
        const std::string p(law.name);
        if (!ex.contains(p))
          continue;
        const auto& pe = ex.at(p);
        const bool ok = pe.contains("resolved") && pe.at("resolved").as_bool();
        const std::string why = pe.contains("resolution") ? pe.at("resolution").as_string() : "";
        double v = 0.0, e = 0.0;
        if (ok && measured(pe, "inf", v, e)) {
          ++resolved;
          const double sys = systematic_of(pe, "inf");
          rows.push_back({p, with_systematic(v, e, sys), num(law.inf, 4),
                          sigma_text(v, e, sys, law.inf), why});
        } else {
          rows.push_back({p, "-", num(law.inf, 4), "-", why});
        }
      }
      // The rule's numbers from the analysis' options (older JSON: the defaults).
      const analysis::Json no_options;
      const analysis::Json& opts = result.contains("options") ? result.at("options") : no_options;
      const analysis::HardSphereOptions defaults;
      md << "An N -> infinity value is given only where the extrapolation O(N) = O_inf + A_O "
            "N^-alpha_O is resolved: a power-law fit over at least "
         << num(number_of(opts, "min_sizes_for_extrapolation",
                          defaults.min_sizes_for_extrapolation),
                3)
         << " sizes whose A_O differs from 0 by more than "
         << num(number_of(opts, "resolved_amplitude_sigma", defaults.resolved_amplitude_sigma), 3)
         << " sigma. " << resolved << " of " << rows.size()
         << " parameters are; elsewhere the per-N values above, beside the seed's law at the "
            "same N, are the results.\n\n"
         << markdown_table({"parameter", "jamflow O_inf", "seed O_inf", "difference", "resolution"},
                           rows);
      md << sensitivity_markdown(ex);
      md << unit_free_markdown(ex);
    }
  }
  if (result.is_object() && result.contains("nu")) {
    const auto& nu = result.at("nu");
    double v = 0.0, e = 0.0;
    md << "\nnu = b / (alpha_O d): ";
    bool any = false;
    for (const auto& [key, label, paper] :
         {std::tuple<const char*, const char*, double>{"from_phi", "from phi", seed::kNuPhi},
          {"from_mu", "from mu", seed::kNuMu}}) {
      if (!measured(nu, key, v, e))
        continue;
      const double sys = systematic_of(nu, key);
      md << (any ? "; " : "") << label << " " << with_systematic(v, e, sys) << " (seed "
         << num(paper, 3) << ", " << sigma_text(v, e, sys, paper) << ")";
      any = true;
    }
    if (!any)
      md << "not determined (it needs a resolved extrapolation of phi_J or mu_J).";
    md << "\n\n";
  }
  if (result.is_object() && result.contains("viscosity")) {
    const auto& vis = result.at("viscosity");
    double v = 0.0;
    md << "## Viscosity divergence (Fig. 7)\n\n";
    md << "The law eta/eta_0 = mu_J [C_phi/(phi_J - phi)]^(1/b_phi) + C_mu [C_phi/(phi_J - "
          "phi)]^((1 - b_mu)/b_phi) with the parameters of "
       << vis.at("source").as_string() << ".\n";
    // An exponent's statistical error, its systematic one (the parameters' J-window and form
    // systematics, propagated) and the text "a ± s (statistical) ± y (systematic)".
    auto exponent = [&](const char* key, double& value, double& total) {
      double stat = 0.0;
      if (!measured(vis, key, value, stat))
        return std::string();
      const auto& x = vis.at(key);
      const double sys = x.contains("systematic") && x.at("systematic").is_number()
                             ? x.at("systematic").as_number()
                             : 0.0;
      total = std::hypot(stat, sys);
      return pm(value, stat) + " (statistical) ± " + num(sys, 2) + " (systematic)";
    };
    double total = 0.0;
    if (const std::string t = exponent("effective_exponent", v, total); !t.empty())
      md << "Effective exponent beta = -d ln eta / d ln(phi_J - phi) over the window: " << t
         << ".\n";
    if (vis.contains("beta_interval")) {
      const auto& bi = vis.at("beta_interval");
      md << "The trade-off interval [(1 - b_mu)/b_phi, 1/b_phi] of these parameters: ["
         << num(bi.at(0).as_number(), 3) << ", " << num(bi.at(1).as_number(), 3)
         << "] (the seed's: [" << num(seed::kViscosityExponentLow, 3) << ", "
         << num(seed::kViscosityExponentHigh, 3) << "]).\n";
    }
    if (const std::string t = exponent("exponent_1", v, total); !t.empty())
      md << "Asymptotic exponent 1/b_phi = " << t << " (seed "
         << num(seed::kViscosityExponentHigh, 3) << ", "
         << sigma_text(v, total, seed::kViscosityExponentHigh) << ", both errors in quadrature).\n";
    if (result.contains("sizes")) {
      for (const auto& [n, fit] : result.at("sizes").members()) {
        if (fit.contains("degenerate") && fit.at("degenerate").as_bool() &&
            vis.at("source").as_string() == "N = " + n)
          md << "The N = " << n
             << " fits are flagged degenerate (above): this law inherits their uncertainty.\n";
      }
    }
  }
  if (result.is_object() && result.contains("sizes")) {
    for (const auto& [n, fit] : result.at("sizes").members()) {
      if (!fit.contains("envelope_eta"))
        continue;
      const auto& ee = fit.at("envelope_eta");
      md << "\nN = " << n << ": the P -> 0 envelope reaches eta/eta_0 = mu/J from "
         << num(ee.at("min").as_number(), 3) << " to " << num(ee.at("max").as_number(), 3);
      const double j_lo = number_of(ee, "J_min"), j_hi = number_of(ee, "J_max");
      if (std::isfinite(j_lo) && std::isfinite(j_hi))
        md << " (J = " << num(j_hi, 3) << " to " << num(j_lo, 3) << ")";
      md << ", " << num(ee.at("decades").as_number(), 3) << " decades";
      if (const double sd = number_of(ee, "seed_decades"); std::isfinite(sd))
        md << "; the seed's Table 2 law at N = " << n << " spans " << num(sd, 3)
           << " decades over the same J";
      md << " (the seed reports about 5 over its whole range).";
    }
    md << "\n";
  }
  if (result.is_object() && result.contains("finite_size_collapse")) {
    const auto& fc = result.at("finite_size_collapse");
    md << "\n## Finite-size collapse (Fig. 6)\n\n";
    for (const char* o : {"phi", "mu"}) {
      if (!fc.contains(o))
        continue;
      const auto& c = fc.at(o);
      md << "- " << o << ": ";
      if (c.contains("unavailable")) {
        md << "not computed: " << c.at("unavailable").as_string() << ".\n";
        continue;
      }
      const auto& q = c.at("quality");
      md << "Houdayer-Hartmann S = " << pm(q.at("value").as_number(), q.at("error").as_number(), 3)
         << " over " << num(q.at("points_used").as_number(), 4) << " points ("
         << (q.at("acceptable").as_bool() ? "the sizes collapse within their errors"
                                          : "not a collapse within the errors")
         << ").\n";
    }
  }
  md << cost_section(study, table, run);
  md << "\nDetails of the fits, the envelope of every point and the figures of "
        "`jamflow analyze hard-sphere`: analysis.md. Flow curves: flow_curves.png.\n";
  return md.str();
}

}  // namespace jamflow::studies::granular
