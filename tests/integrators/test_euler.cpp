// Euler: analytic two-sphere relaxation and measured convergence order.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "ensembles/constant_volume.hpp"
#include "integrators/euler.hpp"
#include "lib/init.hpp"
#include "lib/model.hpp"
#include "tests/two_spheres.hpp"

namespace jamflow {
namespace {

using fixtures::two_spheres;  // tests/two_spheres.hpp

double overlap_after(double dt, double t_end, double shear_rate) {
  Model m(two_spheres(0.8), ModelOptions{2.0, 0.3, 1, 0});
  ConstantVolume ens(shear_rate);
  Euler euler(dt);
  euler.advance(m, ens, t_end);
  const Eigen::Vector3d d = m.state().real(1) - m.state().real(0);
  return 1.0 - d.norm();
}

TEST(Euler, TwoSpheresRelaxExponentially) {
  // Same y: the shear flow does not separate them, so shear must not matter either.
  for (double gdot : {0.0, 1e-2}) {
    const double exact = 0.2 * std::exp(-2.0 * 1.0);
    // Euler gives (1 - 2 dt)^(t/dt): relative error lambda^2 dt t / 2 = 2e-4 at dt = 1e-4, so
    // 5e-4 bounds the discretisation error while any wrong rate (e.g. exp(-t)) fails by 60%.
    EXPECT_NEAR(overlap_after(1e-4, 1.0, gdot), exact, 5e-4 * exact) << "gdot " << gdot;
    // And the leading error term itself: (1 - 2dt)^(1/dt) = e^-2 (1 - 2 dt + O(dt^2)).
    const double predicted = exact * (1.0 - 2.0 * 1e-3);
    EXPECT_NEAR(overlap_after(1e-3, 1.0, gdot), predicted, 1e-5 * exact) << "gdot " << gdot;
  }
}

TEST(Euler, ConvergenceOrderIsOne) {
  const double exact = 0.2 * std::exp(-2.0);
  std::vector<double> err;
  for (double dt : {0.02, 0.01, 0.005, 0.0025}) {
    err.push_back(std::abs(overlap_after(dt, 1.0, 0.0) - exact));
  }
  for (std::size_t k = 1; k < err.size(); ++k) {
    const double order = std::log2(err[k - 1] / err[k]);
    EXPECT_NEAR(order, 1.0, 0.05) << "refinement " << k;
  }
}

TEST(Euler, LandsExactlyOnRequestedTime) {
  Model m(two_spheres(0.9), ModelOptions{2.0, 0.3, 1, 0});
  ConstantVolume ens(1e-3);
  Euler euler(0.3);
  euler.advance(m, ens, 1.0);  // 3 steps of 0.3 and one of 0.1
  EXPECT_DOUBLE_EQ(m.state().time, 1.0);
  EXPECT_NEAR(m.state().box.strain, 1e-3, 1e-15);
}

// At constant volume Euler asks the force backend for its pass with the drift (the simd
// backend fuses it; the others compute and then drift). It must give the same bits as the plain
// sequence: evaluate the forces, move the cell, drift with those forces. The run (strain 0.6 at
// a high rate, from a random, overlapping start) goes through inner-list re-selections and full
// rebuilds, where the pass stops and is repeated, and through a Lees–Edwards remap; on one to
// three threads, with both list-based backends.
TEST(Euler, DriftInTheForcePassGivesTheSameBitsAsSeparateSteps) {
  const double dt = 0.1, gdot = 6e-3, t_end = 100.0;
  for (const char* kernel : {"simd", "portable"}) {
    for (int threads : {1, 2, 3}) {
      const State start = random_state(400, 0.64, 11);
      const ModelOptions options{2.0, 0.3, threads, 20, kernel};
      Model fused(start, options);
      ConstantVolume ens(gdot);
      Euler euler(dt);
      euler.advance(fused, ens, t_end);

      Model plain(start, options);
      while (plain.state().time < t_end) {  // Euler::advance's steps, the last landing on t_end
        plain.prepare_step();
        const double t = plain.state().time;
        const double h = t_end - t <= dt * (1.0 + 1e-9) ? t_end - t : dt;
        const Evaluation& ev = plain.evaluate();
        plain.modify([&](State& s) {
          move_cell(s, gdot * h, s.box.volume());
          drift_particles(s, ev.forces.force, h, threads);
        });
        plain.set_time(h == dt ? t + h : t_end);
      }
      const std::string where = std::string(kernel) + ", " + std::to_string(threads) + " thread(s)";
      ASSERT_GT(fused.neighbour_list().inner_builds(), fused.list_builds() + 5) << where;
      ASSERT_GT(fused.list_builds(), 2u) << where;
      EXPECT_EQ(fused.state().box.flips, plain.state().box.flips) << where;
      EXPECT_NE(fused.state().box.flips, 0) << where;  // the run went through a remap
      EXPECT_EQ(fused.state().box.strain, plain.state().box.strain) << where;
      EXPECT_EQ(fused.state().pos, plain.state().pos) << where;
      EXPECT_EQ(fused.state().image, plain.state().image) << where;
      EXPECT_EQ(fused.state().id, plain.state().id) << where;
      // The simd backend lays out the next pass's rows in its drift; 1000 steps, and the passes
      // after a list renewal, remap or sort lay them out afresh. Plain steps never reuse them.
      if (std::string(kernel) == "simd") {
        EXPECT_GT(fused.force_field().prepared_passes(), 800u) << where;
      }
      EXPECT_EQ(plain.force_field().prepared_passes(), 0u) << where;
    }
  }
}

// Rows laid out ahead belong to one state: a change through modify() between two fused passes
// (here one particle nudged) must make the next pass lay its rows out afresh, so that its forces
// are those of the changed state. Checked against a fresh model of the same state, whose own
// list build wraps the positions, so the two agree to round-off (1e-12), not bit for bit; stale
// rows would be off by the nudge, about 1e-4.
TEST(Euler, RowsLaidOutAheadAreNotUsedForAChangedState) {
  const double dt = 0.1, gdot = 6e-3;
  const State start = random_state(400, 0.64, 5);
  const ModelOptions options{2.0, 0.3, 1, 20, "simd"};
  Model fused(start, options);
  ConstantVolume ens(gdot);
  for (int step = 0; step < 300; ++step) {
    fused.prepare_step();
    Model plain(fused.state(), ModelOptions{2.0, 0.3, 1, 0, "simd"});
    const Evaluation ref = plain.evaluate();
    Box next = fused.state().box;
    next.strain += gdot * dt;
    const Evaluation& ev = fused.evaluate_and_drift(Drift::of(next.h_inv(), dt / kXiS), next);
    for (std::size_t k = 0; k < ref.forces.force.size(); ++k)
      ASSERT_NEAR(ev.forces.force[k], ref.forces.force[k], 1e-12) << "step " << step;
    ASSERT_NEAR(ev.forces.energy, ref.forces.energy, 1e-12 * ref.forces.energy) << step;
    fused.set_time(fused.state().time + dt);
    if (step % 50 == 25)  // a change from outside
      fused.modify([](State& s) { s.x()[7] += 1e-4; });
  }
  EXPECT_GT(fused.force_field().prepared_passes(), 200u);
}

}  // namespace
}  // namespace jamflow
