// Plot-script runner (see plots.hpp).
#include "analysis/plots.hpp"

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

#include "lib/data_files.hpp"

#ifndef JAMFLOW_PYTHON
#define JAMFLOW_PYTHON "/usr/bin/python3"
#endif
#ifndef JAMFLOW_ANALYSIS_SCRIPTS
#define JAMFLOW_ANALYSIS_SCRIPTS "analysis/plots"
#endif

extern char** environ;

namespace jamflow::analysis {

std::string python_interpreter() {
  const char* env = std::getenv("JAMFLOW_PYTHON");
  return env && *env ? env : JAMFLOW_PYTHON;
}

std::string plot_scripts_dir() {
  const char* env = std::getenv("JAMFLOW_ANALYSIS_SCRIPTS");
  return env && *env ? env : data_dir("analysis/plots", JAMFLOW_ANALYSIS_SCRIPTS);
}

PlotOutcome run_plot_script(const std::string& script, const std::string& sidecar,
                            const std::string& prefix) {
  const std::string python = python_interpreter();
  const std::string path = plot_scripts_dir() + "/" + script;
  if (access(python.c_str(), X_OK) != 0) {
    return {PlotStatus::kUnavailable,
            "plots skipped: no Python interpreter at '" + python + "' (set JAMFLOW_PYTHON)"};
  }
  if (access(path.c_str(), R_OK) != 0) {
    return {PlotStatus::kFailed, "plots failed: cannot read plot script '" + path + "'"};
  }
  // posix_spawn with an argument vector: no shell, so no quoting issues with
  // file names.
  std::string a0 = python, a1 = path, a2 = sidecar, a3 = prefix;
  char* argv[] = {a0.data(), a1.data(), a2.data(), a3.data(), nullptr};
  pid_t pid = 0;
  int rc = posix_spawn(&pid, python.c_str(), nullptr, nullptr, argv, environ);
  if (rc != 0) {
    return {PlotStatus::kUnavailable,
            "plots skipped: cannot run '" + python + "': " + std::strerror(rc)};
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR)
      return {PlotStatus::kFailed, "plots failed: waitpid error"};
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0)
    return {PlotStatus::kOk, ""};
  if (WIFEXITED(status) && WEXITSTATUS(status) == 3) {
    return {PlotStatus::kUnavailable,
            "plots skipped: matplotlib is not available to '" + python + "' (set JAMFLOW_PYTHON)"};
  }
  return {PlotStatus::kFailed, "plots failed: '" + script + "' exited with status " +
                                   std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1)};
}

}  // namespace jamflow::analysis
