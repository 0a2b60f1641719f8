// Sweep files: expansion into points, stable names, the replica tasks, array shares, and the
// one-line errors for bad keys and values, found for every point before anything runs. Plans
// built in code from a scene and a grid (make_plan): the same points as the file, no Slurm.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <set>
#include <string>

#include "lib/error.hpp"
#include "sweep/engine.hpp"
#include "sweep/plan.hpp"
#include "sweep/slurm.hpp"

namespace jamflow::sweep {
namespace {

const char* const kScene = R"(
[scene.system]
N = 64
phi = 0.6
[scene.ensemble]
kind = "constant_pressure"
pressure = 1e-2
[scene.shear]
rate = 1e-2
[scene.integrator]
kind = "euler"
dt = 0.1
[scene.run]
t_eq = 10.0
t_av = 20.0
sample_every = 1.0
)";

// kScene as a scene of its own (its tables without the "scene." prefix).
Scene base_scene() {
  std::string text = kScene;
  for (std::size_t at = 0; (at = text.find("[scene.", at)) != std::string::npos;)
    text.erase(at + 1, 6);
  return Scene::parse(text, "base.toml");
}

toml::array values(std::initializer_list<double> xs) {
  toml::array a;
  for (double x : xs)
    a.push_back(x);
  return a;
}

Plan parse(const std::string& sweep) {
  return parse_plan(sweep + kScene, "test.toml", "/tmp", "/tmp/out");
}

std::string error_of(const std::string& sweep) {
  try {
    parse(sweep);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(SweepPlan, GridTimesZipInAlphabeticalKeyOrder) {
  const Plan p = parse(R"([sweep]
replicas = 2
[sweep.grid]
"shear.rate" = [1e-3, 1e-4, 1e-5]
"ensemble.pressure" = [1e-3, 1e-4]
[sweep.zip]
"system.N" = [100, 200]
"integrator.dt" = [0.2, 0.1]
)");
  ASSERT_EQ(p.points.size(), 12u);  // 2 pressures x 3 rates x 2 zipped pairs
  EXPECT_EQ(p.axes, (std::vector<std::string>{"ensemble.pressure", "shear.rate", "integrator.dt",
                                              "system.N"}));
  EXPECT_EQ(p.points.front().name, "pressure-0.001_rate-0.001_dt-0.2_N-100");
  EXPECT_EQ(p.points[1].name, "pressure-0.001_rate-0.001_dt-0.1_N-200");
  EXPECT_EQ(p.points.back().name, "pressure-1e-04_rate-1e-05_dt-0.1_N-200");
  std::set<std::string> names;
  for (const auto& pt : p.points)
    names.insert(pt.name);
  EXPECT_EQ(names.size(), p.points.size());
  // The values are in the point's scene exactly (no text round trip).
  const toml::table* shear = p.points.back().scene.table("shear");
  ASSERT_NE(shear, nullptr);
  EXPECT_EQ(shear->get("rate")->as_floating_point()->get(), 1e-5);
  EXPECT_EQ(p.points.back().n, 200);
  EXPECT_EQ(p.out_dir, "/tmp/out");
}

TEST(SweepPlan, NamesDoNotDependOnOtherAxesValues) {
  const Plan a = parse("[sweep]\n[sweep.grid]\n\"shear.rate\" = [1e-3, 1e-4]\n");
  const Plan b = parse("[sweep]\n[sweep.grid]\n\"shear.rate\" = [1e-4, 1e-2, 1e-3]\n");
  EXPECT_EQ(a.points[0].name, b.points[2].name);
  EXPECT_EQ(a.points[1].name, b.points[0].name);
}

// A point's expected cost is its integrator's measured CPU time per particle and unit time
// (Integrator::cpu_seconds_per_particle_time) x N x (t_eq + t_av), in CPU seconds: half the
// step costs twice as much; RKC costs more at a tighter tolerance and at a higher pressure.
TEST(SweepPlan, CostIsTheIntegratorsCpuTimeOverTheRun) {
  const Plan euler = parse(R"([sweep]
[sweep.zip]
"integrator.dt" = [0.2, 0.1]
)");
  ASSERT_EQ(euler.points.size(), 2u);
  // N = 64, t = 30, 5 passes per unit time at kCpuSecondsPerParticlePass (17 ns).
  EXPECT_NEAR(euler.points[0].cost, 64 * 30.0 * 5 * 17e-9, 1e-12);
  EXPECT_NEAR(euler.points[1].cost / euler.points[0].cost, 2.0, 1e-12);
  const Plan rkc = parse(R"([sweep]
[sweep.zip]
"integrator" = [{kind = "rkc", atol = 1e-4}, {kind = "rkc", atol = 1e-2},
                {kind = "rkc", atol = 1e-4}]
"ensemble.pressure" = [1e-2, 1e-2, 1e-4]
)");
  ASSERT_EQ(rkc.points.size(), 3u);
  for (const auto& pt : rkc.points)
    EXPECT_TRUE(pt.cost > 0.0 && std::isfinite(pt.cost)) << pt.name;
  EXPECT_GT(rkc.points[0].cost, rkc.points[1].cost);  // tighter atol
  EXPECT_GT(rkc.points[0].cost, rkc.points[2].cost);  // higher pressure
  // Below J = 0.1, at atol = 0.1 delta (delta = P for harmonic spheres), a slower shear costs
  // less per unit time (measured: about (J / 0.1)^0.2); at atol = delta it does not.
  const Plan slow = parse(R"([sweep]
[sweep.zip]
"integrator" = [{kind = "rkc", atol = 1e-6}, {kind = "rkc", atol = 1e-6},
                {kind = "rkc", atol = 1e-5}, {kind = "rkc", atol = 1e-5}]
"ensemble.pressure" = [1e-5, 1e-5, 1e-5, 1e-5]
"shear.rate" = [1e-6, 1e-8, 1e-6, 1e-8]
)");
  ASSERT_EQ(slow.points.size(), 4u);
  EXPECT_NEAR(slow.points[1].cost / slow.points[0].cost, std::pow(1e-2, 0.2), 1e-9);
  EXPECT_NEAR(slow.points[3].cost / slow.points[2].cost, 1.0, 1e-9);
}

TEST(SweepPlan, TasksAreReplicasWithConsecutiveSeedsLongestFirst) {
  const Plan p = parse(R"([sweep]
replicas = 3
[sweep.zip]
"system.N" = [50, 400]
)");
  const auto tasks = p.tasks();
  ASSERT_EQ(tasks.size(), 6u);
  EXPECT_EQ(p.points[tasks[0].point].n, 400);  // expected-longest first
  EXPECT_GT(tasks[0].cost, tasks[5].cost);
  EXPECT_EQ(tasks[0].seed, 1u);
  EXPECT_EQ(tasks[1].seed, 2u);
  EXPECT_EQ(tasks[2].seed, 3u);
  EXPECT_EQ(tasks[2].replica, 2);
  const Scene s = p.task_scene(tasks[1]);
  EXPECT_EQ(s.table("system")->get("seed")->as_integer()->get(), 2);
  EXPECT_EQ(s.table("run")->get("replicas")->as_integer()->get(), 1);
  EXPECT_EQ(s.table("run")->get("threads")->as_integer()->get(), 1);
  EXPECT_EQ(s.table("output")->get("file")->as_string()->get(), "r1.h5");
}

TEST(SweepPlan, ArraySharesPartitionTheTasks) {
  const Plan p = parse(R"([sweep]
replicas = 2
[sweep.grid]
"shear.rate" = [1e-2, 1e-3, 1e-4]
"system.N" = [50, 100, 400]
)");
  const auto tasks = p.tasks();
  for (int size : {1, 2, 5, 40}) {
    std::multiset<std::size_t> all;
    double most = 0.0, least = 1e300;
    for (int k = 0; k < size; ++k) {
      const auto share = array_share(tasks, k, size);
      EXPECT_EQ(share, array_share(tasks, k, size));  // the same split every time
      double load = 0.0;
      for (auto i : share) {
        all.insert(i);
        load += tasks[i].cost;
      }
      if (!share.empty()) {
        most = std::max(most, load);
        least = std::min(least, load);
      }
    }
    EXPECT_EQ(all.size(), tasks.size()) << size;
    EXPECT_EQ(std::set<std::size_t>(all.begin(), all.end()).size(), tasks.size()) << size;
    // Longest-processing-time dealing: no share exceeds another by more than the largest task.
    if (size == 2) {
      EXPECT_LE(most - least, tasks.front().cost);
    }
  }
}

TEST(SweepPlan, BadInputIsOneLineNamingThePointAndTheKey) {
  const std::string bad_value = error_of("[sweep]\n[sweep.grid]\n\"system.phi\" = [0.6, 1.5]\n");
  EXPECT_NE(bad_value.find("sweep point phi-1.5:"), std::string::npos) << bad_value;
  EXPECT_NE(bad_value.find("phi"), std::string::npos) << bad_value;
  const std::string bad_key = error_of("[sweep]\n[sweep.grid]\n\"system.phy\" = [0.6]\n");
  EXPECT_NE(bad_key.find("sweep point phy-0.6:"), std::string::npos) << bad_key;
  EXPECT_NE(bad_key.find("phy"), std::string::npos) << bad_key;
  for (const std::string& e : {bad_value, bad_key})
    EXPECT_EQ(e.find('\n'), std::string::npos) << e;
  EXPECT_NE(error_of("[sweep]\n[sweep.zip]\n\"system.N\" = [1, 2]\n\"integrator.dt\" = [0.1]\n")
                .find("allowed lists of equal length"),
            std::string::npos);
  EXPECT_NE(
      error_of("[sweep]\n[sweep.grid]\n\"output.file\" = [\"a.h5\"]\n").find("set by the sweep"),
      std::string::npos);
  EXPECT_NE(error_of("[sweep]\n[sweep.grid]\n\"shear.rate\" = []\n").find("non-empty list"),
            std::string::npos);
  EXPECT_NE(
      error_of("[sweep]\n[sweep.grid]\n\"shear.rate\" = [1e-3, 1e-3]\n").find("appears twice"),
      std::string::npos);
  EXPECT_NE(error_of("[sweep]\nreplicas = 0\n").find("[sweep] replicas = 0"), std::string::npos);
  EXPECT_NE(error_of("[sweep]\nrepilcas = 2\n").find("unknown key [sweep] repilcas"),
            std::string::npos);
  EXPECT_NE(
      error_of("[sweep]\n[sweep.grid]\n\"shear.rate\" = [1e-3]\n[sweep.zip]\n\"shear.rate\" = "
               "[1e-3]\n")
          .find("varied twice"),
      std::string::npos);
  EXPECT_THROW(parse_plan("[sweep]\n", "t.toml", "/tmp", ""), ConfigError);  // no base scene
}

TEST(SweepPlan, NamesFromChoosesTheNamingKeys) {
  const Plan p = parse(R"([sweep]
names_from = ["shear.rate"]
[sweep.zip]
"shear.rate" = [1e-3, 1e-4]
"run.t_av" = [100.0, 200.0]
)");
  EXPECT_EQ(p.points[0].name, "rate-0.001");
  EXPECT_EQ(p.points[1].name, "rate-1e-04");
  EXPECT_NE(error_of(R"([sweep]
names_from = ["shear.rate"]
[sweep.grid]
"shear.rate" = [1e-3, 1e-4]
"run.t_av" = [100.0, 200.0]
)")
                .find("both named 'rate-0.001'"),
            std::string::npos);
  EXPECT_NE(
      error_of("[sweep]\nnames_from = [\"system.N\"]\n[sweep.grid]\n\"shear.rate\" = [1e-3]\n")
          .find("allowed keys varied"),
      std::string::npos);
}

// [sweep] names: one name per point, in point order (the studies name their runs so).
TEST(SweepPlan, NamesGivesEachPointItsName) {
  const Plan p = parse(R"([sweep]
names = ["prep run", "other/run"]
[sweep.zip]
"shear.rate" = [1e-3, 1e-3]
"run.t_av" = [100.0, 200.0]
)");
  ASSERT_EQ(p.points.size(), 2u);
  EXPECT_EQ(p.points[0].name, "prep_run");  // file-name characters only
  EXPECT_EQ(p.points[1].name, "other_run");
  EXPECT_NE(error_of("[sweep]\nnames = [\"a\"]\n[sweep.zip]\n\"shear.rate\" = [1e-3, 1e-4]\n")
                .find("[sweep] names has 1 names for 2 points; allowed one name per point"),
            std::string::npos);
  EXPECT_NE(error_of("[sweep]\nnames = [\"a\", \"a\"]\n[sweep.zip]\n\"shear.rate\" = [1e-3, "
                     "1e-4]\n")
                .find("both named 'a'"),
            std::string::npos);
  EXPECT_NE(error_of("[sweep]\nnames = [\"a\"]\nnames_from = [\"shear.rate\"]\n[sweep.zip]\n"
                     "\"shear.rate\" = [1e-3]\n")
                .find("allowed one of them"),
            std::string::npos);
}

TEST(SweepPlan, AWholeSectionCanBeAnAxis) {
  const Plan p = parse(R"([sweep]
names_from = ["system.N"]
[sweep.zip]
"system.N" = [64, 128]
integrator = [{kind = "euler", dt = 0.1}, {kind = "cvode", rtol = 1e-5}]
)");
  ASSERT_EQ(p.points.size(), 2u);
  EXPECT_EQ(p.points[1].name, "N-128");
  const toml::table* in = p.points[1].scene.table("integrator");
  EXPECT_EQ(in->get("kind")->as_string()->get(), "cvode");
  EXPECT_EQ(in->get("dt"), nullptr);  // replaced whole: no dt left over from the base scene
  EXPECT_NE(error_of("[sweep]\n[sweep.grid]\nrun = [{t_av = 10.0}]\n").find("the sweep sets"),
            std::string::npos);
  EXPECT_NE(error_of("[sweep]\n[sweep.grid]\nintegrator = [1]\n").find("inline tables"),
            std::string::npos);
}

TEST(SweepPlan, NestedTablesAreKeysToo) {
  const Plan p = parse("[sweep]\n[sweep.grid.shear]\nrate = [1e-3, 1e-4]\n");
  ASSERT_EQ(p.points.size(), 2u);
  EXPECT_EQ(p.axes.front(), "shear.rate");
}

}  // namespace
}  // namespace jamflow::sweep

namespace jamflow::sweep {
namespace {

// A grid built in code is the same plan as the sweep file with that [sweep.grid]: the same axes,
// points in the same order with the same names, values, scenes and costs, and the same tasks.
TEST(SweepMakePlan, TheSamePointsAsTheEquivalentSweepFile) {
  const Plan file = parse(R"([sweep]
replicas = 2
[sweep.grid]
"shear.rate" = [1e-3, 1e-4, 1e-5]
"ensemble.pressure" = [1e-3, 1e-4]
integrator = [{kind = "euler", dt = 0.2}, {kind = "rkc", atol = 1e-3}]
)");
  Grid grid;
  grid["shear.rate"] = values({1e-3, 1e-4, 1e-5});
  grid["ensemble.pressure"] = values({1e-3, 1e-4});
  toml::array sections;
  sections.push_back(toml::table{{"kind", "euler"}, {"dt", 0.2}});
  sections.push_back(toml::table{{"kind", "rkc"}, {"atol", 1e-3}});
  grid["integrator"] = sections;
  const Plan made = make_plan(base_scene(), grid, "/tmp/out/grid.sweep", 2);
  ASSERT_EQ(file.points.size(), 12u);
  EXPECT_EQ(made.axes, file.axes);
  EXPECT_EQ(made.replicas, 2);
  ASSERT_EQ(made.points.size(), file.points.size());
  for (std::size_t i = 0; i < file.points.size(); ++i) {
    const Point &a = made.points[i], &b = file.points[i];
    EXPECT_EQ(a.index, b.index);
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.values, b.values) << a.name;
    EXPECT_EQ(a.scene.text(), b.scene.text()) << a.name;
    EXPECT_EQ(a.n, b.n) << a.name;
    EXPECT_EQ(a.cost, b.cost) << a.name;
  }
  const auto ta = made.tasks(), tb = file.tasks();
  ASSERT_EQ(ta.size(), tb.size());
  for (std::size_t i = 0; i < ta.size(); ++i) {
    EXPECT_EQ(ta[i].point, tb[i].point);
    EXPECT_EQ(ta[i].seed, tb[i].seed);
  }
  // No sweep file; named after its folder.
  EXPECT_EQ(made.path, "");
  EXPECT_EQ(made.name, "grid");
  EXPECT_EQ(made.out_dir, "/tmp/out/grid.sweep");
  // The replicas default to the scene's, as a file's do.
  EXPECT_EQ(make_plan(base_scene(), grid, "/tmp/out/x").replicas, 1);
}

TEST(SweepMakePlan, BadGridsAreTheFilesOneLineErrors) {
  auto error_of_grid = [](const Grid& grid, std::int64_t replicas = 0) -> std::string {
    try {
      make_plan(base_scene(), grid, "/tmp/out/g", replicas);
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "(no error)";
  };
  const std::string twice = error_of_grid({{"shear.rate", values({1e-3, 1e-3})}});
  EXPECT_NE(twice.find("the grid"), std::string::npos) << twice;
  EXPECT_NE(twice.find("appears twice"), std::string::npos) << twice;
  const std::string bad = error_of_grid({{"system.phi", values({0.6, 1.5})}});
  EXPECT_NE(bad.find("sweep point phi-1.5:"), std::string::npos) << bad;
  EXPECT_NE(error_of_grid({{"output.file", toml::array{"a.h5"}}}).find("set by the sweep"),
            std::string::npos);
  EXPECT_NE(error_of_grid({{"shear.rate", values({1e-3})}}, 0).find("(no error)"),
            std::string::npos);
  EXPECT_NE(error_of_grid({{"shear.rate", values({1e-3})}}, -1).find("replicas = -1"),
            std::string::npos);
  EXPECT_THROW(make_plan(base_scene(), {}, ""), ConfigError);  // nowhere to write
}

// Slurm's array tasks rerun `jamflow sweep FILE` on the nodes: a plan without a file is refused
// with one line saying so, before anything is written.
TEST(SweepMakePlan, SlurmRefusesAPlanWithoutASweepFile) {
  namespace fs = std::filesystem;
  const fs::path out = fs::temp_directory_path() / "jamflow-make-plan-slurm-never-written";
  fs::remove_all(out);
  const Plan made = make_plan(base_scene(), {{"shear.rate", values({1e-3, 1e-4})}}, out.string());
  SlurmOptions options;
  options.exe = "/bin/true";
  std::string message;
  try {
    write_slurm_script(made, options);
  } catch (const ConfigError& e) {
    message = e.what();
  }
  EXPECT_NE(message.find("no sweep file"), std::string::npos) << message;
  EXPECT_NE(message.find("Slurm"), std::string::npos) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(out));
  EXPECT_THROW(slurm_script(made, options), ConfigError);
  // The same grid from a file is accepted.
  Plan file = parse("[sweep]\n[sweep.grid]\n\"shear.rate\" = [1e-3, 1e-4]\n");
  EXPECT_NE(slurm_script(file, options).find("--array=0-1"), std::string::npos);
}

}  // namespace
}  // namespace jamflow::sweep
