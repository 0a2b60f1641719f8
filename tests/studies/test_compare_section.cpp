// A study's own report section on a comparison (studies/compare.hpp CompareReportSection): it
// sees every case's plan, analysis and runs (by setting and replica, the diagnostic window
// included), once, and what it returns goes into the one report (without cases, before the
// recommendation) or at the end of OUT/report.md (with cases), not into the cases' reports.
// What the stability and timestep studies need to become comparison plans.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "studies/compare.hpp"
#include "tests/driver/temp_dir.hpp"
#include "tests/studies/jamflow_exe.hpp"

namespace jamflow::studies {
namespace {

namespace fs = std::filesystem;

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// N = 64 harmonic spheres at constant volume, two replicas, Euler at dt = 0.05 (the reference)
// and dt = 1 (twice the step at which Euler first oscillates, SPEC §4), with the diagnostic
// window; `cases`: TOML appended (the [[case]] tables, or nothing).
std::string compare_text(const std::string& cases) {
  return R"(reference = "fine"
replicas = 2
observables = ["sigma_xy"]
diagnose = true
[base.system]
N = 64
phi = 0.60
seed = 7
[base.ensemble]
kind = "constant_volume"
[base.shear]
rate = 1e-2
[base.integrator]
kind = "euler"
dt = 0.05
[base.run]
t_eq = 0.0
t_av = 100.0
[prepare]
t = 100.0
[run]
t_eq = 10.0
t_av = 40.0
sample_every = 1.0
[[setting]]
label = "fine"
[[setting]]
label = "coarse"
integrator.dt = 1.0
[[setting]]
label = "middle"
integrator.dt = 0.1
)" + cases;
}

// The section the test study writes: per case its label, and per setting its replicas' classes.
struct Seen {
  int calls = 0;
  std::vector<std::string> labels;
  std::vector<std::size_t> settings, replicas;
  bool coarse_unstable = true, fine_stable = true;
};

CompareReportSection recording(Seen& seen) {
  return [&seen](const std::vector<CompareCaseOutcome>& cases) {
    ++seen.calls;
    std::string md = "## The test study's section\n\n";
    for (const auto& c : cases) {
      seen.labels.push_back(c.plan->label);
      seen.settings.push_back(c.runs.size());
      for (std::size_t s = 0; s < c.runs.size(); ++s) {
        seen.replicas.push_back(c.runs[s].size());
        const std::string& label = c.plan->settings[s].label;
        for (const DiagnosedRun* r : c.runs[s]) {
          const bool oscillates =
              r->cls.verdict == Verdict::kOscillating || r->cls.verdict == Verdict::kDiverged;
          if (label == "coarse")
            seen.coarse_unstable = seen.coarse_unstable && oscillates;
          if (label == "fine")
            seen.fine_stable = seen.fine_stable && !oscillates && r->complete();
        }
        md += "- case '" + c.plan->label + "', " + label + ": " + std::to_string(c.runs[s].size()) +
              " runs, " + (c.result->settings[s].stable ? "stable" : "unstable") + "\n";
      }
    }
    return md;
  };
}

TEST(CompareSection, SeesEveryCaseAndItsRunsOnceAndGoesIntoTheTopReport) {
  use_test_jamflow();
  const testing_support::TempDir dir("jamflow-compare-section-");
  const ComparePlan plan = parse_compare(compare_text(R"([[case]]
label = "dense"
[[case]]
label = "dilute"
settings = ["fine", "coarse"]
system = { phi = 0.55 }
)"),
                                         "section.toml", dir.path());
  StudyOptions o;
  o.out_dir = (fs::path(dir.path()) / "out").string();
  o.quiet = true;
  o.no_plots = true;
  o.jobs = 2;
  Seen seen;
  ASSERT_EQ(run_compare(plan, o, recording(seen)), 0);
  EXPECT_EQ(seen.calls, 1);
  EXPECT_EQ(seen.labels, (std::vector<std::string>{"dense", "dilute"}));
  EXPECT_EQ(seen.settings, (std::vector<std::size_t>{3, 2}));  // the second case runs two
  EXPECT_EQ(seen.replicas, (std::vector<std::size_t>(5, 2)));
  EXPECT_TRUE(seen.coarse_unstable) << "dt = 1 should oscillate or diverge in every replica";
  EXPECT_TRUE(seen.fine_stable);
  const std::string top = read_text(fs::path(o.out_dir) / "report.md");
  const auto at = top.find("## The test study's section");
  ASSERT_NE(at, std::string::npos) << top;
  EXPECT_GT(at, top.find("| case | reference | cheapest within tolerance | unstable |"));
  EXPECT_NE(top.find("- case 'dilute', coarse: 2 runs, unstable", at), std::string::npos) << top;
  for (const char* c : {"dense", "dilute"}) {
    const std::string report = read_text(fs::path(o.out_dir) / c / "report.md");
    EXPECT_NE(report.find("## Recommendation"), std::string::npos) << c;
    EXPECT_EQ(report.find("The test study's section"), std::string::npos) << c;
  }
}

TEST(CompareSection, WithoutCasesGoesIntoTheReportBeforeTheRecommendation) {
  use_test_jamflow();
  const testing_support::TempDir dir("jamflow-compare-section-");
  const ComparePlan plan = parse_compare(compare_text(""), "one.toml", dir.path());
  StudyOptions o;
  o.out_dir = (fs::path(dir.path()) / "out").string();
  o.quiet = true;
  o.no_plots = true;
  o.jobs = 2;
  Seen seen;
  ASSERT_EQ(run_compare(plan, o, recording(seen)), 0);
  EXPECT_EQ(seen.calls, 1);
  EXPECT_EQ(seen.settings, (std::vector<std::size_t>{3}));
  const std::string report = read_text(fs::path(o.out_dir) / "report.md");
  const auto at = report.find("## The test study's section");
  ASSERT_NE(at, std::string::npos);
  EXPECT_LT(at, report.find("## Recommendation"));
  EXPECT_NE(report.find("- case '', coarse: 2 runs, unstable", at), std::string::npos) << report;
}

}  // namespace
}  // namespace jamflow::studies
