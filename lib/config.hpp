// Scene files: TOML parsed and validated in one place into plain numbers.
//
// Every read goes through a ConfigSection, which checks type and range and remembers which
// keys were used; finish() turns any key nobody read into an error. So a scene gets exactly
// the parts it names, and a misspelt key never passes silently.
#pragma once
#include <cstdint>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include <toml++/toml.h>

namespace jamflow {

struct Range {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;  // lo excluded
  bool hi_open = false;  // hi excluded
  static Range positive() { return {0.0, std::numeric_limits<double>::infinity(), true, false}; }
  static Range non_negative() { return {0.0, std::numeric_limits<double>::infinity()}; }
  bool contains(double v) const;
  std::string text() const;
};

class ConfigSection {
 public:
  ConfigSection(std::string name, const toml::table* table);

  const std::string& name() const { return name_; }
  bool present() const { return table_ != nullptr; }
  bool has(std::string_view key) const;

  double number(std::string_view key, Range range);
  double number(std::string_view key, double fallback, Range range);
  std::int64_t integer(std::string_view key, std::int64_t lo, std::int64_t hi);
  std::int64_t integer(std::string_view key, std::int64_t fallback, std::int64_t lo,
                       std::int64_t hi);
  std::string choice(std::string_view key, const std::vector<std::string>& allowed);
  std::string choice(std::string_view key, std::string_view fallback,
                     const std::vector<std::string>& allowed);
  std::string text(std::string_view key, std::string_view fallback);
  // A number in `range`, or the text "auto" (then empty).
  std::optional<double> number_or_auto(std::string_view key, Range range);
  bool flag(std::string_view key, bool fallback);

  // Error for any key that was never read.
  void finish() const;

  // "[section] key = value": how errors name a setting.
  std::string label(std::string_view key) const;

 private:
  const toml::node* node(std::string_view key) const;
  std::string name_;
  const toml::table* table_;
  std::set<std::string, std::less<>> used_;
};

class Scene {
 public:
  // Parses TOML text; errors name the source and the line.
  static Scene parse(std::string_view text, std::string_view source);
  // A scene file that cannot be opened or read is an InputFileError.
  static Scene load(const std::string& path);

  // Applies "section.key=value" (the value is read as TOML, else as a string).
  void set(std::string_view assignment);
  // Sets "section.key" to a typed TOML value (no text round trip: doubles stay exact).
  void set_value(std::string_view key_path, const toml::node& value);
  // Sections must be among these; each gets its ConfigSection.
  void check_sections(const std::vector<std::string>& allowed) const;
  ConfigSection section(const std::string& name) const;
  bool has_section(const std::string& name) const;
  // The section as a table (nullptr if absent or not a table), and replacing it whole with
  // typed values (no text round trip: doubles stay exact).
  const toml::table* table(const std::string& name) const;
  void set_section(const std::string& name, toml::table table);

  std::string text() const;  // canonical TOML after overrides: what goes into outputs
  // The text as jamflow 0.1.0 printed it (toml++'s 17-digit floats), from which checkpoint
  // digests are computed: the same for a scene however its file prints the floats. Never
  // change it, or checkpoints written before stop resuming.
  std::string legacy_text() const;
  const std::string& source() const { return source_; }

 private:
  toml::table table_;
  std::string source_;
};

// Formats a double for messages (shortest round-trip form).
std::string fmt(double v);
// Scene text as Scene::text() prints it, for comparing scenes across printing styles; empty if
// the text is not TOML.
std::string canonical_scene_text(std::string_view text);
// A double as a TOML float in its shortest round-trip form: 0.1, 1e-05, 3.0, inf, nan.
std::string toml_float(double v);
// TOML text of a table as toml++ lays it out, with every float in its shortest round-trip form
// (dt = 0.1, not 0.10000000000000001): scenes, sweep files and manifests that jamflow writes.
std::string toml_text(const toml::table& table);

}  // namespace jamflow
