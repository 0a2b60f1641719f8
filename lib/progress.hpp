// Progress line with an ETA on stderr for long runs.
#pragma once
#include <chrono>
#include <string>

namespace jamflow {

class Progress {
 public:
  // total: the run's length in simulation time. Quiet suppresses all output.
  Progress(std::string label, double total, bool quiet);
  // done: simulation time reached; extra: short text appended (e.g. current observables).
  void update(double done, const std::string& extra = {});
  void finish();

 private:
  std::string label_;
  double total_;
  bool quiet_;
  bool tty_;
  std::chrono::steady_clock::time_point start_, last_;
  double last_fraction_ = -1.0;
};

std::string format_duration(double seconds);

}  // namespace jamflow
