// What the study framework and the studies share to write reports: markdown tables and numbers,
// the plotting scripts (Debian's python3 with matplotlib), the installed data folder, and atomic
// writes.
#pragma once
#include <string>
#include <vector>

#include "framework/study.hpp"

namespace jamflow::studies {

// A markdown table: header names, then rows of already formatted cells. A '|' in a cell (as in
// "|t| <= 4") is escaped, so that it does not split the cell.
std::string markdown_table(const std::vector<std::string>& header,
                           const std::vector<std::vector<std::string>>& rows);

// "a, b, c".
std::string join(const std::vector<std::string>& items);

// "1.234e-05 +- 6.7e-07" style formatting.
std::string pm(double value, double error, int digits = 4);
std::string num(double value, int digits = 4);

// Runs analysis/plot script `script` (a path relative to the studies folder, e.g.
// "ensemble/plot.py") with arguments; returns false (with a one-line warning) if python or
// matplotlib is unavailable or the script fails. Honours options.no_plots.
bool run_plot(const std::string& script, const std::vector<std::string>& args,
              const StudyOptions& options);

// The studies' installed data folder (plot scripts, compare files): <share>/jamflow/studies, or
// the source folder in a build tree (lib/data_files.hpp).
std::string studies_data_dir();

// Creates the output folder (and parents); throws IoError if it cannot.
void ensure_dir(const std::string& dir);

// Writes text to a file atomically (temporary + rename).
void write_text(const std::string& path, const std::string& text);

}  // namespace jamflow::studies
