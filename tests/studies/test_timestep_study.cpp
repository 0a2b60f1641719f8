// Timestep study: its presets are compare plans that load and check, its section (the cheapest
// usable setting per target, the seed's claim, the first unstable Euler step) is a pure
// function checked on a synthetic outcome, and a tiny plan runs end to end: the reference is
// Euler at the smallest step, dt = 0.05 and RKC are stable with small shifts, dt = 1.5 is
// unstable, the first unstable step and never meets a target.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "lib/h5.hpp"
#include "studies/timestep/timestep.hpp"
#include "tests/driver/temp_dir.hpp"
#include "tests/studies/jamflow_exe.hpp"

using namespace jamflow;
using namespace jamflow::studies;

namespace {

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// The settings of both tests: Euler at 0.02 (the reference), 0.05, 0.4 and 1.5, RESPA
// (particles x 4) at dt = 1 and RKC at 0.1 overlaps, at constant pressure P = 0.1, gdot = 0.01
// (harmonic, J = 0.1), where verdicts are firm (the stability test's case): the piston relaxes
// phi within 5 / P = 50 (the preparation runs 200), and tau of sigma_xy, phi and P is at most
// about 13, so blocks of 75 (t_av = 1500, 20 blocks) are about 3x the decorrelated verdict's
// 2 tau. Euler's limit there lies between dt = 0.2 and 0.3: 0.02 and 0.05 are far below it,
// 1.5 far above.
std::string plan_text(const std::string& settings) {
  return R"(reference = "euler-0.02"
observables = ["sigma_xy", "phi", "pressure"]
diagnose = true
relative_tolerance = { sigma_xy = 0.01, phi = 0.0016, pressure = 0.01 }
[base.system]
N = 150
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
dt = 0.02
[base.run]
t_eq = 0.0
t_av = 1.0
[prepare]
t = 200.0
integrator = { kind = "euler", dt = 0.05 }
[run]
t_eq = 48.0
t_av = 1500.0
sample_every = 12.0
[[setting]]
label = "euler-0.02"
converged = true
[[setting]]
label = "euler-0.05"
integrator.dt = 0.05
converged = true
)" + settings;
}

}  // namespace

TEST(TimestepStudy, PresetsAreComparePlansWithEveryIntegratorFamily) {
  for (const char* preset : {"quick", "standard", "paper"}) {
    const ComparePlan plan = study_compare_plan("timestep", preset);
    EXPECT_EQ(plan.settings[plan.reference].label, "euler-0.02") << preset;
    EXPECT_GE(plan.cases.size(), 4u) << preset;
    EXPECT_TRUE(plan.diagnose) << preset;
    int euler = 0, respa = 0, cvode = 0, rkc = 0, converged = 0;
    for (std::size_t s = 0; s < plan.settings.size(); ++s) {
      const std::string kind =
          (*plan.setting_scene(s).table("integrator"))["kind"].value_or(std::string());
      euler += kind == "euler";
      respa += kind == "respa";
      cvode += kind == "cvode";
      rkc += kind == "rkc";
      converged += plan.settings[s].converged;
    }
    EXPECT_GE(euler, 6) << preset;
    EXPECT_GE(respa, 2) << preset;
    EXPECT_GE(cvode, 2) << preset;
    EXPECT_GE(rkc, 3) << preset;
    EXPECT_GE(converged, 4) << preset;
  }
}

// The section on a synthetic outcome whose answers are known by construction.
TEST(TimestepStudy, SectionPicksTheCheapestUsableSettingPerTargetAndNamesTheFirstUnstableStep) {
  const ComparePlan plan = parse_compare(plan_text(R"([[setting]]
label = "euler-0.4"
integrator.dt = 0.4
[[setting]]
label = "euler-1.5"
integrator.dt = 1.5
[[setting]]
label = "respa-1"
integrator = { kind = "respa", dt = 1.0, n_inner = 4, inner = "particles" }
[[setting]]
label = "rkc-0.1"
integrator = { kind = "rkc", atol_overlaps = 0.1 }
)"),
                                         "synthetic.toml", ".");
  ASSERT_EQ(plan.settings.size(), 6u);
  // sigma_xy 1e-2 at the reference. Differences (error): euler-0.05 1e-4 (1e-4), cost 4;
  // euler-0.4 2.5e-4 (1e-4), cost 1; euler-1.5 unstable (oscillating), cost 0.5; respa-1 stable
  // but correlated, cost 0.8, difference 0; rkc-0.1 2e-4 (1e-4), cost 2.
  analysis::CompareResult res;
  const double diff[] = {0.0, 1e-4, 2.5e-4, 0.0, 0.0, 2e-4};
  const double cpu[] = {10.0, 4.0, 1.0, 0.5, 0.8, 2.0};
  std::vector<DiagnosedRun> runs(6);
  for (std::size_t s = 0; s < 6; ++s) {
    analysis::SettingResult r;
    r.label = plan.settings[s].label;
    r.ensemble = "constant_pressure";
    r.ran = true;
    r.stable = s != 3;
    r.steady = true;
    r.cpu_per_particle_tau = {cpu[s], 0.0};
    r.observables.resize(3);
    for (auto& o : r.observables) {
      o.mean = {1e-2, 1e-4};
      o.difference = {diff[s], 1e-4};
      o.z = diff[s] / 1e-4;
      o.within = o.z <= 2.0;
    }
    res.settings.push_back(r);
    runs[s].cls.verdict = s == 3   ? studies::Verdict::kOscillating
                          : s == 4 ? studies::Verdict::kCorrelated
                                   : studies::Verdict::kStable;
    runs[s].balance.valid = true;
    runs[s].balance.ratio = s == 3 ? 0.01 : 1.0 - 0.001 * double(s);
    runs[s].balance.error = 1e-3;
  }
  CompareCaseOutcome c;
  c.plan = &plan;
  c.result = &res;
  for (auto& r : runs)
    c.runs.push_back({&r});
  const std::string md = timestep_section({c}).markdown;
  auto row = [&](const std::string& start) {
    const auto at = md.find("| " + start);
    return at == std::string::npos ? std::string() : md.substr(at, md.find('\n', at) - at);
  };
  // sigma_xy within 5 %: error + 2 x 1 % (relative) for all three usable ones; euler-0.4 is the
  // cheapest (respa-1 is cheaper but correlated, euler-1.5 cheaper but unstable).
  EXPECT_NE(row("σ_xy ≤ 5 %").find("euler-0.4 (1)"), std::string::npos) << md;
  // Within 1 %: 2 x 1 % exceeds it for every usable setting.
  EXPECT_NE(row("σ_xy ≤ 1 %").find("unresolved (2σ 2 %)"), std::string::npos) << md;
  // phi absolute within 1e-3: euler-0.05 (1e-4 + 2e-4), euler-0.4 (2.5e-4 + 2e-4) and rkc-0.1
  // (2e-4 + 2e-4) meet it; euler-0.4 is the cheapest. Within 1e-4 none can (2 x 1e-4).
  EXPECT_NE(row("\\|Δφ\\| ≤ 0.001").find("euler-0.4 (1)"), std::string::npos) << md;
  EXPECT_NE(row("\\|Δφ\\| ≤ 0.0001").find("unresolved"), std::string::npos) << md;
  // P_hat is imposed at constant pressure: no target.
  EXPECT_NE(row("P̂ ≤ 5 %").find("n/a"), std::string::npos) << md;
  // Energy balance within 1 %: |EB - 1| + 2 x 0.1 % is 0.3 % (euler-0.05), 0.4 % (euler-0.4),
  // 0.7 % (rkc-0.1); euler-0.4 is again the cheapest.
  EXPECT_NE(row("\\|EB − 1\\| ≤ 1 %").find("euler-0.4 (1)"), std::string::npos) << md;
  EXPECT_EQ(md.find("euler-1.5 ("), std::string::npos) << md;
  EXPECT_EQ(md.find("respa-1 ("), std::string::npos) << md;
  // The claim table: Euler at 0.4 differs (2.5e-4 / 1e-4 = 2.5 sigma, outside the synthetic
  // `within`, z <= 2), 1.5 oscillates; RESPA at dt = 1 is correlated.
  const std::string euler_row = row("synthetic | euler |");
  EXPECT_NE(euler_row.find("stable, **differs**: σ 2.5 % (2.5σ)"), std::string::npos) << md;
  EXPECT_NE(euler_row.find("oscillating (EB 0.01)"), std::string::npos) << md;
  EXPECT_NE(row("synthetic | respa particlesx4 |").find("correlated"), std::string::npos) << md;
  EXPECT_NE(md.find("First unstable Euler dt per state point: synthetic: 1.5."), std::string::npos)
      << md;
  // No usable reference, no pick.
  runs[0].cls.verdict = studies::Verdict::kNotSteady;
  const std::string none = timestep_section({c}).markdown;
  EXPECT_NE(none.find("no usable reference (not steady)"), std::string::npos) << none;
}

TEST(TimestepStudy, TinyPlanEndToEnd) {
  use_test_jamflow();
  const testing_support::TempDir scratch("jamflow_timestep_study.");
  const ComparePlan plan = parse_compare(plan_text(R"([[setting]]
label = "euler-1.5"
integrator.dt = 1.5
[[setting]]
label = "rkc-0.1"
integrator = { kind = "rkc", atol_overlaps = 0.1 }
)"),
                                         "tiny.toml", scratch.path());
  StudyOptions o;
  o.out_dir = (std::filesystem::path(scratch.path()) / "out").string();
  o.quiet = true;
  o.jobs = 2;
  o.no_plots = true;
  ASSERT_EQ(run_compare(plan, o, timestep_section), 0);
  // Every run is a point file of the sweep engine; a rerun reads them back, computing nothing.
  const auto files = point_files(o.out_dir);
  EXPECT_EQ(files.size(), 5u);  // the preparation and four settings
  ASSERT_EQ(run_compare(plan, o, timestep_section), 0);
  EXPECT_EQ(point_files(o.out_dir), files);

  H5Reader r(o.out_dir + "/compare.h5");
  for (const char* s : {"euler-0.02", "euler-0.05", "rkc-0.1"})
    EXPECT_EQ(r.attr_int(std::string("/settings/") + s, "stable"), 1)
        << s << ": " << r.attr_string(std::string("/settings/") + s, "why_unstable");
  EXPECT_EQ(r.attr_int("/settings/euler-1.5", "stable"), 0);
  // The shift is Euler's first-order bias at dt = 0.05 (or RKC's at 0.1 delta) plus noise: both
  // well below 5 % of sigma_xy here, so the shift is below 5 % + 4 errors (4 sigma: the noise
  // part exceeds it with probability below 1e-4).
  const double s_ref = r.attr_double("/settings/euler-0.02/sigma_xy", "mean");
  for (const char* s : {"euler-0.05", "rkc-0.1"}) {
    const std::string g = std::string("/settings/") + s + "/sigma_xy";
    const double d = std::abs(r.attr_double(g, "difference")) / std::abs(s_ref);
    const double e = r.attr_double(g, "difference_err") / std::abs(s_ref);
    EXPECT_GT(e, 0.0) << s;
    EXPECT_LT(d, 0.05 + 4.0 * e) << s;
  }
  // The section's numbers for programs: OUT/<stem>.h5 (OUT/timestep.h5 for the study).
  {
    H5Reader t(o.out_dir + "/tiny.h5");
    EXPECT_DOUBLE_EQ(t.attr_double("/cases/tiny", "first_unstable_euler_dt"), 1.5);
    EXPECT_EQ(t.attr_string("/targets/t00", "observable"), "sigma_xy");
    EXPECT_EQ(t.attr_string("/targets/t00", "tiny").find("euler-1.5"), std::string::npos);
  }
  // The converged settings (the reference and dt = 0.05) entered the error model.
  EXPECT_EQ(r.attr_int("/observables/sigma_xy", "converged_settings"), 2);
  EXPECT_GE(r.attr_double("/observables/sigma_xy", "error_scale"), 1.0);

  const std::string report = read_text(std::filesystem::path(o.out_dir) / "report.md");
  const auto at = report.find("## Cheapest setting per accuracy target");
  ASSERT_NE(at, std::string::npos) << report;
  EXPECT_LT(at, report.find("## Recommendation"));
  EXPECT_NE(report.find("First unstable Euler dt per state point: tiny: 1.5."), std::string::npos)
      << report;
  // dt = 1.5 is never counted as meeting a target.
  EXPECT_EQ(report.find("euler-1.5 (", at), std::string::npos) << report;
}
