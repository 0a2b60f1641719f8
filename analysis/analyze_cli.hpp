// `jamflow analyze`: command-line entry point of the analysis module.
//   jamflow analyze hard-sphere DATA... -o hs.json
//   jamflow analyze soft DATA... -o soft.json
//   jamflow analyze olsson-teitel DATA... -o ot.json
//   jamflow analyze flow-curve DATA... -o fc.json [--include-failed]
//
// The same analyses are called with typed options (the studies do): read the DATA files, analyse,
// write the outputs, return the command's exit code.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "analysis/flow_curve.hpp"
#include "analysis/hard_sphere.hpp"
#include "analysis/olsson_teitel.hpp"
#include "analysis/soft.hpp"

namespace jamflow::analysis {

// Where an analysis writes: the JSON at `json`, and beside it the report (.md), the plot data
// (.plotdata.json) and, with `plots`, the PNGs of its matplotlib script.
struct AnalysisOutputs {
  std::string json;
  bool plots = true;
};

// Each analysis as `jamflow analyze` runs it: `files` are CSV tables or run files. Returns the
// exit code of analyze_main (0 ok; 2 an input error, or data that cannot support the analysis;
// 1 a failed analysis or plot), after printing each warning and error as one line on stderr.
// An output that would replace an input is refused (2) before anything is read.
int analyze_hard_sphere_files(const std::vector<std::string>& files, const HardSphereOptions& o,
                              const AnalysisOutputs& out);
// `yield_files`: constant-volume tables or run files for o.yield_data (read here).
int analyze_soft_files(const std::vector<std::string>& files,
                       const std::vector<std::string>& yield_files, SoftOptions o,
                       const AnalysisOutputs& out);
// `size`: analyse only this N (the data must hold it).
int analyze_olsson_teitel_files(const std::vector<std::string>& files, const OlssonTeitelOptions& o,
                                std::optional<std::int64_t> size, const AnalysisOutputs& out);
// `include_failed`: rows whose verdicts failed are admitted, marked.
int analyze_flow_curve_files(const std::vector<std::string>& files, const FlowCurveOptions& o,
                             bool include_failed, const AnalysisOutputs& out);

// `args` are the words after `jamflow analyze`. Returns the exit code: 0 ok,
// 2 usage or input error, 1 any other failure (outputs that could be
// computed are still written). Errors are printed as one line on stderr.
int analyze_main(const std::vector<std::string>& args);

}  // namespace jamflow::analysis
