// CSV and HDF5 readers for state-point summaries (see data.hpp).
#include "analysis/data.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <new>
#include <optional>
#include <sstream>
#include <tuple>
#include <type_traits>

#include "analysis/admission.hpp"
#include "analysis/errors.hpp"
#include "analysis/json.hpp"
#include "driver/run_summary.hpp"
#include "lib/error.hpp"
#include "lib/names.hpp"
#include "lib/statistics.hpp"
#include "lib/table.hpp"

namespace jamflow::analysis {

namespace {

// A CSV table read by the one table reader (lib/table.hpp), its errors as input errors, and at
// least one row.
Table read_csv(const std::string& path) {
  Table table;
  try {
    table = read_csv_table(path);
  } catch (const InputFileError& e) {
    throw InputError(e.what());
  }
  if (table.rows.empty())
    throw InputError(path + ": no data rows after the header");
  return table;
}

// Parses one numeric field; the message names file, line and column.
double field_number(const Table& t, std::size_t row, const std::string& name) {
  const std::string& text = t.rows[row][static_cast<std::size_t>(t.column(name))];
  std::string where = t.path + ":" + std::to_string(t.lines[row]) + ": column '" + name + "'";
  double value = 0.0;
  const char* b = text.data();
  const char* e = b + text.size();
  if (!text.empty() && *b == '+')
    ++b;
  auto res = std::from_chars(b, e, value);
  if (text.empty() || res.ec != std::errc() || res.ptr != e) {
    throw InputError(where + ": expected a number, got '" + text + "'");
  }
  if (!std::isfinite(value))
    throw InputError(where + ": non-finite value '" + text + "'");
  return value;
}

std::int64_t field_size(const Table& t, std::size_t row, const std::string& name) {
  double v = field_number(t, row, name);
  if (v < 1.0 || v != std::floor(v) || v > 1e15) {
    throw InputError(t.path + ":" + std::to_string(t.lines[row]) + ": column '" + name +
                     "': expected a positive integer particle number, got " + std::to_string(v));
  }
  return static_cast<std::int64_t>(v);
}

[[noreturn]] void range_error(const std::string& where, const std::string& name, double v,
                              const std::string& allowed) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  throw InputError(where + ": " + name + " = " + buf + " is out of range (" + allowed + ")");
}

void check_positive(const std::string& where, const std::string& name, double v) {
  if (!std::isfinite(v))
    range_error(where, name, v, "must be finite");
  if (!(v > 0.0))
    range_error(where, name, v, "must be > 0");
  // A subnormal value (1e-320) loses its digits, and its logarithm, inverse square (a weight)
  // or ratios overflow in the fits: refused here, naming the row, not after fitting.
  if (!std::isnormal(v))
    range_error(where, name, v, "must be at least 2.2250738585072014e-308");
}

// J = gdot / P of a row whose gdot and P are each in range may still overflow or underflow.
void check_viscous_number(const std::string& where, double j) {
  if (!std::isnormal(j) || !(j > 0.0))
    range_error(where, "J = shear_rate / imposed_pressure", j,
                "must be a finite number of at least 2.2e-308");
}

void check_phi(const std::string& where, double v) {
  if (!std::isnormal(v) || !(v > 0.0 && v < 1.0))
    range_error(where, "phi", v, "0 < phi < 1, at least 2.2e-308");
}

void check_finite(const std::string& where, const std::string& name, double v) {
  if (!std::isfinite(v))
    range_error(where, name, v, "must be finite");
}

// The column names of lib/names.hpp; tables with the deprecated gdot and P are renamed to them
// by the table reader, with a warning.
const std::string kShearRateColumn(names::kShearRate);
const std::string kImposedPressureColumn(names::kImposedPressure);
const std::vector<std::string> kGranularColumns = {
    "N", kImposedPressureColumn, kShearRateColumn, "phi", "phi_err", "mu", "mu_err"};
const std::vector<std::string> kShearColumns = {"N", "phi", kShearRateColumn, "sigma_xy",
                                                "sigma_xy_err"};

std::string join(const std::vector<std::string>& xs) {
  std::string out;
  for (const auto& x : xs)
    out += (out.empty() ? "" : ",") + x;
  return out;
}

enum class TableForm { kGranular, kShear };

TableForm table_form(const Table& t) {
  if (t.has_columns(kGranularColumns))
    return TableForm::kGranular;
  if (t.has_columns(kShearColumns))
    return TableForm::kShear;
  std::vector<std::string> missing_g, missing_s;
  for (const auto& c : kGranularColumns) {
    if (t.column(c) < 0)
      missing_g.push_back(c);
  }
  for (const auto& c : kShearColumns) {
    if (t.column(c) < 0)
      missing_s.push_back(c);
  }
  throw InputError(t.path + ": header '" + join(t.header) +
                   "' matches neither the granular table (" + join(kGranularColumns) +
                   "; missing " + join(missing_g) + ") nor the constant-volume table (" +
                   join(kShearColumns) + "; missing " + join(missing_s) + ")");
}

// A table whose errors come in two parts (<o>_block_err, <o>_replica_err: `jamflow sweep
// --collect` since the parts were separated).
bool separate_error_parts(const Table& t) {
  return std::any_of(t.header.begin(), t.header.end(), [](const std::string& h) {
    return h.size() > 10 && h.compare(h.size() - 10, 10, "_block_err") == 0;
  });
}

double replicas_of(const Table& t, std::size_t r) {
  const int c = t.column("replicas");
  return c >= 0 ? std::atof(t.rows[r][static_cast<std::size_t>(c)].c_str()) : 0.0;
}

// The errors of a row by the replica rule: with separate parts, each <o>_err of `errs` is
// recomputed from <o>_block_err and <o>_replica_err (lib/statistics.hpp replica_point_error);
// the basis says what they are made of.
ErrorBasis row_errors(const Table& t, std::size_t r,
                      const std::vector<std::pair<std::string, double*>>& errs, double& replicas) {
  const int c = t.column("replicas");
  replicas = replicas_of(t, r);
  if (c < 0)
    return ErrorBasis::kGiven;
  if (!separate_error_parts(t))
    return replicas >= 2.0 ? ErrorBasis::kCollectedMax : ErrorBasis::kBlockOne;
  const std::string where = t.path + ":" + std::to_string(t.lines[r]);
  for (const auto& [name, err] : errs) {
    if (t.column(name + "_block_err") < 0)
      continue;  // a column the collector does not split: as given
    const double block = field_number(t, r, name + "_block_err");
    const int rc = t.column(name + "_replica_err");
    const std::string& cell = rc >= 0 ? t.rows[r][static_cast<std::size_t>(rc)] : std::string();
    const double scatter = cell.empty() ? std::nan("") : field_number(t, r, name + "_replica_err");
    *err = replica_point_error(block, scatter, replicas);
  }
  if (replica_scatter_used(replicas))
    return ErrorBasis::kScatter;
  if (replicas < 2.0)
    return ErrorBasis::kBlockOne;
  const int d = t.column("decorrelated");
  const bool short_blocks = d >= 0 && t.rows[r][static_cast<std::size_t>(d)] == "0";
  return short_blocks ? ErrorBasis::kBlockTwoShort : ErrorBasis::kBlockTwo;
}

// Rows of a collected sweep table (`jamflow sweep --collect`) carry the runs' verdicts in the
// columns steady, stable and decorrelated (1 pass, 0 fail, empty not checked), admitted by the
// rule of analysis/admission.hpp. A row kept with blocks shorter than two correlation times has
// from 3 replicas errors that include their scatter, which needs no decorrelated blocks; with 2
// in a table with separate error parts its error is the block error, and its basis
// (kBlockTwoShort) says that this understates it; an older table's errors include the scatter
// of its 2 replicas, as collected.
// Returns the reason to leave the row out, or "".
std::string failed_verdicts(const Table& t, std::size_t r) {
  auto verdict = [&](const char* name) -> std::optional<bool> {
    const int c = t.column(name);
    if (c < 0)
      return std::nullopt;
    const std::string& cell = t.rows[r][static_cast<std::size_t>(c)];
    if (cell == "0" || cell == "1")
      return cell == "1";
    return std::nullopt;
  };
  return admit({verdict("steady"), verdict("stable"), verdict("decorrelated"), replicas_of(t, r)})
      .reason;
}

// The rows of a table that the analyses use, with one note on stderr for those left out (or,
// with include_failed, admitted although their verdicts failed).
std::vector<std::size_t> usable_rows(const Table& t, const VerdictAdmission& verdicts = {}) {
  std::vector<std::size_t> rows;
  std::string left;
  std::size_t count = 0;
  for (std::size_t r = 0; r < t.rows.size(); ++r) {
    const std::string why = failed_verdicts(t, r);
    if (why.empty() || verdicts.include_failed)
      rows.push_back(r);
    if (why.empty())
      continue;
    if (verdicts.left_out && !verdicts.include_failed)
      verdicts.left_out->push_back(t.path + ":" + std::to_string(t.lines[r]) + ": " + why);
    ++count;
    if (count <= 10)
      left.append(left.empty() ? "" : "; ")
          .append("line ")
          .append(std::to_string(t.lines[r]))
          .append(": ")
          .append(why);
  }
  if (count > 0) {
    std::fprintf(stderr, "note: %s: %zu of %zu rows %s, their verdicts failed (%s%s)\n",
                 t.path.c_str(), count, t.rows.size(),
                 verdicts.include_failed ? "included and marked although" : "left out",
                 left.c_str(), count > 10 ? "; ..." : "");
  }
  return rows;
}

GranularPoint granular_from_row(const Table& t, std::size_t r) {
  GranularPoint p;
  p.source = t.path + ":" + std::to_string(t.lines[r]);
  p.n = field_size(t, r, "N");
  p.pressure = field_number(t, r, kImposedPressureColumn);
  p.shear_rate = field_number(t, r, kShearRateColumn);
  p.phi = field_number(t, r, "phi");
  p.phi_err = field_number(t, r, "phi_err");
  p.mu = field_number(t, r, "mu");
  p.mu_err = field_number(t, r, "mu_err");
  p.error_basis = row_errors(t, r, {{"phi", &p.phi_err}, {"mu", &p.mu_err}}, p.replicas);
  check_positive(p.source + ": column 'imposed_pressure'", kImposedPressureColumn, p.pressure);
  check_positive(p.source + ": column 'shear_rate'", kShearRateColumn, p.shear_rate);
  check_phi(p.source + ": column 'phi'", p.phi);
  check_positive(p.source + ": column 'phi_err'", "phi_err", p.phi_err);
  check_positive(p.source + ": column 'mu_err'", "mu_err", p.mu_err);
  p.j = p.shear_rate / p.pressure;
  check_viscous_number(p.source + ": columns 'shear_rate' and 'imposed_pressure'", p.j);
  return p;
}

std::string set_label_volume(std::int64_t n, double phi) {
  return "N=" + std::to_string(n) + ",phi=" + format_key(phi);
}
std::string set_label_pressure(std::int64_t n, double p) {
  return "N=" + std::to_string(n) + ",imposed_pressure=" + format_key(p);
}

ShearPoint shear_from_row(const Table& t, std::size_t r, TableForm form) {
  ShearPoint s;
  s.source = t.path + ":" + std::to_string(t.lines[r]);
  s.n = field_size(t, r, "N");
  s.phi = field_number(t, r, "phi");
  s.shear_rate = field_number(t, r, kShearRateColumn);
  check_phi(s.source + ": column 'phi'", s.phi);
  check_positive(s.source + ": column 'shear_rate'", kShearRateColumn, s.shear_rate);
  if (form == TableForm::kShear) {
    s.sigma = field_number(t, r, "sigma_xy");
    s.sigma_err = field_number(t, r, "sigma_xy_err");
    check_positive(s.source + ": column 'sigma_xy' (the collapse works with log sigma_xy)",
                   "sigma_xy", s.sigma);
    s.set = set_label_volume(s.n, s.phi);
    // A collected sweep table carries the measured pressure; other tables may not.
    const int cp = t.column("pressure"), ce = t.column("pressure_err");
    const bool has_pressure = cp >= 0 && ce >= 0 &&
                              !t.rows[r][static_cast<std::size_t>(cp)].empty() &&
                              !t.rows[r][static_cast<std::size_t>(ce)].empty();
    if (has_pressure) {
      s.pressure = field_number(t, r, "pressure");
      s.pressure_err = field_number(t, r, "pressure_err");
    }
    std::vector<std::pair<std::string, double*>> errs = {{"sigma_xy", &s.sigma_err}};
    if (has_pressure)
      errs.push_back({"pressure", &s.pressure_err});
    s.error_basis = row_errors(t, r, errs, s.replicas);
    check_positive(s.source + ": column 'sigma_xy_err'", "sigma_xy_err", s.sigma_err);
  } else {
    GranularPoint g = granular_from_row(t, r);
    check_positive(s.source + ": column 'mu' (the collapse works with log sigma_xy = mu P)", "mu",
                   g.mu);
    s.sigma = g.mu * g.pressure;
    s.sigma_err = g.mu_err * g.pressure;
    s.error_basis = g.error_basis;
    s.replicas = g.replicas;
    s.set = set_label_pressure(g.n, g.pressure);
  }
  return s;
}

}  // namespace

bool is_hdf5_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    return false;
  char sig[8] = {};
  in.read(sig, 8);
  static const char kSignature[8] = {'\x89', 'H', 'D', 'F', '\r', '\n', '\x1a', '\n'};
  return in.gcount() == 8 && std::equal(sig, sig + 8, kSignature);
}

namespace {

// Reads the summary in this process: the run-file module's reader, its errors as input errors.
RunSummary read_summary_here(const std::string& path) {
  try {
    return read_run_file_summary(path);
  } catch (const InputFileError& e) {
    throw InputError(e.what());
  }
}

// --- libhdf5 in a child process ------------------------------------------------
//
// Fuzzing found corrupt files on which Debian's libhdf5 1.10.8 itself crashes (global heap and
// attribute decoding), hangs (metadata cache) or asks for absurd amounts of memory, below
// anything this reader can check. So each file is read in a forked child: it reads the summary,
// writes it to a pipe (strings as length and bytes, numbers as their bits: the values are the
// same bits as an in-process read) and leaves with _exit. The parent waits at most
// kChildSeconds and the child's address space may grow by at most kChildMemory; a crash, a
// hang or an allocation beyond that becomes an InputError naming the file.

constexpr int kChildSeconds = 20;
constexpr unsigned long long kChildMemory = 4ULL << 30;  // 4 GiB on top of what the parent maps

Hdf5Isolation g_isolation = Hdf5Isolation::kChildProcess;

// Every field of a RunSummary, in one order for writing and reading.
template <class S, class F>
void for_each_field(S& s, F&& f) {
  f(s.path);
  f(s.scene);
  f(s.version);
  f(s.git_commit);
  f(s.created);
  f(s.ensemble);
  f(s.n);
  for (auto* x :
       {&s.sigma_xy, &s.sigma_xy_err, &s.pressure, &s.pressure_err, &s.phi, &s.phi_err, &s.eta,
        &s.eta_err, &s.mu, &s.mu_err, &s.j, &s.energy_balance, &s.shear_rate, &s.alpha, &s.replicas,
        &s.sigma_xy_replica_err, &s.pressure_replica_err, &s.phi_replica_err, &s.mu_replica_err})
    f(*x);
  f(s.has_imposed_pressure);
  f(s.imposed_pressure);
}

void put_bytes(std::string& out, const void* p, std::size_t n) {
  out.append(static_cast<const char*>(p), n);
}

std::string pack(const RunSummary& s) {
  std::string out;
  for_each_field(s, [&](const auto& x) {
    using T = std::decay_t<decltype(x)>;
    if constexpr (std::is_same_v<T, std::string>) {
      const std::uint64_t n = x.size();
      put_bytes(out, &n, sizeof n);
      out += x;
    } else {
      put_bytes(out, &x, sizeof x);
    }
  });
  return out;
}

// False if the bytes end early or are left over.
bool unpack(const std::string& in, std::size_t pos, RunSummary& s) {
  bool ok = true;
  const auto take = [&](void* p, std::size_t n) {
    if (!ok || in.size() - pos < n) {
      ok = false;
      return;
    }
    std::memcpy(p, in.data() + pos, n);
    pos += n;
  };
  for_each_field(s, [&](auto& x) {
    using T = std::decay_t<decltype(x)>;
    if constexpr (std::is_same_v<T, std::string>) {
      std::uint64_t n = 0;
      take(&n, sizeof n);
      if (!ok || n > in.size() - pos) {
        ok = false;
        return;
      }
      x.assign(in, pos, n);
      pos += n;
    } else {
      take(&x, sizeof x);
    }
  });
  return ok && pos == in.size();
}

// The child's result: a tag, then the packed summary or a message.
constexpr char kSummary = 'S', kInputError = 'E', kNoMemory = 'M', kOtherError = 'X';

std::string failure(const std::string& path, const std::string& why) {
  return path + ": could not be read: " + why;
}

// The child: never returns.
[[noreturn]] void child_reads(const std::string& path, int fd) {
  // Room for kChildMemory more than the parent maps (sanitizer builds map terabytes up front).
  unsigned long long pages = 0;
  if (std::FILE* f = std::fopen("/proc/self/statm", "r")) {
    if (std::fscanf(f, "%llu", &pages) != 1)
      pages = 0;
    std::fclose(f);
  }
  if (pages > 0) {
    const rlim_t limit =
        pages * static_cast<unsigned long long>(::sysconf(_SC_PAGESIZE)) + kChildMemory;
    rlimit rl{};
    if (::getrlimit(RLIMIT_AS, &rl) == 0 && (rl.rlim_max == RLIM_INFINITY || limit < rl.rlim_max)) {
      rl.rlim_cur = limit;
      ::setrlimit(RLIMIT_AS, &rl);
    }
  }
  // A crash is reported by the parent; a core dump of libhdf5 would only take time and space.
  const rlimit no_core{0, 0};
  ::setrlimit(RLIMIT_CORE, &no_core);
  // The reader speaks through the pipe only: what a crashing libhdf5 prints (in a sanitizer
  // build, the sanitizer's report of its bad read, 36 lines) is not the user's one-line error.
  if (const int null = ::open("/dev/null", O_WRONLY | O_CLOEXEC); null >= 0) {
    ::dup2(null, STDERR_FILENO);
    ::close(null);
  }
  std::string out;
  try {
    try {
      out = kSummary + pack(read_summary_here(path));
    } catch (const InputError& e) {
      out = kInputError + std::string(e.what());
    } catch (const std::bad_alloc&) {
      out = kNoMemory;
    } catch (const std::exception& e) {
      out = kOtherError + std::string(e.what());
    }
  } catch (...) {
    out = kNoMemory;  // building the message itself failed
  }
  std::size_t done = 0;
  while (done < out.size()) {
    const ssize_t w = ::write(fd, out.data() + done, out.size() - done);
    if (w < 0 && errno == EINTR)
      continue;
    if (w <= 0)
      ::_exit(3);
    done += static_cast<std::size_t>(w);
  }
  ::_exit(0);
}

RunSummary read_in_child(const std::string& path) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0)
    throw InputError(failure(path, std::string("cannot create a pipe: ") + std::strerror(errno)));
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int err = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    throw InputError(failure(path, std::string("cannot start a reader: ") + std::strerror(err)));
  }
  if (pid == 0) {
    ::close(fds[0]);
    child_reads(path, fds[1]);
  }
  ::close(fds[1]);
  std::string in;
  bool timed_out = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(kChildSeconds);
  char buf[65536];
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      timed_out = true;
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    const int r = ::poll(&p, 1, static_cast<int>(left.count()));
    if (r < 0 && errno == EINTR)
      continue;
    if (r <= 0) {
      timed_out = r == 0;
      break;
    }
    const ssize_t n = ::read(fds[0], buf, sizeof buf);
    if (n < 0 && errno == EINTR)
      continue;
    if (n <= 0)
      break;  // end of file: the child is done (or died)
    in.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fds[0]);
  if (timed_out)
    ::kill(pid, SIGKILL);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (timed_out) {
    throw InputError(failure(
        path, "the HDF5 library did not finish within " + std::to_string(kChildSeconds) + " s"));
  }
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    const char* name = ::sigabbrev_np(sig);
    throw InputError(failure(path, "the HDF5 library crashed (signal " + std::to_string(sig) +
                                       (name ? std::string(", SIG") + name : std::string()) + ")"));
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || in.empty()) {
    throw InputError(
        failure(path, "the HDF5 library crashed (exit status " +
                          std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ")"));
  }
  const std::string text = in.substr(1);
  switch (in[0]) {
    case kSummary: {
      RunSummary s;
      if (!unpack(in, 1, s))
        break;
      return s;
    }
    case kInputError:
      throw InputError(text);
    case kNoMemory:
      throw InputError(failure(path, "reading it needs more than " +
                                         std::to_string(kChildMemory >> 30) + " GiB of memory"));
    case kOtherError:
      throw InputError(failure(path, text));
  }
  throw InputError(failure(path, "the reader's answer is garbled"));
}

}  // namespace

void set_hdf5_isolation(Hdf5Isolation isolation) {
  g_isolation = isolation;
}

RunSummary read_run_summary(const std::string& path) {
  if (g_isolation == Hdf5Isolation::kInProcess)
    return read_summary_here(path);
  return read_in_child(path);
}

bool same_file(const std::string& a, const std::string& b) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec))
    return fs::equivalent(a, b, ec) && !ec;
  return fs::absolute(a, ec).lexically_normal() == fs::absolute(b, ec).lexically_normal();
}

namespace {

void refuse_repeated_files(const std::vector<std::string>& paths) {
  for (std::size_t j = 1; j < paths.size(); ++j)
    for (std::size_t i = 0; i < j; ++i)
      if (same_file(paths[i], paths[j]))
        throw InputError("DATA '" + paths[j] + "' is the same file as '" + paths[i] +
                         "'; allowed each data file once (repeats would count one run twice)");
}

// Two records equal in every value are one run given twice (a row or a run file copied), not
// two independent runs: merged as repeats they would shrink the error bars by sqrt(2).
template <class Point, class Key>
void refuse_identical(const std::vector<Point>& points, const Key& key) {
  std::map<std::invoke_result_t<Key, const Point&>, std::size_t> seen;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto [it, fresh] = seen.emplace(key(points[i]), i);
    if (!fresh)
      throw InputError(points[i].source + ": the same record as " + points[it->second].source +
                       " (every value equal); allowed each run once: remove the duplicate");
  }
}

// A run file's /summary: *_err the block errors (of the mean over replicas), *_replica_err
// the scatter.
ErrorBasis run_file_basis(double replicas) {
  if (replica_scatter_used(replicas))
    return ErrorBasis::kScatter;
  if (replicas < 2.0)
    return ErrorBasis::kBlockOne;
  return ErrorBasis::kBlockTwo;  // the run file's verdicts are not read here
}

}  // namespace

std::vector<GranularPoint> read_granular(const std::vector<std::string>& paths) {
  if (paths.empty())
    throw InputError("no data files given");
  refuse_repeated_files(paths);
  std::vector<GranularPoint> points;
  for (const auto& path : paths) {
    if (is_hdf5_file(path)) {
      RunSummary s = read_run_summary(path);
      const std::string where = path + ": /summary";
      if (s.ensemble != "constant_pressure") {
        throw InputError(path + ": ensemble is '" + s.ensemble +
                         "'; the granular analyses need constant_pressure runs");
      }
      GranularPoint p;
      p.source = path;
      p.n = s.n;
      p.pressure = s.imposed_pressure;
      p.shear_rate = s.shear_rate;
      p.phi = s.phi;
      p.phi_err = replica_point_error(s.phi_err, s.phi_replica_err, s.replicas);
      p.mu = s.mu;
      p.mu_err = replica_point_error(s.mu_err, s.mu_replica_err, s.replicas);
      p.replicas = s.replicas;
      p.error_basis = run_file_basis(s.replicas);
      check_positive(where, "imposed_pressure", p.pressure);
      check_positive(where, "shear_rate", p.shear_rate);
      check_phi(where, p.phi);
      check_positive(where, "phi_err", p.phi_err);
      check_finite(where, "mu", p.mu);
      check_positive(where, "mu_err", p.mu_err);
      p.j = p.shear_rate / p.pressure;
      check_viscous_number(where, p.j);
      points.push_back(p);
      continue;
    }
    Table t = read_csv(path);
    if (table_form(t) != TableForm::kGranular) {
      throw InputError(path + ": this is a constant-volume table (" + join(kShearColumns) +
                       "); the granular analyses need constant-pressure data with columns " +
                       join(kGranularColumns));
    }
    for (const std::size_t r : usable_rows(t))
      points.push_back(granular_from_row(t, r));
  }
  refuse_identical(points, [](const GranularPoint& p) {
    return std::make_tuple(p.n, p.pressure, p.shear_rate, p.phi, p.phi_err, p.mu, p.mu_err);
  });
  return merge_repeats(std::move(points));
}

std::vector<ShearPoint> read_shear(const std::vector<std::string>& paths) {
  return read_shear(paths, VerdictAdmission{});
}

std::vector<ShearPoint> read_shear(const std::vector<std::string>& paths,
                                   const VerdictAdmission& verdicts) {
  if (paths.empty())
    throw InputError("no data files given");
  refuse_repeated_files(paths);
  std::vector<ShearPoint> points;
  for (const auto& path : paths) {
    if (is_hdf5_file(path)) {
      RunSummary s = read_run_summary(path);
      const std::string where = path + ": /summary";
      ShearPoint p;
      p.source = path;
      p.n = s.n;
      p.phi = s.phi;
      p.shear_rate = s.shear_rate;
      p.sigma = s.sigma_xy;
      p.sigma_err = replica_point_error(s.sigma_xy_err, s.sigma_xy_replica_err, s.replicas);
      p.replicas = s.replicas;
      p.error_basis = run_file_basis(s.replicas);
      check_phi(where, p.phi);
      check_positive(where, "shear_rate", p.shear_rate);
      check_positive(where + " (the collapse works with log sigma_xy)", "sigma_xy", p.sigma);
      check_positive(where, "sigma_xy_err", p.sigma_err);
      if (s.ensemble == "constant_volume") {
        p.set = set_label_volume(s.n, s.phi);
        p.pressure = s.pressure;
        p.pressure_err = replica_point_error(s.pressure_err, s.pressure_replica_err, s.replicas);
      } else {
        check_positive(where, "imposed_pressure", s.imposed_pressure);
        p.set = set_label_pressure(s.n, s.imposed_pressure);
      }
      points.push_back(p);
      continue;
    }
    Table t = read_csv(path);
    TableForm form = table_form(t);
    for (const std::size_t r : usable_rows(t, verdicts)) {
      points.push_back(shear_from_row(t, r, form));
      points.back().failed_verdicts = failed_verdicts(t, r);
    }
  }
  refuse_identical(points, [](const ShearPoint& p) {
    return std::make_tuple(p.set, p.n, p.phi, p.shear_rate, p.sigma, p.sigma_err, p.pressure,
                           p.pressure_err);
  });
  return merge_repeats(std::move(points));
}

namespace {

// Inverse-variance weighted mean of values with errors.
std::pair<double, double> weighted_mean(const std::vector<std::pair<double, double>>& xs) {
  double sw = 0.0, swx = 0.0;
  for (auto [x, e] : xs) {
    double w = 1.0 / (e * e);
    sw += w;
    swx += w * x;
  }
  return {swx / sw, 1.0 / std::sqrt(sw)};
}

std::string merged_source(const std::vector<std::string>& sources) {
  if (sources.size() == 1)
    return sources[0];
  return sources[0] + " (+" + std::to_string(sources.size() - 1) + " repeats)";
}

}  // namespace

std::vector<GranularPoint> merge_repeats(std::vector<GranularPoint> points) {
  std::map<std::tuple<std::int64_t, double, double>, std::vector<std::size_t>> groups;
  for (std::size_t i = 0; i < points.size(); ++i) {
    groups[{points[i].n, points[i].pressure, points[i].shear_rate}].push_back(i);
  }
  std::vector<GranularPoint> out;
  out.reserve(groups.size());
  for (const auto& [key, idx] : groups) {
    GranularPoint m = points[idx[0]];
    if (idx.size() > 1) {
      std::vector<std::pair<double, double>> phis, mus;
      std::vector<std::string> sources;
      for (std::size_t i : idx) {
        phis.emplace_back(points[i].phi, points[i].phi_err);
        mus.emplace_back(points[i].mu, points[i].mu_err);
        sources.push_back(points[i].source);
      }
      std::tie(m.phi, m.phi_err) = weighted_mean(phis);
      std::tie(m.mu, m.mu_err) = weighted_mean(mus);
      m.source = merged_source(sources);
      for (std::size_t i : idx) {
        if (points[i].error_basis != m.error_basis)
          m.error_basis = ErrorBasis::kMixed;
      }
    }
    out.push_back(m);
  }
  return out;
}

std::vector<ShearPoint> merge_repeats(std::vector<ShearPoint> points) {
  std::map<std::tuple<std::string, double>, std::vector<std::size_t>> groups;
  for (std::size_t i = 0; i < points.size(); ++i) {
    groups[{points[i].set, points[i].shear_rate}].push_back(i);
  }
  std::vector<ShearPoint> out;
  out.reserve(groups.size());
  for (const auto& [key, idx] : groups) {
    ShearPoint m = points[idx[0]];
    if (idx.size() > 1) {
      std::vector<std::pair<double, double>> sigmas;
      std::vector<std::string> sources;
      double phi_sum = 0.0;
      for (std::size_t i : idx) {
        sigmas.emplace_back(points[i].sigma, points[i].sigma_err);
        sources.push_back(points[i].source);
        if (m.failed_verdicts.empty())  // a merge with a failed run is marked as failed
          m.failed_verdicts = points[i].failed_verdicts;
        phi_sum += points[i].phi;
      }
      std::tie(m.sigma, m.sigma_err) = weighted_mean(sigmas);
      std::vector<std::pair<double, double>> pressures;
      for (std::size_t i : idx) {
        if (points[i].pressure > 0.0 && points[i].pressure_err > 0.0)
          pressures.emplace_back(points[i].pressure, points[i].pressure_err);
      }
      if (pressures.size() == idx.size())
        std::tie(m.pressure, m.pressure_err) = weighted_mean(pressures);
      else
        m.pressure = m.pressure_err = 0.0;
      // Constant volume: identical phi; constant pressure: the measured phi of
      // repeated runs, averaged (its error is neglected by the collapse).
      m.phi = phi_sum / static_cast<double>(idx.size());
      m.source = merged_source(sources);
      for (std::size_t i : idx) {
        if (points[i].error_basis != m.error_basis)
          m.error_basis = ErrorBasis::kMixed;
      }
    }
    out.push_back(m);
  }
  return out;
}

const char* error_basis_name(ErrorBasis b) {
  switch (b) {
    case ErrorBasis::kGiven:
      return "as_given";
    case ErrorBasis::kBlockOne:
      return "block_1_replica";
    case ErrorBasis::kBlockTwo:
      return "block_2_replicas";
    case ErrorBasis::kBlockTwoShort:
      return "block_2_replicas_short_blocks";
    case ErrorBasis::kScatter:
      return "block_or_replica_scatter";
    case ErrorBasis::kCollectedMax:
      return "collected_max_block_scatter";
    case ErrorBasis::kMixed:
      return "mixed";
  }
  return "unknown";
}

const char* error_basis_meaning(ErrorBasis b) {
  switch (b) {
    case ErrorBasis::kGiven:
      return "errors as given in the table (no replica count)";
    case ErrorBasis::kBlockOne:
      return "the block error of one replica";
    case ErrorBasis::kBlockTwo:
      return "the block error of the mean over 2 replicas (their scatter, with one degree of "
             "freedom, is not used: it needs 3 replicas)";
    case ErrorBasis::kBlockTwoShort:
      return "the block error of the mean over 2 replicas from blocks shorter than 2 tau (not "
             "decorrelated): it understates the error, and 2 replicas give no scatter to use";
    case ErrorBasis::kScatter:
      return "the larger of the block error and the scatter of 3 or more replicas";
    case ErrorBasis::kCollectedMax:
      return "the larger of the block error and the scatter of 2 or more replicas, as an older "
             "table was collected (the two parts are not in it separately; with 2 replicas the "
             "scatter has one degree of freedom)";
    case ErrorBasis::kMixed:
      return "repeated state points of different error bases, merged";
  }
  return "unknown";
}

namespace {

template <class P>
PointErrors count_bases(const std::vector<P>& points) {
  PointErrors e;
  e.points = points.size();
  for (ErrorBasis b : {ErrorBasis::kGiven, ErrorBasis::kBlockOne, ErrorBasis::kBlockTwo,
                       ErrorBasis::kBlockTwoShort, ErrorBasis::kScatter, ErrorBasis::kCollectedMax,
                       ErrorBasis::kMixed}) {
    const auto n = static_cast<std::size_t>(std::count_if(
        points.begin(), points.end(), [b](const P& p) { return p.error_basis == b; }));
    if (n > 0)
      e.counts.emplace_back(b, n);
  }
  return e;
}

}  // namespace

PointErrors point_errors_of(const std::vector<GranularPoint>& points) {
  return count_bases(points);
}
PointErrors point_errors_of(const std::vector<ShearPoint>& points) {
  return count_bases(points);
}

std::string describe(const PointErrors& e) {
  std::string out = "Point errors (replica scatter only from 3 replicas on): ";
  for (std::size_t i = 0; i < e.counts.size(); ++i) {
    out += (i ? "; " : "") + std::to_string(e.counts[i].second) + " of " +
           std::to_string(e.points) + " points: " + error_basis_meaning(e.counts[i].first);
  }
  return out + ".";
}

}  // namespace jamflow::analysis
