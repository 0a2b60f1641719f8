// `jamflow` as a user runs it: bad usage and bad input exit with status 2 and one line on
// stderr naming what is wrong and what is allowed, before any computation; --help exits 0.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

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
