// Extended XYZ reader and writer (lib/xyz.hpp): the Lees–Edwards cell as the Lattice key,
// real-space positions and radii, one frame.
#include "lib/xyz.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <optional>
#include <ostream>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "lib/error.hpp"
#include "lib/neighbour_list.hpp"

namespace jamflow {

namespace {

// Shortest representation that reads back to the same double.
void append_number(std::string& out, double v) {
  std::array<char, 32> buf;
  const auto res = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  out.append(buf.data(), res.ptr);
}

std::string lower(std::string_view s) {
  std::string r(s);
  for (char& c : r)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return r;
}

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n';
}

std::vector<std::string_view> split_ws(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && is_space(s[i]))
      ++i;
    const std::size_t start = i;
    while (i < s.size() && !is_space(s[i]))
      ++i;
    if (i > start)
      out.push_back(s.substr(start, i - start));
  }
  return out;
}

// Whole-token parse: "1.5abc" is not a number. from_chars rejects a leading '+', which is
// legal in the files other tools write, so skip it.
std::optional<double> parse_double(std::string_view s) {
  if (s.size() > 1 && s[0] == '+' && s[1] != '-')
    s.remove_prefix(1);
  double v = 0.0;
  const auto res = std::from_chars(s.data(), s.data() + s.size(), v);
  if (res.ec != std::errc() || res.ptr != s.data() + s.size())
    return std::nullopt;
  return v;
}

std::optional<long long> parse_int(std::string_view s) {
  if (s.size() > 1 && s[0] == '+' && s[1] != '-')
    s.remove_prefix(1);
  long long v = 0;
  const auto res = std::from_chars(s.data(), s.data() + s.size(), v);
  if (res.ec != std::errc() || res.ptr != s.data() + s.size())
    return std::nullopt;
  return v;
}

std::string fmt_radius(double v) {
  std::string out;
  append_number(out, v);
  return out;
}

std::string shorten(std::string_view s) {
  constexpr std::size_t kMax = 60;
  if (s.size() <= kMax)
    return std::string(s);
  return std::string(s.substr(0, kMax)) + "...";
}

class Parser {
 public:
  explicit Parser(std::string path) : path_(std::move(path)) {}

  [[noreturn]] void fail(std::size_t line, const std::string& what) const {
    throw ConfigError(path_ + ":" + std::to_string(line) + ": " + what);
  }

  // The comment line: key=value pairs, values optionally in double quotes. A bare key (ASE
  // writes e.g. "pbc" flags that way) gets an empty value.
  std::vector<std::pair<std::string, std::string>> key_values(std::string_view s) const {
    std::vector<std::pair<std::string, std::string>> out;
    std::size_t i = 0;
    while (true) {
      while (i < s.size() && is_space(s[i]))
        ++i;
      if (i >= s.size())
        break;
      const std::size_t key_start = i;
      while (i < s.size() && !is_space(s[i]) && s[i] != '=')
        ++i;
      std::string key(s.substr(key_start, i - key_start));
      if (key.empty())
        fail(2, "expected key=value, got '" + shorten(s.substr(key_start)) + "'");
      std::string value;
      if (i < s.size() && s[i] == '=') {
        ++i;
        if (i < s.size() && s[i] == '"') {
          const std::size_t close = s.find('"', i + 1);
          if (close == std::string_view::npos) {
            fail(2, "unterminated quoted value of key '" + key + "'");
          }
          value = std::string(s.substr(i + 1, close - i - 1));
          i = close + 1;
        } else {
          const std::size_t start = i;
          while (i < s.size() && !is_space(s[i]))
            ++i;
          value = std::string(s.substr(start, i - start));
        }
      }
      out.emplace_back(std::move(key), std::move(value));
    }
    return out;
  }

 private:
  std::string path_;
};

bool blank(std::string_view s) {
  return std::all_of(s.begin(), s.end(), is_space);
}

// At most this many columns per row (over all Properties entries): a count of 10^9 would
// otherwise allocate the column table before the first row is read.
constexpr long long kMaxColumns = 1000;

// Scaled coordinates beyond this many cell lengths are refused: they carry no digits of the
// position inside the cell, and their image counters would overflow.
constexpr double kMaxCellLengths = 1e6;

struct Column {
  std::string name;  // as reported in errors: "pos y", "radius", "id"
  enum class Role { kSkip, kPosX, kPosY, kPosZ, kRadius } role = Role::kSkip;
};

}  // namespace

State read_xyz(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputFileError(path + ": is a directory, not a file");
  // A device or pipe has no size to check the count against, and /dev/zero has no line end.
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec))
    throw InputFileError(path + ": is not a regular file; allowed: an extended XYZ file");
  std::ifstream in(path);
  if (!in)
    throw InputFileError(path + ": cannot open for reading: " + std::strerror(errno));
  const Parser p(path);

  std::string line;
  std::size_t line_no = 0;
  std::uintmax_t consumed = 0;  // bytes read so far, line ends included
  auto next_line = [&]() -> bool {
    if (!std::getline(in, line))
      return false;
    ++line_no;
    consumed += line.size() + 1;
    if (!line.empty() && line.back() == '\r')
      line.pop_back();  // files from Windows tools
    return true;
  };

  if (!next_line())
    p.fail(1, "empty file: expected the particle count on line 1");
  const auto tokens1 = split_ws(line);
  const auto n_parsed = tokens1.size() == 1 ? parse_int(tokens1[0]) : std::nullopt;
  if (!n_parsed || *n_parsed <= 0) {
    p.fail(1, "expected the particle count (a positive integer), got '" + shorten(line) + "'");
  }
  if (*n_parsed > static_cast<long long>(NeighbourList::kMaxParticles)) {
    p.fail(1, "particle count = " + std::to_string(*n_parsed) + " is too large; allowed: 1 to " +
                  std::to_string(NeighbourList::kMaxParticles) + " (the neighbour-list limit)");
  }
  const auto n = static_cast<std::size_t>(*n_parsed);

  if (!next_line())
    p.fail(2, "missing the comment line with Lattice= and Properties=");
  std::optional<std::string> lattice_text, properties_text, time_text, strain_text, pbc_text;
  for (auto& [key, value] : p.key_values(line)) {
    const std::string k = lower(key);
    if (k == "lattice")
      lattice_text = value;
    if (k == "properties")
      properties_text = value;
    if (k == "time")
      time_text = value;
    if (k == "strain")
      strain_text = value;
    if (k == "pbc")
      pbc_text = value;
  }

  // Lees-Edwards cells are periodic in all three directions; a file meant for open
  // boundaries would silently become a periodic system.
  if (pbc_text) {
    const auto flags = split_ws(*pbc_text);
    const bool all_periodic =
        flags.size() == 3 && std::all_of(flags.begin(), flags.end(), [](std::string_view f) {
          return lower(f) == "t" || lower(f) == "true";
        });
    if (!all_periodic) {
      p.fail(2, "pbc=\"" + shorten(*pbc_text) +
                    "\" is not allowed; allowed: pbc=\"T T T\" (periodic in x, y and z) or no pbc");
    }
  }

  // Cell.
  if (!lattice_text)
    p.fail(2, "missing Lattice=\"ax ay az bx by bz cx cy cz\"");
  const auto lattice_tokens = split_ws(*lattice_text);
  if (lattice_tokens.size() != 9) {
    p.fail(2, "Lattice must have 9 numbers, got " + std::to_string(lattice_tokens.size()));
  }
  std::array<double, 9> lat{};
  for (std::size_t k = 0; k < 9; ++k) {
    const auto v = parse_double(lattice_tokens[k]);
    if (!v || !std::isfinite(*v)) {
      p.fail(2, "Lattice entry " + std::to_string(k + 1) + " is not a finite number: '" +
                    std::string(lattice_tokens[k]) + "'");
    }
    lat[k] = *v;
  }
  {
    const double scale = std::max({std::abs(lat[0]), std::abs(lat[4]), std::abs(lat[8])});
    const double tol = 1e-12 * scale;
    const bool le_form = lat[0] > 0.0 && lat[4] > 0.0 && lat[8] > 0.0 && std::abs(lat[1]) <= tol &&
                         std::abs(lat[2]) <= tol && std::abs(lat[5]) <= tol &&
                         std::abs(lat[6]) <= tol && std::abs(lat[7]) <= tol;
    if (!le_form) {
      p.fail(2, "Lattice=\"" + *lattice_text +
                    "\" is not a Lees-Edwards cell; allowed: a = (Lx 0 0), b = (xy Ly 0), "
                    "c = (0 0 Lz) with Lx, Ly, Lz > 0");
    }
  }

  // Columns.
  if (!properties_text)
    p.fail(2, "missing Properties=species:S:1:pos:R:3:radius:R:1");
  std::vector<Column> columns;
  bool has_species = false, has_pos = false, has_radius = false;
  {
    std::vector<std::string_view> fields;
    std::string_view rest = *properties_text;
    while (true) {
      const std::size_t colon = rest.find(':');
      fields.push_back(rest.substr(0, colon));
      if (colon == std::string_view::npos)
        break;
      rest.remove_prefix(colon + 1);
    }
    if (fields.size() % 3 != 0) {
      p.fail(2, "Properties must be name:type:count triples, got '" + *properties_text + "'");
    }
    for (std::size_t f = 0; f < fields.size(); f += 3) {
      const std::string name(fields[f]);
      const std::string type = lower(fields[f + 1]);
      const auto count = parse_int(fields[f + 2]);
      const std::string spec =
          name + ":" + std::string(fields[f + 1]) + ":" + std::string(fields[f + 2]);
      if (name.empty() || !count || *count <= 0 ||
          (type != "s" && type != "r" && type != "i" && type != "l")) {
        p.fail(2, "malformed Properties entry '" + spec +
                      "'; allowed: name:type:count with type S, R, I or L and count > 0");
      }
      if (*count > kMaxColumns || static_cast<long long>(columns.size()) + *count > kMaxColumns) {
        p.fail(2, "Properties entry '" + spec + "' makes more than " + std::to_string(kMaxColumns) +
                      " columns; allowed: at most " + std::to_string(kMaxColumns) +
                      " columns in all");
      }
      const std::string key = lower(name);
      auto require = [&](const char* want_type, long long want_count, const char* want) {
        if (type != want_type || *count != want_count) {
          p.fail(2, "Properties entry '" + spec + "' must be " + want);
        }
      };
      if (key == "species") {
        require("s", 1, "species:S:1");
        has_species = true;
        columns.push_back({"species", Column::Role::kSkip});
      } else if (key == "pos") {
        require("r", 3, "pos:R:3");
        has_pos = true;
        columns.push_back({"pos x", Column::Role::kPosX});
        columns.push_back({"pos y", Column::Role::kPosY});
        columns.push_back({"pos z", Column::Role::kPosZ});
      } else if (key == "radius") {
        require("r", 1, "radius:R:1");
        has_radius = true;
        columns.push_back({"radius", Column::Role::kRadius});
      } else {
        for (long long c = 0; c < *count; ++c) {
          columns.push_back(
              {*count == 1 ? name : name + "[" + std::to_string(c) + "]", Column::Role::kSkip});
        }
      }
    }
  }
  if (!has_species || !has_pos || !has_radius) {
    p.fail(2, "Properties=" + *properties_text + " lacks " +
                  (!has_species ? "species:S:1"
                   : !has_pos   ? "pos:R:3"
                                : "radius:R:1") +
                  "; required: species:S:1, pos:R:3 and radius:R:1 (any order)");
  }

  auto header_number = [&](const std::optional<std::string>& text, const char* key) {
    const auto v = parse_double(*text);
    if (!v || !std::isfinite(*v)) {
      p.fail(2, std::string(key) + "= is not a finite number: '" + *text + "'");
    }
    return *v;
  };

  // Each row is at least one character per column, separated by spaces, with a newline: refuse
  // a count the rest of the file cannot hold before allocating for it.
  // (Counted from the lines read: tellg() is -1 once the header line ended the file.)
  {
    std::error_code size_ec;
    const auto file_bytes = std::filesystem::file_size(path, size_ec);
    if (!size_ec) {
      const std::uintmax_t left = file_bytes > consumed ? file_bytes - consumed : 0;
      const std::uintmax_t row_min = 2 * columns.size();
      if (left + 1 < static_cast<std::uintmax_t>(n) * row_min) {
        p.fail(1, "particle count = " + std::to_string(n) + " needs at least " + std::to_string(n) +
                      " rows of " + std::to_string(columns.size()) + " columns, but only " +
                      std::to_string(left) +
                      " bytes follow the header; allowed: the number of particle rows");
      }
    }
  }

  State state;
  state.resize(n);
  state.box.lx = lat[0];
  state.box.ly = lat[4];
  state.box.lz = lat[8];
  const double tilt = lat[3] / lat[4];
  if (strain_text) {
    // Strain is the state variable; the cell only shows it modulo remaps (b -> b - a).
    const double strain = header_number(strain_text, "Strain");
    state.box.strain = strain;
    state.box.flips = std::llround((strain - tilt) * state.box.ly / state.box.lx);
    if (!(std::abs(state.box.tilt() - tilt) <= 1e-9 * std::max(1.0, std::abs(strain)))) {
      p.fail(2, "Strain=" + *strain_text +
                    " does not match the Lattice tilt xy/Ly = " + std::to_string(tilt) +
                    " modulo Lx/Ly = " + std::to_string(state.box.lx / state.box.ly));
    }
  } else {
    state.box.strain = tilt;
    state.box.flips = 0;
  }
  if (time_text)
    state.time = header_number(time_text, "Time");

  const Eigen::Matrix3d h_inv = state.box.h_inv();
  std::vector<std::size_t> row_line(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!next_line()) {
      p.fail(line_no + 1, "expected " + std::to_string(n) +
                              " particle lines, the file ends after " + std::to_string(i));
    }
    const auto tokens = split_ws(line);
    if (tokens.size() != columns.size()) {
      p.fail(line_no, "expected " + std::to_string(columns.size()) + " columns (Properties=" +
                          *properties_text + "), got " + std::to_string(tokens.size()));
    }
    Eigen::Vector3d r = Eigen::Vector3d::Zero();  // every column is set (checked above)
    double radius = 0.0;
    std::size_t radius_column = 0;
    std::array<std::size_t, 3> pos_column{};
    for (std::size_t c = 0; c < columns.size(); ++c) {
      const Column& col = columns[c];
      if (col.role == Column::Role::kSkip)
        continue;
      const std::string where = "column " + std::to_string(c + 1) + " (" + col.name + ")";
      const auto v = parse_double(tokens[c]);
      if (!v)
        p.fail(line_no, where + " is not a number: '" + shorten(tokens[c]) + "'");
      if (!std::isfinite(*v))
        p.fail(line_no, where + " is not finite: '" + shorten(tokens[c]) + "'");
      switch (col.role) {
        case Column::Role::kPosX:
          r.x() = *v;
          pos_column[0] = c;
          break;
        case Column::Role::kPosY:
          r.y() = *v;
          pos_column[1] = c;
          break;
        case Column::Role::kPosZ:
          r.z() = *v;
          pos_column[2] = c;
          break;
        case Column::Role::kRadius:
          radius = *v;
          radius_column = c;
          break;
        case Column::Role::kSkip:
          break;
      }
    }
    // Species from the diameters, not the labels: other tools label the mixture differently.
    // Only the two species of the model exist; a third size is not rounded to the nearer one.
    const double d = 2.0 * radius;
    if (std::abs(d - kSmallDiameter) <= kDiameterTolerance * kSmallDiameter) {
      state.species[i] = 0;
      state.diameter[i] = kSmallDiameter;
    } else if (std::abs(d - kLargeDiameter) <= kDiameterTolerance * kLargeDiameter) {
      state.species[i] = 1;
      state.diameter[i] = kLargeDiameter;
    } else {
      p.fail(line_no, "column " + std::to_string(radius_column + 1) +
                          " (radius) = " + shorten(tokens[radius_column]) +
                          " is not a species radius; allowed: " + fmt_radius(0.5 * kSmallDiameter) +
                          " or " + fmt_radius(0.5 * kLargeDiameter) + " (diameters " +
                          fmt_radius(kSmallDiameter) + " and " + fmt_radius(kLargeDiameter) +
                          ") within a relative " + fmt_radius(kDiameterTolerance));
    }
    const Eigen::Vector3d s = h_inv * r;
    if (!(s.cwiseAbs().maxCoeff() <= kMaxCellLengths)) {
      p.fail(line_no, "position (" + shorten(tokens[pos_column[0]]) + ", " +
                          shorten(tokens[pos_column[1]]) + ", " + shorten(tokens[pos_column[2]]) +
                          ") lies " + fmt_radius(s.cwiseAbs().maxCoeff()) +
                          " cell lengths from the cell; allowed: at most " +
                          fmt_radius(kMaxCellLengths));
    }
    state.x()[i] = s.x();
    state.y()[i] = s.y();
    state.z()[i] = s.z();
    row_line[i] = line_no;
  }

  // Nothing but blank lines may follow: more rows mean the count is wrong, another count
  // line starts a second frame (this reader takes exactly one).
  while (next_line()) {
    if (blank(line))
      continue;
    const std::size_t first_extra = line_no;
    const auto extra = split_ws(line);
    const auto next_count = extra.size() == 1 ? parse_int(extra[0]) : std::nullopt;
    if (!next_count || *next_count <= 0) {
      p.fail(first_extra, "particle count = " + std::to_string(n) +
                              " (line 1) but more particle rows follow; allowed: exactly " +
                              std::to_string(n) + " particle rows, then only blank lines");
    }
    // Count the frames: each is a count line, a comment line and that many rows.
    std::size_t frames = 1;
    auto count = next_count;
    while (count && *count > 0) {
      ++frames;
      for (long long k = 0; k <= *count && next_line(); ++k) {
      }
      count = std::nullopt;
      while (next_line()) {
        if (blank(line))
          continue;
        const auto t = split_ws(line);
        count = t.size() == 1 ? parse_int(t[0]) : std::nullopt;
        break;
      }
    }
    p.fail(first_extra, "the file has " + std::to_string(frames) +
                            " frames (frame 2 starts on line " + std::to_string(first_extra) +
                            "); allowed: a single frame (e.g. cut out the one to start from)");
  }

  state.wrap();
  // Two spheres at one place have no direction to push each other apart: the first force pass
  // would be 0 / 0. Bad input, named here, not a run that fails at t = 0.
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  const auto at = [&](std::size_t i) {
    return std::array<double, 3>{state.x()[i], state.y()[i], state.z()[i]};
  };
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return std::pair(at(a), a) < std::pair(at(b), b);
  });
  for (std::size_t k = 1; k < n; ++k) {
    const std::size_t a = order[k - 1], b = order[k];
    if (at(a) == at(b)) {
      const std::size_t later = std::max(a, b), first = std::min(a, b);
      p.fail(row_line[later],
             "particle " + std::to_string(later + 1) + " is at the same position as particle " +
                 std::to_string(first + 1) + " (line " + std::to_string(row_line[first]) +
                 "); allowed distinct positions");
    }
  }
  return state;
}

void write_xyz(std::ostream& out, const State& state) {
  const std::size_t n = state.size();
  // Memory order -> id order; a broken permutation would silently drop particles.
  std::vector<std::size_t> order(n, n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::int64_t id = state.id.size() == n ? state.id[i] : -1;
    if (id < 0 || static_cast<std::size_t>(id) >= n || order[static_cast<std::size_t>(id)] != n) {
      throw ConfigError("write_xyz: State.id is not a permutation of 0.." +
                        std::to_string(n == 0 ? 0 : n - 1) + " (entry " + std::to_string(i) + ")");
    }
    order[static_cast<std::size_t>(id)] = i;
  }

  const Eigen::Matrix3d h = state.box.h();
  std::string text;
  text.reserve(64 * (n + 4));
  text += std::to_string(n);
  text += "\nLattice=\"";
  for (int col = 0; col < 3; ++col) {
    for (int row = 0; row < 3; ++row) {
      if (col + row > 0)
        text += ' ';
      append_number(text, h(row, col));
    }
  }
  text += "\" Properties=species:S:1:pos:R:3:radius:R:1 Time=";
  append_number(text, state.time);
  text += " Strain=";
  append_number(text, state.box.strain);
  text += " pbc=\"T T T\"\n";

  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t i = order[k];
    Eigen::Vector3d s = state.scaled(i);
    for (int d = 0; d < 3; ++d) {
      s[d] -= std::floor(s[d]);
      if (s[d] >= 1.0)
        s[d] = 0.0;  // a tiny negative value can round up to 1
    }
    const Eigen::Vector3d r = h * s;
    // Chemical symbols, so that ASE (which accepts nothing else) and OVITO read the file as
    // it is: H for the small species, He for the large one. Reading ignores the labels.
    text += state.species[i] == 0 ? "H" : "He";
    for (int d = 0; d < 3; ++d) {
      text += ' ';
      append_number(text, r[d]);
    }
    text += ' ';
    append_number(text, 0.5 * state.diameter[i]);
    text += '\n';
  }
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
}

void write_xyz_file(const std::string& path, const State& state) {
  const std::string part = path + ".part";
  {
    std::ofstream out(part, std::ios::binary | std::ios::trunc);
    if (!out)
      throw IoError(part + ": cannot open for writing: " + std::strerror(errno));
    try {
      write_xyz(out, state);
    } catch (...) {
      out.close();
      std::remove(part.c_str());
      throw;
    }
    out.close();
    if (!out) {
      std::remove(part.c_str());
      throw IoError(part + ": write failed (disk full?)");
    }
  }
  if (std::rename(part.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    std::remove(part.c_str());
    throw IoError("cannot rename " + part + " to " + path + ": " + reason);
  }
}

}  // namespace jamflow
