// Progress line with an ETA on stderr for long runs, or reports to a sink (the Python module).
#pragma once
#include <chrono>
#include <functional>
#include <string>

namespace jamflow {

// Where a run stands, as the progress line shows it.
struct ProgressReport {
  std::string label;
  double time = 0.0;      // simulation time reached
  double total = 0.0;     // the run's length as now estimated (grows under "auto" lengths)
  double fraction = 0.0;  // time / total, at most 1
  double elapsed = 0.0;   // wall seconds since this process started the run
  double eta = 0.0;       // wall seconds left (NaN while unknown)
  std::string extra;      // current observables, e.g. "phi 0.6  P 1e-3  sigma_xy 2e-4"
  bool finished = false;  // the last report of a completed run (fraction 1)
};

class Progress {
 public:
  using Sink = std::function<void(const ProgressReport&)>;
  // total: the run's length in simulation time; begin: where this process starts it (a
  // continued run), so that the ETA counts only the time done here. Quiet suppresses all output.
  // With a sink, every update goes to it instead of stderr (the sink throttles if it must).
  Progress(std::string label, double total, bool quiet, double begin = 0.0, Sink sink = {});
  // A run whose length is not known in advance (t_eq or t_av = "auto") moves its end: the
  // line shows the new estimate once it has grown by a tenth.
  void set_total(double total);
  // done: simulation time reached; extra: short text appended (e.g. current observables).
  void update(double done, const std::string& extra = {});
  // The run ended complete at `done`: the last line shows it at 100 %, whatever was estimated.
  void finish(double done);

 private:
  ProgressReport report(double done, const std::string& extra) const;
  void print(const ProgressReport& r, const char* tail) const;

  std::string label_;
  double total_;
  double begin_;
  bool quiet_;
  bool tty_;
  Sink sink_;
  std::chrono::steady_clock::time_point start_, last_;
  double printed_time_ = 0.0, printed_total_ = -1.0;  // of the last line printed
  std::string last_extra_;
};

std::string format_duration(double seconds);

}  // namespace jamflow
