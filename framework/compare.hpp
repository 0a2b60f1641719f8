// `jamflow compare COMPARE.toml`: a methodology comparison on any scene. A base scene, a
// preparation (a run that reaches a steady state, or an XYZ start), the settings to compare
// (typed overrides of the base scene: integrator and its parameters, ensemble, alpha_r, N, shear
// rate), a reference setting, replicas and observables. Replica k of every setting continues
// from the same prepared state k (prepared with seed base + k), so settings are paired replica
// by replica; a setting may instead continue from another setting's replica k (`from`). The
// stages (preparation, settings, settings continued from settings) run on the sweep engine
// (framework/stage.hpp run_stage: local cores, MPI ranks, Slurm arrays, resume, --dry-run);
// the numbers come from analysis/compare.hpp, and the report (OUT/compare.h5, OUT/table.csv, PNG
// plots, OUT/report.md) renders them. A study can be a compare file plus a report section of its
// own (CompareReportSection): studies/ensemble is one.
#pragma once
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "analysis/compare.hpp"
#include "framework/stage.hpp"
#include "framework/study.hpp"
#include "lib/attributes.hpp"
#include "lib/config.hpp"

namespace jamflow::studies {

// Observables a comparison may name: the sampled series (README "Output") and eta = sigma_xy /
// gdot.
const std::vector<std::string>& compare_observables();

struct CompareSetting {
  std::string label;
  toml::table overrides;  // section -> table of keys, applied to the base scene
  std::int64_t n = 0;     // particles (the base scene's N unless the setting sets system.N)
  // from = "LABEL": replica k continues from that setting's replica k (which itself starts from
  // the preparation) instead of from prepared state k; a third stage runs these settings.
  std::string from;
  std::size_t from_index = 0;
  // start = "mean_phi": a constant-volume setting starts from its source's final state (the
  // preparation's, or the `from` setting's) dilated affinely to the source's mean phi: the mean
  // over its steady replicas (all, if none is steady) of their window means. Every replica then
  // runs at the same packing fraction, not at the last frame's phi (a fluctuation away from the
  // mean) nor at one replica's window mean: one state point, as an ensemble comparison needs.
  bool start_mean_phi = false;
  // converged = true: a setting fine enough that its differences from the reference are
  // statistical only; the converged settings' scatter scales the errors where it exceeds them
  // (analysis::CompareResult::converged_scatter).
  bool converged = false;
};

struct ComparePlan {
  std::string path;   // the compare file
  std::string name;   // its stem (a study's plan: the study's name)
  std::string study;  // the study whose preset this is; empty for `jamflow compare`
  Scene base;
  // The preparation: an XYZ start (absolute path), or a run of length prepare_t from a random
  // state (one per N and replica) with the [prepare] overrides.
  std::string init;
  double prepare_t = 0.0;
  std::optional<double> prepare_sample_every;
  toml::table prepare_overrides;
  std::vector<CompareSetting> settings;
  std::size_t reference = 0;
  std::int64_t replicas = 1;
  std::uint64_t seed = 1;  // the base scene's system.seed: replica k prepares with seed + k
  std::vector<std::string> observables;
  double tolerance_sigma = 2.0;
  std::vector<double> relative_tolerance;  // per observable (0: none)
  toml::table run;                         // [run] keys for every setting (t_eq, t_av, ...)
  std::int64_t blocks = 20;
  // diagnose = true: every setting's run is followed by the diagnostic window
  // (driver/diagnostics.hpp: 256 steps sampled at every step), which classifies it as stable,
  // oscillating or diverged and flags lanes; oscillating or diverged makes a setting unstable.
  bool diagnose = false;
  // window_step: the diagnostic window's sampling interval for adaptive integrators (CVODE,
  // RKC), whose step-correlation test measures how smooth the forces are over that interval.
  // 0 (unset): the run's sample_every / 16; window_step = "contact" (window_step_contact): a
  // tenth of the contact relaxation time, 0.1 / max(1, k) with k = (alpha_r - 1)
  // delta^(alpha_r - 2) the contact stiffness at the typical overlap delta (as atol_overlaps).
  double window_step = 0.0;
  bool window_step_contact = false;
  // [study]: keys that the study whose preset this is reads itself (the engine only keeps them);
  // a compare file run by `jamflow compare` may not have it.
  toml::table study_keys;

  // [[case]]: the same comparison at several state points. Each case is a plan of its own (the
  // base scene, [run] lengths and [prepare] t overridden by the case, `settings` a subset of the
  // settings; `label` its label), run
  // together: each stage of every case is one sweep stage, and each case reports into
  // OUT/<label>/, with OUT/report.md and OUT/table.csv over all of them. Empty: one comparison.
  std::vector<ComparePlan> cases;
  std::string label;

  // The scene of a setting (base + overrides + [run]) and of the preparation at N particles. A
  // setting's integrator.atol_overlaps = x becomes atol = x delta, delta = P^(1/(alpha_r - 1))
  // the typical overlap, with P the imposed pressure at constant pressure, else
  // `measured_pressure` (the mean P_hat of the runs the setting starts from; NaN: 1e-3 stands in).
  Scene setting_scene(std::size_t s,
                      double measured_pressure = std::numeric_limits<double>::quiet_NaN()) const;
  Scene prepare_scene(std::int64_t n) const;
  // The diagnostic window of a setting's runs (window_step), at the same state point as
  // setting_scene(s, measured_pressure).
  WindowOptions window_options(
      std::size_t s, double measured_pressure = std::numeric_limits<double>::quiet_NaN()) const;
  // The distinct N of the settings, in order of first appearance.
  std::vector<std::int64_t> sizes() const;
};

// The typical overlap delta = P^(1/(alpha_r - 1)) (SPEC §4) of a scene: its imposed pressure at
// constant pressure, else `measured` (a mean P_hat), else 1e-3 (a stand-in where nothing has run).
double typical_overlap(const Scene& scene,
                       double measured = std::numeric_limits<double>::quiet_NaN());

// A setting's integrator as the tables name it: its kind, its family (the kind, and for RESPA
// its splitting: "respa particlesx4", "respa particlesx2 heun"), its fixed step and its relative
// tolerance (NaN where the kind has none).
struct CompareMethod {
  std::string kind, family;
  double dt = std::numeric_limits<double>::quiet_NaN();
  double rtol = std::numeric_limits<double>::quiet_NaN();
};
CompareMethod compare_method(const ComparePlan& plan, std::size_t setting);

// Reads and checks a compare file: every setting's scene and the preparation's go through the
// checks of `jamflow run`, so a bad key or value is one ConfigError line naming the setting and
// the key before anything runs.
ComparePlan load_compare(const std::string& path);
ComparePlan parse_compare(const std::string& text, const std::string& source,
                          const std::string& base_dir);

// One case of a comparison (the whole comparison without [[case]]) as a study's own report
// section sees it: its plan, the analysis, and every run by setting and replica (the summaries,
// verdicts, diagnostic windows and series).
struct CompareCaseOutcome {
  const ComparePlan* plan = nullptr;
  const analysis::CompareResult* result = nullptr;
  std::vector<std::vector<const DiagnosedRun*>> runs;  // [setting][replica]
  // How the tables name the case: its label, or the comparison's name without cases.
  const std::string& name() const { return plan->label.empty() ? plan->name : plan->label; }
};

// What a study's own section adds to a comparison's report: markdown and, for programs, its
// conclusions as HDF5 attributes (group path -> attributes), written to OUT/<study>.h5 (the
// compare file's stem for `jamflow compare`). A section that only writes text returns a string.
struct CompareSection {
  CompareSection() = default;
  CompareSection(std::string text) : markdown(std::move(text)) {}  // NOLINT: implicit
  std::string markdown;
  std::vector<std::pair<std::string, Attributes>> values;
  // A follow-up's own runs (CompareFollowUp): their number and CPU seconds join the report's
  // cost line.
  std::size_t runs = 0;
  double cpu_seconds = 0.0;
};

// A study's own section of a comparison's report (the seed's numbers beside the comparison's,
// the largest stable step per case, ...), a pure function of every case's runs and their
// analysis. Without [[case]] its markdown goes into report.md before the recommendation; with
// cases, at the end of OUT/report.md, after the table of cases.
using CompareReportSection = std::function<CompareSection(const std::vector<CompareCaseOutcome>&)>;

// A study that runs stages of its own after the comparison (studies/softness: pressure scans with
// each case's chosen integrator). It is called with every case's outcome once the comparison's
// stages are done and analysed, and under --dry-run (with no outcomes: nothing has run) so that
// its stages are counted too. It runs its stages (run_stage) and returns its section, or the
// status to stop with when a stage did not finish (--dry-run, --slurm, a signal, an MPI rank
// other than 0): then no report is written.
using CompareFollowUp =
    std::function<std::variant<int, CompareSection>(const std::vector<CompareCaseOutcome>&)>;

// Runs (or resumes, dry-runs, writes the Slurm array of) the comparison into options.out_dir
// and writes the report; returns the exit status. `follow_up` takes the place of `section`.
// `plot_scripts`: a study's own plots (paths under the studies' folder, e.g. "stability/plot.py"),
// each run as `SCRIPT OUT/table.csv OUT` after the report (OUT/table.csv has every case's rows,
// with a `case` column when there are cases, and the integrator's dt and rtol and the diagnostic
// window's classes).
int run_compare(const ComparePlan& plan, const StudyOptions& options,
                const CompareReportSection& section = {},
                const std::vector<std::string>& plot_scripts = {},
                const CompareFollowUp& follow_up = {});

// The compare file of a study's preset, shipped in the study's folder as <preset>.toml (installed
// with the plot scripts); a preset without one is a ConfigError naming the allowed presets.
ComparePlan study_compare_plan(const std::string& study, const std::string& preset);

// `jamflow compare ...` (args are the words after "compare").
int compare_main(const std::vector<std::string>& args);

}  // namespace jamflow::studies
