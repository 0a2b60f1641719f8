// `jamflow` as a user runs it: bad usage and bad input exit with status 2 and one line on
// stderr naming what is wrong and what is allowed, before any computation; --help exits 0.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

struct Outcome {
  int status = -1;  // exit status, or -1 if the process did not exit normally
  std::string out, err;
  int err_lines() const {
    int n = 0;
    for (char c : err)
      n += c == '\n';
    return n;
  }
};

// Appends s in single quotes for the shell. (Appending, not "x" + std::string: GCC 12 warns
// about that with -Wrestrict.)
void append_quoted(std::string& out, const std::string& s) {
  out += '\'';
  for (char c : s) {
    if (c == '\'')
      out += "'\\''";
    else
      out += c;
  }
  out += '\'';
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

class ExitStatus : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("jamflow_test_exit_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string file(const std::string& name, const std::string& text) const {
    const fs::path p = dir_ / name;
    std::ofstream(p) << text;
    return p.string();
  }

  // Runs jamflow with the arguments in the scratch folder (outputs land there).
  Outcome run(const std::vector<std::string>& args) const {
    std::string cmd = "cd ";
    append_quoted(cmd, dir_.string());
    cmd += " && ";
    append_quoted(cmd, JAMFLOW_BIN);
    for (const auto& a : args) {
      cmd += ' ';
      append_quoted(cmd, a);
    }
    cmd += " >";
    append_quoted(cmd, (dir_ / "stdout").string());
    cmd += " 2>";
    append_quoted(cmd, (dir_ / "stderr").string());
    const int raw = std::system(cmd.c_str());
    Outcome o;
    o.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
    o.out = slurp(dir_ / "stdout");
    o.err = slurp(dir_ / "stderr");
    return o;
  }

  fs::path dir_;
};

// Status 2, exactly one stderr line that contains `want`.
void expect_usage_error(const Outcome& o, const std::string& want) {
  EXPECT_EQ(o.status, 2) << o.err;
  EXPECT_EQ(o.err_lines(), 1) << o.err;
  EXPECT_NE(o.err.find(want), std::string::npos) << o.err;
}

constexpr const char* kScene =
    "[system]\nN = 20\nphi = 0.5\n"
    "[ensemble]\nkind = \"constant_volume\"\n"
    "[shear]\nrate = 1e-3\n"
    "[integrator]\nkind = \"euler\"\ndt = 0.1\n"
    "[run]\nt_eq = 0\nt_av = 2\nsample_every = 0.1\n";

TEST_F(ExitStatus, HelpExitsZero) {
  EXPECT_EQ(run({"--help"}).status, 0);
  const Outcome help = run({"run", "--help"});
  EXPECT_EQ(help.status, 0);
  EXPECT_NE(help.out.find("--output"), std::string::npos) << help.out;
  EXPECT_EQ(run({"study", "--help"}).status, 0);
  EXPECT_EQ(run({"analyze", "--help"}).status, 0);
  // `scene --help` says what the command does; it printed the scene.
  const Outcome scene_help = run({"scene", "--help"});
  EXPECT_EQ(scene_help.status, 0);
  EXPECT_NE(scene_help.out.find("default scene"), std::string::npos) << scene_help.out;
  EXPECT_EQ(scene_help.out.find("[system]"), std::string::npos) << scene_help.out;
  const Outcome scene = run({"scene"});
  EXPECT_EQ(scene.status, 0);
  EXPECT_NE(scene.out.find("[system]"), std::string::npos) << scene.out;
  expect_usage_error(run({"scene", "extra"}), "jamflow scene: error: ");
}

TEST_F(ExitStatus, RunParseErrorsAreUsageErrors) {
  // CLI11's own codes would be 109 (extras), 105 (validation) and 106 (argument mismatch).
  expect_usage_error(run({"run", "--no-such-option"}), "jamflow run: error: ");
  expect_usage_error(run({"run", "a.toml", "b.toml"}), "jamflow run: error: ");
  expect_usage_error(run({"run", "--threads", "-1"}),
                     "jamflow run: error: --threads: Value -1 not in range 0 to 1024");
  expect_usage_error(run({"run", "--replicas", "0"}), "jamflow run: error: ");
  expect_usage_error(run({"run", "--threads", "two"}), "jamflow run: error: ");
  expect_usage_error(run({"run", "--output"}), "jamflow run: error: ");
}

TEST_F(ExitStatus, OtherCommandsParseErrorsAreUsageErrors) {
  expect_usage_error(run({"study", "--no-such-option"}), "jamflow study: error: ");
  expect_usage_error(run({"study"}), "jamflow study: error: ");
  expect_usage_error(run({"study", "stability", "--preset", "huge"}), "jamflow study: error: ");
  expect_usage_error(run({"study", "no-such-study"}), "unknown study 'no-such-study'");
  // No preset: an error naming the presets, not a silent `quick` (nothing is written).
  expect_usage_error(run({"study", "timestep"}),
                     "jamflow study timestep: --preset is not given; allowed: quick, standard, "
                     "paper");
  EXPECT_FALSE(fs::exists(dir_ / "out"));
  expect_usage_error(run({"analyze", "--bogus"}), "jamflow analyze: error: ");
  expect_usage_error(run({"frobnicate"}), "unknown command 'frobnicate'");
  expect_usage_error(run({}), "no command given");
}

TEST_F(ExitStatus, MissingOrUnreadableSceneIsBadInput) {
  const std::string missing = (dir_ / "missing.toml").string();
  expect_usage_error(run({"run", missing}), "cannot open scene file '" + missing + "'");
  expect_usage_error(run({"run", dir_.string()}), "is a directory");
  EXPECT_FALSE(fs::exists(dir_ / "jamflow.h5"));
}

TEST_F(ExitStatus, BadSceneAndInitAreBadInputBeforeAnyRun) {
  const std::string bad = file("bad.toml", std::string(kScene) + "[output]\nfile = 3\n");
  expect_usage_error(run({"run", bad}), "[output] file = 3 is not a string");
  const std::string syntax = file("syntax.toml", "[system\nN = 3\n");
  expect_usage_error(run({"run", syntax}), "syntax.toml:1: ");

  // The init configuration: a missing file and an XYZ file with two frames.
  const std::string no_init = file("no_init.toml", std::string(kScene) + "");
  expect_usage_error(run({"run", no_init, "--set", "system.init=\"nope.xyz\""}),
                     "nope.xyz: cannot open for reading");
  const std::string frame =
      "1\nLattice=\"6 0 0 0 6 0 0 0 6\" Properties=species:S:1:pos:R:3:radius:R:1\n"
      "A 1 1 1 0.5\n";
  file("two.xyz", frame + frame);
  const std::string scene = file("init.toml",
                                 "[system]\ninit = \"two.xyz\"\n"
                                 "[ensemble]\nkind = \"constant_volume\"\n"
                                 "[shear]\nrate = 1e-3\n"
                                 "[integrator]\nkind = \"euler\"\ndt = 0.1\n"
                                 "[run]\nt_eq = 0\nt_av = 2\nsample_every = 0.1\n");
  expect_usage_error(run({"run", scene}), "two.xyz:4: the file has 2 frames");
  EXPECT_FALSE(fs::exists(dir_ / "jamflow.h5"));
  EXPECT_FALSE(fs::exists(dir_ / "jamflow.h5.part"));
}

// Messages that misled (issue 34): each names the option or file, the value and what is allowed,
// on one line with status 2, or says only what can be done.
TEST_F(ExitStatus, MessagesSayWhatIsWrongAndWhatCanBeDone) {
  // A failed run: no "continue it with --resume" (which then says a failed run cannot be).
  const std::string failing = file("fail.toml",
                                   "[system]\nN = 60\nphi = 0.5\n"
                                   "[ensemble]\nkind = \"constant_pressure\"\npressure = 10\n"
                                   "xi_V = 1e-6\n[shear]\nrate = 1e-3\n"
                                   "[integrator]\nkind = \"euler\"\ndt = 0.1\n"
                                   "[run]\nt_eq = 0\nt_av = 2\nsample_every = 0.1\n");
  const Outcome failed = run({"run", failing, "-o", "fail.h5", "-q"});
  EXPECT_EQ(failed.status, 1) << failed.err;
  EXPECT_NE(failed.err.find("a failed run cannot be continued"), std::string::npos) << failed.err;
  EXPECT_EQ(failed.err.find("--resume"), std::string::npos) << failed.err;

  // --replicas 0 names the range, not a 309-digit bound.
  const Outcome zero = run({"run", "--replicas", "0"});
  expect_usage_error(zero, "--replicas: Value 0 not in range 1 to 10000");
  EXPECT_LT(zero.err.size(), 200u) << zero.err;

  // An empty output or folder is refused, not replaced by the default.
  expect_usage_error(run({"run", "-o", ""}), "--output: '' is empty");
  expect_usage_error(run({"sweep", "s.toml", "--out", ""}), "--out: '' is empty");
  expect_usage_error(run({"study", "timestep", "--out", ""}), "--out: '' is empty");
  EXPECT_FALSE(fs::exists(dir_ / "jamflow.h5"));
  EXPECT_FALSE(fs::exists(dir_ / "out"));

  // A folder to reuse that is not there; a Slurm time limit sbatch would reject.
  expect_usage_error(run({"sweep", "s.toml", "--reuse", (dir_ / "nowhere").string()}),
                     "--reuse: '" + (dir_ / "nowhere").string() + "' is not a folder");
  for (const char* bad : {"99:99", "1:60:00", "1-24:00", "12:00:0000"})
    expect_usage_error(run({"sweep", "s.toml", "--slurm", "--time", bad}),
                       "--time '" + std::string(bad) + "': allowed a Slurm time limit");

  // An unknown analysis is named.
  expect_usage_error(run({"analyze", "bogus"}), "unknown analysis 'bogus'; allowed: hard-sphere");

  // A value no fit can use (subnormal P) is named by file and line before any fitting.
  file("tiny.csv",
       "N,imposed_pressure,shear_rate,phi,phi_err,mu,mu_err\n100,1e-4,1e-6,0.63,1e-4,0.2,0.01\n"
       "100,1e-320,1e-6,0.63,1e-4,0.2,0.01\n");
  expect_usage_error(run({"analyze", "hard-sphere", "tiny.csv", "-o", "t.json", "--no-plots"}),
                     "tiny.csv:3: column 'imposed_pressure': imposed_pressure = ");
  EXPECT_FALSE(fs::exists(dir_ / "t.json"));

  // Two particles at one place in an init file: bad input naming the lines, not a failed run.
  file("dup.xyz",
       "3\nLattice=\"6 0 0 0 6 0 0 0 6\" Properties=species:S:1:pos:R:3:radius:R:1\n"
       "H 1 1 1 0.5\nH 3 3 3 0.5\nHe 1 1 1 0.7\n");
  const std::string dup = file("dup.toml",
                               "[system]\ninit = \"dup.xyz\"\n"
                               "[ensemble]\nkind = \"constant_volume\"\n"
                               "[shear]\nrate = 1e-3\n"
                               "[integrator]\nkind = \"euler\"\ndt = 0.1\n"
                               "[run]\nt_eq = 0\nt_av = 2\nsample_every = 0.1\n");
  expect_usage_error(run({"run", dup, "-o", "dup.h5"}),
                     "dup.xyz:5: particle 3 is at the same position as particle 1 (line 3)");
  EXPECT_FALSE(fs::exists(dir_ / "dup.h5.part"));
}

// The progress line under t_eq = "auto": the run's length is decided as it goes (the transient's
// end plus t_av), so the estimate grows with the run, no line shows a time beyond its estimate,
// and the last line shows the run complete at 100 %. (It ended at 91.5 % of the first estimate
// while the run went on.)
TEST_F(ExitStatus, ProgressUnderAutoLengthGrowsAndEndsAt100Percent) {
  // Random start at phi = 0.6: the pressure relaxes over the whole first t_av, so the transient
  // found is longer than zero and the run goes beyond its first estimate (t_av = 20).
  const std::string scene = file("auto.toml",
                                 "[system]\nN = 100\nphi = 0.6\n"
                                 "[ensemble]\nkind = \"constant_volume\"\n"
                                 "[shear]\nrate = 1e-2\n"
                                 "[integrator]\nkind = \"euler\"\ndt = 0.1\n"
                                 "[run]\nt_eq = \"auto\"\nt_av = 20\nsample_every = 0.1\n");
  const Outcome o = run({"run", scene, "-o", "auto.h5"});
  ASSERT_EQ(o.status, 0) << o.err;
  struct Line {
    double t, total, percent;
    std::string text;
  };
  std::vector<Line> lines;
  std::istringstream in(o.err);
  for (std::string text; std::getline(in, text);) {
    Line l{0, 0, 0, text};
    if (std::sscanf(text.c_str(), "[auto] t = %lf / %lf %lf%%", &l.t, &l.total, &l.percent) == 3)
      lines.push_back(l);
  }
  ASSERT_GE(lines.size(), 3u) << o.err;
  bool grew = false;
  for (const Line& l : lines) {
    EXPECT_LE(l.t, l.total) << l.text;
    EXPECT_LE(l.percent, 100.0) << l.text;
    grew = grew || l.total > 20.0;
  }
  EXPECT_TRUE(grew) << "the estimate never grew beyond t_av:\n" << o.err;
  const Line& last = lines.back();
  EXPECT_EQ(last.percent, 100.0) << o.err;
  EXPECT_EQ(last.t, last.total) << o.err;
  EXPECT_GT(last.total, 20.0) << o.err;
  EXPECT_NE(last.text.find("done"), std::string::npos) << o.err;
}

// A step that shears by more than a cell length (gdot dt = 2 and 20) runs (it crashed with
// SIGSEGV in the neighbour list); a strain beyond the tilt's round-off is bad input.
TEST_F(ExitStatus, FastShearRunsAndAStrainBeyondRoundOffIsBadInput) {
  const std::string scene = file("fast.toml",
                                 "[system]\nN = 60\nphi = 0.5\n"
                                 "[ensemble]\nkind = \"constant_volume\"\n"
                                 "[shear]\nrate = 1e-3\n"
                                 "[integrator]\nkind = \"euler\"\ndt = 0.1\n"
                                 "[run]\nt_eq = 0\nt_av = 2\nsample_every = 0.1\n");
  for (const char* rate : {"shear.rate=20", "shear.rate=200"}) {
    const Outcome o = run({"run", scene, "--set", rate, "-o", "fast.h5", "--force"});
    EXPECT_EQ(o.status, 0) << rate << ": " << o.err;
    EXPECT_NE(o.err.find("not stable"), std::string::npos) << rate << ": " << o.err;
  }
  expect_usage_error(run({"run", scene, "--set", "shear.rate=1e100", "-o", "huge.h5"}),
                     "[shear] rate = 1e+100 shears the cell by 2e+100 over (t_eq + t_av) = 2; "
                     "allowed a strain of at most 1e+09");
  EXPECT_FALSE(fs::exists(dir_ / "huge.h5.part"));
}

// Run files that libhdf5 cannot read: a truncated copy of a real run, and a corrupt file on
// which libhdf5 1.10.8 itself crashes (tests/analysis/data/README.md). Each is bad input,
// named in one line; the crash stays in the process that read the file.
TEST_F(ExitStatus, CorruptRunFilesAreBadInput) {
  const std::string scene = file("run.toml",
                                 "[system]\nN = 60\nphi = 0.5\n"
                                 "[ensemble]\nkind = \"constant_volume\"\n"
                                 "[shear]\nrate = 1e-3\n"
                                 "[integrator]\nkind = \"euler\"\ndt = 0.1\n"
                                 "[run]\nt_eq = 0\nt_av = 2\nsample_every = 0.1\n");
  ASSERT_EQ(run({"run", scene, "-o", "run.h5"}).status, 0);
  const std::string bytes = slurp(dir_ / "run.h5");
  ASSERT_GT(bytes.size(), 4000u);
  std::ofstream(dir_ / "cut.h5", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  expect_usage_error(run({"analyze", "olsson-teitel", "cut.h5", "-o", "ot.json", "--no-plots"}),
                     "cut.h5: cannot open as an HDF5 file");
  const std::string crash = std::string(JAMFLOW_ANALYSIS_TEST_DATA) + "/h5hg_read_sigsegv.h5";
  for (const char* analysis : {"olsson-teitel", "hard-sphere"}) {
    const Outcome o = run({"analyze", analysis, crash, "run.h5", "-o", "out.json", "--no-plots"});
    expect_usage_error(o, "h5hg_read_sigsegv.h5: could not be read: the HDF5 library crashed (");
  }
}

}  // namespace
