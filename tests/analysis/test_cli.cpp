// `jamflow analyze` end to end: CSV in, JSON + markdown (+ plots) out, exit
// codes and one-line error messages.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "analysis/analyze_cli.hpp"
#include "analysis/json.hpp"
#include "analysis/plots.hpp"
#include "tests/analysis/synthetic.hpp"
#include "tests/analysis/test_util.hpp"

namespace jamflow::analysis {
namespace {

using testing::CliRun;
using testing::num;
using testing::read_text;
using testing::run_analyze;
using testing::ScratchDir;

std::string granular_csv(const std::vector<GranularPoint>& pts) {
  std::string s = "N,imposed_pressure,shear_rate,phi,phi_err,mu,mu_err\n";
  for (const auto& p : pts) {
    s += std::to_string(p.n) + "," + num(p.pressure) + "," + num(p.shear_rate) + "," + num(p.phi) +
         "," + num(p.phi_err) + "," + num(p.mu) + "," + num(p.mu_err) + "\n";
  }
  return s;
}

std::string shear_csv(const std::vector<ShearPoint>& pts) {
  std::string s = "N,phi,shear_rate,sigma_xy,sigma_xy_err\n";
  for (const auto& p : pts) {
    s += std::to_string(p.n) + "," + num(p.phi) + "," + num(p.shear_rate) + "," + num(p.sigma) +
         "," + num(p.sigma_err) + "\n";
  }
  return s;
}

// With the measured pressure, as a collected constant-volume sweep table has it.
std::string shear_csv_with_pressure(const std::vector<ShearPoint>& pts) {
  std::string s = "N,phi,shear_rate,sigma_xy,sigma_xy_err,pressure,pressure_err\n";
  for (const auto& p : pts) {
    s += std::to_string(p.n) + "," + num(p.phi) + "," + num(p.shear_rate) + "," + num(p.sigma) +
         "," + num(p.sigma_err) + "," + num(p.pressure) + "," + num(p.pressure_err) + "\n";
  }
  return s;
}

// Every field the issue names is an object {"value", "error"} with finite numbers.
void expect_measured(const Json& j, const std::string& what) {
  ASSERT_TRUE(j.is_object()) << what;
  EXPECT_TRUE(j.at("value").is_number()) << what;
  EXPECT_TRUE(j.at("error").is_number()) << what;
  EXPECT_GE(j.at("error").as_number(), 0.0) << what;
}

TEST(Cli, HelpAndUsageErrors) {
  EXPECT_EQ(run_analyze({"--help"}).code, 0);
  EXPECT_EQ(run_analyze({"hard-sphere", "--help"}).code, 0);
  CliRun none = run_analyze({});
  EXPECT_EQ(none.code, 2);
  EXPECT_NE(none.err.find("jamflow analyze: error:"), std::string::npos) << none.err;
  EXPECT_EQ(run_analyze({"hard-sphere", "x.csv"}).code, 2);  // -o missing
  CliRun missing = run_analyze({"hard-sphere", "/nonexistent/x.csv", "-o", "/tmp/x.json"});
  EXPECT_EQ(missing.code, 2);
  EXPECT_NE(missing.err.find("/nonexistent/x.csv: cannot open file"), std::string::npos)
      << missing.err;
  // One line per error.
  EXPECT_EQ(std::count(missing.err.begin(), missing.err.end(), '\n'), 1);
}

TEST(Cli, HardSphereWritesJsonAndReport) {
  ScratchDir dir;
  testing::GranularSpec spec;
  spec.sizes = {100, 300, 1000, 3000, 10000};
  auto data = dir.write("granular.csv", granular_csv(testing::make_granular(spec)));
  const std::string out = dir.file("hs.json");
  CliRun r = run_analyze({"hard-sphere", data, "-o", out, "--no-plots", "--window", "0.58:0.635"});
  ASSERT_EQ(r.code, 0) << r.err;
  Json j = Json::parse(read_text(out));
  for (const char* n : {"100", "1000", "10000"}) {
    const Json& s = j.at("sizes").at(n);
    for (const char* k : {"phi_J", "b_phi", "C_phi", "mu_J", "b_mu", "C_mu"}) {
      expect_measured(s.at(k), std::string(n) + "." + k);
    }
    EXPECT_GE(s.at("points_used").as_number(), 4.0);
  }
  for (const char* p : {"phi_J", "b_phi", "C_phi", "mu_J", "b_mu", "C_mu"}) {
    const Json& e = j.at("extrapolated").at(p);
    const std::string status = e.at("status").as_string();
    ASSERT_NE(status, "failed") << p;
    if (status == "not_resolved")
      continue;
    expect_measured(e.at("inf"), std::string(p) + ".inf");
    if (status == "fit") {
      expect_measured(e.at("A"), std::string(p) + ".A");
      expect_measured(e.at("alpha"), std::string(p) + ".alpha");
    }
  }
  // phi_J(N) varies strongly with N: its power law is always resolved.
  EXPECT_EQ(j.at("extrapolated").at("phi_J").at("status").as_string(), "fit");
  expect_measured(j.at("nu").at("from_phi"), "nu.from_phi");
  expect_measured(j.at("nu").at("from_mu"), "nu.from_mu");
  expect_measured(j.at("viscosity").at("effective_exponent"), "effective exponent");
  EXPECT_EQ(j.at("viscosity").at("window").at(1).as_number(), 0.635);
  const std::string md = read_text(dir.file("hs.md"));
  EXPECT_NE(md.find("compared with Table 2"), std::string::npos);
  EXPECT_NE(md.find("| phi_J | 0.647"), std::string::npos) << md;
}

// The typed entry the studies call is the command's analysis: with the options the flags set, it
// writes the same JSON and report and returns the same code; it refuses an output that is an
// input as the command does.
TEST(Cli, TypedEntryIsTheCommandsAnalysis) {
  ScratchDir dir;
  testing::GranularSpec spec;
  spec.sizes = {100, 300, 1000, 3000, 10000};
  auto data = dir.write("granular.csv", granular_csv(testing::make_granular(spec)));
  CliRun cli = run_analyze(
      {"hard-sphere", data, "-o", dir.file("cli.json"), "--no-plots", "--window", "0.58:0.635"});
  ASSERT_EQ(cli.code, 0) << cli.err;
  HardSphereOptions o;
  o.window_min = 0.58;
  o.window_max = 0.635;
  ::testing::internal::CaptureStderr();
  const int code = analyze_hard_sphere_files({data}, o, {dir.file("typed.json"), false});
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(code, cli.code) << err;
  EXPECT_EQ(err, cli.err);
  EXPECT_EQ(read_text(dir.file("typed.json")), read_text(dir.file("cli.json")));
  EXPECT_EQ(read_text(dir.file("typed.md")), read_text(dir.file("cli.md")));
  // A different option is a different analysis (the comparison above can fail).
  o.window_max = 0.63;
  ::testing::internal::CaptureStderr();
  analyze_hard_sphere_files({data}, o, {dir.file("other.json"), false});
  (void)::testing::internal::GetCapturedStderr();
  EXPECT_NE(read_text(dir.file("other.json")), read_text(dir.file("cli.json")));

  const std::string before = read_text(data);
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(analyze_hard_sphere_files({data}, o, {data, false}), 2);
  const std::string refused = ::testing::internal::GetCapturedStderr();
  EXPECT_NE(refused.find("would overwrite the input"), std::string::npos) << refused;
  EXPECT_EQ(read_text(data), before);
}

// An output that is an input is refused before anything is written, however the path is spelled
// (before, `-o d.csv` replaced the data with JSON and exited 0).
TEST(Cli, AnOutputThatIsAnInputIsRefused) {
  ScratchDir dir;
  testing::GranularSpec spec;
  spec.sizes = {100, 1000};
  const std::string text = granular_csv(testing::make_granular(spec));
  auto data = dir.write("d.csv", text);
  std::filesystem::create_directories(dir.file("sub"));
  const std::string other = dir.file("sub") + "/../d.csv";
  for (const std::string& out : {data, other}) {
    CliRun r = run_analyze({"hard-sphere", data, "-o", out, "--no-plots"});
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("would overwrite the input '" + data + "'"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(read_text(data), text);
  }
  // The report beside the JSON counts too: -o d.json writes d.md.
  auto md = dir.write("r.md", text);
  CliRun r = run_analyze({"olsson-teitel", md, "-o", dir.file("r.json"), "--no-plots"});
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("would overwrite the input"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("r.json")));
}

// An unknown analysis is named (it read "A subcommand is required"); -o '' is refused.
TEST(Cli, UnknownAnalysisAndEmptyOutputAreNamed) {
  CliRun bogus = run_analyze({"bogus", "x.csv", "-o", "x.json"});
  EXPECT_EQ(bogus.code, 2);
  EXPECT_NE(bogus.err.find(
                "unknown analysis 'bogus'; allowed: hard-sphere, soft, olsson-teitel, flow-curve"),
            std::string::npos)
      << bogus.err;
  CliRun empty = run_analyze({"hard-sphere", "x.csv", "-o", ""});
  EXPECT_EQ(empty.code, 2);
  EXPECT_NE(empty.err.find("-o '': allowed a file name"), std::string::npos) << empty.err;
}

TEST(Cli, HardSphereReportsBadWindowAsUsageError) {
  ScratchDir dir;
  testing::GranularSpec spec;
  auto data = dir.write("g.csv", granular_csv(testing::make_granular(spec)));
  CliRun r = run_analyze(
      {"hard-sphere", data, "-o", dir.file("hs.json"), "--no-plots", "--window", "0.6"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--window"), std::string::npos) << r.err;
  r = run_analyze(
      {"hard-sphere", data, "-o", dir.file("hs.json"), "--no-plots", "--window", "0.6:0.7"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("phi_J"), std::string::npos) << r.err;
}

TEST(Cli, SoftWritesPerPressureResults) {
  ScratchDir dir;
  testing::GranularSpec spec;
  spec.pressures = {1e-7, 1e-6, 1e-5, 1e-4, 1e-3};
  auto data = dir.write("granular.csv", granular_csv(testing::make_granular(spec)));
  const std::string out = dir.file("soft.json");
  CliRun r = run_analyze({"soft", data, "-o", out, "--no-plots"});
  ASSERT_EQ(r.code, 0) << r.err;
  Json j = Json::parse(read_text(out));
  const Json& s = j.at("sizes").at("1000");
  for (const char* k : {"phi_J0", "c_phi", "x", "mu_J0", "c_mu", "y"})
    expect_measured(s.at(k), k);
  expect_measured(s.at("pressures").at("1e-05").at("phi_J"), "phi_J(1e-5)");
  expect_measured(s.at("pressures").at("1e-05").at("mu_J"), "mu_J(1e-5)");
  expect_measured(s.at("yield").at("exponent_1"), "yield exponent");
  for (const char* k : {"x", "y", "alpha", "phi_J0", "mu_J0"})
    expect_measured(s.at("joint").at(k), std::string("joint.") + k);
  EXPECT_EQ(s.at("joint").at("bootstrap").at("used").as_number(), 200.0);
  // The yield stress against constant-volume data, and a bootstrap count out of range.
  testing::TwoBranchSpec cv;
  cv.phis = {0.66, 0.68};
  cv.gdot_min = 1e-6;
  cv.gdot_max = 1e-4;
  cv.n = 1000;
  auto cv_data = dir.write(
      "cv.csv", shear_csv_with_pressure(testing::make_soft_flow_curves(cv, testing::SoftTruth{})));
  r = run_analyze(
      {"soft", data, "--yield-data", cv_data, "-o", out, "--no-plots", "--bootstrap", "20"});
  ASSERT_EQ(r.code, 0) << r.err;
  const Json y = Json::parse(read_text(out)).at("sizes").at("1000").at("joint").at("yield_data");
  EXPECT_EQ(y.at("phi").size(), 14u);
  CliRun few = run_analyze({"soft", data, "-o", out, "--no-plots", "--bootstrap", "3"});
  EXPECT_EQ(few.code, 2);
  EXPECT_NE(few.err.find("--bootstrap 3"), std::string::npos) << few.err;
  CliRun bad =
      run_analyze({"soft", data, "-o", out, "--no-plots", "--hs-params", "0.4:0.07:x:0.35"});
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("--hs-params"), std::string::npos) << bad.err;
}

TEST(Cli, OlssonTeitelWithPlotsOrAWarningWhenPythonIsMissing) {
  ScratchDir dir;
  testing::TwoBranchSpec spec;
  auto data = dir.write("cv.csv", shear_csv(testing::make_two_branch(spec)));
  const std::string out = dir.file("ot.json");
  // No interpreter: a one-line warning, JSON and markdown still written, exit 0.
  ::setenv("JAMFLOW_PYTHON", "/nonexistent/python3", 1);
  CliRun r = run_analyze(
      {"olsson-teitel", data, "-o", out, "--bootstrap", "10", "--at", "0.6474:1.33:2.55"});
  ::unsetenv("JAMFLOW_PYTHON");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("warning: plots skipped"), std::string::npos) << r.err;
  Json j = Json::parse(read_text(out));
  for (const char* k : {"phi_J", "alpha", "beta"})
    expect_measured(j.at("best").at(k), k);
  expect_measured(j.at("best").at("quality"), "best.quality");
  expect_measured(j.at("at").at("quality"), "at.quality");
  for (const char* s : {"near", "far", "slow", "fast"}) {
    expect_measured(j.at("subsets").at(s).at("phi_J"), s);
    EXPECT_TRUE(j.at("subsets").at(s).contains("trade_off")) << s;
  }
  EXPECT_TRUE(std::filesystem::exists(dir.file("ot.md")));
  // With the build's interpreter: the figure is drawn when matplotlib exists.
  r = run_analyze({"olsson-teitel", data, "-o", out, "--bootstrap", "10"});
  ASSERT_EQ(r.code, 0) << r.err;
  if (r.err.find("plots skipped") == std::string::npos) {
    EXPECT_TRUE(std::filesystem::exists(dir.file("ot_fig9.png")));
  }
}

// The one plot launcher (analysis and studies alike) hands its arguments over as they are: a
// file name with quotes and spaces, which a shell command line would have split or broken.
TEST(PlotLauncher, ArgumentsReachTheScriptVerbatimAndFailuresAreNamed) {
  ScratchDir dir;
  const std::string script = dir.write("echo args.py",
                                       "import sys\n"
                                       "open(sys.argv[1], 'w').write('\\n'.join(sys.argv[2:]))\n"
                                       "sys.exit(int(sys.argv[2]))\n");
  const std::string out = dir.file("it's out.txt");
  const std::vector<std::string> odd = {"0", "a b", "it's", "\"q\"", "$HOME", ""};
  std::vector<std::string> args = {out};
  args.insert(args.end(), odd.begin(), odd.end());
  PlotOutcome o = run_python_plot(script, args);
  ASSERT_EQ(o.status, PlotStatus::kOk) << o.message;
  std::string expected;
  for (std::size_t k = 0; k < odd.size(); ++k)
    expected += (k ? "\n" : "") + odd[k];
  EXPECT_EQ(read_text(out), expected);
  // A script that fails is named with its status; exit 3 means no matplotlib.
  args[1] = "5";
  o = run_python_plot(script, args);
  EXPECT_EQ(o.status, PlotStatus::kFailed);
  EXPECT_NE(o.message.find("'echo args.py' exited with status 5"), std::string::npos) << o.message;
  args[1] = "3";
  EXPECT_EQ(run_python_plot(script, args).status, PlotStatus::kUnavailable);
  ::setenv("JAMFLOW_PYTHON", "/nonexistent/python3", 1);
  o = run_python_plot(script, args);
  ::unsetenv("JAMFLOW_PYTHON");
  EXPECT_EQ(o.status, PlotStatus::kUnavailable);
  EXPECT_NE(o.message.find("/nonexistent/python3"), std::string::npos) << o.message;
}

TEST(Cli, OlssonTeitelFitsTheSoftRheologyWhenPressuresAreMeasured) {
  ScratchDir dir;
  testing::TwoBranchSpec spec;
  spec.points_per_decade = 1;
  auto data = dir.write("cv.csv", shear_csv_with_pressure(
                                      testing::make_soft_flow_curves(spec, testing::SoftTruth{})));
  const std::string out = dir.file("ot.json");
  CliRun r = run_analyze({"olsson-teitel", data, "-o", out, "--bootstrap", "10", "--no-plots"});
  ASSERT_EQ(r.code, 0) << r.err;
  Json j = Json::parse(read_text(out));
  ASSERT_TRUE(j.contains("soft")) << r.err;
  expect_measured(j.at("soft").at("quality"), "soft.quality");
  expect_measured(j.at("soft").at("y"), "soft.y");
  EXPECT_TRUE(j.at("best").contains("quality_bootstrap_spread"));
  // Without the pressure columns the soft law is skipped, and the result says why.
  auto bare = dir.write("bare.csv", shear_csv(testing::make_two_branch(spec)));
  r = run_analyze({"olsson-teitel", bare, "-o", out, "--bootstrap", "10", "--no-plots"});
  ASSERT_EQ(r.code, 0) << r.err;
  j = Json::parse(read_text(out));
  EXPECT_FALSE(j.contains("soft"));
  EXPECT_NE(j.at("soft_skipped").as_string().find("pressure"), std::string::npos);
}

// The slow/fast split is set by --split-shear-rate; the option's former name --split-gdot still
// works, with a deprecation warning, and the two together are refused.
TEST(Cli, SplitShearRateAndItsDeprecatedName) {
  ScratchDir dir;
  testing::TwoBranchSpec spec;
  spec.points_per_decade = 1;
  auto data = dir.write("cv.csv", shear_csv(testing::make_two_branch(spec)));
  const std::string out = dir.file("ot.json");
  CliRun r = run_analyze({"olsson-teitel", data, "-o", out, "--bootstrap", "10", "--no-plots",
                          "--split-shear-rate", "1e-4"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err.find("deprecated"), std::string::npos) << r.err;
  EXPECT_EQ(Json::parse(read_text(out)).at("subset_splits").at("shear_rate").as_number(), 1e-4);
  r = run_analyze({"olsson-teitel", data, "-o", out, "--bootstrap", "10", "--no-plots",
                   "--split-gdot", "2e-4"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("--split-gdot is deprecated; use --split-shear-rate"), std::string::npos)
      << r.err;
  EXPECT_EQ(Json::parse(read_text(out)).at("subset_splits").at("shear_rate").as_number(), 2e-4);
  r = run_analyze({"olsson-teitel", data, "-o", out, "--no-plots", "--split-gdot", "2e-4",
                   "--split-shear-rate", "1e-4"});
  EXPECT_EQ(r.code, 2) << r.err;
}

TEST(Cli, RunFileWithoutSummaryIsAnInputError) {
  ScratchDir dir;
  // An HDF5 signature followed by garbage: recognised as HDF5, then rejected.
  auto path = dir.write("broken.h5", std::string("\x89HDF\r\n\x1a\n", 8) + "garbage");
  CliRun r = run_analyze({"olsson-teitel", path, "-o", dir.file("ot.json"), "--no-plots"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("broken.h5"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace jamflow::analysis
