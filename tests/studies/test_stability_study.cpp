// Stability study end to end on a tiny version of the quick preset: outputs exist, and an
// obviously stable (Euler dt = 0.05) and an obviously unstable (dt = 1.5) run are classified
// as such.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>

#include "lib/h5.hpp"
#include "studies/stability/stability.hpp"
#include "tests/driver/temp_dir.hpp"
#include "tests/studies/jamflow_exe.hpp"

using namespace jamflow;
using namespace jamflow::studies;

TEST(StabilityStudy, TinyQuickPreset) {
  StabilityPreset p = stability_preset("quick");
  p.dts = {0.05, 1.5};
  p.respa.clear();
  p.cvode_tols.clear();
  p.budget_particle_steps = 0.0;  // no budget: the runs are short
  p.t_prep_min = 200.0;
  p.strain_prep = 0.0;
  p.t_eq_min = 50.0;
  p.strain_eq = 0.0;
  p.t_av_min = 300.0;
  p.strain_av = 0.0;
  const testing_support::TempDir scratch(
      "jamflow_stability_study.");  // removed however the test ends
  const std::string dir = scratch.path();
  std::filesystem::remove_all(dir);
  use_test_jamflow();
  StudyOptions o;
  o.preset = "quick";
  o.out_dir = dir;
  o.quiet = true;
  o.jobs = 1;
  ASSERT_EQ(run_stability_preset(p, o, {"alpha=2"}), 0);
  // Every run is a point file of the sweep engine; a rerun reads them back, computing nothing.
  const auto files = point_files(dir);
  EXPECT_GE(files.size(), 2u);
  o.no_plots = true;  // the plots of the first run stay
  ASSERT_EQ(run_stability_preset(p, o, {"alpha=2"}), 0);
  EXPECT_EQ(point_files(dir), files);
  ASSERT_TRUE(std::filesystem::exists(dir + "/report.md"));
  ASSERT_TRUE(std::filesystem::exists(dir + "/stability.h5"));
  if (std::filesystem::exists("/usr/bin/python3")) {
    EXPECT_TRUE(std::filesystem::exists(dir + "/stability_map.png"));
  }

  H5Reader r(dir + "/stability.h5");
  ASSERT_EQ(r.attr_string("/cases/c00", "name"), "alpha=2");
  std::map<double, std::string> verdict;
  for (const auto& run : r.children("/cases/c00/runs")) {
    const std::string g = "/cases/c00/runs/" + run;
    verdict[r.attr_double(g, "step")] = r.attr_string(g, "verdict");
  }
  ASSERT_EQ(verdict.size(), 2u);
  // This tiny constant-pressure system is still compacting after t_eq = 50 (phi moved by 15%
  // across the window on this machine, trend t = 14): the run's steady verdict fails, and a
  // run that is not steady is left out of the study's conclusions. Were it steady, dt = 0.05
  // would be the largest stable step.
  // A run whose blocks are shorter than 2 tau (one replica: its block errors are too small) is
  // left out too ("correlated").
  EXPECT_TRUE(verdict[0.05] == "stable" || verdict[0.05] == "not steady" ||
              verdict[0.05] == "correlated")
      << verdict[0.05];
  EXPECT_TRUE(verdict[1.5] == "oscillating" || verdict[1.5] == "diverged") << verdict[1.5];
  const double largest = r.attr_double("/cases/c00", "largest_stable_dt");
  if (verdict[0.05] == "stable")
    EXPECT_DOUBLE_EQ(largest, 0.05);
  else
    EXPECT_TRUE(std::isnan(largest)) << largest;
  // Either way dt = 0.05 ran to its end without oscillating; when its verdicts leave it out,
  // the report says the stable range is not established instead of calling Euler unstable.
  EXPECT_DOUBLE_EQ(r.attr_double("/cases/c00", "largest_dt_without_oscillation"), 0.05);
  EXPECT_EQ(r.attr_int("/cases/c00", "runs_without_oscillation_left_out"),
            verdict[0.05] == "stable" ? 0 : 1);
  {
    std::ifstream in(dir + "/report.md");
    const std::string md((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(md.find("Euler unstable at every scanned dt"), std::string::npos);
    if (verdict[0.05] != "stable") {
      EXPECT_NE(md.find("not established (no oscillation up to 0.05"), std::string::npos);
    }
  }
  EXPECT_DOUBLE_EQ(r.attr_double("/cases/c00", "first_unstable_dt"), 1.5);
}

// The RESPA-against-N scan on one small size: only the RESPA steps run, and the thresholds are
// written. At N = 100, P = 1e-3 the outer-level piston at dt = 1 is far outside its stable
// range (energy balance about 0.01 on the quick preset: the piston's dissipation is inflated
// about 80x), so the verdict is robust to the short windows used here.
TEST(StabilityStudy, TinyRespaSizeScan) {
  StabilityPreset p = stability_preset("quick");
  p.respa_sizes = {100};
  p.respa_size_pressures = {1e-3};
  p.budget_particle_steps = 0.0;
  p.t_prep_min = 300.0;
  p.strain_prep = 0.0;
  p.t_eq_min = 50.0;
  p.strain_eq = 0.0;
  p.t_av_min = 400.0;
  p.strain_av = 0.0;
  const testing_support::TempDir scratch(
      "jamflow_stability_respa.");  // removed however the test ends
  const std::string dir = scratch.path();
  std::filesystem::remove_all(dir);
  use_test_jamflow();
  StudyOptions o;
  o.preset = "quick";
  o.out_dir = dir;
  o.quiet = true;
  o.jobs = 1;
  o.no_plots = true;
  ASSERT_EQ(run_stability_preset(p, o, {"RESPA N=100 P=0.001"}), 0);
  H5Reader r(dir + "/stability.h5");
  ASSERT_EQ(r.attr_string("/cases/c00", "name"), "RESPA N=100 P=0.001");
  std::map<double, std::string> verdict;
  for (const auto& run : r.children("/cases/c00/runs")) {
    const std::string g = "/cases/c00/runs/" + run;
    EXPECT_EQ(r.attr_string(g, "family"), "respa");
    verdict[r.attr_double(g, "step")] = r.attr_string(g, "verdict");
  }
  ASSERT_EQ(verdict.size(), 2u);  // dt = 0.5 and 1, nothing else
  EXPECT_TRUE(verdict[1.0] == "oscillating" || verdict[1.0] == "diverged") << verdict[1.0];
  const auto thresholds = r.children("/respa_size_thresholds");
  ASSERT_EQ(thresholds.size(), 2u);
  const std::string t1 = "/respa_size_thresholds/t01";
  EXPECT_DOUBLE_EQ(r.attr_double(t1, "dt"), 1.0);
  EXPECT_EQ(r.attr_int(t1, "largest_failing_N"), 100);
  EXPECT_EQ(r.attr_int(t1, "smallest_holding_N"), 0);
  std::ifstream in(dir + "/report.md");
  const std::string md((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(md.find("## RESPA with particle sub-steps against N"), std::string::npos);
  std::filesystem::remove_all(dir);
}
