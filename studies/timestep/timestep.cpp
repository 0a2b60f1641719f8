// Error against run time (issue: `studies/timestep`). For fixed state points (harmonic; constant
// pressure P in {1e-3, 1e-5} and constant volume phi in {0.60, 0.64}, two shear rates each),
// the error of the steady-state means (sigma_xy; phi at constant pressure or P_hat at
// constant volume; the energy-balance residual) against a converged reference (Euler at the
// smallest dt), versus CPU seconds, for Euler, RESPA splittings and CVODE tolerances. Every
// run of a state point starts from the same prepared steady state with the same seed, so the
// comparison is as correlated as the chaotic dynamics allows; the combined block errors are
// the statistical floor below which differences are not resolved. SPEC §4-6.
#include "studies/timestep/timestep.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include "analysis/error_model.hpp"
#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "studies/common.hpp"

namespace jamflow::studies {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Least common multiple of the steps used by the presets (0.02 ... 1.5 and 0.8): 12.
constexpr double kSampleGrid = 12.0;
// Preparation length at constant pressure, in units of 1 / P (xi_s = a = 1): at N = 1000,
// P = 3e-4, J = 1, phi was within 0.002 of its steady value by t = 1.5 / P (the hard-sphere
// study's measurement, studies/pressure_points.hpp).
constexpr double kRelaxPressure = 5.0;

StatePoint cp_point(std::int64_t n, double pressure, double gdot) {
  StatePoint p;
  p.n = n;
  p.constant_pressure = true;
  p.pressure = pressure;
  // Initial packing only: the hard-sphere law at this J (studies/common.hpp), so that the piston
  // starts near the steady state. From 0.635, the P = 1e-5, gdot = 1e-5 point (N = 500) was
  // dilated to phi = 0.5495 by its preparation and was still compacting (to 0.5685) across the
  // averaging window of the reference run.
  p.phi = phi_start(gdot / pressure, n);
  p.gdot = gdot;
  p.name = "P=" + short_num(pressure) + " gdot=" + short_num(gdot);
  return p;
}

StatePoint cv_point(std::int64_t n, double phi, double gdot) {
  StatePoint p;
  p.n = n;
  p.constant_pressure = false;
  p.phi = phi;
  p.gdot = gdot;
  p.name = "phi=" + short_num(phi) + " gdot=" + short_num(gdot);
  return p;
}

}  // namespace

TimestepPreset timestep_preset(const std::string& name) {
  TimestepPreset p;
  p.name = name;
  const std::vector<double> full_dts = {0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 1.0, 1.2, 1.5};
  if (name == "quick") {
    const std::int64_t n = 250;
    p.points = {cp_point(n, 1e-3, 1e-3), cp_point(n, 1e-4, 1e-4), cv_point(n, 0.60, 1e-3),
                cv_point(n, 0.64, 1e-3)};
    p.strain_prep = 0.1;
    p.t_prep_min = 500.0;
    p.strain_eq = 0.01;
    p.t_eq_min = 100.0;
    p.strain_av = 0.2;
    // Blocks of 250 (20 over t_av = 5000): longer than 2 tau_sigma_xy at phi = 0.60 (about
    // 100), so the constant-volume references pass the decorrelated verdict and the study has
    // points to compare (at phi = 0.64, 2 tau is about 230: borderline).
    p.t_av_min = 5000.0;
    p.euler_dts = {0.02, 0.1, 0.3, 0.5, 1.0, 1.5};
    p.respa = {{{"particles", 4, "euler"}, {1.0}}, {{"piston", 4, "euler"}, {0.2}}};
    p.cvode_tols = {1e-3, 1e-5};
    p.rkc_overlaps = {1e-2, 0.1, 1.0};
    p.budget_particle_steps = 2.5e8;  // about 10 s
    p.cvode_max_steps = 20000;
  } else if (name == "standard") {
    const std::int64_t n = 1000;
    // P = 1e-5 near jamming needs small J = gdot / P: N = 500 there to fit the hour.
    p.points = {cp_point(n, 1e-3, 1e-3),   cp_point(n, 1e-3, 1e-4), cp_point(500, 1e-5, 1e-5),
                cp_point(500, 1e-5, 3e-6), cv_point(n, 0.60, 1e-3), cv_point(n, 0.60, 1e-4),
                cv_point(n, 0.64, 1e-3),   cv_point(n, 0.64, 1e-4)};
    p.strain_prep = 0.5;
    p.t_prep_min = 2000.0;
    p.strain_eq = 0.05;
    p.t_eq_min = 500.0;
    p.strain_av = 0.3;
    // Blocks of 3000 (20 over t_av = 6e4): at least 2 tau_sigma_xy, tau_phi (500-1400 at these
    // points). With t_av = 1e4 (blocks of 480), 81 stable runs of one replica each were left
    // out as correlated and six of the eight points had no usable reference.
    p.t_av_min = 6e4;
    p.euler_dts = full_dts;
    p.respa = {{{"particles", 4, "euler"}, {0.5, 1.0, 1.2, 1.5}},
               {{"piston", 4, "euler"}, {0.1, 0.2, 0.4}},
               {{"particles", 2, "heun"}, {0.2, 0.4, 0.8}}};
    p.cvode_tols = {1e-3, 1e-4, 1e-5, 1e-6};
    p.rkc_overlaps = {1e-2, 0.1, 0.3, 1.0};
    p.budget_particle_steps = 1.5e10;  // about 600 s
  } else if (name == "paper") {
    const std::int64_t n = 1000;
    p.points = {cp_point(n, 1e-3, 1e-4), cp_point(n, 1e-3, 1e-5), cp_point(n, 1e-5, 1e-6),
                cp_point(n, 1e-5, 1e-7), cv_point(n, 0.60, 1e-4), cv_point(n, 0.60, 1e-5),
                cv_point(n, 0.64, 1e-5), cv_point(n, 0.64, 1e-6)};
    p.strain_prep = 1.0;
    p.t_prep_min = 1e4;
    p.strain_eq = 0.5;  // t_eq = t_av, t_eq + t_av >= 1 / gdot (seed's protocol)
    p.t_eq_min = 1e4;
    p.strain_av = 0.5;
    p.t_av_min = 1e4;
    p.euler_dts = full_dts;
    p.respa = {{{"particles", 4, "euler"}, {0.5, 1.0, 1.2, 1.5}},
               {{"piston", 4, "euler"}, {0.1, 0.2, 0.4, 0.5}},
               {{"particles", 2, "heun"}, {0.2, 0.4, 0.8, 1.0}}};
    p.cvode_tols = {1e-3, 1e-4, 1e-5, 1e-6, 1e-7};
    p.rkc_overlaps = {1e-3, 1e-2, 0.1, 0.3, 1.0};
  } else {
    throw ConfigError("--preset " + name + "; allowed quick, standard, paper");
  }
  return p;
}

std::vector<AccuracyTarget> accuracy_targets() {
  return {{"sigma_xy", 0.05}, {"sigma_xy", 0.01}, {"phi", 1e-3},     {"phi", 1e-4},
          {"pressure", 0.05}, {"pressure", 0.01}, {"balance", 0.05}, {"balance", 0.01}};
}

namespace {

struct RunErrors {
  bool available = false;                       // complete, stable, reference usable
  double sigma_err = kNaN, sigma_floor = kNaN;  // relative
  double obs_err = kNaN, obs_floor = kNaN;      // phi absolute (CP) or P_hat relative (CV)
  double balance = kNaN, balance_floor = kNaN;  // |ratio - 1| and its error
};

struct PointResult {
  StatePoint point;
  DiagnosedRun prep;
  std::vector<IntegratorSetting> settings;
  std::vector<DiagnosedRun> runs;
  std::vector<RunErrors> errors;
  int reference = -1;
  double t_eq = 0.0, t_av = 0.0;
  // The fine settings' scatter (see compute_errors): the factor applied to the floors.
  analysis::Scatter sigma_scatter, obs_scatter;
  int fine_runs = 0;
};

// Settings fine enough that their means differ from the exact dynamics' far below the
// statistical floor: Euler at dt <= 0.1 (SPEC §4: stable to about 0.4), CVODE at rtol <= 1e-5,
// RKC at atol <= 0.01 delta. Their scatter measures how far the block errors understate the
// run-to-run scatter (chaotic trajectories decorrelate; slow modes such as phi at constant
// pressure outlast the blocks).
bool fine_setting(const IntegratorSetting& s) {
  return (s.family() == "euler" && s.dt() <= 0.1 + 1e-12) ||
         (s.family() == "cvode" && s.tolerance <= 1e-5 * (1 + 1e-9)) ||
         (s.family() == "rkc" && s.tolerance <= 0.01 * (1 + 1e-9));
}

double duration(double strain, double gdot, double t_min) {
  return std::max(t_min, strain / gdot);
}

std::string family_label(const IntegratorSetting& s) {
  const std::string l = s.label;
  const auto cut = l.rfind(' ');
  return s.family() == "cvode" || s.family() == "rkc" ? s.family() : l.substr(0, cut);
}

void compute_errors(PointResult& pr) {
  pr.errors.assign(pr.runs.size(), {});
  // Reference: Euler at the smallest dt, if it is stable.
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < pr.runs.size(); ++k) {
    if (pr.settings[k].family() == "euler" && pr.settings[k].dt() < best) {
      best = pr.settings[k].dt();
      pr.reference = static_cast<int>(k);
    }
  }
  if (pr.reference < 0)
    return;
  const DiagnosedRun& ref = pr.runs[std::size_t(pr.reference)];
  if (ref.cls.verdict != Verdict::kStable)
    return;
  const bool cp = pr.point.constant_pressure;
  const std::string obs = cp ? "phi" : "pressure";
  const double s_ref = ref.value("sigma_xy"), s_ref_e = ref.value("sigma_xy_err");
  const double o_ref = ref.value(obs), o_ref_e = ref.value(obs + "_err");
  for (std::size_t k = 0; k < pr.runs.size(); ++k) {
    const DiagnosedRun& r = pr.runs[k];
    RunErrors& e = pr.errors[k];
    if (!r.complete())
      continue;
    e.available = r.cls.verdict == Verdict::kStable || r.cls.verdict == Verdict::kOscillating;
    const double s = r.value("sigma_xy"), se = r.value("sigma_xy_err");
    const double t_eq = r.t_eq;
    const auto blocks = static_cast<std::size_t>(r.blocks);
    // Floor: the paired error when the sample grids match, else the combined block errors.
    auto floor_of = [&](double Sample::*field, double e1, double e2) {
      const double p = paired_error(r.result.series, ref.result.series, t_eq, field, blocks);
      return std::isfinite(p) && int(k) != pr.reference ? p : std::hypot(e1, e2);
    };
    e.sigma_err = std::abs(s - s_ref) / std::abs(s_ref);
    e.sigma_floor = floor_of(&Sample::sigma_xy, se, s_ref_e) / std::abs(s_ref);
    const double o = r.value(obs), oe = r.value(obs + "_err");
    const double scale = cp ? 1.0 : std::abs(o_ref);
    e.obs_err = std::abs(o - o_ref) / scale;
    e.obs_floor = floor_of(cp ? &Sample::phi : &Sample::pressure, oe, o_ref_e) / scale;
    e.balance = r.balance.residual;
    e.balance_floor = r.balance.error;
  }
  // The floors are block errors. Where the fine settings' stable runs scatter more than their
  // block errors allow (chi2/dof > 1 about their weighted mean), the floors are multiplied by
  // sqrt(chi2/dof), the rule of the analysis' fits (analysis/error_model.hpp).
  std::vector<double> sx, se, ox, oe;
  for (std::size_t k = 0; k < pr.runs.size(); ++k) {
    const DiagnosedRun& r = pr.runs[k];
    if (!r.complete() || r.cls.verdict != Verdict::kStable || !fine_setting(pr.settings[k]))
      continue;
    sx.push_back(r.value("sigma_xy"));
    se.push_back(r.value("sigma_xy_err"));
    ox.push_back(r.value(obs));
    oe.push_back(r.value(obs + "_err"));
  }
  pr.fine_runs = static_cast<int>(sx.size());
  pr.sigma_scatter = analysis::scatter_of(sx, se);
  pr.obs_scatter = analysis::scatter_of(ox, oe);
  for (auto& e : pr.errors) {
    e.sigma_floor *= pr.sigma_scatter.error_scale;
    e.obs_floor *= pr.obs_scatter.error_scale;
  }
}

// (error, floor) of a run for a target observable; NaN if it does not apply.
std::pair<double, double> error_for(const PointResult& pr, std::size_t k,
                                    const std::string& observable) {
  const RunErrors& e = pr.errors[k];
  const bool cp = pr.point.constant_pressure;
  if (observable == "sigma_xy")
    return {e.sigma_err, e.sigma_floor};
  if (observable == "phi")
    return cp ? std::make_pair(e.obs_err, e.obs_floor) : std::make_pair(kNaN, kNaN);
  if (observable == "pressure")
    return cp ? std::make_pair(kNaN, kNaN) : std::make_pair(e.obs_err, e.obs_floor);
  return {e.balance, e.balance_floor};
}

struct TargetOutcome {
  std::string text;  // "euler dt=0.3 (12 s)", "unresolved (2σ floor 1.3 %)", "none", "n/a"
  int run = -1;
};

std::string percent_or_abs(const std::string& observable, double v) {
  if (!std::isfinite(v))
    return "—";
  if (observable == "phi")
    return num(v, 2);
  return num(100.0 * v, 2) + " %";
}

TargetOutcome cheapest(const PointResult& pr, const AccuracyTarget& t) {
  TargetOutcome out;
  if (pr.reference < 0 || pr.runs[std::size_t(pr.reference)].cls.verdict != Verdict::kStable) {
    out.text = "no stable reference";
    return out;
  }
  double best_cpu = std::numeric_limits<double>::infinity();
  double min_floor = std::numeric_limits<double>::infinity();
  bool applies = false;
  for (std::size_t k = 0; k < pr.runs.size(); ++k) {
    if (int(k) == pr.reference || !pr.runs[k].complete())
      continue;
    const auto [err, floor] = error_for(pr, k, t.observable);
    if (!std::isfinite(err))
      continue;
    applies = true;
    if (pr.runs[k].cls.verdict != Verdict::kStable)
      continue;
    min_floor = std::min(min_floor, floor);
    if (err + 2.0 * floor <= t.value && pr.runs[k].cpu_seconds < best_cpu) {
      best_cpu = pr.runs[k].cpu_seconds;
      out.run = int(k);
    }
  }
  if (!applies) {
    out.text = "n/a";
  } else if (out.run >= 0) {
    out.text = pr.settings[std::size_t(out.run)].label + " (" + num(best_cpu, 3) + " s)";
  } else if (std::isfinite(min_floor) && 2.0 * min_floor > t.value) {
    out.text = "unresolved (2σ floor " + percent_or_abs(t.observable, 2.0 * min_floor) + ")";
  } else {
    out.text = "none of the stable settings";
  }
  return out;
}

std::string point_table(const PointResult& pr) {
  const bool cp = pr.point.constant_pressure;
  std::vector<std::vector<std::string>> rows;
  for (std::size_t k = 0; k < pr.runs.size(); ++k) {
    const DiagnosedRun& r = pr.runs[k];
    const RunErrors& e = pr.errors.empty() ? RunErrors{} : pr.errors[k];
    std::string label = pr.settings[k].label + (int(k) == pr.reference ? " (ref.)" : "");
    if (!r.complete()) {
      rows.push_back({label, r.verdict_text(), "—", "—", "—", "—", "—", "—", "—"});
      continue;
    }
    const std::string obs = cp ? "phi" : "pressure";
    rows.push_back({label, r.verdict_text(), pm(r.value("sigma_xy"), r.value("sigma_xy_err"), 4),
                    std::isfinite(e.sigma_err)
                        ? num(100 * e.sigma_err, 2) + " ± " + num(100 * e.sigma_floor, 2) + " %"
                        : "—",
                    pm(r.value(obs), r.value(obs + "_err"), cp ? 5 : 4),
                    std::isfinite(e.obs_err)
                        ? (cp ? num(e.obs_err, 2) + " ± " + num(e.obs_floor, 2)
                              : num(100 * e.obs_err, 2) + " ± " + num(100 * e.obs_floor, 2) + " %")
                        : "—",
                    pm(r.balance.ratio, r.balance.error, 3), cpu_cell(r),
                    num(r.particle_steps, 3)});
  }
  return markdown_table(
      {"integrator", "verdict", "σ_xy", "|Δσ_xy|/σ_ref ± floor", cp ? "φ" : "P̂",
       cp ? "|Δφ| ± floor" : "|ΔP̂|/P̂_ref ± floor", "energy balance", "CPU s", "particle-steps"},
      rows);
}

// One cell of the claims table: the verdict and, if stable, the sigma_xy and phi/P shifts from
// the reference with their significance (z = shift / paired floor). "agrees" = both shifts
// below 1 % (sigma_xy, P_hat) and 1e-3 (phi) or statistically unresolved (z <= 2).
std::string claim_cell(const PointResult& pr, int k) {
  if (k < 0)
    return "—";
  const DiagnosedRun& r = pr.runs[std::size_t(k)];
  if (r.cls.verdict != Verdict::kStable) {
    if (r.cls.verdict == Verdict::kOscillating)
      return "oscillating (EB " + num(r.balance.ratio, 2) + ")";
    if (r.cls.verdict == Verdict::kDiverged)
      return "**diverged**";
    return verdict_name(r.cls.verdict);
  }
  if (pr.errors.empty() || !std::isfinite(pr.errors[std::size_t(k)].sigma_err))
    return "stable";
  const RunErrors& e = pr.errors[std::size_t(k)];
  const bool cp = pr.point.constant_pressure;
  const double zs = e.sigma_err / e.sigma_floor, zo = e.obs_err / e.obs_floor;
  const bool s_ok = zs <= 2.0 || e.sigma_err <= 0.01;
  const bool o_ok = zo <= 2.0 || e.obs_err <= (cp ? 1e-3 : 0.01);
  return std::string(s_ok && o_ok ? "stable, agrees" : "stable, **differs**") + ": σ " +
         num(100 * e.sigma_err, 2) + " % (" + num(zs, 2) + "σ), " + (cp ? "φ " : "P̂ ") +
         (cp ? num(e.obs_err, 2) : num(100 * e.obs_err, 2) + " %") + " (" + num(zo, 2) + "σ)";
}

int find_setting(const PointResult& pr, const std::string& family_prefix, double dt) {
  for (std::size_t k = 0; k < pr.settings.size(); ++k) {
    if (family_label(pr.settings[k]) == family_prefix && std::abs(pr.settings[k].dt() - dt) < 1e-12)
      return int(k);
  }
  return -1;
}

double first_unstable_euler(const PointResult& pr) {
  std::vector<std::pair<double, Verdict>> e;
  for (std::size_t k = 0; k < pr.runs.size(); ++k)
    if (pr.settings[k].family() == "euler")
      e.emplace_back(pr.settings[k].dt(), pr.runs[k].cls.verdict);
  std::sort(e.begin(), e.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [dt, v] : e)
    if (v == Verdict::kOscillating || v == Verdict::kDiverged)
      return dt;
  return kNaN;
}

}  // namespace

int run_timestep(const StudyOptions& options) {
  return run_timestep_preset(timestep_preset(options.preset), options);
}

int run_timestep_preset(const TimestepPreset& preset, const StudyOptions& options) {
  ensure_dir(options.out_dir);
  const auto wall0 = std::chrono::steady_clock::now();
  if (!options.quiet) {
    std::printf("jamflow study timestep (%s): %zu state points -> %s\n", preset.name.c_str(),
                preset.points.size(), options.out_dir.c_str());
  }
  // 1. One prepared steady state per point (Euler dt = 0.05 from a random state). At constant
  // pressure, phi relaxes on the time scale xi_s a / P: at least kRelaxPressure / P.
  std::vector<RunRequest> prep_requests;
  for (const auto& pt : preset.points) {
    double t = duration(preset.strain_prep, pt.gdot, preset.t_prep_min);
    if (pt.constant_pressure)
      t = std::max(t, kRelaxPressure / pt.pressure);
    RunRequest r;
    r.label = pt.name + " prep";
    r.scene = scene_toml(pt, euler_setting(0.05), 0.5 * t, 0.5 * t, t / 400.0);
    r.seed = pt.seed;
    r.window = false;
    prep_requests.push_back(r);
  }
  std::vector<DiagnosedRun> preps;
  if (const auto status = run_stage("timestep", "prep", prep_requests, options, preps, false))
    return *status;

  // 2. Every integrator setting from the prepared state.
  std::vector<PointResult> results;
  std::vector<RunRequest> requests;
  std::vector<std::pair<std::size_t, std::size_t>> index;
  for (std::size_t pi = 0; pi < preset.points.size(); ++pi) {
    PointResult pr;
    pr.point = preset.points[pi];
    pr.prep = preps[pi];
    for (double dt : preset.euler_dts)
      pr.settings.push_back(euler_setting(dt));
    for (const auto& rs : preset.respa)
      for (double dt : rs.dts)
        pr.settings.push_back(
            respa_setting(dt, rs.splitting.n_inner, rs.splitting.inner, rs.splitting.scheme));
    // CVODE: atol = rtol x the typical overlap delta = P^(1/(alpha_r - 1)), so that the
    // relative and absolute criteria tighten together.
    const double p_est = pr.point.constant_pressure ? pr.point.pressure : pr.prep.value("pressure");
    const double delta = std::clamp(
        std::pow(std::isfinite(p_est) && p_est > 0 ? p_est : 1e-3, 1.0 / (pr.point.alpha - 1.0)),
        1e-9, 1.0);
    for (double tol : preset.cvode_tols)
      pr.settings.push_back(cvode_setting(tol, tol * delta, preset.cvode_max_steps));
    for (double overlaps : preset.rkc_overlaps)
      pr.settings.push_back(rkc_setting(overlaps, delta));
    pr.t_eq = duration(preset.strain_eq, pr.point.gdot, preset.t_eq_min);
    pr.t_av = duration(preset.strain_av, pr.point.gdot, preset.t_av_min);
    pr.runs.resize(pr.settings.size());
    // One sampling grid for every setting (a multiple of every step in the presets, so that
    // no step is shortened and the runs can be compared sample by sample): ~400 samples.
    const double grid = kSampleGrid * std::max(1.0, std::round(pr.t_av / 400.0 / kSampleGrid));
    if (pr.prep.complete() && !pr.prep.final_xyz.empty()) {
      for (std::size_t k = 0; k < pr.settings.size(); ++k) {
        RunRequest r;
        r.label = pr.point.name + " " + pr.settings[k].label;
        r.scene = scene_toml(pr.point, pr.settings[k], pr.t_eq, pr.t_av, grid);
        r.seed = pr.point.seed;
        r.init = pr.prep.final_xyz;
        // The reference (smallest Euler dt, the first setting) is never cut by the budget.
        r.budget = k == 0 ? 0 : budget_for(preset.budget_particle_steps, pr.point.n);
        index.emplace_back(pi, k);
        requests.push_back(std::move(r));
      }
    } else {
      for (std::size_t k = 0; k < pr.settings.size(); ++k) {
        pr.runs[k].cls.verdict = Verdict::kNotAvailable;
        pr.runs[k].unavailable = "preparation " + pr.prep.verdict_text();
        pr.runs[k].result.status = RunStatus::not_run();
      }
    }
    results.push_back(std::move(pr));
  }
  // The sweep engine runs the longest first, so that the cores finish together.
  std::vector<DiagnosedRun> done;
  if (const auto status = run_stage("timestep", "settings", requests, options, done, true))
    return *status;
  for (std::size_t q = 0; q < done.size(); ++q) {
    const auto& [pi, k] = index[q];
    results[pi].runs[k] = std::move(done[q]);
  }
  for (auto& pr : results)
    compute_errors(pr);

  // 3. Targets.
  const auto targets = accuracy_targets();
  std::vector<std::vector<TargetOutcome>> outcomes(targets.size());
  for (std::size_t t = 0; t < targets.size(); ++t)
    for (const auto& pr : results)
      outcomes[t].push_back(cheapest(pr, targets[t]));

  // 4. HDF5.
  const std::string h5 = options.out_dir + "/timestep.h5";
  {
    H5Writer w(h5);
    w.attr("/", "study", "timestep");
    w.attr("/", "preset", preset.name);
    w.attr("/", "timing",
           "cpu_seconds: CPU seconds of each run's jamflow run process on 1 thread, one run "
           "per core (a run with cpu_from_wall = 1 was written before CPU time was recorded: "
           "its wall seconds)");
    for (std::size_t pi = 0; pi < results.size(); ++pi) {
      const PointResult& pr = results[pi];
      char g[32];
      std::snprintf(g, sizeof g, "/points/p%02zu", pi);
      const std::string grp = g;
      w.group(grp);
      w.attr(grp, "name", pr.point.name);
      w.attr(grp, "state_point", pr.point.describe());
      w.attr(grp, "constant_pressure", static_cast<std::int64_t>(pr.point.constant_pressure));
      w.attr(grp, "imposed_pressure", pr.point.pressure);
      w.attr(grp, "phi", pr.point.phi);
      w.attr(grp, "shear_rate", pr.point.gdot);
      w.attr(grp, "N", pr.point.n);
      w.attr(grp, "t_eq", pr.t_eq);
      w.attr(grp, "t_av", pr.t_av);
      w.attr(grp, "reference", static_cast<std::int64_t>(pr.reference));
      w.attr(grp, "first_unstable_euler_dt", first_unstable_euler(pr));
      write_diagnosed(w, grp + "/prep", pr.prep, false);
      for (std::size_t k = 0; k < pr.runs.size(); ++k) {
        char rg[32];
        std::snprintf(rg, sizeof rg, "/runs/r%03zu", k);
        const std::string run_group = grp + rg;
        write_diagnosed(w, run_group, pr.runs[k], true);
        w.attr(run_group, "family", pr.settings[k].family());
        w.attr(run_group, "curve", family_label(pr.settings[k]));
        w.attr(run_group, "setting", pr.settings[k].label);
        w.attr(run_group, "step", pr.settings[k].dt());
        w.attr(run_group, "tolerance", pr.settings[k].tolerance);
        const RunErrors& e = pr.errors[k];
        w.attr(run_group, "err_sigma_xy", e.sigma_err);
        w.attr(run_group, "floor_sigma_xy", e.sigma_floor);
        w.attr(run_group, pr.point.constant_pressure ? "err_phi" : "err_pressure", e.obs_err);
        w.attr(run_group, pr.point.constant_pressure ? "floor_phi" : "floor_pressure", e.obs_floor);
        w.attr(run_group, "err_balance", e.balance);
        w.attr(run_group, "floor_balance", e.balance_floor);
        w.attr(run_group, "is_reference", static_cast<std::int64_t>(int(k) == pr.reference));
      }
    }
    for (std::size_t t = 0; t < targets.size(); ++t) {
      char g[32];
      std::snprintf(g, sizeof g, "/targets/t%02zu", t);
      w.group(g);
      w.attr(g, "observable", targets[t].observable);
      w.attr(g, "value", targets[t].value);
      for (std::size_t pi = 0; pi < results.size(); ++pi)
        w.attr(g, "p" + std::to_string(pi), outcomes[t][pi].text);
    }
    w.commit();
  }
  const bool plotted = run_plot("timestep/plot.py", {h5, options.out_dir}, options);

  // 5. Report.
  std::string md = "# Error against run time (preset `" + preset.name + "`)\n\n";
  md +=
      "Harmonic mixture. Each state point is prepared once (Euler dt = 0.05 from a random "
      "state at the hard-sphere law's phi for its J, t = " +
      short_num(preset.t_prep_min) + " or strain " + short_num(preset.strain_prep) +
      ", whichever is longer, and at constant pressure at least " + short_num(kRelaxPressure) +
      " / P, the time over which phi relaxes); every integrator then continues from that same "
      "state with "
      "the same seed: t_eq = max(" +
      short_num(preset.t_eq_min) + ", " + short_num(preset.strain_eq) + " / gdot), t_av = max(" +
      short_num(preset.t_av_min) + ", " + short_num(preset.strain_av) +
      " / gdot), 20 blocks. The reference is Euler at the smallest dt. Errors are |mean − "
      "reference| (relative for σ_xy and P̂, absolute for φ) ± the combined block error "
      "(the statistical floor: the dynamics is chaotic, so runs decorrelate and differences "
      "below ~2× the floor are not resolved). The energy-balance error is |ratio − 1| "
      "(exact value 1; drift corrected, see studies/stability/README.md). CPU s is the "
      "CPU time of each run's `jamflow run` process on one thread (the sweep engine runs one "
      "run per core; \"(wall)\": a run file written before CPU time was recorded, its wall "
      "time); particle-steps = N × force-pass equivalents (force evaluations, plus CVODE's "
      "Jacobian work in force-pass units). Stability verdicts as in the stability "
      "study. A target is met when error + 2 × floor ≤ target for a *stable* run.\n\n";
  if (preset.name != "paper") {
    md +=
        "Reductions against the seed's protocol (`paper` preset): run lengths above (the seed "
        "uses t_eq = t_av with t_eq + t_av ≥ 1/gdot, i.e. strain ≥ 1); the state points "
        "listed below (quick: N = 250, one shear rate each, P = 1e-4 instead of 1e-5; "
        "standard: the P = 1e-5 points at N = 500 and J = 1, 0.3 instead of N = 1000 and "
        "J ≲ 0.1); one replica. A per-run budget of " +
        short_num(preset.budget_particle_steps) +
        " particle-steps ([run] max_force_evaluations = budget / N; about " +
        short_num(preset.budget_particle_steps * 40e-9) +
        " s of one core) marks slower runs *incomplete*.\n\n";
  }
  // Headline: cheapest setting per target.
  {
    std::vector<std::string> header = {"target"};
    for (const auto& pr : results)
      header.push_back(pr.point.name);
    std::vector<std::vector<std::string>> rows;
    for (std::size_t t = 0; t < targets.size(); ++t) {
      const auto& tg = targets[t];
      std::string name = tg.observable == "phi"
                             ? "|Δφ| ≤ " + short_num(tg.value)
                             : (tg.observable == "balance"
                                    ? "|EB − 1| ≤ " + num(100 * tg.value, 2) + " %"
                                    : (tg.observable == "sigma_xy" ? "σ_xy" : "P̂") +
                                          std::string(" ≤ ") + num(100 * tg.value, 2) + " %");
      std::vector<std::string> row = {name};
      for (std::size_t pi = 0; pi < results.size(); ++pi)
        row.push_back(outcomes[t][pi].text);
      rows.push_back(row);
    }
    md += "## Cheapest setting per accuracy target\n\n" + markdown_table(header, rows) + "\n";
  }
  // Claims.
  {
    const std::vector<double> claim_dts = {0.4, 0.5, 1.0, 1.2, 1.5};
    std::vector<std::string> header = {"state point", "integrator"};
    for (double dt : claim_dts)
      header.push_back("dt = " + short_num(dt));
    std::vector<std::vector<std::string>> rows;
    for (const auto& pr : results) {
      for (const std::string fam : {"euler", "respa particlesx4"}) {
        std::vector<std::string> row = {pr.point.name, fam};
        bool any = false;
        for (double dt : claim_dts) {
          const int k = find_setting(pr, fam, dt);
          any = any || k >= 0;
          row.push_back(claim_cell(pr, k));
        }
        if (any)
          rows.push_back(row);
      }
    }
    md +=
        "## The seed's claim (dt = 1.0 as good as 0.5 and 1.2; 1.5 unstable) and SPEC §4 "
        "(Euler unstable from dt ≈ 0.4)\n\n";
    md +=
        "Cells: verdict; for stable runs the shifts of σ_xy and of φ (or P̂) from the "
        "reference and their significance in units of the paired floor; agrees = each shift "
        "below 1 % (σ_xy, P̂) or 1e-3 (φ), or not resolved (≤ 2σ).\n\n";
    md += markdown_table(header, rows) + "\n";
    md += "First unstable Euler dt per state point: ";
    for (std::size_t pi = 0; pi < results.size(); ++pi) {
      const double d = first_unstable_euler(results[pi]);
      md += (pi ? "; " : "") + results[pi].point.name + ": " +
            (std::isfinite(d) ? short_num(d) : "none in scan");
    }
    md += ".\n\n";
  }
  {
    std::vector<const DiagnosedRun*> all;
    for (const auto& pr : results)
      for (const auto& r : pr.runs)
        all.push_back(&r);
    md += excluded_section(all);
  }
  md += "## Per state point\n\n";
  for (const auto& pr : results) {
    md += "### " + pr.point.name + "\n\n" + pr.point.describe() + "; t_eq = " + short_num(pr.t_eq) +
          ", t_av = " + short_num(pr.t_av) + ". Preparation: " + pr.prep.verdict_text() + ".\n\n";
    if (pr.fine_runs >= 2) {
      const auto scale_text = [](const analysis::Scatter& sc) {
        return sc.error_scale > 1.0 ? "chi2/dof = " + num(sc.reduced_chi2, 3) +
                                          ", floors multiplied by " + num(sc.error_scale, 3)
                                    : "chi2/dof = " + num(sc.reduced_chi2, 3) + ", floors kept";
      };
      md += "The " + std::to_string(pr.fine_runs) +
            " stable fine settings (Euler dt ≤ 0.1, CVODE rtol ≤ 1e-5, RKC atol ≤ 0.01 δ) "
            "about their weighted mean: σ_xy " +
            scale_text(pr.sigma_scatter) + "; " + (pr.point.constant_pressure ? "φ " : "P̂ ") +
            scale_text(pr.obs_scatter) +
            " (block errors understate the scatter of runs where "
            "chi2/dof > 1).\n\n";
    }
    md += point_table(pr) + "\n";
  }
  md += "\nPlots: " +
        std::string(plotted ? "`timestep_wp_sigma_xy.png`, `timestep_wp_phi_pressure.png`, "
                              "`timestep_wp_balance.png` (work–precision, log–log; crosses: "
                              "unstable runs; dashed: 2× statistical floor)."
                            : "not produced (see warnings).") +
        "\n";
  write_text(options.out_dir + "/report.md", md);

  if (!options.quiet) {
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    std::printf("\ntimestep: first unstable Euler dt:");
    for (const auto& pr : results)
      std::printf("  [%s] %g", pr.point.name.c_str(), first_unstable_euler(pr));
    std::printf("\ncheapest for sigma_xy <= 5 %%:");
    for (std::size_t pi = 0; pi < results.size(); ++pi)
      std::printf("  [%s] %s", results[pi].point.name.c_str(), outcomes[0][pi].text.c_str());
    std::printf("\ntimestep: wall %.1f s; report %s/report.md\n", wall, options.out_dir.c_str());
  }
  return 0;
}

namespace {
const Registrar reg{{"timestep",
                     "error of steady-state means against CPU time for Euler, RESPA and CVODE "
                     "(work-precision) at fixed state points",
                     run_timestep}};
}  // namespace

}  // namespace jamflow::studies
