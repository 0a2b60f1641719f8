// The hard-sphere and finite-size studies' points: the sweep file they write is a valid sweep
// whose points are the preset's grid, named by N, P and gdot, with the integrator the protocol
// prescribes for each size and pressure.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>

#include "analysis/seed.hpp"
#include "studies/common.hpp"
#include "studies/granular_report.hpp"
#include "studies/pressure_points.hpp"
#include "sweep/plan.hpp"

namespace jamflow::studies {
namespace {

sweep::Plan plan_of(const GridPreset& g) {
  return sweep::parse_plan(pressure_sweep_text(g), "hs.toml", "/tmp", "/tmp/hs-runs");
}

TEST(HardSpherePoints, StandardGridIsEveryPressureAndJAboveTheRateFloor) {
  const GridPreset g = grid_preset("standard");
  const sweep::Plan p = plan_of(g);
  std::size_t expected = 0;
  for (double pr : g.pressures) {
    for (double j : g.js)
      expected += j * pr >= g.gdot_min ? 1 : 0;
  }
  EXPECT_EQ(p.points.size(), expected);
  EXPECT_EQ(p.replicas, g.replicas);
  std::set<std::string> names;
  for (const auto& pt : p.points) {
    names.insert(pt.name);
    const double pressure = pt.scene.table("ensemble")->get("pressure")->as_floating_point()->get();
    const double rate = pt.scene.table("shear")->get("rate")->as_floating_point()->get();
    const double t_eq = pt.scene.table("run")->get("t_eq")->as_floating_point()->get();
    const double t_av = pt.scene.table("run")->get("t_av")->as_floating_point()->get();
    // Lengths in strain and in units of the compaction time 1/P (3 significant digits).
    EXPECT_GE(t_eq * rate, g.strain_eq * 0.995) << pt.name;
    EXPECT_GE(t_eq * pressure, g.relax_pressure * 0.995) << pt.name;
    // t_av = t_eq, as the seed does.
    EXPECT_DOUBLE_EQ(t_av, t_eq) << pt.name;
    EXPECT_EQ(pt.name.find("99999"), std::string::npos) << pt.name;  // rounded decimals
    // RKC at atol = 0.1 delta = 0.1 P near jamming.
    const auto* integ = pt.scene.table("integrator");
    EXPECT_EQ(integ->get("kind")->as_string()->get(), "rkc");
    EXPECT_DOUBLE_EQ(integ->get("atol")->as_floating_point()->get(), 0.1 * pressure);
  }
  EXPECT_EQ(names.size(), p.points.size());
  EXPECT_NE(names.count("pressure-1e-05_rate-3e-09_N-1000"), 0u);  // J = 3e-4
}

// The paper preset is the seed's grid above its shear-rate floor, plus the low-J ladder at
// N = 1000 below it: every J of the ladder at two pressures (so that the envelope can test it),
// nothing else below the floor, and no point twice where a ladder meets the grid.
TEST(HardSpherePoints, PaperPresetAddsTheLowJLadderAtOneSize) {
  const GridPreset g = grid_preset("paper");
  ASSERT_FALSE(g.extensions.empty());
  const sweep::Plan p = plan_of(g);
  std::set<std::string> names;
  std::map<double, std::set<double>> ladder;  // J -> pressures, below the floor
  for (const auto& pt : p.points) {
    names.insert(pt.name);
    const double pressure = pt.scene.table("ensemble")->get("pressure")->as_floating_point()->get();
    const double rate = pt.scene.table("shear")->get("rate")->as_floating_point()->get();
    const auto n = pt.scene.table("system")->get("N")->as_integer()->get();
    if (rate >= g.gdot_min)
      continue;
    EXPECT_EQ(n, 1000) << pt.name;
    ladder[std::round(rate / pressure * 1e6) / 1e6].insert(pressure);
  }
  EXPECT_EQ(names.size(), p.points.size());
  ASSERT_EQ(ladder.size(), 3u);  // J = 3e-5, 1e-4, 3e-4
  EXPECT_EQ(ladder.begin()->first, 3e-5);
  for (const auto& [j, pressures] : ladder)
    EXPECT_EQ(pressures.size(), 2u) << j;
  // The grid's own points are those of the seed's grid without the ladder.
  GridPreset seed_grid = g;
  seed_grid.extensions.clear();
  EXPECT_EQ(plan_of(seed_grid).points.size() + 6u, p.points.size());
  // The finite-size study's paper preset is the seed's grid alone: its sizes share one J window.
  const sweep::Plan fs = plan_of(finite_size_preset("paper"));
  EXPECT_EQ(fs.points.size(), plan_of(seed_grid).points.size());
  for (const auto& pt : fs.points)
    EXPECT_GE(pt.scene.table("shear")->get("rate")->as_floating_point()->get(), g.gdot_min)
        << pt.name;
}

TEST(HardSpherePoints, IntegratorFollowsSizeAndPressure) {
  EXPECT_EQ(integrator_for(1000, 1e-5).settings.kind, "rkc");
  EXPECT_DOUBLE_EQ(*integrator_for(1000, 1e-5).settings.number("atol"), 1e-6);
  EXPECT_EQ(integrator_for(1000, 1e-3).settings.kind, "respa");
  EXPECT_EQ(integrator_for(1000, 1e-3).settings.number("dt"), 1.0);
  EXPECT_EQ(integrator_for(300, 1e-3).settings.number("dt"), 0.5);
  EXPECT_EQ(integrator_for(100, 1e-3).settings.table()["inner"].value<std::string>(), "piston");
  EXPECT_EQ(integrator_for(100, 1e-3).settings.number("n_inner"), 8.0);
  // The paper preset's sweep is valid in every point (RKC has no dt key, RESPA has one).
  const sweep::Plan paper = plan_of(grid_preset("paper"));
  bool rkc = false, piston = false;
  for (const auto& pt : paper.points) {
    const auto* in = pt.scene.table("integrator");
    rkc = rkc || in->get("kind")->as_string()->get() == "rkc";
    piston = piston || (in->get("inner") && in->get("inner")->as_string()->get() == "piston");
    if (in->get("kind")->as_string()->get() == "rkc") {
      EXPECT_EQ(in->get("dt"), nullptr);
    }
  }
  EXPECT_TRUE(rkc);
  EXPECT_TRUE(piston);
}

TEST(HardSpherePoints, SeedValuesFollowTable2) {
  // The N = 1000 values from Table 2's size law.
  EXPECT_NEAR(seed::table2("phi_J").at(1000), 0.6465, 5e-5);
  EXPECT_NEAR(seed::table2("b_phi").at(1000), 0.414, 5e-4);
  EXPECT_NEAR(seed::table2("C_phi").at(1000), 0.068, 5e-4);
  EXPECT_NEAR(seed::table2("mu_J").at(1000), 0.1117, 5e-5);
  EXPECT_NEAR(seed::table2("b_mu").at(1000), 0.350, 5e-4);
  EXPECT_NEAR(seed::table2("C_mu").at(1000), 0.346, 5e-4);
  EXPECT_DOUBLE_EQ(seed::table2("phi_J").at(0), 0.6474);
  EXPECT_THROW(seed::table2("phi_j"), std::out_of_range);
  // The studies' starting packing fractions come from the same law, bit for bit as the
  // formula written out (the committed sweeps' scenes were planned with it).
  for (std::int64_t n : {100, 1000, 2000}) {
    for (double j : {1e-3, 3e-2, 1.0}) {
      const double nn = double(n);
      const double phi_j = 0.6474 - 0.323 * std::pow(nn, -0.852);
      const double b = 0.391 + 0.756 * std::pow(nn, -0.505);
      const double c = 0.0683 - 1.15 * std::pow(nn, -1.17);
      EXPECT_EQ(hard_sphere_phi(j, n), phi_j - c * std::pow(j, b)) << n << " " << j;
    }
  }
}

}  // namespace
}  // namespace jamflow::studies
