// What the reports of the studies on the sweep engine share: the collected table
// (sweep/collect.cpp) read back, its verdicts, its points as HDF5, and the comparison of a
// fitted value with the seed's in sigma.
#pragma once
#include <cstddef>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "analysis/json.hpp"
#include "framework/sweep_study.hpp"
#include "lib/h5.hpp"
#include "lib/table.hpp"

namespace jamflow::studies {

// A collected table (lib/table.hpp), or an empty one if the file is absent.
Table read_table(const std::string& path);
std::string read_file(const std::string& path);

// The CPU-hours of the runs under `dir`: the CPU seconds (one thread each) of every finished
// run of every sweep below it (each `sweep.toml` with its `runs/`: every stage of a study in
// stages too); a run stopped by its budget counts, an unfinished one does not. A run file
// written before CPU time was recorded counts its wall seconds; `from_wall` (if given) is then
// the number of such runs.
double points_cpu_hours(const std::string& dir, std::size_t* from_wall = nullptr);

// A report's cost line: the points' measured CPU-hours under `dir` against the estimate, and
// this invocation's wall time.
std::string cost_line(const std::string& dir, double cpu_hours_estimate, double wall_seconds);

// The cost line of a report rebuilt from its tables alone (--report-only, the run files
// elsewhere): the tables' cpu_seconds summed (wall_seconds for tables or rows without them, and
// the line says how many), against the estimate.
std::string cost_line_from_tables(const std::vector<const Table*>& tables,
                                  double cpu_hours_estimate);

// The hours those tables record: CPU seconds summed, wall seconds where no CPU time was
// recorded; `rows` and `from_wall` (if given) count the rows summed and those given in wall
// seconds.
double tables_hours(const std::vector<const Table*>& tables, std::size_t* rows = nullptr,
                    std::size_t* from_wall = nullptr);

// The analysis JSON written by `jamflow analyze` (an empty object, with a warning on stderr,
// if it is absent or unreadable).
analysis::Json read_analysis(const std::string& study, const std::string& json_path);

// The number j[key], or `fallback` if j is no object, or the member is absent or not a number.
double number_of(const analysis::Json& j, const std::string& key,
                 double fallback = std::numeric_limits<double>::quiet_NaN());

// value and error of a {"value", "error"} member; false if absent.
bool measured(const analysis::Json& j, const std::string& key, double& v, double& e);

// The "systematic" of a {"value", "error", "systematic"} member; NaN if absent or null.
double systematic_of(const analysis::Json& j, const std::string& key);
// "v ± e", and " ± sys (systematic)" where sys is finite.
std::string with_systematic(double v, double e, double sys);

// "+1.2 sigma" (with "(disagrees)" beyond 2), or "n/a" without an error.
std::string sigma_text(double ours, double err, double seed);
// The same with a statistical error and a systematic one (NaN: none) in quadrature.
std::string sigma_text(double ours, double err, double sys, double seed);

// A row's label in a report, e.g. the integrator a point ran (studies/pressure_points.hpp
// integrator_label).
using RowLabel = std::function<std::string(const Table&, std::size_t)>;

// The "## Cost" section of a sweep study's report, measured from its collected table: CPU time
// (each replica on one thread) per integrator (`integrator_label` of each row), per particle
// force-pass equivalent and per particle and tau_0, the most expensive point, and the finished
// points against the sweep's cost-model estimate. A table collected before CPU time and
// force-pass equivalents were recorded gives wall seconds and force evaluations instead (and the
// text says so); one without cost columns gives a line saying so and `has_cost` (if given) false.
std::string sweep_cost_markdown(const Table& table, const SweepStudy& run,
                                const RowLabel& integrator_label, bool* has_cost = nullptr);

// The rows whose verdicts failed: {point, verdict, what the analysis does with it}, as
// analysis/data.cpp decides (not steady or not stable: left out; not decorrelated: kept when
// its errors include a replica scatter, from 3 replicas on, or 2 in an older table).
std::vector<std::vector<std::string>> flagged_rows(const Table& table);

// The "## Verdicts" section of a report for one table.
std::string verdicts_markdown(const Table& table, const std::string& what);

}  // namespace jamflow::studies
