// Running a sweep's tasks: each task is a `jamflow run` child process on one thread, so a
// point's file is the same bits whoever runs it (a local sweep, an MPI rank, a Slurm array
// task), a crash or out-of-memory kill takes down one point only, and every point gets the
// run driver's checkpoints, resume and verdicts.
//
// The state of a task is read from its files, never remembered: finished (its r<k>.h5 is
// complete), checkpointed (r<k>.h5.part continues with --resume), failed (the .part says the
// run failed), or waiting. So rerunning a sweep skips finished points and resumes the others,
// and the manifest is a view of the files, rewritten atomically now and then (the journal has
// every event as it happens).
#pragma once
#include <atomic>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "driver/run_status.hpp"
#include "sweep/plan.hpp"

namespace jamflow::sweep {

enum class TaskState { kWaiting, kCheckpointed, kRunning, kDone, kFailed, kBusyElsewhere };
const char* state_name(TaskState s);

// What the files say of a task (kWaiting, kCheckpointed, kDone or kFailed); `status` gets the
// run file's status (read_run_status), when there is a file.
TaskState probe(const Plan& plan, const Task& task, RunStatus* status = nullptr);

// Writes each point's scene.toml, or checks that an existing one is the same scene: a point
// whose scene changed since its files were written is a ConfigError (use another --out).
void prepare_out_dir(const Plan& plan);

// The sweep's bookkeeping, on the process that hands out tasks (the only one on a local sweep,
// rank 0 under MPI): task states, the progress line, the event journal and the manifest.
//
// Its cost per task does not grow with the sweep: each event appends one line to
// DIR/journal.log; the manifest (a line per point) is rewritten at the start and the end, and
// in between only after an eighth of the tasks have ended since the last rewrite, or after a
// minute that is at least 20 times its last write time (then at most 5% of the wall time).
class Coordinator {
 public:
  // `share`: indices into plan.tasks() this process is responsible for (all if empty).
  // `slots`: workers in all, for the ETA.
  Coordinator(const Plan& plan, std::vector<std::size_t> share, int slots, bool quiet);
  const std::vector<Task>& tasks() const { return tasks_; }
  // The next task to run (expected-longest first), or nothing.
  std::optional<std::size_t> take();
  void started(std::size_t task);
  void finished(std::size_t task, TaskState state, double wall_seconds, const std::string& why);
  void tick();  // progress line (at most once a second on a terminal)
  // DIR/manifest.toml, atomically, after probing again the tasks this process does not run
  // (so finished work of another sweep process on the folder shows as done).
  void write_manifest();
  void final_line();
  int failed() const { return failed_; }
  int remaining() const;  // tasks not finished (waiting, checkpointed or running)
  // Bytes and files the bookkeeping has written (manifest and journal), for the tests.
  struct Writes {
    std::size_t manifests = 0, journal_lines = 0, bytes = 0;
  };
  const Writes& writes() const { return writes_; }
  // The progress line as it stands (tests).
  std::string line() const;

 private:
  void journal(std::size_t task, const char* event, double wall_seconds, const std::string& why);
  void maybe_write_manifest();
  const Plan& plan_;
  std::vector<Task> tasks_;
  std::vector<TaskState> state_;
  std::vector<std::string> why_;
  std::vector<std::size_t> queue_;  // tasks to run, in order
  std::size_t next_ = 0;
  double queued_cost_ = 0.0;          // expected work of queue_[next_..]
  std::vector<std::size_t> running_;  // tasks running here (at most the slots)
  std::vector<double> started_at_;
  std::vector<bool> resumed_;  // started from a checkpoint: left out of the rate
  int slots_;
  bool quiet_, tty_;
  std::size_t total_ = 0;
  int done_ = 0, skipped_ = 0, failed_ = 0;
  // Tasks started here from the beginning and finished: their expected work and wall seconds
  // (the rate of one worker), and the wall time since the first task started here.
  double done_cost_ = 0.0, done_wall_ = 0.0, first_start_ = -1.0;
  double t0_, last_print_ = -1.0;
  std::size_t events_since_manifest_ = 0;
  double manifest_at_ = 0.0, manifest_seconds_ = 0.0;
  Writes writes_;
};

struct SlotOptions {
  int slots = 1;
  std::string exe;  // the jamflow binary
  // Set asynchronously: a signal to forward to the running tasks (SIGINT, SIGTERM, SIGHUP: then
  // no task is started any more and the loop ends when the running ones have checkpointed) and
  // a request to checkpoint now (SIGUSR1).
  const std::atomic<int>* stop = nullptr;
  std::atomic<bool>* checkpoint = nullptr;
};

// Runs tasks in `slots` child processes at a time: take() gives the next task index (nothing:
// no more), report() is told how each ended, tick() is called about every 50 ms (progress, MPI
// messages), and the loop ends once take() has run dry, nothing runs and idle_done() is true.
// Returns the signal that stopped it, or 0.
int run_slots(
    const Plan& plan, const std::vector<Task>& tasks, const SlotOptions& options,
    const std::function<std::optional<std::size_t>()>& take,
    const std::function<void(std::size_t)>& started,
    const std::function<void(std::size_t, TaskState, double, const std::string&)>& report,
    const std::function<void()>& tick,
    const std::function<bool()>& idle_done = [] { return true; });

// A whole local sweep (or one Slurm array task's share): returns the exit status, 0 when every
// task is finished, 1 when some failed, 128 + the signal when stopped by one.
int run_local(const Plan& plan, int jobs, const std::vector<std::size_t>& share, bool quiet,
              const std::string& exe, const std::atomic<int>* stop, std::atomic<bool>* checkpoint);

// The path of the running binary (/proc/self/exe).
std::string self_exe();

}  // namespace jamflow::sweep
