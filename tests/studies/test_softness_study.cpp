// Softness study end to end on a tiny version of the quick preset (harmonic only): outputs
// exist, dt = 0.05 is stable and accurate, dt = 1.5 is not, so dt_max = 0.05, and the cost
// follows particle-steps = 1 / (J P* dt_max).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "lib/h5.hpp"
#include "studies/softness/softness.hpp"
#include "tests/studies/jamflow_exe.hpp"

using namespace jamflow;
using namespace jamflow::studies;

TEST(SoftnessStudy, CostModel) {
  EXPECT_DOUBLE_EQ(steps_per_particle(0.1, 1e-3, 0.5), 1.0 / (0.1 * 1e-3 * 0.5));
}

TEST(SoftnessStudy, TinyQuickPreset) {
  SoftnessPreset p = softness_preset("quick");
  p.n = 100;
  p.alphas = {2.0};
  p.deltas = {1e-2, 3e-3};
  p.scan_dts = {0.05, 1.5};
  p.t_prep = 200.0;
  p.strain_prep = 0.0;
  p.t_scan = 240.0;
  p.t_min = 300.0;
  p.strain_eq = 0.0;
  p.strain_av = 0.0;
  p.budget_particle_steps = 0.0;  // no budget: the runs are short
  const std::string dir =
      ::testing::TempDir() + "jamflow_softness_study." + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  use_test_jamflow();
  StudyOptions o;
  o.preset = "quick";
  o.out_dir = dir;
  o.quiet = true;
  o.jobs = 1;
  ASSERT_EQ(run_softness_preset(p, o), 0);
  // Every run is a point file of the sweep engine; a rerun reads them back, computing nothing.
  const auto files = point_files(dir);
  EXPECT_GE(files.size(), 2u);
  o.no_plots = true;  // the plots of the first run stay
  ASSERT_EQ(run_softness_preset(p, o), 0);
  EXPECT_EQ(point_files(dir), files);
  ASSERT_TRUE(std::filesystem::exists(dir + "/report.md"));
  ASSERT_TRUE(std::filesystem::exists(dir + "/softness.h5"));
  if (std::filesystem::exists("/usr/bin/python3")) {
    EXPECT_TRUE(std::filesystem::exists(dir + "/softness_cost.png"));
  }

  H5Reader r(dir + "/softness.h5");
  const std::string a = "/alphas/a00";
  EXPECT_DOUBLE_EQ(r.attr_double(a, "alpha"), 2.0);
  // A run enters the conclusions only if it is stable and passes its own verdicts; this tiny
  // system may still drift (not steady) or have blocks shorter than 2 tau (correlated, one
  // replica): then the report lists it among the runs left out.
  bool all_in = true;
  for (const std::string end : {"/scan_hi", "/scan_lo"}) {
    const std::string v0 = r.attr_string(a + end + "/runs/r000", "verdict");
    EXPECT_TRUE(v0 == "stable" || v0 == "not steady" || v0 == "correlated") << v0;
    all_in = all_in && v0 == "stable";
    const std::string v = r.attr_string(a + end + "/runs/r001", "verdict");
    EXPECT_TRUE(v == "oscillating" || v == "diverged") << v;
  }
  if (all_in)
    EXPECT_DOUBLE_EQ(r.attr_double(a, "dt_max"), 0.05);
  else
    EXPECT_TRUE(std::isnan(r.attr_double(a, "dt_max")));
  // The pressure scan runs at dt_max, or at the smallest scanned step when none is found.
  const std::string pg = a + "/pscan/J1";
  const double p_star = r.attr_double(pg, "p_star");
  if (std::isfinite(p_star)) {
    EXPECT_NEAR(r.attr_double(pg, "steps_per_particle"), steps_per_particle(1.0, p_star, 0.05),
                1e-9 * steps_per_particle(1.0, p_star, 0.05));
  }
  if (!all_in || !std::isfinite(p_star)) {
    std::ifstream in(dir + "/report.md");
    const std::string report((std::istreambuf_iterator<char>(in)), {});
    const auto at = report.find("## Runs left out by their verdicts");
    ASSERT_NE(at, std::string::npos);
    EXPECT_NE(report.find("\n- ", at), std::string::npos) << report.substr(at);
  }
}
