// Potential-exponent optimization (studies/softness; the seed's alpha_r study, sec. "Model and
// numerical methods"; SPEC §5 last item). For each alpha_r:
//   A. the fastest stable integrator: the comparison plan (studies/softness/<preset>.toml) runs
//      every integrator setting at both ends of the alpha_r's overlap range, one [[case]] each,
//      from one prepared state against the case's smallest Euler step; here, the cheapest
//      setting that is stable and accurate (mu and phi) at both ends, per tau_0 over the pressure
//      scan it will run;
//   B. for target viscous numbers J, a pressure scan with that integrator: P* = the largest P
//      at which mu and phi agree with a common P -> 0 reference within errors. The hard-sphere
//      limit phi(J), mu(J) does not depend on alpha_r, so the reference is one per J: alpha_r =
//      2 at a pressure far below the grid (CVODE, relaxed for t >= relax_pressure / P);
//   C. the measured cost to reach strain 1 at (P*, J) with that integrator.
// B and C are the comparison's follow-up (framework/compare.hpp CompareFollowUp): one more sweep
// stage, whose scenes the plan builds (ComparePlan::setting_scene at each point of the grid).
#include "studies/softness/softness.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>
#include <tuple>

#include "lib/error.hpp"
#include "studies/common.hpp"

namespace jamflow::studies {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A list of numbers > 0 from [study]; one line naming the key otherwise.
std::vector<double> positive_list(const toml::table& t, const ConfigSection& sec, const char* key) {
  const toml::node* n = t.get(key);
  const toml::array* a = n ? n->as_array() : nullptr;
  std::vector<double> out;
  if (a)
    for (const auto& v : *a)
      if (v.is_number() && v.value<double>().value_or(0.0) > 0.0)
        out.push_back(*v.value<double>());
  if (!a || a->empty() || out.size() != a->size()) {
    std::ostringstream shown;
    if (n)
      n->visit([&](const auto& x) { shown << x; });
    throw ConfigError(sec.label(key) + " = " + (n ? shown.str() : "(missing)") +
                      "; allowed a non-empty list of numbers > 0");
  }
  return out;
}
}  // namespace

SoftnessParameters softness_parameters(const ComparePlan& plan) {
  SoftnessParameters p;
  if (plan.study_keys.empty())
    throw ConfigError(plan.path +
                      ": no [study] table; allowed a softness plan with [study] "
                      "targets_j, deltas, p_min, ... (studies/softness/README.md)");
  ConfigSection sec("study", &plan.study_keys);
  try {
    p.targets_j = positive_list(plan.study_keys, sec, "targets_j");
    p.deltas = positive_list(plan.study_keys, sec, "deltas");
    p.p_min = sec.number("p_min", 0.0, Range::non_negative());
    p.mu_tolerance = sec.number("mu_tolerance", p.mu_tolerance, Range::positive());
    p.phi_tolerance = sec.number("phi_tolerance", p.phi_tolerance, Range::positive());
    p.strain_eq = sec.number("strain_eq", Range::non_negative());
    p.strain_av = sec.number("strain_av", Range::non_negative());
    p.t_min = sec.number("t_min", Range::positive());
    p.relax_pressure = sec.number("relax_pressure", Range::positive());
    p.average_pressure = sec.number("average_pressure", Range::positive());
    p.p_reference = sec.number("p_reference", Range::positive());
    p.reference_rtol = sec.number("reference_rtol", Range::positive());
    p.reference_average = sec.number("reference_average", Range::positive());
    p.reference_replicas = sec.integer("reference_replicas", 1, 100);
    static const std::vector<std::string> kKeys = {"targets_j",
                                                   "deltas",
                                                   "p_min",
                                                   "mu_tolerance",
                                                   "phi_tolerance",
                                                   "strain_eq",
                                                   "strain_av",
                                                   "t_min",
                                                   "relax_pressure",
                                                   "average_pressure",
                                                   "p_reference",
                                                   "reference_rtol",
                                                   "reference_average",
                                                   "reference_replicas"};
    for (const auto& [k, v] : plan.study_keys)
      if (std::find(kKeys.begin(), kKeys.end(), k.str()) == kKeys.end())
        throw ConfigError("unknown key " + sec.label(k.str()) + "; allowed " + join(kKeys));
  } catch (const ConfigError& e) {
    throw ConfigError(plan.path + ": " + e.what());
  }
  return p;
}

double steps_per_particle(double j, double pressure, double dt) {
  return 1.0 / (j * pressure * dt);
}

double cost_to_strain_one(double per_tau, double j, double pressure) {
  return per_tau / (j * pressure);
}

namespace {

double pressure_of(double alpha, double delta) {
  return std::pow(delta, alpha - 1.0);
}

// The deltas of one alpha_r that are run (P >= p_min), largest first.
std::vector<double> deltas_for(const SoftnessParameters& p, double alpha) {
  std::vector<double> out;
  for (double d : p.deltas)
    if (pressure_of(alpha, d) >= p.p_min * (1.0 - 1e-12))
      out.push_back(d);
  std::sort(out.rbegin(), out.rend());
  return out;
}

double t_eq_for(const SoftnessParameters& p, double pressure, double gdot) {
  return std::max({p.t_min, p.strain_eq / gdot, p.relax_pressure / pressure});
}
double t_av_for(const SoftnessParameters& p, double pressure, double gdot) {
  return std::max({p.t_min, p.strain_av / gdot, p.average_pressure / pressure});
}

double scene_number(const Scene& scene, const char* section, const char* key, double fallback) {
  const toml::table* t = scene.table(section);
  const toml::node* n = t ? t->get(key) : nullptr;
  return n && n->is_number() ? n->value<double>().value_or(fallback) : fallback;
}

// One case of the plan: one end of an alpha_r's overlap range, its settings judged against the
// case's reference (accurate: |d mu| / mu and |d phi| within the tolerances plus 2x the paired
// error of the difference; mu = sigma_xy / P at the imposed P, so its relative difference is
// sigma_xy's).
struct End {
  const CompareCaseOutcome* outcome = nullptr;
  double delta = 0.0, pressure = 0.0;
  std::vector<double> mu_err, mu_floor, phi_err, phi_floor;
  std::vector<double> seconds_per_tau, evaluations_per_tau;  // per particle
  std::vector<bool> accurate;
  double euler_dt_max = kNaN;
  std::size_t setting(const std::string& label) const {  // index in the case, or size()
    const auto& s = outcome->plan->settings;
    for (std::size_t k = 0; k < s.size(); ++k)
      if (s[k].label == label)
        return k;
    return s.size();
  }
};

void analyse_end(End& e, const SoftnessParameters& p) {
  const ComparePlan& plan = *e.outcome->plan;
  const analysis::CompareResult& res = *e.outcome->result;
  const std::size_t m = plan.settings.size();
  e.mu_err.assign(m, kNaN);
  e.mu_floor.assign(m, kNaN);
  e.phi_err.assign(m, kNaN);
  e.phi_floor.assign(m, kNaN);
  e.seconds_per_tau.assign(m, kNaN);
  e.evaluations_per_tau.assign(m, kNaN);
  e.accurate.assign(m, false);
  const auto index = [&](const char* o) {
    return std::size_t(std::find(plan.observables.begin(), plan.observables.end(), o) -
                       plan.observables.begin());
  };
  const std::size_t os = index("sigma_xy"), of = index("phi");
  const auto& ref = res.settings[plan.reference];
  const bool have_ref =
      ref.ran && ref.stable && os < ref.observables.size() && of < ref.observables.size();
  for (std::size_t k = 0; k < m; ++k) {
    const auto& r = res.settings[k];
    e.seconds_per_tau[k] = r.ran ? r.cpu_per_particle_tau.value : kNaN;
    double evals = 0.0, n = 0.0;
    for (const DiagnosedRun* d : e.outcome->runs[k]) {
      const auto& samples = d->result.series.samples;
      if (d->complete() && !samples.empty() && samples.back().time > 0.0 && d->n > 0) {
        evals += d->particle_steps / (samples.back().time * double(d->n));
        n += 1.0;
      }
    }
    e.evaluations_per_tau[k] = n > 0.0 ? evals / n : kNaN;
    if (!have_ref || !r.ran || !r.stable || os >= r.observables.size() ||
        of >= r.observables.size())
      continue;
    const double sigma_ref = std::abs(ref.observables[os].mean.value);
    const bool self = k == plan.reference;
    e.mu_err[k] = std::abs(r.observables[os].difference.value) / sigma_ref;
    e.mu_floor[k] = self ? 0.0 : r.observables[os].difference.error / sigma_ref;
    e.phi_err[k] = std::abs(r.observables[of].difference.value);
    e.phi_floor[k] = self ? 0.0 : r.observables[of].difference.error;
    e.accurate[k] = e.mu_err[k] <= p.mu_tolerance + 2.0 * e.mu_floor[k] &&
                    e.phi_err[k] <= p.phi_tolerance + 2.0 * e.phi_floor[k];
  }
  // Euler's largest step: from the reference up the Euler steps, to the first one that is not
  // stable and accurate.
  std::vector<std::pair<double, std::size_t>> euler;
  for (std::size_t k = 0; k < m; ++k) {
    const CompareMethod method = compare_method(plan, k);
    if (method.kind == "euler")
      euler.emplace_back(method.dt, k);
  }
  std::sort(euler.begin(), euler.end());
  const double dt_ref = compare_method(plan, plan.reference).dt;
  for (const auto& [dt, k] : euler) {
    if (dt < dt_ref)
      continue;
    if (!e.accurate[k])
      break;
    e.euler_dt_max = dt;
  }
}

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
  std::string why;  // why it is not usable
  double tau_phi = kNaN, tau_sigma = kNaN, block_length = kNaN;
};

struct Candidate {
  std::string label;   // the setting's, the same in every case of the alpha_r
  bool ok = false;     // stable and accurate at every end
  double cost = kNaN;  // seconds per tau_0 per particle, weighted over the scan
  double cost_hi = kNaN, cost_lo = kNaN;
};

struct Cost {
  double seconds_n = kNaN;     // CPU seconds to strain 1 at the plan's N
  double seconds_1000 = kNaN;  // the same scaled to N = 1000
  double evaluations = kNaN;   // particle force evaluations per particle to strain 1
};

struct AlphaResult {
  double alpha = 2.0;
  std::vector<double> deltas;         // run, largest first
  const ComparePlan* plan = nullptr;  // the largest delta's case: the scans' scenes come from it
  std::vector<End> ends;              // largest delta, then smallest (one if they coincide)
  std::vector<Candidate> candidates;
  int chosen = -1;               // index into candidates
  bool chosen_verified = false;  // stable and accurate at every end (else a fallback)
  std::string integrator;        // the chosen setting's label
  double euler_dt_max = kNaN;
  std::map<double, std::vector<PressureRun>> pscan;  // J -> runs (deltas descending)
  std::map<double, PStar> p_star;
  std::map<double, Cost> cost;
};

// A candidate's cost per tau_0 over the pressure scan it would run: the measured costs at the
// two ends, interpolated in log P (and held beyond them), weighted by each scan run's length.
double weighted_cost(const SoftnessParameters& p, const AlphaResult& ar, double c_hi, double c_lo) {
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

// The integrator of an alpha_r: the cheapest setting stable and accurate at every end. Without
// one (no usable reference, or none accurate) the scans run with the cheapest setting that
// finished stable at every end, else the reference, flagged, and its cost enters no comparison.
void choose(AlphaResult& ar, const SoftnessParameters& p) {
  const End& hi = ar.ends.front();
  const End& lo = ar.ends.back();
  double best = std::numeric_limits<double>::infinity();
  for (const CompareSetting& s : hi.outcome->plan->settings) {
    Candidate c;
    c.label = s.label;
    c.ok = true;
    for (const End& e : ar.ends) {
      const std::size_t k = e.setting(s.label);
      c.ok = c.ok && k < e.accurate.size() && e.accurate[k] && std::isfinite(e.seconds_per_tau[k]);
    }
    const std::size_t kh = hi.setting(s.label), kl = lo.setting(s.label);
    c.cost_hi = kh < hi.seconds_per_tau.size() ? hi.seconds_per_tau[kh] : kNaN;
    c.cost_lo = kl < lo.seconds_per_tau.size() ? lo.seconds_per_tau[kl] : kNaN;
    if (c.ok) {
      c.cost = weighted_cost(p, ar, c.cost_hi, c.cost_lo);
      if (c.cost < best) {
        best = c.cost;
        ar.chosen = int(ar.candidates.size());
      }
    }
    ar.candidates.push_back(c);
  }
  ar.chosen_verified = ar.chosen >= 0;
  if (ar.chosen < 0) {
    double cheapest = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < ar.candidates.size(); ++k) {
      bool fine = true;
      for (const End& e : ar.ends) {
        const std::size_t i = e.setting(ar.candidates[k].label);
        fine = fine && i < e.accurate.size() && e.outcome->result->settings[i].stable &&
               std::isfinite(e.seconds_per_tau[i]);
      }
      const double c = weighted_cost(p, ar, ar.candidates[k].cost_hi, ar.candidates[k].cost_lo);
      if (fine && c < cheapest) {
        cheapest = c;
        ar.chosen = int(k);
      }
    }
    if (ar.chosen < 0)
      ar.chosen = int(hi.outcome->plan->reference);
  }
  ar.integrator = ar.candidates[std::size_t(ar.chosen)].label;
  ar.euler_dt_max = hi.euler_dt_max;
  for (const End& e : ar.ends)
    ar.euler_dt_max = std::isfinite(e.euler_dt_max) && std::isfinite(ar.euler_dt_max)
                          ? std::min(ar.euler_dt_max, e.euler_dt_max)
                          : kNaN;
}

// A pressure-scan or reference run: the plan's scene of setting `s` at another state point
// (alpha_r, P, gdot = J P, the start phi, the seed, the lengths), the one place where a request
// becomes a scene. `extra`: a setting that is not the plan's (the reference's CVODE).
RunRequest scan_request(ComparePlan q, std::size_t s, double alpha, double pressure, double j,
                        std::uint64_t seed, double t_eq, double t_av, bool budget,
                        std::string label) {
  const double phi = phi_start(j, q.settings[s].n, 0.01, 0.63);
  q.base.set_value("system.alpha", toml::value<double>(alpha));
  q.base.set_value("system.phi", toml::value<double>(phi));
  q.base.set_value("system.seed", toml::value<std::int64_t>(std::int64_t(seed)));
  q.base.set_value("ensemble.pressure", toml::value<double>(pressure));
  q.base.set_value("shear.rate", toml::value<double>(j * pressure));
  q.run.insert_or_assign("t_eq", t_eq);
  q.run.insert_or_assign("t_av", t_av);
  // 400 samples over the window; with a fixed step, a whole number of steps each.
  double every = t_av / 400.0;
  if (const double dt = compare_method(q, s).dt; std::isfinite(dt) && dt > 0.0)
    every = dt * std::max(1.0, std::floor(every / dt + 1e-9));
  q.run.insert_or_assign("sample_every", every);
  if (!budget)
    q.run.insert_or_assign("max_force_evaluations", std::int64_t{0});
  RunRequest r;
  r.label = std::move(label);
  const Scene scene = q.setting_scene(s);
  r.scene = scene.text();
  r.seed = seed;
  r.window_options = q.window_options(s);
  const toml::table* run = scene.table("run");
  const toml::node* b = run ? run->get("max_force_evaluations") : nullptr;
  r.budget = b && b->is_integer() ? b->as_integer()->get() : 0;
  return r;
}

Reference combine_reference(double j, std::vector<DiagnosedRun> replicas) {
  Reference ref;
  ref.j = j;
  ref.replicas = std::move(replicas);
  std::vector<Summary> sums;
  bool all_decorrelated = true;
  for (const DiagnosedRun& r : ref.replicas) {
    // Stable and steady; blocks shorter than 2 tau are kept when another replica gives a scatter.
    if (r.cls.verdict != Verdict::kStable && r.cls.verdict != Verdict::kCorrelated)
      continue;
    sums.push_back(r.result.summary);
    all_decorrelated = all_decorrelated && r.cls.verdict == Verdict::kStable;
  }
  ref.used = sums.size();
  if (sums.empty()) {
    ref.why = "no replica finished stable and steady";
    return ref;
  }
  if (sums.size() == 1 && !all_decorrelated) {
    ref.why = "one usable replica, and its blocks are shorter than 2 tau";
    return ref;
  }
  const Summary s = sums.size() > 1 ? combine_replicas(sums) : sums.front();
  // The block error of the mean, or the replica scatter if larger (the rule of the sweep's
  // collect for points with several replicas).
  auto err = [&](const Estimate& e) {
    const double r = e.replica_err.value_or(kNaN);
    return std::isfinite(r) ? std::max(e.err, r) : e.err;
  };
  ref.value.usable = true;
  ref.value.mu = s.mu.value;
  ref.value.mu_err = err(s.mu);
  ref.value.phi = s.phi.value;
  ref.value.phi_err = err(s.phi);
  ref.tau_phi = s.tau_phi;
  ref.tau_sigma = s.tau_sigma_xy;
  ref.block_length = s.block_length;
  return ref;
}

std::string cell(double v, int digits = 3) {
  return std::isfinite(v) ? num(v, digits) : "—";
}

// Attributes of a pressure-scan or reference run (the names of the plots' reader).
Attributes run_attributes(const DiagnosedRun& r) {
  Attributes a = {{"label", r.label},
                  {"verdict", verdict_name(r.cls.verdict)},
                  {"reason", r.cls.reason},
                  {"cpu_seconds", r.cpu_seconds},
                  {"particle_steps", r.particle_steps}};
  const Summary& s = r.result.summary;
  for (const auto& [k, v] : {std::pair{"mu", s.mu.value},
                             {"mu_err", s.mu.err},
                             {"phi", s.phi.value},
                             {"phi_err", s.phi.err},
                             {"tau_phi", s.tau_phi},
                             {"tau_sigma_xy", s.tau_sigma_xy}})
    a.push_back({std::string("summary_") + k, v});
  return a;
}

// The study's section of the report (after the table of cases, each case's comparison in its
// folder) and its conclusions for programs (OUT/softness.h5).
CompareSection softness_section(const SoftnessParameters& p,
                                const std::vector<AlphaResult>& results,
                                const std::map<double, Reference>& refs,
                                const std::map<double, std::size_t>& optimum, double n) {
  CompareSection out;
  const std::string N = std::to_string(std::int64_t(n));
  std::string md = "## The softness study\n\n";
  {
    std::vector<double> ds = p.deltas;
    std::sort(ds.rbegin(), ds.rend());
    std::string grid;
    for (double d : ds)
      grid += (grid.empty() ? "" : ", ") + short_num(d);
    md += "Constant pressure, N = " + N + ". The pressure grid of each α_r is P = δ^(α_r − 1) " +
          "over the typical overlaps δ ∈ {" + grid +
          "}, without the points below P = " + short_num(p.p_min) + ".\n\n";
  }
  md +=
      "**A. Fastest stable integrator.** Each case above is one end of an α_r's overlap range "
      "at J = " +
      short_num(p.targets_j.front()) +
      ": every setting continues from one prepared state with the same seed, against the "
      "case's smallest Euler step. Stable = the comparison's stability verdicts (no divergence, "
      "no step-to-step oscillation in the diagnostic window, energy balance); accurate = "
      "|Δμ|/μ ≤ " +
      num(100 * p.mu_tolerance, 2) + " % and |Δφ| ≤ " + short_num(p.phi_tolerance) +
      ", each plus 2× the paired error of the difference. Runs that are not steady or whose "
      "blocks are shorter than 2 τ are admitted: the test is paired, so a drift common to both "
      "runs cancels. The integrator is the cheapest setting stable and accurate at both ends, "
      "in measured CPU seconds per τ0 per particle, the two ends' costs interpolated in log P "
      "and weighted by the pressure scan's run lengths. (The table of cases above gives each "
      "case's own recommendation, the comparison engine's: steady runs only, within 2 paired "
      "errors. The study's choice is this one.)\n\n"
      "**Common P → 0 reference.** The hard-sphere limit φ(J), μ(J) does not depend on α_r: "
      "one reference per J, α_r = 2 at P = " +
      short_num(p.p_reference) + ", CVODE rtol " + short_num(p.reference_rtol) + ", " +
      std::to_string(p.reference_replicas) +
      " replicas from random states at the hard-sphere law's φ, t_eq = max(" +
      short_num(p.relax_pressure) + "/P, " + short_num(p.strain_eq) + "/gdot), t_av = max(" +
      short_num(p.reference_average) + "/P, " + short_num(p.strain_av) +
      "/gdot). Errors: the block error of the replica mean, or the replica scatter if "
      "larger.\n\n"
      "**B. Pressure scan.** For each J, runs at every P of the grid with the α_r's "
      "integrator, from random states at the hard-sphere law's φ, t_eq = max(" +
      short_num(p.t_min) + ", " + short_num(p.strain_eq) + "/gdot, " + short_num(p.relax_pressure) +
      "/P), t_av = max(" + short_num(p.t_min) + ", " + short_num(p.strain_av) + "/gdot, " +
      short_num(p.average_pressure) +
      "/P). P* = the largest P such that μ and φ at it and at every smaller usable P agree "
      "with the common reference within 2 combined standard errors. If the smallest usable P "
      "already differs, the α_r never reached the limit within the grid and has no P*. Larger "
      "error bars make agreement easier: P* is resolution-limited, and quantised by the "
      "grid.\n\n"
      "**C. Cost** to shear to strain 1 (the seed's t ≥ 1/gdot) at (P*, J): the measured CPU "
      "seconds per τ0 per particle of the pressure-scan run at P* × N / (J P*), and its "
      "particle force evaluations per particle / (J P*).\n\n";

  md += "### Common P → 0 reference\n\n";
  {
    std::vector<std::vector<std::string>> rows;
    for (const auto& [j, ref] : refs) {
      std::string verdicts;
      for (std::size_t k = 0; k < ref.replicas.size(); ++k)
        verdicts += (k ? "; " : "") + ref.replicas[k].verdict_text();
      rows.push_back({short_num(j), ref.value.usable ? pm(ref.value.mu, ref.value.mu_err, 4) : "—",
                      ref.value.usable ? pm(ref.value.phi, ref.value.phi_err, 5) : "—",
                      num(hard_sphere_phi(j, std::int64_t(n)), 4),
                      std::to_string(ref.used) + " of " + std::to_string(ref.replicas.size()) +
                          (ref.value.usable ? "" : " (**not usable**: " + ref.why + ")"),
                      cell(ref.block_length), cell(ref.tau_phi), cell(ref.tau_sigma), verdicts});
      Attributes a = {{"J", j},
                      {"imposed_pressure", p.p_reference},
                      {"alpha", 2.0},
                      {"usable", std::int64_t(ref.value.usable)},
                      {"why", ref.why},
                      {"replicas_used", std::int64_t(ref.used)},
                      {"mu", ref.value.mu},
                      {"mu_err", ref.value.mu_err},
                      {"phi", ref.value.phi},
                      {"phi_err", ref.value.phi_err},
                      {"tau_phi", ref.tau_phi},
                      {"tau_sigma_xy", ref.tau_sigma},
                      {"block_length", ref.block_length},
                      {"phi_hard_sphere_law", hard_sphere_phi(j, std::int64_t(n))}};
      out.values.push_back({"/reference/J" + short_num(j), std::move(a)});
      for (std::size_t k = 0; k < ref.replicas.size(); ++k)
        out.values.push_back({"/reference/J" + short_num(j) + "/replicas/r" + std::to_string(k),
                              run_attributes(ref.replicas[k])});
    }
    md += markdown_table({"J", "μ", "φ", "φ, seed's law at N", "replicas used", "block length",
                          "τ_φ", "τ_σ", "verdicts"},
                         rows) +
          "\n(τ: the integrated autocorrelation times, mean over the replicas; the seed's law "
          "is its finite-size fit, shown for orientation only.)\n\n";
  }

  md += "### A. Fastest stable integrator\n\n";
  {
    std::vector<std::vector<std::string>> rows;
    for (std::size_t a = 0; a < results.size(); ++a) {
      const AlphaResult& ar = results[a];
      const Candidate& c = ar.candidates[std::size_t(ar.chosen)];
      std::string others, ends;
      for (const Candidate& o : ar.candidates)
        if (o.ok && &o != &c)
          others += (others.empty() ? "" : ", ") + o.label + " " + num(1e6 * o.cost, 3);
      for (const End& e : ar.ends)
        ends += (ends.empty() ? "" : ", ") + std::string("[δ = ") + short_num(e.delta) + "](" +
                e.outcome->name() + "/report.md)";
      rows.push_back({short_num(ar.alpha),
                      ar.integrator + (ar.chosen_verified ? ""
                                                          : " (**not verified**: no setting "
                                                            "stable and accurate at both ends)"),
                      ar.chosen_verified ? num(1e6 * c.cost, 3) : "—",
                      cell(1e6 * c.cost_hi) + " / " + cell(1e6 * c.cost_lo),
                      std::isfinite(ar.euler_dt_max) ? short_num(ar.euler_dt_max) : "none",
                      others.empty() ? "—" : others, ends});
      char g[32];
      std::snprintf(g, sizeof g, "/alphas/a%02zu", a);
      out.values.push_back({g,
                            {{"alpha", ar.alpha},
                             {"euler_dt_max", ar.euler_dt_max},
                             {"integrator", ar.integrator},
                             {"integrator_verified", std::int64_t(ar.chosen_verified)}}});
      for (std::size_t k = 0; k < ar.candidates.size(); ++k) {
        const Candidate& x = ar.candidates[k];
        out.values.push_back({std::string(g) + "/candidates/c" + std::to_string(k),
                              {{"setting", x.label},
                               {"ok", std::int64_t(x.ok)},
                               {"seconds_per_tau_particle", x.cost},
                               {"seconds_per_tau_particle_hi", x.cost_hi},
                               {"seconds_per_tau_particle_lo", x.cost_lo},
                               {"chosen", std::int64_t(int(k) == ar.chosen)}}});
      }
      for (std::size_t e = 0; e < ar.ends.size(); ++e) {
        const End& end = ar.ends[e];
        const std::string sg = std::string(g) + (e == 0 ? "/scan_hi" : "/scan_lo");
        out.values.push_back({sg,
                              {{"case", end.outcome->name()},
                               {"delta", end.delta},
                               {"imposed_pressure", end.pressure},
                               {"euler_dt_max", end.euler_dt_max}}});
        for (std::size_t k = 0; k < end.accurate.size(); ++k)
          out.values.push_back({sg + "/settings/" + end.outcome->plan->settings[k].label,
                                {{"accurate", std::int64_t(end.accurate[k])},
                                 {"mu_rel_err", end.mu_err[k]},
                                 {"mu_rel_floor", end.mu_floor[k]},
                                 {"phi_err", end.phi_err[k]},
                                 {"phi_floor", end.phi_floor[k]},
                                 {"seconds_per_tau_particle", end.seconds_per_tau[k]},
                                 {"evaluations_per_tau", end.evaluations_per_tau[k]}}});
      }
    }
    md += markdown_table(
              {"α_r", "integrator", "μs / τ0 / particle (scan-weighted)", "at largest / smallest δ",
               "Euler dt_max", "other stable and accurate settings (μs / τ0 / particle)", "cases"},
              rows) +
          "\n";
  }

  md += "### B–C. Largest hard-sphere-limit pressure and cost\n\n";
  {
    std::vector<std::string> header = {"α_r"};
    for (double j : p.targets_j) {
      header.push_back("P* (J = " + short_num(j) + ")");
      header.push_back("CPU s to strain 1, N = " + N);
      header.push_back("force evaluations / particle");
    }
    std::vector<std::vector<std::string>> rows;
    for (std::size_t a = 0; a < results.size(); ++a) {
      const AlphaResult& ar = results[a];
      std::vector<std::string> row = {short_num(ar.alpha)};
      for (double j : p.targets_j) {
        const PStar& ps = ar.p_star.at(j);
        const auto& runs = ar.pscan.at(j);
        std::string s;
        if (!refs.at(j).value.usable)
          s = "undetermined (no usable reference)";
        else if (ps.smallest < 0)
          s = "undetermined (no usable run)";
        else if (!ps.reached && ps.left_out_below > 0)
          s = "undetermined (smallest usable P " + num(runs[std::size_t(ps.smallest)].pressure, 3) +
              " differs; " + std::to_string(ps.left_out_below) +
              " smaller P left out by their verdicts" +
              (ps.left_out_below_agrees ? ", one of which agrees on its own errors)" : ")");
        else if (!ps.reached)
          s = "**not reached** (smallest usable P " +
              num(runs[std::size_t(ps.smallest)].pressure, 3) + " differs)";
        else
          s = (ps.p_star_is_largest ? "≥ " : "") + num(ps.p_star, 3) +
              (ps.p_star_is_smallest ? " (smallest)" : "");
        row.push_back(s);
        const Cost c = ar.cost.at(j);
        row.push_back(std::isfinite(c.seconds_n)
                          ? num(c.seconds_n, 3) +
                                (ar.chosen_verified ? "" : " (unverified integrator)")
                          : "—");
        row.push_back(cell(c.evaluations));
        char g[64];
        std::snprintf(g, sizeof g, "/alphas/a%02zu/pscan/J%g", a, j);
        out.values.push_back({g,
                              {{"J", j},
                               {"p_star", ps.p_star},
                               {"reached", std::int64_t(ps.reached)},
                               {"p_star_is_smallest", std::int64_t(ps.p_star_is_smallest)},
                               {"p_star_is_largest", std::int64_t(ps.p_star_is_largest)},
                               {"cpu_seconds_N", c.seconds_n},
                               {"cpu_seconds_N1000", c.seconds_1000},
                               {"evaluations_per_particle", c.evaluations}}});
        for (std::size_t k = 0; k < runs.size(); ++k) {
          char rg[32];
          std::snprintf(rg, sizeof rg, "/runs/r%03zu", k);
          Attributes at = run_attributes(runs[k].run);
          at.insert(at.end(), {{"delta", runs[k].delta},
                               {"imposed_pressure", runs[k].pressure},
                               {"duration", runs[k].duration},
                               {"agrees", std::int64_t(runs[k].agrees)},
                               {"dmu", runs[k].dmu},
                               {"dmu_err", runs[k].dmu_err},
                               {"dphi", runs[k].dphi},
                               {"dphi_err", runs[k].dphi_err}});
          out.values.push_back({std::string(g) + rg, std::move(at)});
        }
      }
      rows.push_back(row);
    }
    md += markdown_table(header, rows) +
          "\n(smallest: P* is the smallest usable P of the grid, because the next larger one "
          "already differs; the true P* lies between the two. ≥: every usable P of the grid "
          "agrees, so the true P* may be larger.)\n\n";
  }

  md += "### Pressure scans\n\n";
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
        rows.push_back(
            {short_num(pr.delta), num(pr.pressure, 3), r.verdict_text(),
             r.complete() ? pm(r.result.summary.mu.value, r.result.summary.mu.err, 4) : "—",
             r.complete() ? pm(r.result.summary.phi.value, r.result.summary.phi.err, 5) : "—", vs,
             cell(pr.duration), cpu_cell(r)});
      }
      md += "#### α_r = " + short_num(ar.alpha) + ", J = " + short_num(j) + " (" + ar.integrator +
            ")\n\n" +
            markdown_table(
                {"δ", "P", "verdict", "μ", "φ", "vs the common reference", "t_eq + t_av", "CPU s"},
                rows) +
            "\n";
    }
  }
  {
    std::vector<const DiagnosedRun*> all;
    for (const auto& ar : results)
      for (const auto& [j, list] : ar.pscan)
        for (const auto& pr : list)
          all.push_back(&pr.run);
    for (const auto& [j, ref] : refs)
      for (const auto& r : ref.replicas)
        all.push_back(&r);
    md += "#" + excluded_section(all);
    md +=
        "The reference's replicas left out as *correlated* are kept when another replica is "
        "usable (their errors then include the replica scatter). The cases' own runs left "
        "out are in their reports.\n\n";
  }
  md += "### Conclusion\n\n";
  for (double j : p.targets_j) {
    md += "- J = " + short_num(j) + ": ";
    if (!refs.at(j).value.usable) {
      md += "no usable common reference (" + refs.at(j).why + "): no P* and no optimum.\n";
      continue;
    }
    if (optimum.count(j)) {
      const AlphaResult& ar = results[optimum.at(j)];
      md += "cheapest α_r = " + short_num(ar.alpha) + " (" + ar.integrator + ", " +
            num(ar.cost.at(j).seconds_n, 3) + " CPU s to strain 1 at N = " + N + ").";
    } else {
      md += "no α_r has a verified integrator and a P* within the grid.";
    }
    std::string never, none;
    for (const AlphaResult& ar : results) {
      const PStar& ps = ar.p_star.at(j);
      if (ps.smallest >= 0 && !ps.reached && ps.left_out_below == 0)
        never += (never.empty() ? "" : ", ") + short_num(ar.alpha);
      if (ps.smallest < 0)
        none += (none.empty() ? "" : ", ") + short_num(ar.alpha);
    }
    if (!never.empty())
      md += " Never reached the hard-sphere limit within the grid: α_r = " + never + ".";
    if (!none.empty())
      md += " No usable pressure-scan run: α_r = " + none + ".";
    md += "\n";
  }
  md +=
      "- Each pressure-scan point is one run: P*, and \"never reached\", rest on single runs "
      "compared with the reference at 2 combined standard errors, and a run's block errors "
      "understate its scatter when its blocks are short.\n"
      "- The seed's optimum is α_r ∈ [1.75, 2.0]. Ours is the cheapest α_r above, within the "
      "resolution of the δ grid and of the integrator scans; CPU seconds are measured on "
      "shared cores and carry their noise.\n\nPlots: `softness_dt.png`, `softness_pscan.png`, "
      "`softness_cost.png` (none if the plots were skipped or failed; see the warnings).\n";
  out.values.push_back({"/",
                        {{"study", "softness"},
                         {"N", n},
                         {"mu_tolerance", p.mu_tolerance},
                         {"phi_tolerance", p.phi_tolerance},
                         {"pressure_grid", "P = delta^(alpha_r - 1)"},
                         {"p_min", p.p_min}}});
  out.markdown = std::move(md);
  return out;
}

}  // namespace

int run_softness_plan(const ComparePlan& softness_plan, const StudyOptions& options) {
  ComparePlan plan = softness_plan;
  plan.study = "softness";  // its stages, OUT/softness.h5 and the plot script's input
  const SoftnessParameters p = softness_parameters(plan);
  if (plan.cases.empty())
    throw ConfigError(plan.path +
                      ": no [[case]]; allowed a case per end of each alpha_r's "
                      "overlap range");
  // The cases by alpha_r (the scene's system.alpha), largest delta first.
  std::map<double, std::vector<std::size_t>> by_alpha;
  for (std::size_t c = 0; c < plan.cases.size(); ++c)
    by_alpha[scene_number(plan.cases[c].base, "system", "alpha", 2.0)].push_back(c);
  const auto delta_of = [&](std::size_t c) { return typical_overlap(plan.cases[c].base); };
  for (auto& [alpha, cases] : by_alpha) {
    std::sort(cases.begin(), cases.end(),
              [&](std::size_t a, std::size_t b) { return delta_of(a) > delta_of(b); });
    if (deltas_for(p, alpha).empty())
      throw ConfigError(plan.path + ": cases at alpha_r = " + short_num(alpha) +
                        ", whose [study] deltas all give P < p_min; allowed alpha_r with a "
                        "pressure on the grid");
  }

  const CompareFollowUp follow_up =
      [&](const std::vector<CompareCaseOutcome>& outcomes) -> std::variant<int, CompareSection> {
    std::vector<AlphaResult> results;
    for (const auto& [alpha, cases] : by_alpha) {
      AlphaResult ar;
      ar.alpha = alpha;
      ar.deltas = deltas_for(p, alpha);
      ar.plan = &plan.cases[cases.front()];
      std::vector<std::size_t> ends = {cases.front()};
      if (cases.size() > 1)
        ends.push_back(cases.back());
      for (std::size_t c : ends) {
        if (outcomes.empty())
          break;
        End e;
        e.outcome = &outcomes[c];
        e.delta = delta_of(c);
        e.pressure = scene_number(plan.cases[c].base, "ensemble", "pressure", kNaN);
        analyse_end(e, p);
        ar.ends.push_back(std::move(e));
      }
      if (ar.ends.empty()) {  // --dry-run: the reference stands in (the most expensive)
        ar.chosen = 0;
        ar.candidates.push_back({ar.plan->settings[ar.plan->reference].label});
        ar.integrator = ar.candidates.front().label;
      } else {
        choose(ar, p);
      }
      results.push_back(std::move(ar));
    }

    // B: the pressure scans with each alpha_r's integrator, and the common P -> 0 reference
    // (alpha_r = 2, CVODE, several replicas) in the same stage.
    std::vector<RunRequest> requests;
    std::vector<std::tuple<std::size_t, double, std::size_t>> index;
    for (std::size_t a = 0; a < results.size(); ++a) {
      AlphaResult& ar = results[a];
      std::size_t s = 0;
      while (ar.plan->settings[s].label != ar.integrator)
        ++s;
      for (double j : p.targets_j) {
        auto& list = ar.pscan[j];
        for (double d : ar.deltas) {
          PressureRun pr;
          pr.delta = d;
          pr.pressure = pressure_of(ar.alpha, d);
          const double gdot = j * pr.pressure;
          const double t_eq = t_eq_for(p, pr.pressure, gdot), t_av = t_av_for(p, pr.pressure, gdot);
          pr.duration = t_eq + t_av;
          list.push_back(pr);
          requests.push_back(
              scan_request(*ar.plan, s, ar.alpha, pr.pressure, j, plan.seed + 1, t_eq, t_av, true,
                           "alpha=" + short_num(ar.alpha) + " delta=" + short_num(d) +
                               " J=" + short_num(j) + " " + ar.integrator));
          index.emplace_back(a, j, list.size() - 1);
        }
      }
    }
    const std::size_t n_scan = requests.size();
    {
      ComparePlan q = plan.cases.front();
      CompareSetting cvode;
      cvode.label = "reference";
      cvode.n = q.settings.front().n;
      cvode.overrides.insert("integrator",
                             toml::table{{"kind", "cvode"}, {"rtol", p.reference_rtol}});
      q.settings.push_back(cvode);
      for (double j : p.targets_j) {
        const double gdot = j * p.p_reference;
        const double t_eq = std::max(p.relax_pressure / p.p_reference, p.strain_eq / gdot);
        const double t_av = std::max(p.reference_average / p.p_reference, p.strain_av / gdot);
        for (std::int64_t k = 0; k < p.reference_replicas; ++k)
          requests.push_back(scan_request(q, q.settings.size() - 1, 2.0, p.p_reference, j,
                                          101 + std::uint64_t(k), t_eq, t_av, false,
                                          "reference alpha=2 P=" + short_num(p.p_reference) +
                                              " J=" + short_num(j) + " replica " +
                                              std::to_string(k)));
      }
    }
    std::vector<DiagnosedRun> done;
    if (const auto status = run_stage("softness", "pscan", requests, options, done, true))
      return *status;
    std::size_t runs = 0;
    double cpu = 0.0;
    for (const DiagnosedRun& r : done)
      if (r.cpu_seconds > 0.0) {
        ++runs;
        cpu += r.cpu_seconds;
      }
    for (std::size_t q = 0; q < n_scan; ++q) {
      const auto& [a, j, k] = index[q];
      results[a].pscan[j][k].run = std::move(done[q]);
    }
    std::map<double, Reference> refs;
    for (std::size_t q = n_scan; double j : p.targets_j) {
      std::vector<DiagnosedRun> reps;
      for (std::int64_t k = 0; k < p.reference_replicas; ++k)
        reps.push_back(std::move(done[q++]));
      refs[j] = combine_reference(j, std::move(reps));
    }

    // P* against the common reference, and the cost to strain 1 there (C).
    const double n_particles = double(plan.cases.front().settings.front().n);
    std::map<double, std::size_t> optimum;
    for (double j : p.targets_j) {
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t a = 0; a < results.size(); ++a) {
        AlphaResult& ar = results[a];
        auto& runs = ar.pscan[j];
        std::vector<ScanValue> values;
        for (const PressureRun& pr : runs) {
          const Summary& s = pr.run.result.summary;
          values.push_back({pr.pressure, pr.run.cls.verdict == Verdict::kStable, s.mu.value,
                            s.mu.err, s.phi.value, s.phi.err});
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
        for (const PressureRun& pr : runs) {
          if (!std::isfinite(ps.p_star) || pr.pressure != ps.p_star || !(pr.duration > 0.0) ||
              pr.run.n <= 0)
            continue;
          const double per_tau = pr.run.cpu_seconds / (pr.duration * double(pr.run.n));
          const double evals = pr.run.particle_steps / (pr.duration * double(pr.run.n));
          c.seconds_n = cost_to_strain_one(per_tau, j, ps.p_star) * n_particles;
          c.seconds_1000 = cost_to_strain_one(per_tau, j, ps.p_star) * 1000.0;
          c.evaluations = cost_to_strain_one(evals, j, ps.p_star);
        }
        if (ar.chosen_verified && std::isfinite(c.seconds_n) && c.seconds_n < best) {
          best = c.seconds_n;
          optimum[j] = a;
        }
        ar.cost[j] = c;
      }
    }
    CompareSection section = softness_section(p, results, refs, optimum, n_particles);
    section.runs = runs;
    section.cpu_seconds = cpu;
    return section;
  };
  return run_compare(plan, options, {}, {"softness/plot.py"}, follow_up);
}

namespace {
const Registrar reg{{"softness",
                     "potential-exponent optimization: fastest stable integrator, largest hard-"
                     "sphere-limit pressure against a common P -> 0 reference, and total cost "
                     "against alpha_r",
                     [](const StudyOptions& o) {
                       return run_softness_plan(study_compare_plan("softness", o.preset), o);
                     }}};
}  // namespace

}  // namespace jamflow::studies
