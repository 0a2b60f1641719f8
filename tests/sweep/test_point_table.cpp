// The table of every point of a sweep (point_table): finished, failed and not-run points alike,
// each with its status, where collect() keeps only the finished ones.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "driver/run.hpp"
#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "sweep/collect.hpp"
#include "sweep/execute.hpp"
#include "sweep/plan.hpp"
#include "tests/sweep/temp_dir.hpp"

namespace jamflow::sweep {
namespace {
namespace fs = std::filesystem;

struct TempDir : testing_support::TempDir {
  TempDir() : testing_support::TempDir("jamflow-point-table") {}
};

// Three points of a tiny run on the shear rate.
Plan three_points(const std::string& out_dir) {
  const Scene scene = Scene::parse(R"(
[system]
N = 40
phi = 0.6
[ensemble]
kind = "constant_volume"
[shear]
rate = 1e-2
[integrator]
kind = "euler"
dt = 0.1
[run]
t_eq = 1.0
t_av = 4.0
sample_every = 1.0
blocks = 2
)",
                                   "tiny.toml");
  Grid grid;
  grid["shear.rate"] = toml::array{1e-1, 1e-2, 1e-3};
  return make_plan(scene, grid, out_dir);
}

std::size_t column(const PointTable& t, const std::string& name) {
  const auto it = std::find(t.header.begin(), t.header.end(), name);
  EXPECT_NE(it, t.header.end()) << name;
  return static_cast<std::size_t>(it - t.header.begin());
}

// Point 0 ran to the end, point 1 failed (its checkpoint says so), point 2 never ran: the
// table has all three in point order with their status, and results for point 0 only.
TEST(SweepPointTable, FailedAndNotRunPointsAreRowsWithTheirStatus) {
  TempDir dir;
  const Plan plan = three_points(dir.path.string());
  prepare_out_dir(plan);
  const auto tasks = plan.tasks();
  auto task_of = [&](std::size_t point) {
    return *std::find_if(tasks.begin(), tasks.end(),
                         [&](const Task& t) { return t.point == point; });
  };
  {
    Scene s = plan.task_scene(task_of(0));
    s.set_value("output.file", toml::value<std::string>(plan.task_file(task_of(0))));
    RunOptions quiet;
    quiet.quiet = true;
    ASSERT_EQ(run_replicas(parse_run_spec(s), quiet).code, 0);
  }
  const RunStatus failed = RunStatus::failed("at t = 2: the step size underflowed");
  {
    H5Writer w(plan.task_file(task_of(1)) + ".part");
    w.attr("/", "status", failed.text());
    w.commit();
  }
  const PointTable t = point_table(plan);
  ASSERT_EQ(t.rows.size(), 3u);
  ASSERT_EQ(t.status.size(), 3u);
  EXPECT_EQ(t.header.back(), "status");
  const std::size_t point = column(t, "point"), status = column(t, "status"),
                    eta = column(t, "eta"), rate = column(t, "shear_rate"),
                    replicas = column(t, "replicas");
  // The varied key shear.rate is the column shear_rate, once: one name for one quantity.
  EXPECT_EQ(std::count(t.header.begin(), t.header.end(), "shear.rate"), 0);
  for (std::size_t i = 0; i < 3; ++i) {
    ASSERT_EQ(t.rows[i].size(), t.header.size());
    EXPECT_EQ(t.rows[i][point], plan.points[i].name);
    ASSERT_EQ(plan.points[i].values.front().first, "shear.rate");
    // The scene's cells, finished or not.
    EXPECT_EQ(std::strtod(t.rows[i][rate].c_str(), nullptr),
              std::strtod(plan.points[i].values.front().second.c_str(), nullptr));
  }
  EXPECT_EQ(t.status[0], RunStatus::complete());
  EXPECT_EQ(t.rows[0][status], "complete");
  EXPECT_TRUE(std::isfinite(std::strtod(t.rows[0][eta].c_str(), nullptr))) << t.rows[0][eta];
  EXPECT_EQ(t.rows[0][replicas], "1");
  EXPECT_EQ(t.status[1], failed);
  EXPECT_EQ(t.rows[1][status], "failed at t = 2: the step size underflowed");
  EXPECT_EQ(t.status[2].kind, RunStatus::Kind::kNotRun);
  EXPECT_EQ(t.rows[2][status], "not run");
  for (std::size_t i : {1u, 2u}) {
    EXPECT_EQ(t.rows[i][eta], "") << i;
    EXPECT_EQ(t.rows[i][replicas], "") << i;
  }
  EXPECT_EQ(t.left_out.size(), 2u);
  // collect() keeps its table as it was: the finished point only, and no status column.
  const std::string csv = (dir.path / "table.csv").string();
  const Collected c = collect(plan, csv);
  EXPECT_EQ(c.rows, 1u);
  EXPECT_EQ(c.left_out, t.left_out);
  std::ifstream in(csv);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header.find("status"), std::string::npos) << header;
  std::vector<std::string> expected = t.header;
  expected.pop_back();
  std::string joined;
  for (const auto& h : expected)
    joined.append(joined.empty() ? "" : ",").append(h);
  EXPECT_EQ(header, joined);
}

// `jamflow sweep --collect table.h5`: every column of the CSV table is a dataset under /table,
// text columns (point, ensemble, folder) as strings, numbers as the CSV's values bit for bit
// (NaN where the CSV is empty), in the order of the attribute "columns".
TEST(SweepPointTable, CollectedHdf5TableHasEveryColumnAsADataset) {
  TempDir dir;
  const Plan plan = three_points(dir.path.string());
  prepare_out_dir(plan);
  RunOptions quiet;
  quiet.quiet = true;
  for (const Task& task : plan.tasks()) {
    Scene s = plan.task_scene(task);
    s.set_value("output.file", toml::value<std::string>(plan.task_file(task)));
    ASSERT_EQ(run_replicas(parse_run_spec(s), quiet).code, 0);
  }
  const std::string csv = (dir.path / "table.csv").string();
  const std::string h5 = (dir.path / "table.h5").string();
  ASSERT_EQ(collect(plan, csv).rows, 3u);
  ASSERT_EQ(collect(plan, h5).rows, 3u);
  const auto split = [](const std::string& line) {
    std::vector<std::string> cells;
    std::stringstream in(line);
    std::string cell;
    while (std::getline(in, cell, ','))
      cells.push_back(cell);
    if (!line.empty() && line.back() == ',')
      cells.emplace_back();
    return cells;
  };
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  const std::vector<std::string> header = split(line);
  std::vector<std::vector<std::string>> rows;
  while (std::getline(in, line))
    rows.push_back(split(line));
  ASSERT_EQ(rows.size(), 3u);

  const H5Reader r(h5);
  EXPECT_EQ(r.attr_strings("/table", "columns"), header);
  EXPECT_EQ(r.attr_int("/table", "rows"), 3);
  std::vector<std::string> text;
  for (std::size_t c = 0; c < header.size(); ++c) {
    const std::string path = "/table/" + header[c];
    ASSERT_TRUE(r.exists(path)) << header[c];
    EXPECT_EQ(r.dims(path), (std::vector<std::size_t>{3})) << header[c];
    std::vector<std::string> expected;
    for (const auto& row : rows)
      expected.push_back(row.at(c));
    std::vector<double> numbers;
    try {
      numbers = r.read_doubles(path);
    } catch (const IoError&) {
      text.push_back(header[c]);
      EXPECT_EQ(r.read_strings(path), expected) << header[c];
      continue;
    }
    for (std::size_t i = 0; i < 3; ++i) {
      if (expected[i].empty()) {
        EXPECT_TRUE(std::isnan(numbers[i])) << header[c] << " row " << i;
      } else {
        EXPECT_EQ(numbers[i], std::strtod(expected[i].c_str(), nullptr))
            << header[c] << " row " << i;
      }
    }
  }
  EXPECT_EQ(text, (std::vector<std::string>{"point", "ensemble", "folder"}));
  EXPECT_EQ(r.children("/table").size(), header.size());
}

}  // namespace
}  // namespace jamflow::sweep
