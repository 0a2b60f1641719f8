// The run driver: a validated scene in, a simulation with sampled observables, block-averaged
// summary and an HDF5 file out. Studies compose runs through this same code.
#pragma once
#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "driver/run_status.hpp"
#include "ensembles/ensemble.hpp"
#include "integrators/integrator.hpp"
#include "integrators/registry.hpp"
#include "lib/config.hpp"
#include "lib/model.hpp"
#include "lib/progress.hpp"
#include "lib/state.hpp"
#include "lib/statistics.hpp"

namespace jamflow {

class H5Writer;

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
  // t_eq = "auto": the transient's end is found from the data (MSER-5, lib/statistics.hpp), and
  // t_av then counts from there. t_av = "auto": the window grows until the relative block error
  // of eta (of mu at constant pressure; of P_hat without shear) is at most target_error with
  // blocks of at least 2 tau, or until t_eq + t_av reaches max_time. t_av then holds the first
  // window tried.
  bool auto_eq = false, auto_av = false;
  double target_error = 0.0, max_time = 0.0;
  std::int64_t blocks = 20;
  std::int64_t replicas = 1;
  int threads = 0;
  // Budget: a replica stops at the first sample at which its cost in force-pass equivalents
  // (Integrator::force_pass_equivalents: the model's force passes, plus CVODE's Jacobian work
  // weighted by its cost against a force pass) reaches this; 0 = none (the default). Counted,
  // not timed, so a budget cuts a run at the same sample wherever it runs. The key keeps its
  // name. See RunStatus::Kind::kBudget.
  std::int64_t max_force_evaluations = 0;
  // [output]
  std::string file = "jamflow.h5";
  double trajectory_every = 0.0;  // 0: no trajectory file
  // "xyz" (<stem>.traj.xyz), "h5md" (<stem>.traj.h5md, H5MD 1.1) or "both".
  std::string trajectory_format = "xyz";
  double checkpoint_every = 600.0;  // seconds of wall time between checkpoints
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

// One verdict of a summary (driver/verdicts.hpp): passed, failed and why, or not checked and
// why. Run files hold it as text(): "pass", "fail: <why>" or "not checked: <why>".
struct Verdict {
  enum class Outcome { kPass, kFail, kNotChecked };
  Outcome outcome = Outcome::kNotChecked;
  std::string why;  // empty when passed

  static Verdict pass() { return {Outcome::kPass, {}}; }
  static Verdict fail(std::string why) { return {Outcome::kFail, std::move(why)}; }
  static Verdict not_checked(std::string why) { return {Outcome::kNotChecked, std::move(why)}; }
  // The text of a run file; anything else is "not checked", with the text as why.
  static Verdict parse(const std::string& text);

  bool passed() const { return outcome == Outcome::kPass; }
  bool failed() const { return outcome == Outcome::kFail; }
  std::string text() const;
  double value() const;  // 1 passed, 0 failed, NaN not checked (the summary value of its name)
  bool operator==(const Verdict&) const = default;
};

// An observable averaged over the window (its blocks): the mean, the block error and, for the
// mean of several replicas, the error from their scatter (combine_replicas).
struct Estimate {
  double value = std::numeric_limits<double>::quiet_NaN();
  double err = std::numeric_limits<double>::quiet_NaN();
  std::optional<double> replica_err;  // a mean over replicas only
};

// The summary of a run or of the mean of its replicas. A number that does not apply is absent
// (an empty optional) and is not written to the run file; the names of the numbers in files,
// tables and Python are those of value() (README "Output").
struct Summary {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  bool computed = false;  // false: the run stopped before its summary (its budget)
  // Block averages: <name>, <name>_err and, over replicas, <name>_replica_err.
  Estimate sigma_xy, pressure, phi, energy;
  Estimate mu;  // sigma_xy / P, with the imposed P at constant pressure
  // Work / dissipation with the enthalpy drift removed; its error is the file's
  // energy_balance_err.
  Estimate energy_balance_corrected;
  std::optional<Estimate> eta;             // sigma_xy / gdot, with shear only
  std::optional<double> eta_block_std, J;  // with shear only (J = gdot / P)
  double phi_block_std = kNaN, dissipation = kNaN;
  double energy_balance = kNaN;  // work / dissipation
  double samples = kNaN, block_length = kNaN;
  // Integrated autocorrelation times and the trends' t statistics of the block means.
  double tau_sigma_xy = kNaN, tau_pressure = kNaN, tau_phi = kNaN;
  double trend_t_phi = kNaN, trend_t_sigma_xy = kNaN, trend_t_pressure = kNaN;
  std::optional<double> force_step_correlation;  // fixed-step integrators only
  std::optional<double> t_eq, t_av;              // the window the run took (run_replica)
  std::optional<double> replicas;                // a mean over this many replicas
  std::optional<double> wall_seconds_total, cpu_seconds_total;  // over the replicas

  // The verdicts (driver/verdicts.hpp): no significant trend of the block means; the energy
  // balance and no step-to-step oscillation; blocks of at least 2 tau. Their values
  // (Verdict::value) are numbers of the summary under the same names (kVerdicts).
  Verdict steady, stable, decorrelated;
  std::vector<std::string> warnings;
  // How the run's window was chosen (set by run_replica): whether the t_av = "auto" target or
  // max_time ended the run, and how t_eq was found.
  std::optional<std::string> run_length, t_eq_method;
  bool failed() const;  // any verdict failed
  // The verdict of that name in run files; nullptr if none has it.
  Verdict* verdict(std::string_view name);

  // Every number present, by its name in run files, in the order of names.
  std::vector<std::pair<std::string, double>> values() const;
  // One of them by name; NaN if absent.
  double value(std::string_view name) const;
  // Sets a number by its name in run files (the verdicts' values are ignored: they come with
  // the verdicts); false if no number has that name.
  bool set(std::string_view name, double v);
};

// The verdicts of a summary by their names in run files (verdict_<name>), in the order of names.
inline constexpr std::pair<const char*, Verdict Summary::*> kVerdicts[] = {
    {"decorrelated", &Summary::decorrelated},
    {"stable", &Summary::stable},
    {"steady", &Summary::steady}};

// Forces at consecutive integrator steps, at each sample of the averaging window: sum of
// F(t - dt) . F(t) and of (|F(t - dt)|^2 + |F(t)|^2) / 2 (the stable verdict's oscillation test).
struct StepPairs {
  double cross = 0.0, norm = 0.0;
  std::int64_t pairs = 0;
  void add(const std::vector<double>& before, const std::vector<double>& now);  // verdicts.cpp
  double correlation() const { return norm > 0.0 ? cross / norm : 1.0; }
};

// Block-averaged observables over the window t >= t_eq, with the integrated autocorrelation
// times tau_sigma_xy, tau_pressure, tau_phi (time units) and a warning for each that is longer
// than half a block.
// With `steps` (fixed-step integrators), the stable verdict also tests for step-to-step
// oscillation.
Summary summarize(const RunSpec& spec, const Series& series, const StepPairs* steps = nullptr);

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
  // CPU seconds of the replica's computation (see run_replica); a continued replica counts the
  // whole run. cpu_from_wall: a file or checkpoint written before CPU time was recorded, whose
  // wall seconds stand in for (part of) it.
  double cpu_seconds = 0.0;
  bool cpu_from_wall = false;
  std::uint64_t seed = 0;
  // A replica stopped by [run] max_force_evaluations (kBudget) is finished (its file is final,
  // not a checkpoint to continue) but has no summary.
  RunStatus status;
  // Provenance: the force backend, the instruction-set target it ran on, and the thread count.
  std::string kernel, kernel_target;
  int threads = 1;
  // To continue the replica (checkpoints, --resume, --extend): the model where it stopped,
  // the state's time at its start, and the bytes of its trajectory file written so far.
  Model::Snapshot end;
  double t_start = 0.0;
  std::int64_t trajectory_bytes = 0;
  std::int64_t resumes = 0;  // times continued from a checkpoint
  double horizon = 0.0;      // the time the run currently aims for (t_eq + t_av, or auto)
  StepPairs steps;           // what the oscillation test has seen so far
  // "none" (fixed-step integrators keep no history between steps), "kept", or, for an adaptive
  // solver continued from a checkpoint, "fresh after resume at t = ...".
  std::string history = "none";
  int signal = 0;  // the signal that interrupted it (0: none)
};

// Set asynchronously (a signal handler) to stop a run or ask for a checkpoint.
struct RunControl {
  std::atomic<int> signal{0};           // SIGTERM, SIGINT or SIGHUP: checkpoint and stop
  std::atomic<bool> checkpoint{false};  // SIGUSR1: checkpoint now and go on
};

struct RunOptions {
  bool quiet = false;
  std::string label = "run";
  const std::atomic<bool>* stop = nullptr;  // set asynchronously to interrupt
  RunControl* control = nullptr;
  // Called with the replica as it stands, ready to continue, when a checkpoint is due: every
  // checkpoint_every seconds of wall time, on RunControl::checkpoint, before stopping for a
  // signal, and once at the start. Empty: no checkpoints.
  std::function<void(const ReplicaResult&)> checkpoint;
  double checkpoint_every = 600.0;
  // Where the progress goes unless quiet: empty, the progress line on stderr; else every
  // sample's report (and the last, `finished`, of a completed replica), from the run's thread.
  std::function<void(const ProgressReport&)> progress;
};

// Builds the initial state (random or from init), and runs one replica with the given seed.
// An IntegrationError or an interruption ends the run early: status says why and the series
// holds everything sampled until then. With `from` (a checkpoint of this spec's replica), the
// replica continues where it stopped: for Euler and RESPA bit for bit as if never stopped.
// The flags of `options` are polled between integrator steps, so a run stops within about
// 0.1 s of wall time plus one step. The replica's wall and CPU seconds are measured around this
// call (and added to those of `from`).
ReplicaResult run_replica(const RunSpec& spec, std::uint64_t seed, const RunOptions& options,
                          const ReplicaResult* from = nullptr);

// Initial state for a spec and seed.
State initial_state(const RunSpec& spec, std::uint64_t seed);

// Writes the HDF5 layout (see README "Output") and the replicas' checkpoints (driver/
// checkpoint.hpp) through `w`. With several replicas, the first is written at the top level
// and all of them under /replicas/<k>; the top-level /summary then holds combine_replicas() of
// all of them plus wall_seconds_total and cpu_seconds_total (its integrator counters,
// wall_seconds and cpu_seconds stay the first replica's). The root attribute "status" is "complete"
// only when every replica is.
void write_run_layout(H5Writer& w, const RunSpec& spec, const std::vector<ReplicaResult>& replicas);
// Writes the attribute "unit" (unit_of its name) on the dataset `path` just written.
void write_unit(H5Writer& w, const std::string& path);

// The /summary attributes of replica r, in the order the run file writes them: its summary
// values, verdicts and texts, N, alpha, the ensemble's attributes, the integrator and its
// counters, the CPU and wall seconds, the status. With `summary` (replicas_summary() of a
// multi-replica run, for the top level), that one's values, verdicts, counters and times.
// The Python module's RunResult.summary is this list.
Attributes summary_attributes(const RunSpec& spec, const ReplicaResult& r,
                              const ReplicaResult* summary = nullptr);
// The unit of a quantity the run file stores, by its name (a dataset's last path component or
// a /summary attribute), in reduced units a = eps = xi_s = 1 (the small diameter, the energy
// scale, the solvent friction; tau_0 = xi_s a^2 / eps): "a", "tau_0", "eps/a^3", "xi_s/a",
// "1" for a dimensionless number or a count, "s" for wall and CPU seconds, and so on
// (docs/guide/files.md). <x>_err, <x>_replica_err, <x>_block_std and <x>_total have the unit
// of x; tau_<x> is a time, trend_t_<x> a t-statistic. Empty for text (ensemble, verdicts) and
// for a name it does not know. Every dataset of a run file carries it as the attribute "unit";
// each numeric /summary attribute has it under /summary/units, by the same name.
std::string unit_of(std::string_view name);

// The top-level summary of several replicas: combine_replicas() of theirs plus
// wall_seconds_total and cpu_seconds_total; the integrator counters and the wall and CPU
// seconds are the first replica's.
ReplicaResult replicas_summary(const std::vector<ReplicaResult>& replicas);

// write_run_layout() into `path` (through a temporary file renamed when complete). Returns
// false if any replica is not finished (RunStatus::is_finished()): then the file is written as
// <path>.part instead.
bool write_run_file(const RunSpec& spec, const std::vector<ReplicaResult>& replicas,
                    const std::string& path);

// The final configuration as outputs give it: particles in id order, real-space positions
// wrapped into the cell, rows of `cell` the lattice vectors (row-major 3 x 3).
struct Configuration {
  std::vector<double> positions;  // N x 3, row-major
  std::vector<double> diameters;
  std::vector<std::int64_t> species;
  std::vector<double> cell;  // 3 x 3, row-major
  double strain = 0.0, time = 0.0;
};
Configuration configuration_of(const State& state);

// How run_and_write treats existing files and earlier runs.
struct OutputOptions {
  // false: nothing is written (no HDF5, XYZ or checkpoint file; the caller keeps the results);
  // a trajectory then is a ConfigError.
  bool write = true;
  bool force = false;  // overwrite an existing output or checkpoint
  // Continue these replicas (read from a checkpoint) instead of starting afresh.
  std::optional<std::vector<ReplicaResult>> continue_from;
  bool extend = false;  // the output is the finished file being extended: replace it
  bool strict = false;  // a failed verdict is exit status 3
};

// The output path is usable before anything is computed: a file name (not empty, ".", or a
// directory) in an existing, writable directory, not an existing file unless `force`, and
// no checkpoint of another run beside it. A ConfigError names [output] file and the reason.
void check_output(const std::string& file, const OutputOptions& output);

// What run_replicas did: every replica run so far, and how it ended.
struct RunOutcome {
  std::vector<ReplicaResult> replicas;
  // 0 when every replica is complete, 1 when one failed, 128 + the signal when one was stopped
  // by a signal, 130 when interrupted by `stop`.
  int code = 0;
  // The final file could not be written: why, and where the finished run was written instead
  // (empty: nowhere; OUT.part holds the last checkpoint). See kept_message().
  std::string write_error, kept_in;
};

// Runs all replicas of a spec (or continues them) and writes the output (with output.write),
// without printing anything but the progress line. A replica that does not complete ends the
// run: its checkpoint is kept in OUT.part.
RunOutcome run_replicas(const RunSpec& spec, const RunOptions& options,
                        const OutputOptions& output = {});

// The summary of a finished run: the one replica's, or combine_replicas() of several.
Summary combined_summary(const std::vector<ReplicaResult>& replicas);

// run_replicas(), then the summary on stdout. Returns the process exit code: 0, 1 for a failed
// run or output, 3 for a failed verdict with `strict`, 128 + the signal for a run stopped by a
// signal (130 when interrupted by `stop`).
int run_and_write(const RunSpec& spec, const RunOptions& options, const OutputOptions& output = {});

}  // namespace jamflow
