// A stage's sweep file (the points of the studies run as `jamflow run` processes) keeps what
// the request says: the step at the very double of the scene's text (dt = 0.1 / 3, printed at
// round-trip precision), and the request's seed and budget in the point's scene.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "framework/stage.hpp"
#include "sweep/plan.hpp"

namespace jamflow::studies {
namespace {

TEST(StageSweep, KeepsTheExactStepSeedAndBudget) {
  const double dt = 0.1 / 3.0;
  char step[64];
  std::snprintf(step, sizeof step, "%.17g", dt);
  RunRequest r;
  r.label = "phi=0.6 euler dt=0.0333";
  r.scene = std::string(
                "[system]\nN = 100\nphi = 0.6\n[ensemble]\nkind = \"constant_volume\"\n"
                "[shear]\nrate = 1e-3\n[integrator]\nkind = \"euler\"\ndt = ") +
            step + "\n[run]\nt_eq = 0.0\nt_av = 10.0\nsample_every = 0.5\n";
  r.seed = 7;
  r.budget = 1234;
  StudyOptions o;
  o.out_dir = ::testing::TempDir() + "jamflow_stage_sweep";
  std::filesystem::remove_all(o.out_dir);
  o.quiet = true;
  o.dry_run = true;  // writes the sweep file, counts, runs nothing
  std::vector<DiagnosedRun> out;
  ASSERT_EQ(run_stage("test", "only", {r}, o, out, true), 0);
  const sweep::Plan plan = sweep::load_plan(o.out_dir + "/only/sweep.toml");
  ASSERT_EQ(plan.points.size(), 1u);
  EXPECT_EQ(plan.points[0].name, "phi_0.6_euler_dt_0.0333");
  const auto tasks = plan.tasks();
  ASSERT_EQ(tasks.size(), 1u);
  EXPECT_EQ(tasks[0].seed, 7u);
  const RunSpec spec = parse_run_spec(plan.task_scene(tasks[0]));
  EXPECT_EQ(spec.integrator.number("dt"), dt);
  EXPECT_EQ(spec.make_integrator()->nominal_dt(), dt);
  EXPECT_EQ(spec.max_force_evaluations, 1234);
  EXPECT_FALSE(std::filesystem::exists(o.out_dir + "/only/runs/points"));
  std::filesystem::remove_all(o.out_dir);
}

}  // namespace
}  // namespace jamflow::studies
