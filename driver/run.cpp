// The run driver: scene -> state -> time loop with sampling -> summary -> HDF5 + XYZ.
#include "driver/run.hpp"

#include <time.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <stdexcept>
#include <thread>

#include "driver/checkpoint.hpp"
#include "driver/verdicts.hpp"
#include "integrators/registry.hpp"
#include "lib/cpu_clock.hpp"
#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "lib/h5md.hpp"
#include "lib/init.hpp"
#include "lib/progress.hpp"
#include "lib/statistics.hpp"
#include "lib/version.hpp"
#include "lib/xyz.hpp"

#ifndef JAMFLOW_VERSION
#define JAMFLOW_VERSION "unknown"
#endif

namespace jamflow {

const char* const kDefaultScene =
    R"(# jamflow default scene: harmonic soft spheres sheared at constant volume.
[system]
N = 1000          # particles, equimolar mixture of diameters 1 and 1.4
phi = 0.62        # packing fraction
alpha = 2.0       # pair exponent alpha_r (2 = harmonic)
seed = 1

[ensemble]
kind = "constant_volume"

[shear]
rate = 1e-3       # gdot in 1/tau_0

[integrator]
kind = "euler"
dt = 0.1          # tau_0; dt >= 0.4 oscillates for explicit Euler (SPEC section 4)

[run]
t_eq = 1000.0     # equilibration (not averaged)
t_av = 10000.0    # averaging window: 20 blocks of 500, several correlation times each
sample_every = 1.0
blocks = 20

[output]
file = "jamflow.h5"
)";

namespace {

std::string stem_of(const std::string& path) {
  const std::string ext = ".h5";
  if (path.size() > ext.size() && path.compare(path.size() - ext.size(), ext.size(), ext) == 0) {
    return path.substr(0, path.size() - ext.size());
  }
  return path;
}

std::string replica_suffix(std::size_t k, std::size_t count) {
  return count > 1 ? ".r" + std::to_string(k) : "";
}

std::string iso_now() {
  const std::time_t t = std::time(nullptr);
  char buf[64];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

// Limits a scene is checked against before it runs (README "Limits").
constexpr double kMaxSteps = 1e12;
constexpr double kMaxParticleSteps = 1e15;  // about 230 days at 20 ns per particle-step
constexpr double kMaxSamples = 1e9;
// The cell's tilt is the strain less whole remaps: past 1e9 its round-off exceeds 1e-7 cell
// lengths, and the Lees–Edwards images drift apart step by step.
constexpr double kMaxStrain = 1e9;
constexpr std::int64_t kMaxForceEvaluations = 1000000000000000;  // 1e15
constexpr double kBytesPerSample = 3.0 * sizeof(Sample);         // the series, its copies at output
// Measured: the peak resident size grows by 740 bytes per particle from N = 1e5 to 4e5 (lists,
// checkpoint copies and output included); rounded up for margin.
constexpr double kBytesPerParticle = 1000.0;

// A number for a one-line message: 6 significant digits.
std::string short_num(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", v);
  return text;
}

// The longest a run of this spec may go: with t_eq = "auto" the transient is searched within the
// first half of the run, so at most 2 t_av.
double run_length_bound(const RunSpec& spec) {
  if (spec.auto_av)
    return spec.max_time;
  return spec.auto_eq ? 2.0 * spec.t_av : spec.t_eq + spec.t_av;
}

double physical_memory_bytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), size = ::sysconf(_SC_PAGE_SIZE);
  return pages > 0 && size > 0 ? double(pages) * double(size) : 0.0;
}

}  // namespace

std::unique_ptr<Integrator> RunSpec::make_integrator() const {
  return jamflow::make_integrator(integrator);
}

RunSpec parse_run_spec(const Scene& scene, const IntegratorSettings& integrator) {
  if (scene.has_section("integrator")) {
    throw ConfigError("[integrator] is given twice: in " + scene.source() +
                      " and as typed settings; allowed one of them");
  }
  Scene with = scene;
  with.set_section("integrator", integrator.table());
  return parse_run_spec(with);
}

RunSpec parse_run_spec(const Scene& scene) {
  scene.check_sections({"system", "ensemble", "shear", "integrator", "run", "output"});
  for (const char* required : {"system", "ensemble", "shear", "integrator", "run"}) {
    if (!scene.has_section(required)) {
      throw ConfigError(std::string("missing section [") + required + "] in " + scene.source());
    }
  }
  RunSpec spec;
  spec.scene_text = scene.text();

  ConfigSection sys = scene.section("system");
  spec.init = sys.text("init", "");
  const Range phi_range{0.0, 0.95, true, false};
  if (spec.init.empty()) {
    spec.n = sys.integer("N", 2, NeighbourList::kMaxParticles);
    spec.phi = sys.number("phi", phi_range);
  } else {
    State s = read_xyz(spec.init);
    spec.n = static_cast<std::int64_t>(s.size());
    spec.phi = s.packing_fraction();
    if (sys.has("N")) {
      const std::int64_t n = sys.integer("N", 2, NeighbourList::kMaxParticles);
      if (n != spec.n) {
        throw ConfigError("[system] N = " + std::to_string(n) + " disagrees with init '" +
                          spec.init + "' (" + std::to_string(spec.n) + " particles)");
      }
    }
    if (sys.has("phi")) {
      const double phi = sys.number("phi", phi_range);
      if (std::abs(phi - spec.phi) > 1e-6) {
        throw ConfigError("[system] phi = " + fmt(phi) + " disagrees with init '" + spec.init +
                          "' (phi = " + fmt(spec.phi) + "); allowed within 1e-6 of it");
      }
    }
    spec.init_state = std::move(s);
  }
  spec.alpha = sys.number("alpha", 2.0, Range{kAlphaMin, kAlphaMax});
  spec.seed = static_cast<std::uint64_t>(
      sys.integer("seed", 1, 0, std::numeric_limits<std::int64_t>::max()));
  spec.skin = sys.number("skin", 0.3, Range{0.01, 2.0});
  sys.finish();

  ConfigSection shear = scene.section("shear");
  spec.shear_rate = shear.number("rate", Range::non_negative());
  shear.finish();

  ConfigSection ens = scene.section("ensemble");
  spec.ensemble = make_ensemble(ens, spec.shear_rate);

  // The TOML path converts [integrator] into the same typed settings a study hands over;
  // full validation (kind-specific keys) happens in the factory.
  spec.integrator = IntegratorSettings::from_table(*scene.table("integrator"));
  (void)spec.make_integrator();

  ConfigSection run = scene.section("run");
  const std::optional<double> t_eq = run.number_or_auto("t_eq", Range::non_negative());
  const std::optional<double> t_av = run.number_or_auto("t_av", Range::positive());
  spec.auto_eq = !t_eq;
  spec.auto_av = !t_av;
  spec.t_eq = t_eq.value_or(0.0);
  spec.t_av = t_av.value_or(0.0);
  spec.sample_every = run.number("sample_every", Range::positive());
  spec.blocks = run.integer("blocks", 20, 2, 100000);
  spec.replicas = run.integer("replicas", 1, 1, 10000);
  // One thread unless asked: runs side by side (studies, sweeps, several users) then never
  // compete for cores; see README "Threads".
  spec.threads = static_cast<int>(run.integer("threads", 1, 0, 1024));
  spec.max_force_evaluations = run.integer("max_force_evaluations", 0, 0, kMaxForceEvaluations);
  const bool round_sampling = run.flag("round_sample_every", false);
  if (spec.auto_av) {
    spec.target_error = run.number("target_error", Range{0.0, 1.0, false, false});
    spec.max_time = run.number("max_time", Range::positive());
  } else {
    for (const char* key : {"target_error", "max_time"}) {
      if (run.has(key))
        throw ConfigError(run.label(key) +
                          " is used only with [run] t_av = \"auto\"; allowed "
                          "without it");
    }
  }
  run.finish();
  if (spec.auto_av) {
    // The first window: 4 samples per block, or 1/32 of the budget; then it grows.
    const double budget = spec.max_time - spec.t_eq;
    spec.t_av =
        std::min(budget, std::max(4.0 * double(spec.blocks) * spec.sample_every, budget / 32.0));
    if (!(spec.t_av >= double(spec.blocks) * spec.sample_every)) {
      throw ConfigError("[run] max_time = " + fmt(spec.max_time) +
                        " leaves less than blocks * "
                        "sample_every = " +
                        fmt(double(spec.blocks) * spec.sample_every) + " after t_eq; allowed more");
    }
  }
  // dt is never changed: sampling lands on whole steps, or (asked for) sample_every is rounded
  // to the nearest whole number of steps, and the stored scene says so.
  if (const double dt = spec.make_integrator()->nominal_dt(); dt > 0.0) {
    const double ratio = spec.sample_every / dt;
    const double whole = std::max(1.0, std::round(ratio));
    if (std::abs(ratio - whole) > 1e-9 * whole) {
      if (!round_sampling) {
        throw ConfigError("[run] sample_every = " + fmt(spec.sample_every) +
                          " is not a whole number of [integrator] dt = " + fmt(dt) + " (" +
                          short_num(ratio) + " steps); allowed multiples of dt, such as " +
                          short_num(whole * dt) + ", or set [run] round_sample_every = true");
      }
      spec.sample_every = whole * dt;
      Scene rounded = scene;
      char text[64];
      std::snprintf(text, sizeof text, "run.sample_every=%.17g", spec.sample_every);
      rounded.set(text);
      spec.scene_text = rounded.text();
    }
    // Steps up front: a run that cannot end is refused before it starts.
    const double steps = run_length_bound(spec) / dt;
    if (!(steps <= kMaxSteps)) {
      throw ConfigError("[integrator] dt = " + fmt(dt) + " makes " + short_num(steps) +
                        " steps of (t_eq + t_av) = " + fmt(run_length_bound(spec)) +
                        "; allowed at most " + fmt(kMaxSteps) + " steps per replica");
    }
    if (!(steps * double(spec.n) <= kMaxParticleSteps)) {
      throw ConfigError("[system] N = " + std::to_string(spec.n) + " for " + short_num(steps) +
                        " steps is " + short_num(steps * double(spec.n)) +
                        " particle-steps (about " +
                        fmt(std::round(steps * double(spec.n) * 20e-9 / 86400.0)) +
                        " days on one core); allowed at most " + fmt(kMaxParticleSteps));
    }
  }
  if (const double strain = spec.shear_rate * run_length_bound(spec); !(strain <= kMaxStrain)) {
    throw ConfigError("[shear] rate = " + fmt(spec.shear_rate) + " shears the cell by " +
                      short_num(strain) + " over (t_eq + t_av) = " + fmt(run_length_bound(spec)) +
                      "; allowed a strain of at most " + fmt(kMaxStrain) + " per replica");
  }
  // Memory up front: the samples and the particles (measured per particle, with the
  // checkpoint's copy) against what the machine has.
  {
    const double samples = run_length_bound(spec) / spec.sample_every + 1.0;
    const double bytes = samples * kBytesPerSample + double(spec.n) * kBytesPerParticle;
    const double have = physical_memory_bytes();
    if (!(samples <= kMaxSamples) || (have > 0.0 && !(bytes <= have))) {
      char text[320];
      std::snprintf(text, sizeof text,
                    "[run] (t_eq + t_av) / sample_every = %.3g samples and [system] N = %lld "
                    "need about %.3g GB of memory; this machine has %.3g GB (allowed at most "
                    "%.3g samples)",
                    samples, (long long)spec.n, bytes / 1e9, have / 1e9, kMaxSamples);
      throw ConfigError(text);
    }
  }
  const double window_samples = std::floor(spec.t_av / spec.sample_every + 1e-9);
  if (window_samples < double(spec.blocks)) {
    throw ConfigError("[run] t_av / sample_every = " + fmt(window_samples) +
                      " samples is fewer than [run] blocks = " + std::to_string(spec.blocks) +
                      "; allowed t_av >= blocks * sample_every");
  }

  ConfigSection out = scene.section("output");
  spec.file = out.text("file", "jamflow.h5");
  spec.trajectory_every = out.number("trajectory_every", 0.0, Range::non_negative());
  spec.checkpoint_every = out.number("checkpoint_every", 600.0, Range{1e-3, 1e9});
  spec.trajectory_format = out.choice("trajectory_format", "xyz", {"xyz", "h5md", "both"});
  out.finish();
  if (spec.trajectory_every > 0.0) {
    const double ratio = spec.trajectory_every / spec.sample_every;
    if (std::abs(ratio - std::round(ratio)) > 1e-9 * ratio) {
      throw ConfigError("[output] trajectory_every = " + fmt(spec.trajectory_every) +
                        " must be a multiple of [run] sample_every = " + fmt(spec.sample_every));
    }
  }
  return spec;
}

std::vector<double> Series::column(double Sample::*field) const {
  std::vector<double> v;
  v.reserve(samples.size());
  for (const auto& s : samples)
    v.push_back(s.*field);
  return v;
}

bool stopped_by_budget(const std::string& status) {
  return status.rfind("budget", 0) == 0;
}

bool finished_status(const std::string& status) {
  return status == "complete" || stopped_by_budget(status);
}

bool Summary::failed() const {
  for (const auto& [name, text] : verdicts)
    if (text.rfind("fail", 0) == 0)
      return true;
  return false;
}

Summary summarize(const RunSpec& spec, const Series& series, const StepPairs* steps) {
  Summary sum;
  auto& out = sum.values;
  std::vector<Sample> win;
  const double t0 = spec.t_eq - 1e-9 * spec.sample_every;
  for (const auto& s : series.samples) {
    if (s.time >= t0)
      win.push_back(s);
  }
  // The t = t_eq sample closes equilibration; averages use the samples after it.
  if (!win.empty() && std::abs(win.front().time - spec.t_eq) < 1e-9 * spec.sample_every &&
      spec.t_eq > 0.0) {
    win.erase(win.begin());
  }
  const std::size_t nb = static_cast<std::size_t>(spec.blocks);
  if (win.size() < nb) {
    throw IntegrationError(
        "only " + std::to_string(win.size()) +
        " samples in the averaging window, fewer than blocks = " + std::to_string(nb));
  }
  Series w{win};
  const auto sigma = w.column(&Sample::sigma_xy);
  const auto press = w.column(&Sample::pressure);
  const auto phi = w.column(&Sample::phi);
  const auto energy = w.column(&Sample::energy);
  const double gdot = spec.shear_rate;
  std::vector<double> work(win.size()), loss(win.size());
  for (std::size_t k = 0; k < win.size(); ++k) {
    work[k] = win[k].sigma_xy * gdot * win[k].volume;
    loss[k] = win[k].dissipation + win[k].piston_dissipation;
  }
  const BlockAverage bs = block_average(sigma, nb);
  const BlockAverage bp = block_average(press, nb);
  const BlockAverage bphi = block_average(phi, nb);
  const BlockAverage be = block_average(energy, nb);
  const BlockAverage bw = block_average(work, nb);
  const BlockAverage bl = block_average(loss, nb);
  out["sigma_xy"] = bs.mean;
  out["sigma_xy_err"] = bs.error;
  out["pressure"] = bp.mean;
  out["pressure_err"] = bp.error;
  out["phi"] = bphi.mean;
  out["phi_err"] = bphi.error;
  out["phi_block_std"] = bphi.block_std;
  out["energy"] = be.mean;
  out["energy_err"] = be.error;
  out["dissipation"] = bl.mean;
  out["energy_balance"] =
      bl.mean > 0.0 ? bw.mean / bl.mean : std::numeric_limits<double>::quiet_NaN();
  out["samples"] = double(win.size());
  out["block_length"] = double(win.size() / nb) * spec.sample_every;

  const std::optional<double> imposed = spec.ensemble->imposed_pressure();
  // mu = sigma / P: with the imposed P at constant pressure, else the block ratio.
  std::vector<double> mu_blocks(nb);
  for (std::size_t b = 0; b < nb; ++b) {
    mu_blocks[b] = bs.blocks[b] / (imposed ? *imposed : bp.blocks[b]);
  }
  const BlockAverage bmu = block_average(mu_blocks, nb);
  out["mu"] = imposed ? bs.mean / *imposed : bs.mean / bp.mean;
  out["mu_err"] = bmu.error;
  const double p_ref = imposed ? *imposed : bp.mean;
  if (gdot > 0.0) {
    out["eta"] = bs.mean / gdot;
    out["eta_err"] = bs.error / gdot;
    out["eta_block_std"] = bs.block_std / gdot;
    out["J"] = gdot / p_ref;  // J = gdot eta_0 / P with eta_0 = xi_s / a = 1
  }
  // Integrated autocorrelation times (in time units) of the main observables. Block errors
  // are only trustworthy when a block spans at least about 2 of them. A constant series (phi
  // at constant volume) has tau = half a sample and never warns.
  const std::pair<const char*, const std::vector<double>*> correlated[] = {
      {"sigma_xy", &sigma}, {"pressure", &press}, {"phi", &phi}};
  const VerdictThresholds limits;
  std::string too_short;
  for (const auto& [name, series_ptr] : correlated) {
    const double tau = integrated_autocorrelation(*series_ptr) * spec.sample_every;
    out[std::string("tau_") + name] = tau;
    if (!std::isfinite(tau) && too_short.empty()) {
      too_short = std::string("tau_") + name + " = " + short_num(tau) + " not finite";
    } else if (!(out["block_length"] >= limits.decorrelation_blocks * tau) && too_short.empty()) {
      // How much too small the block errors are, for correlations that decay exponentially
      // (more if slower).
      const double low = 1.0 - block_error_ratio(out["block_length"], tau);
      char text[240];
      std::snprintf(text, sizeof text,
                    "blocks of %.4g are shorter than %g tau_%s = %.4g, so block errors are "
                    "about %.0f%% too small (more if correlations decay slower than "
                    "exponentially)",
                    out["block_length"], limits.decorrelation_blocks, name,
                    limits.decorrelation_blocks * tau, 100.0 * low);
      too_short = text;
    }
  }
  auto verdict = [&](const std::string& name, bool pass, const std::string& why) {
    sum.verdicts[name] = pass ? "pass" : "fail: " + why;
    out[name] = pass ? 1.0 : 0.0;
  };
  // A value that is not a number (0 / 0 with no contacts, say) fails the verdict that rests on
  // it: NaN would pass every test written as !(x > limit).
  const auto not_finite = [&](std::initializer_list<const char*> keys) {
    std::string bad;
    for (const char* key : keys) {
      const auto it = out.find(key);
      if (it != out.end() && !std::isfinite(it->second))
        bad += (bad.empty() ? "" : ", ") + std::string(key) + " = " + short_num(it->second);
    }
    return bad.empty() ? bad : bad + " not finite";
  };
  // decorrelated: every block at least 2 tau long.
  const bool undefined_tau = too_short.find(" not finite") != std::string::npos;
  verdict("decorrelated", too_short.empty(), too_short + (undefined_tau ? "" : "; lengthen t_av"));

  // steady: no significant trend of the block means.
  std::string drift;
  double worst = 0.0;
  for (const auto& [name, b] : {std::pair<const char*, const BlockAverage*>{"phi", &bphi},
                                {"sigma_xy", &bs},
                                {"pressure", &bp}}) {
    const double t = trend_t(b->blocks);
    out[std::string("trend_t_") + name] = t;
    if (std::abs(t) > worst || !std::isfinite(t)) {
      worst = std::isfinite(t) ? std::abs(t) : std::numeric_limits<double>::infinity();
      if (!(std::abs(t) <= limits.trend_t_max)) {
        char text[200];
        std::snprintf(text, sizeof text,
                      "%s drifts from %.6g (first block) to %.6g (last), trend t = %.3g over "
                      "%zu blocks (allowed |t| <= %g)",
                      name, b->blocks.front(), b->blocks.back(), t, nb, limits.trend_t_max);
        drift = text;
      }
    }
  }
  if (const std::string bad = not_finite({"sigma_xy", "sigma_xy_err", "pressure", "pressure_err",
                                          "phi", "phi_err", "eta", "eta_err", "mu", "mu_err", "J"});
      drift.empty() && !bad.empty())
    verdict("steady", false, bad);
  else
    verdict("steady", drift.empty(), drift + "; lengthen t_eq");

  // stable: energy balance and no step-to-step oscillation of the forces.
  const EnergyBalance eb = energy_balance(series.samples, spec.t_eq, gdot, imposed, nb);
  out["energy_balance_corrected"] = eb.ratio;
  out["energy_balance_err"] = eb.error;
  std::string unstable, unchecked;
  if (gdot > 0.0 && !std::isfinite(out["energy_balance"])) {
    char text[200];
    std::snprintf(text, sizeof text,
                  "energy balance = %s not finite (work %.4g / dissipation %.4g)",
                  short_num(out["energy_balance"]).c_str(), bw.mean, bl.mean);
    unstable = text;
  } else if (eb.valid) {
    const double allowed = std::max(limits.balance_tolerance, limits.balance_sigmas * eb.error);
    if (eb.residual > allowed) {
      char text[200];
      std::snprintf(text, sizeof text,
                    "energy balance %.4g +- %.2g (work / dissipation, enthalpy drift removed); "
                    "allowed within %.3g of 1",
                    eb.ratio, eb.error, allowed);
      unstable = text;
    }
  } else {
    unchecked = gdot > 0.0 ? "energy balance not available" : "no shear: no energy balance";
  }
  if (steps && steps->pairs > 0) {
    out["force_step_correlation"] = steps->correlation();
    if (!(steps->correlation() >= limits.force_correlation_min) && unstable.empty()) {
      char text[200];
      std::snprintf(text, sizeof text,
                    "forces at consecutive steps correlate %.3g (period-2 share of the force "
                    "power %.1f%%); allowed >= %g: lower dt",
                    steps->correlation(), 50.0 * (1.0 - steps->correlation()),
                    limits.force_correlation_min);
      unstable = text;
    }
  } else if (!unchecked.empty()) {
    unchecked += "; adaptive integrator: no step-to-step test";
  }
  if (!unstable.empty()) {
    verdict("stable", false, unstable);
  } else if (!unchecked.empty() && !(steps && steps->pairs > 0)) {
    sum.verdicts["stable"] = "not checked: " + unchecked;
    out["stable"] = std::numeric_limits<double>::quiet_NaN();
  } else {
    verdict("stable", true, "");
  }
  for (const auto& [name, text] : sum.verdicts) {
    if (text.rfind("fail", 0) == 0)
      sum.warnings.push_back("not " + name + ": " + text.substr(6));
  }
  return sum;
}

Summary combine_replicas(const std::vector<Summary>& summaries) {
  if (summaries.empty())
    throw std::invalid_argument("combine_replicas: no replicas");
  const auto k = summaries.size();
  auto ends_with = [](const std::string& s, const std::string& tail) {
    return s.size() > tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
  };
  Summary out;
  for (const auto& [name, first] : summaries.front().values) {
    (void)first;
    if (ends_with(name, "_err"))
      continue;  // handled with its observable
    std::vector<double> means, errors;
    bool everywhere = true;
    for (const auto& s : summaries) {
      const auto it = s.values.find(name);
      if (it == s.values.end()) {
        everywhere = false;
        break;
      }
      means.push_back(it->second);
      const auto e = s.values.find(name + "_err");
      errors.push_back(e == s.values.end() ? 0.0 : e->second);
    }
    if (!everywhere)
      continue;
    const ReplicaAverage ra = replica_average(means, errors);
    out.values[name] = ra.mean;
    if (summaries.front().values.count(name + "_err")) {
      out.values[name + "_err"] = ra.block_error;
      out.values[name + "_replica_err"] = ra.replica_error;
    }
  }
  out.values["replicas"] = double(k);
  // A verdict of the replicas passes only if it passes for each of them.
  for (const auto& [name, text] : summaries.front().verdicts) {
    (void)text;
    std::string combined = "pass";
    double value = 1.0;
    for (std::size_t r = 0; r < k; ++r) {
      const auto it = summaries[r].verdicts.find(name);
      const std::string v = it == summaries[r].verdicts.end() ? "not checked" : it->second;
      if (v.rfind("fail", 0) == 0) {
        combined = "fail: replica " + std::to_string(r) + ": " + v.substr(6);
        value = 0.0;
        break;
      }
      if (v != "pass" && combined == "pass") {
        combined = v;
        value = std::numeric_limits<double>::quiet_NaN();
      }
    }
    out.verdicts[name] = combined;
    out.values[name] = value;
  }
  for (std::size_t r = 0; r < k; ++r) {
    for (const auto& w : summaries[r].warnings)
      out.warnings.push_back("replica " + std::to_string(r) + ": " + w);
  }
  return out;
}

State initial_state(const RunSpec& spec, std::uint64_t seed) {
  if (spec.init_state)
    return *spec.init_state;
  return random_state(static_cast<std::size_t>(spec.n), spec.phi, seed);
}

namespace {

std::string signal_name(int sig) {
  switch (sig) {
    case SIGTERM:
      return "SIGTERM";
    case SIGINT:
      return "SIGINT";
    case SIGHUP:
      return "SIGHUP";
    default:
      return "signal " + std::to_string(sig);
  }
}

// Raises `attention` (which the integrator polls between steps) when the run must look up
// from its loop: a stop request, a signal, a checkpoint request, or a checkpoint due by the
// clock. Polls every 10 ms from a thread of its own.
class Watcher {
 public:
  Watcher(const RunOptions& options, std::atomic<bool>& attention)
      : options_(options), attention_(attention) {
    const bool timed = bool(options.checkpoint) && options.checkpoint_every > 0.0;
    if (!options.stop && !options.control && !timed)
      return;
    if (raised())
      attention_.store(true);  // already set before the run began
    thread_ = std::jthread([this, timed](std::stop_token token) {
      auto next = std::chrono::steady_clock::now() +
                  std::chrono::duration<double>(options_.checkpoint_every);
      while (!token.stop_requested()) {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
        bool raise = raised();
        if (timed && std::chrono::steady_clock::now() >= next) {
          timer_due_.store(true);
          next = std::chrono::steady_clock::now() +
                 std::chrono::duration<double>(options_.checkpoint_every);
          raise = true;
        }
        if (raise)
          attention_.store(true);
      }
    });
  }
  bool take_timer() { return timer_due_.exchange(false); }

 private:
  bool raised() const {
    return (options_.stop && options_.stop->load()) ||
           (options_.control &&
            (options_.control->signal.load() != 0 || options_.control->checkpoint.load()));
  }
  const RunOptions& options_;
  std::atomic<bool>& attention_;
  std::atomic<bool> timer_due_{false};
  std::jthread thread_;
};

}  // namespace

namespace {

// CPU seconds for run_replica. With one thread, the run's own thread's CPU time
// (CLOCK_THREAD_CPUTIME_ID): every force pass, integrator step and checkpoint write of the
// replica happens in it, and other threads of the process are not counted: the Watcher above,
// the Python module's thread that polls for signals while a run goes on in another thread, and
// other Python threads or runs of other replicas that a caller might start in the same process.
// With OpenMP threads the force passes are spread over a team, so the whole process's CPU time
// (CLOCK_PROCESS_CPUTIME_ID) is taken instead: it counts the team, and would also count
// anything else the process does meanwhile (a `jamflow run` does nothing else, and the sweep
// engine and the studies start one `jamflow run` process per point). lib/cpu_clock.hpp.

// How long a run goes, decided from its samples so far (so a continued run decides the same).
struct Length {
  bool done = false;
  double t_eq = 0.0;     // the transient's end (given, or found)
  double horizon = 0.0;  // the time to reach before deciding again
  std::string why, method;
};

Length decide_length(const RunSpec& spec, const Series& series, const StepPairs* steps) {
  Length len;
  const double eps = 1e-9 * spec.sample_every;
  const double t = series.samples.back().time;
  len.t_eq = spec.t_eq;
  len.method = "given";
  if (spec.auto_eq) {
    std::size_t drop = 0;
    for (double Sample::*field : {&Sample::sigma_xy, &Sample::pressure, &Sample::phi})
      drop = std::max(drop, mser_truncation(series.column(field)));
    drop = std::min(drop, series.samples.size() - 1);
    len.t_eq = series.samples[drop].time;
    len.method =
        "MSER-5 (marginal standard error rule on batch means of 5 samples) of sigma_xy, "
        "P_hat and phi; the latest of their truncation points";
  }
  if (!spec.auto_av) {
    len.horizon = len.t_eq + spec.t_av;
    if (spec.auto_eq)
      len.horizon = std::min(len.horizon, run_length_bound(spec));
    len.done = t >= len.horizon - eps;
    len.why =
        spec.auto_eq ? "t_av = " + fmt(spec.t_av) + " after the transient" : "t_eq + t_av as given";
    return len;
  }
  const double window = t - len.t_eq;
  const double least = 4.0 * double(spec.blocks) * spec.sample_every;
  if (window < least - eps) {
    len.horizon = std::min(spec.max_time, len.t_eq + least);
    len.done = t >= spec.max_time - eps;
    len.why = "max_time reached before the window held 4 samples per block";
    return len;
  }
  RunSpec eff = spec;
  eff.t_eq = len.t_eq;
  const Summary sum = summarize(eff, series, steps);
  const bool sheared = spec.shear_rate > 0.0;
  const std::string name = !sheared ? "pressure" : spec.ensemble->imposed_pressure() ? "mu" : "eta";
  const double value = sum.values.at(name), err = sum.values.at(name + "_err");
  const double rel = std::abs(err / value);
  const bool decorrelated = sum.verdicts.at("decorrelated") == "pass";
  char what[200];
  std::snprintf(what, sizeof what, "relative error of %s %.3g %s target_error %g%s at t_av = %g",
                name.c_str(), rel, rel <= spec.target_error ? "<=" : ">", spec.target_error,
                decorrelated ? "" : " (blocks shorter than 2 tau)", window);
  if (rel <= spec.target_error && decorrelated) {
    len.done = true;
    len.why = std::string("target reached: ") + what;
  } else if (t >= spec.max_time - eps) {
    len.done = true;
    len.why = std::string("max_time reached: ") + what;
  } else {
    // The block error falls as 1 / sqrt(window): aim for the target, growing by 1.5x to 4x.
    const double ratio = rel / spec.target_error;
    const double grow = std::clamp(std::isfinite(ratio) ? ratio * ratio : 4.0, 1.5, 4.0);
    len.horizon = std::min(spec.max_time, len.t_eq + grow * window);
    len.why = what;
  }
  return len;
}

long long sample_index(double time, double sample_every) {
  return static_cast<long long>(std::floor(time / sample_every + 1e-9));
}

}  // namespace

ReplicaResult run_replica(const RunSpec& spec, std::uint64_t seed, const RunOptions& options,
                          const ReplicaResult* from) {
  ReplicaResult res;
  res.seed = seed;
  const auto wall0 = std::chrono::steady_clock::now();
  ModelOptions mo;
  mo.alpha = spec.alpha;
  mo.skin = spec.skin;
  mo.threads = spec.threads;
  Model model(from ? from->end.state : initial_state(spec, seed), mo);
  res.kernel = model.force_field().kernel();
  res.kernel_target = model.force_field().target();
  res.threads = model.force_field().threads();
  const bool cpu_process = res.threads > 1;
  const double cpu0 = cpu_clock(cpu_process);
  std::unique_ptr<Integrator> integ = spec.make_integrator();
  std::atomic<bool> attention{false};
  integ->set_interrupt(&attention);
  const Ensemble& ens = *spec.ensemble;
  if (integ->has_solver_history())
    res.history = "kept";

  double wall_before = 0.0, cpu_before = 0.0;
  long long k_first = 1;  // the first sample this call computes
  if (from) {
    if (from->series.samples.empty())
      throw IoError("the checkpoint of replica seed " + std::to_string(seed) + " holds no samples");
    model.restore(from->end);
    integ->restore_statistics(from->integrator_stats);
    res.series = from->series;
    res.t_start = from->t_start;
    res.resumes = from->resumes + 1;
    res.seed = from->seed;
    wall_before = from->wall_seconds;
    cpu_before = from->cpu_seconds;
    res.cpu_from_wall = from->cpu_from_wall;
    k_first = static_cast<long long>(from->series.samples.size());
    if (integ->has_solver_history()) {
      res.history = (from->history == "kept" ? std::string() : from->history + "; ") +
                    "fresh after resume at t = " + fmt(model.state().time - from->t_start);
    }
  } else {
    res.t_start = model.state().time;
  }
  const double t_start = res.t_start;
  const bool automatic = spec.auto_eq || spec.auto_av;
  // The first horizon: t_eq + t_av; with t_eq = "auto", t_av (where the transient is first
  // looked for); a continued automatic run keeps the horizon it had.
  res.horizon = spec.auto_eq && !spec.auto_av ? spec.t_av : spec.t_eq + spec.t_av;
  if (from && automatic && from->horizon > 0.0)
    res.horizon = from->horizon;
  long long k_max = sample_index(res.horizon, spec.sample_every);
  const double t_total = res.horizon;
  const long long traj_stride =
      spec.trajectory_every > 0 ? std::llround(spec.trajectory_every / spec.sample_every) : 0;

  const bool traj_xyz = traj_stride > 0 && spec.trajectory_format != "h5md";
  const bool traj_h5md = traj_stride > 0 && spec.trajectory_format != "xyz";
  std::ofstream traj;
  std::string traj_path;
  std::unique_ptr<H5mdTrajectory> h5md;
  const std::string h5md_path = options.label + ".traj.h5md";
  if (from && from->status == "complete") {
    // Extending a finished run: its trajectories were completed (renamed); they go on as .part.
    for (const std::string& path : {options.label + ".traj.xyz", h5md_path}) {
      std::error_code ec;
      if (std::filesystem::exists(path, ec) && !std::filesystem::exists(path + ".part", ec))
        std::filesystem::rename(path, path + ".part", ec);
    }
  }
  if (traj_h5md) {
    // The frames up to the checkpoint's last sample (k = 0, stride, 2 stride, ...) are kept.
    const std::int64_t keep =
        from ? std::int64_t(from->series.samples.size() - 1) / traj_stride + 1 : -1;
    h5md = std::make_unique<H5mdTrajectory>(h5md_path + ".part",
                                            from ? from->end.state : model.state(), keep);
  }
  if (traj_xyz) {
    traj_path = options.label + ".traj.xyz";
    if (from) {
      // Frames written after the checkpoint (a run killed later) are dropped.
      std::error_code ec;
      std::filesystem::resize_file(traj_path + ".part", std::uintmax_t(from->trajectory_bytes), ec);
      if (ec)
        throw IoError("cannot continue trajectory '" + traj_path + ".part': " + ec.message());
      traj.open(traj_path + ".part", std::ios::app);
    } else {
      traj.open(traj_path + ".part");
    }
    if (!traj)
      throw IoError("cannot write trajectory '" + traj_path + ".part'");
  }
  res.trajectory_bytes = from ? from->trajectory_bytes : 0;

  Progress progress(options.label, t_total, options.quiet,
                    from ? from->series.samples.back().time : 0.0);
  auto record = [&](double t_rel) {
    const Evaluation& ev = model.evaluate();
    const State& s = model.state();
    res.series.samples.push_back(Sample{t_rel, s.box.strain, ev.volume, ev.phi, ev.pressure,
                                        ev.sigma_xy, ev.forces.energy, ev.dissipation,
                                        ens.piston_dissipation(ev.pressure)});
  };
  auto elapsed = [&] {
    return wall_before +
           std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  };
  auto cpu_elapsed = [&] { return cpu_before + (cpu_clock(cpu_process) - cpu0); };
  // The replica as it stands, ready to continue.
  auto fill = [&](ReplicaResult& r) {
    r.end = model.snapshot();
    r.final_state = model.state();
    r.integrator_stats = integ->statistics();
    r.integrator_stats.emplace_back("force_evaluations", double(model.force_evaluations()));
    r.integrator_stats.emplace_back("force_pass_equivalents", integ->force_pass_equivalents(model));
    r.wall_seconds = elapsed();
    r.cpu_seconds = cpu_elapsed();
    if (traj_xyz) {
      traj.flush();
      r.trajectory_bytes = static_cast<std::int64_t>(traj.tellp());
    }
    if (h5md)
      h5md->flush();
  };
  auto write_frame = [&](long long k, double t_rel) {
    if (traj_xyz)
      write_xyz(traj, model.state());
    if (h5md)
      h5md->append(model.state(), k, t_rel);
  };
  auto checkpoint = [&] {
    if (!options.checkpoint)
      return;
    const std::string status = res.status;
    res.status = "running";
    fill(res);
    options.checkpoint(res);
    res.status = status;
  };
  Watcher watcher(options, attention);
  // Looks up from the loop: writes a checkpoint if one is due; true if the run must stop.
  auto attend = [&]() -> bool {
    attention.store(false);
    const int sig = options.control ? options.control->signal.load() : 0;
    const bool stop = sig != 0 || (options.stop && options.stop->load());
    const bool asked = options.control && options.control->checkpoint.exchange(false);
    if (watcher.take_timer() || asked || stop)
      checkpoint();
    if (stop) {
      res.status = "interrupted at t = " + fmt(model.state().time - t_start) +
                   (sig != 0 ? " by " + signal_name(sig) : std::string());
      res.signal = sig;
    }
    return stop;
  };
  // The step-to-step oscillation test (fixed-step integrators).
  const bool step_test = integ->nominal_dt() > 0.0;
  std::vector<double> before;
  if (from)
    res.steps = from->steps;
  const double t_begin = model.state().time;
  try {
    if (!from) {
      record(0.0);
      if (traj_stride > 0)
        write_frame(0, 0.0);
      checkpoint();  // the .part file exists from the start
    }
    bool stopped = false;
    for (long long k = k_first; !stopped; ++k) {
      if (k > k_max) {
        if (!automatic)
          break;
        const Length len = decide_length(spec, res.series, step_test ? &res.steps : nullptr);
        if (len.done)
          break;
        res.horizon = std::max(len.horizon, double(k) * spec.sample_every);
        k_max = sample_index(res.horizon, spec.sample_every);
        progress.set_total(res.horizon);
      }
      // The budget, checked before each sample (a count, so the same sample wherever it runs),
      // in force-pass equivalents: what the integrator computed, not only the model's passes.
      if (spec.max_force_evaluations > 0 &&
          integ->force_pass_equivalents(model) >= double(spec.max_force_evaluations)) {
        res.status = "budget: stopped at t = " + fmt(model.state().time - t_start) + " after " +
                     fmt(integ->force_pass_equivalents(model)) + " force-pass equivalents (" +
                     std::to_string(model.force_evaluations()) +
                     " force evaluations; [run] max_force_evaluations = " +
                     std::to_string(spec.max_force_evaluations) + ")";
        break;
      }
      const double t_rel = double(k) * spec.sample_every;
      const double t_end = t_start + t_rel;
      integ->advance(model, ens, t_end);
      while (model.state().time < t_end && !stopped) {
        // Interrupted between steps: attend, then go on to the same sample.
        stopped = attend();
        if (!stopped)
          integ->advance(model, ens, t_end);
      }
      if (stopped)
        break;
      if (step_test && t_rel > spec.t_eq + 1e-9 * spec.sample_every) {
        // The forces of the step before this sample, and of the sample itself.
        before = model.last_evaluation().forces.force;
        record(t_rel);
        res.steps.add(before, model.last_evaluation().forces.force);
      } else {
        record(t_rel);
      }
      if (traj_stride > 0 && k % traj_stride == 0)
        write_frame(k, t_rel);
      const Sample& last = res.series.samples.back();
      char extra[160];
      std::snprintf(extra, sizeof extra, "phi %.5f  P %.3e  sigma_xy %.3e", last.phi, last.pressure,
                    last.sigma_xy);
      progress.update(t_rel, extra);
      if (attention.load())
        stopped = attend();
    }
    if (res.status == "complete")
      progress.finish();
  } catch (const IntegrationError& e) {
    res.status = "failed at t = " + fmt(model.state().time - t_start) + ": " + e.what();
  } catch (const ConfigError& e) {
    // The scene was valid when the run started; a state that has since left the range the
    // engine accepts (a piston that collapsed the box below the neighbour list's cell) is a
    // failure of the run, recorded in its .part like any other, not bad input.
    if (!(model.state().time > t_begin))
      throw;
    res.status = "failed at t = " + fmt(model.state().time - t_start) +
                 ": the state left the engine's range: " + e.what();
  }
  fill(res);
  res.integrator_stats.emplace_back("neighbour_list_builds", double(model.list_builds()));
  if (traj_xyz) {
    traj.close();
    if (res.status == "complete")
      std::filesystem::rename(traj_path + ".part", traj_path);
  }
  if (h5md) {
    h5md->close();
    if (res.status == "complete")
      std::filesystem::rename(h5md_path + ".part", h5md_path);
  }
  if (res.status == "complete") {
    const StepPairs* steps = step_test ? &res.steps : nullptr;
    const Length len = decide_length(spec, res.series, steps);
    RunSpec eff = spec;
    eff.t_eq = len.t_eq;
    res.summary = summarize(eff, res.series, steps);
    res.summary.values["t_eq"] = len.t_eq;
    res.summary.values["t_av"] = res.series.samples.back().time - len.t_eq;
    res.summary.texts["run_length"] = len.why;
    res.summary.texts["t_eq_method"] = len.method;
    if (spec.auto_av && len.why.rfind("max_time", 0) == 0)
      res.summary.warnings.push_back("t_av = \"auto\": " + len.why);
  }
  res.wall_seconds = elapsed();
  res.cpu_seconds = cpu_elapsed();
  return res;
}

Configuration configuration_of(const State& st) {
  Configuration c;
  const std::size_t n = st.size();
  c.positions.resize(3 * n);
  c.diameters.resize(n);
  c.species.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto id = static_cast<std::size_t>(st.id[i]);
    Eigen::Vector3d s = st.scaled(i);
    for (int k = 0; k < 3; ++k)
      s[k] -= std::floor(s[k]);
    const Eigen::Vector3d x = st.box.h() * s;
    for (int k = 0; k < 3; ++k)
      c.positions[3 * id + k] = x[k];
    c.diameters[id] = st.diameter[i];
    c.species[id] = st.species[i];
  }
  const Eigen::Matrix3d cell = st.box.h().transpose();
  c.cell.resize(9);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      c.cell[3 * a + b] = cell(a, b);
  c.strain = st.box.strain;
  c.time = st.time;
  return c;
}

namespace {

// `summary` replaces r's own summary values, counters and wall time (the replica mean at the
// top level of a multi-replica file).
void write_replica(H5Writer& w, const RunSpec& spec, const ReplicaResult& r,
                   const std::string& prefix, const ReplicaResult* summary = nullptr) {
  const auto& ss = r.series;
  const std::string ts = prefix + "/timeseries";
  w.dataset(ts + "/time", ss.column(&Sample::time));
  w.dataset(ts + "/strain", ss.column(&Sample::strain));
  w.dataset(ts + "/volume", ss.column(&Sample::volume));
  w.dataset(ts + "/phi", ss.column(&Sample::phi));
  w.dataset(ts + "/pressure", ss.column(&Sample::pressure));
  w.dataset(ts + "/sigma_xy", ss.column(&Sample::sigma_xy));
  w.dataset(ts + "/energy", ss.column(&Sample::energy));
  w.dataset(ts + "/dissipation", ss.column(&Sample::dissipation));
  if (spec.ensemble->has_piston()) {
    w.dataset(ts + "/piston_dissipation", ss.column(&Sample::piston_dissipation));
  }
  const auto t_eq = r.summary.values.find("t_eq");
  w.attr(ts, "t_eq", t_eq == r.summary.values.end() ? spec.t_eq : t_eq->second);
  w.attr(ts, "seed", static_cast<std::int64_t>(r.seed));

  // Final configuration, in particle id order; cell rows are the lattice vectors.
  const Configuration c = configuration_of(r.final_state);
  const std::size_t n = c.diameters.size();
  const std::string fin = prefix + "/final";
  w.dataset(fin + "/positions", c.positions, {n, 3});
  w.dataset(fin + "/diameters", c.diameters);
  w.dataset(fin + "/species", c.species);
  w.dataset(fin + "/cell", c.cell, {3, 3});
  w.attr(fin, "strain", c.strain);
  w.attr(fin, "time", c.time);

  const std::string sm = prefix + "/summary";
  w.group(sm);
  const ReplicaResult& src = summary ? *summary : r;
  for (const auto& [k, v] : src.summary.values)
    w.attr(sm, k, v);
  for (const auto& [k, v] : src.summary.verdicts)
    w.attr(sm, "verdict_" + k, v);
  for (const auto& [k, v] : r.summary.texts)
    w.attr(sm, k, v);
  w.attr(sm, "N", static_cast<std::int64_t>(n));
  w.attr(sm, "alpha", spec.alpha);
  spec.ensemble->describe(w, sm);
  w.attr(sm, "integrator", spec.integrator.kind);
  for (const auto& [k, v] : src.integrator_stats)
    w.attr(sm, "integrator_" + k, v);
  w.attr(sm, "wall_seconds", src.wall_seconds);
  w.attr(sm, "cpu_seconds", src.cpu_seconds);
  if (src.cpu_from_wall)
    w.attr(sm, "cpu_seconds_note",
           "includes wall seconds: continued from a checkpoint that recorded no CPU time");
  w.attr(sm, "status", src.status);
}

}  // namespace

void write_run_layout(H5Writer& w, const RunSpec& spec,
                      const std::vector<ReplicaResult>& replicas) {
  w.attr("/", "scene", spec.scene_text);
  w.attr("/", "version", JAMFLOW_VERSION);
  w.attr("/", "git_commit", git_commit());
  w.attr("/", "created", iso_now());
  std::string status = "complete";
  std::int64_t resumes = 0;
  std::string history;
  for (const auto& r : replicas) {
    if (r.status != "complete" && status == "complete")
      status = r.status;
    resumes += r.resumes;
    if (r.history != "none" && r.history != "kept")
      history += (history.empty() ? "" : "; ") + r.history;
  }
  if (!replicas.empty()) {
    w.attr("/", "kernel", replicas.front().kernel);
    w.attr("/", "kernel_target", replicas.front().kernel_target);
    w.attr("/", "threads", static_cast<std::int64_t>(replicas.front().threads));
    // "none", "kept", or where an adaptive solver started afresh (a continued run).
    w.attr("/", "solver_history", history.empty() ? replicas.front().history : history);
  }
  w.attr("/", "replicas", static_cast<std::int64_t>(replicas.size()));
  w.attr("/", "resumes", resumes);
  w.attr("/", "status", status);
  if (replicas.empty())
    return;
  if (replicas.size() > 1 && status == "complete") {
    // Top level: the first replica's series, final state, integrator counters and wall time
    // (counters need not be additive, e.g. CVODE's atol), the summary of all replicas.
    ReplicaResult all;
    all.integrator_stats = replicas.front().integrator_stats;
    all.wall_seconds = replicas.front().wall_seconds;
    all.cpu_seconds = replicas.front().cpu_seconds;
    all.status = replicas.front().status;
    std::vector<Summary> sums;
    double wall = 0.0, cpu = 0.0;
    for (const auto& r : replicas) {
      sums.push_back(r.summary);
      wall += r.wall_seconds;
      cpu += r.cpu_seconds;
      all.cpu_from_wall = all.cpu_from_wall || r.cpu_from_wall;
    }
    all.summary = combine_replicas(sums);
    all.summary.values["wall_seconds_total"] = wall;
    all.summary.values["cpu_seconds_total"] = cpu;
    write_replica(w, spec, replicas.front(), "", &all);
  } else {
    write_replica(w, spec, replicas.front(), "");
  }
  if (replicas.size() > 1) {
    for (std::size_t k = 0; k < replicas.size(); ++k) {
      write_replica(w, spec, replicas[k], "/replicas/" + std::to_string(k));
    }
  }
  write_checkpoint(w, spec, replicas);
}

bool write_run_file(const RunSpec& spec, const std::vector<ReplicaResult>& replicas,
                    const std::string& path) {
  bool complete = !replicas.empty();
  for (const auto& r : replicas)
    complete = complete && finished_status(r.status);
  H5Writer w(complete ? path : path + ".part", ".tmp");
  write_run_layout(w, spec, replicas);
  w.commit();
  return complete;
}

void check_output(const std::string& file, const OutputOptions& output) {
  namespace fs = std::filesystem;
  const auto bad = [&](const std::string& why) {
    throw ConfigError("[output] file = \"" + file + "\" " + why);
  };
  const fs::path p(file);
  if (file.empty() || !p.has_filename() || p.filename() == "." || p.filename() == "..")
    bad("is not a file name; allowed a path to an .h5 file, such as \"run.h5\"");
  std::error_code ec;
  if (fs::is_directory(p, ec))
    bad("is a directory; allowed a path to an .h5 file inside it");
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  if (!fs::is_directory(dir, ec))
    bad("is in a directory that does not exist ('" + dir.string() + "'); create it first");
  // Writable, as the run will find it: a probe file is created and removed.
  const fs::path probe = dir / (".jamflow-probe-" + std::to_string(::getpid()));
  {
    std::ofstream f(probe);
    if (!f)
      bad("is in a directory that is not writable ('" + dir.string() + "')");
  }
  fs::remove(probe, ec);
  if (output.continue_from)
    return;  // --resume and --extend replace their own files (checked by the caller)
  if (!output.force && fs::exists(p, ec))
    bad("exists; pass --force to overwrite it, or --extend it");
  if (!output.force && fs::exists(file + ".part", ec))
    bad("has a checkpoint beside it ('" + file + ".part'); continue it with --resume " + file +
        ".part, or pass --force to start over");
}

namespace {

// Prints the summary; returns whether a verdict failed.
bool print_summary(const RunSpec& spec, const std::vector<ReplicaResult>& results) {
  std::vector<Summary> sums;
  double wall = 0.0, cpu = 0.0, equivalents = 0.0;
  bool cpu_from_wall = false;
  for (const auto& r : results) {
    sums.push_back(r.summary);
    wall += r.wall_seconds;
    cpu += r.cpu_seconds;
    cpu_from_wall = cpu_from_wall || r.cpu_from_wall;
    equivalents += statistic(r.integrator_stats, "force_pass_equivalents");
  }
  const std::size_t count = results.size();
  const Summary combined = count > 1 ? combine_replicas(sums) : results.front().summary;
  for (const auto& wmsg : combined.warnings)
    std::fprintf(stderr, "warning: %s\n", wmsg.c_str());
  const auto& v = combined.values;
  auto get = [&](const std::string& k) { return v.count(k) ? v.at(k) : std::nan(""); };
  std::printf("jamflow run: N = %lld, %s, %s, gdot = %g -> %s\n", (long long)spec.n,
              spec.ensemble->name().c_str(), spec.integrator.kind.c_str(), spec.shear_rate,
              spec.file.c_str());
  std::printf("  kernel         = %s on %s, %d thread%s\n", results.front().kernel.c_str(),
              results.front().kernel_target.c_str(), results.front().threads,
              results.front().threads == 1 ? "" : "s");
  if (count > 1) {
    std::printf("  mean over %zu replicas +- block error +- replica-scatter error\n", count);
  }
  // With replicas: "value +- block error +- replica error"; alone: "value +- block error".
  auto line = [&](const char* label, const std::string& k, const char* value_format) {
    std::printf("  %-14s = ", label);
    std::printf(value_format, get(k));
    std::printf(" +- %.2e", get(k + "_err"));
    if (count > 1)
      std::printf(" +- %.2e", get(k + "_replica_err"));
    std::printf("\n");
  };
  line("phi", "phi", "%.6f");
  line("pressure", "pressure", "%.6e");
  line("sigma_xy", "sigma_xy", "%.6e");
  line("eta", "eta", "%.6e");
  line("mu", "mu", "%.6f");
  std::printf("  J              = %.6e\n", get("J"));
  std::printf("  energy_balance = %.4f\n", get("energy_balance"));
  std::printf("  tau_sigma_xy   = %.4g\n", get("tau_sigma_xy"));
  for (const auto& [name, text] : combined.verdicts)
    std::printf("  %-14s = %s\n", name.c_str(), text.c_str());
  if (spec.auto_eq || spec.auto_av) {
    for (std::size_t r = 0; r < results.size(); ++r) {
      const auto& t = results[r].summary;
      std::printf("  %-14s = %s%.6g after t_eq = %.6g (%s)\n", "t_av",
                  count > 1 ? ("replica " + std::to_string(r) + ": ").c_str() : "",
                  t.values.at("t_av"), t.values.at("t_eq"), t.texts.at("run_length").c_str());
    }
  }
  std::printf("  force passes   = %.6g force-pass equivalents%s\n", equivalents,
              count > 1 ? " (all replicas)" : "");
  std::printf("  cpu time       = %.2f s%s\n", cpu,
              cpu_from_wall ? " (partly wall time: continued from an older checkpoint)" : "");
  std::printf("  wall time      = %.2f s\n", wall);
  return combined.failed();
}

}  // namespace

Summary combined_summary(const std::vector<ReplicaResult>& replicas) {
  if (replicas.size() == 1)
    return replicas.front().summary;
  std::vector<Summary> sums;
  for (const auto& r : replicas)
    sums.push_back(r.summary);
  return combine_replicas(sums);
}

RunOutcome run_replicas(const RunSpec& spec, const RunOptions& options,
                        const OutputOptions& output) {
  if (output.write) {
    check_output(spec.file, output);
  } else if (spec.trajectory_every > 0.0) {
    throw ConfigError("[output] trajectory_every = " + fmt(spec.trajectory_every) +
                      " needs an output file; allowed 0 for a run that writes no files");
  }
  RunOutcome outcome;
  std::vector<ReplicaResult>& results = outcome.replicas;
  if (output.continue_from)
    results = *output.continue_from;
  const std::string stem = stem_of(spec.file);
  const auto count = static_cast<std::size_t>(spec.replicas);
  if (results.size() > count) {
    throw ConfigError("[run] replicas = " + std::to_string(count) + " but the checkpoint holds " +
                      std::to_string(results.size()) + "; allowed at least that many");
  }
  // The .part file: every replica so far, the current one as it stands.
  auto write_part = [&](std::size_t k, const ReplicaResult& current) {
    if (!output.write)
      return;
    std::vector<ReplicaResult> all(results.begin(), results.begin() + std::ptrdiff_t(k));
    all.push_back(current);
    H5Writer w(spec.file + ".part", ".tmp");
    write_run_layout(w, spec, all);
    w.commit();
  };
  for (std::size_t k = 0; k < count; ++k) {
    const ReplicaResult* from = k < results.size() ? &results[k] : nullptr;
    if (from && from->status.rfind("failed", 0) == 0) {
      throw ConfigError("replica " + std::to_string(k) + " of this run " + from->status +
                        "; a failed run cannot be continued");
    }
    if (from && replica_finished(spec, *from))
      continue;  // done
    RunOptions o = options;
    o.label = stem + replica_suffix(k, count);
    o.checkpoint_every = spec.checkpoint_every;
    if (output.write)
      o.checkpoint = [&, k](const ReplicaResult& current) {
        // A checkpoint that cannot be written (a full disk) does not end the run: the previous
        // one stays in OUT.part, and the final write comes at the end.
        try {
          write_part(k, current);
        } catch (const IoError& e) {
          std::fprintf(stderr, "jamflow: warning: checkpoint not written: %s; the run goes on\n",
                       e.what());
        }
      };
    ReplicaResult r = run_replica(spec, spec.seed + k, o, from);
    if (k < results.size())
      results[k] = std::move(r);
    else
      results.push_back(std::move(r));
    const ReplicaResult& last = results[k];
    const bool ok = last.status == "complete";
    if (output.write) {
      try {
        write_xyz_file(o.label + (ok ? ".final.xyz" : ".last.xyz"), last.final_state);
      } catch (const IoError& e) {  // the run file holds the same state under /final
        std::fprintf(stderr, "jamflow: warning: %s\n", e.what());
      }
    }
    if (stopped_by_budget(last.status)) {
      // Finished without a summary: the file is final, the next replica goes on.
      if (output.write)
        std::fprintf(stderr, "jamflow: %s: %s\n", o.label.c_str(), last.status.c_str());
    } else if (!ok) {
      write_part(k, last);
      if (output.write) {
        // Only a stopped run can be continued; --resume refuses a failed one.
        const bool resumable = last.status.rfind("interrupted", 0) == 0 || last.signal != 0;
        const std::string next = resumable ? " (continue it with --resume " + spec.file + ".part)"
                                           : std::string(" (a failed run cannot be continued)");
        std::fprintf(stderr, "jamflow: %s; data kept in %s.part%s\n", last.status.c_str(),
                     spec.file.c_str(), next.c_str());
      }
      outcome.code = last.signal != 0                           ? 128 + last.signal
                     : last.status.rfind("interrupted", 0) == 0 ? 130
                                                                : 1;
      return outcome;
    }
    if (k + 1 < count)
      write_part(k, last);
  }
  if (!output.write)
    return outcome;
  try {
    write_run_file(spec, results, spec.file);
    std::error_code ec;
    std::filesystem::remove(spec.file + ".part", ec);
  } catch (const std::exception& e) {
    outcome.write_error = e.what();
    outcome.kept_in = write_run_file_elsewhere(spec, results);
    // A final configuration beside no finished run file would look like a finished run.
    for (std::size_t k = 0; k < results.size(); ++k)
      std::remove((stem + replica_suffix(k, count) + ".final.xyz").c_str());
  }
  return outcome;
}

int run_and_write(const RunSpec& spec, const RunOptions& options, const OutputOptions& output) {
  const RunOutcome outcome = run_replicas(spec, options, output);
  if (outcome.code != 0)
    return outcome.code;
  bool budget = false;
  for (const auto& r : outcome.replicas)
    budget = budget || stopped_by_budget(r.status);
  // A replica stopped by the budget has no summary to print: the file says where it stopped.
  const bool failed_verdict = !budget && print_summary(spec, outcome.replicas);
  if (budget)
    std::printf("jamflow run: stopped by [run] max_force_evaluations (no summary) -> %s\n",
                spec.file.c_str());
  if (!outcome.write_error.empty()) {
    std::fprintf(stderr, "jamflow: error: %s\n",
                 kept_message(spec.file, outcome.write_error, outcome.kept_in).c_str());
    return 1;
  }
  if (failed_verdict && output.strict) {
    std::fprintf(stderr, "jamflow: a verdict failed and --strict was given\n");
    return 3;
  }
  return 0;
}

}  // namespace jamflow
