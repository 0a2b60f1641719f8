// The soft-rheology and Olsson–Teitel studies' points: the sweep files they write are valid
// sweeps; the constant-volume points lie on the sides of phi_J the study needs, the standard
// and paper presets span at least three decades of gdot, and each point's integrator is the
// one the timestep study's findings give for the pressure expected there.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "analysis/seed.hpp"
#include "lib/error.hpp"
#include "studies/granular_report.hpp"
#include "studies/olsson-teitel/points.hpp"
#include "studies/soft-rheology/points.hpp"
#include "sweep/plan.hpp"

namespace jamflow::studies {
namespace {

sweep::Plan plan_of(const std::string& text) {
  return sweep::parse_plan(text, "v.toml", "/tmp", "/tmp/v-runs");
}

double number(const sweep::Point& pt, const char* table, const char* key) {
  const auto* node = pt.scene.table(table)->get(key);
  if (const auto* f = node->as_floating_point())
    return f->get();
  return static_cast<double>(node->as_integer()->get());
}

TEST(OlssonTeitelPoints, BothSidesOfJammingOverThreeDecades) {
  for (const char* name : {"quick", "standard", "paper"}) {
    const VolumePreset g = olsson_teitel::preset(name);
    const sweep::Plan p = plan_of(volume_sweep_text(g));
    EXPECT_EQ(p.points.size(), g.sizes.size() * g.phis.size() * g.rates.size()) << name;
    for (const auto n : g.sizes) {
      const double phi_j = seed::table2("phi_J").at(double(n));
      int below = 0, above = 0;
      for (double phi : g.phis)
        (phi < phi_j ? below : above) += 1;
      EXPECT_GE(below, 2) << name;
      EXPECT_GE(above, 2) << name;
    }
    const auto [lo, hi] = std::minmax_element(g.rates.begin(), g.rates.end());
    if (std::string(name) != "quick") {
      EXPECT_GE(std::log10(*hi / *lo), 3.0 - 1e-9) << name;
    }
    std::set<std::string> names;
    for (const auto& pt : p.points) {
      names.insert(pt.name);
      EXPECT_EQ(pt.scene.table("ensemble")->get("kind")->as_string()->get(), "constant_volume");
      const double phi = number(pt, "system", "phi"), rate = number(pt, "shear", "rate");
      const double n = number(pt, "system", "N");
      const auto ic = integrator_for(std::int64_t(n), expected_pressure(phi, rate));
      EXPECT_EQ(pt.scene.table("integrator")->get("kind")->as_string()->get(), ic.settings.kind)
          << pt.name;
      EXPECT_GE(number(pt, "run", "t_eq") * rate, g.strain_eq * 0.995) << pt.name;
      EXPECT_GE(number(pt, "run", "t_av") * rate, g.strain_av * 0.995) << pt.name;
    }
    EXPECT_EQ(names.size(), p.points.size()) << name;
  }
}

TEST(OlssonTeitelPoints, ExpectedPressureFollowsTheRegimes) {
  // Below phi_J the pressure vanishes with gdot (hard-sphere flow: J fixed by phi); above, it
  // tends to a finite yield pressure.
  EXPECT_LT(expected_pressure(0.62, 1e-8), 1e-6);
  EXPECT_NEAR(expected_pressure(0.62, 1e-6) / expected_pressure(0.62, 1e-7), 10.0, 0.5);
  EXPECT_GT(expected_pressure(0.68, 1e-9), 1e-3);
}

TEST(VolumePoints, RefusesSmallSystems) {
  VolumePreset g = olsson_teitel::preset("quick");
  g.sizes = {100};
  try {
    volume_sweep_text(g);
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("system.N = 100"), std::string::npos) << e.what();
  }
  EXPECT_THROW(olsson_teitel::preset("huge"), ConfigError);
}

TEST(SoftRheologyPoints, PressuresForTheExponentsAndVolumesAboveJamming) {
  for (const char* name : {"quick", "standard", "paper"}) {
    const soft_rheology::Preset g = soft_rheology::preset(name);
    // The joint fit needs three pressures at least; x and y need their lever arm.
    EXPECT_GE(g.pressure.pressures.size(), 3u) << name;
    const sweep::Plan cp = plan_of(pressure_sweep_text(g.pressure));
    EXPECT_GE(cp.points.size(), 11u) << name;
    EXPECT_NE(pressure_sweep_text(g.pressure).find("soft-rheology study"), std::string::npos);
    const sweep::Plan cv = plan_of(volume_sweep_text(g.volume));
    for (const auto& pt : cv.points) {
      const double n = number(pt, "system", "N");
      EXPECT_GT(number(pt, "system", "phi"), seed::table2("phi_J").at(n)) << pt.name;
    }
  }
  EXPECT_THROW(soft_rheology::preset("huge"), ConfigError);
}

}  // namespace
}  // namespace jamflow::studies
