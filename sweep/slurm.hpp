// A Slurm job array for a sweep: `jamflow sweep SWEEP.toml --slurm` writes DIR/sweep.sbatch.
// Array task k runs `jamflow sweep SWEEP.toml --out DIR --task k --array-size M` on its share
// of the tasks (plan.hpp: array_share). Slurm signals the batch shell before the time limit;
// the running points checkpoint, and the array task requeues itself, so that its next start
// resumes them. A resubmitted array resumes the same way.
#pragma once
#include <string>

#include "sweep/plan.hpp"

namespace jamflow::sweep {

struct SlurmOptions {
  int array_size = 0;  // 0: one array task per task, at most 1000
  std::string time = "24:00:00";
  int cpus_per_task = 1;     // points run at once in each array task
  int signal_seconds = 300;  // TERM this long before the time limit (then checkpoints)
  std::string partition;     // empty: the cluster's default
  std::string exe;           // the jamflow binary
};

// The script's text. Paths in it are absolute. A plan without a sweep file (make_plan) is a
// ConfigError: the array tasks run `jamflow sweep FILE` on the nodes.
std::string slurm_script(const Plan& plan, const SlurmOptions& options);

// The ConfigError slurm_script throws for a plan without a sweep file, thrown here too (so
// callers refuse before they write anything).
void check_slurm_plan(const Plan& plan);

// One batch job (a sweep's array, or `jamflow study paper` on MPI ranks): the #SBATCH header,
// then `command` in the background ($exe is options.exe). Slurm's TERM before the time limit
// is passed on to it, and a command stopped by a signal requeues the job, which resumes from
// the checkpoints.
struct BatchJob {
  std::string name;
  std::string comment;  // lines after #!/bin/bash, each "# ...\n"
  std::string array;    // "0-9", or empty for a single job
  int ntasks = 1;
  std::string output;   // --output pattern (absolute)
  std::string command;  // shell text, already quoted
};
std::string batch_script(const BatchJob& job, const SlurmOptions& options);

// Single-quoted for bash.
std::string shell_quoted(const std::string& s);

// Checks "[D-]HH:MM:SS" (or MM:SS or minutes) as sbatch --time takes it; a ConfigError names
// --time otherwise.
void check_slurm_time(const std::string& time);

}  // namespace jamflow::sweep
