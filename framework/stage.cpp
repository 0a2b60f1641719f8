// Stability and accuracy diagnostics shared by the timestep, stability and softness studies.
#include "framework/stage.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>

#include <toml++/toml.h>

#include "analysis/admission.hpp"
#include "driver/checkpoint.hpp"
#include "framework/report.hpp"
#include "framework/sweep_study.hpp"
#include "lib/error.hpp"
#include "sweep/execute.hpp"

namespace jamflow::studies {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}  // namespace

// ---- Diagnosed runs -------------------------------------------------------------------------

std::string DiagnosedRun::verdict_text() const {
  switch (cls.verdict) {
    case Verdict::kStable:
      return std::string("stable") + (cls.laned ? ", lanes" : "") +
             (cls.correlated ? ", blocks < 2 tau (replica scatter used)" : "");
    case Verdict::kOscillating:
      return std::string("oscillating (") + cls.reason + ")" + (cls.laned ? ", lanes" : "");
    case Verdict::kDiverged: {
      std::string r = cls.reason;
      if (r.rfind("failed at ", 0) == 0)
        r = r.substr(10);
      return "diverged (" + r + ")";
    }
    case Verdict::kNotAvailable:
      return "not available (" + unavailable + ")";
    case Verdict::kIncomplete:
      return "incomplete (" + cls.reason + ")";
    case Verdict::kNotSteady:
      return "not steady (" + cls.reason + ")";
    case Verdict::kCorrelated:
      return "correlated (" + cls.reason + ")";
  }
  return "?";
}

namespace {

// The text of a failed verdict ("" if it passed or was not checked).
std::string failed_verdict(const jamflow::Verdict& v) {
  return v.failed() ? v.why : std::string();
}

// The last non-empty line of a file (a run's log: what stopped it).
std::string last_line(const std::string& path) {
  std::ifstream in(path);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty())
      last = line;
  return last;
}

// The scene of a request as the stage's sweep gives it to its point: with the seed, the start
// state and the budget.
Scene request_scene(const RunRequest& r) {
  Scene scene = Scene::parse(r.scene, r.label);
  toml::table system = scene.table("system") ? *scene.table("system") : toml::table{};
  system.insert_or_assign("seed", static_cast<std::int64_t>(r.seed));
  if (!r.init.empty() && r.init != kCountedStart) {
    system.erase("N");  // both come from the start state
    system.erase("phi");
    system.insert_or_assign("init", std::filesystem::absolute(r.init).string());
  }
  scene.set_section("system", std::move(system));
  if (const toml::table* run = scene.table("run")) {
    toml::table t = *run;
    t.erase("threads");  // the sweep's to set
    t.insert_or_assign("max_force_evaluations", r.budget);
    scene.set_section("run", std::move(t));
  }
  return scene;
}

// The sweep of a stage: the first point's scene as the base, every section of each point (whole
// [system], [ensemble], [shear], [integrator] tables; [run] key by key) in a zip, and the
// points named by their labels.
std::string stage_sweep(const std::vector<Scene>& scenes, const std::vector<std::string>& names,
                        const std::string& study, const std::string& stage) {
  toml::table zip;
  for (const char* section : {"system", "ensemble", "shear", "integrator"}) {
    toml::array column;
    for (const auto& sc : scenes)
      column.push_back(sc.table(section) ? *sc.table(section) : toml::table{});
    zip.insert(section, std::move(column));
  }
  const toml::table* run0 = scenes.front().table("run");
  if (run0) {
    for (const auto& [key, value] : *run0) {
      (void)value;
      toml::array column;
      for (const auto& sc : scenes) {
        const toml::table* run = sc.table("run");
        const toml::node* v = run ? run->get(key) : nullptr;
        if (!v || run->size() != run0->size())
          throw std::logic_error("stage " + stage + ": points with different [run] keys");
        column.push_back(*v);
      }
      zip.insert("run." + std::string(key.str()), std::move(column));
    }
  }
  toml::array name_list;
  for (const auto& n : names)
    name_list.push_back(n);
  toml::table base;  // the first point's scene ([sweep.zip] sets every point's)
  for (const char* section : {"system", "ensemble", "shear", "integrator", "run", "output"})
    if (const toml::table* t = scenes.front().table(section))
      base.insert(section, *t);
  toml::table root{
      {"sweep",
       toml::table{{"replicas", 1}, {"names", std::move(name_list)}, {"zip", std::move(zip)}}},
      {"scene", std::move(base)}};
  std::ostringstream os;
  os << "# The " << study << " study's stage '" << stage
     << "': one point per run.\n# Written by `jamflow study`; run by it, or by `jamflow sweep` "
        "like any sweep.\n"
     << toml_text(root) << "\n";
  return os.str();
}

}  // namespace

std::string excluded_section(const std::vector<const DiagnosedRun*>& runs) {
  std::string md =
      "## Runs left out by their verdicts\n\n"
      "A run enters the conclusions only if it is stable and its own verdicts pass: *not "
      "steady* (its averaging window drifts), *correlated* (blocks shorter than 2 τ: with one "
      "replica its block errors are too small and there is no replica scatter to use instead) "
      "and *incomplete* (stopped by the budget) runs are left out.\n\n";
  std::size_t count = 0;
  for (const DiagnosedRun* r : runs) {
    const Verdict v = r->cls.verdict;
    if (v == Verdict::kNotSteady || v == Verdict::kCorrelated || v == Verdict::kIncomplete) {
      md += "- " + r->label + ": " + r->verdict_text() + "\n";
      ++count;
    }
  }
  if (count == 0)
    md += "None: every run that finished stable passed its verdicts.\n";
  return md + "\n";
}

DiagnosedRun diagnose_file(const std::string& label, const RunSpec& spec, const std::string& file,
                           const RunRequest& request, const Thresholds& thresholds) {
  DiagnosedRun d;
  d.label = label;
  d.file = file;
  d.scene_text = spec.scene_text;
  d.n = spec.init_state ? static_cast<std::int64_t>(spec.init_state->size()) : spec.n;
  d.gdot = spec.shear_rate;
  d.dt = spec.make_integrator()->nominal_dt();
  d.t_eq = spec.t_eq;
  d.blocks = spec.blocks;
  RunFile f = read_run_file(file);
  if (f.replicas.empty())
    throw IoError("'" + file + "' holds no replica");
  d.result = std::move(f.replicas.front());
  if (d.result.status.kind == RunStatus::Kind::kRunning) {
    // The process stopped without a status of its own (an error other than a failed
    // integration, e.g. a box that collapsed below the cell size): its log says why.
    const std::string log = file.substr(0, file.find(".h5")) + ".log";
    d.result.status = RunStatus::aborted(last_line(log));
  }
  // The run's CPU seconds (an older file's wall seconds: result.cpu_from_wall), and its cost in
  // force-pass equivalents (CVODE's Jacobian work included; an older file's force evaluations).
  d.cpu_seconds = d.result.cpu_seconds;
  const double passes = statistic(d.result.integrator_stats, "force_evaluations");
  d.particle_steps =
      statistic(d.result.integrator_stats, "force_pass_equivalents", passes) * double(d.n);
  const bool ok = d.result.status.is_complete();
  if (ok) {
    d.balance =
        energy_balance(d.result.series.samples, spec.t_eq, spec.shear_rate,
                       spec.ensemble->imposed_pressure(), static_cast<std::size_t>(spec.blocks));
    const std::string xyz = file.substr(0, file.find(".h5")) + ".final.xyz";
    if (std::filesystem::exists(xyz))
      d.final_xyz = xyz;
  }
  if (ok && request.window) {
    try {
      d.window = diagnostic_window(spec, d.result.final_state, request.window_options);
    } catch (const std::exception& e) {
      d.window.status = RunStatus::aborted(e.what());
    }
  }
  d.cls = classify(d.result, d.balance, ok && request.window ? &d.window : nullptr, thresholds);
  // The run's own verdicts, by the admission rule of every table (analysis/admission.hpp): a
  // stable run whose window still drifts is kept out of conclusions, and so is one whose blocks
  // are shorter than 2 tau with one replica (no scatter to fall back on).
  const std::string drift = failed_verdict(d.result.summary.steady);
  const std::string short_blocks = failed_verdict(d.result.summary.decorrelated);
  const analysis::Admission admission =
      analysis::admit({drift.empty() ? std::nullopt : std::optional<bool>(false), std::nullopt,
                       short_blocks.empty() ? std::nullopt : std::optional<bool>(false),
                       d.result.summary.replicas.value_or(1.0)});
  d.cls.correlated = !short_blocks.empty();
  if (d.cls.verdict == Verdict::kStable && !admission.admitted) {
    d.cls.verdict = drift.empty() ? Verdict::kCorrelated : Verdict::kNotSteady;
    d.cls.reason = drift.empty() ? short_blocks : drift;
  }
  return d;
}

std::optional<int> run_stage(const std::string& study, const std::string& stage,
                             const std::vector<RunRequest>& requests, const StudyOptions& options,
                             std::vector<DiagnosedRun>& out, bool last_stage,
                             const Thresholds& thresholds) {
  out.clear();
  out.resize(requests.size());
  std::vector<Scene> scenes;
  std::vector<std::string> names;
  std::vector<std::size_t> point_of(requests.size(), SIZE_MAX);
  for (std::size_t k = 0; k < requests.size(); ++k) {
    const RunRequest& r = requests[k];
    DiagnosedRun& d = out[k];
    d.label = r.label;
    try {
      Scene scene = request_scene(r);
      (void)parse_run_spec(scene);  // rejected here: not available, never run
      point_of[k] = scenes.size();
      scenes.push_back(std::move(scene));
      names.push_back(r.label);
    } catch (const ConfigError& e) {
      d.unavailable = e.what();
      d.cls.verdict = Verdict::kNotAvailable;
      d.cls.reason = e.what();
      d.result.status = RunStatus::not_run();
    }
  }
  if (scenes.empty())
    return std::nullopt;
  SweepStudy sw;
  SweepStage where;
  where.name = stage;
  where.last = last_stage;
  where.collect_table = false;
  if (const auto status =
          run_sweep_study(study, stage_sweep(scenes, names, study, stage), options, sw, where))
    return status;
  if (sw.counted_only) {  // --dry-run: stand-ins, so that the next stage can be counted
    for (std::size_t k = 0; k < requests.size(); ++k) {
      if (point_of[k] == SIZE_MAX)
        continue;
      out[k].result.status = RunStatus::complete();
      out[k].final_xyz = kCountedStart;
    }
    return std::nullopt;
  }
  for (std::size_t k = 0; k < requests.size(); ++k) {
    if (point_of[k] == SIZE_MAX)
      continue;
    const sweep::Point& p = sw.plan.points[point_of[k]];
    const sweep::Task task{p.index, 0, requests[k].seed, p.cost};
    const RunSpec spec = parse_run_spec(sw.plan.task_scene(task));
    const std::string file = sw.plan.task_file(task);
    const sweep::TaskState state = sweep::probe(sw.plan, task);
    DiagnosedRun& d = out[k];
    if (state == sweep::TaskState::kDone) {
      d = diagnose_file(requests[k].label, spec, file, requests[k], thresholds);
    } else if (std::filesystem::exists(file + ".part")) {
      d = diagnose_file(requests[k].label, spec, file + ".part", requests[k], thresholds);
    } else {
      d.cls.verdict = Verdict::kDiverged;
      d.cls.reason = "no output: " + last_line(sw.plan.task_log(task));
      d.result.status = RunStatus::aborted(d.cls.reason);
    }
    if (!options.quiet)
      std::printf("  %-44s %8.3g particle-steps  %s\n", d.label.c_str(), d.particle_steps,
                  d.verdict_text().c_str());
  }
  return std::nullopt;
}

// ---- Output ---------------------------------------------------------------------------------

std::string cpu_cell(const DiagnosedRun& run) {
  return num(run.cpu_seconds, 3) + (run.result.cpu_from_wall ? " (wall)" : "");
}

std::string short_num(double v) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

}  // namespace jamflow::studies
