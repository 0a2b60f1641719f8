// Where the files jamflow reads at run time (plot scripts) are: in an installed tree,
// <prefix>/share/jamflow, found relative to the running binary or to the Python module, so that
// the tree can be moved; in a build tree, the source folder compiled in.
#pragma once
#include <string>

namespace jamflow {

// The folder `relative` (e.g. "analysis/plots") of the installed data: <root>/relative, where
// <root> is the root set_data_root() registered, else <dir of the running binary>/../share/
// jamflow (the installed layout); `source_dir` only when neither exists (a build tree). An
// installed tree never reads the source tree.
std::string data_dir(const std::string& relative, const std::string& source_dir);

// The Python module registers its install tree's data root (the interpreter is the running
// binary there, and is not looked beside); a root that does not exist means a build tree.
void set_data_root(std::string root);

}  // namespace jamflow
