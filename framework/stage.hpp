// Diagnosed runs for the methodology studies and the comparison engine: the runs of a study
// stage go through the sweep engine (run_stage: one mechanism for running points, whatever the
// study) and are read back with their verdicts and the stability diagnostics of
// driver/diagnostics.hpp (lane order, diagnostic window, classification).
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "driver/diagnostics.hpp"
#include "driver/run.hpp"
#include "driver/verdicts.hpp"
#include "framework/study.hpp"

namespace jamflow::studies {

// The stability diagnostics, as the studies name them.
using diagnostics::Classification;
using diagnostics::classify;
using diagnostics::diagnostic_window;
using diagnostics::LaneAccumulator;
using diagnostics::paired_error;
using diagnostics::Thresholds;
using diagnostics::Verdict;
using diagnostics::verdict_name;
using diagnostics::WindowOptions;
using diagnostics::WindowResult;

// ---- A diagnosed run ------------------------------------------------------------------------

// The final_xyz of a run that --dry-run counted but did not run.
inline constexpr const char* kCountedStart = "<counted, not run>";

struct RunRequest {
  std::string label;  // also its point's name in the stage's sweep
  std::string scene;  // the scene's TOML text (a comparison plan's setting_scene)
  std::uint64_t seed = 1;
  // XYZ start (an earlier stage's DiagnosedRun::final_xyz); empty: random. kCountedStart (the
  // final state of a stage that --dry-run only counted): the scene's own N and phi stand in.
  std::string init;
  bool window = true;  // run the diagnostic window after the run
  WindowOptions window_options;
  std::int64_t budget = 0;  // [run] max_force_evaluations of the run (0: none)
};

struct DiagnosedRun {
  std::string label;
  std::string scene_text;  // canonical scene (empty if the scene was rejected)
  double dt = 0.0;         // nominal dt (0: adaptive or unavailable)
  double t_eq = 0.0;       // the run's [run] t_eq and blocks (the averaging window)
  std::int64_t blocks = 20;
  std::int64_t n = 0;
  double gdot = 0.0;
  ReplicaResult result;
  EnergyBalance balance;
  WindowResult window;
  Classification cls;
  // The run's CPU seconds in its `jamflow run` process (one thread; the engine runs one point
  // per core; a file written before CPU time was recorded gives its wall seconds, and
  // result.cpu_from_wall says so), and N * its force-pass equivalents (the cost that does not
  // depend on the machine: force passes, plus CVODE's Jacobian work in force-pass units).
  double cpu_seconds = 0.0;
  double particle_steps = 0.0;
  std::string unavailable;  // ConfigError text when the scene was rejected
  std::string file;         // the point's run file (r0.h5, or r0.h5.part if it did not finish)
  std::string final_xyz;    // its final state (r0.final.xyz) when complete: a later stage's init

  bool complete() const {
    return cls.verdict != Verdict::kNotAvailable && result.status.is_complete();
  }
  // "stable", "oscillating (reason)", "diverged (t = ..., message)", "not available (...)",
  // "incomplete (stopped at t = ... by the budget)", "correlated (blocks < 2 tau, ...)".
  std::string verdict_text() const;
};

// Runs the requests of one stage of `study` as a sweep (framework/sweep_study.hpp) in
// OUT/<stage>/, one point per request named by its label, and reads every point back from its
// run file (driver/checkpoint.hpp read_run_file): series, summary and verdicts, final state,
// counters, cost; then the energy balance, the diagnostic window (256 steps from the run's final
// state, computed here: cheap next to the runs, and a diagnostic of these studies rather than a
// verdict of every run) and the classification. A rejected scene is kNotAvailable and not run; a
// run that failed is kDiverged. Returns an exit status when the study stops here (--dry-run,
// --slurm, a signal, a non-root MPI rank), or nothing when `out` holds a run per request.
std::optional<int> run_stage(const std::string& study, const std::string& stage,
                             const std::vector<RunRequest>& requests, const StudyOptions& options,
                             std::vector<DiagnosedRun>& out, bool last_stage,
                             const Thresholds& thresholds = {});

// The report's section on runs left out of the conclusions by the verdicts of issue 20 (not
// steady, blocks < 2 tau with one replica, stopped by the budget), one line per run with why;
// "none" when every run is in.
std::string excluded_section(const std::vector<const DiagnosedRun*>& runs);

// Reads one run back as run_stage does (tests): `file` is a run file of `spec`'s scene.
DiagnosedRun diagnose_file(const std::string& label, const RunSpec& spec, const std::string& file,
                           const RunRequest& request, const Thresholds& thresholds = {});

// A report's "CPU s" cell: the run's CPU seconds (3 digits), marked "(wall)" when its file was
// written before CPU time was recorded and its wall seconds stand in.
std::string cpu_cell(const DiagnosedRun& run);

// Formats a number for labels ("0.05", "1e-05"; 6 significant digits).
std::string short_num(double v);

}  // namespace jamflow::studies
