// The Olsson–Teitel study's report, a rendering of the analysis JSON (`jamflow analyze
// olsson-teitel`) and the collected table: every number and verdict in it comes from them.
#pragma once
#include <string>

#include "analysis/json.hpp"
#include "framework/sweep_study.hpp"
#include "framework/table_report.hpp"
#include "studies/volume_points.hpp"

namespace jamflow::studies::olsson_teitel {

// report.md: the sweep, its table, the analysis JSON and its exit status, and the cost line
// (cost_line or cost_line_from_tables).
std::string report_markdown(const VolumePreset& preset, const SweepStudy& run, const Table& table,
                            const analysis::Json& result, int analysis_status,
                            const std::string& cost);

}  // namespace jamflow::studies::olsson_teitel
