// Attributes as a list, in the order they are written: what an HDF5 writer writes
// (H5Writer::attrs) and what a caller that wants the same keys reads (the Python module's
// RunResult.summary is the run file's /summary through this list).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace jamflow {

using AttrValue = std::variant<double, std::int64_t, std::string>;
using Attributes = std::vector<std::pair<std::string, AttrValue>>;

}  // namespace jamflow
