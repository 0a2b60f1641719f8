// Progress line: redrawn in place on a terminal, a line every 10% (or 30 s) otherwise, and
// always a line when the estimated length changes and when the run completes (at 100 %).
#include "lib/progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace jamflow {

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0)
    return "--:--:--";
  const long s = std::lround(seconds);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%02ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  return buf;
}

Progress::Progress(std::string label, double total, bool quiet, double begin, Sink sink)
    : label_(std::move(label)),
      total_(total),
      begin_(begin),
      quiet_(quiet),
      tty_(isatty(STDERR_FILENO) != 0),
      sink_(std::move(sink)),
      start_(std::chrono::steady_clock::now()),
      last_(start_) {}

void Progress::set_total(double total) {
  total_ = total;
}

ProgressReport Progress::report(double done, const std::string& extra) const {
  ProgressReport r;
  r.label = label_;
  r.time = done;
  r.total = total_;
  r.fraction = total_ > 0 ? std::clamp(done / total_, 0.0, 1.0) : 1.0;
  r.elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double here = done - begin_;  // simulation time done by this process
  r.eta = here > 0 ? std::max(0.0, r.elapsed * (total_ - done) / here) : NAN;
  r.extra = extra;
  return r;
}

void Progress::print(const ProgressReport& r, const char* tail) const {
  std::fprintf(stderr, "%s[%s] t = %.6g / %.6g  %5.1f%%  elapsed %s  %s%s  %s%s",
               tty_ ? "\r\033[K" : "", r.label.c_str(), r.time, r.total, 100.0 * r.fraction,
               format_duration(r.elapsed).c_str(), r.finished ? "" : "ETA ",
               r.finished ? "done" : format_duration(r.eta).c_str(), r.extra.c_str(), tail);
  std::fflush(stderr);
}

void Progress::update(double done, const std::string& extra) {
  if (quiet_)
    return;
  // A run that goes past its estimate (the horizon of an automatic length is decided when it
  // is reached) is shown against the time reached, never beyond 100 %.
  total_ = std::max(total_, done);
  last_extra_ = extra;
  if (sink_) {
    sink_(report(done, extra));
    return;
  }
  const auto now = std::chrono::steady_clock::now();
  const double since_last = std::chrono::duration<double>(now - last_).count();
  // Off a terminal: a line every tenth of the run as now estimated, every 30 s, and when the
  // estimate has grown by a tenth since the last line.
  const bool due =
      printed_total_ < 0.0 || (tty_ ? since_last >= 0.5
                                    : done >= printed_time_ + 0.1 * total_ || since_last >= 30.0 ||
                                          total_ > 1.1 * printed_total_);
  if (!due)
    return;
  last_ = now;
  printed_time_ = done;
  printed_total_ = total_;
  print(report(done, extra), tty_ ? "" : "\n");
}

void Progress::finish(double done) {
  if (quiet_)
    return;
  total_ = done;  // the run's length as it turned out
  ProgressReport r = report(done, last_extra_);
  r.finished = true;
  r.eta = 0.0;
  if (sink_) {
    sink_(r);
    return;
  }
  print(r, "\n");
}

}  // namespace jamflow
