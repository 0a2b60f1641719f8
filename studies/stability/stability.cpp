// Stability on stiff and extreme cases (`studies/stability`): a comparison plan per preset
// (quick.toml, standard.toml, paper.toml), one [[case]] per case (alpha_r in [1.2, 3], high
// pressure, a stiff piston, a large shear rate, N = 100 near jamming, where the seed saw lanes
// for dt >= 0.3, sec. "Model and numerical methods", and RESPA with particle sub-steps against
// N), every setting (Euler steps, RESPA splittings, CVODE tolerances) continuing from the case's
// prepared state, each run classified by its diagnostic window (driver/diagnostics.hpp,
// studies/stability/README.md). The compare engine gives each case's verdicts, energy balance and
// differences from its reference; this section adds the stable / oscillating / diverged map
// across them, and stability/plot.py draws it from OUT/table.csv.
#include "studies/stability/stability.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "framework/study.hpp"
#include "studies/common.hpp"

namespace jamflow::studies {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The state point of a case, from its base scene.
struct Point {
  std::int64_t n = 0;
  double alpha = 2.0, pressure = kNaN, xi_v = kNaN, gdot = kNaN, phi = kNaN;
  bool constant_pressure = false;
};

Point point_of(const ComparePlan& plan) {
  Point p;
  const toml::table* sys = plan.base.table("system");
  const toml::table* ens = plan.base.table("ensemble");
  const toml::table* shear = plan.base.table("shear");
  if (sys) {
    p.n = (*sys)["N"].value_or(std::int64_t{0});
    p.alpha = (*sys)["alpha"].value_or(2.0);
    p.phi = (*sys)["phi"].value_or(kNaN);
  }
  if (ens) {
    p.constant_pressure = (*ens)["kind"].value_or(std::string()) == "constant_pressure";
    p.pressure = (*ens)["pressure"].value_or(kNaN);
    p.xi_v = (*ens)["xi_V"].value_or(1e-4);
  }
  if (shear)
    p.gdot = (*shear)["rate"].value_or(kNaN);
  return p;
}

std::string describe(const Point& p) {
  std::string s = "N = " + std::to_string(p.n) + ", α_r = " + short_num(p.alpha);
  s += p.constant_pressure ? ", P = " + short_num(p.pressure) + ", ξ_V = " + short_num(p.xi_v)
                           : ", φ = " + short_num(p.phi);
  return s + ", γ̇ = " + short_num(p.gdot);
}

// A setting's runs: the first replica's classification that is not stable, else stable.
const DiagnosedRun* deciding_run(const CompareCaseOutcome& c, std::size_t s) {
  const DiagnosedRun* out = nullptr;
  for (const DiagnosedRun* d : c.runs[s]) {
    if (!d)
      continue;
    if (!out || (out->cls.verdict == Verdict::kStable && d->cls.verdict != Verdict::kStable))
      out = d;
  }
  return out;
}

Verdict verdict_of(const CompareCaseOutcome& c, std::size_t s) {
  const DiagnosedRun* d = deciding_run(c, s);
  return d ? d->cls.verdict : Verdict::kNotAvailable;
}

std::string verdict_text(const CompareCaseOutcome& c, std::size_t s) {
  const DiagnosedRun* d = deciding_run(c, s);
  return d ? d->verdict_text() : std::string("not run");
}

bool oscillates(Verdict v) {
  return v == Verdict::kOscillating || v == Verdict::kDiverged;
}
// Ran to its end without oscillating (whether or not its own verdicts admit its numbers).
bool holds(Verdict v) {
  return v == Verdict::kStable || v == Verdict::kNotSteady || v == Verdict::kCorrelated;
}

// Explicit Euler in increasing dt: the largest step below which every run is stable, the
// largest below the first unstable one that ran to its end without oscillating (counting runs
// their verdicts leave out: what the classification says, but not a conclusion unless the
// stable step says the same), and the first unstable step.
struct EulerScan {
  bool scanned = false;
  double smallest = kNaN, largest_stable = kNaN, largest_held = kNaN, first_unstable = kNaN;
  std::size_t held_left_out = 0;
  std::string first_unstable_text;
  bool lanes = false;
};

EulerScan euler_scan(const CompareCaseOutcome& c) {
  EulerScan e;
  std::vector<std::pair<double, std::size_t>> steps;
  for (std::size_t s = 0; s < c.plan->settings.size(); ++s) {
    for (const DiagnosedRun* d : c.runs[s])
      e.lanes = e.lanes || (d && d->cls.laned);
    const CompareMethod m = compare_method(*c.plan, s);
    if (m.kind == "euler" && !c.runs[s].empty())
      steps.emplace_back(m.dt, s);
  }
  std::sort(steps.begin(), steps.end());
  e.scanned = !steps.empty();
  if (e.scanned)
    e.smallest = steps.front().first;
  for (const auto& [dt, s] : steps) {
    const Verdict v = verdict_of(c, s);
    if (v == Verdict::kStable) {
      e.largest_stable = e.largest_held = dt;
    } else if (holds(v)) {
      e.largest_held = dt;
      ++e.held_left_out;
    } else if (oscillates(v)) {
      e.first_unstable = dt;
      e.first_unstable_text = verdict_text(c, s);
      break;
    }
  }
  return e;
}

std::string largest_stable_cell(const EulerScan& e) {
  const std::string cell = std::isfinite(e.largest_stable) ? short_num(e.largest_stable) : "";
  if (!std::isfinite(e.largest_held))
    return cell.empty() ? "< " + short_num(e.smallest) : cell;
  if (e.largest_held == e.largest_stable && e.held_left_out == 0)
    return cell;
  const std::string held = "no oscillation up to " + short_num(e.largest_held) + ", but " +
                           std::to_string(e.held_left_out) + " of those runs left out";
  return cell.empty() ? "not established (" + held + ")" : cell + " (" + held + ")";
}

// The cases that scan RESPA only: RESPA with particle sub-steps against N, per pressure and step.
struct SizeRun {
  std::int64_t n;
  double pressure, dt;
  const CompareCaseOutcome* c;
  std::size_t s;
};

std::vector<SizeRun> size_runs(const std::vector<CompareCaseOutcome>& cases) {
  std::vector<SizeRun> out;
  for (const auto& c : cases) {
    if (euler_scan(c).scanned)
      continue;
    const Point p = point_of(*c.plan);
    for (std::size_t s = 0; s < c.plan->settings.size(); ++s) {
      const CompareMethod m = compare_method(*c.plan, s);
      if (m.kind == "respa" && !c.runs[s].empty())
        out.push_back({p.n, p.pressure, m.dt, &c, s});
    }
  }
  return out;
}

template <class T>
std::vector<T> distinct(std::vector<T> v) {
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
  return v;
}

// Per pressure and step: the largest size that oscillated or diverged, the smallest from which
// every larger size held (0: none), and whether every size gave a verdict either way.
struct SizeThreshold {
  std::int64_t largest_failing = 0, smallest_holding = 0;
  bool complete = true;
};

SizeThreshold size_threshold(const std::vector<SizeRun>& runs, double pressure, double dt) {
  std::vector<std::pair<std::int64_t, Verdict>> v;
  for (const auto& r : runs)
    if (r.pressure == pressure && r.dt == dt)
      v.emplace_back(r.n, verdict_of(*r.c, r.s));
  std::sort(v.begin(), v.end());
  SizeThreshold t;
  for (const auto& [n, verdict] : v) {
    if (oscillates(verdict))
      t.largest_failing = n;
    else if (!holds(verdict))
      t.complete = false;
  }
  for (auto it = v.rbegin(); it != v.rend() && holds(it->second); ++it)
    t.smallest_holding = it->first;
  return t;
}

std::string threshold_text(const SizeThreshold& t, std::int64_t largest_size) {
  const auto [largest_failing, smallest_holding, complete] = t;
  std::string out;
  if (largest_failing == 0)
    out = "held at every size scanned";
  else if (smallest_holding > 0)
    out = "oscillating or diverged at N <= " + std::to_string(largest_failing) +
          ", holds for N >= " + std::to_string(smallest_holding);
  else if (largest_failing == largest_size)
    out = "oscillating or diverged even at the largest size scanned, N = " +
          std::to_string(largest_size);
  else
    out = "oscillating or diverged at N = " + std::to_string(largest_failing) +
          "; the larger sizes gave no verdict";
  if (!complete)
    out += " (some sizes gave no verdict: over budget, or not available)";
  return out;
}

std::string respa_size_section(const std::vector<SizeRun>& runs, std::vector<std::string>& lines,
                               CompareSection& out) {
  if (runs.empty())
    return {};
  std::vector<double> pressures, dts;
  std::vector<std::int64_t> sizes;
  for (const auto& r : runs) {
    if (std::find(pressures.begin(), pressures.end(), r.pressure) == pressures.end())
      pressures.push_back(r.pressure);
    dts.push_back(r.dt);
    sizes.push_back(r.n);
  }
  dts = distinct(dts);
  sizes = distinct(sizes);
  std::vector<std::string> header = {"N"};
  for (double pr : pressures)
    for (double dt : dts)
      header.push_back("P = " + short_num(pr) + ", dt = " + short_num(dt));
  std::vector<std::vector<std::string>> rows;
  for (std::int64_t n : sizes) {
    std::vector<std::string> row = {std::to_string(n)};
    for (double pr : pressures)
      for (double dt : dts) {
        std::string cell = "—";
        for (const auto& r : runs) {
          if (r.n != n || r.pressure != pr || r.dt != dt)
            continue;
          const DiagnosedRun* d = deciding_run(*r.c, r.s);
          cell = verdict_text(*r.c, r.s) +
                 (d && d->complete() ? " (c = " + num(d->window.force_correlation, 3) + ")" : "");
        }
        row.push_back(cell);
      }
    rows.push_back(std::move(row));
  }
  std::string md =
      "## RESPA with particle sub-steps against N\n\n"
      "RESPA with the particles on the inner level (4 explicit-Euler sub-steps) and the piston "
      "on the outer level, at J = gdot / P of each case. Each size starts at the hard-sphere "
      "law's phi for its J and N and is prepared for at least 5 / P, the time phi takes to relax "
      "at pressure P. The piston's relaxation rate K / (V xi_V) grows as the box volume V "
      "shrinks, so the outer step that the piston tolerates shrinks with N. c is the force step "
      "correlation of the diagnostic window (oscillating below 0.9).\n\n" +
      markdown_table(header, rows) + "\n";
  for (double pr : pressures)
    for (double dt : dts) {
      const SizeThreshold th = size_threshold(runs, pr, dt);
      out.values.push_back({"/respa_size_thresholds/P=" + short_num(pr) + "_dt=" + short_num(dt),
                            {{"imposed_pressure", pr},
                             {"dt", dt},
                             {"largest_failing_N", th.largest_failing},
                             {"smallest_holding_N", th.smallest_holding},
                             {"every_size_has_a_verdict", std::int64_t{th.complete}}}});
      const std::string t = threshold_text(th, sizes.back());
      md += "- P = " + short_num(pr) + ", dt = " + short_num(dt) + ": " + t + ".\n";
      lines.push_back("- **RESPA (particles inner) at dt = " + short_num(dt) +
                      ", P = " + short_num(pr) + "**: " + t + ".\n");
    }
  return md + "\n";
}

// Each run's diagnostic-window numbers (the engine's case report has the energy balance and the
// classes; these say why).
std::string window_table(const CompareCaseOutcome& c) {
  const Point p = point_of(*c.plan);
  std::vector<std::vector<std::string>> rows;
  for (std::size_t s = 0; s < c.plan->settings.size(); ++s) {
    for (const DiagnosedRun* d : c.runs[s]) {
      if (!d)
        continue;
      const std::string label = c.plan->settings[s].label;
      if (!d->complete()) {
        rows.push_back({label, d->verdict_text(), "—", "—", "—", "—", "—", "—", "—"});
        continue;
      }
      rows.push_back(
          {label, d->verdict_text(), pm(d->balance.ratio, d->balance.error, 3),
           num(d->window.force_correlation, 3), num(d->window.reversed_fraction, 2),
           num(d->window.dsigma_lag1, 2), num(d->window.lane_order, 2),
           num((p.constant_pressure ? d->result.summary.phi : d->result.summary.pressure).value, 5),
           cpu_cell(*d)});
    }
  }
  return markdown_table(
      {"setting", "verdict", "energy balance", "force step corr.", "reversed frac.", "lag-1 dσ",
       "lane order", p.constant_pressure ? "φ" : "P̂", "CPU s"},
      rows);
}

}  // namespace

CompareSection stability_section(const std::vector<CompareCaseOutcome>& cases) {
  CompareSection out;
  std::string md =
      "## Summary (explicit Euler)\n\n"
      "Verdicts (the diagnostic window after each run; studies/stability/README.md): **diverged** "
      "= the run stopped (non-finite values, a negative volume, or an implicit solver that could "
      "not advance: CVODE's CV_TOO_MUCH_WORK), shown with the time and message, never as "
      "numbers; **oscillating** = period-2 share of the force power above 5 % (force "
      "step correlation < 0.9) or, for a fixed step, an energy balance below 1 by more than "
      "max(5 %, 3σ) (dissipation inflated); **lanes** = lane order ≥ 0.3; **incomplete** = "
      "stopped by the per-run budget (too slow for this preset, not a stability statement). A "
      "step counts as stable where its run is stable and passes its own verdicts (steady, and "
      "blocks of at least 2τ).\n\n";
  std::vector<std::vector<std::string>> rows;
  std::vector<std::string> conclusions;
  for (const auto& c : cases) {
    const EulerScan e = euler_scan(c);
    if (!e.scanned)
      continue;
    out.values.push_back({"/cases/" + c.name(),
                          {{"largest_stable_dt", e.largest_stable},
                           {"largest_dt_without_oscillation", e.largest_held},
                           {"runs_without_oscillation_left_out", std::int64_t(e.held_left_out)},
                           {"first_unstable_dt", e.first_unstable},
                           {"first_unstable_verdict", e.first_unstable_text},
                           {"lanes", std::int64_t{e.lanes}}}});
    rows.push_back({c.name(), describe(point_of(*c.plan)), largest_stable_cell(e),
                    std::isfinite(e.first_unstable)
                        ? short_num(e.first_unstable) + ": " + e.first_unstable_text
                        : "none in the scan",
                    e.lanes ? "yes" : "no"});
    std::string line = "- **" + c.name() + "**: ";
    if (std::isfinite(e.largest_stable))
      line += "Euler stable up to dt = " + short_num(e.largest_stable);
    else if (std::isfinite(e.largest_held))
      line += "Euler's stable range is not established: no run oscillates up to dt = " +
              short_num(e.largest_held) + ", but those runs are left out by their verdicts";
    else
      line += "Euler unstable at every scanned dt (smallest " + short_num(e.smallest) + ")";
    if (std::isfinite(e.largest_stable) && e.held_left_out > 0)
      line += " (" + std::to_string(e.held_left_out) +
              " runs that do not oscillate are left out by their verdicts; the largest such dt "
              "is " +
              short_num(e.largest_held) + ")";
    if (std::isfinite(e.first_unstable))
      line += "; at dt = " + short_num(e.first_unstable) + ": " + e.first_unstable_text;
    conclusions.push_back(line + (e.lanes ? "; lanes detected.\n" : "; no lanes detected.\n"));
  }
  md += markdown_table({"case", "state point", "largest stable dt", "first unstable dt", "lanes"},
                       rows) +
        "\n";
  std::vector<std::string> respa_lines;
  md += respa_size_section(size_runs(cases), respa_lines, out);
  md += "## Diagnostic windows per case\n\n";
  for (const auto& c : cases)
    md +=
        "### " + c.name() + "\n\n" + describe(point_of(*c.plan)) + ".\n\n" + window_table(c) + "\n";
  md += "## Conclusions\n\n";
  for (const auto& l : respa_lines)
    md += l;
  for (const auto& l : conclusions)
    md += l;
  out.markdown = md +
                 "\nPlots (stability/plot.py, from table.csv): `stability_map.png` (each case's "
                 "verdict against the step or tolerance), `stability_diagnostics.png` (energy "
                 "balance and force step correlation against Euler's step). The numbers of this "
                 "section: `stability.h5`.\n\n";
  return out;
}

namespace {

int run_stability(const StudyOptions& options) {
  return run_compare(study_compare_plan("stability", options.preset), options, stability_section,
                     {"stability/plot.py"});
}

const Registrar registrar{
    {"stability",
     "stable / oscillating / diverged map against dt or tolerance on stiff and extreme cases "
     "(alpha_r, high P, stiff piston, large gdot, N = 100 lanes, RESPA against N; a compare plan)",
     run_stability}};

}  // namespace

}  // namespace jamflow::studies
