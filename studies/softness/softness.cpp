// Potential-exponent optimization (issue: `studies/softness`; the seed's alpha_r study, sec.
// "Model and numerical methods"; SPEC §5 last item). For each alpha_r:
//   A. the fastest stable integrator: explicit Euler, RESPA (particles on the inner level) and
//      CVODE, each stable (studies/diagnostics) and accurate against the smallest stable Euler
//      step at both ends of the overlap range; the cheapest of these per tau_0 (measured);
//   B. for target viscous numbers J, a pressure scan with that integrator: P* = the largest P
//      at which mu and phi agree with a common P -> 0 reference within errors. The hard-sphere
//      limit phi(J), mu(J) does not depend on alpha_r, so the reference is one per J: alpha_r =
//      2 at a pressure far below the grid (CVODE, relaxed for t >= relax_pressure / P);
//   C. the measured cost to reach strain 1 at (P*, J) with that integrator.
// The pressure grid of each alpha_r is P = delta^(alpha_r - 1) over a common list of typical
// overlaps delta (contact force = delta^(alpha_r - 1) in units eps/a).
#include "studies/softness/softness.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numeric>
#include <tuple>

#include "ensembles/constant_pressure.hpp"
#include "integrators/registry.hpp"
#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "studies/common.hpp"

namespace jamflow::studies {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kSampleGrid = 12.0;  // a multiple of every scanned step: paired comparisons
}  // namespace

SoftnessPreset softness_preset(const std::string& name) {
  SoftnessPreset p;
  p.name = name;
  if (name == "quick") {
    p.n = 150;
    p.alphas = {1.5, 2.0, 3.0};
    p.deltas = {1e-2, 3e-3};
    p.p_min = 1e-4;  // alpha_r = 3 keeps delta = 1e-2 only (P = 1e-4)
    p.targets_j = {1.0};
    p.scan_dts = {0.002, 0.01, 0.05, 0.2, 0.4, 1.0, 1.5};
    p.respa_dts = {1.0};
    p.cvode_tols = {1e-4};
    p.rkc_overlaps = {0.1};
    p.cvode_max_steps = 20000;
    p.t_prep = 200.0;
    p.strain_prep = 0.02;
    p.t_scan = 600.0;
    p.strain_eq = 0.05;
    p.strain_av = 0.2;
    p.t_min = 600.0;
    // Blocks of 0.5 / P: shorter than 2 tau at the lower pressures, so some runs are left out
    // as correlated (the pipeline, not the physics).
    p.average_pressure = 10.0;
    p.p_reference = 1e-4;
    p.reference_average = 10.0;
    p.reference_replicas = 2;
    p.budget_particle_steps = 3.75e8;  // about 15 s
  } else if (name == "standard") {
    p.n = 250;
    // alpha_r = 1.2 is left out: no step down to 0.001 was stable in the earlier standard
    // preset, and CVODE diverged there in the stability study; the paper preset keeps it.
    p.alphas = {1.5, 1.75, 2.0, 2.5, 3.0};
    // Down to delta = 1e-4: at delta = 1e-3 every alpha_r still differed from the common
    // reference by 0.004-0.006 in phi (about 8 standard errors), so no P* was reached.
    p.deltas = {3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4};
    // Leaves out alpha_r = 3 from delta = 1e-3 and alpha_r = 2.5 at delta = 1e-4 (P = 1e-6:
    // t_eq = 5e6).
    p.p_min = 5e-6;
    p.targets_j = {1.0, 0.1};
    p.scan_dts = {0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 1.0, 1.5};
    p.respa_dts = {0.008, 0.04, 0.4, 1.0, 2.0};
    p.cvode_tols = {1e-3, 1e-5};
    p.rkc_overlaps = {1e-2, 0.1, 1.0};
    p.t_prep = 500.0;
    p.strain_prep = 0.05;
    p.t_scan = 1500.0;
    p.strain_eq = 0.1;
    p.strain_av = 0.5;
    p.t_min = 1000.0;
    // Blocks of 2 / P: the quick preset measured tau_phi = 0.25-0.5 / P near jamming (N = 150,
    // P = 1e-4), the finite-size standard preset blocks of 0.15 / P too short at P = 1e-5.
    p.average_pressure = 40.0;
    p.p_reference = 1e-5;
    p.reference_average = 40.0;
    p.reference_replicas = 2;
    // About 80 s at 40 ns, 200 s at 100 ns: the longest planned Euler run (alpha_r = 1.75,
    // delta = 1e-3, dt = 0.002, t = 8100) needs 1.0e9.
    p.budget_particle_steps = 2e9;
  } else if (name == "paper") {
    p.n = 1000;
    p.alphas = {1.2, 1.5, 1.75, 2.0, 2.25, 2.5, 3.0};
    p.deltas = {1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 3e-4};
    p.p_min = 1e-7;
    p.targets_j = {1.0, 0.1, 0.01};
    p.scan_dts = {0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2,
                  0.3,    0.4,   0.5,   1.0,   1.2,  1.5,  2.0,  3.0};
    p.respa_dts = {0.004, 0.008, 0.04, 0.2, 0.4, 1.0, 1.2, 2.0, 3.0};
    p.cvode_tols = {1e-3, 1e-4, 1e-5, 1e-6};
    p.rkc_overlaps = {1e-3, 1e-2, 0.1, 0.3, 1.0};
    p.t_prep = 5000.0;
    p.strain_prep = 0.5;
    p.t_scan = 10000.0;
    p.strain_eq = 0.5;  // t_eq = t_av, strain >= 1 (seed's protocol)
    p.strain_av = 0.5;
    p.t_min = 10000.0;
    p.average_pressure = 40.0;
    p.p_reference = 1e-6;
    p.reference_average = 40.0;
    p.reference_replicas = 3;
  } else {
    throw ConfigError("--preset " + name + "; allowed quick, standard, paper");
  }
  return p;
}

double steps_per_particle(double j, double pressure, double dt) {
  return 1.0 / (j * pressure * dt);
}

double cost_to_strain_one(double per_tau, double j, double pressure) {
  return per_tau / (j * pressure);
}

PStar find_p_star(const std::vector<ScanValue>& points, const ScanValue& ref, double sigmas) {
  PStar out;
  const std::size_t m = points.size();
  out.agrees.assign(m, -1);
  out.dmu.assign(m, kNaN);
  out.dmu_err.assign(m, kNaN);
  out.dphi.assign(m, kNaN);
  out.dphi_err.assign(m, kNaN);
  std::vector<std::size_t> order(m);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return points[a].pressure < points[b].pressure; });
  for (std::size_t k = 0; k < m; ++k) {
    const ScanValue& p = points[k];
    if (!p.usable || !ref.usable)
      continue;
    out.dmu[k] = p.mu - ref.mu;
    out.dmu_err[k] = std::hypot(p.mu_err, ref.mu_err);
    out.dphi[k] = p.phi - ref.phi;
    out.dphi_err[k] = std::hypot(p.phi_err, ref.phi_err);
    out.agrees[k] = std::abs(out.dmu[k]) <= sigmas * out.dmu_err[k] &&
                    std::abs(out.dphi[k]) <= sigmas * out.dphi_err[k];
  }
  bool chain = true, above = false;
  std::size_t in_chain = 0;
  for (const std::size_t k : order) {
    if (out.agrees[k] < 0)
      continue;
    if (out.smallest < 0) {
      out.smallest = int(k);
      out.reached = out.agrees[k] == 1;
    }
    if (!chain || out.agrees[k] != 1) {
      above = above || chain;  // the first usable point that differs
      chain = false;
      continue;
    }
    out.p_star = points[k].pressure;
    ++in_chain;
  }
  if (!out.reached)
    out.p_star = kNaN;
  if (out.smallest >= 0 && ref.usable) {
    for (std::size_t k = 0; k < m; ++k) {
      const ScanValue& p = points[k];
      if (p.usable || !(p.pressure < points[std::size_t(out.smallest)].pressure) ||
          !std::isfinite(p.mu) || !std::isfinite(p.phi))
        continue;
      ++out.left_out_below;
      out.left_out_below_agrees =
          out.left_out_below_agrees ||
          (std::abs(p.mu - ref.mu) <= sigmas * std::hypot(p.mu_err, ref.mu_err) &&
           std::abs(p.phi - ref.phi) <= sigmas * std::hypot(p.phi_err, ref.phi_err));
    }
  }
  out.p_star_is_smallest = out.reached && in_chain == 1 && above;
  out.p_star_is_largest = out.reached && !above;
  return out;
}

namespace {

double pressure_of(double alpha, double delta) {
  return std::pow(delta, alpha - 1.0);
}

// The typical overlap of a pressure (the inverse of pressure_of).
double overlap_of(double alpha, double pressure) {
  return std::pow(pressure, 1.0 / (alpha - 1.0));
}

StatePoint point_for(const SoftnessPreset& p, double alpha, double delta, double j) {
  StatePoint s;
  s.n = p.n;
  s.alpha = alpha;
  s.constant_pressure = true;
  s.pressure = pressure_of(alpha, delta);
  // The start: the hard-sphere law at J, 0.01 lower, as the hard-sphere study starts.
  s.phi = phi_start(j, p.n, 0.01, 0.63);
  s.gdot = j * s.pressure;
  s.name = "alpha=" + short_num(alpha) + " delta=" + short_num(delta) + " J=" + short_num(j);
  return s;
}

// The deltas of one alpha_r that are run (P >= p_min), largest first.
std::vector<double> deltas_for(const SoftnessPreset& p, double alpha) {
  std::vector<double> out;
  for (double d : p.deltas)
    if (pressure_of(alpha, d) >= p.p_min * (1.0 - 1e-12))
      out.push_back(d);
  std::sort(out.rbegin(), out.rend());
  return out;
}

// The smallest Euler step scanned for an alpha_r: contacts of alpha_r < 2 are stiffer near
// contact, so the small steps are only scanned there.
double dt_floor(double alpha) {
  return alpha >= 2.0 ? 0.01 : (alpha >= 1.6 ? 0.002 : 0.0);
}

std::vector<double> dts_for(const SoftnessPreset& p, double alpha) {
  std::vector<double> out;
  for (double dt : p.scan_dts)
    if (dt >= dt_floor(alpha) - 1e-15)
      out.push_back(dt);
  if (out.empty())
    out = p.scan_dts;
  return out;
}

// RESPA outer steps: the inner (particle) step dt / respa_inner obeys the same floor.
std::vector<double> respa_dts_for(const SoftnessPreset& p, double alpha) {
  std::vector<double> out;
  for (double dt : p.respa_dts)
    if (dt >= p.respa_inner * dt_floor(alpha) - 1e-15)
      out.push_back(dt);
  return out;
}

// Every integrator setting of phase A at overlap delta; the first is the smallest Euler step
// (the accuracy reference). CVODE's atol = rtol x delta (the timestep study's rule), RKC's atol
// = rkc_overlaps x delta.
std::vector<IntegratorSetting> settings_for(const SoftnessPreset& p, double alpha, double delta) {
  std::vector<IntegratorSetting> out;
  for (double dt : dts_for(p, alpha))
    out.push_back(euler_setting(dt));
  for (double dt : respa_dts_for(p, alpha))
    out.push_back(respa_setting(dt, p.respa_inner, "particles", "euler"));
  for (double tol : p.cvode_tols)
    out.push_back(cvode_setting(tol, tol * delta, p.cvode_max_steps));
  for (double overlaps : p.rkc_overlaps)
    out.push_back(rkc_setting(overlaps, delta));
  return out;
}

// The same setting at another overlap (CVODE's and RKC's atol follow delta).
IntegratorSetting setting_at(const SoftnessPreset& p, const IntegratorSetting& s, double delta) {
  if (s.family() == "cvode")
    return cvode_setting(s.tolerance, s.tolerance * delta, p.cvode_max_steps);
  if (s.family() == "rkc")
    return rkc_setting(s.tolerance, delta);
  return s;
}

double t_eq_for(const SoftnessPreset& p, double pressure, double gdot) {
  return std::max({p.t_min, p.strain_eq / gdot, p.relax_pressure / pressure});
}
double t_av_for(const SoftnessPreset& p, double pressure, double gdot) {
  return std::max({p.t_min, p.strain_av / gdot, p.average_pressure / pressure});
}
double t_prep_for(const SoftnessPreset& p, const StatePoint& s) {
  return std::max({p.t_prep, p.strain_prep / s.gdot, p.relax_pressure / s.pressure});
}
// The preparation's integrator: CVODE (rtol 1e-4) where the relaxation is long and the
// contacts are not stiff (alpha_r >= 2), else Euler at the smallest scanned step.
IntegratorSetting prep_setting(const SoftnessPreset& p, double alpha, double delta,
                               double pressure) {
  if (alpha >= 2.0 && p.relax_pressure / pressure > p.t_prep)
    return cvode_setting(1e-4, 1e-4 * delta, p.cvode_max_steps);
  return euler_setting(dts_for(p, alpha).front());
}

double t_ref_eq(const SoftnessPreset& p, double j) {
  return std::max(p.relax_pressure / p.p_reference, p.strain_eq / (j * p.p_reference));
}
double t_ref_av(const SoftnessPreset& p, double j) {
  return std::max(p.reference_average / p.p_reference, p.strain_av / (j * p.p_reference));
}

// A run enters phase A's comparison if it finished and is stable (the stability verdict). Its
// steady and decorrelated verdicts are about the state point's statistics over a window much
// shorter than 1 / P at low pressure; the accuracy test is paired against the reference run
// from the same state with the same seed, so a slow drift common to both cancels, and blocks
// shorter than 2 tau make its floor smaller: the test only gets stricter.
bool usable_in_scan(const DiagnosedRun& r) {
  return r.cls.verdict == Verdict::kStable || r.cls.verdict == Verdict::kCorrelated ||
         r.cls.verdict == Verdict::kNotSteady;
}

// The reference's replicas: stable and steady; blocks shorter than 2 tau are kept when another
// replica gives a scatter.
bool usable_replica(const DiagnosedRun& r) {
  return r.cls.verdict == Verdict::kStable || r.cls.verdict == Verdict::kCorrelated;
}

// The diagnostic window's sampling interval for CVODE: a tenth of the contact relaxation time
// 1 / k, k = (alpha_r - 1) delta^(alpha_r - 2) (at most 0.1), so that its step-correlation test
// measures smoothness rather than how far the forces move in a long interval.
WindowOptions window_for(double alpha, double delta) {
  WindowOptions w;
  const double k = (alpha - 1.0) * std::pow(delta, alpha - 2.0);
  w.adaptive_step = 0.1 / std::max(k, 1.0);
  return w;
}

struct Scan {  // phase A at one end of the overlap range
  double delta = 0.0;
  StatePoint point;
  DiagnosedRun prep;
  std::vector<IntegratorSetting> settings;
  std::vector<DiagnosedRun> runs;
  double duration = 0.0;  // t_eq + t_av of every run
  std::vector<double> mu_err, mu_floor, phi_err, phi_floor;
  std::vector<bool> accurate;
  std::vector<std::string> verdict;
  std::vector<double> seconds_per_tau, evaluations_per_tau;  // per particle
  double euler_dt_max = kNaN;
  int reference = -1;
};

struct PressureRun {
  double delta = 0.0, pressure = 0.0, duration = 0.0;
  DiagnosedRun run;
  int agrees = -1;
  double dmu = kNaN, dmu_err = kNaN, dphi = kNaN, dphi_err = kNaN;
};

struct Reference {  // the common P -> 0 reference at one J
  double j = 1.0;
  std::vector<DiagnosedRun> replicas;
  ScanValue value;
  std::size_t used = 0;
  bool replica_errors = false;  // errors include the replica scatter
  std::string why;              // why it is not usable
  double tau_phi = kNaN, tau_sigma = kNaN, block_length = kNaN;
};

struct Candidate {
  std::size_t setting = 0;  // index into the scans' settings
  bool ok = false;          // stable and accurate at every end
  double cost = kNaN;       // seconds per tau_0 per particle, weighted over the scan
  double cost_hi = kNaN, cost_lo = kNaN, eval_hi = kNaN, eval_lo = kNaN;
};

struct Cost {
  double seconds_n = kNaN;     // CPU seconds to strain 1 at the preset's N
  double seconds_1000 = kNaN;  // the same scaled to N = 1000
  double evaluations = kNaN;   // particle force evaluations per particle to strain 1
};

struct AlphaResult {
  double alpha = 2.0;
  std::vector<double> deltas;  // run, largest first
  std::vector<Scan> ends;      // largest delta, then smallest (one if they coincide)
  std::vector<Candidate> candidates;
  int chosen = -1;               // index into candidates
  bool chosen_verified = false;  // stable and accurate at every end (else a fallback)
  IntegratorSetting integrator;
  double euler_dt_max = kNaN;
  std::map<double, std::vector<PressureRun>> pscan;  // J -> runs (deltas descending)
  std::map<double, PStar> p_star;
  std::map<double, Cost> cost;
};

void analyse_scan(Scan& s, const SoftnessPreset& p) {
  const std::size_t m = s.runs.size();
  s.mu_err.assign(m, kNaN);
  s.mu_floor.assign(m, kNaN);
  s.phi_err.assign(m, kNaN);
  s.phi_floor.assign(m, kNaN);
  s.accurate.assign(m, false);
  s.verdict.assign(m, "");
  s.seconds_per_tau.assign(m, kNaN);
  s.evaluations_per_tau.assign(m, kNaN);
  for (std::size_t k = 0; k < m; ++k) {
    const DiagnosedRun& r = s.runs[k];
    s.verdict[k] = r.verdict_text();
    if (r.complete() && s.duration > 0.0 && r.n > 0) {
      s.seconds_per_tau[k] = r.cpu_seconds / (s.duration * double(r.n));
      s.evaluations_per_tau[k] = r.particle_steps / (s.duration * double(r.n));
    }
  }
  for (std::size_t k = 0; k < m; ++k) {
    if (s.settings[k].family() == "euler" && usable_in_scan(s.runs[k])) {
      s.reference = int(k);
      break;
    }
  }
  if (s.reference < 0)
    return;
  const DiagnosedRun& ref = s.runs[std::size_t(s.reference)];
  const double mu_ref = ref.value("mu"), phi_ref = ref.value("phi");
  for (std::size_t k = 0; k < m; ++k) {
    const DiagnosedRun& r = s.runs[k];
    if (!usable_in_scan(r))
      continue;
    const auto blocks = static_cast<std::size_t>(r.blocks);
    // mu = sigma_xy / P with the imposed P: the paired error of sigma_xy / P.
    const double pe =
        paired_error(r.result.series, ref.result.series, r.t_eq, &Sample::sigma_xy, blocks);
    const double fe =
        paired_error(r.result.series, ref.result.series, r.t_eq, &Sample::phi, blocks);
    const bool self = int(k) == s.reference;
    s.mu_err[k] = std::abs(r.value("mu") - mu_ref) / std::abs(mu_ref);
    s.mu_floor[k] = self
                        ? 0.0
                        : (std::isfinite(pe) ? pe / s.point.pressure
                                             : std::hypot(r.value("mu_err"), ref.value("mu_err"))) /
                              std::abs(mu_ref);
    s.phi_err[k] = std::abs(r.value("phi") - phi_ref);
    s.phi_floor[k] =
        self ? 0.0
             : (std::isfinite(fe) ? fe : std::hypot(r.value("phi_err"), ref.value("phi_err")));
    s.accurate[k] = s.mu_err[k] <= p.mu_tolerance + 2.0 * s.mu_floor[k] &&
                    s.phi_err[k] <= p.phi_tolerance + 2.0 * s.phi_floor[k];
    s.verdict[k] = r.verdict_text() + (s.accurate[k] ? ", accurate" : ", **inaccurate**");
  }
  // Euler's largest step: the steps from the reference up to the first one that is not
  // stable and accurate.
  for (std::size_t k = std::size_t(s.reference); k < m && s.settings[k].family() == "euler"; ++k) {
    if (!s.accurate[k])
      break;
    s.euler_dt_max = s.settings[k].dt();
  }
}

// A candidate's cost per tau_0 over the pressure scan it would run: the measured costs at the
// two ends, interpolated in log P (and held beyond them), weighted by each scan run's length.
double weighted_cost(const SoftnessPreset& p, const AlphaResult& ar, double c_hi, double c_lo) {
  const double p_hi = pressure_of(ar.alpha, ar.deltas.front());
  const double p_lo = pressure_of(ar.alpha, ar.deltas.back());
  double num = 0.0, den = 0.0;
  for (double j : p.targets_j) {
    for (double d : ar.deltas) {
      const double pr = pressure_of(ar.alpha, d);
      const double t = t_eq_for(p, pr, j * pr) + t_av_for(p, pr, j * pr);
      double c = c_hi;
      if (p_hi > p_lo) {
        const double x = std::clamp(std::log(pr / p_lo) / std::log(p_hi / p_lo), 0.0, 1.0);
        c = std::exp(std::log(c_lo) + x * (std::log(c_hi) - std::log(c_lo)));
      }
      num += t * c;
      den += t;
    }
  }
  return den > 0.0 ? num / den : kNaN;
}

Reference combine_reference(double j, std::vector<DiagnosedRun> replicas) {
  Reference ref;
  ref.j = j;
  ref.replicas = std::move(replicas);
  std::vector<Summary> sums;
  bool all_decorrelated = true;
  for (const DiagnosedRun& r : ref.replicas) {
    if (!usable_replica(r))
      continue;
    sums.push_back(r.result.summary);
    all_decorrelated = all_decorrelated && r.cls.verdict == Verdict::kStable;
  }
  ref.used = sums.size();
  ref.value.pressure = 0.0;
  if (sums.empty()) {
    ref.why = "no replica finished stable and steady";
    return ref;
  }
  if (sums.size() == 1 && !all_decorrelated) {
    ref.why = "one usable replica, and its blocks are shorter than 2 tau";
    return ref;
  }
  const Summary s = sums.size() > 1 ? combine_replicas(sums) : sums.front();
  auto get = [&](const std::string& k) {
    const auto it = s.values.find(k);
    return it == s.values.end() ? kNaN : it->second;
  };
  // The error: the block error of the mean, or the replica scatter if larger (the rule of the
  // sweep's collect for points with several replicas).
  auto err = [&](const std::string& k) {
    const double b = get(k + "_err"), r = get(k + "_replica_err");
    return std::isfinite(r) ? std::max(b, r) : b;
  };
  ref.replica_errors = sums.size() > 1;
  ref.value.usable = true;
  ref.value.mu = get("mu");
  ref.value.mu_err = err("mu");
  ref.value.phi = get("phi");
  ref.value.phi_err = err("phi");
  ref.tau_phi = get("tau_phi");
  ref.tau_sigma = get("tau_sigma_xy");
  ref.block_length = get("block_length");
  return ref;
}

std::string cell(double v, int digits = 3) {
  return std::isfinite(v) ? num(v, digits) : "—";
}

// ---- The dry-run cost model -------------------------------------------------------------------

// Seconds per particle force evaluation of the explicit schemes: the standard preset's measured
// 61 ns (harmonic, specialised loop) and 100-150 ns (pow loop) at N = 250 on shared cores.
double model_seconds_per_step(double alpha) {
  return alpha == 2.0 ? 60e-9 : 110e-9;
}
// CVODE's seconds per particle per tau_0: right-hand-side evaluations per tau_0 times their
// cost. The evaluations follow the contact stiffness k = (alpha_r - 1) delta^(alpha_r - 2) and
// grow slowly with P: about 10 k (P / 0.01)^0.35, at least 0.2 (the quick preset measured 108-136
// at alpha_r = 1.5, P = 0.05-0.1; 4-7 at alpha_r = 2, P = 3e-3-1e-2; 0.19 at alpha_r = 3,
// P = 1e-4; the finite-size standard preset 0.48 at alpha_r = 2, P = 1e-5). Each costs about
// 0.6 us per particle (harmonic) or 0.9 us (pow loop), Krylov iterations included.
double model_cvode_seconds(double alpha, double pressure) {
  const double delta = overlap_of(alpha, pressure);
  const double k = (alpha - 1.0) * std::pow(delta, alpha - 2.0);
  const double evaluations = std::max(0.2, 10.0 * k * std::pow(pressure / 0.01, 0.35));
  return evaluations * (alpha == 2.0 ? 0.6e-6 : 0.9e-6);
}
// The largest accurate Euler step found by this study's earlier standard preset (Euler only):
// 0.001 at alpha_r = 1.5, 0.002 at 1.75, 0.2 at 2, 0.5 at 2.5 and 1.5 at 3 (interpolated in
// log dt). Used for the estimate only.
double model_euler_dt(double alpha) {
  const std::vector<std::pair<double, double>> t = {
      {1.5, 0.001}, {1.75, 0.002}, {2.0, 0.2}, {2.5, 0.5}, {3.0, 1.5}};
  if (alpha <= t.front().first)
    return t.front().second;
  for (std::size_t k = 1; k < t.size(); ++k) {
    if (alpha <= t[k].first) {
      const double x = (alpha - t[k - 1].first) / (t[k].first - t[k - 1].first);
      return std::exp(std::log(t[k - 1].second) + x * std::log(t[k].second / t[k - 1].second));
    }
  }
  return t.back().second;
}

double model_seconds(const SoftnessPreset& p, double alpha, const IntegratorSetting& s,
                     double pressure, double t, bool budget) {
  const double n = double(p.n);
  double sec = 0.0;
  if (s.family() == "cvode") {
    sec = n * t * model_cvode_seconds(alpha, pressure);
  } else if (s.family() == "rkc") {
    // Adaptive: about 1 force pass per tau_0 (0.4-2.8 measured at N = 1000, alpha_r = 2,
    // atol = 0.01-1 delta, benchmarks/README.md), each 1.2x an Euler pass.
    double steps = n * t * 1.0;
    if (budget && p.budget_particle_steps > 0.0)
      steps = std::min(steps, p.budget_particle_steps);
    sec = 1.2 * steps * model_seconds_per_step(alpha);
  } else {
    // The integrator's own nominal force passes per unit time. Every run of this study is at
    // constant pressure (StatePoint's xi_V): the piston is what RESPA's cost depends on.
    const ConstantPressure ensemble(0.0, pressure, StatePoint{}.xi_v);
    double steps = n * t * make_integrator(s.settings)->force_passes_per_time(ensemble);
    if (budget && p.budget_particle_steps > 0.0)
      steps = std::min(steps, p.budget_particle_steps);
    sec = steps * model_seconds_per_step(alpha);
  }
  if (budget && p.budget_particle_steps > 0.0 && s.family() == "cvode") {
    const double per_evaluation = alpha == 2.0 ? 0.6e-6 : 0.9e-6;
    sec = std::min(sec, p.budget_particle_steps * per_evaluation);
  }
  return sec;
}

}  // namespace

SoftnessEstimate estimate_softness(const SoftnessPreset& p) {
  SoftnessEstimate e;
  const double j0 = p.targets_j.front();
  for (double alpha : p.alphas) {
    const std::vector<double> ds = deltas_for(p, alpha);
    if (ds.empty())
      continue;
    std::vector<double> ends = {ds.front()};
    if (ds.back() != ds.front())
      ends.push_back(ds.back());
    for (double d : ends) {
      const StatePoint pt = point_for(p, alpha, d, j0);
      e.prep += model_seconds(p, alpha, prep_setting(p, alpha, d, pt.pressure), pt.pressure,
                              t_prep_for(p, pt), false);
      ++e.runs;
      for (const auto& s : settings_for(p, alpha, d)) {
        e.scan += model_seconds(p, alpha, s, pt.pressure, 1.1 * p.t_scan, true);
        ++e.runs;
      }
    }
    for (double j : p.targets_j) {
      for (double d : ds) {
        const double pr = pressure_of(alpha, d);
        const double t = t_eq_for(p, pr, j * pr) + t_av_for(p, pr, j * pr);
        const double euler =
            model_seconds(p, alpha, euler_setting(model_euler_dt(alpha)), pr, t, true);
        const double cvode = model_seconds(p, alpha, cvode_setting(1e-5, 0.0), pr, t, true);
        e.pscan += std::min(euler, cvode);
        ++e.runs;
      }
    }
  }
  for (double j : p.targets_j) {
    const double t = t_ref_eq(p, j) + t_ref_av(p, j);
    e.reference += p.reference_replicas * double(p.n) * t * model_cvode_seconds(2.0, p.p_reference);
    e.runs += std::size_t(p.reference_replicas);
  }
  e.prep /= 3600.0;
  e.scan /= 3600.0;
  e.pscan /= 3600.0;
  e.reference /= 3600.0;
  return e;
}

int run_softness(const StudyOptions& options) {
  return run_softness_preset(softness_preset(options.preset), options);
}

int run_softness_preset(const SoftnessPreset& preset, const StudyOptions& options) {
  ensure_dir(options.out_dir);
  const auto wall0 = std::chrono::steady_clock::now();
  if (!options.quiet) {
    std::printf("jamflow study softness (%s): %zu exponents -> %s\n", preset.name.c_str(),
                preset.alphas.size(), options.out_dir.c_str());
  }
  if (options.dry_run) {
    const SoftnessEstimate e = estimate_softness(preset);
    std::printf(
        "softness --preset %s, every stage (cost model, studies/softness/README.md): %zu runs, "
        "about %.2g CPU-hours (preparations %.2g, integrator scans %.2g, pressure scans %.2g, "
        "P -> 0 reference %.2g)\n",
        preset.name.c_str(), e.runs, e.total(), e.prep, e.scan, e.pscan, e.reference);
  }
  const double j_scan = preset.targets_j.front();
  std::vector<AlphaResult> results(preset.alphas.size());

  // Phase A: preparations, then the integrator scans.
  std::vector<RunRequest> preps;
  std::vector<Scan*> prep_of;
  for (std::size_t a = 0; a < preset.alphas.size(); ++a) {
    AlphaResult& ar = results[a];
    ar.alpha = preset.alphas[a];
    ar.deltas = deltas_for(preset, ar.alpha);
    if (ar.deltas.empty())
      continue;
    std::vector<double> ends = {ar.deltas.front()};
    if (ar.deltas.back() != ar.deltas.front())
      ends.push_back(ar.deltas.back());
    ar.ends.resize(ends.size());
    for (std::size_t e = 0; e < ends.size(); ++e) {
      Scan& s = ar.ends[e];
      s.delta = ends[e];
      s.point = point_for(preset, ar.alpha, s.delta, j_scan);
      s.settings = settings_for(preset, ar.alpha, s.delta);
      const double t_prep = t_prep_for(preset, s.point);
      RunRequest r;
      r.label = s.point.name + " prep";
      r.scene = scene_toml(s.point, prep_setting(preset, ar.alpha, s.delta, s.point.pressure),
                           0.5 * t_prep, 0.5 * t_prep, t_prep / 100.0);
      r.seed = s.point.seed;
      r.window = false;
      preps.push_back(r);
    }
  }
  for (AlphaResult& ar : results)
    for (Scan& s : ar.ends)
      prep_of.push_back(&s);
  std::vector<DiagnosedRun> prep_done;
  if (const auto status = run_stage("softness", "prep", preps, options, prep_done, false))
    return *status;
  for (std::size_t q = 0; q < prep_done.size(); ++q)
    prep_of[q]->prep = std::move(prep_done[q]);

  std::vector<RunRequest> scans;
  std::vector<std::pair<Scan*, std::size_t>> scan_index;
  const double grid = kSampleGrid * std::max(1.0, std::round(preset.t_scan / 100.0 / kSampleGrid));
  for (AlphaResult& ar : results) {
    for (Scan& s : ar.ends) {
      s.runs.resize(s.settings.size());
      s.duration = 0.1 * preset.t_scan + preset.t_scan;
      for (std::size_t k = 0; k < s.settings.size(); ++k) {
        if (!s.prep.complete() || s.prep.final_xyz.empty()) {
          s.runs[k].cls.verdict = Verdict::kNotAvailable;
          s.runs[k].unavailable = "preparation " + s.prep.verdict_text();
          s.runs[k].result.status = RunStatus::not_run();
          continue;
        }
        RunRequest r;
        r.label = s.point.name + " " + s.settings[k].label;
        r.scene = scene_toml(s.point, s.settings[k], 0.1 * preset.t_scan, preset.t_scan, grid);
        r.seed = s.point.seed;
        r.init = s.prep.final_xyz;
        r.budget = k == 0 ? 0 : budget_for(preset.budget_particle_steps, s.point.n);
        r.window_options = window_for(ar.alpha, s.delta);
        scans.push_back(std::move(r));
        scan_index.emplace_back(&s, k);
      }
    }
  }
  std::vector<DiagnosedRun> scan_done;
  if (const auto status = run_stage("softness", "scan", scans, options, scan_done, false))
    return *status;
  for (std::size_t q = 0; q < scan_done.size(); ++q)
    scan_index[q].first->runs[scan_index[q].second] = std::move(scan_done[q]);

  // The fastest stable integrator of each alpha_r.
  for (AlphaResult& ar : results) {
    if (ar.ends.empty())
      continue;
    for (Scan& s : ar.ends)
      analyse_scan(s, preset);
    ar.euler_dt_max = ar.ends.front().euler_dt_max;
    for (const Scan& s : ar.ends)
      ar.euler_dt_max = std::isfinite(s.euler_dt_max) && std::isfinite(ar.euler_dt_max)
                            ? std::min(ar.euler_dt_max, s.euler_dt_max)
                            : kNaN;
    const Scan& hi = ar.ends.front();
    const Scan& lo = ar.ends.back();
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < hi.settings.size(); ++k) {
      Candidate c;
      c.setting = k;
      c.ok = true;
      for (const Scan& s : ar.ends)
        c.ok = c.ok && s.accurate[k] && std::isfinite(s.seconds_per_tau[k]);
      c.cost_hi = hi.seconds_per_tau[k];
      c.cost_lo = lo.seconds_per_tau[k];
      c.eval_hi = hi.evaluations_per_tau[k];
      c.eval_lo = lo.evaluations_per_tau[k];
      if (c.ok) {
        c.cost = weighted_cost(preset, ar, c.cost_hi, c.cost_lo);
        if (c.cost < best) {
          best = c.cost;
          ar.chosen = int(ar.candidates.size());
        }
      }
      ar.candidates.push_back(c);
    }
    ar.chosen_verified = ar.chosen >= 0;
    if (ar.chosen < 0) {
      // No setting is stable and accurate at every end (no usable accuracy reference, or none
      // accurate): the pressure scan runs with the cheapest setting that finished stable at
      // every end (else the smallest Euler step), flagged, and its cost enters no comparison.
      double cheapest = std::numeric_limits<double>::infinity();
      for (std::size_t k = 0; k < hi.settings.size(); ++k) {
        bool fine = true;
        for (const Scan& s : ar.ends)
          fine = fine && usable_in_scan(s.runs[k]) && std::isfinite(s.seconds_per_tau[k]);
        if (!fine)
          continue;
        const double c = weighted_cost(preset, ar, hi.seconds_per_tau[k], lo.seconds_per_tau[k]);
        if (c < cheapest) {
          cheapest = c;
          ar.chosen = int(k);
        }
      }
      if (ar.chosen < 0)
        ar.chosen = 0;
    }
    ar.integrator = hi.settings[ar.candidates[std::size_t(ar.chosen)].setting];
  }

  // Phase B: the pressure scans with each alpha_r's integrator, and the common P -> 0
  // reference (alpha_r = 2, CVODE, several replicas) in the same stage.
  std::vector<RunRequest> pruns;
  std::vector<std::tuple<std::size_t, double, std::size_t>> p_index;
  for (std::size_t a = 0; a < results.size(); ++a) {
    AlphaResult& ar = results[a];
    if (ar.ends.empty())
      continue;
    for (double j : preset.targets_j) {
      auto& list = ar.pscan[j];
      for (double d : ar.deltas) {
        const StatePoint pt = point_for(preset, ar.alpha, d, j);
        PressureRun pr;
        pr.delta = d;
        pr.pressure = pt.pressure;
        const double t_eq = t_eq_for(preset, pt.pressure, pt.gdot);
        const double t_av = t_av_for(preset, pt.pressure, pt.gdot);
        pr.duration = t_eq + t_av;
        list.push_back(pr);
        const IntegratorSetting s = setting_at(preset, ar.integrator, d);
        RunRequest r;
        r.label = pt.name + " " + s.label;
        r.scene = scene_toml(pt, s, t_eq, t_av, t_av / 400.0);
        r.seed = pt.seed + 1;  // independent of the phase-A preparations
        r.budget = budget_for(preset.budget_particle_steps, pt.n);
        r.window_options = window_for(ar.alpha, d);
        pruns.push_back(std::move(r));
        p_index.emplace_back(a, j, list.size() - 1);
      }
    }
  }
  const std::size_t n_scan_runs = pruns.size();
  const double d_ref = overlap_of(2.0, preset.p_reference);
  for (double j : preset.targets_j) {
    StatePoint pt = point_for(preset, 2.0, d_ref, j);
    pt.name = "reference alpha=2 P=" + short_num(preset.p_reference) + " J=" + short_num(j);
    const double t_eq = t_ref_eq(preset, j), t_av = t_ref_av(preset, j);
    for (int k = 0; k < preset.reference_replicas; ++k) {
      RunRequest r;
      r.label = pt.name + " replica " + std::to_string(k);
      r.scene = scene_toml(pt, cvode_setting(preset.reference_rtol, 0.0), t_eq, t_av, t_av / 400.0);
      r.seed = 101 + std::uint64_t(k);
      r.budget = 0;  // the reference is never cut
      r.window_options = window_for(2.0, d_ref);
      pruns.push_back(std::move(r));
    }
  }
  std::vector<DiagnosedRun> p_done;
  if (const auto status = run_stage("softness", "pscan", pruns, options, p_done, true))
    return *status;
  for (std::size_t q = 0; q < n_scan_runs; ++q) {
    const auto& [a, j, k] = p_index[q];
    results[a].pscan[j][k].run = std::move(p_done[q]);
  }
  std::map<double, Reference> refs;
  {
    std::size_t q = n_scan_runs;
    for (double j : preset.targets_j) {
      std::vector<DiagnosedRun> reps;
      for (int k = 0; k < preset.reference_replicas; ++k)
        reps.push_back(std::move(p_done[q++]));
      refs[j] = combine_reference(j, std::move(reps));
    }
  }

  // P* against the common reference, and the cost to strain 1 there (phase C).
  std::map<double, std::size_t> optimum;
  for (double j : preset.targets_j) {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t a = 0; a < results.size(); ++a) {
      AlphaResult& ar = results[a];
      if (!ar.pscan.count(j))
        continue;
      auto& runs = ar.pscan[j];
      std::vector<ScanValue> values;
      for (const PressureRun& pr : runs) {
        ScanValue v;
        v.pressure = pr.pressure;
        v.usable = pr.run.cls.verdict == Verdict::kStable;
        v.mu = pr.run.value("mu");
        v.mu_err = pr.run.value("mu_err");
        v.phi = pr.run.value("phi");
        v.phi_err = pr.run.value("phi_err");
        values.push_back(v);
      }
      const PStar ps = find_p_star(values, refs[j].value);
      for (std::size_t k = 0; k < runs.size(); ++k) {
        runs[k].agrees = ps.agrees[k];
        runs[k].dmu = ps.dmu[k];
        runs[k].dmu_err = ps.dmu_err[k];
        runs[k].dphi = ps.dphi[k];
        runs[k].dphi_err = ps.dphi_err[k];
      }
      ar.p_star[j] = ps;
      Cost c;
      if (std::isfinite(ps.p_star)) {
        for (const PressureRun& pr : runs) {
          if (pr.pressure != ps.p_star || !(pr.duration > 0.0) || pr.run.n <= 0)
            continue;
          const double per_tau = pr.run.cpu_seconds / (pr.duration * double(pr.run.n));
          const double evals = pr.run.particle_steps / (pr.duration * double(pr.run.n));
          c.seconds_n = cost_to_strain_one(per_tau, j, ps.p_star) * double(preset.n);
          c.seconds_1000 = cost_to_strain_one(per_tau, j, ps.p_star) * 1000.0;
          c.evaluations = cost_to_strain_one(evals, j, ps.p_star);
        }
        if (ar.chosen_verified && std::isfinite(c.seconds_n) && c.seconds_n < best) {
          best = c.seconds_n;
          optimum[j] = a;
        }
      }
      ar.cost[j] = c;
    }
  }

  // Output.
  const std::string h5 = options.out_dir + "/softness.h5";
  {
    H5Writer w(h5);
    w.attr("/", "study", "softness");
    w.attr("/", "preset", preset.name);
    w.attr("/", "N", preset.n);
    w.attr("/", "mu_tolerance", preset.mu_tolerance);
    w.attr("/", "phi_tolerance", preset.phi_tolerance);
    w.attr("/", "pressure_grid", "P = delta^(alpha_r - 1)");
    w.attr("/", "p_min", preset.p_min);
    w.attr("/", "timing",
           "cpu_seconds: CPU seconds of each run's jamflow run process on 1 thread, one run "
           "per core (a run with cpu_from_wall = 1 was written before CPU time was recorded: "
           "its wall seconds)");
    for (const auto& [j, ref] : refs) {
      char g[64];
      std::snprintf(g, sizeof g, "/reference/J%g", j);
      const std::string rg = g;
      w.group(rg);
      w.attr(rg, "J", j);
      w.attr(rg, "imposed_pressure", preset.p_reference);
      w.attr(rg, "alpha", 2.0);
      w.attr(rg, "usable", static_cast<std::int64_t>(ref.value.usable));
      w.attr(rg, "why", ref.why);
      w.attr(rg, "replicas_used", static_cast<std::int64_t>(ref.used));
      w.attr(rg, "mu", ref.value.mu);
      w.attr(rg, "mu_err", ref.value.mu_err);
      w.attr(rg, "phi", ref.value.phi);
      w.attr(rg, "phi_err", ref.value.phi_err);
      w.attr(rg, "tau_phi", ref.tau_phi);
      w.attr(rg, "tau_sigma_xy", ref.tau_sigma);
      w.attr(rg, "block_length", ref.block_length);
      w.attr(rg, "phi_hard_sphere_law", hard_sphere_phi(j, preset.n));
      for (std::size_t k = 0; k < ref.replicas.size(); ++k)
        write_diagnosed(w, rg + "/replicas/r" + std::to_string(k), ref.replicas[k], false);
    }
    for (std::size_t a = 0; a < results.size(); ++a) {
      const AlphaResult& ar = results[a];
      char g[32];
      std::snprintf(g, sizeof g, "/alphas/a%02zu", a);
      const std::string grp = g;
      w.group(grp);
      w.attr(grp, "alpha", ar.alpha);
      w.attr(grp, "euler_dt_max", ar.euler_dt_max);
      w.attr(grp, "integrator", ar.integrator.label);
      w.attr(grp, "integrator_family", ar.integrator.family());
      w.attr(grp, "integrator_verified", static_cast<std::int64_t>(ar.chosen_verified));
      if (ar.ends.empty())
        continue;
      for (std::size_t e = 0; e < ar.ends.size(); ++e) {
        const Scan& s = ar.ends[e];
        const std::string sg = grp + (e == 0 ? "/scan_hi" : "/scan_lo");
        w.group(sg);
        w.attr(sg, "delta", s.delta);
        w.attr(sg, "imposed_pressure", s.point.pressure);
        w.attr(sg, "shear_rate", s.point.gdot);
        w.attr(sg, "euler_dt_max", s.euler_dt_max);
        write_diagnosed(w, sg + "/prep", s.prep, false);
        for (std::size_t k = 0; k < s.runs.size(); ++k) {
          char rg[32];
          std::snprintf(rg, sizeof rg, "/runs/r%03zu", k);
          write_diagnosed(w, sg + rg, s.runs[k], false);
          w.attr(sg + rg, "setting", s.settings[k].label);
          w.attr(sg + rg, "family", s.settings[k].family());
          w.attr(sg + rg, "step", s.settings[k].dt());
          w.attr(sg + rg, "scan_verdict", s.verdict[k]);
          w.attr(sg + rg, "accurate", static_cast<std::int64_t>(s.accurate[k]));
          w.attr(sg + rg, "mu_rel_err", s.mu_err[k]);
          w.attr(sg + rg, "mu_rel_floor", s.mu_floor[k]);
          w.attr(sg + rg, "phi_err", s.phi_err[k]);
          w.attr(sg + rg, "phi_floor", s.phi_floor[k]);
          w.attr(sg + rg, "seconds_per_tau_particle", s.seconds_per_tau[k]);
          w.attr(sg + rg, "evaluations_per_tau", s.evaluations_per_tau[k]);
        }
      }
      for (std::size_t k = 0; k < ar.candidates.size(); ++k) {
        const Candidate& c = ar.candidates[k];
        const std::string cg = grp + "/candidates/c" + std::to_string(k);
        w.group(cg);
        w.attr(cg, "setting", ar.ends.front().settings[c.setting].label);
        w.attr(cg, "ok", static_cast<std::int64_t>(c.ok));
        w.attr(cg, "seconds_per_tau_particle", c.cost);
        w.attr(cg, "seconds_per_tau_particle_hi", c.cost_hi);
        w.attr(cg, "seconds_per_tau_particle_lo", c.cost_lo);
        w.attr(cg, "chosen", static_cast<std::int64_t>(int(k) == ar.chosen));
      }
      for (const auto& [j, runs] : ar.pscan) {
        char jg[64];
        std::snprintf(jg, sizeof jg, "/pscan/J%g", j);
        const std::string pg = grp + jg;
        w.group(pg);
        w.attr(pg, "J", j);
        const PStar& ps = ar.p_star.at(j);
        w.attr(pg, "p_star", ps.p_star);
        w.attr(pg, "reached", static_cast<std::int64_t>(ps.reached));
        w.attr(pg, "p_star_is_smallest", static_cast<std::int64_t>(ps.p_star_is_smallest));
        w.attr(pg, "p_star_is_largest", static_cast<std::int64_t>(ps.p_star_is_largest));
        const Cost c = ar.cost.count(j) ? ar.cost.at(j) : Cost{};
        w.attr(pg, "cpu_seconds_N", c.seconds_n);
        w.attr(pg, "cpu_seconds_N1000", c.seconds_1000);
        w.attr(pg, "evaluations_per_particle", c.evaluations);
        for (std::size_t k = 0; k < runs.size(); ++k) {
          char rg[32];
          std::snprintf(rg, sizeof rg, "/runs/r%03zu", k);
          write_diagnosed(w, pg + rg, runs[k].run, false);
          w.attr(pg + rg, "delta", runs[k].delta);
          w.attr(pg + rg, "imposed_pressure", runs[k].pressure);
          w.attr(pg + rg, "duration", runs[k].duration);
          w.attr(pg + rg, "agrees", static_cast<std::int64_t>(runs[k].agrees));
          w.attr(pg + rg, "dmu", runs[k].dmu);
          w.attr(pg + rg, "dmu_err", runs[k].dmu_err);
          w.attr(pg + rg, "dphi", runs[k].dphi);
          w.attr(pg + rg, "dphi_err", runs[k].dphi_err);
        }
      }
    }
    w.commit();
  }
  const bool plotted = run_plot("softness/plot.py", {h5, options.out_dir}, options);

  // Report.
  std::string md = "# Potential-exponent optimization (preset `" + preset.name + "`)\n\n";
  md += "Constant pressure, N = " + std::to_string(preset.n) +
        ". The pressure grid of each α_r is P = δ^(α_r − 1) over the typical overlaps δ ∈ {";
  {
    std::vector<double> ds = preset.deltas;
    std::sort(ds.rbegin(), ds.rend());
    for (std::size_t k = 0; k < ds.size(); ++k)
      md += (k ? ", " : "") + short_num(ds[k]);
  }
  md +=
      "}, without the points below P = " + short_num(preset.p_min) +
      " (their runs would last t ≥ " + short_num(preset.relax_pressure) +
      "/P).\n\n"
      "**A. Fastest stable integrator.** At both ends of each α_r's overlap range (J = " +
      short_num(j_scan) + "), every setting runs t = " + short_num(1.1 * preset.t_scan) +
      " from one prepared state (t = max(" + short_num(preset.t_prep) + ", " +
      short_num(preset.strain_prep) + "/gdot, " + short_num(preset.relax_pressure) +
      "/P) from a random state at the hard-sphere law's φ): explicit Euler, RESPA (particles "
      "on the inner level, " +
      std::to_string(preset.respa_inner) +
      " Euler sub-steps) and CVODE (atol = rtol × δ). Stable = the stability study's "
      "verdict (no divergence, no step-to-step oscillation, energy balance); accurate = |Δμ|/μ ≤ " +
      num(100 * preset.mu_tolerance, 2) + " % and |Δφ| ≤ " + short_num(preset.phi_tolerance) +
      " (each plus 2× the paired statistical floor) against the smallest stable Euler step. "
      "Runs that are not steady or whose blocks are shorter than 2 τ are admitted here: the "
      "test is paired (same state, same seed), so a slow drift common to both runs cancels "
      "and short blocks only make it stricter. CVODE's diagnostic window samples every "
      "0.1/max(1, k), k = (α_r − 1) δ^(α_r − 2) the contact stiffness. Of the settings stable "
      "and accurate at both ends, the "
      "integrator is the cheapest in measured seconds per τ0 per particle (each run's wall "
      "time in its one-thread process), averaged over the pressure scan it will run (the two ends' "
      "costs interpolated in log P, weighted by "
      "the scan's run lengths).\n\n"
      "**Common P → 0 reference.** The hard-sphere limit φ(J), μ(J) does not depend on α_r: "
      "one reference per J, α_r = 2 at P = " +
      short_num(preset.p_reference) + " (δ = " + short_num(d_ref) + "), CVODE rtol " +
      short_num(preset.reference_rtol) + ", " + std::to_string(preset.reference_replicas) +
      " replicas from random states at the hard-sphere law's φ, t_eq = max(" +
      short_num(preset.relax_pressure) + "/P, " + short_num(preset.strain_eq) +
      "/gdot), t_av = max(" + short_num(preset.reference_average) + "/P, " +
      short_num(preset.strain_av) +
      "/gdot). Errors: the block error of the replica mean, or the replica scatter if "
      "larger.\n\n"
      "**B. Pressure scan.** For each J, runs at every P of the grid with the α_r's "
      "integrator, from random states at the hard-sphere law's φ, t_eq = max(" +
      short_num(preset.t_min) + ", " + short_num(preset.strain_eq) + "/gdot, " +
      short_num(preset.relax_pressure) + "/P), t_av = max(" + short_num(preset.t_min) + ", " +
      short_num(preset.strain_av) + "/gdot, " + short_num(preset.average_pressure) +
      "/P). P* = the largest P such that μ and φ at it and at every smaller usable P agree "
      "with the common reference within 2 combined standard errors. If the smallest usable P "
      "already differs, the α_r never reached the limit within the grid and has no P*. Larger "
      "error bars make agreement easier: P* is resolution-limited, and quantised by the "
      "grid.\n\n"
      "**C. Cost** to shear to strain 1 (the seed's t ≥ 1/gdot) at (P*, J): the measured CPU "
      "seconds per τ0 per particle of the pressure-scan run at P* × N / (J P*), and its "
      "particle force evaluations per particle / (J P*).\n\n";

  md += "## Common P → 0 reference\n\n";
  {
    std::vector<std::vector<std::string>> rows;
    for (const auto& [j, ref] : refs) {
      std::string verdicts;
      for (std::size_t k = 0; k < ref.replicas.size(); ++k)
        verdicts += (k ? "; " : "") + ref.replicas[k].verdict_text();
      rows.push_back({short_num(j), ref.value.usable ? pm(ref.value.mu, ref.value.mu_err, 4) : "—",
                      ref.value.usable ? pm(ref.value.phi, ref.value.phi_err, 5) : "—",
                      num(hard_sphere_phi(j, preset.n), 4),
                      std::to_string(ref.used) + " of " + std::to_string(ref.replicas.size()) +
                          (ref.value.usable ? "" : " (**not usable**: " + ref.why + ")"),
                      cell(ref.block_length), cell(ref.tau_phi), cell(ref.tau_sigma), verdicts});
    }
    md += markdown_table({"J", "μ", "φ", "φ, seed's law at N", "replicas used", "block length",
                          "τ_φ", "τ_σ", "verdicts"},
                         rows) +
          "\n(τ: the integrated autocorrelation times, mean over the replicas; the seed's law "
          "is its finite-size fit, shown for orientation only.)\n\n";
  }

  md += "## A. Fastest stable integrator\n\n";
  {
    std::vector<std::vector<std::string>> rows;
    for (const AlphaResult& ar : results) {
      if (ar.ends.empty()) {
        rows.push_back({short_num(ar.alpha), "no δ with P ≥ p_min", "—", "—", "—", "—"});
        continue;
      }
      const Candidate& c = ar.candidates[std::size_t(ar.chosen)];
      std::string others;
      for (const Candidate& o : ar.candidates) {
        if (!o.ok || &o == &c)
          continue;
        others += (others.empty() ? "" : ", ") + ar.ends.front().settings[o.setting].label + " " +
                  num(1e6 * o.cost, 3);
      }
      rows.push_back(
          {short_num(ar.alpha),
           ar.integrator.label + (ar.chosen_verified ? ""
                                                     : " (**not verified**: no setting "
                                                       "stable and accurate at both ends)"),
           ar.chosen_verified ? num(1e6 * c.cost, 3) : "—",
           cell(1e6 * c.cost_hi) + " / " + cell(1e6 * c.cost_lo),
           std::isfinite(ar.euler_dt_max) ? short_num(ar.euler_dt_max) : "none",
           others.empty() ? "—" : others});
    }
    md += markdown_table(
              {"α_r", "integrator", "μs / τ0 / particle (scan-weighted)", "at largest / smallest δ",
               "Euler dt_max", "other stable and accurate settings (μs / τ0 / particle)"},
              rows) +
          "\n";
  }

  md += "## B–C. Largest hard-sphere-limit pressure and cost\n\n";
  {
    std::vector<std::string> header = {"α_r"};
    for (double j : preset.targets_j) {
      header.push_back("P* (J = " + short_num(j) + ")");
      header.push_back("CPU s to strain 1, N = " + std::to_string(preset.n));
      header.push_back("force evaluations / particle");
    }
    std::vector<std::vector<std::string>> rows;
    for (const AlphaResult& ar : results) {
      std::vector<std::string> row = {short_num(ar.alpha)};
      for (double j : preset.targets_j) {
        if (!ar.p_star.count(j)) {
          row.insert(row.end(), {"—", "—", "—"});
          continue;
        }
        const PStar& ps = ar.p_star.at(j);
        std::string s;
        if (!refs[j].value.usable)
          s = "undetermined (no usable reference)";
        else if (ps.smallest < 0)
          s = "undetermined (no usable run)";
        else if (!ps.reached && ps.left_out_below > 0)
          s = "undetermined (smallest usable P " +
              num(ar.pscan.at(j)[std::size_t(ps.smallest)].pressure, 3) + " differs; " +
              std::to_string(ps.left_out_below) + " smaller P left out by their verdicts" +
              (ps.left_out_below_agrees ? ", one of which agrees on its own errors)" : ")");
        else if (!ps.reached)
          s = "**not reached** (smallest usable P " +
              num(ar.pscan.at(j)[std::size_t(ps.smallest)].pressure, 3) + " differs)";
        else
          s = (ps.p_star_is_largest ? "≥ " : "") + num(ps.p_star, 3) +
              (ps.p_star_is_smallest ? " (smallest)" : "");
        row.push_back(s);
        const Cost c = ar.cost.count(j) ? ar.cost.at(j) : Cost{};
        const std::string flag = ar.chosen_verified ? "" : " (unverified integrator)";
        row.push_back(std::isfinite(c.seconds_n) ? num(c.seconds_n, 3) + flag : "—");
        row.push_back(cell(c.evaluations));
      }
      rows.push_back(row);
    }
    md += markdown_table(header, rows) +
          "\n(smallest: P* is the smallest usable P of the grid, because the next larger one "
          "already differs; the true P* lies between the two. ≥: every usable P of the grid "
          "agrees, so the true P* may be larger.)\n\n";
  }

  md += "## Pressure scans\n\n";
  for (const AlphaResult& ar : results) {
    for (const auto& [j, runs] : ar.pscan) {
      std::vector<std::vector<std::string>> rows;
      for (const auto& pr : runs) {
        const DiagnosedRun& r = pr.run;
        std::string vs = "—";
        if (pr.agrees >= 0)
          vs = std::string(pr.agrees ? "agrees" : "**differs**") + " (Δμ " + num(pr.dmu, 2) +
               " ± " + num(pr.dmu_err, 2) + ", Δφ " + num(pr.dphi, 2) + " ± " +
               num(pr.dphi_err, 2) + ")";
        if (!r.complete()) {
          rows.push_back({short_num(pr.delta), num(pr.pressure, 3), r.verdict_text(), "—", "—", vs,
                          cell(pr.duration), cpu_cell(r)});
          continue;
        }
        rows.push_back({short_num(pr.delta), num(pr.pressure, 3), r.verdict_text(),
                        pm(r.value("mu"), r.value("mu_err"), 4),
                        pm(r.value("phi"), r.value("phi_err"), 5), vs, cell(pr.duration),
                        cpu_cell(r)});
      }
      md += "### α_r = " + short_num(ar.alpha) + ", J = " + short_num(j) + " (" +
            ar.integrator.label + ")\n\n" +
            markdown_table(
                {"δ", "P", "verdict", "μ", "φ", "vs the common reference", "t_eq + t_av", "CPU s"},
                rows) +
            "\n";
    }
  }
  md += "## Integrator scans\n\n";
  for (const AlphaResult& ar : results) {
    for (const Scan& s : ar.ends) {
      std::vector<std::vector<std::string>> rows;
      for (std::size_t k = 0; k < s.runs.size(); ++k) {
        const DiagnosedRun& r = s.runs[k];
        rows.push_back(
            {s.settings[k].label, s.verdict[k],
             r.complete() ? pm(r.balance.ratio, r.balance.error, 3) : "—",
             r.complete() ? num(r.window.force_correlation, 3) : "—",
             std::isfinite(s.mu_err[k])
                 ? num(100 * s.mu_err[k], 2) + " ± " + num(100 * s.mu_floor[k], 2) + " %"
                 : "—",
             std::isfinite(s.phi_err[k]) ? num(s.phi_err[k], 2) + " ± " + num(s.phi_floor[k], 2)
                                         : "—",
             cell(1e6 * s.seconds_per_tau[k]), cell(s.evaluations_per_tau[k]), cpu_cell(r)});
      }
      md += "### α_r = " + short_num(ar.alpha) + ", δ = " + short_num(s.delta) +
            " (P = " + num(s.point.pressure, 3) + ", gdot = " + num(s.point.gdot, 3) +
            "); preparation: " + s.prep.verdict_text() + "\n\n" +
            markdown_table(
                {"setting", "verdict", "energy balance", "force step corr.", "|Δμ|/μ ± floor",
                 "|Δφ| ± floor", "μs / τ0 / particle", "force evaluations / τ0", "CPU s"},
                rows) +
            "\n";
    }
  }
  {
    std::vector<const DiagnosedRun*> all;
    for (const auto& ar : results) {
      for (const Scan& sc : ar.ends)
        for (const auto& r : sc.runs)
          all.push_back(&r);
      for (const auto& [j, list] : ar.pscan)
        for (const auto& pr : list)
          all.push_back(&pr.run);
    }
    for (const auto& [j, ref] : refs)
      for (const auto& r : ref.replicas)
        all.push_back(&r);
    md += excluded_section(all);
    md +=
        "In the integrator scans, runs listed here as *not steady* or *correlated* still enter "
        "the paired accuracy test (see A); the reference's replicas left out as *correlated* are "
        "kept when another "
        "replica is usable (their errors then include the replica scatter).\n\n";
  }
  md += "## Conclusion\n\n";
  for (double j : preset.targets_j) {
    md += "- J = " + short_num(j) + ": ";
    if (!refs[j].value.usable) {
      md += "no usable common reference (" + refs[j].why + "): no P* and no optimum.\n";
      continue;
    }
    if (optimum.count(j)) {
      const AlphaResult& ar = results[optimum.at(j)];
      md += "cheapest α_r = " + short_num(ar.alpha) + " (" + ar.integrator.label + ", " +
            num(ar.cost.at(j).seconds_n, 3) +
            " CPU s to strain 1 at N = " + std::to_string(preset.n) + ").";
    } else {
      md += "no α_r has a verified integrator and a P* within the grid.";
    }
    std::string never;
    for (const AlphaResult& ar : results)
      if (ar.p_star.count(j) && ar.p_star.at(j).smallest >= 0 && !ar.p_star.at(j).reached &&
          ar.p_star.at(j).left_out_below == 0)
        never += (never.empty() ? "" : ", ") + short_num(ar.alpha);
    if (!never.empty())
      md += " Never reached the hard-sphere limit within the grid: α_r = " + never + ".";
    std::string none;
    for (const AlphaResult& ar : results)
      if (ar.p_star.count(j) && ar.p_star.at(j).smallest < 0)
        none += (none.empty() ? "" : ", ") + short_num(ar.alpha);
    if (!none.empty())
      md += " No usable pressure-scan run: α_r = " + none + ".";
    md += "\n";
  }
  md +=
      "- The seed's optimum is α_r ∈ [1.75, 2.0]. Ours is the cheapest α_r above, within the "
      "resolution of the δ grid and of the integrator scans; CPU seconds are measured on "
      "shared cores and carry their noise.\n";
  md += "\nPlots: " +
        std::string(plotted ? "`softness_dt.png`, `softness_pscan.png`, `softness_cost.png`."
                            : "not produced (see warnings).") +
        "\n";
  write_text(options.out_dir + "/report.md", md);

  if (!options.quiet) {
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    std::printf("\nsoftness: alpha_r : integrator");
    for (const auto& ar : results)
      std::printf("  %g: %s%s", ar.alpha, ar.integrator.label.c_str(),
                  ar.chosen_verified ? "" : " (unverified)");
    for (double j : preset.targets_j) {
      std::printf(
          "\n  J = %g: reference phi %s, optimum alpha_r = %s", j,
          refs[j].value.usable ? pm(refs[j].value.phi, refs[j].value.phi_err, 4).c_str() : "none",
          optimum.count(j) ? short_num(results[optimum.at(j)].alpha).c_str() : "none");
    }
    std::printf("\nsoftness: wall %.1f s; report %s/report.md\n", wall, options.out_dir.c_str());
  }
  return 0;
}

namespace {
const Registrar reg{{"softness",
                     "potential-exponent optimization: fastest stable integrator, largest hard-"
                     "sphere-limit pressure against a common P -> 0 reference, and total cost "
                     "against alpha_r",
                     run_softness}};
}  // namespace

}  // namespace jamflow::studies
