#include "studies/sweep_study.hpp"

#include <cstdio>
#include <filesystem>

#include "lib/error.hpp"
#include "studies/common.hpp"
#include "sweep/collect.hpp"
#include "sweep/engine.hpp"
#include "sweep/execute.hpp"
#include "sweep/mpi.hpp"

namespace jamflow::studies {

std::optional<int> run_sweep_study(const std::string& study, const std::string& sweep_text,
                                   const StudyOptions& options, SweepStudy& out) {
  namespace fs = std::filesystem;
  ensure_dir(options.out_dir);
  const std::string file = (fs::path(options.out_dir) / "sweep.toml").string();
  write_text(file, sweep_text);
  out.plan = sweep::load_plan(file, (fs::path(options.out_dir) / "runs").string());
  out.plan.name = study;  // for the progress line
  const sweep::CostEstimate cost = sweep::estimate_cost(out.plan);
  out.cpu_hours_estimate = cost.cpu_hours;
  if (options.dry_run && options.tally && cost.particle_steps > 0.0) {
    double fresh = 0.0;
    for (const auto& t : out.plan.tasks()) {
      if (options.tally->scenes.insert(out.plan.task_scene(t).text()).second)
        fresh += t.cost;
    }
    options.tally->cpu_hours += cost.cpu_hours * fresh / cost.particle_steps;
  }
  if (options.dry_run) {
    std::printf(
        "%s --preset %s: %zu points x %lld replicas = %zu runs, %.3g particle force "
        "evaluations, about %.3g CPU-hours (40 ns each; CVODE counted as 4 per tau_0) "
        "-> %s\n",
        study.c_str(), options.preset.c_str(), out.plan.points.size(),
        static_cast<long long>(out.plan.replicas), cost.tasks, cost.particle_steps, cost.cpu_hours,
        out.plan.out_dir.c_str());
    return 0;
  }
  if (options.slurm) {
    sweep::SlurmOptions so;
    so.time = options.slurm_time;
    so.array_size = options.slurm_array_size;
    so.partition = options.slurm_partition;
    const std::string script = sweep::write_slurm_script(out.plan, so);
    std::printf(
        "%s\nsubmit it with: sbatch %s\nthen, when the array is done: jamflow study %s "
        "--preset %s --out %s\n",
        script.c_str(), script.c_str(), study.c_str(), options.preset.c_str(),
        options.out_dir.c_str());
    return 0;
  }
  sweep::EngineOptions eo;
  eo.jobs = options.jobs;
  eo.quiet = options.quiet;
  eo.reuse = options.reuse;
  const int status = sweep::run_plan(out.plan, eo);
  if (status >= 128)
    return status;  // stopped: the checkpoints continue on the next run
  if (sweep::mpi_launched() && sweep::launched_rank() != 0)
    return status;  // under mpirun, rank 0 alone collects and analyses
  out.table = (fs::path(options.out_dir) / "table.csv").string();
  const sweep::Collected c = sweep::collect(out.plan, out.table);
  out.finished = c.rows;
  for (const auto& why : c.left_out)
    std::fprintf(stderr, "%s: left out %s\n", study.c_str(), why.c_str());
  if (c.rows == 0)
    throw ConfigError(study + ": no point finished; allowed a preset whose points run");
  return std::nullopt;
}

}  // namespace jamflow::studies
