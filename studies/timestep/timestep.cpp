// Error against run time (`studies/timestep`): a comparison plan per preset (quick.toml,
// standard.toml, paper.toml), one [[case]] per state point (harmonic; constant pressure and
// constant volume, two shear rates each), every setting (Euler steps, RESPA splittings, CVODE
// and RKC tolerances) continuing from the case's prepared state with the same seed, against
// Euler at the smallest step. The compare engine gives each case's paired errors, floors, CPU
// cost, verdicts and plots; this section adds what the study asks across them: the cheapest
// setting per accuracy target, the seed's claim on RESPA's step, and where explicit Euler turns
// unstable (SPEC §4-6).
#include "studies/timestep/timestep.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

#include "framework/study.hpp"
#include "studies/common.hpp"

namespace jamflow::studies {

std::vector<AccuracyTarget> accuracy_targets() {
  return {{"sigma_xy", 0.05}, {"sigma_xy", 0.01}, {"phi", 1e-3},     {"phi", 1e-4},
          {"pressure", 0.05}, {"pressure", 0.01}, {"balance", 0.05}, {"balance", 0.01}};
}

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::size_t observable_index(const ComparePlan& plan, const std::string& name) {
  const auto it = std::find(plan.observables.begin(), plan.observables.end(), name);
  return static_cast<std::size_t>(it - plan.observables.begin());
}

bool constant_pressure(const CompareCaseOutcome& c) {
  return c.result->settings[c.plan->reference].ensemble == "constant_pressure";
}

// Usable for the targets: ran, stable, and every replica classified stable by its diagnostic
// window (which also requires the steady and, with one replica, the decorrelated verdict: blocks
// shorter than 2 tau understate the error the target is judged with).
bool usable(const CompareCaseOutcome& c, std::size_t s) {
  const auto& r = c.result->settings[s];
  if (!r.ran || !r.stable || c.runs[s].empty())
    return false;
  return std::all_of(c.runs[s].begin(), c.runs[s].end(),
                     [](const DiagnosedRun* d) { return d && d->cls.verdict == Verdict::kStable; });
}

std::string verdict_of(const CompareCaseOutcome& c, std::size_t s) {
  const auto& r = c.result->settings[s];
  if (r.over_budget)
    return "over budget";
  for (const DiagnosedRun* d : c.runs[s])
    if (d && d->cls.verdict != Verdict::kStable)
      return verdict_name(d->cls.verdict);
  return r.ran ? "stable" : "not run";
}

// (error, its error) of setting s for a target's observable: relative for sigma_xy and P_hat,
// absolute for phi (at constant pressure only; P_hat at constant volume only), |energy balance
// - 1| for "balance". NaN where the target does not apply or the setting has no analysis.
std::pair<double, double> error_for(const CompareCaseOutcome& c, std::size_t s,
                                    const std::string& observable) {
  const ComparePlan& plan = *c.plan;
  const auto& r = c.result->settings[s];
  if (!r.ran)
    return {kNaN, kNaN};
  if (observable == "balance") {
    double sum = 0.0, var = 0.0;
    int n = 0;
    for (const DiagnosedRun* d : c.runs[s]) {
      if (!d || !d->balance.valid)
        return {kNaN, kNaN};
      sum += std::abs(d->balance.ratio - 1.0);
      var += d->balance.error * d->balance.error;
      ++n;
    }
    return n ? std::make_pair(sum / n, std::sqrt(var) / n) : std::make_pair(kNaN, kNaN);
  }
  const bool cp = constant_pressure(c);
  if ((observable == "phi" && !cp) || (observable == "pressure" && cp))
    return {kNaN, kNaN};
  const std::size_t o = observable_index(plan, observable);
  if (o >= r.observables.size())
    return {kNaN, kNaN};
  const auto& x = r.observables[o];
  const double scale = observable == "phi"
                           ? 1.0
                           : std::abs(c.result->settings[plan.reference].observables[o].mean.value);
  return {std::abs(x.difference.value) / scale, x.difference.error / scale};
}

std::string target_value(const std::string& observable, double v) {
  if (!std::isfinite(v))
    return "—";
  return observable == "phi" ? num(v, 2) : num(100.0 * v, 2) + " %";
}

// (A table cell: its bars are escaped.)
std::string target_name(const AccuracyTarget& t) {
  if (t.observable == "phi")
    return "\\|Δφ\\| ≤ " + short_num(t.value);
  if (t.observable == "balance")
    return "\\|EB − 1\\| ≤ " + num(100 * t.value, 2) + " %";
  return (t.observable == "sigma_xy" ? "σ_xy" : "P̂") + std::string(" ≤ ") + num(100 * t.value, 2) +
         " %";
}

// The cheapest usable setting (CPU seconds per particle and tau_0) with error + 2 x its error
// <= the target; else why none.
std::string cheapest(const CompareCaseOutcome& c, const AccuracyTarget& t) {
  const std::size_t ref = c.plan->reference;
  if (!usable(c, ref))
    return "no usable reference (" + verdict_of(c, ref) + ")";
  double best_cpu = std::numeric_limits<double>::infinity(), min_error = best_cpu;
  int best = -1;
  bool applies = false;
  for (std::size_t s = 0; s < c.result->settings.size(); ++s) {
    if (s == ref)
      continue;
    const auto [err, error] = error_for(c, s, t.observable);
    if (!std::isfinite(err))
      continue;
    applies = true;
    if (!usable(c, s))
      continue;
    min_error = std::min(min_error, error);
    const double cpu = c.result->settings[s].cpu_per_particle_tau.value;
    if (err + 2.0 * error <= t.value && cpu < best_cpu) {
      best_cpu = cpu;
      best = static_cast<int>(s);
    }
  }
  if (!applies)
    return "n/a";
  if (best >= 0)
    return c.result->settings[std::size_t(best)].label + " (" + num(best_cpu, 2) + ")";
  if (std::isfinite(min_error) && 2.0 * min_error > t.value)
    return "unresolved (2σ " + target_value(t.observable, 2.0 * min_error) + ")";
  return "none of the usable settings";
}

// One cell of the claim table: the verdict and, for a usable run, the shifts of sigma_xy and of
// phi (or P_hat) from the reference with their significance; "agrees" = within the plan's
// tolerance in both (2 sigma, or 1 % of sigma_xy and P_hat and about 1e-3 of phi).
std::string claim_cell(const CompareCaseOutcome& c, int s) {
  if (s < 0)
    return "—";
  const auto k = static_cast<std::size_t>(s);
  const std::string verdict = verdict_of(c, k);
  if (!usable(c, k)) {
    if (verdict == "oscillating" && !c.runs[k].empty() && c.runs[k].front()->balance.valid)
      return "oscillating (EB " + num(c.runs[k].front()->balance.ratio, 2) + ")";
    return verdict == "diverged" ? "**diverged**" : verdict;
  }
  const ComparePlan& plan = *c.plan;
  const bool cp = constant_pressure(c);
  const std::size_t os = observable_index(plan, "sigma_xy");
  const std::size_t oo = observable_index(plan, cp ? "phi" : "pressure");
  const auto& r = c.result->settings[k];
  if (os >= r.observables.size() || oo >= r.observables.size())
    return verdict;
  const auto [es, ss] = error_for(c, k, "sigma_xy");
  const auto [eo, so] = error_for(c, k, cp ? "phi" : "pressure");
  const bool agrees = r.observables[os].within && r.observables[oo].within;
  return std::string(agrees ? "stable, agrees" : "stable, **differs**") + ": σ " +
         num(100 * es, 2) + " % (" + num(r.observables[os].z, 2) + "σ), " +
         (cp ? "φ " + num(eo, 2) : "P̂ " + num(100 * eo, 2) + " %") + " (" +
         num(r.observables[oo].z, 2) + "σ)";
}

double first_unstable_euler(const CompareCaseOutcome& c) {
  std::vector<std::pair<double, bool>> steps;  // (dt, oscillating or diverged)
  for (std::size_t s = 0; s < c.plan->settings.size(); ++s) {
    const CompareMethod m = compare_method(*c.plan, s);
    if (m.family != "euler" || c.runs[s].empty())
      continue;
    const bool bad = std::any_of(c.runs[s].begin(), c.runs[s].end(), [](const DiagnosedRun* d) {
      return d && (d->cls.verdict == Verdict::kOscillating || d->cls.verdict == Verdict::kDiverged);
    });
    steps.emplace_back(m.dt, bad);
  }
  std::sort(steps.begin(), steps.end());
  for (const auto& [dt, bad] : steps)
    if (bad)
      return dt;
  return kNaN;
}

}  // namespace

CompareSection timestep_section(const std::vector<CompareCaseOutcome>& cases) {
  CompareSection out;
  std::string md = "## Cheapest setting per accuracy target\n\n";
  md +=
      "Per state point, the cheapest setting (CPU seconds per particle·τ0 in brackets) whose "
      "error against the reference plus twice the error of that difference is within the "
      "target: σ_xy and P̂ relative to the reference, φ absolute, and |energy balance − 1|. "
      "Only usable runs count: stable, and classified stable by the diagnostic window (so "
      "steady, with blocks of at least 2τ). \"unresolved\": even the smallest error of a "
      "usable setting is too large to tell. (Each case's \"cheapest within tolerance\" also "
      "counts runs whose blocks are shorter than 2τ, whose errors are then too small, as its "
      "report says; these targets do not.)\n\n";
  std::vector<std::string> header = {"target"};
  for (const auto& c : cases)
    header.push_back(c.name());
  std::vector<std::vector<std::string>> rows;
  const auto targets = accuracy_targets();
  for (std::size_t k = 0; k < targets.size(); ++k) {
    std::vector<std::string> row = {target_name(targets[k])};
    Attributes values = {{"observable", targets[k].observable}, {"value", targets[k].value}};
    for (const auto& c : cases) {
      row.push_back(cheapest(c, targets[k]));
      values.emplace_back(c.name(), row.back());
    }
    rows.push_back(std::move(row));
    char group[32];
    std::snprintf(group, sizeof group, "/targets/t%02zu", k);
    out.values.emplace_back(group, std::move(values));
  }
  md += markdown_table(header, rows) + "\n";

  md +=
      "## The seed's claim (dt = 1.0 as good as 0.5 and 1.2; 1.5 unstable) and SPEC §4 "
      "(Euler unstable from dt ≈ 0.4)\n\n"
      "Cells: the verdict; for usable runs the shifts of σ_xy and of φ (or P̂) from the "
      "reference and their significance; agrees = within the comparison's tolerance in "
      "both.\n\n";
  const std::vector<double> claim_dts = {0.4, 0.5, 1.0, 1.2, 1.5};
  header = {"state point", "integrator"};
  for (double dt : claim_dts)
    header.push_back("dt = " + short_num(dt));
  rows.clear();
  for (const auto& c : cases) {
    for (const std::string family : {"euler", "respa particlesx4"}) {
      std::vector<std::string> row = {c.name(), family};
      bool any = false;
      for (double dt : claim_dts) {
        int found = -1;
        for (std::size_t s = 0; s < c.plan->settings.size() && found < 0; ++s) {
          const CompareMethod m = compare_method(*c.plan, s);
          if (m.family == family && std::abs(m.dt - dt) < 1e-12)
            found = static_cast<int>(s);
        }
        any = any || found >= 0;
        row.push_back(claim_cell(c, found));
      }
      if (any)
        rows.push_back(std::move(row));
    }
  }
  md += markdown_table(header, rows) + "\n";
  md += "First unstable Euler dt per state point: ";
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const double d = first_unstable_euler(cases[i]);
    const std::string name = cases[i].name();
    md += (i ? "; " : "") + name + ": " + (std::isfinite(d) ? short_num(d) : "none in the scan");
    out.values.push_back({"/cases/" + name, {{"first_unstable_euler_dt", d}}});
  }
  out.markdown = md + ".\n\nThe numbers of this section: `timestep.h5` (`/targets`, `/cases`).\n\n";
  return out;
}

namespace {

int run_timestep(const StudyOptions& options) {
  return run_compare(study_compare_plan("timestep", options.preset), options, timestep_section);
}

const Registrar registrar{{"timestep",
                           "error of steady-state means against CPU time for Euler, RESPA, CVODE "
                           "and RKC (work-precision) at fixed state points (a compare plan)",
                           run_timestep}};

}  // namespace

}  // namespace jamflow::studies
