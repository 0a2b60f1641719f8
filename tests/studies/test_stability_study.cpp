// Stability study: its presets are compare plans with a reference per case, its section (the
// largest stable and first unstable step, RESPA against N) is checked on synthetic outcomes, and
// a tiny plan runs end to end: an obviously stable (Euler dt = 0.05) and an obviously unstable
// (dt = 1.5) run, and RESPA at N = 100 failing at dt = 1, are classified as such.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "lib/h5.hpp"
#include "studies/stability/stability.hpp"
#include "tests/driver/temp_dir.hpp"
#include "tests/studies/jamflow_exe.hpp"

using namespace jamflow;
using namespace jamflow::studies;

namespace {

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Two cases. P = 0.1 (harmonic, J = 0.1): its piston relaxes phi within 5 / P = 50, so a
// preparation of 200 leaves a steady state, and tau of sigma_xy, phi and P is at most 13 there,
// so blocks of 75 (t_av = 1500, 20 blocks) are about 3x the decorrelated verdict's 2 tau. The
// standard preset (N = 500) finds Euler stable up to dt = 0.2 and oscillating from 0.3 there:
// dt = 0.05 is 4x below that limit and dt = 1.5 5x above it, so both verdicts are firm. RESPA at
// N = 100, P = 1e-3 (prepared for 5 / P): the outer-level piston at dt = 1 is far outside its
// stable range (energy balance about 0.01 on the quick preset: the piston's dissipation inflated
// about 80x), so its verdict is robust to the short window used here.
constexpr const char* kPlan = R"(reference = "euler-0.05"
observables = ["sigma_xy", "phi"]
diagnose = true
[base.system]
N = 200
phi = 0.75
seed = 1
[base.ensemble]
kind = "constant_pressure"
pressure = 0.1
xi_V = 1e-4
[base.shear]
rate = 0.01
[base.integrator]
kind = "euler"
dt = 0.05
[base.run]
t_eq = 0.0
t_av = 1.0
[prepare]
t = 200.0
[run]
t_eq = 48.0
t_av = 1500.0
sample_every = 6.0
[[setting]]
label = "euler-0.05"
[[setting]]
label = "euler-1.5"
integrator.dt = 1.5
[[setting]]
label = "respa-0.5"
integrator = { kind = "respa", dt = 0.5, n_inner = 4, inner = "particles" }
[[setting]]
label = "respa-1"
integrator = { kind = "respa", dt = 1.0, n_inner = 4, inner = "particles" }
[[case]]
label = "P=0.1"
settings = ["euler-0.05", "euler-1.5"]
[[case]]
label = "RESPA_N=100"
reference = "respa-0.5"
system = { N = 100, phi = 0.578 }
ensemble = { kind = "constant_pressure", pressure = 1e-3, xi_V = 1e-4 }
shear = { rate = 1e-3 }
prepare = { t = 5000.0, sample_every = 25.0 }
run = { t_av = 402.0 }
settings = ["respa-0.5", "respa-1"]
)";

}  // namespace

TEST(StabilityStudy, PresetsAreComparePlansWithAReferencePerCase) {
  for (const char* preset : {"quick", "standard", "paper"}) {
    const ComparePlan plan = study_compare_plan("stability", preset);
    EXPECT_TRUE(plan.diagnose) << preset;
    EXPECT_GE(plan.cases.size(), 12u) << preset;
    int respa_only = 0, stiff = 0;
    for (const ComparePlan& c : plan.cases) {
      const CompareMethod ref = compare_method(c, c.reference);
      bool euler = false;
      double smallest = 1e9;
      for (std::size_t s = 0; s < c.settings.size(); ++s) {
        const CompareMethod m = compare_method(c, s);
        euler = euler || m.kind == "euler";
        if (m.kind == ref.kind)
          smallest = std::min(smallest, m.dt);
      }
      // The reference is the smallest step of its kind in the case: Euler where the case scans
      // Euler, RESPA where it scans RESPA only.
      EXPECT_EQ(ref.kind, euler ? "euler" : "respa") << preset << " " << c.label;
      EXPECT_DOUBLE_EQ(ref.dt, smallest) << preset << " " << c.label;
      respa_only += !euler;
      stiff += euler && ref.dt < 0.02;
    }
    EXPECT_GE(respa_only, 2) << preset;
    EXPECT_GE(stiff, 3) << preset;  // alpha_r < 2, P = 0.1, the stiff piston
  }
}

TEST(StabilityStudy, SectionSaysWhereEulerHoldsAndWhereItsStableRangeIsNotEstablished) {
  const ComparePlan plan = parse_compare(std::string(kPlan) + R"([[setting]]
label = "euler-0.1"
integrator.dt = 0.1
[[setting]]
label = "euler-0.2"
integrator.dt = 0.2
)",
                                         "synthetic.toml", ".");
  ComparePlan one = plan;  // every setting at the base state point (P = 0.1), as one case
  one.cases.clear();
  one.label = "one";
  // Settings: euler-0.05, euler-1.5, respa-0.5, respa-1, euler-0.1, euler-0.2.
  std::vector<DiagnosedRun> runs(one.settings.size());
  auto section = [&](std::vector<studies::Verdict> v) {
    for (std::size_t s = 0; s < runs.size(); ++s)
      runs[s].cls.verdict = v[s];
    CompareCaseOutcome o;
    o.plan = &one;
    for (auto& r : runs)
      o.runs.push_back({&r});
    return stability_section({o}).markdown;
  };
  using V = studies::Verdict;
  // 0.05 stable, 0.1 correlated (left out), 0.2 oscillating.
  std::string md =
      section({V::kStable, V::kDiverged, V::kStable, V::kStable, V::kCorrelated, V::kOscillating});
  EXPECT_NE(md.find("| one | N = 200, α_r = 2, P = 0.1, ξ_V = 0.0001, γ̇ = 0.01 | 0.05 (no "
                    "oscillation up to 0.1, but 1 of those runs left out) | 0.2: oscillating"),
            std::string::npos)
      << md;
  // Nothing stable: 0.05 not steady, 0.1 correlated, 0.2 diverged.
  md = section({V::kNotSteady, V::kDiverged, V::kStable, V::kStable, V::kCorrelated, V::kDiverged});
  EXPECT_NE(md.find("| not established (no oscillation up to 0.1, but 2 of those runs left "
                    "out) | 0.2: diverged"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("Euler's stable range is not established: no run oscillates up to dt = 0.1"),
            std::string::npos)
      << md;
  // Unstable from the smallest step.
  md = section({V::kOscillating, V::kDiverged, V::kStable, V::kStable, V::kDiverged, V::kDiverged});
  EXPECT_NE(md.find("| < 0.05 | 0.05: oscillating"), std::string::npos) << md;
}

TEST(StabilityStudy, TinyPlanEndToEnd) {
  use_test_jamflow();
  const testing_support::TempDir scratch("jamflow_stability_study.");
  const ComparePlan plan = parse_compare(kPlan, "tiny.toml", scratch.path());
  StudyOptions o;
  o.out_dir = (std::filesystem::path(scratch.path()) / "out").string();
  o.quiet = true;
  o.jobs = 2;
  ASSERT_EQ(run_compare(plan, o, stability_section, {"stability/plot.py"}), 0);
  // Every run is a point file of the sweep engine; a rerun reads them back, computing nothing.
  const auto files = point_files(o.out_dir);
  EXPECT_EQ(files.size(), 6u);  // two preparations and four runs
  o.no_plots = true;            // the plots of the first run stay
  ASSERT_EQ(run_compare(plan, o, stability_section, {"stability/plot.py"}), 0);
  EXPECT_EQ(point_files(o.out_dir), files);
  if (std::filesystem::exists("/usr/bin/python3")) {
    EXPECT_TRUE(std::filesystem::exists(o.out_dir + "/stability_map.png"));
    EXPECT_TRUE(std::filesystem::exists(o.out_dir + "/stability_diagnostics.png"));
  }
  const std::string md = read_text(std::filesystem::path(o.out_dir) / "report.md");
  // Stable at 0.05, oscillating or diverged at 1.5.
  const auto at = md.find("- **P=0.1**: Euler stable up to dt = 0.05; at dt = 1.5: ");
  ASSERT_NE(at, std::string::npos) << md;
  const std::string rest = md.substr(at, 120);
  EXPECT_TRUE(rest.find("oscillating") != std::string::npos ||
              rest.find("diverged") != std::string::npos)
      << rest;
  // RESPA at N = 100: dt = 1 fails at the only (so the largest) size scanned.
  EXPECT_NE(md.find("## RESPA with particle sub-steps against N"), std::string::npos);
  EXPECT_NE(md.find("- P = 0.001, dt = 1: oscillating or diverged even at the largest size "
                    "scanned, N = 100."),
            std::string::npos)
      << md;
  // The section's numbers for programs: OUT/<stem>.h5 (OUT/stability.h5 for the study).
  H5Reader h5(o.out_dir + "/tiny.h5");
  EXPECT_DOUBLE_EQ(h5.attr_double("/cases/P=0.1", "largest_stable_dt"), 0.05);
  EXPECT_DOUBLE_EQ(h5.attr_double("/cases/P=0.1", "first_unstable_dt"), 1.5);
  EXPECT_EQ(h5.attr_int("/cases/P=0.1", "runs_without_oscillation_left_out"), 0);
  const std::string t = "/respa_size_thresholds/P=0.001_dt=1";
  EXPECT_EQ(h5.attr_int(t, "largest_failing_N"), 100);
  EXPECT_EQ(h5.attr_int(t, "smallest_holding_N"), 0);
  EXPECT_EQ(h5.attr_int(t, "every_size_has_a_verdict"), 1);
  // The table the plots read has the step and the diagnostic window's class.
  const std::string csv = read_text(std::filesystem::path(o.out_dir) / "table.csv");
  EXPECT_EQ(csv.rfind("case,setting,reference,integrator,dt,rtol,", 0), 0u) << csv.substr(0, 200);
  EXPECT_NE(csv.find(",window,"), std::string::npos);
  EXPECT_NE(csv.find("P=0.1,euler-0.05,1,euler,0.05,,"), std::string::npos) << csv;
}
