// The run spec: a scene parsed into typed, validated settings (RunSpec), the default scene, and
// the initial state a spec starts from.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>

#include "driver/run.hpp"
#include "driver/run_detail.hpp"
#include "integrators/registry.hpp"
#include "lib/error.hpp"
#include "lib/init.hpp"
#include "lib/xyz.hpp"

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

double physical_memory_bytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), size = ::sysconf(_SC_PAGE_SIZE);
  return pages > 0 && size > 0 ? double(pages) * double(size) : 0.0;
}

}  // namespace

namespace detail {

std::string short_num(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", v);
  return text;
}

double run_length_bound(const RunSpec& spec) {
  if (spec.auto_av)
    return spec.max_time;
  return spec.auto_eq ? 2.0 * spec.t_av : spec.t_eq + spec.t_av;
}

}  // namespace detail

using detail::run_length_bound;
using detail::short_num;

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

State initial_state(const RunSpec& spec, std::uint64_t seed) {
  if (spec.init_state)
    return *spec.init_state;
  return random_state(static_cast<std::size_t>(spec.n), spec.phi, seed);
}

}  // namespace jamflow
