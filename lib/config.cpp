// Scene parsing and validation.
#include "lib/config.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "lib/error.hpp"

namespace jamflow {

std::string fmt(double v) {
  char buf[64];
  auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  return ec == std::errc() ? std::string(buf, end) : std::to_string(v);
}

bool Range::contains(double v) const {
  if (!std::isfinite(v))
    return false;
  if (lo_open ? !(v > lo) : !(v >= lo))
    return false;
  if (hi_open ? !(v < hi) : !(v <= hi))
    return false;
  return true;
}

std::string Range::text() const {
  const bool no_lo = std::isinf(lo), no_hi = std::isinf(hi);
  if (no_lo && no_hi)
    return "any finite number";
  if (no_hi)
    return std::string(lo_open ? "> " : ">= ") + fmt(lo);
  if (no_lo)
    return std::string(hi_open ? "< " : "<= ") + fmt(hi);
  return std::string(lo_open ? "(" : "[") + fmt(lo) + ", " + fmt(hi) + (hi_open ? ")" : "]");
}

ConfigSection::ConfigSection(std::string name, const toml::table* table)
    : name_(std::move(name)), table_(table) {}

const toml::node* ConfigSection::node(std::string_view key) const {
  return table_ ? table_->get(key) : nullptr;
}

bool ConfigSection::has(std::string_view key) const {
  return node(key) != nullptr;
}

std::string ConfigSection::label(std::string_view key) const {
  return "[" + name_ + "] " + std::string(key);
}

namespace {

// Where toml++ 3.3 (Debian 12) would classify a non-ASCII character as whitespace or not: its
// table of non-ASCII whitespace reaches __builtin_unreachable for most code points (upstream
// issue #190), i.e. undefined behaviour in the parser, found by fuzz_scene. That happens for a
// non-ASCII character outside strings and comments (never valid TOML 1.0: bare keys, numbers,
// booleans and dates are ASCII) and right after a backslash in a basic string (escapes are
// ASCII too), and also inside a value the parser scans as a bare word (a number, date or
// boolean, up to the next whitespace, ']', '}', ',' or '#'): there a quote does not open a
// string. Returns the 1-based line of the first such character and what it follows, or line
// 0 if there is none; non-ASCII text in strings and comments is fine.
std::pair<std::size_t, const char*> unsafe_non_ascii(std::string_view t) {
  enum class In { kCode, kComment, kBasic, kLiteral, kMultiBasic, kMultiLiteral } in = In::kCode;
  std::size_t line = 1;
  std::size_t i = t.substr(0, 3) == "\xEF\xBB\xBF" ? 3 : 0;  // a UTF-8 byte order mark
  auto high = [](char c) { return static_cast<unsigned char>(c) >= 0x80; };
  auto at = [&](std::size_t k, std::string_view s) { return t.substr(k, s.size()) == s; };
  bool value_next = false;  // after '=', or '[' and ',' in an array: a value starts here
  bool bare = false;        // inside a value scanned as a bare word
  std::string open;         // the '[' of arrays and '{' of inline tables, innermost last
  for (; i < t.size(); ++i) {
    const char c = t[i];
    if (c == '\n')
      ++line;
    switch (in) {
      case In::kCode:
        if (high(c))
          return {line, "outside a string or comment"};
        if (bare) {
          if (c != ' ' && c != '\t' && c != '\r' && c != '\n' && c != ']' && c != '}' && c != ',' &&
              c != '#')
            break;  // quotes too are characters of the word
          bare = false;
        }
        if (c == '#') {
          in = In::kComment;
        } else if (c == '"') {
          in = at(i, "\"\"\"") ? In::kMultiBasic : In::kBasic;
          i += in == In::kMultiBasic ? 2 : 0;
          value_next = false;
        } else if (c == '\'') {
          in = at(i, "'''") ? In::kMultiLiteral : In::kLiteral;
          i += in == In::kMultiLiteral ? 2 : 0;
          value_next = false;
        } else if (c == '=') {
          value_next = true;
        } else if (c == '[') {
          if (value_next || (!open.empty() && open.back() == '['))
            open += '[';  // an array (else a table header)
          value_next = !open.empty() && open.back() == '[';
        } else if (c == '{') {
          open += '{';
          value_next = false;
        } else if (c == ']' || c == '}') {
          if (!open.empty())
            open.pop_back();
          value_next = false;
        } else if (c == ',') {
          value_next = !open.empty() && open.back() == '[';
        } else if (c != ' ' && c != '\t' && c != '\r' && c != '\n' && value_next) {
          bare = true;
          value_next = false;
        }
        break;
      case In::kComment:
        if (c == '\n')
          in = In::kCode;
        break;
      case In::kLiteral:
        if (c == '\'' || c == '\n')
          in = In::kCode;
        break;
      case In::kBasic:
      case In::kMultiBasic:
        if (c == '\\') {
          // An escape, or (multi-line) a line-ending backslash: the parser then skips
          // whitespace and line breaks and looks at the first character after them.
          std::size_t k = i + 1;
          while (k < t.size() && (t[k] == ' ' || t[k] == '\t' || t[k] == '\r' ||
                                  (in == In::kMultiBasic && t[k] == '\n'))) {
            line += t[k] == '\n' ? 1 : 0;
            ++k;
          }
          if (k < t.size() && high(t[k]))
            return {line, "right after a backslash in a string"};
          i = k > i + 1 ? k - 1 : k;  // an escaped character is not a closing quote
        } else if (in == In::kBasic && (c == '"' || c == '\n')) {
          in = In::kCode;
        } else if (in == In::kMultiBasic && at(i, "\"\"\"")) {
          i += 2;
          while (i + 1 < t.size() && t[i + 1] == '"')  // up to two quotes end the string
            ++i;
          in = In::kCode;
        }
        break;
      case In::kMultiLiteral:
        if (at(i, "'''")) {
          i += 2;
          while (i + 1 < t.size() && t[i + 1] == '\'')
            ++i;
          in = In::kCode;
        }
        break;
    }
  }
  return {0, ""};
}

std::string show(const toml::node& n) {
  std::ostringstream os;
  if (n.is_string()) {
    os << '"' << n.as_string()->get() << '"';
  } else if (n.is_table()) {
    os << "{...}";
  } else if (n.is_array()) {
    os << "[...]";
  } else {
    n.visit([&](auto&& v) {
      if constexpr (toml::is_number<decltype(v)> || toml::is_boolean<decltype(v)>)
        os << v;
    });
  }
  return os.str();
}
}  // namespace

double ConfigSection::number(std::string_view key, Range range) {
  const toml::node* n = node(key);
  if (!n)
    throw ConfigError("missing key " + label(key) + "; allowed " + range.text());
  used_.emplace(key);
  if (!n->is_number()) {
    throw ConfigError(label(key) + " = " + show(*n) + " is not a number; allowed " + range.text());
  }
  const double v = n->value<double>().value();
  if (!range.contains(v)) {
    throw ConfigError(label(key) + " = " + fmt(v) + " is out of range; allowed " + range.text());
  }
  return v;
}

std::optional<double> ConfigSection::number_or_auto(std::string_view key, Range range) {
  const toml::node* n = node(key);
  if (n && n->is_string()) {
    used_.emplace(key);
    if (n->value<std::string>().value() == "auto")
      return std::nullopt;
    throw ConfigError(label(key) + " = " + show(*n) + " is not allowed; allowed " + range.text() +
                      " or \"auto\"");
  }
  if (n && !n->is_number()) {
    used_.emplace(key);
    throw ConfigError(label(key) + " = " + show(*n) + " is not a number; allowed " + range.text() +
                      " or \"auto\"");
  }
  return number(key, range);
}

double ConfigSection::number(std::string_view key, double fallback, Range range) {
  return has(key) ? number(key, range) : fallback;
}

std::int64_t ConfigSection::integer(std::string_view key, std::int64_t lo, std::int64_t hi) {
  const toml::node* n = node(key);
  const std::string allowed =
      "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  if (!n)
    throw ConfigError("missing key " + label(key) + "; allowed " + allowed);
  used_.emplace(key);
  std::int64_t v = 0;
  if (n->is_integer()) {
    v = n->as_integer()->get();
  } else if (n->is_floating_point() &&
             std::nearbyint(n->as_floating_point()->get()) == n->as_floating_point()->get() &&
             std::abs(n->as_floating_point()->get()) < 9e15) {
    v = static_cast<std::int64_t>(n->as_floating_point()->get());
  } else {
    throw ConfigError(label(key) + " = " + show(*n) + " is not an integer; allowed " + allowed);
  }
  if (v < lo || v > hi) {
    throw ConfigError(label(key) + " = " + std::to_string(v) + " is out of range; allowed " +
                      allowed);
  }
  return v;
}

std::int64_t ConfigSection::integer(std::string_view key, std::int64_t fallback, std::int64_t lo,
                                    std::int64_t hi) {
  return has(key) ? integer(key, lo, hi) : fallback;
}

std::string ConfigSection::choice(std::string_view key, const std::vector<std::string>& allowed) {
  std::string list;
  for (const auto& a : allowed)
    list += (list.empty() ? "\"" : ", \"") + a + "\"";
  const toml::node* n = node(key);
  if (!n)
    throw ConfigError("missing key " + label(key) + "; allowed " + list);
  used_.emplace(key);
  if (!n->is_string()) {
    throw ConfigError(label(key) + " = " + show(*n) + " is not a string; allowed " + list);
  }
  const std::string v = n->as_string()->get();
  for (const auto& a : allowed) {
    if (a == v)
      return v;
  }
  throw ConfigError(label(key) + " = \"" + v + "\" is not allowed; allowed " + list);
}

std::string ConfigSection::choice(std::string_view key, std::string_view fallback,
                                  const std::vector<std::string>& allowed) {
  return has(key) ? choice(key, allowed) : std::string(fallback);
}

std::string ConfigSection::text(std::string_view key, std::string_view fallback) {
  const toml::node* n = node(key);
  if (!n)
    return std::string(fallback);
  used_.emplace(key);
  if (!n->is_string()) {
    throw ConfigError(label(key) + " = " + show(*n) + " is not a string; allowed a quoted path");
  }
  return n->as_string()->get();
}

bool ConfigSection::flag(std::string_view key, bool fallback) {
  const toml::node* n = node(key);
  if (!n)
    return fallback;
  used_.emplace(key);
  if (!n->is_boolean()) {
    throw ConfigError(label(key) + " = " + show(*n) + " is not a boolean; allowed true, false");
  }
  return n->as_boolean()->get();
}

void ConfigSection::finish() const {
  if (!table_)
    return;
  for (const auto& [k, v] : *table_) {
    if (!used_.contains(k.str())) {
      std::string list;
      for (const auto& u : used_)
        list += (list.empty() ? "" : ", ") + u;
      throw ConfigError("unknown key " + label(k.str()) + " = " + show(v) +
                        "; keys used in this section here: " + (list.empty() ? "none" : list));
    }
  }
}

Scene Scene::parse(std::string_view text, std::string_view source) {
  Scene s;
  s.source_ = std::string(source);
  if (const auto [line, where] = unsafe_non_ascii(text); line > 0) {
    throw ConfigError(std::string(source) + ":" + std::to_string(line) + ": non-ASCII character " +
                      where +
                      "; allowed: ASCII there (keys, numbers, booleans, dates and escapes); "
                      "any text inside quoted strings and comments");
  }
  try {
    s.table_ = toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    throw ConfigError(std::string(source) + ":" + std::to_string(e.source().begin.line) + ": " +
                      std::string(e.description()));
  }
  return s;
}

Scene Scene::load(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputFileError("scene file '" + path + "' is a directory; allowed: a TOML file");
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw InputFileError("cannot open scene file '" + path + "': " + std::strerror(errno) +
                         "; allowed: a readable TOML file");
  }
  std::ostringstream buf;
  buf << in.rdbuf();
  if (in.bad())
    throw InputFileError("cannot read scene file '" + path + "'; allowed: a readable TOML file");
  return parse(buf.str(), path);
}

void Scene::set(std::string_view assignment) {
  const auto eq = assignment.find('=');
  const auto dot = assignment.substr(0, eq).find('.');
  if (eq == std::string_view::npos || dot == std::string_view::npos || dot == 0 || dot + 1 >= eq) {
    throw ConfigError("--set '" + std::string(assignment) +
                      "' must look like section.key=value (e.g. shear.rate=1e-4)");
  }
  const std::string section(assignment.substr(0, dot));
  const std::string key(assignment.substr(dot + 1, eq - dot - 1));
  const std::string value(assignment.substr(eq + 1));
  toml::table parsed;
  bool typed = false;
  const std::string as_toml = "v = " + value;
  if (unsafe_non_ascii(as_toml).first == 0) {  // else not TOML, and unsafe for toml++ 3.3
    try {
      parsed = toml::parse(as_toml);
      typed = true;
    } catch (const toml::parse_error&) {
    }
  }
  if (!typed)
    parsed = toml::table{{"v", value}};  // bare word: a string
  set_value(section + "." + key, *parsed.get("v"));
}

void Scene::set_value(std::string_view key_path, const toml::node& value) {
  const auto dot = key_path.find('.');
  if (dot == std::string_view::npos || dot == 0 || dot + 1 >= key_path.size())
    throw ConfigError("'" + std::string(key_path) + "' must look like section.key");
  const std::string section(key_path.substr(0, dot));
  const std::string key(key_path.substr(dot + 1));
  toml::table* sec = table_[section].as_table();
  if (!sec) {
    if (table_.contains(section))
      throw ConfigError("--set: '" + section + "' is not a section");
    table_.insert(section, toml::table{});
    sec = table_[section].as_table();
  }
  sec->insert_or_assign(key, value);
}

void Scene::check_sections(const std::vector<std::string>& allowed) const {
  for (const auto& [k, v] : table_) {
    bool ok = false;
    for (const auto& a : allowed)
      ok = ok || a == k.str();
    std::string list;
    for (const auto& a : allowed)
      list += (list.empty() ? "[" : ", [") + a + "]";
    if (!ok)
      throw ConfigError("unknown section [" + std::string(k.str()) + "]; allowed " + list);
    if (!v.is_table()) {
      throw ConfigError("'" + std::string(k.str()) + "' must be a section [" +
                        std::string(k.str()) + "]");
    }
  }
}

bool Scene::has_section(const std::string& name) const {
  return table_.contains(name);
}

ConfigSection Scene::section(const std::string& name) const {
  const toml::node* n = table_.get(name);
  return ConfigSection(name, n ? n->as_table() : nullptr);
}

const toml::table* Scene::table(const std::string& name) const {
  const toml::node* n = table_.get(name);
  return n ? n->as_table() : nullptr;
}

void Scene::set_section(const std::string& name, toml::table table) {
  table_.insert_or_assign(name, std::move(table));
}

namespace {

// toml++ 3.3, as Debian builds it (without floating-point to_chars), prints a double with 17
// significant digits: dt = 0.10000000000000001. toml_text() lets it lay the table out and
// puts in each float in its shortest form that reads back to the same double (std::to_chars),
// by printing a copy whose floats are marker strings and replacing the markers.
constexpr std::string_view kFloatMarker = "@jamflow-float-";

bool has_marker(const toml::node& n) {
  if (const auto* s = n.as_string())
    return s->get().find(kFloatMarker) != std::string::npos;
  if (const auto* t = n.as_table()) {
    for (const auto& [k, v] : *t)
      if (k.str().find(kFloatMarker) != std::string_view::npos || has_marker(v))
        return true;
  }
  if (const auto* a = n.as_array()) {
    for (const auto& v : *a)
      if (has_marker(v))
        return true;
  }
  return false;
}

std::string marker(std::size_t k) {
  return std::string(kFloatMarker) + std::to_string(k) + "@";
}

void mark_floats(toml::node& n, std::vector<double>& floats) {
  if (auto* t = n.as_table()) {
    for (auto&& [k, v] : *t) {
      if (const auto* d = v.as_floating_point()) {
        floats.push_back(d->get());
        t->insert_or_assign(k, marker(floats.size() - 1));
      } else {
        mark_floats(v, floats);
      }
    }
  } else if (auto* a = n.as_array()) {
    for (std::size_t i = 0; i < a->size(); ++i) {
      if (const auto* d = a->get(i)->as_floating_point()) {
        floats.push_back(d->get());
        a->replace(a->cbegin() + static_cast<std::ptrdiff_t>(i), marker(floats.size() - 1));
      } else {
        mark_floats(*a->get(i), floats);
      }
    }
  }
}

}  // namespace

std::string toml_float(double v) {
  if (std::isnan(v))
    return "nan";
  if (std::isinf(v))
    return v > 0 ? "inf" : "-inf";
  // The shortest digits that read back to v (std::to_chars), written as Python's repr writes
  // them: positional for decimal exponents -4 to 15 (0.0002, 30000.0), else with an exponent
  // (1e-05, 1e+16).
  char buf[400];  // fixed notation of an exponent up to 15, or scientific: far less
  char* end = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::scientific).ptr;
  const char* e = std::find(buf, end, 'e');
  int exponent = 0;
  if (e != end)
    std::from_chars(e + 1 + (e[1] == '+'), end, exponent);
  if (exponent < -4 || exponent >= 16)
    return std::string(buf, end);
  end = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed).ptr;
  std::string s(buf, end);
  if (s.find('.') == std::string::npos)
    s += ".0";  // 3 would read back as an integer
  return s;
}

std::string toml_text(const toml::table& table) {
  std::ostringstream os;
  if (has_marker(table)) {  // a string that looks like a marker: printed as toml++ does
    os << table;
    return os.str();
  }
  toml::table copy = table;
  std::vector<double> floats;
  mark_floats(copy, floats);
  os << copy;
  std::string text = os.str();
  // Each marker is printed once, as a quoted string ('...' or "..."), where toml++ lays out its
  // float (not in the order of marking: a table's values come before its sub-tables).
  std::string out;
  out.reserve(text.size());
  std::size_t done = 0, replaced = 0;
  for (std::size_t at = text.find(kFloatMarker); at != std::string::npos;
       at = text.find(kFloatMarker, done)) {
    const std::size_t digits = at + kFloatMarker.size();
    std::size_t k = 0;
    const auto [end, ec] = std::from_chars(text.data() + digits, text.data() + text.size(), k);
    const std::size_t close = static_cast<std::size_t>(end - text.data());
    if (ec != std::errc() || k >= floats.size() || at == 0 || close + 1 >= text.size() ||
        text[close] != '@' || text[close + 1] != text[at - 1])
      throw std::logic_error("toml_text: a float marker was printed unexpectedly");
    out.append(text, done, at - 1 - done).append(toml_float(floats[k]));
    done = close + 2;
    ++replaced;
  }
  if (replaced != floats.size())
    throw std::logic_error("toml_text: a float marker was not printed");
  out.append(text, done, std::string::npos);
  return out;
}

std::string Scene::text() const {
  return toml_text(table_) + "\n";
}

std::string canonical_scene_text(std::string_view text) {
  try {
    return Scene::parse(text, "scene").text();
  } catch (const std::exception&) {
    return {};
  }
}

std::string Scene::legacy_text() const {
  std::ostringstream os;
  os << table_ << "\n";
  return os.str();
}

}  // namespace jamflow
