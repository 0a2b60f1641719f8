// The sweep's bookkeeping (Coordinator): what it writes per task does not grow with the sweep,
// its manifest shows the work another sweep process finished on the same folder, and names the
// sweep file only when there is one.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "lib/h5.hpp"
#include "sweep/execute.hpp"
#include "sweep/plan.hpp"
#include "tests/sweep/temp_dir.hpp"

namespace jamflow::sweep {
namespace {
namespace fs = std::filesystem;

struct TempDir : testing_support::TempDir {
  TempDir() : testing_support::TempDir("jamflow-bookkeeping") {}
};

// A sweep of `points` points (one replica each) on the shear rate.
Plan plan_of(int points, const std::string& out_dir) {
  std::ostringstream s;
  s << "[sweep]\n[sweep.grid]\n\"shear.rate\" = [";
  for (int i = 0; i < points; ++i)
    s << (i ? ", " : "") << 1e-3 * (1.0 + i);
  s << R"(]
[scene.system]
N = 64
phi = 0.6
[scene.ensemble]
kind = "constant_volume"
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
  return parse_plan(s.str(), "sizes.toml", "/tmp", out_dir);
}

// Runs the whole plan through the bookkeeping, every task ending done, as run_local does
// (a manifest at the start and at the end), and returns what it wrote.
Coordinator::Writes bookkeeping_of(const Plan& plan) {
  prepare_out_dir(plan);
  Coordinator co(plan, {}, 2, true);
  co.write_manifest();
  while (const auto t = co.take()) {
    co.started(*t);
    co.finished(*t, TaskState::kDone, 0.01, "");
  }
  co.write_manifest();
  EXPECT_EQ(co.remaining(), 0);
  return co.writes();
}

TEST(SweepBookkeeping, WritesPerTaskDoNotGrowWithTheSweep) {
  TempDir small_dir, large_dir;
  const Plan small = plan_of(40, small_dir.path.string());
  const Plan large = plan_of(320, large_dir.path.string());
  const auto ws = bookkeeping_of(small);
  const auto wl = bookkeeping_of(large);
  // Two journal lines per task (started, done), whatever the size.
  EXPECT_EQ(ws.journal_lines, 2 * small.points.size());
  EXPECT_EQ(wl.journal_lines, 2 * large.points.size());
  // The manifest (a line per point) is rewritten a bounded number of times: at the start, after
  // each eighth of the tasks and at the end. Rewriting it after every task would be 41 and 321.
  EXPECT_LE(ws.manifests, 10u);
  EXPECT_LE(wl.manifests, 10u);
  // So the bytes per task stay put at 8 times the size (the manifest's size per point varies
  // with the length of the names and values; 1.5 leaves room for that, while a cost growing
  // with the sweep would give 8).
  const double per_small = double(ws.bytes) / double(small.points.size());
  const double per_large = double(wl.bytes) / double(large.points.size());
  EXPECT_LT(per_large, 1.5 * per_small) << per_small << " vs " << per_large << " bytes per task";
  EXPECT_GT(per_large, 0.0);
  // The journal holds each event.
  std::ifstream in(large_dir.path / "journal.log");
  std::string line;
  std::size_t lines = 0;
  while (std::getline(in, line))
    ++lines;
  EXPECT_EQ(lines, wl.journal_lines);
}

std::string read_all(const fs::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Two sweep processes on one folder: the one that ends last writes a manifest in which the
// tasks the other finished are done, not "running elsewhere".
TEST(SweepBookkeeping, ManifestShowsTasksFinishedByAnotherProcess) {
  TempDir dir;
  const Plan plan = plan_of(3, dir.path.string());
  prepare_out_dir(plan);
  Coordinator co(plan, {}, 1, true);
  co.write_manifest();
  const auto first = co.take();
  ASSERT_TRUE(first);
  // The other process holds this task's lock: it is reported as running elsewhere ...
  co.finished(*first, TaskState::kBusyElsewhere, 0.0, "locked by another sweep process");
  // ... and finishes it: a complete run file appears.
  {
    H5Writer w(plan.task_file(co.tasks()[*first]));
    w.attr("/", "status", "complete");
    w.commit();
  }
  while (const auto t = co.take()) {
    co.started(*t);
    co.finished(*t, TaskState::kDone, 0.01, "");
  }
  co.write_manifest();
  const std::string manifest = read_all(dir.path / "manifest.toml");
  EXPECT_EQ(manifest.find("running elsewhere"), std::string::npos) << manifest;
  // Every point's state is done.
  std::size_t done = 0;
  for (std::size_t at = 0; (at = manifest.find("state = 'done'", at)) != std::string::npos; ++at)
    ++done;
  EXPECT_EQ(done, 3u) << manifest;
}

// A plan built in code (make_plan) has no sweep file: its manifest has no `file` entry, where a
// file's plan names its file.
TEST(SweepBookkeeping, ManifestNamesNoFileForAPlanBuiltInCode) {
  TempDir made_dir, file_dir;
  const Plan file = plan_of(2, file_dir.path.string());
  Grid grid;
  grid["shear.rate"] = toml::array{1e-3, 2e-3};
  Scene scene = file.points.front().scene;
  const Plan made = make_plan(scene, grid, made_dir.path.string());
  for (const Plan* plan : {&made, &file}) {
    prepare_out_dir(*plan);
    Coordinator co(*plan, {}, 1, true);
    co.write_manifest();
  }
  const toml::table m = toml::parse(read_all(made_dir.path / "manifest.toml"));
  const toml::table f = toml::parse(read_all(file_dir.path / "manifest.toml"));
  ASSERT_NE(m["sweep"].as_table(), nullptr);
  EXPECT_EQ(m["sweep"]["file"].node(), nullptr);
  EXPECT_EQ(m["sweep"]["points"].value<std::int64_t>(), 2);
  ASSERT_NE(m["point"].as_array(), nullptr);
  EXPECT_EQ(m["point"].as_array()->size(), 2u);
  EXPECT_EQ(f["sweep"]["file"].value<std::string>(), fs::absolute("sizes.toml").string());
}

}  // namespace
}  // namespace jamflow::sweep
