// Shear of more than one cell length per step (gdot dt > 1): every integrator runs it, the
// neighbour lists stay within their image codes, and no contact is missed. Before the fix the
// tilt left [-1/2, 1/2] by more than one remap per step, the list's image codes overflowed into
// the particle index, and the first re-selection read out of bounds (SIGSEGV).
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "ensembles/constant_pressure.hpp"
#include "ensembles/constant_volume.hpp"
#include "integrators/integrator.hpp"
#include "lib/error.hpp"
#include "lib/forces.hpp"
#include "lib/init.hpp"
#include "lib/model.hpp"

namespace jamflow {
namespace {

std::unique_ptr<Integrator> integrator(const std::string& body) {
  const Scene scene = Scene::parse("[integrator]\n" + body, "fast-shear-test.toml");
  ConfigSection sec = scene.section("integrator");
  return make_integrator(sec);
}

// Every entry of both lists names a particle and one of the 27 images.
void expect_lists_in_range(const Model& m, const std::string& where) {
  const NeighbourList& list = m.neighbour_list();
  const std::size_t n = m.state().size();
  for (const auto* entries : {&list.entries(), &list.inner_entries()}) {
    for (std::uint32_t e : *entries) {
      ASSERT_LT(e >> NeighbourList::kCodeBits, n) << where;
      ASSERT_LT(e & NeighbourList::kCodeMask, 27u) << where;
    }
  }
}

// The list-based forces equal the all-pairs forces of the same state: no contact missed.
void expect_all_pairs_forces(Model& m, const std::string& where) {
  const Evaluation& ev = m.evaluate();
  ForceField all(m.options().alpha, 1);
  ForceResult ref;
  all.compute_all_pairs(m.state(), ref);
  ASSERT_EQ(ev.forces.contacts, ref.contacts) << where;
  for (std::size_t k = 0; k < ref.force.size(); ++k)
    ASSERT_NEAR(ev.forces.force[k], ref.force[k], 1e-10) << where << ", component " << k;
}

TEST(FastShear, AnyStrainPerStepKeepsTheListsWithinRangeAndMissesNoContact) {
  const char* integrators[] = {"kind = \"euler\"\ndt = 0.1\n", "kind = \"respa\"\ndt = 0.1\n",
                               "kind = \"respa\"\ndt = 0.1\ninner = \"piston\"\n"};
  for (const char* body : integrators) {
    for (double gdot : {15.0, 20.0, 200.0, 1e4}) {
      for (bool piston : {false, true}) {
        const std::string where = std::string(body) + "gdot " + std::to_string(gdot) +
                                  (piston ? ", constant pressure" : ", constant volume");
        Model m(random_state(200, 0.62, 7), ModelOptions{2.0, 0.3, 1, 20});
        auto integ = integrator(body);
        ConstantVolume nv(gdot);
        ConstantPressure np(gdot, 1e-2, 1e-2);
        const Ensemble& ens = piston ? static_cast<const Ensemble&>(np) : nv;
        for (int k = 1; k <= 20; ++k) {
          integ->advance(m, ens, 0.1 * k);
          expect_lists_in_range(m, where);
          if (::testing::Test::HasFatalFailure())
            return;
        }
        EXPECT_GT(m.state().box.strain, 0.5 * gdot) << where;
        EXPECT_LE(std::abs(m.state().box.tilt_fraction()), 0.5 + gdot * 0.1) << where;
        expect_all_pairs_forces(m, where);
        if (::testing::Test::HasFatalFailure())
          return;
      }
    }
  }
}

// CVODE ends its stretches at each remap; at a high rate it takes many, and stays in range.
TEST(FastShear, CvodeThroughManyRemaps) {
  Model m(random_state(200, 0.62, 3), ModelOptions{2.0, 0.3, 1, 20});
  auto integ = integrator("kind = \"cvode\"\n");
  ConstantVolume ens(20.0);
  integ->advance(m, ens, 0.5);
  EXPECT_GE(m.state().box.flips, 9);
  EXPECT_LE(std::abs(m.state().box.tilt_fraction()), 0.5 + 1e-9);
  expect_lists_in_range(m, "cvode");
  expect_all_pairs_forces(m, "cvode");
}

// A strain whose fraction round-off has lost cannot be reduced: a failed run, not a crash.
TEST(FastShear, ATiltBeyondRepresentationIsAnIntegrationError) {
  Model m(random_state(100, 0.6, 1), ModelOptions{2.0, 0.3, 1, 20});
  auto integ = integrator("kind = \"euler\"\ndt = 0.1\n");
  ConstantVolume ens(1e100);
  EXPECT_THROW(integ->advance(m, ens, 1.0), IntegrationError);
}

TEST(Box, RemapsDueBringAnyTiltWithinOneHalf) {
  for (double strain : {0.3, 0.55, -0.55, 1.49, 7.3, -7.3, 123456.7}) {
    State s = random_state(50, 0.5, 2);
    s.box.strain = strain;
    const std::int64_t k = s.box.remaps_due();
    EXPECT_EQ(k == 0, s.box.remap_direction() == 0) << strain;
    const Eigen::Vector3d r0 = s.real(3);
    s.remap(k);
    EXPECT_LE(std::abs(s.box.tilt_fraction()), 0.5 + 1e-9) << strain;
    EXPECT_LT((s.real(3) - r0).norm(), 1e-9 * std::max(1.0, std::abs(strain))) << strain;
  }
  Box b;
  b.strain = 1e100;
  EXPECT_THROW(b.remaps_due(), IntegrationError);
  b.strain = INFINITY;
  EXPECT_THROW(b.remaps_due(), IntegrationError);
}

// What the list cannot name is refused, not written: a cell tilted past kMaxBuildTilt,
// positions outside [0, 1), non-finite positions.
TEST(NeighbourList, RefusesABuildWhoseImagesItCannotName) {
  NeighbourList list(0.3);
  State tilted = random_state(200, 0.6, 4);
  tilted.box.strain = 0.9;
  EXPECT_THROW(list.build(tilted), std::invalid_argument);
  tilted.box.strain = NeighbourList::kMaxBuildTilt;
  EXPECT_NO_THROW(list.build(tilted));
  State unwrapped = random_state(200, 0.6, 4);
  unwrapped.x()[5] += 3.0;
  EXPECT_THROW(list.build(unwrapped), std::invalid_argument);
  unwrapped.x()[5] = -1e-3;
  EXPECT_THROW(list.build(unwrapped), std::invalid_argument);
  State nan = random_state(200, 0.6, 4);
  nan.y()[0] = std::nan("");
  EXPECT_THROW(list.build(nan), IntegrationError);
}

// The image codes name n_x in {-1, 0, 1} only; the nearest image of any wrapped separation in a
// cell within kMaxBuildTilt is one of them, and beyond, the code says no image.
TEST(NeighbourList, ImageCodesStayInRange) {
  for (double t : {-0.75, -0.5, 0.0, 0.37, 0.5, 0.75}) {
    for (double sx : {-0.999, -0.5, 0.0, 0.5, 0.999}) {
      for (double sy : {-0.999, -0.51, -0.49, 0.0, 0.49, 0.51, 0.999}) {
        double dx = sx, dy = sy, dz = 0.2;
        EXPECT_LT(image_code(dx, dy, dz, t), 27u) << t << " " << sx << " " << sy;
      }
    }
  }
  double dx = 0.9, dy = 0.5, dz = 0.0;
  EXPECT_EQ(image_code(dx, dy, dz, 5.0), NeighbourList::kNoImage);
  dx = 3.0, dy = 0.0, dz = 0.0;
  EXPECT_EQ(image_code(dx, dy, dz, 0.0), NeighbourList::kNoImage);
}

}  // namespace
}  // namespace jamflow
