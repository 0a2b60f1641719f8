#include "sweep/slurm.hpp"

#include <algorithm>
#include <filesystem>
#include <regex>
#include <string>

#include "lib/error.hpp"

namespace jamflow::sweep {
namespace fs = std::filesystem;

void check_slurm_time(const std::string& time) {
  // Slurm's forms: M, M:S, H:M:S, D-H, D-H:M, D-H:M:S. Every field after the first is below 60,
  // and hours after days below 24; sbatch rejects anything else (99:99 is 99 min 99 s).
  static const std::regex form(R"(^(?:(\d+)-)?(\d+)(?::(\d{1,2}))?(?::(\d{1,2}))?$)");
  std::smatch m;
  bool ok = time.size() <= 20 && std::regex_match(time, m, form);
  if (ok) {
    for (int k = 3; k <= 4; ++k)
      ok = ok && (!m[k].matched || std::stoi(m[k].str()) < 60);
    if (m[1].matched)
      ok = ok && m[2].length() <= 2 && std::stoi(m[2].str()) < 24;
  }
  if (!ok)
    throw ConfigError("--time '" + time +
                      "': allowed a Slurm time limit [D-]HH:MM:SS (or MM, MM:SS, D-HH, D-HH:MM) "
                      "with minutes and seconds below 60 and hours below 24 after days, such as "
                      "24:00:00, 1-12:00:00 or 90");
}

std::string shell_quoted(const std::string& s) {
  std::string out = "'";
  for (char c : s)
    out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string batch_script(const BatchJob& job, const SlurmOptions& o) {
  std::string s;
  s += "#!/bin/bash\n";
  s += job.comment;
  s += "#SBATCH --job-name=" + job.name + "\n";
  if (!job.array.empty())
    s += "#SBATCH --array=" + job.array + "\n";
  s += "#SBATCH --ntasks=" + std::to_string(job.ntasks) + "\n";
  s += "#SBATCH --cpus-per-task=" + std::to_string(o.cpus_per_task) + "\n";
  s += "#SBATCH --time=" + o.time + "\n";
  if (!o.partition.empty())
    s += "#SBATCH --partition=" + o.partition + "\n";
  // TERM to the batch shell (B:) this long before the limit: the running points checkpoint.
  s += "#SBATCH --signal=B:TERM@" + std::to_string(o.signal_seconds) + "\n";
  s += "#SBATCH --requeue\n";
  s += "#SBATCH --open-mode=append\n";
  s += "#SBATCH --output=" + job.output + "\n";
  s += "#SBATCH --chdir=" + fs::current_path().string() + "\n";
  s += "\n";
  s += "exe=" + shell_quoted(o.exe) + "\n";
  s += job.command + " &\n";
  s += "pid=$!\n";
  s += "# Slurm's TERM reaches this shell only: pass it on, so the running points checkpoint.\n";
  s += "trap 'kill -TERM $pid 2>/dev/null' TERM\n";
  s += "wait $pid; status=$?\n";
  s += "while kill -0 $pid 2>/dev/null; do wait $pid; status=$?; done\n";
  s += "if [ \"$status\" -ge 128 ]; then\n";
  s += "  # Stopped before its work was done (time limit, scancel -s TERM): run again later,\n";
  s += "  # resuming from the checkpoints.\n";
  s += "  echo \"jamflow stopped (status $status); requeueing $SLURM_JOB_ID\"\n";
  s += "  scontrol requeue \"$SLURM_JOB_ID\"\n";
  s += "fi\n";
  s += "exit $status\n";
  return s;
}

void check_slurm_plan(const Plan& plan) {
  if (plan.path.empty())
    throw ConfigError("sweep " + plan.name +
                      " has no sweep file (it was built from a scene and a grid); Slurm's array "
                      "tasks rerun `jamflow sweep FILE` on the nodes, so allowed a sweep file "
                      "(its grid as [sweep.grid]) for Slurm");
}

std::string slurm_script(const Plan& plan, const SlurmOptions& o) {
  check_slurm_plan(plan);
  const std::size_t tasks = plan.tasks().size();
  const int size =
      o.array_size > 0 ? o.array_size : static_cast<int>(std::min<std::size_t>(tasks, 1000));
  const std::string out = fs::absolute(plan.out_dir).lexically_normal().string();
  const std::string sweep = fs::absolute(plan.path).lexically_normal().string();
  BatchJob job;
  job.name = "jamflow-" + plan.name;
  job.comment = "# Written by `jamflow sweep --slurm` for " + sweep + ".\n" +
                "# Submit with: sbatch " + out +
                "/sweep.sbatch   (resubmitting it resumes the sweep)\n";
  job.array = "0-" + std::to_string(std::max(size, 1) - 1);
  job.output = out + "/slurm/%A_%a.out";
  job.command = "\"$exe\" sweep " + shell_quoted(sweep) + " --out " + shell_quoted(out) +
                " --task \"$SLURM_ARRAY_TASK_ID\" --array-size " +
                std::to_string(std::max(size, 1)) + " -j \"${SLURM_CPUS_PER_TASK:-1}\"";
  return batch_script(job, o);
}

}  // namespace jamflow::sweep
