// `jamflow compare` (framework/compare.hpp): the stages of a comparison (preparations, settings,
// settings continued from settings; every case's together) on the sweep engine, the analysis
// of each case, and its report. The compare file and its scenes: compare_plan.cpp.
#include "framework/compare.hpp"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "analysis/compare.hpp"
#include "driver/run.hpp"
#include "driver/verdicts.hpp"
#include "framework/report.hpp"
#include "framework/stage.hpp"
#include "lib/cli_exit.hpp"
#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "lib/statistics.hpp"
#include "lib/text_file.hpp"
#include "lib/xyz.hpp"
#include "sweep/mpi.hpp"
#include "sweep/slurm.hpp"

namespace jamflow::studies {

namespace fs = std::filesystem;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// One observable as a sampled field, times a factor (eta = sigma_xy / gdot).
struct Field {
  double Sample::*member = &Sample::sigma_xy;
  double factor = 1.0;
};
Field field_of(const std::string& name, double gdot) {
  if (name == "pressure")
    return {&Sample::pressure, 1.0};
  if (name == "phi")
    return {&Sample::phi, 1.0};
  if (name == "energy")
    return {&Sample::energy, 1.0};
  if (name == "dissipation")
    return {&Sample::dissipation, 1.0};
  if (name == "eta")
    return {&Sample::sigma_xy, gdot > 0.0 ? 1.0 / gdot : kNaN};
  return {&Sample::sigma_xy, 1.0};
}

// The averaging window of a run: samples after t_eq (as the summary and paired_error take it).
std::vector<double> window_values(const DiagnosedRun& r, const Field& f) {
  std::vector<double> x;
  for (const Sample& s : r.result.series.samples)
    if (s.time > r.t_eq + 1e-6)
      x.push_back(s.*(f.member) * f.factor);
  return x;
}

double sample_interval(const DiagnosedRun& r) {
  const auto& s = r.result.series.samples;
  return s.size() >= 2 ? s[1].time - s[0].time : kNaN;
}

// Why a finished run is not stable: a failed run, or its stable verdict (energy balance, force
// step correlation; driver/verdicts.hpp) failed. Empty: stable.
// With diagnose, the diagnostic window's classification too (oscillating, diverged).
std::string unstable_reason(const DiagnosedRun& r, bool diagnose) {
  if (!r.result.status.is_complete())
    return r.verdict_text();
  if (diagnose && (r.cls.verdict == Verdict::kOscillating || r.cls.verdict == Verdict::kDiverged))
    return r.verdict_text();
  const jamflow::Verdict& stable = r.result.summary.stable;
  return stable.failed() ? stable.text() : std::string();
}

struct SettingRuns {
  std::vector<DiagnosedRun> replicas;  // one per replica (replica k from prepared state k)
  double balance = kNaN, balance_err = kNaN, step_correlation = kNaN;
  int steady_failed = 0, decorrelated_failed = 0;
  std::string integrator, ensemble;
};

analysis::CompareInput analysis_input(const ComparePlan& plan,
                                      const std::vector<SettingRuns>& runs) {
  analysis::CompareInput in;
  in.observables = plan.observables;
  in.reference = plan.reference;
  in.blocks = static_cast<std::size_t>(plan.blocks);
  in.tolerance_sigma = plan.tolerance_sigma;
  in.relative_tolerance = plan.relative_tolerance;
  const SettingRuns& ref = runs[plan.reference];
  for (std::size_t s = 0; s < plan.settings.size(); ++s) {
    analysis::SettingInput si;
    si.label = plan.settings[s].label;
    si.ensemble = runs[s].ensemble;
    si.particles = double(plan.settings[s].n);
    si.converged = plan.settings[s].converged;
    bool all_complete = true;
    for (const auto& r : runs[s].replicas) {
      si.over_budget = si.over_budget || r.result.status.is_budget();
      const std::string why = unstable_reason(r, plan.diagnose);
      if (!why.empty() && si.why_unstable.empty())
        si.why_unstable = r.label + ": " + why;
      si.stable = si.stable && why.empty();
      si.steady = si.steady && !r.result.summary.steady.failed();
      all_complete = all_complete && r.result.status.is_complete();
    }
    // Pairs need every replica: a setting whose preparation failed for some replica did not run
    // that replica, and is not analysed.
    if (all_complete && runs[s].replicas.size() == static_cast<std::size_t>(plan.replicas)) {
      si.observables.resize(plan.observables.size());
      for (std::size_t k = 0; k < runs[s].replicas.size(); ++k) {
        const DiagnosedRun& r = runs[s].replicas[k];
        const auto& samples = r.result.series.samples;
        const double t_total = samples.empty() ? kNaN : samples.back().time;
        si.cpu_per_tau.push_back(r.cpu_seconds / t_total);
        for (std::size_t o = 0; o < plan.observables.size(); ++o) {
          const Field f = field_of(plan.observables[o], r.gdot);
          const std::vector<double> x = window_values(r, f);
          analysis::ReplicaObservable ro;
          if (x.size() < static_cast<std::size_t>(plan.blocks)) {
            ro.mean = ro.block_error = ro.block_std = ro.tau = ro.paired_error = kNaN;
          } else {
            const BlockAverage b = block_average(x, static_cast<std::size_t>(plan.blocks));
            ro.mean = b.mean;
            ro.block_error = b.error;
            ro.block_std = b.block_std;
            ro.tau = integrated_autocorrelation(x) * sample_interval(r);
            ro.paired_error = kNaN;
            if (k < ref.replicas.size() && ref.replicas[k].result.status.is_complete()) {
              const Field rf = field_of(plan.observables[o], ref.replicas[k].gdot);
              if (rf.factor == f.factor)
                ro.paired_error =
                    paired_error(r.result.series, ref.replicas[k].result.series, r.t_eq, f.member,
                                 static_cast<std::size_t>(plan.blocks)) *
                    std::abs(f.factor);
            }
          }
          si.observables[o].push_back(ro);
        }
      }
    }
    in.settings.push_back(std::move(si));
  }
  return in;
}

// Fills the per-setting diagnostics the table reports beside the analysis: energy balance, force
// step correlation and the verdict counts (means over the finished replicas).
void diagnostics_of(SettingRuns& sr) {
  double b = 0.0, be = 0.0, c = 0.0;
  int nb = 0, nc = 0;
  for (const auto& r : sr.replicas) {
    if (!r.result.status.is_complete())
      continue;
    if (r.balance.valid) {
      b += r.balance.ratio;
      be += r.balance.error * r.balance.error;
      ++nb;
    }
    const double corr = r.result.summary.force_step_correlation.value_or(kNaN);
    if (std::isfinite(corr)) {
      c += corr;
      ++nc;
    }
    sr.steady_failed += r.result.summary.steady.failed();
    sr.decorrelated_failed += r.result.summary.decorrelated.failed();
  }
  if (nb > 0) {
    sr.balance = b / nb;
    sr.balance_err = std::sqrt(be) / nb;
  }
  if (nc > 0)
    sr.step_correlation = c / nc;
}

std::string csv_num(double v) {
  if (!std::isfinite(v))
    return "";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

// Each replica's class after its diagnostic window, the same ones counted once ("oscillating x
// 2; stable x 1"); empty without diagnose = true.
std::string window_classes(const ComparePlan& plan, const SettingRuns& sr) {
  if (!plan.diagnose)
    return {};
  std::map<std::string, int> seen;
  for (const DiagnosedRun& d : sr.replicas)
    ++seen[verdict_name(d.cls.verdict) + (d.cls.laned ? ", lanes" : "")];
  std::string cell;
  for (const auto& [text, count] : seen)
    cell += (cell.empty() ? "" : "; ") + text + " × " + std::to_string(count);
  return cell;
}

std::string table_csv(const ComparePlan& plan, const std::vector<SettingRuns>& runs,
                      const analysis::CompareResult& res) {
  std::ostringstream os;
  os << "setting,reference,integrator,dt,rtol,ensemble,N,replicas,stable,within,rank,recommended,"
        "cpu_per_tau,cpu_per_tau_err,cpu_per_particle_tau,cpu_per_particle_tau_err,"
        "energy_balance,energy_balance_err,force_step_correlation,steady_failed,"
        "decorrelated_failed,window";
  for (const auto& o : plan.observables)
    for (const char* c : {"", "_err", "_diff", "_diff_err", "_diff_source", "_floor", "_z",
                          "_block_std", "_block_std_err", "_replica_std", "_replica_std_err",
                          "_block_std_ratio", "_block_std_ratio_err", "_replica_std_ratio",
                          "_replica_std_ratio_err", "_tau", "_tau_err"})
      os << "," << o << c;
  os << ",why_unstable\n";
  for (std::size_t s = 0; s < res.settings.size(); ++s) {
    const auto& r = res.settings[s];
    const auto& sr = runs[s];
    const CompareMethod m = compare_method(plan, s);  // dt and rtol where the kind has them
    os << r.label << "," << (s == plan.reference ? 1 : 0) << "," << sr.integrator << ","
       << csv_num(m.dt) << "," << csv_num(m.rtol) << "," << sr.ensemble << "," << plan.settings[s].n
       << "," << sr.replicas.size() << "," << (r.stable ? 1 : 0) << "," << (r.within ? 1 : 0) << ","
       << r.rank << "," << (int(s) == res.recommended ? 1 : 0) << ","
       << csv_num(r.cpu_per_tau.value) << "," << csv_num(r.cpu_per_tau.error) << ","
       << csv_num(r.cpu_per_particle_tau.value) << "," << csv_num(r.cpu_per_particle_tau.error)
       << "," << csv_num(sr.balance) << "," << csv_num(sr.balance_err) << ","
       << csv_num(sr.step_correlation) << "," << sr.steady_failed << "," << sr.decorrelated_failed
       << ",";
    std::string window = window_classes(plan, sr);  // "stable, lanes": no commas in a cell
    std::replace(window.begin(), window.end(), ',', ';');
    os << window;
    for (std::size_t o = 0; o < plan.observables.size(); ++o) {
      if (o >= r.observables.size()) {
        for (int c = 0; c < 17; ++c)
          os << ",";
        continue;
      }
      const auto& x = r.observables[o];
      os << "," << csv_num(x.mean.value) << "," << csv_num(x.mean.error) << ","
         << csv_num(x.difference.value) << "," << csv_num(x.difference.error) << ","
         << analysis::error_source_name(x.source) << "," << csv_num(x.floor) << "," << csv_num(x.z)
         << "," << csv_num(x.block_std.value) << "," << csv_num(x.block_std.error) << ","
         << csv_num(x.replica_std.value) << "," << csv_num(x.replica_std.error) << ","
         << csv_num(x.block_std_ratio.value) << "," << csv_num(x.block_std_ratio.error) << ","
         << csv_num(x.replica_std_ratio.value) << "," << csv_num(x.replica_std_ratio.error) << ","
         << csv_num(x.tau.value) << "," << csv_num(x.tau.error);
    }
    std::string why = r.stable ? "" : r.why_unstable;
    std::replace(why.begin(), why.end(), ',', ';');
    std::replace(why.begin(), why.end(), '\n', ' ');
    os << "," << why << "\n";
  }
  return os.str();
}

void write_h5(const std::string& path, const ComparePlan& plan,
              const std::vector<SettingRuns>& runs, const analysis::CompareResult& res) {
  H5Writer w(path);
  w.attr("/", "compare_file", plan.path);
  w.attr("/", "reference", plan.settings[plan.reference].label);
  w.attr("/", "replicas", plan.replicas);
  w.attr("/", "tolerance_sigma", plan.tolerance_sigma);
  w.attr("/", "recommended",
         res.recommended >= 0 ? plan.settings[std::size_t(res.recommended)].label : "");
  w.attr("/", "base_scene", plan.base.text());
  for (std::size_t o = 0; o < plan.observables.size() && o < res.converged_scatter.size(); ++o) {
    const auto& c = res.converged_scatter[o];
    const std::string g = "/observables/" + plan.observables[o];
    w.group(g);
    w.attr(g, "converged_settings", static_cast<std::int64_t>(c.settings));
    w.attr(g, "converged_reduced_chi2", c.reduced_chi2);
    w.attr(g, "error_scale", c.error_scale);
  }
  for (std::size_t s = 0; s < res.settings.size(); ++s) {
    const auto& r = res.settings[s];
    const auto& sr = runs[s];
    const std::string g = "/settings/" + r.label;
    w.group(g);
    w.attr(g, "index", static_cast<std::int64_t>(s));
    w.attr(g, "integrator", sr.integrator);
    w.attr(g, "ensemble", sr.ensemble);
    w.attr(g, "N", plan.settings[s].n);
    w.attr(g, "stable", static_cast<std::int64_t>(r.stable));
    w.attr(g, "why_unstable", r.why_unstable);
    w.attr(g, "over_budget", static_cast<std::int64_t>(r.over_budget));
    w.attr(g, "converged", static_cast<std::int64_t>(plan.settings[s].converged));
    w.attr(g, "within", static_cast<std::int64_t>(r.within));
    w.attr(g, "rank", static_cast<std::int64_t>(r.rank));
    w.attr(g, "cpu_per_tau", r.cpu_per_tau.value);
    w.attr(g, "cpu_per_tau_err", r.cpu_per_tau.error);
    w.attr(g, "cpu_per_particle_tau", r.cpu_per_particle_tau.value);
    w.attr(g, "energy_balance", sr.balance);
    w.attr(g, "energy_balance_err", sr.balance_err);
    w.attr(g, "force_step_correlation", sr.step_correlation);
    if (!sr.replicas.empty())
      w.attr(g, "scene", sr.replicas.front().scene_text);
    // Every replica's sampled series of the observables (the transient too), for plots.
    for (std::size_t k = 0; k < sr.replicas.size(); ++k) {
      const DiagnosedRun& rr = sr.replicas[k];
      const std::string rg = g + "/replicas/" + std::to_string(k);
      w.dataset(rg + "/time", rr.result.series.column(&Sample::time));
      w.attr(rg, "t_eq", rr.t_eq);
      w.attr(rg, "verdict", rr.verdict_text());
      if (plan.diagnose)
        w.attr(rg, "lanes", static_cast<std::int64_t>(rr.cls.laned));
      for (const auto& name : plan.observables) {
        const Field f = field_of(name, rr.gdot);
        std::vector<double> x = rr.result.series.column(f.member);
        for (double& v : x)
          v *= f.factor;
        w.dataset(rg + "/" + name, x);
      }
    }
    for (std::size_t o = 0; o < r.observables.size(); ++o) {
      const auto& x = r.observables[o];
      const std::string og = g + "/" + plan.observables[o];
      w.group(og);
      w.attr(og, "mean", x.mean.value);
      w.attr(og, "mean_err", x.mean.error);
      w.attr(og, "difference", x.difference.value);
      w.attr(og, "difference_err", x.difference.error);
      w.attr(og, "difference_error_source", analysis::error_source_name(x.source));
      w.attr(og, "floor", x.floor);
      w.attr(og, "z", x.z);
      w.attr(og, "within", static_cast<std::int64_t>(x.within));
      w.attr(og, "block_std", x.block_std.value);
      w.attr(og, "block_std_err", x.block_std.error);
      w.attr(og, "replica_std", x.replica_std.value);
      w.attr(og, "replica_std_err", x.replica_std.error);
      w.attr(og, "block_std_ratio", x.block_std_ratio.value);
      w.attr(og, "block_std_ratio_err", x.block_std_ratio.error);
      w.attr(og, "replica_std_ratio", x.replica_std_ratio.value);
      w.attr(og, "replica_std_ratio_err", x.replica_std_ratio.error);
      w.attr(og, "tau", x.tau.value);
      w.attr(og, "tau_err", x.tau.error);
    }
  }
  w.commit();
}

// What the converged settings' scatter did to the errors (analysis::CompareResult).
std::string converged_text(const ComparePlan& plan, const analysis::CompareResult& res) {
  std::vector<std::string> marked;
  for (const auto& s : plan.settings)
    if (s.converged)
      marked.push_back("`" + s.label + "`");
  if (marked.empty())
    return {};
  std::string md =
      "Converged settings (converged = true: their differences from the reference "
      "are statistical only): " +
      join(marked) +
      ". Their stable runs and the reference's means scatter about their weighted "
      "mean with, per observable: ";
  for (std::size_t o = 0; o < plan.observables.size() && o < res.converged_scatter.size(); ++o) {
    const auto& c = res.converged_scatter[o];
    md += std::string(o ? "; " : "") + plan.observables[o] + " ";
    if (c.settings < 2) {
      md += "fewer than 2 settings, errors kept";
      continue;
    }
    md += "chi2/dof = " + num(c.reduced_chi2, 3) + " over " + std::to_string(c.settings) +
          (c.error_scale > 1.0 ? ", every error multiplied by " + num(c.error_scale, 3)
                               : std::string(", errors kept"));
  }
  return md +
         " (the errors of single runs understate the run-to-run scatter where chi2/dof > 1; "
         "the errors, floors, σ and the tolerance below include the factor).\n\n";
}

std::string report_md(const ComparePlan& plan, const std::vector<SettingRuns>& runs,
                      const analysis::CompareResult& res, bool plotted,
                      const std::vector<DiagnosedRun>& preps, const std::string& section,
                      const std::string& cost) {
  const std::string ref = plan.settings[plan.reference].label;
  std::string md = "# Comparison `" + plan.name + "`\n\n";
  md += std::to_string(plan.settings.size()) + " settings, " + std::to_string(plan.replicas) +
        " replica" + (plan.replicas > 1 ? "s" : "") + " each, against the reference `" + ref +
        "`. ";
  md += plan.init.empty()
            ? "Replica k of every setting continues from prepared state k (a run of t = " +
                  short_num(plan.prepare_t) + " from a random state with seed " +
                  std::to_string(plan.seed) +
                  " + k, one per N), so differences are paired "
                  "replica by replica.\n\n"
            : "Every setting continues from `" + plan.init + "`.\n\n";
  md += cost;
  for (std::size_t i = 0; i < plan.settings.size(); ++i) {
    const CompareSetting& s = plan.settings[i];
    const std::string source =
        s.from.empty() ? std::string("prepared state") : "`" + s.from + "` run";
    if (!s.from.empty())
      md += "`" + s.label + "` continues from replica k of `" + s.from + "`" +
            (s.start_mean_phi ? "" : ", as it ended") + ".\n\n";
    if (s.start_mean_phi) {
      const auto& reps = runs[i].replicas;
      md += "`" + s.label + "` (constant volume) starts from each " + source +
            " dilated affinely to one packing fraction, the mean over the steady replicas of "
            "their window-mean phi (start = \"mean_phi\")" +
            (reps.empty() ? std::string()
                          : ": phi = " + num(reps.front().result.summary.phi.value, 6)) +
            ".\n\n";
    }
  }
  // A preparation that still drifts at its end leaves the rest of the transient to the
  // settings' t_eq; one that did not finish leaves its replica out.
  std::vector<std::string> drifting_preps;
  for (const DiagnosedRun& p : preps) {
    if (!p.result.status.is_complete())
      md += "Preparation " + p.label + " did not finish (" + p.verdict_text() +
            "): the settings that start from it are not analysed (to retry, remove its "
            "folder under prepare/runs/points/ and run again).\n\n";
    else if (p.result.summary.steady.failed())
      drifting_preps.push_back(p.label + " (" + p.result.summary.steady.why + ")");
  }
  if (!drifting_preps.empty())
    md +=
        "Preparations that still drift in their second half, so that the settings' t_eq has "
        "to absorb the rest of their transient: " +
        join(drifting_preps) + ".\n\n";
  md += "Observables: " + join(plan.observables) +
        ". A setting is within tolerance when it is "
        "stable, steady (every replica) and, for every observable, |difference| <= " +
        short_num(plan.tolerance_sigma) + " x its error";
  bool any_rel = false;
  for (std::size_t o = 0; o < plan.observables.size(); ++o)
    if (plan.relative_tolerance[o] > 0.0) {
      md += std::string(any_rel ? ", " : " or, relative to the reference, ") + plan.observables[o] +
            " <= " + short_num(plan.relative_tolerance[o]);
      any_rel = true;
    }
  md +=
      ". Errors of a difference come from the scatter of the paired differences over the "
      "replicas with " +
      std::to_string(kMinReplicasForScatter) +
      " replicas or more, else from the block errors of the paired difference "
      "series (the table says which). The floor is the reference's own error. CPU cost is "
      "each run's CPU seconds (its `jamflow run` process, one thread) over its simulated time "
      "(t_eq + t_av), per tau_0 and per particle and tau_0.\n\n";
  md += converged_text(plan, res);

  // Work-precision.
  md += "## Work and precision\n\n";
  std::vector<std::vector<std::string>> rows;
  for (std::size_t s = 0; s < res.settings.size(); ++s) {
    const auto& r = res.settings[s];
    std::vector<std::string> row = {
        r.label + (s == plan.reference ? " (reference)" : ""),
        runs[s].integrator,
        r.ensemble,
        r.stable ? "stable" : "**unstable**",
        r.ran ? pm(r.cpu_per_particle_tau.value, r.cpu_per_particle_tau.error, 3) : "—",
        r.ran ? std::to_string(r.rank) : "—"};
    for (std::size_t o = 0; o < plan.observables.size(); ++o) {
      if (o >= r.observables.size()) {
        row.push_back("—");
        continue;
      }
      const auto& x = r.observables[o];
      row.push_back(s == plan.reference
                        ? pm(x.mean.value, x.mean.error) + " (floor " + num(x.floor, 2) + ")"
                        : num(x.difference.value, 3) + " ± " + num(x.difference.error, 2) + " (" +
                              num(x.z, 2) + "σ, " + error_source_name(x.source) + ")");
    }
    row.push_back(r.within ? "yes" : "no");
    rows.push_back(std::move(row));
  }
  std::vector<std::string> header = {
      "setting", "integrator", "ensemble", "verdict", "CPU s per particle·τ0", "rank by error"};
  for (const auto& o : plan.observables)
    header.push_back("Δ" + o + " (reference: value)");
  header.push_back("within");
  md += markdown_table(header, rows) + "\n";
  if (plotted) {
    md +=
        "Work–precision plots (|difference| against CPU seconds per particle·τ0, log–log; "
        "dashed: the floor; crosses: unstable settings): ";
    for (std::size_t o = 0; o < plan.observables.size(); ++o)
      md += std::string(o ? ", " : "") + "`work_precision_" + plan.observables[o] + ".png`";
    md += "; every replica's series against time: `timeseries.png`.\n\n";
  } else {
    md += "Plots: not produced (see the warnings).\n\n";
  }

  // Stability.
  md += "## Stability\n\n";
  rows.clear();
  for (std::size_t s = 0; s < res.settings.size(); ++s) {
    const auto& r = res.settings[s];
    const auto& sr = runs[s];
    rows.push_back(
        {r.label, r.stable ? "stable" : "unstable: " + r.why_unstable,
         std::isfinite(sr.balance) ? pm(sr.balance, sr.balance_err, 3) : "—",
         std::isfinite(sr.step_correlation) ? num(sr.step_correlation, 3) : "—",
         std::to_string(sr.steady_failed) + " / " + std::to_string(sr.replicas.size()),
         std::to_string(sr.decorrelated_failed) + " / " + std::to_string(sr.replicas.size())});
    if (plan.diagnose) {
      const std::string cell = window_classes(plan, sr);
      rows.back().push_back(cell.empty() ? "—" : cell);
    }
  }
  std::vector<std::string> stability_header = {"setting",        "verdict",
                                               "energy balance", "force step correlation",
                                               "not steady",     "blocks < 2τ"};
  if (plan.diagnose)
    stability_header.push_back("diagnostic window (replicas)");
  md += markdown_table(stability_header, rows) + "\n";
  if (plan.diagnose)
    md +=
        "Diagnostic window (diagnose = true): after each run, 256 steps sampled at every step "
        "classify it as stable, oscillating (force step correlation < 0.9, or an energy "
        "deficit of a fixed-step integrator) or diverged, and flag lanes "
        "(studies/stability/README.md); an oscillating or diverged replica makes its setting "
        "unstable.\n\n";

  // Verdicts that weaken the comparison.
  int short_blocks = 0, drifting = 0, total = 0;
  for (const auto& sr : runs) {
    short_blocks += sr.decorrelated_failed;
    drifting += sr.steady_failed;
    total += static_cast<int>(sr.replicas.size());
  }
  if (drifting > 0)
    md += std::to_string(drifting) + " of " + std::to_string(total) +
          " runs failed the steady verdict (their windows drift): their settings are not "
          "recommended; lengthen [run] t_eq or the preparation.\n\n";
  if (short_blocks > 0)
    md += std::to_string(short_blocks) + " of " + std::to_string(total) +
          " runs have blocks shorter than 2 τ, so their block errors are too small" +
          (plan.replicas >= kMinReplicasForScatter
               ? std::string(": the differences' errors above come from the replica "
                             "scatter, which does not rely on the blocks")
               : std::string(", and so are the differences' errors above (too "
                             "few replicas for their scatter): lengthen [run] t_av or add "
                             "replicas")) +
          ".\n\n";

  // Fluctuations.
  md += "## Fluctuations\n\n";
  md += "Block std: the standard deviation of the " + std::to_string(plan.blocks) +
        " block means (mean over replicas); replica std: of the replica means (2 replicas or "
        "more). Ratios are the setting's over the reference's (`" +
        ref + "`, " + res.settings[plan.reference].ensemble +
        "), with errors propagated as independent "
        "relative errors. τ: the integrated autocorrelation time.\n\n";
  rows.clear();
  for (std::size_t s = 0; s < res.settings.size(); ++s) {
    const auto& r = res.settings[s];
    for (std::size_t o = 0; o < r.observables.size(); ++o) {
      const auto& x = r.observables[o];
      auto cell = [](const analysis::Estimate& e, int d) {
        return std::isfinite(e.value) ? pm(e.value, e.error, d) : std::string("—");
      };
      // An observable that does not fluctuate (phi at constant volume: its block means are all
      // the same) has no spread to compare; its replica spread is rounding.
      if (x.block_std.value == 0.0) {
        rows.push_back(
            {r.label, r.ensemble, plan.observables[o], "0 (constant)", "—", "—", "—", "—"});
        continue;
      }
      rows.push_back({r.label, r.ensemble, plan.observables[o], cell(x.block_std, 3),
                      cell(x.replica_std, 3), cell(x.block_std_ratio, 3),
                      cell(x.replica_std_ratio, 3), cell(x.tau, 3)});
    }
  }
  md += markdown_table({"setting", "ensemble", "observable", "block std", "replica std",
                        "block std / reference", "replica std / reference", "τ"},
                       rows) +
        "\n";

  md += section;

  // Recommendation.
  md += "## Recommendation\n\n";
  if (res.recommended >= 0) {
    const auto& r = res.settings[std::size_t(res.recommended)];
    md += "The cheapest setting within tolerance is **" + r.label + "** (" +
          runs[std::size_t(res.recommended)].integrator + ", " +
          num(r.cpu_per_particle_tau.value, 3) + " CPU s per particle·τ0";
    const auto& refr = res.settings[plan.reference];
    if (std::size_t(res.recommended) != plan.reference && refr.cpu_per_particle_tau.value > 0.0)
      md += ", " + num(refr.cpu_per_particle_tau.value / r.cpu_per_particle_tau.value, 3) +
            "x cheaper than the reference";
    md += ").\n\n";
  } else {
    md +=
        "No setting is within tolerance (the reference itself did not finish stable and "
        "steady).\n\n";
  }
  if (!res.over_budget.empty()) {
    md +=
        "Over their per-run budget (run.max_force_evaluations; too slow to finish, not "
        "analysed):\n\n";
    for (std::size_t s : res.over_budget)
      md += "- " + res.settings[s].label + ": " + res.settings[s].why_unstable + "\n";
    md += "\n";
  }
  if (res.unstable.empty()) {
    md += "Unstable settings: none.\n";
  } else {
    md += "Unstable settings:\n\n";
    for (std::size_t s : res.unstable)
      md += "- " + res.settings[s].label + ": " + res.settings[s].why_unstable + "\n";
  }
  return md;
}

// The steady finished runs' mean of a summary value (all finished runs' if none is steady):
// of phi, the packing fraction a start = "mean_phi" setting runs at; of the pressure, the one
// atol_overlaps takes at constant volume. NaN if none finished.
double pooled(const std::vector<const DiagnosedRun*>& runs, Estimate Summary::*observable) {
  std::vector<double> steady, all;
  for (const DiagnosedRun* r : runs) {
    if (!r || !r->result.status.is_complete() || r->final_xyz.empty() ||
        r->final_xyz == kCountedStart)
      continue;
    all.push_back((r->result.summary.*observable).value);
    if (!r->result.summary.steady.failed())
      steady.push_back(all.back());
  }
  const auto& use = steady.empty() ? all : steady;
  if (use.empty())
    return kNaN;
  return replica_average(use, std::vector<double>(use.size(), 0.0)).mean;
}

// `final_xyz` dilated affinely to `phi`, at time 0, as DIR/NAME.xyz: written whole under a unique
// name and renamed (MPI ranks may all get here), and not rewritten when a rerun finds it as it
// would write it. kCountedStart (a --dry-run) stays kCountedStart.
std::string dilated_start(const std::string& final_xyz, double phi, const std::string& dir,
                          const std::string& name) {
  if (final_xyz == kCountedStart)
    return kCountedStart;
  State st = read_xyz(final_xyz);
  st.box.set_volume(st.particle_volume() / phi);
  st.time = 0.0;
  ensure_dir(dir);
  const std::string file = dir + "/" + name + ".xyz";
  std::ostringstream text;
  write_xyz(text, st);
  std::ifstream old(file, std::ios::binary);
  const std::string before((std::istreambuf_iterator<char>(old)), std::istreambuf_iterator<char>());
  if (!old || before != text.str())
    write_text_atomically(file, text.str());
  return file;
}

// The start of replica k of setting s from its source's runs (`source[k]`: the preparation at
// its N, or its `from` setting; null if that replica did not run): the source's final state, or
// with start = "mean_phi" that state at the source's pooled mean phi. Empty: no start (the
// source did not finish).
std::string start_of(const ComparePlan& plan, std::size_t s, std::size_t k,
                     const std::vector<const DiagnosedRun*>& source, const std::string& out_dir) {
  const DiagnosedRun* r = k < source.size() ? source[k] : nullptr;
  if (!r || !r->result.status.is_complete() || r->final_xyz.empty())
    return {};
  if (!plan.settings[s].start_mean_phi || r->final_xyz == kCountedStart)
    return r->final_xyz;
  const double phi = pooled(source, &Summary::phi);
  const bool from_setting = !plan.settings[s].from.empty();
  return dilated_start(r->final_xyz, phi,
                       out_dir + (from_setting ? "/settings/mean_phi" : "/prepare/mean_phi"),
                       r->label);
}

}  // namespace

namespace {

// One comparison of a run: the plan (a case's, or the whole file's), where its runs are in the
// joint stages, and where it reports.
struct CaseRuns {
  const ComparePlan* plan = nullptr;
  std::string prefix;  // of its point labels: "<case>." ("" without cases)
  std::string out;     // its report's folder: OUT/<case> (OUT without cases)
  std::map<std::int64_t, std::vector<const DiagnosedRun*>> prepared;  // N -> replica k
  std::vector<const DiagnosedRun*> preps;
  // Per stage (settings, continued): (setting, replica) of each of its runs, and where the run is
  // in that stage's results.
  std::vector<std::vector<std::pair<std::size_t, std::size_t>>> index{2};
  std::vector<std::vector<std::size_t>> at{2};
};

// Every setting and replica of one case, with its analysis.
struct CaseAnalysis {
  std::vector<SettingRuns> runs;
  analysis::CompareResult result;
  std::string csv;  // its table.csv, once written
};
CaseAnalysis analyse_case(const CaseRuns& c, std::vector<std::vector<DiagnosedRun>>& done) {
  const ComparePlan& plan = *c.plan;
  CaseAnalysis a;
  a.runs.resize(plan.settings.size());
  for (std::size_t s = 0; s < plan.settings.size(); ++s) {
    const Scene scene = plan.setting_scene(s);
    a.runs[s].integrator = scene.section("integrator").text("kind", "?");
    a.runs[s].ensemble = scene.section("ensemble").text("kind", "?");
  }
  for (int stage = 0; stage < 2; ++stage)
    for (std::size_t q = 0; q < c.index[stage].size(); ++q)
      a.runs[c.index[stage][q].first].replicas.push_back(std::move(done[stage][c.at[stage][q]]));
  for (auto& sr : a.runs)
    diagnostics_of(sr);
  a.result = analysis::compare(analysis_input(plan, a.runs));
  return a;
}

// A case's outputs under c.out: table.csv, compare.h5, the plots and report.md (with `section`).
void write_case(const CaseRuns& c, CaseAnalysis& a, const StudyOptions& options,
                const std::string& section, const std::string& cost) {
  const ComparePlan& plan = *c.plan;
  const analysis::CompareResult& res = a.result;
  ensure_dir(c.out);
  a.csv = table_csv(plan, a.runs, res);
  write_text(c.out + "/table.csv", a.csv);
  write_h5(c.out + "/compare.h5", plan, a.runs, res);
  const bool plotted =
      run_plot("compare/plot.py", {c.out + "/table.csv", c.out, c.out + "/compare.h5"}, options);
  std::vector<DiagnosedRun> preps;
  for (const DiagnosedRun* p : c.preps)
    preps.push_back(*p);
  write_text(c.out + "/report.md", report_md(plan, a.runs, res, plotted, preps, section, cost));
  if (!options.quiet) {
    std::printf("compare %s: %zu settings -> %s/report.md\n", plan.name.c_str(),
                plan.settings.size(), c.out.c_str());
    if (res.recommended >= 0)
      std::printf("  cheapest within tolerance: %s\n",
                  plan.settings[std::size_t(res.recommended)].label.c_str());
    for (std::size_t s : res.unstable)
      std::printf("  unstable: %s\n", plan.settings[s].label.c_str());
  }
}

// With [[case]]: OUT/table.csv (every case's rows, a `case` column first) and OUT/report.md (per
// case the recommendation and the unstable settings, and where its report is; then `section`).
void write_cases_summary(const ComparePlan& top, const std::vector<CaseRuns>& cases,
                         const std::vector<CaseAnalysis>& analyses, const std::string& out,
                         const std::string& section, const std::string& cost) {
  std::string csv,
      md = "# Comparison `" + top.name + "`: " + std::to_string(cases.size()) + " cases\n\n";
  md += "The settings against the reference `" + top.settings[top.reference].label +
        "` (or the case's own) in each case; each case's report is in its folder.\n\n" + cost;
  std::vector<std::vector<std::string>> rows;
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const ComparePlan& plan = *cases[i].plan;
    const analysis::CompareResult& res = analyses[i].result;
    std::vector<std::string> unstable;
    for (std::size_t s : res.unstable)
      unstable.push_back(plan.settings[s].label);
    rows.push_back({"[" + plan.label + "](" + plan.label + "/report.md)",
                    plan.settings[plan.reference].label,
                    res.recommended >= 0 ? plan.settings[std::size_t(res.recommended)].label
                                         : std::string("none"),
                    unstable.empty() ? std::string("none") : join(unstable)});
    std::istringstream in(analyses[i].csv);
    std::string line;
    for (bool header = true; std::getline(in, line); header = false) {
      if (header && !csv.empty())
        continue;
      csv += (header ? std::string("case,") : plan.label + ",") + line + "\n";
    }
  }
  md += markdown_table({"case", "reference", "cheapest within tolerance", "unstable"}, rows);
  if (!section.empty())
    md += "\n" + section;
  write_text(out + "/table.csv", csv);
  write_text(out + "/report.md", md);
}

}  // namespace

int run_compare(const ComparePlan& top, const StudyOptions& options,
                const CompareReportSection& section, const std::vector<std::string>& plot_scripts,
                const CompareFollowUp& follow_up) {
  if (!top.study_keys.empty() && !follow_up && !section)
    throw ConfigError(top.path + ": [study] " + std::string(top.study_keys.begin()->first.str()) +
                      "; allowed only in a study's own plan (studies/<study>/<preset>.toml)");
  ensure_dir(options.out_dir);
  const std::string study = top.study.empty() ? "compare" : top.study;
  std::vector<CaseRuns> cases;
  const std::vector<ComparePlan>& plans = top.cases;
  auto add_case = [&](const ComparePlan& plan, std::string prefix, std::string out) {
    CaseRuns c;
    c.plan = &plan;
    c.prefix = std::move(prefix);
    c.out = std::move(out);
    cases.push_back(std::move(c));
  };
  if (plans.empty())
    add_case(top, "", options.out_dir);
  for (const ComparePlan& plan : plans)
    add_case(plan, plan.label + ".", options.out_dir + "/" + plan.label);

  // Stage 1: one preparation per case, N and replica (seed + k), unless an init file starts them.
  std::vector<DiagnosedRun> preps;
  {
    std::vector<RunRequest> requests;
    std::vector<std::pair<std::size_t, std::int64_t>> owner;  // case, N
    for (std::size_t i = 0; i < cases.size(); ++i) {
      const ComparePlan& plan = *cases[i].plan;
      if (!plan.init.empty())
        continue;
      const auto sizes = plan.sizes();
      for (std::int64_t n : sizes) {
        for (std::size_t k = 0; k < std::size_t(plan.replicas); ++k) {
          RunRequest r;
          r.label = cases[i].prefix +
                    (sizes.size() > 1 ? "prepare_N" + std::to_string(n) : std::string("prepare")) +
                    "_r" + std::to_string(k);
          r.scene = plan.prepare_scene(n).text();
          r.seed = plan.seed + k;
          r.window = false;
          requests.push_back(std::move(r));
          owner.emplace_back(i, n);
        }
      }
    }
    if (!requests.empty()) {
      if (const auto status = run_stage(study, "prepare", requests, options, preps, false))
        return *status;
    }
    for (std::size_t q = 0; q < preps.size(); ++q) {
      CaseRuns& c = cases[owner[q].first];
      c.prepared[owner[q].second].push_back(&preps[q]);
      c.preps.push_back(&preps[q]);
      if (!preps[q].result.status.is_complete() && !options.quiet)
        std::fprintf(stderr, "compare: preparation %s did not finish: %s\n", preps[q].label.c_str(),
                     preps[q].verdict_text().c_str());
    }
  }

  // Stage 2: every setting x replica from its prepared state (or the init file); stage 3: the
  // settings that continue from a stage-2 setting's replica k.
  bool continued = false;
  for (const CaseRuns& c : cases)
    for (const CompareSetting& s : c.plan->settings)
      continued = continued || !s.from.empty();
  std::vector<std::vector<DiagnosedRun>> done(2);
  for (int stage = 0; stage < (continued ? 2 : 1); ++stage) {
    std::vector<RunRequest> requests;
    for (CaseRuns& c : cases) {
      const ComparePlan& plan = *c.plan;
      const auto k_rep = static_cast<std::size_t>(plan.replicas);
      for (std::size_t s = 0; s < plan.settings.size(); ++s) {
        const CompareSetting& set = plan.settings[s];
        if (set.from.empty() != (stage == 0))
          continue;
        std::vector<const DiagnosedRun*> source;
        if (stage == 1) {
          source.assign(k_rep, nullptr);
          for (std::size_t q = 0; q < c.index[0].size(); ++q)
            if (c.index[0][q].first == set.from_index)
              source[c.index[0][q].second] = &done[0][c.at[0][q]];
        } else if (plan.init.empty()) {
          source = c.prepared[set.n];
        }
        for (std::size_t k = 0; k < k_rep; ++k) {
          const std::string init = plan.init.empty() || stage == 1
                                       ? start_of(plan, s, k, source, options.out_dir)
                                       : plan.init;
          if (init.empty())
            continue;  // its source failed: reported, and the setting did not run this replica
          RunRequest r;
          r.label = c.prefix + set.label + "_r" + std::to_string(k);
          Scene scene = plan.setting_scene(s, pooled(source, &Summary::pressure));
          r.scene = scene.text();
          r.seed = plan.seed + k;
          r.init = init;
          r.window = plan.diagnose;
          r.window_options = plan.window_options(s, pooled(source, &Summary::pressure));
          const toml::table* run = scene.table("run");
          const toml::node* budget = run ? run->get("max_force_evaluations") : nullptr;
          r.budget = budget && budget->is_integer() ? budget->as_integer()->get() : 0;
          c.index[stage].emplace_back(s, k);
          c.at[stage].push_back(requests.size());
          requests.push_back(std::move(r));
        }
      }
    }
    if (requests.empty())
      throw std::runtime_error("compare " + top.name + ": no " +
                               (stage == 0 ? "preparation" : "setting that others continue from") +
                               " finished, so no setting can start; see the logs under " +
                               options.out_dir + (stage == 0 ? "/prepare" : "/settings") +
                               "/runs/points/");
    if (const auto status =
            run_stage(study, stage == 0 ? "settings" : "continued", requests, options, done[stage],
                      (stage == 1 || !continued) && !follow_up))
      return *status;
  }
  // Counted or written as a job array, not run: nothing to report yet. A follow-up counts its
  // own stages from stand-ins.
  if (options.dry_run && follow_up) {
    const auto counted = follow_up({});
    return std::holds_alternative<int>(counted) ? std::get<int>(counted) : 0;
  }
  // Under --slurm with a follow-up, the comparison's stages are done: the follow-up writes the
  // array of its own stage, or the report follows once that is done too.
  if ((options.dry_run || options.slurm) && !follow_up)
    return 0;
  if (sweep::mpi_launched() && sweep::launched_rank() != 0 && !follow_up)
    return 0;

  std::vector<CaseAnalysis> analyses;
  for (const CaseRuns& c : cases)
    analyses.push_back(analyse_case(c, done));
  CompareSection own;  // the study's section, from every case's outcome
  if (section || follow_up) {
    std::vector<CompareCaseOutcome> outcomes;
    for (std::size_t i = 0; i < cases.size(); ++i) {
      CompareCaseOutcome o;
      o.plan = cases[i].plan;
      o.result = &analyses[i].result;
      for (const SettingRuns& sr : analyses[i].runs) {
        o.runs.emplace_back();
        for (const DiagnosedRun& r : sr.replicas)
          o.runs.back().push_back(&r);
      }
      outcomes.push_back(std::move(o));
    }
    if (follow_up) {
      auto followed = follow_up(outcomes);
      if (std::holds_alternative<int>(followed))
        return std::get<int>(followed);
      own = std::move(std::get<CompareSection>(followed));
    } else {
      own = section(outcomes);
    }
  }
  if (sweep::mpi_launched() && sweep::launched_rank() != 0)
    return 0;
  // The cost of every run of the comparison (and of the study's own stage): one line in the
  // report's opening, which `study paper` shows.
  std::string cost;
  {
    double prep_cpu = 0.0, cpu = 0.0;
    std::size_t runs = 0, from_wall = 0;
    const auto add = [&](const DiagnosedRun& r, double& into) {
      if (!(r.cpu_seconds > 0.0))
        return;
      into += r.cpu_seconds;
      ++runs;
      from_wall += r.result.cpu_from_wall ? 1 : 0;
    };
    for (const DiagnosedRun& r : preps)
      add(r, prep_cpu);
    for (const CaseAnalysis& a : analyses)
      for (const SettingRuns& sr : a.runs)
        for (const DiagnosedRun& r : sr.replicas)
          add(r, cpu);
    runs += own.runs;
    cpu += own.cpu_seconds;
    cost = "Cost: " + num((prep_cpu + cpu) / 3600.0, 3) + " CPU-hours over " +
           std::to_string(runs) + " runs (each run's CPU time on its own thread; preparations " +
           num(prep_cpu / 3600.0, 3) +
           (own.runs > 0 ? ", the study's own stage " + num(own.cpu_seconds / 3600.0, 3)
                         : std::string()) +
           (from_wall > 0 ? "; " + std::to_string(from_wall) +
                                " run files predate CPU time and give their wall time"
                          : std::string()) +
           ").\n\n";
  }
  for (std::size_t i = 0; i < cases.size(); ++i)
    write_case(cases[i], analyses[i], options, top.cases.empty() ? own.markdown : "",
               top.cases.empty() ? cost : "");
  if (!top.cases.empty())
    write_cases_summary(top, cases, analyses, options.out_dir, own.markdown, cost);
  if (!own.values.empty()) {
    H5Writer w(options.out_dir + "/" + (top.study.empty() ? top.name : top.study) + ".h5");
    w.attr("/", "compare_file", top.path);
    std::set<std::string> made = {"/"};
    for (const auto& [group, attributes] : own.values) {
      for (std::size_t at = group.find('/', 1);; at = group.find('/', at + 1)) {
        const std::string g = group.substr(0, at);  // each parent, then the group itself
        if (made.insert(g).second)
          w.group(g);
        if (at == std::string::npos)
          break;
      }
      w.attrs(group, attributes);
    }
    w.commit();
  }
  for (const std::string& script : plot_scripts)
    run_plot(script, {options.out_dir + "/table.csv", options.out_dir}, options);
  return 0;
}

int compare_main(const std::vector<std::string>& args) {
  CLI::App app{"Compare methods (integrators, ensembles, ...) on a scene against a reference.",
               "jamflow compare"};
  std::string path;
  StudyOptions o;
  app.add_option("compare", path, "compare file (TOML)")->required();
  app.add_option("--out", o.out_dir, "output folder (default: <stem>.compare beside the file)")
      ->check(non_empty_path());
  app.add_option("-j,--jobs", o.jobs, "runs at once, one thread each (default: the cores)")
      ->check(CLI::Range(1, 4096));
  app.add_flag("--dry-run", o.dry_run, "count the runs and their expected CPU-hours");
  app.add_flag("--slurm", o.slurm, "write a Slurm job array for the next unfinished stage");
  app.add_option("--time", o.slurm_time, "Slurm time limit of each array task (--slurm)");
  app.add_option("--array-size", o.slurm_array_size, "Slurm array tasks (--slurm)")
      ->check(CLI::Range(1, 100000));
  app.add_option("--partition", o.slurm_partition, "Slurm partition (--slurm)");
  app.add_flag("--no-plots", o.no_plots, "no PNG plots");
  app.add_flag("-q,--quiet", o.quiet, "no progress lines");
  std::vector<std::string> rev(args.rbegin(), args.rend());
  try {
    app.parse(rev);
  } catch (const CLI::ParseError& e) {
    return parse_error_exit(app, e, "jamflow compare");
  }
  if (o.slurm)
    sweep::check_slurm_time(o.slurm_time);
  const ComparePlan plan = load_compare(path);
  if (o.out_dir.empty())
    o.out_dir =
        (fs::path(path).parent_path() / (plan.name + ".compare")).lexically_normal().string();
  if (o.out_dir.empty())
    o.out_dir = ".";
  o.command = "jamflow compare " + path + " --out " + o.out_dir;
  return run_compare(plan, o);
}

}  // namespace jamflow::studies
