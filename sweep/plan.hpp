// A sweep: a base scene plus the axes to vary, expanded into named points, each run as one or
// more replicas (tasks). Every point is validated before anything runs.
//
//   [sweep]
//   scene = "base.toml"          # relative to the sweep file; or an inline [scene] table
//   replicas = 3                 # seeds seed, seed+1, ... (default: the scene's [run] replicas)
//   [sweep.grid]                 # Cartesian product; any scene key
//   "ensemble.pressure" = [1e-3, 1e-4]
//   [sweep.zip]                  # lists varied together (equal lengths), one more grid axis
//   "system.N" = [500, 1000]
//   "integrator.dt" = [0.2, 0.1]
//   # names_from = ["ensemble.pressure", "shear.rate"]   optional: the keys that name points
//   # names = ["a", "b"]   optional instead: one name per point, in point order
//
// Keys are taken in alphabetical order (TOML tables are unordered): the grid's first key varies
// slowest, the zip comes last, and a point's name lists its values in that order.
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "lib/config.hpp"

namespace jamflow::sweep {

// One state point: the base scene with this point's values.
struct Point {
  std::size_t index = 0;  // position in grid order
  // Stable name from the varied keys and values, e.g. "pressure-0.001_rate-0.0001": it does not
  // depend on the order of points or on other axes' values, so reruns find their files.
  std::string name;
  std::vector<std::pair<std::string, std::string>> values;  // varied key -> value as TOML text
  Scene scene;  // base + values; output file, seed, threads and replicas are set per task
  std::int64_t n = 0;
  double cost = 0.0;  // expected CPU seconds of one replica (see plan.cpp)
};

// One replica of one point: what a worker runs.
struct Task {
  std::size_t point = 0;
  std::int64_t replica = 0;
  std::uint64_t seed = 0;
  double cost = 0.0;
};

struct Plan {
  std::string path;     // the sweep file; empty for a plan built in code (make_plan)
  std::string name;     // its stem (make_plan: the output folder's name without .sweep)
  std::string out_dir;  // where points/ and the manifest go
  std::int64_t replicas = 1;
  std::vector<std::string> axes;  // varied keys, in the order of the names
  std::vector<Point> points;
  // Every replica of every point, expected-longest first (ties: grid order, then replica).
  std::vector<Task> tasks() const;

  // Files of a task, relative to nothing (out_dir is already part of them).
  std::string point_dir(const Point& p) const;
  static std::string task_stem(const Task& t);   // r<k>
  std::string task_file(const Task& t) const;    // <point_dir>/r<k>.h5
  std::string task_log(const Task& t) const;     // <point_dir>/r<k>.log
  std::string scene_file(const Point& p) const;  // <point_dir>/scene.toml
  // The scene of a task: the point's scene with its output file (r<k>.h5, relative to the
  // point's folder, where the task runs), seed, one replica and one thread.
  Scene task_scene(const Task& t) const;
};

// Reads and validates a sweep file. Every point's scene goes through the same checks as
// `jamflow run` (parse_run_spec), so a bad key or value anywhere is a ConfigError naming the
// point and the key before anything runs. out_dir: empty for the default <sweep dir>/<stem>.sweep.
Plan load_plan(const std::string& path, const std::string& out_dir = {});
// The same from text (tests); `base_dir` resolves a relative scene path.
Plan parse_plan(const std::string& text, const std::string& source, const std::string& base_dir,
                const std::string& out_dir);

// The axes of a plan built in code: scene key -> values, as [sweep.grid] holds them ("section.key"
// -> numbers, strings or booleans; "section" -> inline tables, each a whole section). Keys are
// taken in alphabetical order, as a file's.
using Grid = std::map<std::string, toml::array>;

// A plan from a scene and a grid, without a sweep file: expanded, named and checked as
// parse_plan does a [sweep.grid] of the same axes (the same points, names and errors, which
// name "the grid"). It has no path, so its manifest names no file and Slurm, which reruns the
// sweep file on the nodes, refuses it. `out_dir` is required; the plan's name is its last part
// without ".sweep". `replicas`: 0 for the scene's [run] replicas, else in [1, 10000]. A relative
// system.init, in the scene or among the values, is taken relative to the current folder.
Plan make_plan(const Scene& scene, const Grid& grid, const std::string& out_dir,
               std::int64_t replicas = 0);

// A base scene named by a file key (`file_key`: a path relative to `dir`) or given as an inline
// table, as sweep and compare files name theirs; a relative `system.init` in it is made
// absolute against the folder of the scene that names it. Errors name `source` and the key.
Scene load_base_scene(const toml::node* file_key, const toml::table* inline_scene,
                      const std::string& dir, const std::string& source,
                      const std::string& file_key_name, const std::string& inline_name,
                      const std::string& relative_to);

// Share of the tasks for one task of a job array of `size` (Slurm): tasks are dealt
// expected-longest first to the share with the least expected work so far. Deterministic, so
// every array task computes the same split. Returns indices into plan.tasks().
std::vector<std::size_t> array_share(const std::vector<Task>& tasks, int task_id, int size);

}  // namespace jamflow::sweep
