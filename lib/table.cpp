#include "lib/table.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "lib/names.hpp"
#include "lib/text_file.hpp"

namespace jamflow {

namespace {

std::string trim(const std::string& s) {
  std::size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b])))
    ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1])))
    --e;
  return s.substr(b, e - b);
}

std::vector<std::string> split_line(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  for (const char c : line) {
    if (c == ',') {
      fields.push_back(trim(field));
      field.clear();
    } else {
      field += c;
    }
  }
  fields.push_back(trim(field));
  return fields;
}

}  // namespace

void rename_deprecated_columns(Table& table) {
  for (const auto& [old_name, name] : names::kDeprecatedColumns) {
    const int c = table.column(old_name);
    if (c < 0)
      continue;
    const std::string where = table.path.empty() ? "table" : table.path;
    if (table.column(name) >= 0) {
      std::fprintf(stderr,
                   "warning: %s: column '%s' is ignored: it is the deprecated name of '%s', which "
                   "the table also has\n",
                   where.c_str(), std::string(old_name).c_str(), std::string(name).c_str());
      continue;
    }
    std::fprintf(stderr, "warning: %s: column '%s' is deprecated; read as '%s'\n", where.c_str(),
                 std::string(old_name).c_str(), std::string(name).c_str());
    table.header[static_cast<std::size_t>(c)] = std::string(name);
  }
}

int Table::column(std::string_view name) const {
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i] == name)
      return static_cast<int>(i);
  }
  return -1;
}

bool Table::has_columns(const std::vector<std::string>& names) const {
  return std::all_of(names.begin(), names.end(),
                     [&](const std::string& n) { return column(n) >= 0; });
}

double Table::number(std::size_t row, std::string_view name) const {
  const std::string cell = text(row, name);
  if (cell.empty())
    return std::nan("");
  char* end = nullptr;
  const double v = std::strtod(cell.c_str(), &end);
  return end && *end == '\0' ? v : std::nan("");
}

std::string Table::text(std::size_t row, std::string_view name) const {
  const int c = column(name);
  if (c < 0 || row >= rows.size() || static_cast<std::size_t>(c) >= rows[row].size())
    return "";
  return rows[row][static_cast<std::size_t>(c)];
}

Table read_csv_table(const std::string& path) {
  std::ifstream in(path);
  if (!in)
    throw InputFileError(path + ": cannot open file");
  Table table;
  table.path = path;
  std::string line;
  int line_no = 0;
  bool header_read = false;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r')
      line.pop_back();
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#')
      continue;  // blank lines and comments
    auto fields = split_line(t);
    const std::string where = path + ":" + std::to_string(line_no) + ": ";
    if (!header_read) {
      for (std::size_t i = 0; i < fields.size(); ++i) {
        if (fields[i].empty())
          throw InputFileError(where + "header column " + std::to_string(i + 1) + " is empty");
        for (std::size_t k = 0; k < i; ++k) {
          if (fields[k] == fields[i])
            throw InputFileError(where + "duplicate column '" + fields[i] + "' in the header");
        }
      }
      table.header = std::move(fields);
      rename_deprecated_columns(table);
      header_read = true;
      continue;
    }
    if (fields.size() != table.header.size()) {
      throw InputFileError(where + "expected " + std::to_string(table.header.size()) +
                           " comma-separated fields (as in the header), found " +
                           std::to_string(fields.size()));
    }
    table.rows.push_back(std::move(fields));
    table.lines.push_back(line_no);
  }
  if (!header_read)
    throw InputFileError(path + ": empty file (no header line)");
  return table;
}

std::string csv_cell(std::string text) {
  for (char& c : text) {
    if (c == ',' || c == '\n' || c == '\r' || c == '"')
      c = ';';
  }
  return text;
}

void write_csv_table(const std::string& path, const std::vector<std::string>& header,
                     const std::vector<std::vector<std::string>>& rows) {
  std::ostringstream os;
  for (std::size_t i = 0; i < header.size(); ++i)
    os << (i ? "," : "") << header[i];
  os << "\n";
  for (const auto& cells : rows) {
    for (std::size_t i = 0; i < cells.size(); ++i)
      os << (i ? "," : "") << cells[i];
    os << "\n";
  }
  write_text_atomically(path, os.str());
}

void write_h5_table(H5Writer& w, const std::string& group, const std::vector<std::string>& header,
                    const std::vector<std::vector<std::string>>& rows) {
  w.group(group, true);  // h5py lists the columns in the table's order
  for (std::size_t c = 0; c < header.size(); ++c) {
    std::vector<double> numbers;
    std::vector<std::string> cells;
    bool numeric = !rows.empty();
    for (const auto& row : rows) {
      const std::string& cell = row[c];
      cells.push_back(cell);
      if (cell.empty()) {
        numbers.push_back(std::nan(""));
        continue;
      }
      char* end = nullptr;
      const double v = std::strtod(cell.c_str(), &end);
      numeric = numeric && end && *end == '\0';
      numbers.push_back(v);
    }
    if (numeric)
      w.dataset(group + "/" + header[c], numbers);
    else
      w.dataset(group + "/" + header[c], cells);
  }
  w.attr(group, "columns", header);
  w.attr(group, "rows", static_cast<std::int64_t>(rows.size()));
}

void write_h5_table(const std::string& path, const std::vector<std::string>& header,
                    const std::vector<std::vector<std::string>>& rows) {
  H5Writer w(path, ".tmp." + std::to_string(::getpid()));
  write_h5_table(w, "/table", header, rows);
  w.commit();
}

}  // namespace jamflow
