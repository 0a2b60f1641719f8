// What the command lines do with a CLI11 parse error (header only; for targets that use
// CLI11): --help and --help-all print and exit 0, everything else is bad usage, reported on
// one line with exit status 2 (README "Exit status").
#pragma once
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <string>

namespace jamflow {

// The message with line breaks turned into spaces: errors are one line on stderr.
inline std::string one_line(std::string text) {
  for (char& c : text) {
    if (c == '\n' || c == '\r')
      c = ' ';
  }
  while (!text.empty() && text.back() == ' ')
    text.pop_back();
  return text;
}

// For options that name a file or folder: given as '' (a shell variable that was not set), the
// option would silently fall back to its default, so it is refused.
inline CLI::Validator non_empty_path() {
  return CLI::Validator(
      [](std::string& value) {
        return value.empty() ? std::string("'' is empty; allowed a file or folder name")
                             : std::string();
      },
      "PATH");
}

// For --reuse DIR (`jamflow sweep`, `jamflow study`): an existing folder of other sweeps.
inline CLI::Validator reuse_folder() {
  return CLI::Validator(
      [](std::string& dir) {
        std::error_code ec;
        return std::filesystem::is_directory(dir, ec)
                   ? std::string()
                   : "'" + dir + "' is not a folder; allowed a folder of other sweeps";
      },
      "DIR");
}

inline int parse_error_exit(const CLI::App& app, const CLI::ParseError& e, const char* program) {
  if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success))
    return app.exit(e);  // help or version: printed to stdout
  std::fprintf(stderr, "%s: error: %s (see `%s --help`)\n", program, one_line(e.what()).c_str(),
               program);
  return 2;
}

}  // namespace jamflow
