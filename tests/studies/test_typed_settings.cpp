// Studies hand typed integrator settings to the driver: a step of dt = 0.1 / 3 is run at exactly
// that double (not at a 6-digit print of it), and sample_every is a whole number of those steps.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <optional>
#include <string>

#include "lib/error.hpp"
#include "studies/diagnostics.hpp"
#include "sweep/plan.hpp"

namespace jamflow::studies {
namespace {

TEST(StudyTypedSettings, EulerAtOneThirdOfAPointOneRunsAtExactlyThatStep) {
  const double dt = 0.1 / 3.0;
  StatePoint p;
  p.name = "typed";
  p.n = 100;
  p.constant_pressure = false;
  p.phi = 0.6;
  p.gdot = 1e-3;
  const IntegratorSetting setting = euler_setting(dt);
  // The label's step and the typed settings the driver receives are the same double.
  ASSERT_EQ(setting.settings.kind, "euler");
  EXPECT_EQ(setting.settings.number("dt"), std::optional<double>(dt));
  EXPECT_EQ(setting.dt(), dt);
  EXPECT_EQ(setting.family(), "euler");
  const StudyScene scene = scene_toml(p, setting, 0.0, 10.0, 0.5);
  ASSERT_TRUE(scene.integrator.has_value());
  const RunSpec spec = scene.spec({"run.threads=1"});

  // The run's step is the study's double.
  EXPECT_EQ(spec.integrator.number("dt"), dt);
  EXPECT_EQ(spec.make_integrator()->nominal_dt(), dt);
  // sample_every is commensurate with that same double: 15 steps of dt, exactly.
  const double steps_per_sample = std::round(spec.sample_every / dt);
  EXPECT_EQ(steps_per_sample, 15.0);
  EXPECT_EQ(spec.sample_every, steps_per_sample * dt);
  EXPECT_EQ(spec.sample_every, commensurate(0.5, dt));

  // The stored scene describes the run exactly: dt and sample_every round-trip bit for bit.
  const Scene stored = Scene::parse(spec.scene_text, "stored");
  ConfigSection integ = stored.section("integrator");
  EXPECT_EQ(integ.number("dt", Range::positive()), dt);
  ConfigSection run = stored.section("run");
  EXPECT_EQ(run.number("sample_every", Range::positive()), spec.sample_every);
  EXPECT_EQ(parse_run_spec(stored).integrator, spec.integrator);

  // No step is shortened to land on a sample: exactly 15 Euler steps per sample interval (a
  // step printed as 0.0333333 would need a 16th, tiny step every sample).
  RunOptions o;
  o.quiet = true;
  const ReplicaResult r = run_replica(spec, 1, o);
  ASSERT_TRUE(r.status.is_complete()) << r.status.text();
  const double samples = std::round((spec.t_eq + spec.t_av) / spec.sample_every);
  double steps = -1.0;
  for (const auto& [k, v] : r.integrator_stats)
    if (k == "steps")
      steps = v;
  EXPECT_EQ(steps, samples * steps_per_sample);
}

// Every typed value of a setting reaches the run's integrator (RESPA: a double, an integer and
// two strings), and a key no integrator has is refused with the same one-line error a scene's
// [integrator] section gets, naming the key.
TEST(StudyTypedSettings, RespaValuesArriveAndAWrongKeyIsRefused) {
  StatePoint p;
  p.n = 100;
  p.constant_pressure = false;
  p.phi = 0.6;
  p.gdot = 1e-3;
  const double dt = 0.7 / 3.0;
  const IntegratorSetting respa = respa_setting(dt, 3, "piston", "heun");
  const RunSpec spec = scene_toml(p, respa, 0.0, 10.0, 0.5).spec();
  EXPECT_EQ(spec.integrator.kind, "respa");
  EXPECT_EQ(spec.integrator.number("dt"), std::optional<double>(dt));
  EXPECT_EQ(spec.integrator.number("n_inner"), std::optional<double>(3.0));
  using Value = IntegratorSettings::Value;
  EXPECT_EQ(spec.integrator.values.at("inner"), Value(std::string("piston")));
  EXPECT_EQ(spec.integrator.values.at("inner_scheme"), Value(std::string("heun")));
  EXPECT_EQ(spec.make_integrator()->nominal_dt(), dt);
  // The stored scene carries them too, so a rerun from the run file builds the same integrator.
  EXPECT_EQ(parse_run_spec(Scene::parse(spec.scene_text, "stored")).integrator, spec.integrator);

  IntegratorSetting typo = euler_setting(0.05);
  typo.settings.set("dtt", 0.1);
  try {
    (void)scene_toml(p, typo, 0.0, 10.0, 0.5).spec();
    ADD_FAILURE() << "an unknown [integrator] key was accepted";
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("[integrator] dtt"), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

// Through a stage's sweep file (the points of the studies run as `jamflow run` processes) the
// step is still that double, and the request's seed, start and budget reach the point's scene.
TEST(StudyTypedSettings, StageSweepKeepsTheExactStepSeedAndBudget) {
  StatePoint p;
  p.n = 100;
  p.constant_pressure = false;
  p.phi = 0.6;
  p.gdot = 1e-3;
  const double dt = 0.1 / 3.0;
  RunRequest r;
  r.label = "phi=0.6 euler dt=0.0333";
  r.scene = scene_toml(p, euler_setting(dt), 0.0, 10.0, 0.5);
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
  EXPECT_EQ(spec.sample_every, commensurate(0.5, dt));
  EXPECT_EQ(spec.max_force_evaluations, 1234);
  EXPECT_FALSE(std::filesystem::exists(o.out_dir + "/only/runs/points"));
  std::filesystem::remove_all(o.out_dir);
}

}  // namespace
}  // namespace jamflow::studies
