// One entry to the sweep engine for the command line and the studies: run a plan where this
// process was started (local cores, one Slurm array task's share, or MPI ranks), or write the
// Slurm job array for it.
#pragma once
#include <atomic>
#include <string>
#include <vector>

#include "sweep/plan.hpp"
#include "sweep/slurm.hpp"

namespace jamflow::sweep {

struct EngineOptions {
  int jobs = 0;  // tasks at once: 0 = the cores (local), 1 per rank (MPI)
  bool quiet = false;
  int task = -1;  // >= 0: run only this array task's share (of array_size)
  int array_size = 0;
  std::string exe;  // the jamflow binary; empty: jamflow_exe()
  // Folders of other sweeps: finished replicas of the very same scene are copied in, not rerun
  // (sweep/reuse.hpp).
  std::vector<std::string> reuse;
  // Set by the caller to stop (a signal number, e.g. SIGINT: the running tasks checkpoint and
  // the engine stops). Given, run_plan installs no signal handlers: the caller keeps its own
  // (the Python module). Not under an MPI launcher.
  std::atomic<int>* stop = nullptr;
};

// SIGINT, SIGTERM, SIGHUP: the running tasks checkpoint and the engine stops; SIGUSR1: the
// running tasks checkpoint and go on. Installed by run_plan (unless EngineOptions::stop).
void install_signal_handlers();

// Runs the plan's tasks that are not finished. Under an MPI launcher with several ranks the
// ranks share them; otherwise they run locally. Returns the exit status: 0 when every task of
// this process's share is finished, 1 when some failed, 128 + the signal when stopped.
int run_plan(const Plan& plan, const EngineOptions& options);

// Writes <out_dir>/sweep.sbatch for the plan's sweep file and returns its path; a plan without
// a sweep file (make_plan) is a ConfigError, before anything is written.
std::string write_slurm_script(const Plan& plan, SlurmOptions options);

// The jamflow binary that runs tasks: $JAMFLOW_EXE if set (tests that are not the jamflow
// binary themselves), else this process's binary.
std::string jamflow_exe();

// Expected CPU hours of a plan's tasks: each integrator's measured CPU time per particle and
// unit time (Integrator::cpu_seconds_per_particle_time) over the runs' lengths.
struct CostEstimate {
  std::size_t tasks = 0;
  double cpu_hours = 0.0;
};
CostEstimate estimate_cost(const Plan& plan);

}  // namespace jamflow::sweep
