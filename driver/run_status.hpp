// The status of a run or of one replica: what the run file's "status" attribute says, typed.
// The text is the file's (unchanged since the first format): "complete", "running" (a
// checkpoint of a run that goes on), "interrupted at t = ...", "failed at t = ...: why",
// "budget: stopped at t = ..." ([run] max_force_evaluations); studies add "not run" and
// "aborted: why". Code above the run file asks the
// kind; only text() and parse() know the words.
#pragma once
#include <string>
#include <string_view>
#include <utility>

namespace jamflow {

struct RunStatus {
  enum class Kind {
    kComplete,
    kRunning,      // a checkpoint written while the run goes on
    kInterrupted,  // stopped by a signal or a stop request; continued with --resume
    kFailed,       // the integration failed; cannot be continued
    kBudget,       // stopped by [run] max_force_evaluations: finished, without a summary
    kNotRun,       // a study's run that was not started
    kAborted,      // the process ended without a status of its own (detail: its last words)
    kUnreadable,   // a file whose status could not be read (detail: why)
  };
  Kind kind = Kind::kComplete;
  std::string detail;  // after the kind's word: "at t = 12 by SIGTERM", "at t = 3: why"

  static RunStatus complete() { return {}; }
  static RunStatus running() { return {Kind::kRunning, {}}; }
  static RunStatus interrupted(std::string detail) {
    return {Kind::kInterrupted, std::move(detail)};
  }
  static RunStatus failed(std::string detail) { return {Kind::kFailed, std::move(detail)}; }
  static RunStatus budget(std::string detail) { return {Kind::kBudget, std::move(detail)}; }
  static RunStatus not_run(std::string detail = {}) { return {Kind::kNotRun, std::move(detail)}; }
  static RunStatus aborted(std::string why) { return {Kind::kAborted, std::move(why)}; }
  static RunStatus unreadable(std::string why) { return {Kind::kUnreadable, std::move(why)}; }
  // A run file's text. Text that names no kind (or is empty) is kUnreadable, with the text
  // quoted in the detail.
  static RunStatus parse(std::string_view text);

  std::string text() const;
  bool is_complete() const { return kind == Kind::kComplete; }
  bool is_failed() const { return kind == Kind::kFailed; }
  bool is_interrupted() const { return kind == Kind::kInterrupted; }
  bool is_budget() const { return kind == Kind::kBudget; }
  // Complete, or stopped by the budget: nothing more will be computed for it.
  bool is_finished() const { return is_complete() || is_budget(); }
  bool operator==(const RunStatus&) const = default;
};

}  // namespace jamflow
