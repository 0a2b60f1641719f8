// Progress line: redrawn in place on a terminal, a line every 10% (or 30 s) otherwise.
#include "lib/progress.hpp"

#include <unistd.h>

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

Progress::Progress(std::string label, double total, bool quiet, double begin)
    : label_(std::move(label)),
      total_(total),
      begin_(begin),
      quiet_(quiet),
      tty_(isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()),
      last_(start_) {}

void Progress::update(double done, const std::string& extra) {
  if (quiet_)
    return;
  const auto now = std::chrono::steady_clock::now();
  const double since_last = std::chrono::duration<double>(now - last_).count();
  const double fraction = total_ > 0 ? std::min(1.0, done / total_) : 1.0;
  const bool due =
      tty_ ? since_last >= 0.5 : (fraction >= last_fraction_ + 0.1 || since_last >= 30.0);
  if (!due)
    return;
  last_ = now;
  last_fraction_ = fraction;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double here = done - begin_;  // simulation time done by this process
  const double eta = here > 0 ? elapsed * (total_ - done) / here : NAN;
  std::fprintf(stderr, "%s[%s] t = %.6g / %.6g  %5.1f%%  elapsed %s  ETA %s  %s%s",
               tty_ ? "\r\033[K" : "", label_.c_str(), done, total_, 100.0 * fraction,
               format_duration(elapsed).c_str(), format_duration(eta).c_str(), extra.c_str(),
               tty_ ? "" : "\n");
  std::fflush(stderr);
}

void Progress::finish() {
  if (quiet_)
    return;
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  std::fprintf(stderr, "%s[%s] done in %s\n", tty_ ? "\r\033[K" : "", label_.c_str(),
               format_duration(elapsed).c_str());
}

}  // namespace jamflow
