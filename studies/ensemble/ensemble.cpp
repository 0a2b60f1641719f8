// Ensemble comparison (the seed's Fig. 1, sec. "Model and numerical methods"): the same shear
// rate at constant pressure P = 1e-5 (Kolb–Dünweg piston) and at constant volume at the
// packing fraction the constant-pressure runs reached. Reports the block standard deviation of
// the viscosity and of phi in each ensemble, their ratio, and the spread of phi over runs.
// The seed finds the viscosity's block deviation ~5x smaller at constant pressure and the
// spread of phi over three runs ~3e-4 (N = 1000, gdot = 3.98e-9). See README.md.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>
#include <optional>
#include <sstream>

#include "analysis/seed.hpp"
#include "driver/run.hpp"
#include "ensembles/constant_volume.hpp"
#include "integrators/euler.hpp"
#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "lib/init.hpp"
#include "lib/model.hpp"
#include "lib/statistics.hpp"
#include "lib/version.hpp"
#include "lib/xyz.hpp"
#include "studies/common.hpp"
#include "studies/diagnostics.hpp"
#include "studies/study.hpp"
#include "studies/table_report.hpp"

namespace jamflow::studies {
namespace {

// Everything a preset changes: sizes, rates, durations. Never the physics or the analysis.
struct Preset {
  std::string name;
  std::int64_t n;
  double pressure;    // imposed P at constant pressure
  double xi_v;        // piston friction (the seed's 1e-4)
  double shear_rate;  // gdot
  double t_eq, t_av;  // per constant-pressure run (the seed: t_eq = t_av, sum >= 1/gdot)
  // Constant volume starts from the constant-pressure final states (already sheared steady
  // states, dilated by a few 1e-4 in phi), so it needs a shorter equilibration; same t_av.
  double t_eq_nv;
  double sample_every;
  int replicas;
  double t_relax;  // overlap relaxation of the random start, at constant volume without shear
  IntegratorSettings integrator;  // handed to the driver as typed settings
};

// Explicit Euler at dt = 0.3 tau_0, for both ensembles and every preset. Measured at
// N = 1000, P = 1e-5 (README.md): Euler is stable up to dt ~ 0.4 here (SPEC §4), dt = 0.3 and 0.15
// give the same means, and its piston obeys <P_hat> - P = xi_V Delta V / T exactly at the
// sampled states. RESPA with Euler sub-steps (dt = 1, 3 sub-steps, the seed's step) costs 1.5x
// more per tau_0 and biases the sampled <P_hat> by +6% at J = 10 (+1% at J = 1), an O(dt)
// splitting error; with Heun on both levels the bias goes but the cost is 3x Euler's.
const IntegratorSettings kIntegrator = IntegratorSettings("euler").set("dt", 0.3);

Preset preset_of(const std::string& name) {
  // About 2000 samples per averaging window (100 per block of the 20), each a whole number of
  // steps of dt = 0.3.
  // quick (CI, ~1 minute on 2 cores): J = gdot / P = 10, a dilute flow (phi ~ 0.46) whose
  // piston relaxation time xi_V V / (phi dP_hat/dphi) is ~7e3 tau_0, hence t_eq = 3e4.
  if (name == "quick")
    return {"quick", 1000, 1e-5, 1e-4, 1e-4, 3e4, 1e4, 5e3, 6.0, 4, 100.0, kIntegrator};
  // standard (about 1.5 h on 2 cores): J = 0.1 (phi ~ 0.62), the nearest point to the seed's
  // J = 4e-4 that fits. With the seed's t_av = 1/(2 gdot) a block (2.5e4 tau_0) was about one
  // correlation time (tau_sigma_xy 1-3.5e4 tau_0 at constant pressure, 1.4-4.1e4 at constant
  // volume, measured), so the block deviations measured the correlation time as much as the
  // fluctuations. Blocks of 8e4 tau_0 (t_av = 1.6e6) are at least 2 tau in every replica
  // measured; the block std then scales as sqrt(tau / block), the same in both ensembles.
  if (name == "standard")
    return {"standard", 1000, 1e-5, 1e-4, 1e-6, 5e5, 1.6e6, 1e5, 810.0, 4, 200.0, kIntegrator};
  // paper: the seed's state point, J = 4e-4 (phi ~ 0.643); a cluster job.
  if (name == "paper")
    return {"paper",
            1000,
            seed::kEnsemblePressure,
            1e-4,
            seed::kEnsembleRate,
            1.25e8,
            1.25e8,
            1.25e8,
            6e4,
            3,
            200.0,
            kIntegrator};
  throw ConfigError("--preset " + name + "; allowed quick, standard, paper");
}

// The scene without [integrator] (Preset::integrator is handed over typed).
std::string scene_toml(const Preset& p, bool constant_pressure, double phi, std::uint64_t seed) {
  StatePoint point;
  point.n = p.n;
  point.constant_pressure = constant_pressure;
  point.pressure = p.pressure;
  point.phi = phi;
  point.xi_v = p.xi_v;
  point.gdot = p.shear_rate;
  point.seed = seed;
  return state_point_scene(point,
                           {constant_pressure ? p.t_eq : p.t_eq_nv, p.t_av, p.sample_every, 20, 1});
}

// A random state at phi with its overlaps relaxed at constant volume without shear (explicit
// Euler, dt = 0.2): the piston then starts from moderate pressures instead of the O(1e-1) of
// random overlaps, which would first blow the box up.
State relaxed_start(const Preset& p, double phi, std::uint64_t seed) {
  Model model(random_state(std::size_t(p.n), phi, seed), ModelOptions{2.0, 0.3, 1, 20});
  Euler euler(0.2);
  euler.advance(model, ConstantVolume(0.0), p.t_relax);
  State s = model.state();
  s.time = 0.0;
  return s;
}

struct EnsembleRuns {
  std::string name;  // constant_pressure | constant_volume
  RunSpec spec;
  std::vector<ReplicaResult> runs;
  Summary combined;
  // Per replica and their mean (the seed's block deviations are per run).
  std::vector<double> eta_block_std, phi_block_std, phi_mean;
  double eta_block_std_mean = 0.0, phi_block_std_mean = 0.0;
  double phi_spread = 0.0;  // std over replicas of the run means of phi (K - 1)
  // The block std depends on the block length against the correlation times (which differ
  // between the ensembles), so it is also given for 10 and 40 blocks: mean over replicas.
  std::map<int, double> eta_block_std_by_blocks;
  // Replicas left out of the comparison because their steady verdict failed ("replica k:
  // why"); all are kept, with a warning in the report, if none is steady.
  std::vector<std::string> excluded;
  bool none_steady = false;
};

constexpr int kBlockCounts[] = {10, 20, 40};

// eta = sigma_xy / gdot over the averaging window (the samples after t_eq, as summarize()).
std::vector<double> eta_window(const RunSpec& spec, const Series& series) {
  std::vector<double> out;
  for (const auto& s : series.samples) {
    if (s.time > spec.t_eq + 1e-9 * spec.sample_every)
      out.push_back(s.sigma_xy / spec.shear_rate);
  }
  return out;
}

void finish_ensemble(EnsembleRuns& e) {
  // Only steady replicas enter the comparison (driver/verdicts.hpp).
  std::vector<const ReplicaResult*> used;
  for (std::size_t k = 0; k < e.runs.size(); ++k) {
    const auto it = e.runs[k].summary.verdicts.find("steady");
    if (it != e.runs[k].summary.verdicts.end() && it->second.failed())
      e.excluded.push_back("replica " + std::to_string(k) + ": " + it->second.why);
    else
      used.push_back(&e.runs[k]);
  }
  if (used.empty()) {
    e.none_steady = true;
    for (const auto& r : e.runs)
      used.push_back(&r);
  }
  std::vector<Summary> sums;
  for (const ReplicaResult* rp : used) {
    const ReplicaResult& r = *rp;
    sums.push_back(r.summary);
    e.eta_block_std.push_back(r.summary.values.at("eta_block_std"));
    e.phi_block_std.push_back(r.summary.values.at("phi_block_std"));
    e.phi_mean.push_back(r.summary.values.at("phi"));
  }
  e.combined = combine_replicas(sums);
  auto mean = [](const std::vector<double>& v) {
    return std::accumulate(v.begin(), v.end(), 0.0) / double(v.size());
  };
  e.eta_block_std_mean = mean(e.eta_block_std);
  e.phi_block_std_mean = mean(e.phi_block_std);
  const ReplicaAverage ra = replica_average(e.phi_mean, std::vector<double>(e.phi_mean.size()));
  e.phi_spread = ra.replica_std;
  for (int nb : kBlockCounts) {
    double sum = 0.0;
    for (const ReplicaResult* r : used)
      sum += block_average(eta_window(e.spec, r->series), std::size_t(nb)).block_std;
    e.eta_block_std_by_blocks[nb] = sum / double(used.size());
  }
}

bool all_complete(const std::vector<ReplicaResult>& runs, std::string& why) {
  for (const auto& r : runs) {
    if (!r.status.is_complete()) {
      why = r.status.text();
      return false;
    }
  }
  return true;
}

void write_ensemble(H5Writer& w, const EnsembleRuns& e) {
  const std::string g = "/" + e.name;
  w.group(g);
  w.attr(g, "scene", e.spec.scene_text);
  for (const auto& [k, v] : e.combined.values)
    w.attr(g, k, v);
  w.attr(g, "eta_block_std_mean", e.eta_block_std_mean);
  w.attr(g, "excluded_not_steady",
         static_cast<std::int64_t>(e.none_steady ? 0 : e.excluded.size()));
  w.attr(g, "phi_block_std_mean", e.phi_block_std_mean);
  w.attr(g, "phi_spread_over_replicas", e.phi_spread);
  w.dataset(g + "/eta_block_std", e.eta_block_std);
  w.dataset(g + "/phi_block_std", e.phi_block_std);
  w.dataset(g + "/phi_mean", e.phi_mean);
  for (const auto& [nb, v] : e.eta_block_std_by_blocks)
    w.attr(g, "eta_block_std_" + std::to_string(nb) + "_blocks", v);
  for (std::size_t k = 0; k < e.runs.size(); ++k) {
    const ReplicaResult& r = e.runs[k];
    const std::string rg = g + "/replicas/" + std::to_string(k);
    const std::string ts = rg + "/timeseries";
    const Series& s = r.series;
    w.dataset(ts + "/time", s.column(&Sample::time));
    w.dataset(ts + "/strain", s.column(&Sample::strain));
    w.dataset(ts + "/volume", s.column(&Sample::volume));
    w.dataset(ts + "/phi", s.column(&Sample::phi));
    w.dataset(ts + "/pressure", s.column(&Sample::pressure));
    w.dataset(ts + "/sigma_xy", s.column(&Sample::sigma_xy));
    w.dataset(ts + "/energy", s.column(&Sample::energy));
    w.dataset(ts + "/dissipation", s.column(&Sample::dissipation));
    w.dataset(ts + "/piston_dissipation", s.column(&Sample::piston_dissipation));
    w.attr(ts, "t_eq", e.spec.t_eq);
    w.attr(ts, "seed", static_cast<std::int64_t>(r.seed));
    const std::string sm = rg + "/summary";
    w.group(sm);
    for (const auto& [k2, v] : r.summary.values)
      w.attr(sm, k2, v);
    w.attr(sm, "wall_seconds", r.wall_seconds);
    w.attr(sm, "cpu_seconds", r.cpu_seconds);
    w.attr(sm, "status", r.status.text());
  }
}

// The ratio NV/NP of the mean block std of eta, with its error from the replica scatter of the
// per-replica block deviations (propagated as independent relative errors; 0 with one replica).
struct Ratio {
  double value = 0.0, error = 0.0;
};
Ratio eta_block_std_ratio(const EnsembleRuns& np, const EnsembleRuns& nv) {
  auto rel = [](const EnsembleRuns& e) {
    const ReplicaAverage ra =
        replica_average(e.eta_block_std, std::vector<double>(e.eta_block_std.size()));
    return ra.mean > 0.0 ? ra.replica_error / ra.mean : 0.0;
  };
  Ratio r;
  r.value = nv.eta_block_std_mean / np.eta_block_std_mean;
  r.error = r.value * std::hypot(rel(np), rel(nv));
  return r;
}

std::string table_markdown(const EnsembleRuns& np, const EnsembleRuns& nv) {
  auto val = [](const EnsembleRuns& e, const std::string& k) { return e.combined.values.at(k); };
  auto pm3 = [&](const EnsembleRuns& e, const std::string& k, int digits) {
    return num(val(e, k), digits) + " ± " + num(val(e, k + "_err"), 2) + " (blocks) ± " +
           num(val(e, k + "_replica_err"), 2) + " (replicas)";
  };
  const Ratio eta_ratio = eta_block_std_ratio(np, nv);
  std::vector<std::vector<std::string>> rows;
  rows.push_back({"viscosity eta = <sigma_xy>/gdot", pm3(np, "eta", 4), pm3(nv, "eta", 4), "", ""});
  rows.push_back({"block std of eta, 20 blocks of " + num(np.spec.t_av / 20, 3) +
                      " tau_0 (mean over replicas)",
                  num(np.eta_block_std_mean, 3), num(nv.eta_block_std_mean, 3),
                  pm(eta_ratio.value, eta_ratio.error), "~5 (NV/NP)"});
  for (int nb : {10, 40}) {
    const double a = np.eta_block_std_by_blocks.at(nb), b = nv.eta_block_std_by_blocks.at(nb);
    rows.push_back({"block std of eta, " + std::to_string(nb) + " blocks of " +
                        num(np.spec.t_av / nb, 3) + " tau_0",
                    num(a, 3), num(b, 3), num(b / a, 3), ""});
  }
  rows.push_back({"packing fraction phi", pm3(np, "phi", 6), num(val(nv, "phi"), 6) + " (imposed)",
                  "", num(seed::kEnsemblePhi, 4)});
  rows.push_back({"block std of phi (mean over replicas)", num(np.phi_block_std_mean, 3),
                  "0 (imposed)", "", ""});
  rows.push_back({"std of phi over replicas (run means)", num(np.phi_spread, 3), "0 (imposed)", "",
                  "~3e-4 (NP, 3 runs)"});
  rows.push_back(
      {"pressure <P_hat>", pm3(np, "pressure", 4), pm3(nv, "pressure", 4), "", "1e-5 (NP)"});
  rows.push_back({"mu = <sigma_xy>/P", pm3(np, "mu", 4), pm3(nv, "mu", 4), "", ""});
  rows.push_back({"tau_sigma_xy / block length",
                  num(val(np, "tau_sigma_xy"), 3) + " / " + num(val(np, "block_length"), 3),
                  num(val(nv, "tau_sigma_xy"), 3) + " / " + num(val(nv, "block_length"), 3), "",
                  ""});
  return markdown_table({"quantity", "constant pressure (NP)", "constant volume (NV)",
                         "ratio NV/NP", "seed (Fig. 1)"},
                        rows);
}

// The runs of one ensemble as a stage of the study (studies/diagnostics.hpp run_stage): replica
// k starts from starts[k] with seed seed0 + k. Returns an exit status when the study stops here.
std::optional<int> run_ensemble_stage(const std::string& stage, const Preset& p,
                                      const std::string& scene,
                                      const std::vector<std::string>& starts, std::uint64_t seed0,
                                      const StudyOptions& options, std::vector<ReplicaResult>& runs,
                                      bool last, bool* counted_only = nullptr) {
  std::vector<RunRequest> requests;
  for (std::size_t k = 0; k < starts.size(); ++k) {
    RunRequest r;
    r.label = stage + " r" + std::to_string(k);
    r.scene = StudyScene(scene, p.integrator);
    r.seed = seed0 + k;
    r.init = starts[k];
    r.window = false;
    requests.push_back(std::move(r));
  }
  std::vector<DiagnosedRun> done;
  if (const auto status = run_stage("ensemble", stage, requests, options, done, last))
    return status;
  runs.clear();
  for (auto& d : done) {
    if (counted_only)
      *counted_only = d.final_xyz == kCountedStart;
    runs.push_back(std::move(d.result));
  }
  return std::nullopt;
}

// Writes a start state for a stage (rewritten with the same bytes on a rerun).
std::string write_start(const std::string& dir, std::size_t k, const State& s) {
  ensure_dir(dir);
  const std::string path = dir + "/r" + std::to_string(k) + ".xyz";
  write_xyz_file(path, s);
  return path;
}

int run_ensemble_study(const StudyOptions& options) {
  const Preset p = preset_of(options.preset);
  const auto wall0 = std::chrono::steady_clock::now();
  ensure_dir(options.out_dir);
  const std::uint64_t seed0 = 1;
  const double j = p.shear_rate / p.pressure;
  const double phi0 = phi_start(j, p.n);
  auto log = [&](const std::string& msg) {
    if (!options.quiet)
      std::fprintf(stderr, "[ensemble] %s\n", msg.c_str());
  };
  log("preset " + p.name + ": N = " + std::to_string(p.n) + ", P = " + fmt(p.pressure) +
      ", gdot = " + fmt(p.shear_rate) + " (J = " + num(j, 4) + "), " + std::to_string(p.replicas) +
      " replicas per ensemble; start phi = " + num(phi0, 4));

  // 1. Starting states: random at phi0, overlaps relaxed without shear (a fraction of a second:
  // computed here, and written as the constant-pressure stage's start files).
  std::vector<std::string> np_starts;
  for (std::size_t k = 0; k < std::size_t(p.replicas); ++k)
    np_starts.push_back(
        write_start(options.out_dir + "/np/starts", k, relaxed_start(p, phi0, seed0 + k)));

  // 2. Constant pressure from those states.
  EnsembleRuns np;
  np.name = "constant_pressure";
  np.spec =
      spec_from_toml(scene_toml(p, true, phi0, seed0), p.integrator, {}, "<ensemble study NP>");
  bool np_counted = false;
  if (const auto status = run_ensemble_stage("np", p, scene_toml(p, true, phi0, seed0), np_starts,
                                             seed0, options, np.runs, false, &np_counted))
    return *status;
  if (np_counted) {  // --dry-run: count the constant-volume stage at the start phi
    const std::vector<std::string> stand_ins(np_starts.size(), kCountedStart);
    std::vector<ReplicaResult> counted;
    const auto status = run_ensemble_stage("nv", p, scene_toml(p, false, phi0, seed0), stand_ins,
                                           seed0, options, counted, true);
    return status.value_or(0);
  }
  std::string why;
  if (!all_complete(np.runs, why)) {
    std::fprintf(stderr, "jamflow study ensemble: a constant-pressure run failed: %s\n",
                 why.c_str());
    return 1;
  }
  finish_ensemble(np);
  const double phi_nv = np.combined.values.at("phi");
  log("constant pressure reached phi = " + num(phi_nv, 6) + "; constant volume runs there");

  // 3. Constant volume at the phi the constant-pressure runs reached (mean over replicas of
  // the window means), each replica continuing from its constant-pressure final state
  // dilated affinely to that phi.
  EnsembleRuns nv;
  nv.name = "constant_volume";
  nv.spec =
      spec_from_toml(scene_toml(p, false, phi_nv, seed0), p.integrator, {}, "<ensemble study NV>");
  std::vector<std::string> nv_starts;
  for (std::size_t k = 0; k < np.runs.size(); ++k) {
    State s = np.runs[k].final_state;
    s.box.set_volume(s.particle_volume() / phi_nv);
    s.time = 0.0;
    nv_starts.push_back(write_start(options.out_dir + "/nv/starts", k, s));
  }
  if (const auto status = run_ensemble_stage("nv", p, scene_toml(p, false, phi_nv, seed0),
                                             nv_starts, seed0, options, nv.runs, true))
    return *status;
  if (!all_complete(nv.runs, why)) {
    std::fprintf(stderr, "jamflow study ensemble: a constant-volume run failed: %s\n", why.c_str());
    return 1;
  }
  finish_ensemble(nv);
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();

  // 4. Outputs: the standard run files, the study's HDF5, the table, the report, the plot.
  write_run_file(np.spec, np.runs, options.out_dir + "/constant_pressure.h5");
  write_run_file(nv.spec, nv.runs, options.out_dir + "/constant_volume.h5");
  const Ratio eta_ratio = eta_block_std_ratio(np, nv);
  const std::string h5 = options.out_dir + "/ensemble.h5";
  {
    H5Writer w(h5);
    w.attr("/", "study", "ensemble");
    w.attr("/", "preset", p.name);
    w.attr("/", "git_commit", git_commit());
    w.attr("/", "N", p.n);
    w.attr("/", "imposed_pressure", p.pressure);
    w.attr("/", "xi_V", p.xi_v);
    w.attr("/", "shear_rate", p.shear_rate);
    w.attr("/", "J", j);
    w.attr("/", "phi_start", phi0);
    w.attr("/", "phi_constant_volume", phi_nv);
    w.attr("/", "replicas", std::int64_t(p.replicas));
    w.attr("/", "t_eq", p.t_eq);
    w.attr("/", "t_eq_constant_volume", p.t_eq_nv);
    w.attr("/", "t_av", p.t_av);
    w.attr("/", "t_relax", p.t_relax);
    w.attr("/", "wall_seconds", wall);
    write_ensemble(w, np);
    write_ensemble(w, nv);
    w.group("/table");
    w.attr("/table", "eta_block_std_np", np.eta_block_std_mean);
    w.attr("/table", "eta_block_std_nv", nv.eta_block_std_mean);
    w.attr("/table", "eta_block_std_ratio_nv_over_np", eta_ratio.value);
    w.attr("/table", "eta_block_std_ratio_nv_over_np_err", eta_ratio.error);
    w.attr("/table", "phi_block_std_np", np.phi_block_std_mean);
    w.attr("/table", "phi_spread_np", np.phi_spread);
    w.attr("/table", "eta_np", np.combined.values.at("eta"));
    w.attr("/table", "eta_nv", nv.combined.values.at("eta"));
    w.attr("/table", "phi_np", np.combined.values.at("phi"));
    w.attr("/table", "pressure_np", np.combined.values.at("pressure"));
    w.attr("/table", "pressure_np_err", np.combined.values.at("pressure_err"));
    w.attr("/table", "seed_eta_block_std_ratio", seed::kEnsembleStdRatio);
    w.attr("/table", "seed_phi_spread", 3e-4);
    w.commit();
  }
  const std::string table = table_markdown(np, nv);
  write_text(options.out_dir + "/table.md", table);

  // Replicas that enter the comparison (the steady ones; all if none is).
  const auto used = [](const EnsembleRuns& e) {
    return e.none_steady ? e.runs.size() : e.runs.size() - e.excluded.size();
  };
  const std::string used_text = std::to_string(p.replicas) +
                                " replicas run per ensemble; the comparison uses " +
                                std::to_string(used(np)) + " at constant pressure and " +
                                std::to_string(used(nv)) + " at constant volume (the verdicts)";
  // The seed's ratio was measured at J = 3.98e-9 / 1e-5: a difference in sigma means something
  // only at that state point.
  const double seed_j = seed::kEnsembleRate / seed::kEnsemblePressure;
  const bool seed_point = std::abs(j / seed_j - 1.0) < 0.05;
  std::ostringstream rep;
  rep << "# Ensemble comparison (preset `" << p.name << "`)\n\n"
      << "The seed's Fig. 1 comparison: N = " << p.n << ", gdot = " << fmt(p.shear_rate)
      << ", constant pressure P = " << fmt(p.pressure) << " (xi_V = " << fmt(p.xi_v)
      << ") against constant volume at the phi the constant-pressure runs reached ("
      << num(phi_nv, 6) << "), " << used_text << ", J = gdot/P = " << num(j, 4) << ".\n\n"
      << "Protocol: random states at phi = " << num(phi0, 4)
      << " (the seed's hard-sphere fit at this J and N), overlaps relaxed for " << fmt(p.t_relax)
      << " tau_0 at constant volume without shear; then constant pressure for t_eq = "
      << fmt(p.t_eq) << " + t_av = " << fmt(p.t_av)
      << "; then each replica continues from its constant-pressure final state, dilated to the"
         " mean phi, at constant volume for t_eq = "
      << fmt(p.t_eq_nv) << " + t_av = " << fmt(p.t_av)
      << ". Integrator: explicit Euler, dt = 0.3 (see studies/ensemble/README.md). 20 blocks over"
         " t_av.\n\n"
      << table << "\n"
      << "Seed (N = 1000, gdot = " << fmt(seed::kEnsembleRate) << ", J = " << num(seed_j, 3)
      << "): block std of the viscosity ~" << fmt(seed::kEnsembleStdRatio)
      << "x smaller at constant pressure; std of phi over three runs ~"
      << fmt(seed::kEnsemblePhiSpread) << ".\n\n"
      << "Here: block std of eta NV/NP = " << pm(eta_ratio.value, eta_ratio.error)
      << (eta_ratio.error > 0.0 && seed_point
              ? " (" + sigma_text(eta_ratio.value, eta_ratio.error, seed::kEnsembleStdRatio) +
                    " from the seed's " + fmt(seed::kEnsembleStdRatio) + ")"
          : seed_point ? std::string()
                       : " (not compared with the seed's ~" + fmt(seed::kEnsembleStdRatio) +
                             " in sigma: that was measured at J = " + num(seed_j, 3) +
                             ", this is J = " + num(j, 3) + ", another state point)")
      << "; std of phi over replicas (NP) = " << num(np.phi_spread, 3) << ".\n\n";
  rep << "## Verdicts\n\n";
  for (const EnsembleRuns* e : {&np, &nv}) {
    if (e->excluded.empty()) {
      rep << "- " << e->name << ": every replica is steady (no trend of phi, sigma_xy, P_hat "
          << "across the blocks).\n";
      continue;
    }
    rep << "- " << e->name << ": "
        << (e->none_steady ? "**Warning**: no replica is steady, so all are kept and the "
                             "comparison above is not a conclusion. "
                           : "left out of the comparison above as not steady: ");
    for (std::size_t k = 0; k < e->excluded.size(); ++k)
      rep << (k ? "; " : "") << e->excluded[k];
    rep << ".\n";
  }
  {
    // Blocks shorter than 2 tau (the decorrelated verdict): with several replicas the point is
    // kept and its error is the larger of the block error and the replica scatter (the rule of
    // the sweep's collect); a single replica would be left out.
    std::string short_blocks;
    for (const EnsembleRuns* e : {&np, &nv}) {
      for (std::size_t k = 0; k < e->runs.size(); ++k) {
        const auto it = e->runs[k].summary.verdicts.find("decorrelated");
        if (it != e->runs[k].summary.verdicts.end() && it->second.failed())
          short_blocks += std::string(short_blocks.empty() ? "" : ", ") + e->name + " replica " +
                          std::to_string(k);
      }
    }
    rep << "- decorrelated: "
        << (short_blocks.empty()
                ? std::string("every replica's blocks are at least 2 tau long.")
                : "blocks shorter than 2 tau in " + short_blocks + "; kept (" + used_text +
                      "): read the larger of the block and the replica-scatter error in the "
                      "table (a single replica would be left out)" +
                      (std::min(used(np), used(nv)) < 3
                           ? std::string("; with fewer than 3 replicas the replica scatter is "
                                         "itself poorly known, so those errors are rough.")
                           : std::string(".")))
        << "\n";
  }
  rep << "\n";
  rep << "## Correlation times and block length\n\n"
      << "Integrated autocorrelation times (tau_0) over the replicas, against the block length "
         "t_av / 20; block errors are trustworthy when a block spans at least 2 tau.\n\n";
  for (const EnsembleRuns* e : {&np, &nv}) {
    rep << "- " << e->name << ":";
    std::string short_blocks;
    for (const char* obs : {"sigma_xy", "pressure", "phi"}) {
      double lo = 0, hi = 0;
      for (std::size_t k = 0; k < e->runs.size(); ++k) {
        const double tau = e->runs[k].summary.values.at(std::string("tau_") + obs);
        lo = k == 0 ? tau : std::min(lo, tau);
        hi = k == 0 ? tau : std::max(hi, tau);
      }
      if (e == &nv && std::string(obs) == "phi")
        continue;  // imposed
      rep << " tau_" << obs << " = " << num(lo, 3) << " - " << num(hi, 3) << ";";
      if (e->combined.values.at("block_length") < 2.0 * hi)
        short_blocks += std::string(short_blocks.empty() ? "" : ", ") + obs;
    }
    rep << " block length " << num(e->combined.values.at("block_length"), 3) << ".";
    if (!short_blocks.empty()) {
      rep << " **Warning**: blocks shorter than 2 tau for " << short_blocks
          << " in some replicas: their block errors are underestimated (the replica-scatter "
             "errors are not).";
    }
    rep << "\n";
  }
  rep << "\n";
  rep << "Wall time: " << num(wall, 4)
      << " s (the runs are `jamflow run` processes of the sweep engine, one per core).\n";
  write_text(options.out_dir + "/report.md", rep.str());
  run_plot("ensemble/plot.py", {h5, options.out_dir + "/timeseries.png"}, options);

  if (!options.quiet) {
    std::printf(
        "ensemble study (%s): %s\n%s\nblock std of eta NV/NP = %s (seed ~5); std of phi "
        "over replicas (NP) = %s (seed ~3e-4); wall %.1f s\n",
        p.name.c_str(), options.out_dir.c_str(), table.c_str(),
        pm(eta_ratio.value, eta_ratio.error).c_str(), num(np.phi_spread, 3).c_str(), wall);
  }
  return 0;
}

const Registrar registrar{
    {"ensemble",
     "constant pressure vs constant volume at the same shear rate (the seed's Fig. 1): block "
     "std of the viscosity and of phi in each ensemble",
     run_ensemble_study}};

}  // namespace
}  // namespace jamflow::studies
