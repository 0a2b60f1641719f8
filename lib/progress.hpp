// Progress line with an ETA on stderr for long runs.
#pragma once
#include <chrono>
#include <string>

namespace jamflow {

class Progress {
 public:
  // total: the run's length in simulation time; begin: where this process starts it (a
  // continued run), so that the ETA counts only the time done here. Quiet suppresses all output.
  Progress(std::string label, double total, bool quiet, double begin = 0.0);
  // A run whose length is not known in advance (t_av = "auto") moves its end.
  void set_total(double total) { total_ = total; }
  // done: simulation time reached; extra: short text appended (e.g. current observables).
  void update(double done, const std::string& extra = {});
  void finish();

 private:
  std::string label_;
  double total_;
  double begin_;
  bool quiet_;
  bool tty_;
  std::chrono::steady_clock::time_point start_, last_;
  double last_fraction_ = -1.0;
};

std::string format_duration(double seconds);

}  // namespace jamflow
