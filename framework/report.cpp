// What the study framework and the studies share to write reports.
#include "framework/report.hpp"

#include <cstdio>
#include <filesystem>
#include <sstream>

#include "analysis/plots.hpp"
#include "analysis/report.hpp"
#include "lib/data_files.hpp"
#include "lib/error.hpp"
#include "lib/text_file.hpp"

#ifndef JAMFLOW_STUDIES_DIR
#define JAMFLOW_STUDIES_DIR "studies"
#endif

namespace jamflow::studies {

std::string markdown_table(const std::vector<std::string>& header,
                           const std::vector<std::vector<std::string>>& rows) {
  std::ostringstream os;
  os << "|";
  for (const auto& h : header)
    os << " " << analysis::markdown_cell(h) << " |";
  os << "\n|";
  for (std::size_t k = 0; k < header.size(); ++k)
    os << "---|";
  os << "\n";
  for (const auto& r : rows) {
    os << "|";
    for (const auto& c : r)
      os << " " << analysis::markdown_cell(c) << " |";
    os << "\n";
  }
  return os.str();
}

std::string num(double value, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, value);
  return buf;
}

std::string join(const std::vector<std::string>& items) {
  std::string s;
  for (const auto& x : items)
    s += (s.empty() ? "" : ", ") + x;
  return s;
}

std::string pm(double value, double error, int digits) {
  return num(value, digits) + " ± " + num(error, 2);
}

bool run_plot(const std::string& script, const std::vector<std::string>& args,
              const StudyOptions& options) {
  if (options.no_plots)
    return false;
  const analysis::PlotOutcome o =
      analysis::run_python_plot(studies_data_dir() + "/" + script, args);
  if (o.status != analysis::PlotStatus::kOk) {
    std::fprintf(stderr, "warning: %s; data and tables are written\n", o.message.c_str());
    return false;
  }
  return true;
}

std::string studies_data_dir() {
  return data_dir("studies", JAMFLOW_STUDIES_DIR);
}

void ensure_dir(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec)
    throw IoError("cannot create folder '" + dir + "': " + ec.message());
}

void write_text(const std::string& path, const std::string& text) {
  write_text_atomically(path, text);
}

}  // namespace jamflow::studies
