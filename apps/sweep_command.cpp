#include "apps/sweep_command.hpp"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "lib/cli_exit.hpp"
#include "lib/error.hpp"
#include "sweep/collect.hpp"
#include "sweep/engine.hpp"
#include "sweep/execute.hpp"
#include "sweep/plan.hpp"

namespace jamflow::apps {
namespace {

void print_dry_run(const sweep::Plan& plan) {
  const auto tasks = plan.tasks();
  const sweep::CostEstimate cost = sweep::estimate_cost(plan);
  std::printf("sweep %s: %zu points x %lld replicas = %zu runs -> %s\n", plan.name.c_str(),
              plan.points.size(), static_cast<long long>(plan.replicas), tasks.size(),
              plan.out_dir.c_str());
  std::printf("  %-48s %8s %12s  %s\n", "point", "N", "CPU s", "state");
  // Each point's replicas, found once (not by a pass over all tasks per point).
  std::vector<std::vector<const sweep::Task*>> of_point(plan.points.size());
  for (const auto& t : tasks)
    of_point[t.point].push_back(&t);
  for (const auto& p : plan.points) {
    auto& ts = of_point[p.index];
    std::sort(ts.begin(), ts.end(), [](auto a, auto b) { return a->replica < b->replica; });
    std::string states;
    for (const sweep::Task* t : ts)
      states += std::string(states.empty() ? "" : ",") + sweep::state_name(sweep::probe(plan, *t));
    std::printf("  %-48s %8lld %12.3g  %s\n", p.name.c_str(), static_cast<long long>(p.n), p.cost,
                states.c_str());
  }
  std::printf(
      "  expected work: about %.3g CPU-hours (each integrator's measured CPU time per particle "
      "and tau_0; CPU s per replica above)\n",
      cost.cpu_hours);
}

}  // namespace

int sweep_command(const std::vector<std::string>& args) {
  CLI::App app{"Run a sweep of state points: a base scene and the axes to vary (TOML).",
               "jamflow sweep"};
  std::string sweep_path, out_dir, collect_path, time = "24:00:00", partition;
  int jobs = 0, task = -1, array_size = 0, cpus = 1, signal_seconds = 300;
  bool slurm = false, dry_run = false, quiet = false;
  std::vector<std::string> reuse;
  app.add_option("sweep", sweep_path, "sweep file (TOML)")->required();
  app.add_option("--out", out_dir, "output folder (default: <sweep stem>.sweep beside the file)")
      ->check(non_empty_path());
  app.add_option("-j,--jobs", jobs, "points run at once, one thread each (default: the cores)")
      ->check(CLI::Range(1, 4096));
  app.add_flag("--dry-run", dry_run, "list the points, their state and the expected cost");
  app.add_option("--collect", collect_path,
                 "write one row per finished point to TABLE.csv (read by `jamflow analyze`), or "
                 "to TABLE.h5 (a dataset per column)");
  app.add_flag("--slurm", slurm, "write DIR/sweep.sbatch, a Slurm job array for the sweep");
  app.add_option("--array-size", array_size,
                 "Slurm array tasks (--slurm; default one per run, at most 1000), or the array "
                 "that --task belongs to")
      ->check(CLI::Range(1, 100000));
  app.add_option("--task", task, "run only this array task's share of the points (0-based)")
      ->check(CLI::Range(0, 99999));
  app.add_option("--time", time, "Slurm time limit of each array task (--slurm)");
  app.add_option("--partition", partition, "Slurm partition (--slurm)");
  app.add_option("--cpus-per-task", cpus, "points at once in each array task (--slurm)")
      ->check(CLI::Range(1, 4096));
  app.add_option("--signal-seconds", signal_seconds,
                 "Slurm sends TERM this long before the time limit (--slurm)")
      ->check(CLI::Range(10, 65535));
  app.add_option("--reuse", reuse,
                 "folder of other sweeps (repeatable): finished replicas of the very same scene "
                 "are copied in, not rerun")
      ->check(reuse_folder());
  app.add_flag("-q,--quiet", quiet, "no progress line");
  std::vector<std::string> rev(args.rbegin(), args.rend());
  try {
    app.parse(rev);
  } catch (const CLI::ParseError& e) {
    return parse_error_exit(app, e, "jamflow sweep");
  }
  if (task >= 0 && array_size == 0)
    throw ConfigError("--task " + std::to_string(task) + " needs --array-size M; allowed both");
  if (task >= array_size && task >= 0)
    throw ConfigError("--task " + std::to_string(task) + " with --array-size " +
                      std::to_string(array_size) + "; allowed 0 to " +
                      std::to_string(array_size - 1));
  if (slurm)
    sweep::check_slurm_time(time);
  const sweep::Plan plan = sweep::load_plan(sweep_path, out_dir);
  if (dry_run) {
    print_dry_run(plan);
    return 0;
  }
  if (!collect_path.empty()) {
    const sweep::Collected c = sweep::collect(plan, collect_path);
    std::printf("%s: %zu of %zu points\n", collect_path.c_str(), c.rows, plan.points.size());
    for (const auto& why : c.left_out)
      std::fprintf(stderr, "sweep: left out %s\n", why.c_str());
    return 0;
  }
  if (slurm) {
    sweep::SlurmOptions so;
    so.array_size = array_size;
    so.time = time;
    so.cpus_per_task = cpus;
    so.signal_seconds = signal_seconds;
    so.partition = partition;
    const std::string script = sweep::write_slurm_script(plan, so);
    std::printf("%s\nsubmit it with: sbatch %s\n", script.c_str(), script.c_str());
    return 0;
  }
  sweep::EngineOptions eo;
  eo.jobs = jobs;
  eo.quiet = quiet;
  eo.task = task;
  eo.array_size = array_size;
  eo.reuse = reuse;
  return sweep::run_plan(plan, eo);
}

}  // namespace jamflow::apps
