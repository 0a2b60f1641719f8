// Stability study end to end on a tiny version of the quick preset: outputs exist, and an
// obviously stable (Euler dt = 0.05) and an obviously unstable (dt = 1.5) run are classified
// as such.
#include <gtest/gtest.h>
#include <unistd.h>

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

// The case is P = 0.1 (harmonic, J = 0.1): its piston relaxes phi within 5 / P = 50, so a
// preparation of 200 leaves a steady state (trend |t| <= 1.8 against the verdict's 4, measured),
// and tau of sigma_xy, phi and P is at most 13 here, so blocks of 75 (t_av = 1500, 20 blocks) are
// about 3x the decorrelated verdict's 2 tau. The standard preset (N = 500) finds Euler stable up
// to dt = 0.2 and oscillating from 0.3 at this case: dt = 0.05 is 4x below that limit and
// dt = 1.5 5x above it, so both verdicts are firm.
TEST(StabilityStudy, TinyQuickPreset) {
  StabilityPreset p = stability_preset("quick");
  // The case is stiff: its scan starts with stiff_dts, and the preparation runs at the first.
  p.stiff_dts = {0.05};
  p.dts = {1.5};
  p.respa.clear();
  p.cvode_tols.clear();
  p.budget_particle_steps = 0.0;  // no budget: the runs are short
  p.t_prep_min = 200.0;
  p.strain_prep = 0.0;
  p.t_eq_min = 50.0;
  p.strain_eq = 0.0;
  p.t_av_min = 1500.0;
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
  ASSERT_EQ(run_stability_preset(p, o, {"P=0.1"}), 0);
  // Every run is a point file of the sweep engine; a rerun reads them back, computing nothing.
  const auto files = point_files(dir);
  EXPECT_EQ(files.size(), 3u);  // the preparation and two runs
  o.no_plots = true;            // the plots of the first run stay
  ASSERT_EQ(run_stability_preset(p, o, {"P=0.1"}), 0);
  EXPECT_EQ(point_files(dir), files);
  ASSERT_TRUE(std::filesystem::exists(dir + "/report.md"));
  ASSERT_TRUE(std::filesystem::exists(dir + "/stability.h5"));
  if (std::filesystem::exists("/usr/bin/python3")) {
    EXPECT_TRUE(std::filesystem::exists(dir + "/stability_map.png"));
  }

  H5Reader r(dir + "/stability.h5");
  ASSERT_EQ(r.attr_string("/cases/c00", "name"), "P=0.1");
  std::map<double, std::string> verdict, reason;
  for (const auto& run : r.children("/cases/c00/runs")) {
    const std::string g = "/cases/c00/runs/" + run;
    verdict[r.attr_double(g, "step")] = r.attr_string(g, "verdict");
    reason[r.attr_double(g, "step")] = r.attr_string(g, "reason");
  }
  ASSERT_EQ(verdict.size(), 2u);
  EXPECT_EQ(verdict[0.05], "stable") << reason[0.05];
  EXPECT_TRUE(verdict[1.5] == "oscillating" || verdict[1.5] == "diverged") << verdict[1.5];
  // The summary: stable up to 0.05, unstable at 1.5, no run left out by its verdicts.
  EXPECT_DOUBLE_EQ(r.attr_double("/cases/c00", "largest_stable_dt"), 0.05);
  EXPECT_DOUBLE_EQ(r.attr_double("/cases/c00", "largest_dt_without_oscillation"), 0.05);
  EXPECT_EQ(r.attr_int("/cases/c00", "runs_without_oscillation_left_out"), 0);
  EXPECT_DOUBLE_EQ(r.attr_double("/cases/c00", "first_unstable_dt"), 1.5);
  {
    std::ifstream in(dir + "/report.md");
    const std::string md((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_NE(md.find("**P=0.1**: Euler stable up to dt = 0.05; at dt = 1.5: " + verdict[1.5]),
              std::string::npos)
        << md;
  }
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
