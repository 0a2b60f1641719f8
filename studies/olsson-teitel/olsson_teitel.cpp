// `jamflow study olsson-teitel`: the seed's Fig. 9 from jamflow's own constant-volume runs on
// both sides of phi_J. One data set, two descriptions: the Olsson–Teitel two-branch scaling
// (at the seed's exponents and at the best collapse) and the soft granular rheology, each with
// a quality number and bootstrap errors. See README.md in this folder.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

#include "analysis/analyze_cli.hpp"
#include "analysis/seed.hpp"
#include "framework/study.hpp"
#include "framework/sweep_study.hpp"
#include "framework/table_report.hpp"
#include "lib/error.hpp"
#include "studies/common.hpp"
#include "studies/granular_report.hpp"
#include "studies/olsson-teitel/points.hpp"
#include "studies/olsson-teitel/report.hpp"
#include "sweep/engine.hpp"
#include "sweep/plan.hpp"

namespace jamflow::studies {
namespace {
namespace fs = std::filesystem;

constexpr const char* kStudy = "olsson-teitel";

struct Quality {
  bool present = false;
  double s = 0.0, error = 0.0;
  bool acceptable = false;
  double used = 0.0, total = 0.0;
};

Quality quality_of(const analysis::Json& q, double spread) {
  Quality out;
  if (!q.is_object() || !q.contains("value") || !q.at("value").is_number())
    return out;
  out.present = true;
  out.s = q.at("value").as_number();
  out.error = spread;
  out.acceptable = q.contains("acceptable") && q.at("acceptable").as_bool();
  out.used = q.contains("points_used") ? q.at("points_used").as_number() : 0.0;
  out.total = q.contains("points_total") ? q.at("points_total").as_number() : 0.0;
  return out;
}

std::string quality_cell(const Quality& q) {
  if (!q.present)
    return "undefined";
  return pm(q.s, q.error, 3) + " (" + num(q.used, 4) + "/" + num(q.total, 4) + " points)";
}

// One collapse measure at its own optimum, from the analysis JSON's "measures".
struct MeasureVerdict {
  std::string key, name, params;
  double s = 0.0, error = 0.0, threshold = 0.0, used = 0.0;
  bool acceptable = false;
};

// The Houdayer–Hartmann measure at its optimum (error: the bootstrap spread of S there) and the
// pairwise-interpolation measure at its own optimum (error: the Gaussian spread); empty when the
// JSON has no "measures" (an analysis from before the second measure).
std::vector<MeasureVerdict> measure_verdicts(const analysis::Json& result, const Quality& q_best) {
  std::vector<MeasureVerdict> out;
  if (!result.is_object() || !result.contains("measures"))
    return out;
  const auto& ms = result.at("measures");
  for (const auto& [key, name, label] :
       {std::tuple<std::string, std::string, std::string>{
            "houdayer_hartmann", "the Houdayer–Hartmann measure (the project's)",
            "Houdayer-Hartmann optimum"},
        {"pairwise_interpolation", "the pairwise-interpolation measure",
         "pairwise-interpolation optimum"}}) {
    for (std::size_t i = 0; i < ms.size(); ++i) {
      const auto& m = ms.at(i);
      if (m.at("label").as_string() != label)
        continue;
      const auto& q = m.at(key);
      if (!q.at("value").is_number())
        continue;
      MeasureVerdict v;
      v.key = key;
      v.name = name;
      v.params = std::string("(")
                     .append(num(m.at("phi_J").as_number(), 4))
                     .append(", ")
                     .append(num(m.at("alpha").as_number(), 3))
                     .append(", ")
                     .append(num(m.at("beta").as_number(), 3))
                     .append(")");
      v.s = q.at("value").as_number();
      v.error = key == "houdayer_hartmann" && std::isfinite(q_best.error)
                    ? q_best.error
                    : q.at("error").as_number();
      v.used = q.at("points_used").as_number();
      v.threshold = q.contains("threshold") ? q.at("threshold").as_number()
                                            : 1.0 + 3.0 * std::sqrt(2.0 / v.used);
      v.acceptable = q.at("acceptable").as_bool();
      out.push_back(v);
    }
  }
  return out;
}

int report(const VolumePreset& preset, const SweepStudy& run, const StudyOptions& options,
           double wall_seconds) {
  const std::string out = options.out_dir;
  const std::string json_path = (fs::path(out) / "analysis.json").string();
  // 1. The analysis, as `jamflow analyze olsson-teitel TABLE -o analysis.json` runs it.
  const int analysis_status = analysis::analyze_olsson_teitel_files(
      {run.table}, analysis::OlssonTeitelOptions{}, std::nullopt, {json_path, !options.no_plots});
  const analysis::Json result = read_analysis(kStudy, json_path);
  const Table table = read_table(run.table);

  // 2. HDF5: the table and the qualities.
  {
    H5Writer w((fs::path(out) / (std::string(kStudy) + ".h5")).string());
    w.attr("/", "study", kStudy);
    w.attr("/", "preset", preset.name);
    w.attr("/", "analysis_status", static_cast<std::int64_t>(analysis_status));
    write_h5_table(w, "/points", table.header, table.rows);
    if (result.is_object() && result.contains("best")) {
      w.group("/fits");
      const auto& best = result.at("best");
      for (const char* p : {"phi_J", "alpha", "beta"}) {
        double v = 0.0, e = 0.0;
        if (measured(best, p, v, e)) {
          w.attr("/fits", std::string("collapse_") + p, v);
          w.attr("/fits", std::string("collapse_") + p + "_err", e);
        }
      }
      double v = 0.0, e = 0.0;
      if (measured(best, "quality", v, e))
        w.attr("/fits", "collapse_S", v);
      if (measured(result.at("at"), "quality", v, e))
        w.attr("/fits", "paper_exponents_S", v);
      if (result.contains("soft") && measured(result.at("soft"), "quality", v, e)) {
        w.attr("/fits", "soft_S", v);
        w.attr("/fits", "soft_S_err", e);
      }
    }
    w.commit();
  }

  // 3. The report.
  const std::string cost = options.report_only
                               ? cost_line_from_tables({&table}, run.cpu_hours_estimate)
                               : cost_line(out, run.cpu_hours_estimate, wall_seconds);
  write_text((fs::path(out) / "report.md").string(),
             olsson_teitel::report_markdown(preset, run, table, result, analysis_status, cost));
  if (!options.quiet)
    std::printf("%s: %s\n", kStudy, (fs::path(out) / "report.md").c_str());
  if (!result.is_object() || !result.contains("best"))
    return 1;  // the analysis could not be done on these points: the report says so
  return analysis_status == 0 ? 0 : 1;
}

}  // namespace

std::string olsson_teitel::report_markdown(const VolumePreset& preset, const SweepStudy& run,
                                           const Table& table, const analysis::Json& result,
                                           int analysis_status, const std::string& cost) {
  std::ostringstream md;
  md << "# olsson-teitel study, preset `" << preset.name << "`\n\n";
  {
    // What the table holds, from the table: the integrators the points ran with.
    md << "Constant volume, harmonic spheres (alpha_r = 2), " << preset.why
       << ". Integrators (points): " << integrators_line(table) << ".\n\n";
  }
  md << "- Points: " << run.plan.points.size() << " x " << run.plan.replicas << " replicas, "
     << run.finished << " finished in every replica (table.csv).\n";
  md << cost;
  {
    double gmin = 1e300, gmax = 0.0;
    std::set<double> below, above;
    for (std::size_t r = 0; r < table.rows.size(); ++r) {
      gmin = std::min(gmin, table.number(r, "shear_rate"));
      gmax = std::max(gmax, table.number(r, "shear_rate"));
    }
    if (gmax > 0.0)
      md << "- Shear rates: " << num(gmin, 3) << " to " << num(gmax, 3) << " ("
         << num(std::log10(gmax / gmin), 3) << " decades).\n\n";
  }
  md << "## Verdicts\n\n" << verdicts_markdown(table, "constant-volume");

  md << "## Two descriptions of one data set\n\n";
  if (analysis_status != 0)
    md << "`jamflow analyze olsson-teitel` exited with status " << analysis_status
       << " (see the messages above and analysis.md): what it could not do is missing here.\n\n";
  if (!result.is_object() || !result.contains("best")) {
    md << "No analysis result.\n";
    return md.str();
  }
  const auto& at = result.at("at");
  const auto& best = result.at("best");
  const double best_spread = best.contains("quality_bootstrap_spread")
                                 ? best.at("quality_bootstrap_spread").as_number()
                                 : std::nan("");
  const auto& at_q = at.at("quality");
  const Quality q_at = quality_of(at_q, at_q.contains("error") && at_q.at("error").is_number()
                                            ? at_q.at("error").as_number()
                                            : std::nan(""));
  const Quality q_best = quality_of(best.at("quality"), best_spread);
  Quality q_soft;
  if (result.contains("soft"))
    q_soft = quality_of(result.at("soft").at("quality"),
                        result.at("soft").at("quality").at("error").as_number());
  md << "Quality: the Houdayer–Hartmann S of the collapse (each point against the master curve "
        "of the other curves) and, for the soft granular rheology fitted to the same points, "
        "the mean squared pull of ln sigma_xy against the law. Both are ~1 when the "
        "description is consistent with the error bars and >> 1 when it is not; acceptable "
        "means S <= 1 + 3 sqrt(2/points). Errors of S: the spread over parametric-bootstrap "
        "resamples (at the seed's exponents, the Gaussian spread: nothing is refitted).\n\n";
  std::vector<std::vector<std::string>> rows;
  double v = 0, e = 0;
  rows.push_back({"Olsson–Teitel, the seed's exponents (Houdayer–Hartmann)",
                  "phi_J = " + num(at.at("phi_J").as_number(), 4) +
                      ", alpha = " + num(at.at("alpha").as_number(), 3) +
                      ", beta = " + num(at.at("beta").as_number(), 3),
                  quality_cell(q_at), q_at.acceptable ? "yes" : "no"});
  std::string best_params;
  for (const char* p : {"phi_J", "alpha", "beta"}) {
    if (measured(best, p, v, e))
      best_params += (best_params.empty() ? "" : ", ") + std::string(p) + " = " + pm(v, e, 3);
  }
  rows.push_back({"Olsson–Teitel, best collapse (Houdayer–Hartmann)", best_params,
                  quality_cell(q_best), q_best.acceptable ? "yes" : "no"});
  // A bootstrap that never moves the optimum (errors at rounding level) means the optimum
  // sits on the optimiser's overlap constraint: its errors say nothing.
  bool pinned = false;
  for (const char* p : {"alpha", "beta"}) {
    if (measured(best, p, v, e) && e <= 1e-9 * std::fabs(v))
      pinned = true;
  }
  if (result.contains("soft")) {
    const auto& soft = result.at("soft");
    std::string sp;
    for (const char* p : {"x", "y", "phi_J0", "mu_J0"}) {
      if (measured(soft, p, v, e))
        sp += (sp.empty() ? "" : ", ") + std::string(p) + " = " + pm(v, e, 3);
    }
    rows.push_back({"soft granular rheology (10 parameters)", sp, quality_cell(q_soft),
                    q_soft.acceptable ? "yes" : "no"});
  } else {
    rows.push_back({"soft granular rheology",
                    result.contains("soft_skipped") ? result.at("soft_skipped").as_string() : "",
                    "not fitted", "-"});
  }
  md << markdown_table({"description", "parameters", "quality", "acceptable"}, rows) << "\n";
  md << "The seed finds no acceptable collapse of the whole data set (Sec. V B, Fig. 9); its "
        "exponents are alpha = "
     << num(seed::kTeitelAlpha, 3) << ", beta = " << num(seed::kTeitelBeta, 3) << ".\n\n";
  if (pinned)
    md << "**The best collapse's errors are not meaningful:** no bootstrap resample moved the "
          "optimum, which sits where a step in any direction would leave fewer than half the "
          "points with a neighbouring curve (the optimiser's overlap constraint, "
          "`--min-overlap`); the curves barely overlap in scaled variables.\n\n";

  // The plain statement: two branches or not, and over which range.
  md << "## Verdict\n\n";
  std::vector<std::string> good_subsets, tradeoffs;
  if (result.contains("subsets")) {
    for (const auto& [name, sub] : result.at("subsets").members()) {
      if (!sub.contains("quality"))
        continue;
      if (sub.at("quality").contains("acceptable") && sub.at("quality").at("acceptable").as_bool())
        good_subsets.push_back(name + " (" + sub.at("description").as_string() + ")");
      if (sub.contains("trade_off") && sub.at("trade_off").as_bool())
        tradeoffs.push_back(name);
    }
  }
  // The whole range under each collapse measure: a conclusion only where both agree.
  const std::vector<MeasureVerdict> measures = measure_verdicts(result, q_best);
  const MeasureVerdict* hh = nullptr;
  const MeasureVerdict* pw = nullptr;
  for (const auto& m : measures)
    (m.key == "houdayer_hartmann" ? hh : pw) = &m;
  if (!measures.empty()) {
    md << "Collapse of the whole range (gdot and phi of the table), each measure at its own "
          "optimum (acceptable: S <= 1 + 3 sqrt(2/points used)):\n\n";
    std::vector<std::vector<std::string>> mrows;
    for (const auto& m : measures)
      mrows.push_back(
          {m.name, m.params, pm(m.s, m.error, 3), num(m.threshold, 3), num(m.used, 4),
           m.acceptable ? "yes" : "no",
           std::fabs(m.s - m.threshold) <= m.error ? "within its error" : "beyond its error"});
    md << markdown_table({"measure", "at (phi_J, alpha, beta)", "S", "threshold", "points used",
                          "acceptable", "S against the threshold"},
                         mrows)
       << "\n";
  }
  if (hh && pw && hh->acceptable != pw->acceptable) {
    const MeasureVerdict& yes = hh->acceptable ? *hh : *pw;
    const MeasureVerdict& no = hh->acceptable ? *pw : *hh;
    md << "Whether the whole data set collapses onto two branches depends on the measure: "
       << no.name << " gives S = " << pm(no.s, no.error, 3) << " above its threshold "
       << num(no.threshold, 3) << " at " << no.params << ", " << yes.name
       << " gives S = " << pm(yes.s, yes.error, 3) << " under its threshold "
       << num(yes.threshold, 3) << " at " << yes.params
       << ". Neither \"collapse\" nor \"no collapse\" is supported by both: the collapse is "
          "measure-dependent.";
  } else if (hh && pw) {
    const bool ok = hh->acceptable;
    md << "The data " << (ok ? "collapse" : "do **not** collapse")
       << " onto two branches over the whole range under both measures: " << hh->name
       << " S = " << pm(hh->s, hh->error, 3) << " (threshold " << num(hh->threshold, 3) << "), "
       << pw->name << " S = " << pm(pw->s, pw->error, 3) << " (threshold " << num(pw->threshold, 3)
       << "), each at its own optimum.";
  } else {
    md << "Only the Houdayer–Hartmann measure is in the analysis JSON; by it the data "
       << (q_best.acceptable ? "collapse" : "do not collapse")
       << " over the whole range (S = " << pm(q_best.s, q_best.error, 3)
       << " at its optimum). A verdict from one measure is not checked against another.";
  }
  const bool none = hh && pw ? !hh->acceptable && !pw->acceptable : !q_best.acceptable;
  if (none) {
    if (good_subsets.empty()) {
      md << " No sub-range tested (near/far from phi_J, slow/fast) collapses acceptably on its "
            "own either (Houdayer–Hartmann).";
    } else {
      md << " A collapse is acceptable (Houdayer–Hartmann) within: ";
      for (std::size_t i = 0; i < good_subsets.size(); ++i)
        md << (i ? "; " : "") << good_subsets[i];
      md << ", at that sub-range's own exponents (analysis.md).";
    }
  }
  if (!tradeoffs.empty()) {
    md << " Optimising on ";
    for (std::size_t i = 0; i < tradeoffs.size(); ++i)
      md << (i ? ", " : "") << tradeoffs[i];
    md << " makes the rest of the data collapse worse (the seed's trade-off; "
          "Houdayer–Hartmann).";
  }
  md << "\n\n";
  if (q_soft.present && q_best.present) {
    const double d = q_soft.s - q_best.s;
    const double err = std::hypot(q_soft.error, q_best.error);
    md << "Soft granular rheology against the best collapse: quality " << num(q_soft.s, 3)
       << " against " << num(q_best.s, 3) << " (difference " << pm(d, err, 2) << ", "
       << (err > 0 ? num(std::fabs(d) / err, 2) : std::string("n/a")) << " sigma); the soft "
       << "rheology is " << (q_soft.acceptable ? "" : "not ")
       << "consistent with the error bars. The two numbers weigh the same kind of residual "
          "(ln sigma_xy over its error) but S compares each point with neighbouring curves "
          "while the soft law is one smooth function with ten parameters.\n\n";
  }
  md << "Figures: analysis_fig9.png (the collapse at the seed's and at the best exponents), "
        "analysis_flow.png (the flow curves and the soft law fitted to them). Details, the "
        "sub-ranges and the soft law's parameters: analysis.md.\n";
  return md.str();
}

namespace {

// --report-only: the sweep and table in OUT. A folder with the table but without its sweep
// file (results committed before sweep files were kept) gets the preset's plan: its points and
// replicas, and the cost the current model estimates for them.
SweepStudy existing_points(const VolumePreset& preset, const std::string& out_dir) {
  if (fs::exists(fs::path(out_dir) / "sweep.toml"))
    return existing_sweep(out_dir);
  SweepStudy s;
  s.table = (fs::path(out_dir) / "table.csv").string();
  if (!fs::exists(s.table))
    throw ConfigError("--report-only: " + s.table +
                      " must exist (allowed: an output folder of an earlier run of the study)");
  s.plan = sweep::parse_plan(volume_sweep_text(preset), "<" + preset.name + " preset>", out_dir,
                             (fs::path(out_dir) / "runs").string());
  s.finished = read_table(s.table).rows.size();
  s.cpu_hours_estimate = sweep::estimate_cost(s.plan).cpu_hours;
  return s;
}

int run(const StudyOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const VolumePreset preset = olsson_teitel::preset(options.preset);
  if (options.report_only)
    return report(preset, existing_points(preset, options.out_dir), options, 0.0);
  SweepStudy points;
  if (auto status = run_sweep_study(kStudy, volume_sweep_text(preset), options, points))
    return *status;
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report(preset, points, options, wall);
}

const Registrar reg{{kStudy,
                     "Olsson–Teitel scaling against the soft granular rheology on one "
                     "constant-volume data set on both sides of phi_J (Fig. 9)",
                     run, true}};

}  // namespace
}  // namespace jamflow::studies
