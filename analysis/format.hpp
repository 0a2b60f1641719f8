// How the analysis writes a number into a message or a report: with a printf format, by default
// six significant digits ("%.6g"). One helper for every file of the module.
#pragma once
#include <cstdio>
#include <string>

namespace jamflow::analysis {

inline std::string fmt(double x, const char* format = "%.6g") {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, x);
  return buf;
}

}  // namespace jamflow::analysis
