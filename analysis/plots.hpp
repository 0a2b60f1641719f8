// The one launcher of plot scripts, for the analyses (the matplotlib scripts of analysis/plots/,
// on a plot sidecar JSON) and the studies (their plot.py). The interpreter is JAMFLOW_PYTHON
// (environment, else the build-time path: Debian's python3 with matplotlib); the analyses'
// scripts directory is JAMFLOW_ANALYSIS_SCRIPTS (environment, else the source tree).
#pragma once

#include <string>
#include <vector>

namespace jamflow::analysis {

std::string python_interpreter();
std::string plot_scripts_dir();

enum class PlotStatus { kOk, kUnavailable, kFailed };

struct PlotOutcome {
  PlotStatus status = PlotStatus::kOk;
  std::string message;  // one line, for warnings and errors
};

// Runs `python path args...` with an argument vector (no shell, so any file name) and waits.
// kUnavailable: no interpreter, or no matplotlib (the script exits with 3).
PlotOutcome run_python_plot(const std::string& path, const std::vector<std::string>& args);

// Runs `python <plot_scripts_dir()>/script sidecar prefix`; the script writes prefix_figN.png.
PlotOutcome run_plot_script(const std::string& script, const std::string& sidecar,
                            const std::string& prefix);

}  // namespace jamflow::analysis
