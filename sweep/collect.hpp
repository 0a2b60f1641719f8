// Gathering a sweep's finished points into one table, one row per point (its replicas
// combined), in the CSV form that `jamflow analyze` reads as it is.
#pragma once
#include <string>
#include <vector>

#include "driver/run_status.hpp"
#include "sweep/plan.hpp"

namespace jamflow::sweep {

struct Collected {
  std::size_t rows = 0;
  std::vector<std::string> left_out;  // points not finished in every replica, with why
};

// Columns: point, one per varied key (but shear.rate and ensemble.pressure, which are the
// columns shear_rate and imposed_pressure), ensemble, N, imposed_pressure (only when every row
// is at constant pressure, so that analyze reads the table as granular data), shear_rate, phi,
// pressure, sigma_xy, eta, mu (each with _err), J, energy_balance, replicas, steady, stable,
// decorrelated (1 pass, 0 fail, empty not checked), the cost summed over the replicas:
// wall_seconds, cpu_seconds (the runs' CPU time; cpu_from_wall = 1 when a run file written before
// CPU time was recorded gave its wall seconds instead), force_evaluations and
// force_pass_equivalents (Integrator::force_pass_equivalents: CVODE's Jacobian work included;
// an older file's force evaluations), folder. With several replicas each _err is
// the larger of the block error propagated to the mean and the replica scatter error
// (std / sqrt(R)): the block error alone is too small when blocks are short (README).
// `path` ends in .csv, or in .h5 for the same table as HDF5: every column a dataset
// /table/<column> (numbers as float64, NaN where empty; text as UTF-8 strings), the column
// order in the string-array attribute "columns" of /table. Written atomically.
Collected collect(const Plan& plan, const std::string& path);

// Every point of the sweep, one row per point in point order, whether it finished or not: the
// columns of collect() and last `status`, the point's RunStatus text: "complete", or that of
// its first replica that is not ("failed at t = ...: why", "not run", "interrupted at t = ...",
// "budget: stopped at t = ..."). A point that is not complete has the cells its scene gives
// (point, the varied keys, ensemble, N, imposed_pressure, shear_rate, folder) and empty ones for
// every result.
struct PointTable {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;  // cells as text, "" where there is no value
  std::vector<RunStatus> status;               // per row, typed
  std::vector<std::string> left_out;           // as Collected::left_out
};
PointTable point_table(const Plan& plan);

}  // namespace jamflow::sweep
