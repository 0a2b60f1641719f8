// Softness study: the shared hard-sphere start, the cost to strain 1, the shipped plans and their
// [study] checks, and the study end to end on a tiny plan (harmonic only): outputs exist, Euler
// dt = 1.5 is not stable, the integrator chosen is the cheapest stable and accurate setting, the
// runs left out are listed, phi exceeds the common reference's and grows with P (soft spheres
// compress), P* follows the rule (analysis/p_star.hpp), and the cost at P* follows the measured
// cost per tau_0.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <string>

#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "studies/common.hpp"
#include "studies/softness/softness.hpp"
#include "tests/driver/temp_dir.hpp"
#include "tests/studies/jamflow_exe.hpp"

using namespace jamflow;
using namespace jamflow::studies;

TEST(SoftnessStudy, CostModel) {
  EXPECT_DOUBLE_EQ(steps_per_particle(0.1, 1e-3, 0.5), 1.0 / (0.1 * 1e-3 * 0.5));
  EXPECT_DOUBLE_EQ(cost_to_strain_one(2e-7, 0.1, 1e-3), 2e-7 / (0.1 * 1e-3));
}

TEST(SoftnessStudy, HardSphereStart) {
  // The seed's law at N = 250: phi_J = 0.6445, C = 0.0665, so phi(J = 1) = 0.578.
  EXPECT_NEAR(hard_sphere_phi(1.0, 250), 0.578, 0.001);
  EXPECT_LT(hard_sphere_phi(1.0, 250), hard_sphere_phi(0.1, 250));
  EXPECT_DOUBLE_EQ(phi_start(1.0, 250, 0.01, 0.63), hard_sphere_phi(1.0, 250) - 0.01);
  EXPECT_DOUBLE_EQ(phi_start(1e-12, 250, 0.0, 0.63), 0.63);  // clamped
  EXPECT_DOUBLE_EQ(phi_start(1e6, 250), 0.3);
}

TEST(SoftnessStudy, ShippedPlans) {
  for (const char* preset : {"quick", "standard", "paper"}) {
    const ComparePlan plan = study_compare_plan("softness", preset);
    const SoftnessParameters p = softness_parameters(plan);
    // Every alpha_r of the plan has a case at both ends of its range of the grid (one where they
    // coincide), each against its smallest Euler step.
    std::map<double, std::vector<double>> pressures;
    for (const ComparePlan& c : plan.cases) {
      const double alpha = *c.base.table("system")->get("alpha")->value<double>();
      pressures[alpha].push_back(*c.base.table("ensemble")->get("pressure")->value<double>());
      const CompareMethod ref = compare_method(c, c.reference);
      EXPECT_EQ(ref.kind, "euler") << c.label;
      for (std::size_t s = 0; s < c.settings.size(); ++s) {
        const CompareMethod m = compare_method(c, s);
        if (m.kind == "euler") {
          EXPECT_GE(m.dt, ref.dt) << preset << " " << c.label << " " << c.settings[s].label;
        }
      }
    }
    for (const auto& [alpha, ps] : pressures) {
      std::vector<double> grid;
      for (double d : p.deltas)
        if (std::pow(d, alpha - 1.0) >= p.p_min * (1.0 - 1e-12))
          grid.push_back(std::pow(d, alpha - 1.0));
      ASSERT_FALSE(grid.empty()) << preset << " alpha " << alpha;
      const auto [lo, hi] = std::minmax_element(grid.begin(), grid.end());
      EXPECT_EQ(ps.size(), *lo == *hi ? 1u : 2u) << preset << " alpha " << alpha;
      EXPECT_NEAR(*std::max_element(ps.begin(), ps.end()), *hi, 1e-12 * *hi);
      EXPECT_NEAR(*std::min_element(ps.begin(), ps.end()), *lo, 1e-12 * *lo);
    }
    // The reference lies well below every alpha_r = 2 grid pressure.
    for (double d : p.deltas)
      EXPECT_LE(p.p_reference, 0.1 * d) << preset;
    if (std::string(preset) != "quick") {
      EXPECT_TRUE(pressures.count(1.75)) << preset;
    }
  }
}

namespace {
// A softness plan of one harmonic alpha_r at N = 100: Euler at 0.05 (the reference) and 1.5,
// CVODE and RKC; two overlaps, J = 1; `study`: the [study] table.
std::string tiny_plan(const std::string& study) {
  return R"(reference = "euler-0.05"
replicas = 1
observables = ["sigma_xy", "phi"]
diagnose = true
window_step = "contact"
[base.system]
N = 100
alpha = 2.0
phi = 0.57
seed = 1
[base.ensemble]
kind = "constant_pressure"
pressure = 0.01
xi_V = 0.0001
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
sample_every = 2.0
[run]
t_eq = 24.0
t_av = 240.0
sample_every = 12.0
[[setting]]
label = "euler-0.05"
integrator = { kind = "euler", dt = 0.05 }
[[setting]]
label = "euler-1.5"
integrator = { kind = "euler", dt = 1.5 }
[[setting]]
label = "cvode-0.001"
integrator = { kind = "cvode", rtol = 0.001, atol_overlaps = 0.001 }
[[setting]]
label = "rkc-0.1"
integrator = { kind = "rkc", atol_overlaps = 0.1 }
[[case]]
label = "alpha=2_delta=0.01"
ensemble = { pressure = 0.01 }
shear = { rate = 0.01 }
[[case]]
label = "alpha=2_delta=0.003"
ensemble = { pressure = 0.003 }
shear = { rate = 0.003 }
prepare = { t = 660.0, sample_every = 6.6 }
[study]
)" + study;
}
const char* kTinyStudy = R"(targets_j = [1.0]
deltas = [1e-2, 3e-3]
p_min = 0.0
strain_eq = 0.0
strain_av = 0.0
t_min = 300.0
relax_pressure = 2.0
average_pressure = 40.0
p_reference = 1e-3
reference_rtol = 1e-5
reference_average = 2.0
reference_replicas = 2
)";
}  // namespace

TEST(SoftnessStudy, StudyKeysAreCheckedBeforeAnythingRuns) {
  const testing_support::TempDir dir("jamflow_softness_keys.");
  for (const auto& [bad, key] : std::vector<std::pair<std::string, std::string>>{
           {"deltas = []\n", "deltas"},
           {"deltas = [0.01, -1]\n", "deltas"},
           {"t_min = 0\n", "t_min"},
           {"reference_replicas = 0\n", "reference_replicas"},
           {"colour = 3\n", "colour"}}) {
    std::string study = kTinyStudy;
    const auto at = study.find(key + " = ");
    if (at != std::string::npos)
      study.erase(at, study.find('\n', at) + 1 - at);
    const ComparePlan plan = parse_compare(tiny_plan(study + bad), "s.toml", dir.path());
    try {
      (void)softness_parameters(plan);
      ADD_FAILURE() << bad;
    } catch (const ConfigError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("[study] " + key), std::string::npos) << what;
      EXPECT_NE(what.find("allowed"), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    }
  }
}

TEST(SoftnessStudy, TinyPlan) {
  const testing_support::TempDir scratch("jamflow_softness_study.");
  const std::string dir = scratch.path() + "/out";
  const ComparePlan plan =
      parse_compare(tiny_plan(kTinyStudy), "softness-tiny.toml", scratch.path());
  use_test_jamflow();
  StudyOptions o;
  o.preset = "quick";
  o.out_dir = dir;
  o.quiet = true;
  o.jobs = 1;
  ASSERT_EQ(run_softness_plan(plan, o), 0);
  // Every run is a point file of the sweep engine; a rerun reads them back, computing nothing.
  const auto files = point_files(dir);
  EXPECT_EQ(files.size(), 2u + 8u + 2u + 2u);  // preparations, settings, scans, reference
  o.no_plots = true;                           // the plots of the first run stay
  ASSERT_EQ(run_softness_plan(plan, o), 0);
  EXPECT_EQ(point_files(dir), files);
  ASSERT_TRUE(std::filesystem::exists(dir + "/report.md"));
  ASSERT_TRUE(std::filesystem::exists(dir + "/softness.h5"));
  ASSERT_TRUE(std::filesystem::exists(dir + "/alpha=2_delta=0.01/compare.h5"));
  if (std::filesystem::exists("/usr/bin/python3")) {
    EXPECT_TRUE(std::filesystem::exists(dir + "/softness_cost.png"));
  }
  std::ifstream in(dir + "/report.md");
  const std::string report((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NE(report.find("### Common P → 0 reference"), std::string::npos);
  EXPECT_NE(report.find("](alpha=2_delta=0.003/report.md)"), std::string::npos);
  // The cost line counts the comparison's 10 runs and the study's own stage's 4.
  EXPECT_NE(report.find(" CPU-hours over 14 runs ("), std::string::npos) << report;
  EXPECT_NE(report.find(", the study's own stage "), std::string::npos) << report;

  H5Reader r(dir + "/softness.h5");
  const std::string a = "/alphas/a00";
  EXPECT_DOUBLE_EQ(r.attr_double(a, "alpha"), 2.0);
  const auto at = report.find("### Runs left out by their verdicts");
  ASSERT_NE(at, std::string::npos);
  const std::string left_out = report.substr(at, report.find("\n### ", at + 1) - at);
  // Euler 1.5 is far above Euler's limit (0.2-0.3 in the stability study): unstable, so not
  // accurate, at both ends; Euler 0.05 is the reference, accurate by definition.
  for (const std::string end : {"/scan_hi", "/scan_lo"}) {
    EXPECT_EQ(r.attr_int(a + end + "/settings/euler-1.5", "accurate"), 0);
    EXPECT_EQ(r.attr_int(a + end + "/settings/euler-0.05", "accurate"), 1);
  }
  EXPECT_DOUBLE_EQ(r.attr_double(a, "euler_dt_max"), 0.05);
  // The integrator is the cheapest candidate that is stable and accurate at both ends.
  ASSERT_EQ(r.attr_int(a, "integrator_verified"), 1);
  {
    double best = std::numeric_limits<double>::infinity();
    std::string best_label;
    for (int k = 0; k < 4; ++k) {
      const std::string c = a + "/candidates/c" + std::to_string(k);
      if (r.attr_int(c, "ok") == 1 && r.attr_double(c, "seconds_per_tau_particle") < best) {
        best = r.attr_double(c, "seconds_per_tau_particle");
        best_label = r.attr_string(c, "setting");
      }
    }
    EXPECT_EQ(r.attr_string(a, "integrator"), best_label);
    EXPECT_NE(best_label, "euler-1.5");
    RecordProperty("chosen", best_label);
  }
  // The common reference (two replicas: usable even when each one's blocks are short, its
  // errors then including the replica scatter): harmonic, a flowing dense suspension.
  const std::string ref = "/reference/J1";
  EXPECT_DOUBLE_EQ(r.attr_double(ref, "imposed_pressure"), 1e-3);
  ASSERT_EQ(r.attr_int(ref, "usable"), 1);
  EXPECT_GT(r.attr_double(ref, "phi"), 0.45);
  EXPECT_LT(r.attr_double(ref, "phi"), 0.66);
  EXPECT_GT(r.attr_double(ref, "phi_err"), 0.0);
  // A run is listed among those left out, with its verdict, exactly when its verdict is not
  // steady, correlated or incomplete.
  const auto check_listed = [&](const std::string& g) {
    const std::string v = r.attr_string(g, "verdict");
    const std::string line = "- " + r.attr_string(g, "label") + ": ";
    const bool listed = left_out.find(line) != std::string::npos;
    EXPECT_EQ(listed, v == "not steady" || v == "correlated" || v == "incomplete")
        << g << " (" << v << ")\n"
        << left_out;
    if (listed) {
      EXPECT_NE(left_out.find(line + v), std::string::npos) << g;
    }
  };
  for (int k = 0; k < 2; ++k)
    check_listed(ref + "/replicas/r" + std::to_string(k));
  // The pressure scan at J = 1: blocks of 2 / P are about 2x the decorrelated verdict's 2 tau
  // (2 tau_phi = 106 at P = 1e-2, 207 at 3e-3, measured), so both runs are stable and compared
  // with the reference; agrees = both mu and phi within 2 combined standard errors.
  const std::string pg = a + "/pscan/J1";
  std::map<double, std::string> by_pressure;
  for (int k = 0; k < 2; ++k) {
    const std::string rg = pg + "/runs/r00" + std::to_string(k);
    by_pressure[r.attr_double(rg, "imposed_pressure")] = rg;
    check_listed(rg);
    EXPECT_EQ(r.attr_string(rg, "verdict"), "stable") << rg;
    const bool within = std::abs(r.attr_double(rg, "dmu")) <= 2.0 * r.attr_double(rg, "dmu_err") &&
                        std::abs(r.attr_double(rg, "dphi")) <= 2.0 * r.attr_double(rg, "dphi_err");
    EXPECT_EQ(r.attr_int(rg, "agrees"), within ? 1 : 0) << rg;
    EXPECT_NEAR(r.attr_double(rg, "dphi"),
                r.attr_double(rg, "summary_phi") - r.attr_double(ref, "phi"), 1e-12);
  }
  ASSERT_EQ(by_pressure.size(), 2u);
  // At fixed J the hard-sphere packing fraction does not depend on P, but soft spheres are
  // compressed: phi exceeds the reference's and grows with P. At P = 1e-2 the shift (0.043,
  // measured) is about 17 of its errors: that run disagrees, so P* is below 1e-2. The shifts at
  // 1e-2 and 3e-3 differ by 8 combined errors (measured); the check allows 2.
  const std::string hi = by_pressure.at(1e-2), lo = by_pressure.at(3e-3);
  const double dphi_hi = r.attr_double(hi, "dphi"), dphi_lo = r.attr_double(lo, "dphi");
  EXPECT_GT(dphi_lo, 0.0);
  EXPECT_GT(dphi_hi - dphi_lo,
            2.0 * std::hypot(r.attr_double(hi, "dphi_err"), r.attr_double(lo, "dphi_err")));
  EXPECT_EQ(r.attr_int(hi, "agrees"), 0);
  // "reached" = the smallest P agrees; P* is then 3e-3 (the only P that can agree), and its cost
  // to strain 1 is its measured cost per tau_0 x N / (J P*).
  const bool reached = r.attr_int(lo, "agrees") == 1;
  EXPECT_EQ(r.attr_int(pg, "reached"), reached ? 1 : 0);
  const double p_star = r.attr_double(pg, "p_star");
  if (reached) {
    EXPECT_DOUBLE_EQ(p_star, 3e-3);
    const double per_tau =
        r.attr_double(lo, "cpu_seconds") / (r.attr_double(lo, "duration") * 100.0);
    EXPECT_NEAR(r.attr_double(pg, "cpu_seconds_N"), per_tau * 100.0 / p_star,
                1e-9 * per_tau * 100.0 / p_star);
  } else {
    EXPECT_TRUE(std::isnan(p_star)) << p_star;
    EXPECT_TRUE(std::isnan(r.attr_double(pg, "cpu_seconds_N")));
  }
}
