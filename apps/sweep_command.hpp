// `jamflow sweep`: the sweep engine's command line (sweep/ holds the engine).
#pragma once
#include <string>
#include <vector>

namespace jamflow::apps {

// args: the words after "sweep". Returns the exit status.
int sweep_command(const std::vector<std::string>& args);

}  // namespace jamflow::apps
