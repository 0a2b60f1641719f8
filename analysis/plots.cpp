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

PlotOutcome run_python_plot(const std::string& path, const std::vector<std::string>& args) {
  const std::string python = python_interpreter();
  const std::string script = path.substr(path.find_last_of('/') + 1);
  if (access(python.c_str(), X_OK) != 0) {
    return {PlotStatus::kUnavailable,
            "plots skipped: no Python interpreter at '" + python + "' (set JAMFLOW_PYTHON)"};
  }
  if (access(path.c_str(), R_OK) != 0) {
    return {PlotStatus::kFailed, "plots failed: cannot read plot script '" + path + "'"};
  }
  std::vector<std::string> words = {python, path};
  words.insert(words.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& w : words)
    argv.push_back(w.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  int rc = posix_spawn(&pid, python.c_str(), nullptr, nullptr, argv.data(), environ);
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

PlotOutcome run_plot_script(const std::string& script, const std::string& sidecar,
                            const std::string& prefix) {
  return run_python_plot(plot_scripts_dir() + "/" + script, {sidecar, prefix});
}

}  // namespace jamflow::analysis
