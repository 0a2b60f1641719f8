#include "framework/sweep_study.hpp"

#include <cstdio>
#include <filesystem>

#include "framework/report.hpp"
#include "lib/error.hpp"
#include "lib/table.hpp"
#include "sweep/collect.hpp"
#include "sweep/engine.hpp"
#include "sweep/execute.hpp"
#include "sweep/mpi.hpp"

namespace jamflow::studies {

namespace {

bool all_done(const sweep::Plan& plan) {
  for (const auto& t : plan.tasks())
    if (sweep::probe(plan, t) != sweep::TaskState::kDone)
      return false;
  return true;
}

struct RunsLeft {
  std::size_t finished = 0;  // runs whose files say done
  double cpu_hours = 0.0;    // the others' estimate (a checkpointed run counts whole)
};

// The plan's finished runs and what is left, added to the tally of `study paper --dry-run`
// (each distinct scene once).
RunsLeft count_runs(const sweep::Plan& plan, StudyOptions::DryRunTally* tally) {
  RunsLeft left;
  for (const auto& t : plan.tasks()) {
    const bool done = sweep::probe(plan, t) == sweep::TaskState::kDone;
    const double hours = t.cost / 3600.0;  // Task::cost is in CPU seconds
    left.finished += done ? 1 : 0;
    left.cpu_hours += done ? 0.0 : hours;
    if (tally && tally->scenes.insert(plan.task_scene(t).text()).second) {
      tally->cpu_hours += hours;
      tally->cpu_hours_left += done ? 0.0 : hours;
      tally->finished += done ? 1 : 0;
    }
  }
  return left;
}

}  // namespace

std::optional<int> run_sweep_study(const std::string& study, const std::string& sweep_text,
                                   const StudyOptions& options, SweepStudy& out,
                                   const SweepStage& stage) {
  namespace fs = std::filesystem;
  const fs::path dir =
      stage.name.empty() ? fs::path(options.out_dir) : fs::path(options.out_dir) / stage.name;
  ensure_dir(dir.string());
  const std::string file = (dir / "sweep.toml").string();
  write_text(file, sweep_text);
  out.plan = sweep::load_plan(file, (dir / "runs").string());
  // The progress line and the Slurm job name.
  out.plan.name = stage.name.empty() ? study : study + "-" + stage.name;
  const sweep::CostEstimate cost = sweep::estimate_cost(out.plan);
  out.cpu_hours_estimate = cost.cpu_hours;
  const std::string what = (stage.name.empty() ? study : study + " (stage " + stage.name + ")") +
                           (options.command.empty() ? " --preset " + options.preset : "");
  const std::string again =
      options.command.empty()
          ? "jamflow study " + study + " --preset " + options.preset + " --out " + options.out_dir
          : options.command;
  const std::string next =
      stage.last ? std::string()
      : options.dry_run
          ? "; the study's next stage is counted from its scenes (stand-in start states)"
          : "; the study's next stage is written when this one has finished (the same "
            "command again)";
  // A finished stage of a study in stages is read back: the next stage is the one to count,
  // write or run.
  const bool finished_stage = !stage.name.empty() && all_done(out.plan);
  if (options.dry_run) {
    // A finished stage is counted in the tally, and read back for the next stage.
    const RunsLeft left = count_runs(out.plan, options.tally);
    if (!finished_stage) {
      std::printf(
          "%s: %zu points x %lld replicas = %zu runs, about %.3g CPU-hours (each "
          "integrator's measured CPU time per particle and tau_0); %zu finished, about %.3g "
          "CPU-hours left -> %s%s\n",
          what.c_str(), out.plan.points.size(), static_cast<long long>(out.plan.replicas),
          cost.tasks, cost.cpu_hours, left.finished, left.cpu_hours, out.plan.out_dir.c_str(),
          next.c_str());
      if (stage.last)
        return 0;
      out.counted_only = true;
      return std::nullopt;
    }
  }
  if (options.slurm && !finished_stage) {
    sweep::SlurmOptions so;
    so.time = options.slurm_time;
    so.array_size = options.slurm_array_size;
    so.partition = options.slurm_partition;
    const std::string script = sweep::write_slurm_script(out.plan, so);
    std::printf(
        "%s\nsubmit it with: sbatch %s\nthen, when the array is done: %s%s\n", script.c_str(),
        script.c_str(), again.c_str(),
        stage.last ? "" : " (it writes the next stage's array, or the report after the last)");
    return 0;
  }
  if (!finished_stage) {
    sweep::EngineOptions eo;
    eo.jobs = options.jobs;
    eo.quiet = options.quiet;
    eo.reuse = options.reuse;
    const int status = sweep::run_plan(out.plan, eo);
    if (status >= 128)
      return status;  // stopped: the checkpoints continue on the next run
    if (sweep::mpi_launched()) {
      if (sweep::launched_rank() != 0)
        return status;  // under mpirun, rank 0 alone collects and analyses
      if (!stage.last) {
        std::printf("%s: stage %s done; run the same command again for the next stage\n",
                    study.c_str(), stage.name.c_str());
        return status;
      }
    }
  }
  // Under mpirun, rank 0 alone analyses: the other ranks stop after the last stage, also when
  // it had finished before this launch.
  if (stage.last && sweep::mpi_launched() && sweep::launched_rank() != 0)
    return 0;
  if (!stage.collect_table)
    return std::nullopt;
  out.table = (dir / "table.csv").string();
  const sweep::Collected c = sweep::collect(out.plan, out.table);
  out.finished = c.rows;
  for (const auto& why : c.left_out)
    std::fprintf(stderr, "%s: left out %s\n", study.c_str(), why.c_str());
  if (c.rows == 0)
    throw ConfigError(study + ": no point finished; allowed a preset whose points run");
  return std::nullopt;
}

SweepStudy existing_sweep(const std::string& out_dir) {
  namespace fs = std::filesystem;
  SweepStudy s;
  const fs::path sweep_file = fs::path(out_dir) / "sweep.toml";
  s.table = (fs::path(out_dir) / "table.csv").string();
  if (!fs::exists(sweep_file) || !fs::exists(s.table))
    throw ConfigError("--report-only: " + sweep_file.string() + " and " + s.table +
                      " must exist (allowed: an output folder of an earlier run of the study)");
  s.plan = sweep::load_plan(sweep_file.string(), out_dir);
  s.finished = read_csv_table(s.table).rows.size();
  s.cpu_hours_estimate = sweep::estimate_cost(s.plan).cpu_hours;
  return s;
}

}  // namespace jamflow::studies
