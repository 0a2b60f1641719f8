// Checkpoints, --resume and --extend: an interrupted and continued run gives the same file, bit
// for bit, as an uninterrupted one (Euler, RESPA; CVODE when it goes on in the same process); a
// torn checkpoint write leaves the previous checkpoint readable; the output path is checked
// before anything is computed.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>
#include <cstdio>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "driver/checkpoint.hpp"
#include "driver/run.hpp"
#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "tests/driver/temp_dir.hpp"
#include "tests/short_tests.hpp"

extern char** environ;

namespace jamflow {
namespace {

namespace fs = std::filesystem;

// Each test's files in a directory of its own.
class TempDir : public testing_support::TempDir {
 public:
  TempDir() : testing_support::TempDir("jamflow-ckpt-") {}
};

// A small sheared system with Lees-Edwards remaps (strain 1 every ~7 time units at this box)
// and neighbour-list rebuilds within the run; `ensemble` and `integrator` are TOML sections.
std::string scene(const std::string& file, const std::string& ensemble,
                  const std::string& integrator, double t_eq, double t_av) {
  return "[system]\nN = 150\nphi = 0.62\nseed = 5\n[ensemble]\n" + ensemble +
         "\n[shear]\nrate = 0.15\n[integrator]\n" + integrator +
         "\n[run]\nt_eq = " + std::to_string(t_eq) + "\nt_av = " + std::to_string(t_av) +
         "\nsample_every = 0.5\nblocks = 10\nthreads = 1\n[output]\nfile = \"" + file +
         "\"\ncheckpoint_every = 0.001\n";
}

const char* const kVolume = "kind = \"constant_volume\"";
const char* const kPressure = "kind = \"constant_pressure\"\npressure = 0.01\nxi_V = 0.05";
const char* const kEuler = "kind = \"euler\"\ndt = 0.05";
const char* const kRespa = "kind = \"respa\"\ndt = 0.1\nn_inner = 2";
const char* const kRkc = "kind = \"rkc\"\nrtol = 1e-3\natol = 1e-4";

RunSpec spec_of(const std::string& text) {
  return parse_run_spec(Scene::parse(text, "test.toml"));
}

// Everything of a finished file that does not depend on the wall clock or on the run having
// been continued: the series, the final state and every summary value but the wall times.
void expect_same_run(const std::string& a_path, const std::string& b_path) {
  H5Reader a(a_path), b(b_path);
  for (const auto& name : a.children("/timeseries")) {
    const auto x = a.read_doubles("/timeseries/" + name), y = b.read_doubles("/timeseries/" + name);
    ASSERT_EQ(x.size(), y.size()) << name;
    EXPECT_EQ(0, std::memcmp(x.data(), y.data(), x.size() * sizeof(double))) << name;
  }
  for (const char* name : {"positions", "diameters", "cell"}) {
    const auto x = a.read_doubles(std::string("/final/") + name),
               y = b.read_doubles(std::string("/final/") + name);
    ASSERT_EQ(x.size(), y.size()) << name;
    EXPECT_EQ(0, std::memcmp(x.data(), y.data(), x.size() * sizeof(double))) << name;
  }
  const auto names = a.attr_names("/summary");
  EXPECT_EQ(names, b.attr_names("/summary"));
  for (const auto& name : names) {
    if (name.rfind("wall_seconds", 0) == 0 || name.rfind("cpu_seconds", 0) == 0)
      continue;
    if (name.rfind("verdict_", 0) == 0 || name == "status" || name == "integrator" ||
        name == "ensemble" || name == "run_length" || name == "t_eq_method") {
      EXPECT_EQ(a.attr_string("/summary", name), b.attr_string("/summary", name)) << name;
      continue;
    }
    const double x = a.attr_double("/summary", name), y = b.attr_double("/summary", name);
    EXPECT_TRUE(x == y || (std::isnan(x) && std::isnan(y))) << name << ": " << x << " vs " << y;
  }
}

int run_quietly(const RunSpec& spec, RunOptions opt, const OutputOptions& out = {}) {
  opt.quiet = true;
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  try {
    const int rc = run_and_write(spec, opt, out);
    testing::internal::GetCapturedStdout();
    testing::internal::GetCapturedStderr();
    return rc;
  } catch (...) {
    testing::internal::GetCapturedStdout();
    testing::internal::GetCapturedStderr();
    throw;
  }
}

// Runs the scene to the end through repeated SIGTERMs (set on the run's control from a timer
// thread after `delay` of wall time) and --resume-style continuations from the .part file.
// Returns the number of interruptions and the simulated times where they stopped; `cpu`, if
// given, gets the CPU seconds that each .part file recorded.
std::vector<double> run_interrupted(const std::string& text, const std::string& file,
                                    std::chrono::milliseconds delay,
                                    std::vector<double>* cpu = nullptr) {
  const RunSpec spec = spec_of(text);
  std::vector<double> stops;
  OutputOptions out;
  for (int attempt = 0; attempt < 200; ++attempt) {
    RunControl control;
    RunOptions opt;
    opt.control = &control;
    opt.label = file.substr(0, file.size() - 3);
    // Each start gets longer before its stop, so that a slow machine (sanitizers) still ends.
    const auto wait = delay * (1 + attempt / 8);
    std::jthread timer([&control, wait](std::stop_token token) {
      const auto until = std::chrono::steady_clock::now() + wait;
      while (!token.stop_requested() && std::chrono::steady_clock::now() < until)
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      if (!token.stop_requested())
        control.signal.store(SIGTERM);
    });
    const int rc = run_quietly(spec, opt, out);
    timer.request_stop();
    if (rc == 0)
      return stops;
    EXPECT_EQ(rc, 128 + SIGTERM);
    H5Reader part(file + ".part");
    const std::string status = part.attr_string("/", "status");
    EXPECT_NE(status.find("by SIGTERM"), std::string::npos) << status;
    const auto replicas = read_checkpoint(part);
    stops.push_back(replicas.back().end.state.time);
    if (cpu)
      cpu->push_back(replicas.back().cpu_seconds);
    out.continue_from = replicas;
  }
  ADD_FAILURE() << "the run did not finish in 200 continuations";
  return stops;
}

struct Case {
  const char* name;
  const char* ensemble;
  const char* integrator;
};

class Resume : public testing::TestWithParam<Case> {};

// Stopped by SIGTERM 15 ms of wall time after every start (the first stop falls in t_eq, which
// takes most of the run) and continued from the .part file each time: the finished file equals an
// uninterrupted run's, bit for bit, through remaps, list rebuilds and reorders.
TEST_P(Resume, SigtermAndContinueGiveTheUninterruptedRunBitForBit) {
  TempDir dir;
  const Case c = GetParam();
  const double t_eq = 100.0, t_av = 50.0;
  const std::string ref = dir.file("ref.h5"), cut = dir.file("cut.h5");
  ASSERT_EQ(run_quietly(spec_of(scene(ref, c.ensemble, c.integrator, t_eq, t_av)), {}), 0);
  std::vector<double> cpu;
  const auto stops = run_interrupted(scene(cut, c.ensemble, c.integrator, t_eq, t_av), cut,
                                     std::chrono::milliseconds(15), &cpu);
  ASSERT_TRUE(fs::exists(cut));
  EXPECT_FALSE(fs::exists(cut + ".part"));
  ASSERT_GE(stops.size(), 2u) << "the run was hardly interrupted: the machine ran it in < 30 ms";
  EXPECT_LT(stops.front(), t_eq);
  // Where it stopped: not on the sampling grid in general (between integrator steps).
  std::string where;
  for (double t : stops)
    where += " " + std::to_string(t);
  RecordProperty("stops", where);
  expect_same_run(ref, cut);
  H5Reader h(cut);
  EXPECT_EQ(h.attr_int("/", "resumes"), std::int64_t(stops.size()));
  EXPECT_EQ(h.attr_string("/", "solver_history"), "none");
  // CPU seconds count the whole run, as the counters do: every part at least the one before,
  // the finished file at least the last part.
  ASSERT_EQ(cpu.size(), stops.size());
  for (std::size_t k = 0; k < cpu.size(); ++k) {
    EXPECT_TRUE(std::isfinite(cpu[k]) && cpu[k] > 0.0) << k << ": " << cpu[k];
    if (k > 0) {
      EXPECT_GE(cpu[k], cpu[k - 1]) << k;
    }
  }
  EXPECT_GE(h.attr_double("/summary", "cpu_seconds"), cpu.back());
  EXPECT_FALSE(h.has_attr("/summary", "cpu_seconds_note"));
  // The remaps and list rebuilds happened: strain 22 over a cell about 5 wide.
  EXPECT_GT(h.attr_double("/final", "strain"), 10.0);
  EXPECT_GT(h.attr_double("/summary", "integrator_neighbour_list_builds"), 10.0);
}

INSTANTIATE_TEST_SUITE_P(EulerAndRespa, Resume,
                         testing::Values(Case{"euler_NV", kVolume, kEuler},
                                         Case{"euler_NP", kPressure, kEuler},
                                         Case{"respa_NV", kVolume, kRespa},
                                         Case{"respa_NP", kPressure, kRespa}),
                         [](const auto& info) { return std::string(info.param.name); });

// RKC carries its step proposal, error history and spectral radius between steps; they are
// checkpointed exactly, so it too resumes bit for bit.
INSTANTIATE_TEST_SUITE_P(Rkc, Resume,
                         testing::Values(Case{"rkc_NV", kVolume, kRkc},
                                         Case{"rkc_NP", kPressure, kRkc}),
                         [](const auto& info) { return std::string(info.param.name); });

// A checkpoint that takes longer to write than checkpoint_every (here 30 ms against 1 ms, as a
// large system or a slow disk would) must not leave the run a step between writes: the next one
// waits at least as long as the last write took. 1000 Euler steps; a write per step (what
// happens if the clock keeps running during the write) would be 1000 writes. The bound, 250, is
// a quarter of that: at 30 ms a write and a wait of at least 30 ms between them, it holds
// unless the steps take over 15 ms each, 100x slower than a sanitizer build.
TEST(Checkpoint, SlowWritesDoNotStallTheRun) {
  TempDir dir;
  const RunSpec spec = spec_of(scene(dir.file("slow.h5"), kVolume, kEuler, 10.0, 40.0));
  RunOptions o;
  o.checkpoint_every = 0.001;
  int writes = 0;
  o.checkpoint = [&](const ReplicaResult&) {
    ++writes;
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
  };
  const ReplicaResult r = run_replica(spec, spec.seed, o);
  ASSERT_TRUE(r.status.is_complete()) << r.status.text();
  EXPECT_GE(writes, 1);  // the clock did ask for checkpoints
  EXPECT_LT(writes, 250) << "checkpoint writes during 1000 steps";
}

TEST(Resume, ExtendAppendsAndEqualsTheLongerRun) {
  TempDir dir;
  const std::string ref = dir.file("long.h5"), ext = dir.file("short.h5");
  ASSERT_EQ(run_quietly(spec_of(scene(ref, kVolume, kEuler, 10.0, 40.0)), {}), 0);
  ASSERT_EQ(run_quietly(spec_of(scene(ext, kVolume, kEuler, 10.0, 20.0)), {}), 0);
  OutputOptions out;
  {
    H5Reader h(ext);
    out.continue_from = read_checkpoint(h);
  }
  out.extend = true;
  Scene longer = Scene::parse(scene(ext, kVolume, kEuler, 10.0, 20.0), "short.toml");
  longer.set("run.t_av=40.0");
  ASSERT_EQ(run_quietly(parse_run_spec(longer), {}, out), 0);
  expect_same_run(ref, ext);
  H5Reader h(ext);
  EXPECT_EQ(h.read_doubles("/timeseries/time").size(), 101u);  // t = 0, 0.5, ..., 50
  EXPECT_NE(h.attr_string("/", "scene").find("t_av = 40"), std::string::npos);
}

TEST(Resume, CvodeContinuesWithAFreshSolverHistoryAndSaysSo) {
  TempDir dir;
  const std::string cut = dir.file("cv.h5");
  const auto stops =
      run_interrupted(scene(cut, kVolume, "kind = \"cvode\"\nrtol = 1e-5", 20.0, 20.0), cut,
                      std::chrono::milliseconds(15));
  ASSERT_TRUE(fs::exists(cut));
  H5Reader h(cut);
  if (stops.empty()) {
    EXPECT_EQ(h.attr_string("/", "solver_history"), "kept");
  } else {
    EXPECT_NE(h.attr_string("/", "solver_history").find("fresh after resume at t = "),
              std::string::npos)
        << h.attr_string("/", "solver_history");
  }
  EXPECT_EQ(h.read_doubles("/timeseries/time").size(), 81u);
}

// Checkpoints due by the clock (every millisecond of wall time here) stop CVODE between its
// internal steps and let it go on with the history it had: the finished file is the same, bit
// for bit, as a run that was never stopped.
TEST(Resume, CvodeCheckpointsOnTheClockLeaveTheRunUnchanged) {
  TempDir dir;
  const std::string ref = dir.file("ref.h5"), cut = dir.file("cut.h5");
  const char* const cvode = "kind = \"cvode\"\nrtol = 1e-5";
  std::string never = scene(ref, kVolume, cvode, 20.0, 40.0);
  const std::string every_ms = "checkpoint_every = 0.001";
  never.replace(never.find(every_ms), every_ms.size(), "checkpoint_every = 1e9");
  ASSERT_EQ(run_quietly(spec_of(never), {}), 0);
  ASSERT_EQ(run_quietly(spec_of(scene(cut, kVolume, cvode, 20.0, 40.0)), {}), 0);
  expect_same_run(ref, cut);
  H5Reader h(cut);
  EXPECT_EQ(h.attr_string("/", "solver_history"), "kept");
}

// A write that dies half-way (here: abandoned before its commit) never touches the previous
// checkpoint: it goes to <file>.part.tmp, renamed only once complete.
TEST(Checkpoint, TornWriteLeavesThePreviousCheckpointReadable) {
  TempDir dir;
  const std::string file = dir.file("torn.h5");
  RunControl control;
  control.signal.store(SIGTERM);  // stops at the first step, after the first checkpoint
  RunOptions opt;
  opt.control = &control;
  opt.label = dir.file("torn");
  const RunSpec spec = spec_of(scene(file, kVolume, kEuler, 5.0, 5.0));
  ASSERT_EQ(run_quietly(spec, opt), 128 + SIGTERM);
  const std::string part = file + ".part";
  ASSERT_TRUE(fs::exists(part));
  const auto size = fs::file_size(part);
  {
    H5Writer torn(part, ".tmp");
    torn.dataset("/timeseries/time", std::vector<double>(1000, 1.0));
    // Half-written: the previous checkpoint is still the whole file at `part`.
    EXPECT_EQ(fs::file_size(part), size);
    H5Reader still(part);
    EXPECT_NO_THROW(read_checkpoint(still));
  }  // destroyed without commit: the temporary file is removed
  EXPECT_FALSE(fs::exists(part + ".tmp"));
  // A crash leaves the temporary file behind instead: it is ignored, and the run continues.
  std::ofstream(part + ".tmp") << "garbage";
  OutputOptions out;
  {
    H5Reader h(part);
    out.continue_from = read_checkpoint(h);
  }
  ASSERT_EQ(run_quietly(spec, {}, out), 0);
  const std::string ref = dir.file("ref.h5");
  ASSERT_EQ(run_quietly(spec_of(scene(ref, kVolume, kEuler, 5.0, 5.0)), {}), 0);
  expect_same_run(ref, file);
}

std::string output_error(const std::string& file, OutputOptions out = {}) {
  try {
    check_output(file, out);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(Checkpoint, OutputIsCheckedBeforeComputing) {
  TempDir dir;
  EXPECT_NE(output_error("").find("[output] file = \"\" is not a file name"), std::string::npos);
  EXPECT_NE(output_error(".").find("is not a file name"), std::string::npos);
  EXPECT_NE(output_error(dir.file("")).find("is not a file name"), std::string::npos);
  EXPECT_NE(output_error(dir.file("no/such/dir/x.h5")).find("directory that does not exist"),
            std::string::npos);
  fs::create_directories(dir.file("sub"));
  EXPECT_NE(output_error(dir.file("sub")).find("is a directory"), std::string::npos);
  std::ofstream(dir.file("old.h5")) << "x";
  EXPECT_NE(output_error(dir.file("old.h5")).find("exists; pass --force"), std::string::npos);
  OutputOptions force;
  force.force = true;
  EXPECT_EQ(output_error(dir.file("old.h5"), force), "no error");
  std::ofstream(dir.file("new.h5.part")) << "x";
  EXPECT_NE(output_error(dir.file("new.h5")).find("--resume"), std::string::npos);
  if (::geteuid() != 0) {  // root writes into read-only directories
    fs::create_directories(dir.file("ro"));
    fs::permissions(dir.file("ro"), fs::perms::owner_read | fs::perms::owner_exec);
    EXPECT_NE(output_error(dir.file("ro/x.h5")).find("not writable"), std::string::npos);
    fs::permissions(dir.file("ro"), fs::perms::owner_all);
  }
  // run_and_write checks before its first step: nothing is written, nothing computed.
  const RunSpec spec = spec_of(scene(dir.file("no/such/x.h5"), kVolume, kEuler, 1000.0, 1000.0));
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_THROW(run_quietly(spec, {}), ConfigError);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
}

// ---- The command line: real signals, SIGKILL, exit codes ------------------------------------

struct Child {
  pid_t pid = -1;
  // The exit status (128 + signal when killed). A child that runs on past `limit_seconds` (a run
  // that should have been refused and computes instead) is killed and fails the test, rather
  // than hanging it until ctest's timeout.
  int wait(double limit_seconds = 600.0) const {
    int status = 0;
    const auto t0 = std::chrono::steady_clock::now();
    while (::waitpid(pid, &status, WNOHANG) == 0) {
      if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() >
          limit_seconds) {
        ::kill(pid, SIGKILL);
        ::waitpid(pid, &status, 0);
        ADD_FAILURE() << "a jamflow process ran longer than " << limit_seconds << " s: killed";
        return -1;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    if (WIFSIGNALED(status))
      return 128 + WTERMSIG(status);
    return WEXITSTATUS(status);
  }
};

Child spawn(std::vector<std::string> args) {
  args.insert(args.begin(), JAMFLOW_CLI);
  std::vector<char*> argv;
  for (auto& a : args)
    argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  Child c;
  EXPECT_EQ(posix_spawn(&c.pid, argv[0], &actions, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);
  return c;
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

// Waits until `path` exists and has been replaced at least `changes` times (checkpoints).
void wait_for_checkpoints(const std::string& path, int changes) {
  fs::file_time_type last{};
  int seen = 0;
  for (int k = 0; k < 20000 && seen < changes; ++k) {
    std::error_code ec;
    const auto t = fs::last_write_time(path, ec);
    if (!ec && t != last) {
      last = t;
      ++seen;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

TEST(ResumeCli, SigkillAfterACheckpointThenResumeGivesTheUninterruptedRun) {
  TempDir dir;
  const std::string ref = dir.file("ref.h5"), cut = dir.file("cut.h5");
  write_text(dir.file("ref.toml"), scene(ref, kPressure, kEuler, 60.0, 60.0));
  write_text(dir.file("cut.toml"), scene(cut, kPressure, kEuler, 60.0, 60.0));
  ASSERT_EQ(spawn({"run", dir.file("ref.toml"), "-q"}).wait(), 0);
  Child c = spawn({"run", dir.file("cut.toml"), "-q"});
  wait_for_checkpoints(cut + ".part", 3);
  ::kill(c.pid, SIGKILL);
  EXPECT_EQ(c.wait(), 128 + SIGKILL);
  if (fs::exists(cut)) {
    GTEST_SKIP() << "the run finished before it was killed";
  }
  ASSERT_TRUE(fs::exists(cut + ".part"));
  EXPECT_EQ(spawn({"run", "--resume", cut + ".part", "-q"}).wait(), 0);
  expect_same_run(ref, cut);
  EXPECT_FALSE(fs::exists(cut + ".part"));
}

TEST(ResumeCli, SignalsGiveTheirExitCodesAndUsr1Checkpoints) {
  TempDir dir;
  for (int sig : {SIGTERM, SIGINT, SIGHUP}) {
    const std::string out = dir.file("s" + std::to_string(sig) + ".h5");
    write_text(dir.file("s.toml"), scene(out, kVolume, kEuler, 1e4, 1e4));
    Child c = spawn({"run", dir.file("s.toml"), "-q"});
    wait_for_checkpoints(out + ".part", 1);
    const auto t0 = std::chrono::steady_clock::now();
    ::kill(c.pid, sig);
    EXPECT_EQ(c.wait(), 128 + sig) << sig;
    // Stopped within a second, with a checkpoint that says why.
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 1.0);
    H5Reader h(out + ".part");
    EXPECT_NE(h.attr_string("/", "status").find("interrupted at t = "), std::string::npos);
  }
  // SIGUSR1: a checkpoint, and the run goes on to the end.
  const std::string out = dir.file("usr1.h5");
  write_text(dir.file("u.toml"), scene(out, kVolume, kEuler, 20.0, 20.0) +
                                     "");  // checkpoint_every is tiny: the signal adds one
  Child c = spawn({"run", dir.file("u.toml"), "-q"});
  wait_for_checkpoints(out + ".part", 1);
  ::kill(c.pid, SIGUSR1);
  EXPECT_EQ(c.wait(), 0);
  EXPECT_TRUE(fs::exists(out));
}

TEST(ResumeCli, ExistingOutputNeedsForce) {
  TempDir dir;
  const std::string out = dir.file("o.h5");
  write_text(dir.file("o.toml"), scene(out, kVolume, kEuler, 1.0, 5.0));
  ASSERT_EQ(spawn({"run", dir.file("o.toml"), "-q"}).wait(), 0);
  EXPECT_EQ(spawn({"run", dir.file("o.toml"), "-q"}).wait(), 2);
  EXPECT_EQ(spawn({"run", dir.file("o.toml"), "-q", "--force"}).wait(), 0);
}

}  // namespace
}  // namespace jamflow

namespace jamflow {
namespace {

std::string bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// --extend that would not lengthen the window, and --resume of a finished file renamed .part,
// are refused (exit 2) and leave the finished file as it was: its summary is never replaced by
// one of nothing.
TEST(ExtendCli, RefusesWhatWouldNotLengthenTheWindowAndKeepsTheFile) {
  TempDir dir;
  const std::string out = dir.file("fin.h5");
  write_text(dir.file("fin.toml"), scene(out, kVolume, kEuler, 10.0, 20.0));
  ASSERT_EQ(spawn({"run", dir.file("fin.toml"), "-q"}).wait(), 0);
  const std::string before = bytes_of(out);
  const auto names = H5Reader(out).attr_names("/summary");
  // sample_every = 0.5: t_av = 20.25 is less than one sample longer.
  for (const std::vector<std::string>& extra : {std::vector<std::string>{},
                                                {"--set", "run.t_av=20.0"},
                                                {"--set", "run.t_av=20.25"},
                                                {"--set", "run.t_av=10.0"},
                                                {"--set", "run.threads=1"},
                                                {"--set", "output.checkpoint_every=5"}}) {
    std::vector<std::string> args = {"run", "--extend", out, "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    const int status = spawn(args).wait();
    // t_av = 10 is refused before (the run has reached further), the others by the new check.
    EXPECT_EQ(status, 2) << (extra.empty() ? "no --set" : extra.back());
    EXPECT_TRUE(bytes_of(out) == before) << (extra.empty() ? "no --set" : extra.back());
  }
  // A finished file renamed .part is not "resumed" into a file without a summary.
  const std::string part = dir.file("ren.h5.part");
  fs::copy_file(out, part);
  EXPECT_EQ(spawn({"run", "--resume", part, "-q"}).wait(), 2);
  EXPECT_TRUE(bytes_of(part) == before);
  EXPECT_FALSE(fs::exists(dir.file("ren.h5")));
  // One sample longer is an extension, with the whole summary.
  ASSERT_EQ(spawn({"run", "--extend", out, "--set", "run.t_av=20.5", "-q"}).wait(), 0);
  const H5Reader r(out);
  EXPECT_EQ(r.attr_names("/summary"), names);
  EXPECT_TRUE(std::isfinite(r.attr_double("/summary", "eta")));
  EXPECT_EQ(r.read_doubles("/timeseries/time").size(), 62u);  // t = 0 to 30.5 every 0.5
}

}  // namespace
}  // namespace jamflow

namespace jamflow {
namespace {

// Replaces (or deletes, with value nullptr) a string attribute of an existing HDF5 file: an
// edit by hand, as h5py would make it.
void edit_attr(const std::string& path, const std::string& object, const std::string& name,
               const char* value) {
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(f, 0) << path;
  const hid_t o = H5Oopen(f, object.c_str(), H5P_DEFAULT);
  ASSERT_GE(o, 0) << object;
  if (H5Aexists(o, name.c_str()) > 0)
    H5Adelete(o, name.c_str());
  if (value) {
    const hid_t t = H5Tcopy(H5T_C_S1);
    H5Tset_size(t, H5T_VARIABLE);
    H5Tset_cset(t, H5T_CSET_UTF8);
    const hid_t s = H5Screate(H5S_SCALAR);
    const hid_t a = H5Acreate2(o, name.c_str(), t, s, H5P_DEFAULT, H5P_DEFAULT);
    H5Awrite(a, t, &value);
    H5Aclose(a);
    H5Sclose(s);
    H5Tclose(t);
  }
  H5Oclose(o);
  H5Fclose(f);
}

// A checkpoint of a run stopped by SIGTERM; empty when the run finished first.
// Waits (up to 10 minutes) until the checkpoint at `path` holds `samples` samples: a run that is
// stopped only after it has moved on, whatever the machine's load (a constant-pressure run
// stopped before its first step holds a state no different from a constant-volume one).
void wait_for_samples(const std::string& path, std::size_t samples) {
  for (int k = 0; k < 12000; ++k) {
    try {
      if (fs::exists(path) && H5Reader(path).read_doubles("/timeseries/time").size() >= samples)
        return;
    } catch (const IoError&) {
      // not there yet
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ADD_FAILURE() << path << " did not reach " << samples << " samples in 10 minutes";
}

std::string stopped_part(const TempDir& dir, const std::string& name, const char* ensemble) {
  const std::string out = dir.file(name + ".h5");
  write_text(dir.file(name + ".toml"), scene(out, ensemble, kEuler, 1e4, 1e4));
  Child c = spawn({"run", dir.file(name + ".toml"), "-q"});
  wait_for_samples(out + ".part", 4);
  ::kill(c.pid, SIGTERM);
  return c.wait() == 128 + SIGTERM ? out + ".part" : "";
}

// --resume of a checkpoint whose scene or version was edited: one line, exit 2, nothing run.
// Each edited field separately, with the digest and (a file written before digests) without.
TEST(ResumeCli, RefusesAnEditedSceneOrVersion) {
  TempDir dir;
  const std::string part = stopped_part(dir, "cv", kVolume);
  ASSERT_FALSE(part.empty());
  const std::string scene_text = H5Reader(part).attr_string("/", "scene");
  auto edited = [&](const std::vector<std::string>& sets) {
    Scene s = Scene::parse(scene_text, "stored");
    for (const auto& a : sets)
      s.set(a);
    return s.text();
  };
  const std::vector<std::pair<std::string, std::vector<std::string>>> edits = {
      {"N", {"system.N=200"}},
      {"shear rate", {"shear.rate=0.2"}},
      {"alpha_r", {"system.alpha=2.5"}},
      {"ensemble", {"ensemble.kind=\"constant_pressure\"", "ensemble.pressure=0.01"}},
      {"integrator", {"integrator.kind=\"respa\"", "integrator.n_inner=2"}},
  };
  int k = 0;
  for (const bool digest : {true, false}) {
    for (const auto& [what, sets] : edits) {
      if (!digest && what != "N")
        continue;     // without the digest, the state tells N (and the ensemble, below)
      char name[32];  // (not "e" + std::to_string(k): GCC 12's -Wrestrict false positive)
      std::snprintf(name, sizeof name, "e%d.h5.part", k++);
      const std::string copy = dir.file(name);
      fs::copy_file(part, copy);
      edit_attr(copy, "/", "scene", edited(sets).c_str());
      if (!digest)
        edit_attr(copy, "/checkpoint", "digest", nullptr);
      EXPECT_EQ(spawn({"run", "--resume", copy, "-q"}).wait(), 2) << what << " digest " << digest;
      EXPECT_FALSE(fs::exists(copy.substr(0, copy.size() - 5))) << what;
    }
  }
  // The version string.
  const std::string v = dir.file("version.h5.part");
  fs::copy_file(part, v);
  edit_attr(v, "/", "version", "9.9.9");
  EXPECT_EQ(spawn({"run", "--resume", v, "-q"}).wait(), 2);
  // A constant-pressure checkpoint under a constant-volume scene, with and without the digest.
  const std::string cp = stopped_part(dir, "cp", kPressure);
  ASSERT_FALSE(cp.empty());
  Scene as_cv = Scene::parse(H5Reader(cp).attr_string("/", "scene"), "stored");
  as_cv.set_section("ensemble", toml::table{{"kind", "constant_volume"}});
  for (const bool digest : {true, false}) {
    const std::string copy = dir.file(std::string("cp") + (digest ? "d" : "n") + ".h5.part");
    fs::copy_file(cp, copy);
    edit_attr(copy, "/", "scene", as_cv.text().c_str());
    if (!digest)
      edit_attr(copy, "/checkpoint", "digest", nullptr);
    EXPECT_EQ(spawn({"run", "--resume", copy, "-q"}).wait(), 2) << "digest " << digest;
  }
}

// A checkpoint written before digests were stored still resumes, and so does one with only
// run.threads changed.
TEST(ResumeCli, OlderCheckpointsWithoutDigestStillResume) {
  TempDir dir;
  const std::string out = dir.file("old.h5");
  // Long enough (4e4 steps) to be stopped after its second checkpoint, short enough to resume
  // to the end in about a second; under a sanitizer (minutes for the full length), a tenth.
  const double t = testing_support::shortened(1000.0, 100.0);
  write_text(dir.file("old.toml"), scene(out, kPressure, kEuler, t, t));
  Child c = spawn({"run", dir.file("old.toml"), "-q"});
  wait_for_checkpoints(out + ".part", 2);
  ::kill(c.pid, SIGTERM);
  if (c.wait() != 128 + SIGTERM)
    GTEST_SKIP() << "the run finished before it was stopped";
  edit_attr(out + ".part", "/checkpoint", "digest", nullptr);
  EXPECT_EQ(spawn({"run", "--resume", out + ".part", "--set", "run.threads=1", "-q"}).wait(), 0);
  EXPECT_TRUE(fs::exists(out));
}

// A stopped run leaves its state as OUT.last.xyz; once resumed to the end, only OUT.final.xyz
// is left (the stopped state is superseded).
TEST(ResumeCli, ResumedRunLeavesOnlyTheFinalXyz) {
  TempDir dir;
  const std::string out = dir.file("stop.h5");
  // A checkpoint every millisecond rewrites the whole series each time: under a sanitizer the
  // full length took 175 CPU seconds, and past the 600 s limit on a loaded machine.
  const double t = testing_support::shortened(1000.0, 100.0);
  write_text(dir.file("stop.toml"), scene(out, kPressure, kEuler, t, t));
  Child c = spawn({"run", dir.file("stop.toml"), "-q"});
  wait_for_checkpoints(out + ".part", 2);
  ::kill(c.pid, SIGTERM);
  if (c.wait() != 128 + SIGTERM)
    GTEST_SKIP() << "the run finished before it was stopped";
  ASSERT_TRUE(fs::exists(dir.file("stop.last.xyz")));
  EXPECT_FALSE(fs::exists(dir.file("stop.final.xyz")));
  EXPECT_EQ(spawn({"run", "--resume", out + ".part", "-q"}).wait(), 0);
  EXPECT_TRUE(fs::exists(dir.file("stop.final.xyz")));
  EXPECT_FALSE(fs::exists(dir.file("stop.last.xyz")));
}

}  // namespace
}  // namespace jamflow
