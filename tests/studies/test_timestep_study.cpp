// Timestep study end to end on a tiny version of the quick preset: outputs exist, the
// reference is Euler at the smallest dt, dt = 0.05 is stable with a finite error, dt = 1.5 is
// not stable and never counted as meeting a target.
#include <gtest/gtest.h>
#include <unistd.h>

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

TEST(TimestepStudy, TinyQuickPreset) {
  TimestepPreset p = timestep_preset("quick");
  p.points.resize(1);  // constant pressure P = 1e-3, gdot = 1e-3
  p.points[0].n = 150;
  p.euler_dts = {0.02, 0.05, 1.5};
  p.respa.clear();
  p.cvode_tols.clear();
  p.rkc_overlaps = {0.1};         // one RKC setting, run r003
  p.budget_particle_steps = 0.0;  // no budget: the runs are short
  p.t_prep_min = 3000.0;          // compressed until steady: the runs must pass the steady verdict
  p.strain_prep = 0.0;
  p.t_eq_min = 300.0;
  p.strain_eq = 0.0;
  p.t_av_min = 480.0;
  p.strain_av = 0.0;
  const testing_support::TempDir scratch(
      "jamflow_timestep_study.");  // removed however the test ends
  const std::string dir = scratch.path();
  std::filesystem::remove_all(dir);
  use_test_jamflow();
  StudyOptions o;
  o.preset = "quick";
  o.out_dir = dir;
  o.quiet = true;
  o.jobs = 1;
  ASSERT_EQ(run_timestep_preset(p, o), 0);
  // Every run is a point file of the sweep engine; a rerun reads them back, computing nothing.
  const auto files = point_files(dir);
  EXPECT_GE(files.size(), 2u);
  o.no_plots = true;  // the plots of the first run stay
  ASSERT_EQ(run_timestep_preset(p, o), 0);
  EXPECT_EQ(point_files(dir), files);
  ASSERT_TRUE(std::filesystem::exists(dir + "/report.md"));
  ASSERT_TRUE(std::filesystem::exists(dir + "/timestep.h5"));
  if (std::filesystem::exists("/usr/bin/python3")) {
    EXPECT_TRUE(std::filesystem::exists(dir + "/timestep_wp_sigma_xy.png"));
  }

  H5Reader r(dir + "/timestep.h5");
  EXPECT_EQ(r.attr_int("/points/p00", "reference"), 0);
  const std::string g005 = "/points/p00/runs/r001", g15 = "/points/p00/runs/r002";
  EXPECT_DOUBLE_EQ(r.attr_double(g005, "step"), 0.05);
  // The cost columns: each run's CPU seconds (its file recorded them) and particle-steps.
  for (const std::string& g : {std::string("/points/p00/runs/r000"), g005}) {
    const double cpu = r.attr_double(g, "cpu_seconds");
    EXPECT_TRUE(std::isfinite(cpu) && cpu > 0.0) << g << ": " << cpu;
    EXPECT_EQ(r.attr_int(g, "cpu_from_wall"), 0) << g;
    EXPECT_GT(r.attr_double(g, "particle_steps"), 0.0) << g;
  }
  // A run enters the errors only if it is stable and passes its own verdicts; this tiny system
  // may still drift (not steady) or have blocks shorter than 2 tau (correlated, one replica):
  // then the report lists it among the runs left out, and its error is not a conclusion.
  const std::string v_ref = r.attr_string("/points/p00/runs/r000", "verdict");
  const std::string v005 = r.attr_string(g005, "verdict");
  for (const auto& v : {v_ref, v005})
    EXPECT_TRUE(v == "stable" || v == "not steady" || v == "correlated") << v;
  if (v_ref == "stable" && v005 == "stable") {
    const double err = r.attr_double(g005, "err_sigma_xy");
    const double floor = r.attr_double(g005, "floor_sigma_xy");
    EXPECT_TRUE(std::isfinite(err));
    EXPECT_TRUE(std::isfinite(floor));
    EXPECT_LT(err, 0.05);  // first-order bias of Euler at dt = 0.05 against dt = 0.02
  } else {
    std::ifstream in(dir + "/report.md");
    const std::string report((std::istreambuf_iterator<char>(in)), {});
    const std::string left_out = report.substr(report.find("## Runs left out by their verdicts"));
    if (v005 != "stable") {
      EXPECT_NE(left_out.find("euler dt=0.05: " + v005), std::string::npos) << left_out;
    }
    if (v_ref != "stable") {
      EXPECT_NE(left_out.find("euler dt=0.02: " + v_ref), std::string::npos) << left_out;
    }
  }
  // RKC runs beside the fixed steps, at atol = 0.1 overlaps, and is not unstable.
  const std::string grkc = "/points/p00/runs/r003";
  EXPECT_EQ(r.attr_string(grkc, "family"), "rkc");
  EXPECT_EQ(r.attr_string(grkc, "curve"), "rkc");
  EXPECT_DOUBLE_EQ(r.attr_double(grkc, "tolerance"), 0.1);
  const std::string vrkc = r.attr_string(grkc, "verdict");
  EXPECT_TRUE(vrkc == "stable" || vrkc == "not steady" || vrkc == "correlated") << vrkc;
  EXPECT_GT(r.attr_double(grkc, "cpu_seconds"), 0.0);
  EXPECT_DOUBLE_EQ(r.attr_double(g15, "step"), 1.5);
  const std::string v15 = r.attr_string(g15, "verdict");
  EXPECT_TRUE(v15 == "oscillating" || v15 == "diverged") << v15;
  EXPECT_DOUBLE_EQ(r.attr_double("/points/p00", "first_unstable_euler_dt"), 1.5);
  // No target is met by the unstable run.
  for (const auto& t : r.children("/targets")) {
    const std::string text = r.attr_string("/targets/" + t, "p0");
    EXPECT_EQ(text.find("dt=1.5"), std::string::npos) << text;
  }
}
