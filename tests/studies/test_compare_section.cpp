// A study's own report section on a comparison (framework/compare.hpp CompareReportSection): it
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

#include "framework/compare.hpp"
#include "lib/error.hpp"
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
  // The opening states the cost of every run: 2 cases x 2 prepared states, 3 + 2 settings x 2.
  const auto cost = top.find("Cost: ");
  ASSERT_NE(cost, std::string::npos) << top;
  EXPECT_LT(cost, top.find("| case |"));
  EXPECT_NE(top.find(" CPU-hours over 14 runs (", cost), std::string::npos) << top;
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

// A follow-up (studies/softness) runs a stage of its own after the comparison: --dry-run calls
// it with no outcomes (it counts its stage), a status it returns stops the study without a
// report, and otherwise its section goes into the report like a section's.
TEST(CompareFollowUp, RunsAfterTheAnalysisAndCanStopBeforeTheReport) {
  use_test_jamflow();
  const testing_support::TempDir dir("jamflow-compare-follow-up-");
  const ComparePlan plan =
      parse_compare(compare_text("[study]\nanswer = 42\n"), "f.toml", dir.path());
  ASSERT_EQ(plan.study_keys.size(), 1u);
  EXPECT_EQ(plan.study_keys["answer"].value<int>(), 42);
  StudyOptions o;
  o.out_dir = (fs::path(dir.path()) / "out").string();
  o.quiet = true;
  o.no_plots = true;
  o.jobs = 2;
  // A compare file of `jamflow compare` (no study reads it) may not have [study].
  EXPECT_THROW(run_compare(plan, o), ConfigError);

  std::vector<std::size_t> seen_cases;
  int answer = 0;
  const CompareFollowUp stop =
      [&](const std::vector<CompareCaseOutcome>& cases) -> std::variant<int, CompareSection> {
    seen_cases.push_back(cases.size());
    return answer;
  };
  StudyOptions dry = o;
  dry.dry_run = true;
  answer = 3;
  EXPECT_EQ(run_compare(plan, dry, {}, {}, stop), 3);
  ASSERT_EQ(seen_cases, (std::vector<std::size_t>{0}));  // nothing has run: no outcomes
  answer = 5;  // a stage of its own not finished: no report
  EXPECT_EQ(run_compare(plan, o, {}, {}, stop), 5);
  ASSERT_EQ(seen_cases, (std::vector<std::size_t>{0, 1}));
  EXPECT_FALSE(fs::exists(fs::path(o.out_dir) / "report.md"));

  Seen seen;
  const CompareReportSection section = recording(seen);
  const CompareFollowUp done =
      [&](const std::vector<CompareCaseOutcome>& cases) -> std::variant<int, CompareSection> {
    return section(cases);
  };
  ASSERT_EQ(run_compare(plan, o, {}, {}, done), 0);
  EXPECT_EQ(seen.calls, 1);
  const std::string report = read_text(fs::path(o.out_dir) / "report.md");
  EXPECT_LT(report.find("## The test study's section"), report.find("## Recommendation"));
}

// window_step: the diagnostic window's sampling interval of adaptive integrators, fixed or a
// tenth of the contact relaxation time at the case's typical overlap.
TEST(CompareWindowStep, FixedOrFromTheContactStiffness) {
  const testing_support::TempDir dir("jamflow-compare-window-");
  const std::string cases = R"([[case]]
label = "soft"
system = { alpha = 1.5 }
ensemble = { kind = "constant_pressure", pressure = 0.1 }
[[case]]
label = "harmonic"
ensemble = { kind = "constant_pressure", pressure = 0.01 }
)";
  const ComparePlan unset = parse_compare(compare_text(cases), "w.toml", dir.path());
  EXPECT_EQ(unset.cases[0].window_options(0).adaptive_step, 0.0);  // sample_every / 16
  const ComparePlan fixed =
      parse_compare("window_step = 0.25\n" + compare_text(cases), "w.toml", dir.path());
  EXPECT_EQ(fixed.cases[1].window_options(1).adaptive_step, 0.25);
  const ComparePlan contact =
      parse_compare("window_step = \"contact\"\n" + compare_text(cases), "w.toml", dir.path());
  // alpha_r = 1.5 at P = 0.1: delta = P^2 = 0.01, k = 0.5 delta^-0.5 = 5, so 0.1 / 5.
  EXPECT_NEAR(contact.cases[0].window_options(0).adaptive_step, 0.02, 1e-12);
  // Harmonic contacts: k = 1 at every overlap, so 0.1.
  EXPECT_NEAR(contact.cases[1].window_options(0).adaptive_step, 0.1, 1e-12);
  for (const char* bad : {"window_step = 0.0\n", "window_step = \"soft\"\n"}) {
    try {
      (void)parse_compare(bad + compare_text(cases), "w.toml", dir.path());
      ADD_FAILURE() << bad;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("window_step"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("allowed a number > 0 or \"contact\""),
                std::string::npos)
          << e.what();
    }
  }
}

}  // namespace
}  // namespace jamflow::studies
