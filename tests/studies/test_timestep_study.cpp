// Timestep study end to end on a tiny version of the quick preset: outputs exist, the
// reference is Euler at the smallest dt, dt = 0.05 and RKC are stable and their errors are their
// shifts from the reference within a stated bound, no run is left out, and dt = 1.5 is not
// stable and never counted as meeting a target.
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

// The point is P = 0.1, gdot = 0.01 (harmonic, J = 0.1), where verdicts are firm (the stability
// test's case): the piston relaxes phi within 5 / P = 50 (the preparation runs 200), and tau of
// sigma_xy, phi and P is at most about 13, so blocks of 75 (t_av = 1500, 20 blocks) are about
// 3x the decorrelated verdict's 2 tau. Euler's limit there lies between dt = 0.2 and 0.3
// (standard stability preset): 0.02 and 0.05 are far below it, 1.5 far above.
TEST(TimestepStudy, TinyQuickPreset) {
  TimestepPreset p = timestep_preset("quick");
  p.points.resize(1);
  StatePoint& pt = p.points[0];
  ASSERT_TRUE(pt.constant_pressure);
  pt.n = 150;
  pt.pressure = 0.1;
  pt.gdot = 0.01;
  pt.phi = 0.75;  // initial packing, as the stability study's P = 0.1 case
  pt.name = "P=0.1 gdot=0.01";
  p.euler_dts = {0.02, 0.05, 1.5};
  p.respa.clear();
  p.cvode_tols.clear();
  p.rkc_overlaps = {0.1};         // one RKC setting, run r003
  p.budget_particle_steps = 0.0;  // no budget: the runs are short
  p.t_prep_min = 200.0;
  p.strain_prep = 0.0;
  p.t_eq_min = 50.0;
  p.strain_eq = 0.0;
  p.t_av_min = 1500.0;
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
  EXPECT_EQ(files.size(), 5u);  // the preparation and four settings
  o.no_plots = true;            // the plots of the first run stay
  ASSERT_EQ(run_timestep_preset(p, o), 0);
  EXPECT_EQ(point_files(dir), files);
  ASSERT_TRUE(std::filesystem::exists(dir + "/report.md"));
  ASSERT_TRUE(std::filesystem::exists(dir + "/timestep.h5"));
  if (std::filesystem::exists("/usr/bin/python3")) {
    EXPECT_TRUE(std::filesystem::exists(dir + "/timestep_wp_sigma_xy.png"));
  }

  H5Reader r(dir + "/timestep.h5");
  EXPECT_EQ(r.attr_int("/points/p00", "reference"), 0);
  const std::string g_ref = "/points/p00/runs/r000", g005 = "/points/p00/runs/r001",
                    g15 = "/points/p00/runs/r002", grkc = "/points/p00/runs/r003";
  EXPECT_DOUBLE_EQ(r.attr_double(g_ref, "step"), 0.02);
  EXPECT_DOUBLE_EQ(r.attr_double(g005, "step"), 0.05);
  // The cost columns: each run's CPU seconds (its file recorded them) and particle-steps, and
  // the coarser step costs fewer particle-steps for the same duration (2.5x fewer steps).
  for (const std::string& g : {g_ref, g005}) {
    const double cpu = r.attr_double(g, "cpu_seconds");
    EXPECT_TRUE(std::isfinite(cpu) && cpu > 0.0) << g << ": " << cpu;
    EXPECT_EQ(r.attr_int(g, "cpu_from_wall"), 0) << g;
    EXPECT_GT(r.attr_double(g, "particle_steps"), 0.0) << g;
  }
  EXPECT_NEAR(r.attr_double(g_ref, "particle_steps") / r.attr_double(g005, "particle_steps"), 2.5,
              0.01);
  // The fine steps and RKC are stable and pass their own verdicts, so every one enters the
  // errors and none is left out.
  for (const std::string& g : {g_ref, g005, grkc})
    EXPECT_EQ(r.attr_string(g, "verdict"), "stable") << g << ": " << r.attr_string(g, "reason");
  // Each error is the shift of the run's mean from the reference's, relative for sigma_xy and
  // absolute for phi, with a positive floor; the reference's own shift is zero.
  const double s_ref = r.attr_double(g_ref, "summary_sigma_xy");
  const double phi_ref = r.attr_double(g_ref, "summary_phi");
  EXPECT_EQ(r.attr_int(g_ref, "is_reference"), 1);
  EXPECT_EQ(r.attr_double(g_ref, "err_sigma_xy"), 0.0);
  for (const std::string& g : {g005, grkc}) {
    EXPECT_EQ(r.attr_int(g, "is_reference"), 0) << g;
    const double err = r.attr_double(g, "err_sigma_xy");
    const double floor = r.attr_double(g, "floor_sigma_xy");
    EXPECT_NEAR(err, std::abs(r.attr_double(g, "summary_sigma_xy") - s_ref) / std::abs(s_ref),
                1e-12)
        << g;
    EXPECT_NEAR(r.attr_double(g, "err_phi"), std::abs(r.attr_double(g, "summary_phi") - phi_ref),
                1e-12)
        << g;
    EXPECT_GT(floor, 0.0) << g;
    EXPECT_GT(r.attr_double(g, "floor_phi"), 0.0) << g;
    // The shift is Euler's first-order bias at dt = 0.05 (or RKC's at 0.1 delta) plus noise:
    // both well below 5 % of sigma_xy here, so the shift is below 5 % + 4 floors (4 sigma: the
    // noise part exceeds it with probability below 1e-4).
    EXPECT_LT(err, 0.05 + 4.0 * floor) << g;
    RecordProperty(g + " err_sigma_xy", std::to_string(err));
    RecordProperty(g + " floor_sigma_xy", std::to_string(floor));
  }
  {
    std::ifstream in(dir + "/report.md");
    const std::string report((std::istreambuf_iterator<char>(in)), {});
    const auto at = report.find("## Runs left out by their verdicts");
    ASSERT_NE(at, std::string::npos);
    EXPECT_NE(report.find("None: every run that finished stable passed its verdicts.", at),
              std::string::npos)
        << report.substr(at);
  }
  // RKC runs beside the fixed steps, at atol = 0.1 overlaps.
  EXPECT_EQ(r.attr_string(grkc, "family"), "rkc");
  EXPECT_EQ(r.attr_string(grkc, "curve"), "rkc");
  EXPECT_DOUBLE_EQ(r.attr_double(grkc, "tolerance"), 0.1);
  EXPECT_GT(r.attr_double(grkc, "cpu_seconds"), 0.0);
  // Euler far above its limit is unstable, the first unstable step, and meets no target.
  EXPECT_DOUBLE_EQ(r.attr_double(g15, "step"), 1.5);
  const std::string v15 = r.attr_string(g15, "verdict");
  EXPECT_TRUE(v15 == "oscillating" || v15 == "diverged") << v15;
  EXPECT_DOUBLE_EQ(r.attr_double("/points/p00", "first_unstable_euler_dt"), 1.5);
  for (const auto& t : r.children("/targets")) {
    const std::string text = r.attr_string("/targets/" + t, "p0");
    EXPECT_EQ(text.find("dt=1.5"), std::string::npos) << text;
  }
}
