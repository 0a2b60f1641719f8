// The run driver: a validated scene in, a simulation with sampled observables, block-averaged
// summary and an HDF5 file out. Studies compose runs through this same code.
#pragma once
#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ensembles/ensemble.hpp"
#include "integrators/integrator.hpp"
#include "integrators/registry.hpp"
#include "lib/config.hpp"
#include "lib/model.hpp"
#include "lib/state.hpp"
#include "lib/statistics.hpp"

namespace jamflow {

// The scene a bare `jamflow run` uses (also printed by `jamflow scene`).
extern const char* const kDefaultScene;

// Everything a run needs, validated. Built from a Scene by parse_run_spec().
struct RunSpec {
  std::string scene_text;  // canonical TOML after overrides (provenance)
  // [system]
  std::int64_t n = 0;
  double phi = 0.0;
  double alpha = 2.0;
  std::uint64_t seed = 1;
  std::string init;  // extended XYZ path, or empty for random
  double skin = 0.3;
  // [shear]
  double shear_rate = 0.0;
  // [run]
  double t_eq = 0.0, t_av = 0.0, sample_every = 0.0;
  std::int64_t blocks = 20;
  std::int64_t replicas = 1;
  int threads = 0;
  // [output]
  std::string file = "jamflow.h5";
  double trajectory_every = 0.0;  // 0: no trajectory file
  // Parts: the ensemble is stateless and shared; integrators keep history and counters, so
  // each replica makes its own from the typed settings.
  std::shared_ptr<const Ensemble> ensemble;
  IntegratorSettings integrator;    // [integrator], exactly as given (kind, dt, ...)
  std::optional<State> init_state;  // loaded from `init`
  std::unique_ptr<Integrator> make_integrator() const;
};

// Validates the scene: unknown sections or keys, missing keys and out-of-range values are
// ConfigErrors naming the key, the value and what is allowed.
RunSpec parse_run_spec(const Scene& scene);

// The same for a scene without an [integrator] section and typed integrator settings (what the
// studies use): the run uses exactly these values, and scene_text describes them exactly
// (doubles at round-trip precision). A scene that has an [integrator] section is a ConfigError
// (two sources for one setting).
RunSpec parse_run_spec(const Scene& scene, const IntegratorSettings& integrator);

struct Sample {
  double time, strain, volume, phi, pressure, sigma_xy, energy, dissipation, piston_dissipation;
};

struct Series {
  std::vector<Sample> samples;
  std::vector<double> column(double Sample::*field) const;
};

struct Summary {
  std::map<std::string, double> values;  // name -> value (see write_summary for the names)
  std::vector<std::string> warnings;
};

// Block-averaged observables over the window t >= t_eq, with the integrated autocorrelation
// times tau_sigma_xy, tau_pressure, tau_phi (time units) and a warning for each that is longer
// than half a block.
Summary summarize(const RunSpec& spec, const Series& series);

// The summary of K independent replicas: every value is the mean over replicas; each `<name>_err`
// is the block error propagated to that mean, sqrt(sum_k err_k^2) / K; each observable with an
// error also gets `<name>_replica_err` = (std over replicas) / sqrt(K), the error from the
// replica scatter, which does not rely on blocks being uncorrelated. `replicas` = K. Warnings
// are collected with the replica index.
Summary combine_replicas(const std::vector<Summary>& summaries);

struct ReplicaResult {
  Series series;
  State final_state;
  Summary summary;
  std::vector<std::pair<std::string, double>> integrator_stats;
  double wall_seconds = 0.0;
  std::uint64_t seed = 0;
  std::string status = "complete";  // or the failure / interruption message
  // Provenance: the force backend, the instruction-set target it ran on, and the thread count.
  std::string kernel, kernel_target;
  int threads = 1;
};

struct RunOptions {
  bool quiet = false;
  std::string label = "run";
  const std::atomic<bool>* stop = nullptr;  // set asynchronously to interrupt
};

// Builds the initial state (random or from init), and runs one replica with the given seed.
// An IntegrationError or an interruption ends the run early: status says why and the series
// holds everything sampled until then.
ReplicaResult run_replica(const RunSpec& spec, std::uint64_t seed, const RunOptions& options);

// Initial state for a spec and seed.
State initial_state(const RunSpec& spec, std::uint64_t seed);

// Writes the HDF5 layout (see README "Output"). With several replicas, the first is written
// at the top level and all of them under /replicas/<k>; the top-level /summary then holds
// combine_replicas() of all of them plus wall_seconds_total (its integrator counters and
// wall_seconds stay the first replica's). Returns
// false if any replica failed (then the file is kept as <file>.part with a status attribute).
bool write_run_file(const RunSpec& spec, const std::vector<ReplicaResult>& replicas,
                    const std::string& path);

// Runs all replicas of a spec and writes the output. Returns the process exit code.
int run_and_write(const RunSpec& spec, const RunOptions& options);

}  // namespace jamflow
