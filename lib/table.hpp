// Tables of text cells: the collected sweep table (sweep/collect.cpp) and the CSV tables the
// analyses read. The one reader and writer of their CSV and HDF5 forms, used by the sweeps, the
// analyses and the studies.
#pragma once
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace jamflow {

class H5Writer;

struct Table {
  std::string path;  // the file it was read from ("" for a table built in memory)
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;  // as many cells as the header
  std::vector<int> lines;                      // each row's line in the file (from 1)

  int column(std::string_view name) const;  // -1 if absent
  bool has_columns(const std::vector<std::string>& names) const;
  // The cell as a number: NaN where the column is absent, the cell empty or not a number.
  double number(std::size_t row, std::string_view name) const;
  // The cell's text: "" where the column is absent.
  std::string text(std::size_t row, std::string_view name) const;
};

// Reads a CSV table: fields separated by commas and trimmed of spaces (no quoting: cells hold
// no commas, see csv_cell), a final '\r' dropped, blank lines and lines starting with '#'
// skipped. The first line is the header, with non-empty, distinct names; every row has as many
// fields. An InputFileError names the file and line ("cannot open file", "empty file (no header
// line)", "header column 3 is empty", "duplicate column 'phi' in the header", "expected 7
// comma-separated fields (as in the header), found 6"). A table without rows is returned.
// Columns under a deprecated name (lib/names.hpp: gdot, P) are renamed to the current one
// (shear_rate, imposed_pressure), with a warning on stderr; see rename_deprecated_columns.
Table read_csv_table(const std::string& path);

// Renames the table's columns that carry a deprecated name to the current one, each with a
// one-line warning on stderr. A deprecated column beside its current one is left as it is
// (and warned about): the current one is read.
void rename_deprecated_columns(Table& table);

// A cell's text as a CSV table holds it: commas, quotes and line breaks become ';'.
std::string csv_cell(std::string text);

// Writes the header and rows as CSV (cells as given: csv_cell them first), atomically.
void write_csv_table(const std::string& path, const std::vector<std::string>& header,
                     const std::vector<std::vector<std::string>>& rows);

// Writes them as HDF5, atomically: one dataset per column under /table, in the table's order
// (the group tracks creation order, and the string-array attribute "columns" lists it). A
// numeric column (every cell a number or empty) is float64 with NaN for empty cells, any other
// column variable-length UTF-8 strings; the attribute "rows" is the number of rows. Readers
// build a DataFrame from the datasets (docs/guide/sweeps.md).
void write_h5_table(const std::string& path, const std::vector<std::string>& header,
                    const std::vector<std::vector<std::string>>& rows);

// The same table as the group `group` of a file being written (a study's <study>.h5 /points).
void write_h5_table(H5Writer& w, const std::string& group, const std::vector<std::string>& header,
                    const std::vector<std::vector<std::string>>& rows);

}  // namespace jamflow
