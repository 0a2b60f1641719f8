#include "sweep/engine.hpp"

#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <thread>

#include "lib/error.hpp"
#include "lib/text_file.hpp"
#include "sweep/execute.hpp"
#include "sweep/mpi.hpp"
#include "sweep/reuse.hpp"

namespace jamflow::sweep {
namespace {

std::atomic<int> g_stop{0};
std::atomic<bool> g_checkpoint{false};
extern "C" void on_engine_signal(int sig) {
  if (sig == SIGUSR1)
    g_checkpoint.store(true);
  else
    g_stop.store(sig);
}

}  // namespace

void install_signal_handlers() {
  for (int sig : {SIGINT, SIGTERM, SIGHUP, SIGUSR1})
    std::signal(sig, on_engine_signal);
}

std::string jamflow_exe() {
  if (const char* e = std::getenv("JAMFLOW_EXE"); e && *e)
    return e;
  return self_exe();
}

int run_plan(const Plan& plan, const EngineOptions& o) {
  std::atomic<int>* stop = o.stop ? o.stop : &g_stop;
  if (!o.stop)
    install_signal_handlers();
  const std::string exe = o.exe.empty() ? jamflow_exe() : o.exe;
  if (!o.reuse.empty() && (!mpi_launched() || launched_rank() == 0)) {
    prepare_out_dir(plan);
    const Reused r = reuse_finished(plan, o.reuse);
    if (!o.quiet && r.replicas > 0)
      std::fprintf(stderr, "sweep %s: %zu replicas reused from finished runs of the same scene\n",
                   plan.name.c_str(), r.replicas);
  }
  if (mpi_launched()) {
    if (o.stop)
      throw ConfigError(
          "a sweep under an MPI launcher runs from `jamflow sweep`; allowed "
          "without a launcher here");
    if (o.task >= 0)
      throw ConfigError(
          "--task under an MPI launcher; allowed one of them (MPI ranks share all "
          "points)");
    return run_mpi(plan, o.jobs > 0 ? o.jobs : 1, o.quiet, exe, &g_stop, &g_checkpoint);
  }
  std::vector<std::size_t> share;
  if (o.task >= 0) {
    share = array_share(plan.tasks(), o.task, o.array_size);
    if (share.empty()) {
      if (!o.quiet)
        std::fprintf(stderr, "sweep %s: array task %d of %d has no points\n", plan.name.c_str(),
                     o.task, o.array_size);
      return 0;
    }
  }
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  return run_local(plan, o.jobs > 0 ? o.jobs : cores, share, o.quiet, exe, stop, &g_checkpoint);
}

std::string write_slurm_script(const Plan& plan, SlurmOptions options) {
  check_slurm_plan(plan);
  check_slurm_time(options.time);
  if (options.exe.empty())
    options.exe = jamflow_exe();
  prepare_out_dir(plan);
  namespace fs = std::filesystem;
  fs::create_directories(fs::path(plan.out_dir) / "slurm");
  const std::string script = (fs::path(plan.out_dir) / "sweep.sbatch").string();
  write_text_atomically(script, slurm_script(plan, options));
  return script;
}

CostEstimate estimate_cost(const Plan& plan) {
  CostEstimate c;
  for (const auto& t : plan.tasks()) {
    ++c.tasks;
    c.cpu_hours += t.cost / 3600.0;
  }
  return c;
}

}  // namespace jamflow::sweep
