// `jamflow analyze`: command-line entry point of the analysis module.
//   jamflow analyze hard-sphere DATA... -o hs.json
//   jamflow analyze soft DATA... -o soft.json
//   jamflow analyze olsson-teitel DATA... -o ot.json
//   jamflow analyze flow-curve DATA... -o fc.json [--include-failed]
#pragma once

#include <string>
#include <vector>

namespace jamflow::analysis {

// `args` are the words after `jamflow analyze`. Returns the exit code: 0 ok,
// 2 usage or input error, 1 any other failure (outputs that could be
// computed are still written). Errors are printed as one line on stderr.
int analyze_main(const std::vector<std::string>& args);

}  // namespace jamflow::analysis
