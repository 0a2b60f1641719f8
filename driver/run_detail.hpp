// Helpers shared by the run driver's parts (run_spec.cpp, summary.cpp, run_file.cpp, run.cpp);
// not a public interface.
#pragma once
#include <string>
#include <vector>

#include "driver/run.hpp"

namespace jamflow::detail {

// A number for a one-line message: 6 significant digits.
std::string short_num(double v);

// The longest a run of this spec may go: with t_eq = "auto" the transient is searched within the
// first half of the run, so at most 2 t_av.
double run_length_bound(const RunSpec& spec);

// Prints the summary of a finished run on stdout (warnings on stderr); returns whether a verdict
// failed.
bool print_summary(const RunSpec& spec, const std::vector<ReplicaResult>& results);

}  // namespace jamflow::detail
