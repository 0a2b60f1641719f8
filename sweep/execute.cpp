#include "sweep/execute.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

#include "driver/checkpoint.hpp"
#include "driver/run.hpp"
#include "lib/error.hpp"
#include "lib/progress.hpp"
#include "lib/text_file.hpp"

extern char** environ;

namespace jamflow::sweep {
namespace fs = std::filesystem;

namespace {

double now_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream buf;
  buf << in.rdbuf();
  return buf.str();
}

}  // namespace

const char* state_name(TaskState s) {
  switch (s) {
    case TaskState::kWaiting:
      return "waiting";
    case TaskState::kCheckpointed:
      return "checkpointed";
    case TaskState::kRunning:
      return "running";
    case TaskState::kDone:
      return "done";
    case TaskState::kFailed:
      return "failed";
    case TaskState::kBusyElsewhere:
      return "running elsewhere";
  }
  return "?";
}

TaskState probe(const Plan& plan, const Task& task, RunStatus* out) {
  const std::string file = plan.task_file(task);
  std::error_code ec;
  if (fs::exists(file, ec)) {
    const RunStatus status = read_run_status(file);
    if (out)
      *out = status;
    // A run stopped by its [run] max_force_evaluations is finished too: rerunning it would
    // stop at the same sample (collect leaves it out of the table, saying why).
    return status.is_finished() ? TaskState::kDone : TaskState::kFailed;
  }
  if (fs::exists(file + ".part", ec)) {
    const RunStatus status = read_run_status(file + ".part");
    if (out)
      *out = status;
    if (status.is_failed() || status.kind == RunStatus::Kind::kUnreadable)
      return TaskState::kFailed;
    return TaskState::kCheckpointed;
  }
  return TaskState::kWaiting;
}

void prepare_out_dir(const Plan& plan) {
  std::error_code ec;
  fs::create_directories(fs::path(plan.out_dir) / "points", ec);
  if (ec)
    throw ConfigError("--out '" + plan.out_dir + "': cannot create it (" + ec.message() +
                      "); allowed a writable folder");
  for (const auto& p : plan.points) {
    const std::string text = p.scene.text();
    const std::string file = plan.scene_file(p);
    if (fs::exists(file, ec)) {
      // Compared as scenes: a scene.toml written before floats were printed in their shortest
      // form holds the same scene in longer text, and its point resumes.
      const std::string stored = read_text(file);
      if (stored != text && canonical_scene_text(stored) != text) {
        throw ConfigError("sweep point " + p.name + ": its scene differs from the one in '" + file +
                          "' that its files were run with; allowed the same scene, or "
                          "another --out folder");
      }
      continue;
    }
    fs::create_directories(plan.point_dir(p), ec);
    if (ec)
      throw ConfigError("--out '" + plan.out_dir + "': cannot create '" + plan.point_dir(p) +
                        "' (" + ec.message() + ")");
    write_text_atomically(file, text);
  }
}

std::string self_exe() {
  std::error_code ec;
  const auto p = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string("jamflow") : p.string();
}

// ---- Coordinator ------------------------------------------------------------------------------

Coordinator::Coordinator(const Plan& plan, std::vector<std::size_t> share, int slots, bool quiet)
    : plan_(plan),
      tasks_(plan.tasks()),
      slots_(std::max(1, slots)),
      quiet_(quiet),
      tty_(isatty(STDERR_FILENO) != 0),
      t0_(now_seconds()) {
  if (share.empty()) {
    for (std::size_t i = 0; i < tasks_.size(); ++i)
      share.push_back(i);
  }
  state_.assign(tasks_.size(), TaskState::kWaiting);
  why_.assign(tasks_.size(), "");
  started_at_.assign(tasks_.size(), 0.0);
  resumed_.assign(tasks_.size(), false);
  std::vector<bool> mine(tasks_.size(), false);
  for (auto i : share)
    mine[i] = true;
  for (std::size_t i = 0; i < tasks_.size(); ++i) {
    RunStatus status = RunStatus::not_run();
    state_[i] = probe(plan_, tasks_[i], &status);
    if (status.kind != RunStatus::Kind::kNotRun)
      why_[i] = status.text();
    if (!mine[i])
      continue;
    if (state_[i] == TaskState::kDone) {
      ++skipped_;
    } else if (state_[i] == TaskState::kFailed) {
      ++failed_;
    } else {
      queue_.push_back(i);
      queued_cost_ += tasks_[i].cost;
    }
    ++total_;
  }
}

std::optional<std::size_t> Coordinator::take() {
  if (next_ >= queue_.size())
    return std::nullopt;
  const std::size_t t = queue_[next_++];
  queued_cost_ = next_ < queue_.size() ? std::max(0.0, queued_cost_ - tasks_[t].cost) : 0.0;
  return t;
}

void Coordinator::started(std::size_t task) {
  // A continued task does only part of its work here: it says nothing of the rate.
  resumed_[task] = state_[task] == TaskState::kCheckpointed;
  state_[task] = TaskState::kRunning;
  started_at_[task] = now_seconds();
  if (first_start_ < 0.0)
    first_start_ = started_at_[task];
  running_.push_back(task);
  journal(task, resumed_[task] ? "resumed" : "started", 0.0, "");
  if (!tty_)
    last_print_ = -1.0;
  tick();
}

void Coordinator::finished(std::size_t task, TaskState state, double wall, const std::string& why) {
  const bool ran_here = state_[task] == TaskState::kRunning;
  if (ran_here)
    running_.erase(std::find(running_.begin(), running_.end(), task));
  state_[task] = state;
  why_[task] = why;
  if (state == TaskState::kDone) {
    ++done_;
    // Only a task run here from its start tells the rate (one finished elsewhere took no time
    // here).
    if (ran_here && !resumed_[task]) {
      done_cost_ += tasks_[task].cost;
      done_wall_ += wall;
    }
  } else if (state == TaskState::kFailed) {
    ++failed_;
  }
  journal(task, state_name(state), wall, why);
  const Point& p = plan_.points[tasks_[task].point];
  if (!quiet_ && state != TaskState::kDone) {
    std::fprintf(stderr, "%ssweep: %s r%lld %s%s%s\n", tty_ ? "\r\033[K" : "", p.name.c_str(),
                 static_cast<long long>(tasks_[task].replica), state_name(state),
                 why.empty() ? "" : ": ", why.c_str());
  }
  last_print_ = -1.0;
  tick();
  ++events_since_manifest_;
  maybe_write_manifest();
}

int Coordinator::remaining() const {
  return static_cast<int>(queue_.size() - next_ + running_.size());
}

std::string Coordinator::line() const {
  const double now = now_seconds();
  const double elapsed = now - t0_;
  // ETA: the expected work left (the tasks not started, plus what the running ones have left
  // at one worker's rate, measured on the tasks run here from their start) over the work done
  // per second of this sweep's wall time since its first task started. The latter counts
  // everything between the runs too (starting them, bookkeeping, idle slots), which a rate
  // per worker-second alone would miss.
  double eta = NAN;
  if (done_wall_ > 0.0 && done_cost_ > 0.0 && first_start_ >= 0.0 && now > first_start_) {
    const double rate = done_cost_ / done_wall_;
    double left = queued_cost_, done = done_cost_;
    for (const std::size_t i : running_) {
      const double progress = std::min(tasks_[i].cost, rate * (now - started_at_[i]));
      left += tasks_[i].cost - progress;
      if (!resumed_[i])
        done += progress;
    }
    const double throughput = done / (now - first_start_);
    eta = left / std::min(throughput, rate * double(slots_));
  }
  const int waiting = static_cast<int>(queue_.size() - next_);
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "sweep %s: %d/%zu done%s, %zu running, %d failed, %d waiting  elapsed %s  ETA %s",
                plan_.name.c_str(), done_ + skipped_, total_,
                skipped_ > 0 ? (" (" + std::to_string(skipped_) + " from before)").c_str() : "",
                running_.size(), failed_, waiting, format_duration(elapsed).c_str(),
                format_duration(eta).c_str());
  return buf;
}

void Coordinator::tick() {
  if (quiet_)
    return;
  const double now = now_seconds();
  // On a terminal the line is redrawn every second; in a log, a line at each change and at
  // least every minute.
  if (last_print_ >= 0.0 && now - last_print_ < (tty_ ? 1.0 : 60.0))
    return;
  last_print_ = now;
  std::fprintf(stderr, "%s%s%s", tty_ ? "\r\033[K" : "", line().c_str(), tty_ ? "" : "\n");
  std::fflush(stderr);
}

void Coordinator::final_line() {
  if (quiet_)
    return;
  std::fprintf(stderr, "%s%s\n", tty_ ? "\r\033[K" : "", line().c_str());
}

void Coordinator::journal(std::size_t task, const char* event, double wall,
                          const std::string& why) {
  const std::time_t t = std::time(nullptr);
  char when[64];
  std::strftime(when, sizeof when, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  std::string line = std::string(when) + " " + plan_.points[tasks_[task].point].name + " r" +
                     std::to_string(tasks_[task].replica) + " " + event;
  if (wall > 0.0) {
    char buf[48];
    std::snprintf(buf, sizeof buf, " after %.3g s", wall);
    line += buf;
  }
  if (!why.empty())
    line.append(": ").append(why);
  // One line per event, whatever the sweep's size. A line is one write() of an O_APPEND file,
  // so the lines of two sweep processes on one folder do not mix.
  std::replace(line.begin(), line.end(), '\n', ' ');
  line += '\n';
  const std::string path = (fs::path(plan_.out_dir) / "journal.log").string();
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd < 0)
    return;
  const ssize_t n = ::write(fd, line.data(), line.size());
  ::close(fd);
  if (n > 0) {
    ++writes_.journal_lines;
    writes_.bytes += static_cast<std::size_t>(n);
  }
}

void Coordinator::maybe_write_manifest() {
  const double since = now_seconds() - manifest_at_;
  if (events_since_manifest_ == 0)
    return;
  if (events_since_manifest_ * 8 >= tasks_.size() ||
      since >= std::max(60.0, 20.0 * manifest_seconds_))
    write_manifest();
}

void Coordinator::write_manifest() {
  const double start = now_seconds();
  // What other processes on the folder did since: a task this process neither runs nor ended
  // is probed again (a task running elsewhere stays so until its files say it ended). The
  // first write follows the probes of the constructor.
  for (std::size_t i = 0; writes_.manifests > 0 && i < tasks_.size(); ++i) {
    const TaskState s = state_[i];
    if (s == TaskState::kRunning || s == TaskState::kDone || s == TaskState::kFailed)
      continue;
    RunStatus status = RunStatus::not_run();
    const TaskState now = probe(plan_, tasks_[i], &status);
    if (s == TaskState::kBusyElsewhere && now != TaskState::kDone && now != TaskState::kFailed)
      continue;
    state_[i] = now;
    why_[i] = status.kind == RunStatus::Kind::kNotRun ? "" : status.text();
  }
  toml::table root;
  toml::table head;
  if (!plan_.path.empty())  // a plan built in code (make_plan) has no sweep file
    head.insert("file", fs::absolute(plan_.path).lexically_normal().string());
  head.insert("points", static_cast<std::int64_t>(plan_.points.size()));
  head.insert("replicas", plan_.replicas);
  toml::array axes;
  for (const auto& a : plan_.axes)
    axes.push_back(a);
  head.insert("axes", std::move(axes));
  const std::time_t t = std::time(nullptr);
  char when[64];
  std::strftime(when, sizeof when, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  head.insert("updated", std::string(when));
  root.insert("sweep", std::move(head));
  // One entry per point, with a state per replica.
  std::vector<std::vector<std::size_t>> of_point(plan_.points.size());
  for (std::size_t i = 0; i < tasks_.size(); ++i)
    of_point[tasks_[i].point].push_back(i);
  toml::array points;
  for (const auto& p : plan_.points) {
    toml::table e;
    e.insert("name", p.name);
    e.insert("index", static_cast<std::int64_t>(p.index));
    toml::table keys;
    for (const auto& [k, v] : p.values) {
      const auto dot = k.find('.');
      const toml::table* sec = p.scene.table(k.substr(0, dot));
      if (sec && sec->get(k.substr(dot + 1)))
        keys.insert(k, *sec->get(k.substr(dot + 1)));
    }
    e.insert("keys", std::move(keys));
    e.insert("N", p.n);
    e.insert("folder", fs::path("points").append(p.name).string());
    auto tasks = of_point[p.index];
    std::sort(tasks.begin(), tasks.end(),
              [&](auto a, auto b) { return tasks_[a].replica < tasks_[b].replica; });
    toml::array states, files, details;
    bool all_done = true, any_failed = false, any_started = false;
    for (auto i : tasks) {
      states.push_back(std::string(state_name(state_[i])));
      files.push_back(fs::relative(plan_.task_file(tasks_[i]), plan_.out_dir).string());
      details.push_back(why_[i]);
      all_done = all_done && state_[i] == TaskState::kDone;
      any_failed = any_failed || state_[i] == TaskState::kFailed;
      any_started = any_started || state_[i] != TaskState::kWaiting;
    }
    e.insert("state", std::string(all_done      ? "done"
                                  : any_failed  ? "failed"
                                  : any_started ? "started"
                                                : "waiting"));
    e.insert("replica_states", std::move(states));
    e.insert("files", std::move(files));
    e.insert("status", std::move(details));
    points.push_back(std::move(e));
  }
  root.insert("point", std::move(points));
  std::ostringstream os;
  os << "# jamflow sweep manifest: a view of the point files, rewritten now and then (every\n"
     << "# event is in journal.log as it happens).\n"
     << toml_text(root) << "\n";
  const std::string text = os.str();
  try {
    write_text_atomically((fs::path(plan_.out_dir) / "manifest.toml").string(), text);
    ++writes_.manifests;
    writes_.bytes += text.size();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "sweep: warning: %s\n", e.what());
  }
  events_since_manifest_ = 0;
  manifest_at_ = now_seconds();
  manifest_seconds_ = manifest_at_ - start;
}

// ---- Child processes --------------------------------------------------------------------------

namespace {

struct Child {
  std::size_t task;
  int lock_fd;
  double start;
};

// Locks the task against a second sweep running it at the same time (a rerun while the first
// still runs, two array tasks): an exclusive flock on r<k>.h5.lock, held while the child runs
// and removed when it ends (unlock_task), so that a finished sweep leaves no lock files. The
// holder removes the file before it lets go, so a process that opened the file just before
// may get the lock on a file no longer there: the path must still name the file locked.
int lock_task(const std::string& path) {
  for (int attempt = 0; attempt < 3; ++attempt) {
    const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0)
      return -1;
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      ::close(fd);
      return -1;
    }
    struct stat held = {};
    struct stat named = {};
    if (::fstat(fd, &held) == 0 && ::stat(path.c_str(), &named) == 0 &&
        held.st_dev == named.st_dev && held.st_ino == named.st_ino)
      return fd;
    ::close(fd);  // removed by its holder meanwhile: lock the file now at the path
  }
  return -1;
}

std::string lock_path(const Plan& plan, const Task& t) {
  return plan.task_file(t) + ".lock";
}

void unlock_task(const std::string& path, int fd) {
  ::unlink(path.c_str());
  ::close(fd);
}

// Lock files of finished tasks left by a process that ended without removing them (an older
// jamflow, a killed sweep): removed once no process holds them.
void remove_stale_locks(const Plan& plan, const std::vector<Task>& tasks) {
  for (const Task& t : tasks) {
    const std::string path = lock_path(plan, t);
    std::error_code ec;
    if (!fs::exists(path, ec) || !fs::exists(plan.task_file(t), ec))
      continue;
    const int fd = lock_task(path);
    if (fd >= 0)
      unlock_task(path, fd);
  }
}

// Starts `exe args` in the folder `dir`, with stdout and stderr appended to `log` (a name in
// that folder).
pid_t spawn(const std::string& exe, const std::vector<std::string>& args, const std::string& dir,
            const std::string& log) {
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addchdir_np(&fa, dir.c_str());
  posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_APPEND,
                                   0644);
  posix_spawn_file_actions_adddup2(&fa, STDOUT_FILENO, STDERR_FILENO);
  std::vector<char*> argv;
  argv.push_back(const_cast<char*>(exe.c_str()));
  for (const auto& a : args)
    argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, exe.c_str(), &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0)
    throw IoError("cannot start '" + exe + "': " + std::strerror(rc));
  return pid;
}

std::string exit_text(int status) {
  if (WIFEXITED(status))
    return "exit status " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status))
    return std::string("killed by signal ") + std::to_string(WTERMSIG(status));
  return "ended";
}

}  // namespace

int run_slots(const Plan& plan, const std::vector<Task>& tasks, const SlotOptions& options,
              const std::function<std::optional<std::size_t>()>& take,
              const std::function<void(std::size_t)>& started,
              const std::function<void(std::size_t, TaskState, double, const std::string&)>& report,
              const std::function<void()>& tick, const std::function<bool()>& idle_done) {
  std::map<pid_t, Child> running;
  bool dry = false;
  int stopped_by = 0;
  while (true) {
    const int sig = options.stop ? options.stop->load() : 0;
    if (sig != 0 && stopped_by == 0) {
      stopped_by = sig;
      for (const auto& [pid, c] : running)
        ::kill(pid, sig);
    }
    if (options.checkpoint && options.checkpoint->exchange(false)) {
      for (const auto& [pid, c] : running)
        ::kill(pid, SIGUSR1);
    }
    while (stopped_by == 0 && !dry && static_cast<int>(running.size()) < options.slots) {
      const auto next = take();
      if (!next) {
        dry = true;
        break;
      }
      const Task& t = tasks[*next];
      const int fd = lock_task(lock_path(plan, t));
      if (fd < 0) {
        report(*next, TaskState::kBusyElsewhere, 0.0, "locked by another sweep process");
        continue;
      }
      RunStatus status;
      const TaskState now = probe(plan, t, &status);  // the files may have moved on since
      if (now == TaskState::kDone || now == TaskState::kFailed) {
        unlock_task(lock_path(plan, t), fd);
        report(*next, now, 0.0, now == TaskState::kFailed ? status.text() : "");
        continue;
      }
      // The child runs in the point's folder, so that its files (and the scene stored in
      // them) name no other folder: the same point gives the same bits wherever it runs.
      std::vector<std::string> args;
      const std::string stem = Plan::task_stem(t);
      const std::string dir = plan.point_dir(plan.points[t.point]);
      if (now == TaskState::kCheckpointed) {
        args = {"run", "--resume", stem + ".h5.part", "-q"};
      } else {
        write_text_atomically((fs::path(dir) / (stem + ".toml")).string(),
                              plan.task_scene(t).text());
        args = {"run", stem + ".toml", "-q"};
      }
      pid_t pid = -1;
      try {
        pid = spawn(options.exe, args, dir, stem + ".log");
      } catch (const std::exception& e) {
        unlock_task(lock_path(plan, t), fd);
        report(*next, TaskState::kFailed, 0.0, e.what());
        continue;
      }
      running[pid] = {*next, fd, now_seconds()};
      started(*next);
    }
    if (running.empty() && (dry || stopped_by != 0) && idle_done())
      break;
    int status = 0;
    const pid_t pid = ::waitpid(-1, &status, WNOHANG);
    if (pid > 0 && running.count(pid)) {
      const Child c = running[pid];
      running.erase(pid);
      RunStatus status_read = RunStatus::not_run();
      TaskState s = probe(plan, tasks[c.task], &status_read);
      const std::string detail =
          status_read.kind == RunStatus::Kind::kNotRun ? "" : status_read.text();
      if (s == TaskState::kWaiting)  // nothing written: it failed before its first sample
        s = TaskState::kFailed;
      std::string why;
      if (s == TaskState::kFailed)
        why = exit_text(status) + (detail.empty() ? "" : ", " + detail) + "; see " +
              plan.task_log(tasks[c.task]);
      else if (s == TaskState::kCheckpointed)
        why = detail;
      unlock_task(lock_path(plan, tasks[c.task]), c.lock_fd);
      report(c.task, s, now_seconds() - c.start, why);
      continue;
    }
    tick();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (stopped_by == 0)
    remove_stale_locks(plan, tasks);
  return stopped_by;
}

int run_local(const Plan& plan, int jobs, const std::vector<std::size_t>& share, bool quiet,
              const std::string& exe, const std::atomic<int>* stop, std::atomic<bool>* checkpoint) {
  prepare_out_dir(plan);
  Coordinator co(plan, share, jobs, quiet);
  co.write_manifest();
  co.tick();
  SlotOptions so;
  so.slots = jobs;
  so.exe = exe;
  so.stop = stop;
  so.checkpoint = checkpoint;
  const int sig = run_slots(
      plan, co.tasks(), so, [&] { return co.take(); }, [&](std::size_t t) { co.started(t); },
      [&](std::size_t t, TaskState s, double wall, const std::string& why) {
        co.finished(t, s, wall, why);
      },
      [&] { co.tick(); });
  co.write_manifest();
  co.final_line();
  if (sig != 0)
    return 128 + sig;
  return co.failed() > 0 ? 1 : 0;
}

}  // namespace jamflow::sweep
