// The hard-sphere and finite-size studies' analysis and report: the collected table goes
// through `jamflow analyze hard-sphere` itself (one code path: the P -> 0 envelope, the fits
// per N and the large-N extrapolation), then the study adds the flow curves (the seed's
// Fig. 2-3), the comparison with the seed's numbers in sigma, the verdicts and the cost.
#pragma once
#include <string>

#include "analysis/json.hpp"
#include "framework/study.hpp"
#include "framework/sweep_study.hpp"
#include "framework/table_report.hpp"
#include "studies/pressure_points.hpp"

namespace jamflow::studies::granular {

// Writes OUT/analysis.json (+ .md, PNGs: what `jamflow analyze hard-sphere -o` writes),
// OUT/flow_curves.png, OUT/<study>.h5 and OUT/report.md. Returns the exit status.
int analyze_and_report(const std::string& study, const GridPreset& grid, const SweepStudy& run,
                       const StudyOptions& options, double wall_seconds);

// The report.md text of analyze_and_report, from what it read: the sweep, the collected table,
// the analysis JSON (`jamflow analyze hard-sphere`) and its exit status. Every number and
// verdict comes from `table` and `result`.
std::string report_markdown(const std::string& study, const GridPreset& grid, const SweepStudy& run,
                            const Table& table, const analysis::Json& result, int analysis_status,
                            double wall_seconds);

// A grid study end to end: its points through the sweep engine (framework/sweep_study.hpp), then
// analyze_and_report. Returns the exit status (that of the engine when it stopped early).
int run_grid_study(const std::string& study, const GridPreset& grid, const StudyOptions& options);

}  // namespace jamflow::studies::granular
