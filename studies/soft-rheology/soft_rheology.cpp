// `jamflow study soft-rheology`: the soft granular rheology (the seed's Sec. V A, Fig. 8 and
// the yield stress, label `yield`) from jamflow's own runs: constant pressure over several
// pressures and viscous numbers, constant volume above phi_J. See README.md in this folder.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>
#include <sstream>

#include "analysis/analyze_cli.hpp"
#include "analysis/seed.hpp"
#include "framework/study.hpp"
#include "framework/sweep_study.hpp"
#include "framework/table_report.hpp"
#include "studies/common.hpp"
#include "studies/granular_report.hpp"
#include "studies/soft-rheology/points.hpp"
#include "studies/soft-rheology/report.hpp"

namespace jamflow::studies {
namespace {
namespace fs = std::filesystem;

constexpr const char* kStudy = "soft-rheology";
constexpr double kYTarget = 0.05;  // the error on y the issue asks of the standard preset

// The paper's values of the joint law (Sec. V A; Table 2 for the hard-sphere shape at this N).
double paper_value(const std::string& name, double n) {
  if (name == "x")
    return seed::kX;
  if (name == "y")
    return seed::kY;
  if (name == "alpha")
    return seed::kYieldExponent;
  if (name == "phi_J0")
    return seed::table2("phi_J").at(n);
  if (name == "mu_J0")
    return seed::table2("mu_J").at(n);
  for (const char* p : {"C_phi", "b_phi", "C_mu", "b_mu"}) {
    if (name == p)
      return seed::table2(p).at(n);
  }
  return std::nan("");
}

// One number of the joint fit from the analysis JSON: value, statistical error, the
// systematics (NaN where absent or null) and the paper's value.
struct JointNumber {
  bool present = false;
  double value = 0.0, stat = 0.0;
  double p_window = std::nan(""), j_window = std::nan(""), form = std::nan("");
  double systematic = std::nan("");
  double paper = std::nan("");
  std::string paper_source;
};

JointNumber joint_number(const analysis::Json& joint, const std::string& name, double n) {
  JointNumber out;
  if (!measured(joint, name, out.value, out.stat))
    return out;
  out.present = true;
  const auto& m = joint.at(name);
  out.p_window = number_of(m, "pressure_window");
  out.j_window = number_of(m, "J_window");
  out.form = number_of(m, "fit_form");
  out.systematic = number_of(m, "systematic");
  out.paper = paper_value(name, n);
  out.paper_source = name == "x" || name == "y" || name == "alpha"
                         ? "Sec. V A"
                         : "Table 2 law at N = " + num(n, 6);
  return out;
}

std::string opt_num(double v) {
  return std::isfinite(v) ? num(v, 2) : std::string("-");
}

// "+1.2" (sigma) or "-" without an error.
std::string pull_text(double value, double error, double ref) {
  if (!(error > 0.0) || !std::isfinite(ref))
    return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%+.1f", (value - ref) / error);
  return buf;
}

// What the numbers support about a parameter against the paper: the difference with the
// statistical error alone and with the systematics.
std::string comparison_sentence(const std::string& name, const JointNumber& v) {
  if (!v.present || !std::isfinite(v.paper) || !(v.stat > 0.0))
    return "";
  const double z_stat = (v.value - v.paper) / v.stat;
  std::ostringstream os;
  os << name << " = " << pm(v.value, v.stat) << " against the paper's " << num(v.paper, 4) << " ("
     << v.paper_source << "): " << pull_text(v.value, v.stat, v.paper)
     << " sigma with the statistical error alone";
  if (!std::isfinite(v.systematic)) {
    os << "; no systematic was computed, so "
       << (std::fabs(z_stat) > 2.0 ? "the difference is stated with the statistical error only."
                                   : "it agrees within the statistical error.");
    return os.str();
  }
  const double total = std::hypot(v.stat, v.systematic);
  const double z_total = (v.value - v.paper) / total;
  os << ", " << pull_text(v.value, total, v.paper) << " sigma with the systematic (J window "
     << opt_num(v.j_window) << ", fit form " << opt_num(v.form) << ", pressure window "
     << opt_num(v.p_window) << ") in quadrature. ";
  if (std::fabs(z_stat) > 2.0 && std::fabs(z_total) <= 2.0)
    os << "The difference is within the systematics: the data do not resolve it beyond the "
          "choice of the J and pressure windows and of the fit form.";
  else if (std::fabs(z_total) > 2.0)
    os << "It differs from the paper's value beyond the systematics.";
  else
    os << "It is consistent with the paper's value within these errors.";
  return os.str();
}

// The local exponent over successive pressure windows, and what its drift supports.
std::string local_exponent_text(const analysis::Json& joint, const std::string& name) {
  if (!joint.contains("local_exponents"))
    return "";
  const auto& le = joint.at("local_exponents");
  if (!le.contains(name))
    return "";
  const auto& windows = le.at(name);
  std::ostringstream os;
  os << "Local " << name << " (three adjacent pressures at a time, offset and J-shape held at "
     << "the joint optimum): ";
  for (std::size_t i = 0; i < windows.size(); ++i) {
    const auto& w = windows.at(i);
    const bool known = w.at("value").is_number() && w.at("total_error").is_number();
    os << (i ? "; " : "")
       << (known ? pm(w.at("value").as_number(), w.at("total_error").as_number(), 3)
                 : std::string("not computable"))
       << " over P = " << num(w.at("P_min").as_number(), 3) << " to "
       << num(w.at("P_max").as_number(), 3);
  }
  os << (windows.size() ? ". " : "no window could be fitted. ");
  const std::string key = "drift_" + name;
  if (!le.contains(key) || !le.at(key).at("defined").as_bool())
    return os.str() + "Fewer than two windows: no drift can be stated.";
  const auto& d = le.at(key);
  const double low = d.at("lowest_window").as_number(),
               low_e = d.at("lowest_window_error").as_number();
  const double high = d.at("highest_window").as_number(),
               high_e = d.at("highest_window_error").as_number();
  const double z = d.at("difference_sigma").as_number();
  const double z1 = d.at("lowest_window_minus_1_sigma").as_number();
  if (d.at("resolved").as_bool()) {
    os << "The local " << name << (low > high ? " rises" : " falls")
       << " toward the lowest pressures: " << pm(high, high_e, 3) << " in the highest window, "
       << pm(low, low_e, 3) << " in the lowest (" << num(std::fabs(z), 2) << " sigma apart); "
       << "the lowest window's value is "
       << (std::fabs(z1) <= 2.0
               ? "within 2 sigma of 1"
               : num(std::fabs(z1), 2) + " sigma " + (z1 < 0 ? "below" : "above") + " 1")
       << ". The fitted " << name
       << " is then an average over the pressure window, not an asymptotic exponent.";
  } else {
    os << "No drift is resolved: " << pm(low, low_e, 3) << " in the lowest window against "
       << pm(high, high_e, 3) << " in the highest (" << num(std::fabs(z), 2) << " sigma).";
  }
  return os.str();
}

}  // namespace

std::string soft_rheology::report_markdown(const Preset& preset, const SweepStudy& cp,
                                           const SweepStudy& cv, const Table& cp_table,
                                           const Table& cv_table, const analysis::Json& result,
                                           int analysis_status, const std::string& cost) {
  std::ostringstream md;
  md << "# soft-rheology study, preset `" << preset.pressure.name << "`\n\n";
  // What the tables hold, from the tables (a report rebuilt from older tables describes them,
  // not the current preset).
  {
    auto values = [](const Table& t, const char* column) {
      std::set<double> xs;
      for (std::size_t r = 0; r < t.rows.size(); ++r) {
        const double v = t.number(r, column);
        if (std::isfinite(v))
          xs.insert(v);
      }
      // Three digits, each value once (J = gdot / P of the rows differ in the last digits).
      std::string out, last;
      for (double x : xs) {
        const std::string t = num(x, 3);
        if (t != last)
          out += (out.empty() ? "" : ", ") + t;
        last = t;
      }
      return out;
    };
    auto sizes = [](const Table& t) {
      std::set<long long> ns;
      for (std::size_t r = 0; r < t.rows.size(); ++r)
        ns.insert(static_cast<long long>(t.number(r, "N")));
      std::string out;
      for (long long n : ns)
        out += (out.empty() ? "" : ", ") + std::to_string(n);
      return out;
    };
    md << "Harmonic spheres (alpha_r = 2). The constant-pressure table: N = " << sizes(cp_table)
       << "; P = " << values(cp_table, "imposed_pressure") << "; J = " << values(cp_table, "J")
       << "; replicas per point: " << values(cp_table, "replicas")
       << ". The constant-volume table: N = " << sizes(cv_table)
       << "; phi = " << values(cv_table, "system.phi")
       << "; gdot = " << values(cv_table, "shear_rate")
       << "; replicas per point: " << values(cv_table, "replicas")
       << ". Integrators per point: the tables' integrator column. The preset `"
       << preset.pressure.name << "` now: constant pressure, " << preset.pressure.why
       << "; constant volume, " << preset.volume.why << ".\n\n";
  }
  md << "- Constant pressure: " << cp.plan.points.size() << " points x " << cp.plan.replicas
     << " replicas, " << cp.finished
     << " finished in every replica (constant-pressure/table.csv).\n";
  md << "- Constant volume: " << cv.plan.points.size() << " points x " << cv.plan.replicas
     << " replicas, " << cv.finished << " finished (constant-volume/table.csv).\n";
  md << cost;
  if (result.is_object() && result.contains("point_errors"))
    md << result.at("point_errors").at("description").as_string() << "\n\n";
  md << "## Verdicts\n\n"
     << verdicts_markdown(cp_table, "constant-pressure")
     << verdicts_markdown(cv_table, "constant-volume");

  md << "## Joint fit of the soft granular rheology (every pressure and J at once)\n\n";
  md << "phi(P,J) = phi_J0 + c_phi P^x - C_phi J^b_phi and mu(P,J) = mu_J0 - c_mu P^y + C_mu "
        "J^b_mu are fitted to all constant-pressure points at once (the paper fitted over the "
        "entire pressure range). Statistical errors: the standard deviations over "
        "parametric-bootstrap resamples (analysis.md). Systematic, the second error: the J "
        "window (the largest shift when the points at the largest or the smallest J are "
        "dropped), the fit form (the shift when the paper's J-shape C_phi, b_phi, C_mu, b_mu at "
        "this N is fixed instead of fitted) and the pressure window (the same with the largest "
        "or smallest P), in quadrature. Paper values: x, y and alpha = 1/x from Sec. V A; "
        "phi_J0, mu_J0 and the J-shape from Table 2's size law O(N) = O_inf + A_O N^-alpha_O at "
        "the data's N, the same values everywhere in this report and in analysis.md.\n\n";
  if (analysis_status != 0)
    md << "`jamflow analyze soft` exited with status " << analysis_status
       << " (its messages are on the standard error of this study; analysis.md when it was "
          "written): what it could not fit is missing here.\n\n";
  if (result.is_object() && result.contains("sizes")) {
    for (const auto& [n, size] : result.at("sizes").members()) {
      const double nn = std::stod(n);
      md << "### N = " << n << "\n\n";
      if (!size.contains("joint")) {
        md << "Not fitted: "
           << (size.contains("joint_skipped") ? size.at("joint_skipped").as_string() : "")
           << "\n\n";
        continue;
      }
      const auto& joint = size.at("joint");
      std::vector<std::vector<std::string>> rows;
      for (const char* p : {"x", "y", "alpha", "phi_J0", "mu_J0", "c_phi", "c_mu", "C_phi", "b_phi",
                            "C_mu", "b_mu"}) {
        const JointNumber v = joint_number(joint, p, nn);
        if (!v.present)
          continue;
        const double total =
            std::isfinite(v.systematic) ? std::hypot(v.stat, v.systematic) : v.stat;
        rows.push_back(
            {p, pm(v.value, v.stat), opt_num(v.j_window), opt_num(v.form), opt_num(v.p_window),
             opt_num(v.systematic),
             std::isfinite(v.paper) ? num(v.paper, 4) + " (" + v.paper_source + ")" : "-",
             pull_text(v.value, v.stat, v.paper),
             std::isfinite(v.systematic) ? pull_text(v.value, total, v.paper) : "-"});
      }
      md << markdown_table(
                {"parameter", "joint fit +- statistical", "J window", "fit form", "pressure window",
                 "systematic (quadrature)", "paper", "difference (sigma, statistical)",
                 "difference (sigma, with systematic)"},
                rows)
         << "\n";
      // phi_J0 and mu_J0 against the same paper values, and what the numbers support.
      md << "phi_J0 and mu_J0 are compared with the paper's law at N = " << n << " ("
         << num(paper_value("phi_J0", nn), 4) << ", " << num(paper_value("mu_J0", nn), 4)
         << "), the data's size, not with its N -> infinity values ("
         << num(paper_value("phi_J0", 0.0), 4) << ", " << num(paper_value("mu_J0", 0.0), 4)
         << ").\n\n";
      for (const char* p : {"phi_J0", "mu_J0", "x", "y"}) {
        const std::string sentence = comparison_sentence(p, joint_number(joint, p, nn));
        if (!sentence.empty())
          md << "- " << sentence << "\n";
      }
      md << "\n";
      for (const char* p : {"x", "y"}) {
        const std::string t = local_exponent_text(joint, p);
        if (!t.empty())
          md << t << "\n\n";
      }
      double yv = 0.0, ye = 0.0;
      if (measured(joint, "y", yv, ye)) {
        if (ye <= kYTarget) {
          md << "y is resolved to +-" << num(ye, 2) << " statistically (the target is +-"
             << kYTarget << ").\n\n";
        } else {
          md << "**y is not resolved to +-" << kYTarget << "** (+-" << num(ye, 2) << "):\n\n";
        }
      }
      if (joint.contains("resolution_notes")) {
        const auto& notes = joint.at("resolution_notes");
        for (std::size_t i = 0; i < notes.size(); ++i)
          md << "- " << notes.at(i).as_string() << "\n";
        if (notes.size() > 0)
          md << "\n";
      }
      if (joint.contains("yield_data")) {
        const auto& y = joint.at("yield_data");
        md << "Yield stress: the law's sigma_Y(phi) ~ (phi - phi_J0)^(1/x) against "
           << y.at("phi").size() << " constant-volume points above phi_J0 ("
           << num(y.at("points_at_or_below_phi_J0").as_number(), 3)
           << " at or below it are not compared). The law at each point's (phi, gdot) misses "
              "the measured stress by a mean squared pull of "
           << num(y.at("mean_square_pull").as_number(), 3)
           << " (1 would be agreement within the errors); analysis.md lists every point.\n\n";
      }
      if (size.contains("collapse_skipped"))
        md << "The paper's per-pressure collapse (analysis.md) was not done: "
           << size.at("collapse_skipped").as_string() << "\n\n";
    }
  }
  md << "Figures: analysis_fig8_joint_N*.png (the seed's Fig. 8 from the joint fit: phi_J(P) - "
        "phi and mu - mu_J(P) against J for each P, and phi_J(P), mu_J(P)), "
        "analysis_yield_N*.png (the yield stress against phi - phi_J0, the measured stresses "
        "and the law at the same rates); analysis_fig8_N*.png when the per-pressure collapse "
        "was done. Details: analysis.md.\n";
  return md.str();
}

namespace {

int report(const soft_rheology::Preset& preset, const SweepStudy& cp, const SweepStudy& cv,
           const StudyOptions& options, double wall_seconds) {
  const std::string out = options.out_dir;
  const std::string json_path = (fs::path(out) / "analysis.json").string();
  // 1. The analysis, as `jamflow analyze soft CP_TABLE --yield-data CV_TABLE -o analysis.json`
  //    runs it: the joint fit is kept when the per-pressure collapse cannot be done.
  analysis::SoftOptions soft;
  soft.require_collapse = false;
  const int analysis_status =
      analysis::analyze_soft_files({cp.table}, {cv.table}, soft, {json_path, !options.no_plots});
  const analysis::Json result = read_analysis(kStudy, json_path);
  const Table cp_table = read_table(cp.table), cv_table = read_table(cv.table);

  // 2. HDF5: both tables and the joint fit per N.
  {
    H5Writer w((fs::path(out) / (std::string(kStudy) + ".h5")).string());
    w.attr("/", "study", kStudy);
    w.attr("/", "preset", preset.pressure.name);
    w.attr("/", "analysis_status", static_cast<std::int64_t>(analysis_status));
    write_h5_table(w, "/constant_pressure", cp_table.header, cp_table.rows);
    write_h5_table(w, "/constant_volume", cv_table.header, cv_table.rows);
    if (result.is_object() && result.contains("sizes")) {
      for (const auto& [n, size] : result.at("sizes").members()) {
        if (!size.contains("joint"))
          continue;
        const std::string g = "/joint/N" + n;
        w.group("/joint");
        w.group(g);
        for (const char* p : {"phi_J0", "c_phi", "x", "C_phi", "b_phi", "mu_J0", "c_mu", "y",
                              "C_mu", "b_mu", "alpha"}) {
          double v = 0.0, e = 0.0;
          if (measured(size.at("joint"), p, v, e)) {
            w.attr(g, p, v);
            w.attr(g, std::string(p) + "_err", e);
          }
        }
      }
    }
    w.commit();
  }

  // 3. The report.
  const std::string cost =
      options.report_only
          ? cost_line_from_tables({&cp_table, &cv_table},
                                  cp.cpu_hours_estimate + cv.cpu_hours_estimate)
          : cost_line(out, cp.cpu_hours_estimate + cv.cpu_hours_estimate, wall_seconds);
  write_text((fs::path(out) / "report.md").string(),
             soft_rheology::report_markdown(preset, cp, cv, cp_table, cv_table, result,
                                            analysis_status, cost));
  if (!options.quiet)
    std::printf("%s: %s\n", kStudy, (fs::path(out) / "report.md").c_str());
  return analysis_status == 0 ? 0 : 1;
}

int run(const StudyOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const soft_rheology::Preset preset = soft_rheology::preset(options.preset);
  StudyOptions cp_options = options, cv_options = options;
  cp_options.out_dir = (fs::path(options.out_dir) / "constant-pressure").string();
  cv_options.out_dir = (fs::path(options.out_dir) / "constant-volume").string();
  if (options.report_only)
    return report(preset, existing_sweep(cp_options.out_dir), existing_sweep(cv_options.out_dir),
                  options, 0.0);
  SweepStudy cp, cv;
  const auto cp_status =
      run_sweep_study(kStudy, pressure_sweep_text(preset.pressure), cp_options, cp);
  if (cp_status && *cp_status != 0)
    return *cp_status;  // stopped: the checkpoints continue on the next run
  const auto cv_status = run_sweep_study(kStudy, volume_sweep_text(preset.volume), cv_options, cv);
  if (cv_status || cp_status) {
    if (options.dry_run)
      std::printf("%s --preset %s: both sweeps together about %.3g CPU-hours\n", kStudy,
                  options.preset.c_str(), cp.cpu_hours_estimate + cv.cpu_hours_estimate);
    return cv_status.value_or(0);
  }
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report(preset, cp, cv, options, wall);
}

const Registrar reg{{kStudy,
                     "soft granular rheology: phi_J(P), mu_J(P) with exponents x, y fitted "
                     "jointly over every P and J, and the yield stress above phi_J (Fig. 8)",
                     run, true}};

}  // namespace
}  // namespace jamflow::studies
