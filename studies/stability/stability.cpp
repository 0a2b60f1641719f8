// Stability on stiff and extreme cases (issue: `studies/stability`): a stable / oscillating /
// diverged map against dt (Euler, RESPA) or tolerance (CVODE) for alpha_r in [1.2, 3], high
// pressure, a stiff piston (small xi_V), a large shear rate, and N = 100 near jamming, where
// the seed saw lanes for dt >= 0.3 (sec. "Model and numerical methods"). Diagnostics and
// thresholds: studies/stability/README.md and studies/diagnostics.hpp.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "studies/common.hpp"
#include "studies/diagnostics.hpp"
#include "studies/stability/stability.hpp"

namespace jamflow::studies {

namespace {
// Time for phi to relax at pressure P, in units of xi_s a / P (as the timestep study uses).
constexpr double kRelaxPressure = 5.0;
}  // namespace

StabilityPreset stability_preset(const std::string& name) {
  StabilityPreset p;
  p.name = name;
  if (name == "quick") {
    p.n = 200;
    p.strain_prep = 0.05;
    p.t_prep_min = 300.0;
    p.strain_eq = 0.01;
    p.t_eq_min = 100.0;
    p.strain_av = 0.1;
    // Blocks of 100 (20 over t_av = 2000): longer than 2 tau at P = 0.1 (about 45), so its stable
    // runs pass the decorrelated verdict and count; at P = 1e-2 (2 tau of 110-260) they are
    // still left out as correlated (measured on the quick preset).
    p.t_av_min = 2000.0;
    p.dts = {0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 1.0, 1.5};
    p.stiff_dts = {0.01};
    p.lane_dts = {0.05, 0.1, 0.3, 0.5, 1.0};
    p.respa = {{"particles", 4, "euler"}};
    p.respa_dts = {0.5, 1.5};
    p.cvode_tols = {1e-4};
    p.lane_pressure = 1e-4;
    p.lane_gdot = 1e-4;
    p.respa_sizes = {100, 250};
    p.respa_size_pressures = {1e-3};
    p.budget_particle_steps = 1.25e8;  // about 5 s
    p.cvode_max_steps = 20000;
  } else if (name == "standard") {
    p.n = 500;
    p.strain_prep = 0.2;
    p.t_prep_min = 1000.0;
    p.strain_eq = 0.05;
    p.t_eq_min = 200.0;
    p.strain_av = 0.5;
    p.t_av_min = 2000.0;
    p.dts = {0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0, 1.2, 1.5};
    p.stiff_dts = {0.002, 0.005, 0.01};
    p.lane_dts = {0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 1.0};
    p.respa = {{"particles", 4, "euler"}, {"piston", 4, "euler"}};
    p.respa_dts = {0.3, 0.5, 1.0, 1.5};
    p.cvode_tols = {1e-3, 1e-4, 1e-5, 1e-6};
    p.lane_pressure = 1e-5;
    p.lane_gdot = 1e-6;
    p.lane_strain_av = 1.0;  // the seed's lanes need strain: run to 1
    p.respa_sizes = {100, 175, 250, 350, 500, 750, 1000};
    p.respa_size_pressures = {1e-2, 1e-3, 1e-4};
    p.budget_particle_steps = 7.5e9;  // about 300 s
  } else if (name == "paper") {
    p.n = 1000;
    p.strain_prep = 1.0;
    p.t_prep_min = 5000.0;
    p.strain_eq = 0.5;
    p.t_eq_min = 1000.0;
    p.strain_av = 1.0;
    p.t_av_min = 10000.0;
    p.dts = {0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0, 1.2, 1.5};
    p.stiff_dts = {0.0005, 0.001, 0.002, 0.005, 0.01};
    p.lane_dts = {0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0};
    p.respa = {{"particles", 4, "euler"}, {"piston", 4, "euler"}, {"particles", 2, "heun"}};
    p.respa_dts = {0.3, 0.5, 1.0, 1.2, 1.5, 2.0};
    p.cvode_tols = {1e-3, 1e-4, 1e-5, 1e-6, 1e-7};
    p.lane_pressure = 1e-5;
    p.lane_gdot = 1e-7;
    p.lane_strain_av = 1.0;
    p.respa_sizes = {64, 100, 175, 250, 350, 500, 750, 1000, 2000};
    p.respa_size_pressures = {1e-2, 1e-3, 1e-4, 1e-5};
    p.respa_size_dts = {0.5, 0.7, 1.0, 1.2};
  } else {
    throw ConfigError("--preset " + name + "; allowed quick, standard, paper");
  }
  if (p.lane_strain_av <= 0.0)
    p.lane_strain_av = p.strain_av;
  return p;
}

std::vector<StabilityCase> stability_cases(const StabilityPreset& p) {
  std::vector<StabilityCase> cases;
  StatePoint base;
  base.n = p.n;
  base.constant_pressure = true;
  base.pressure = 1e-3;
  base.phi = 0.64;
  base.gdot = 1e-4;  // J = 0.1
  for (double a : {1.2, 1.5, 2.0, 2.5, 3.0}) {
    StabilityCase c;
    c.point = base;
    c.point.alpha = a;
    c.name = "alpha=" + short_num(a);
    c.why = a < 2.0 ? "force derivative diverges at contact (stiff)"
                    : (a > 2.0 ? "contact stiffness vanishes at contact (soft)"
                               : "harmonic baseline, J = 0.1");
    c.stiff = a < 2.0;
    cases.push_back(c);
  }
  for (double pr : {1e-2, 1e-1}) {
    StabilityCase c;
    c.point = base;
    c.point.pressure = pr;
    c.point.phi = pr > 0.05 ? 0.75 : 0.68;
    c.point.gdot = 0.1 * pr;
    c.name = "P=" + short_num(pr);
    c.why = "high pressure (large overlaps, stiff piston K / (V xi_V)), J = 0.1";
    c.stiff = pr > 0.05;
    cases.push_back(c);
  }
  {
    StabilityCase c;
    c.point = base;
    c.point.xi_v = 1e-6;
    c.name = "xi_V=1e-6";
    c.why = "piston 100x stiffer than the seed's xi_V = 1e-4";
    c.stiff = true;
    cases.push_back(c);
  }
  {
    StabilityCase c;
    c.point = base;
    c.point.gdot = 1e-2;
    c.name = "gdot=1e-2";
    c.why = "large shear rate (J = 10)";
    cases.push_back(c);
  }
  for (double xi : {1e-4, 1e-2}) {
    StabilityCase c;
    c.point = base;
    c.point.n = 100;
    c.point.pressure = p.lane_pressure;
    c.point.phi = 0.62;
    c.point.gdot = p.lane_gdot;
    c.point.xi_v = xi;
    c.name = xi == 1e-4 ? "N=100 jamming" : "N=100 jamming xi_V=1e-2";
    c.why = xi == 1e-4 ? "seed: lanes for dt >= 0.3 near jamming"
                       : "same with a 100x softer piston: separates the piston from lanes";
    c.lanes = true;
    c.strain_av = p.lane_strain_av;
    cases.push_back(c);
  }
  for (double pr : p.respa_size_pressures) {
    for (std::int64_t n : p.respa_sizes) {
      StabilityCase c;
      c.point = base;
      c.point.n = n;
      c.point.pressure = pr;
      c.point.gdot = p.respa_size_j * pr;
      // Start at the hard-sphere law's phi for this J and N, and prepare for at least the
      // pressure relaxation time 5 / P (units xi_s a / P). Started at phi = 0.64, the piston
      // dilated the random state to phi = 0.35 at P = 1e-4 and it was still compressing, at
      // 0.49, when a preparation of t = 2e3 ended (standard preset: every such scan not steady).
      c.point.phi = phi_start(c.point.gdot / pr, n);
      c.t_prep_min = kRelaxPressure / pr;
      c.name = "RESPA N=" + std::to_string(n) + " P=" + short_num(pr);
      c.why =
          "RESPA, particles on the inner level, against N: the outer-level piston's rate "
          "K / (V xi_V) grows as the box shrinks";
      c.respa_size = true;
      cases.push_back(c);
    }
  }
  return cases;
}

namespace {

struct CaseResult {
  StabilityCase c;
  DiagnosedRun prep;
  std::vector<IntegratorSetting> settings;
  std::vector<DiagnosedRun> runs;
  double largest_stable_dt = std::nan("");
  // The largest Euler dt below the first unstable one that ran to its end without oscillating,
  // counting runs that their verdicts leave out (not steady, blocks shorter than 2 tau): what the
  // classification says, but not a conclusion unless largest_stable_dt says the same.
  double largest_held_dt = std::nan("");
  std::size_t held_left_out = 0;  // such runs left out by their verdicts
  double first_unstable_dt = std::nan("");
  std::string first_unstable_verdict;
  bool any_lanes = false;
};

double duration(double strain, double gdot, double t_min) {
  return std::max(t_min, strain / gdot);
}

std::string observable_cell(const DiagnosedRun& r, bool constant_pressure) {
  if (!r.complete())
    return "—";
  return constant_pressure ? num(r.value("phi"), 5) : num(r.value("pressure"), 4);
}

std::string case_table(const CaseResult& cr) {
  const bool cp = cr.c.point.constant_pressure;
  std::vector<std::vector<std::string>> rows;
  for (std::size_t k = 0; k < cr.runs.size(); ++k) {
    const DiagnosedRun& r = cr.runs[k];
    const IntegratorSetting& s = cr.settings[k];
    const std::string setting = s.label;
    if (!r.complete()) {
      rows.push_back({setting, r.verdict_text(), "—", "—", "—", "—", "—", "—", "—", "—"});
      continue;
    }
    rows.push_back({setting, r.verdict_text(), pm(r.balance.ratio, r.balance.error, 3),
                    num(r.window.force_correlation, 3), num(r.window.reversed_fraction, 2),
                    num(r.window.dsigma_lag1, 2), num(r.window.lane_order, 2),
                    pm(r.value("sigma_xy"), r.value("sigma_xy_err"), 3), observable_cell(r, cp),
                    cpu_cell(r)});
  }
  return markdown_table(
      {"integrator", "verdict", "energy balance", "force step corr.", "reversed frac.", "lag-1 dσ",
       "lane order", "σ_xy", cp ? "φ" : "P̂", "CPU s"},
      rows);
}

// The summary's "largest stable dt": the verdicts' value, or why there is none.
std::string largest_stable_cell(const CaseResult& cr) {
  std::string cell = std::isfinite(cr.largest_stable_dt) ? short_num(cr.largest_stable_dt) : "";
  if (!std::isfinite(cr.largest_held_dt))
    return cell.empty() ? "< " + short_num(cr.settings.front().dt()) : cell;
  if (cr.largest_held_dt == cr.largest_stable_dt && cr.held_left_out == 0)
    return cell;
  const std::string held = "no oscillation up to " + short_num(cr.largest_held_dt) + ", but " +
                           std::to_string(cr.held_left_out) + " of those runs left out";
  return cell.empty() ? "not established (" + held + ")" : cell + " (" + held + ")";
}

void summarize_case(CaseResult& cr) {
  // Euler rows only, in increasing dt: the largest dt below which every run is stable.
  std::vector<std::pair<double, const DiagnosedRun*>> euler;
  for (std::size_t k = 0; k < cr.runs.size(); ++k) {
    if (cr.settings[k].family() == "euler")
      euler.emplace_back(cr.settings[k].dt(), &cr.runs[k]);
    if (cr.runs[k].cls.laned)
      cr.any_lanes = true;
  }
  std::sort(euler.begin(), euler.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [dt, r] : euler) {
    if (r->cls.verdict == Verdict::kStable) {
      cr.largest_stable_dt = dt;
      cr.largest_held_dt = dt;
    } else if (r->cls.verdict == Verdict::kCorrelated || r->cls.verdict == Verdict::kNotSteady) {
      cr.largest_held_dt = dt;
      ++cr.held_left_out;
    } else if (r->cls.verdict == Verdict::kOscillating || r->cls.verdict == Verdict::kDiverged) {
      cr.first_unstable_dt = dt;
      cr.first_unstable_verdict = r->verdict_text();
      break;
    }
  }
}

// The RESPA-against-N scan: a table of verdicts (sizes down, pressure x step across) and, per
// pressure and step, the size below which the runs oscillate or diverge.
bool oscillates(const DiagnosedRun& r) {
  return r.cls.verdict == Verdict::kOscillating || r.cls.verdict == Verdict::kDiverged;
}
bool holds(const DiagnosedRun& r) {  // ran to the end without oscillating
  return r.cls.verdict == Verdict::kStable || r.cls.verdict == Verdict::kNotSteady ||
         r.cls.verdict == Verdict::kCorrelated;
}

struct SizeThreshold {
  double pressure = 0.0, dt = 0.0;
  std::int64_t largest_failing = 0;   // 0: none failed
  std::int64_t smallest_holding = 0;  // smallest N from which every larger size held (0: none)
  bool complete = true;               // every size gave a verdict either way
};

std::vector<SizeThreshold> respa_size_thresholds(const std::vector<CaseResult>& results,
                                                 const StabilityPreset& preset) {
  std::vector<SizeThreshold> out;
  for (double pr : preset.respa_size_pressures) {
    for (std::size_t k = 0; k < preset.respa_size_dts.size(); ++k) {
      SizeThreshold t;
      t.pressure = pr;
      t.dt = preset.respa_size_dts[k];
      std::vector<std::pair<std::int64_t, const DiagnosedRun*>> runs;
      for (const auto& cr : results)
        if (cr.c.respa_size && cr.c.point.pressure == pr && k < cr.runs.size())
          runs.emplace_back(cr.c.point.n, &cr.runs[k]);
      std::sort(runs.begin(), runs.end(),
                [](const auto& a, const auto& b) { return a.first < b.first; });
      for (const auto& [n, r] : runs) {
        if (oscillates(*r))
          t.largest_failing = n;
        else if (!holds(*r))
          t.complete = false;
      }
      for (auto it = runs.rbegin(); it != runs.rend() && holds(*it->second); ++it)
        t.smallest_holding = it->first;
      out.push_back(t);
    }
  }
  return out;
}

std::string threshold_text(const SizeThreshold& t, const StabilityPreset& preset) {
  const std::int64_t largest =
      *std::max_element(preset.respa_sizes.begin(), preset.respa_sizes.end());
  std::string out;
  if (t.largest_failing == 0)
    out = "held at every size scanned";
  else if (t.smallest_holding > 0)
    out = "oscillating or diverged at N <= " + std::to_string(t.largest_failing) +
          ", holds for N >= " + std::to_string(t.smallest_holding);
  else if (t.largest_failing == largest)
    out =
        "oscillating or diverged even at the largest size scanned, N = " + std::to_string(largest);
  else
    out = "oscillating or diverged at N = " + std::to_string(t.largest_failing) +
          "; the larger sizes gave no verdict";
  if (!t.complete)
    out += " (some sizes gave no verdict: incomplete, or not available)";
  return out;
}

std::string respa_size_section(const std::vector<CaseResult>& results,
                               const StabilityPreset& preset,
                               const std::vector<SizeThreshold>& thresholds) {
  if (preset.respa_sizes.empty())
    return "";
  std::vector<std::string> header = {"N"};
  for (double pr : preset.respa_size_pressures)
    for (double dt : preset.respa_size_dts)
      header.push_back("P = " + short_num(pr) + ", dt = " + short_num(dt));
  std::vector<std::vector<std::string>> rows;
  for (std::int64_t n : preset.respa_sizes) {
    std::vector<std::string> row = {std::to_string(n)};
    for (double pr : preset.respa_size_pressures) {
      const CaseResult* found = nullptr;
      for (const auto& cr : results)
        if (cr.c.respa_size && cr.c.point.n == n && cr.c.point.pressure == pr)
          found = &cr;
      for (std::size_t k = 0; k < preset.respa_size_dts.size(); ++k) {
        if (!found || k >= found->runs.size()) {
          row.push_back("—");
          continue;
        }
        const DiagnosedRun& r = found->runs[k];
        row.push_back(r.verdict_text() +
                      (r.complete() ? " (c = " + num(r.window.force_correlation, 3) + ")" : ""));
      }
    }
    rows.push_back(row);
  }
  std::string md =
      "## RESPA with particle sub-steps against N\n\n"
      "RESPA with the particles on the inner level (4 explicit-Euler sub-steps) and the piston "
      "on the outer level, at J = " +
      short_num(preset.respa_size_j) +
      " (gdot = J P). Each size starts at the hard-sphere law's phi for its J and N and is "
      "prepared for at least 5 / P, the time phi takes to relax at pressure P. The piston's "
      "relaxation rate "
      "K / (V xi_V) grows as the box volume V shrinks, so the outer step that the piston "
      "tolerates shrinks with N. c is the force step correlation of the diagnostic window "
      "(oscillating below 0.9).\n\n" +
      markdown_table(header, rows) + "\n";
  for (const auto& t : thresholds)
    md += "- P = " + short_num(t.pressure) + ", dt = " + short_num(t.dt) + ": " +
          threshold_text(t, preset) + ".\n";
  return md + "\n";
}

}  // namespace

int run_stability(const StudyOptions& options) {
  return run_stability_preset(stability_preset(options.preset), options);
}

int run_stability_preset(const StabilityPreset& preset, const StudyOptions& options,
                         const std::vector<std::string>& only) {
  ensure_dir(options.out_dir);
  std::vector<StabilityCase> cases;
  for (const auto& c : stability_cases(preset)) {
    if (only.empty() || std::find(only.begin(), only.end(), c.name) != only.end())
      cases.push_back(c);
  }
  if (cases.empty())
    throw ConfigError("stability: no case selected");
  if (!options.quiet) {
    std::printf("jamflow study stability (%s): %zu cases -> %s\n", preset.name.c_str(),
                cases.size(), options.out_dir.c_str());
  }
  const auto wall0 = std::chrono::steady_clock::now();

  // 1. Preparation: one steady state per case at a safe step, shared by all its runs.
  std::vector<RunRequest> prep_requests;
  for (const auto& c : cases) {
    const double dt_prep = c.stiff ? preset.stiff_dts.front() : std::min(0.05, preset.dts.front());
    // (the smallest step of the case's scan, so that the shared state is a stable one)
    const double t =
        std::max(duration(preset.strain_prep, c.point.gdot, preset.t_prep_min), c.t_prep_min);
    RunRequest r;
    r.label = c.name + " prep";
    r.scene = scene_toml(c.point, euler_setting(dt_prep), 0.0, t, t / 200.0);
    r.seed = c.point.seed;
    r.window = false;
    prep_requests.push_back(r);
  }
  std::vector<DiagnosedRun> preps;
  if (const auto status = run_stage("stability", "prep", prep_requests, options, preps, false))
    return *status;

  // 2. The scans.
  std::vector<CaseResult> results;
  std::vector<RunRequest> requests;
  std::vector<std::pair<std::size_t, std::size_t>> index;  // request -> (case, run)
  for (std::size_t ci = 0; ci < cases.size(); ++ci) {
    CaseResult cr;
    cr.c = cases[ci];
    cr.prep = preps[ci];
    const StatePoint& pt = cr.c.point;
    if (cr.c.respa_size) {
      for (double dt : preset.respa_size_dts)
        cr.settings.push_back(respa_setting(dt, 4, "particles", "euler"));
    } else {
      std::vector<double> dts = cr.c.lanes ? preset.lane_dts : preset.dts;
      if (cr.c.stiff)
        dts.insert(dts.begin(), preset.stiff_dts.begin(), preset.stiff_dts.end());
      for (double dt : dts)
        cr.settings.push_back(euler_setting(dt));
      for (const auto& sp : preset.respa)
        for (double dt : preset.respa_dts)
          cr.settings.push_back(respa_setting(dt, sp.n_inner, sp.inner, sp.scheme));
      for (double tol : preset.cvode_tols)
        cr.settings.push_back(cvode_setting(tol, 0.0, preset.cvode_max_steps));
    }
    const double strain_av = cr.c.strain_av > 0.0 ? cr.c.strain_av : preset.strain_av;
    const double t_eq = duration(preset.strain_eq, pt.gdot, preset.t_eq_min);
    const double t_av = duration(strain_av, pt.gdot, preset.t_av_min);
    cr.runs.resize(cr.settings.size());
    if (preps[ci].complete() && !preps[ci].final_xyz.empty()) {
      for (std::size_t k = 0; k < cr.settings.size(); ++k) {
        RunRequest r;
        r.label = cr.c.name + " " + cr.settings[k].label;
        r.scene = scene_toml(pt, cr.settings[k], t_eq, t_av, t_av / 400.0);
        r.seed = pt.seed;
        r.init = preps[ci].final_xyz;
        r.budget = budget_for(preset.budget_particle_steps, pt.n);
        index.emplace_back(ci, k);
        requests.push_back(std::move(r));
      }
    }
    results.push_back(std::move(cr));
  }
  std::vector<DiagnosedRun> done;
  if (const auto status = run_stage("stability", "scan", requests, options, done, true))
    return *status;
  for (std::size_t q = 0; q < done.size(); ++q)
    results[index[q].first].runs[index[q].second] = std::move(done[q]);
  for (auto& cr : results) {
    if (!cr.prep.complete()) {
      for (std::size_t k = 0; k < cr.runs.size(); ++k) {
        cr.runs[k].label = cr.settings[k].label;
        cr.runs[k].cls.verdict = Verdict::kNotAvailable;
        cr.runs[k].unavailable = "preparation run " + cr.prep.verdict_text();
        cr.runs[k].result.status = RunStatus::not_run();
      }
    }
    summarize_case(cr);
  }

  const auto thresholds = respa_size_thresholds(results, preset);

  // 3. Output: HDF5 with everything, the report, the plots.
  const std::string h5 = options.out_dir + "/stability.h5";
  {
    H5Writer w(h5);
    for (std::size_t t = 0; t < thresholds.size(); ++t) {
      char g[64];
      std::snprintf(g, sizeof g, "/respa_size_thresholds/t%02zu", t);
      w.group(g);
      w.attr(g, "imposed_pressure", thresholds[t].pressure);
      w.attr(g, "dt", thresholds[t].dt);
      w.attr(g, "largest_failing_N", thresholds[t].largest_failing);
      w.attr(g, "smallest_holding_N", thresholds[t].smallest_holding);
      w.attr(g, "every_size_has_a_verdict", static_cast<std::int64_t>(thresholds[t].complete));
    }
    w.attr("/", "study", "stability");
    w.attr("/", "preset", preset.name);
    w.attr("/", "cases", static_cast<std::int64_t>(results.size()));
    const Thresholds th;
    w.attr("/", "threshold_force_correlation_min", th.force_correlation_min);
    w.attr("/", "threshold_balance_tolerance", th.balance_tolerance);
    w.attr("/", "threshold_balance_sigmas", th.balance_sigmas);
    w.attr("/", "threshold_lane_order_min", th.lane_order_min);
    for (std::size_t ci = 0; ci < results.size(); ++ci) {
      const CaseResult& cr = results[ci];
      char g[32];
      std::snprintf(g, sizeof g, "/cases/c%02zu", ci);
      const std::string grp = g;
      w.group(grp);
      w.attr(grp, "name", cr.c.name);
      w.attr(grp, "why", cr.c.why);
      w.attr(grp, "state_point", cr.c.point.describe());
      w.attr(grp, "N", cr.c.point.n);
      w.attr(grp, "alpha", cr.c.point.alpha);
      w.attr(grp, "imposed_pressure", cr.c.point.pressure);
      w.attr(grp, "xi_V", cr.c.point.xi_v);
      w.attr(grp, "shear_rate", cr.c.point.gdot);
      w.attr(grp, "largest_stable_dt", cr.largest_stable_dt);
      w.attr(grp, "largest_dt_without_oscillation", cr.largest_held_dt);
      w.attr(grp, "runs_without_oscillation_left_out", std::int64_t(cr.held_left_out));
      w.attr(grp, "first_unstable_dt", cr.first_unstable_dt);
      w.attr(grp, "first_unstable_verdict", cr.first_unstable_verdict);
      w.attr(grp, "lanes", static_cast<std::int64_t>(cr.any_lanes));
      w.attr(grp, "respa_size_scan", static_cast<std::int64_t>(cr.c.respa_size));
      write_diagnosed(w, grp + "/prep", cr.prep, false);
      for (std::size_t k = 0; k < cr.runs.size(); ++k) {
        char rg[32];
        std::snprintf(rg, sizeof rg, "/runs/r%03zu", k);
        const std::string run_group = grp + rg;
        write_diagnosed(w, run_group, cr.runs[k], true);
        w.attr(run_group, "family", cr.settings[k].family());
        w.attr(run_group, "setting", cr.settings[k].label);
        w.attr(run_group, "step", cr.settings[k].dt());
        w.attr(run_group, "tolerance", cr.settings[k].tolerance);
      }
    }
    w.commit();
  }
  const bool plotted = run_plot("stability/plot.py", {h5, options.out_dir}, options);

  // Report.
  std::string md = "# Stability on stiff and extreme cases (preset `" + preset.name + "`)\n\n";
  md +=
      "Each case is prepared once (Euler at a small step from a random state), then every "
      "integrator setting continues from that same state. Verdicts: **diverged** = the run "
      "stopped (non-finite values, negative volume) — shown with the time and message, never "
      "as numbers; **oscillating** = period-2 share of the force power above 5 % (force "
      "step correlation < 0.9) or energy balance below 1 by more than max(5 %, 3σ) (dissipation "
      "inflated); "
      "**lanes** = lane order ≥ 0.3; **incomplete** = stopped by the per-run budget of " +
      short_num(preset.budget_particle_steps) + " particle-steps (about " +
      short_num(preset.budget_particle_steps * 40e-9) +
      " s of one core; 0 = none), i.e. too slow for this preset. Criteria: "
      "`studies/stability/README.md`. Every run is a `jamflow run` process on one thread, one "
      "per core (the sweep engine); CPU s is its CPU time (\"(wall)\": a run file written before "
      "CPU time was recorded, its wall time).\n\n";
  std::vector<std::vector<std::string>> summary_rows;
  for (const auto& cr : results) {
    if (cr.c.respa_size)
      continue;
    summary_rows.push_back({cr.c.name, cr.c.point.describe(), largest_stable_cell(cr),
                            std::isfinite(cr.first_unstable_dt)
                                ? short_num(cr.first_unstable_dt) + ": " + cr.first_unstable_verdict
                                : "none in scan",
                            cr.any_lanes ? "yes" : "no"});
  }
  md += "## Summary (explicit Euler)\n\n";
  md += markdown_table({"case", "state point", "largest stable dt", "first unstable dt", "lanes"},
                       summary_rows);
  md += "\n" + respa_size_section(results, preset, thresholds);
  md += "## Per case\n\n";
  for (const auto& cr : results) {
    md += "### " + cr.c.name + "\n\n" + cr.c.point.describe() + " — " + cr.c.why + ".  \n";
    md += "Preparation: " + cr.prep.verdict_text() + ", t = " +
          short_num(cr.prep.result.series.samples.empty()
                        ? 0.0
                        : cr.prep.result.series.samples.back().time) +
          ".\n\n";
    md += case_table(cr) + "\n";
  }
  {
    std::vector<const DiagnosedRun*> all;
    for (const auto& cr : results)
      for (const auto& r : cr.runs)
        all.push_back(&r);
    md += excluded_section(all);
  }
  md += "## Conclusions\n\n";
  for (const auto& t : thresholds)
    md += "- **RESPA (particles inner) at dt = " + short_num(t.dt) +
          ", P = " + short_num(t.pressure) + "**: " + threshold_text(t, preset) + ".\n";
  for (const auto& cr : results) {
    if (cr.c.respa_size)
      continue;
    md += "- **" + cr.c.name + "**: ";
    if (!cr.prep.complete()) {
      md += "preparation failed: " + cr.prep.verdict_text() + ".\n";
      continue;
    }
    if (std::isfinite(cr.largest_stable_dt))
      md += "Euler stable up to dt = " + short_num(cr.largest_stable_dt);
    else if (std::isfinite(cr.largest_held_dt))
      md += "Euler's stable range is not established: no run oscillates up to dt = " +
            short_num(cr.largest_held_dt) + ", but those runs are left out by their verdicts";
    else
      md += "Euler unstable at every scanned dt (smallest " + short_num(cr.settings.front().dt()) +
            ")";
    if (std::isfinite(cr.largest_stable_dt) && cr.held_left_out > 0)
      md += " (" + std::to_string(cr.held_left_out) +
            " runs that do not oscillate are left out by their verdicts; the largest such dt is " +
            short_num(cr.largest_held_dt) + ")";
    if (std::isfinite(cr.first_unstable_dt))
      md += "; at dt = " + short_num(cr.first_unstable_dt) + ": " + cr.first_unstable_verdict;
    md += cr.any_lanes ? "; lanes detected." : "; no lanes detected.";
    md += "\n";
  }
  md += "\nPlots: " +
        std::string(plotted ? "`stability_map.png`, `stability_diagnostics.png`."
                            : "not produced (see warnings).") +
        "\n";
  write_text(options.out_dir + "/report.md", md);

  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  if (!options.quiet) {
    std::printf("\n%s\n",
                markdown_table({"case", "largest stable dt", "first unstable dt", "lanes"},
                               [&] {
                                 std::vector<std::vector<std::string>> r;
                                 for (const auto& row : summary_rows)
                                   r.push_back({row[0], row[2], row[3], row[4]});
                                 return r;
                               }())
                    .c_str());
    std::printf("stability: wall %.1f s; report %s/report.md\n", wall, options.out_dir.c_str());
  }
  return 0;
}

namespace {
const Registrar reg{{"stability",
                     "stable / oscillating / diverged map against dt or tolerance on stiff and "
                     "extreme cases (alpha_r, high P, stiff piston, large gdot, N = 100 lanes)",
                     run_stability}};
}  // namespace

}  // namespace jamflow::studies
