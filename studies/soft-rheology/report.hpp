// The soft-rheology study's report, a rendering of the analysis JSON (`jamflow analyze soft`)
// and the collected tables: every number and verdict in it comes from them.
#pragma once
#include <string>

#include "analysis/json.hpp"
#include "framework/sweep_study.hpp"
#include "framework/table_report.hpp"
#include "studies/soft-rheology/points.hpp"

namespace jamflow::studies::soft_rheology {

// report.md: the sweeps (constant pressure, constant volume), their tables, the analysis JSON
// and its exit status, and the cost line (cost_line or cost_line_from_tables).
std::string report_markdown(const Preset& preset, const SweepStudy& cp, const SweepStudy& cv,
                            const Table& cp_table, const Table& cv_table,
                            const analysis::Json& result, int analysis_status,
                            const std::string& cost);

}  // namespace jamflow::studies::soft_rheology
