// Softness study end to end on a tiny version of the quick preset (harmonic only): outputs
// exist, dt = 0.05 is stable and accurate, dt = 1.5 is not, so dt_max = 0.05, and the cost
// follows particle-steps = 1 / (J P* dt_max).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>

#include "lib/h5.hpp"
#include "studies/softness/softness.hpp"

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
  p.budget_seconds = 0.0;  // no CPU-time budget in tests (sanitizer builds are slow)
  const std::string dir =
      ::testing::TempDir() + "jamflow_softness_study." + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  StudyOptions o;
  o.preset = "quick";
  o.out_dir = dir;
  o.quiet = true;
  o.threads = 1;
  ASSERT_EQ(run_softness_preset(p, o), 0);
  ASSERT_TRUE(std::filesystem::exists(dir + "/report.md"));
  ASSERT_TRUE(std::filesystem::exists(dir + "/softness.h5"));
  if (std::filesystem::exists("/usr/bin/python3")) {
    EXPECT_TRUE(std::filesystem::exists(dir + "/softness_cost.png"));
  }

  H5Reader r(dir + "/softness.h5");
  const std::string a = "/alphas/a00";
  EXPECT_DOUBLE_EQ(r.attr_double(a, "alpha"), 2.0);
  for (const std::string end : {"/scan_hi", "/scan_lo"}) {
    EXPECT_EQ(r.attr_string(a + end + "/runs/r000", "verdict"), "stable");
    const std::string v = r.attr_string(a + end + "/runs/r001", "verdict");
    EXPECT_TRUE(v == "oscillating" || v == "diverged") << v;
  }
  EXPECT_DOUBLE_EQ(r.attr_double(a, "dt_max"), 0.05);
  const std::string pg = a + "/pscan/J1";
  const double p_star = r.attr_double(pg, "p_star");
  ASSERT_TRUE(std::isfinite(p_star));
  EXPECT_NEAR(r.attr_double(pg, "steps_per_particle"), steps_per_particle(1.0, p_star, 0.05),
              1e-9 * steps_per_particle(1.0, p_star, 0.05));
}
