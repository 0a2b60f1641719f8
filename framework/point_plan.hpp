// A sweep study's plan: its state points as typed run requests (state point, integrator,
// lengths), and the one place that turns them into a sweep file (sweep/plan.hpp), so that the
// grids of every study (pressure_points, volume_points) are run, resumed and read back alike.
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "integrators/registry.hpp"

namespace jamflow::studies {

struct PlannedPoint {
  std::int64_t n = 0;
  double phi = 0.0;  // the start's packing fraction (constant pressure) or the state's
  std::optional<double> pressure;  // the imposed pressure; none: constant volume
  double shear_rate = 0.0;
  double t_eq = 0.0, t_av = 0.0, sample_every = 0.0;
  IntegratorSettings integrator;
};

struct PointPlan {
  std::string header;  // the file's comment: whose points, and why
  int replicas = 1;
  double base_phi = 0.6;  // the base scene's phi (every point sets its own)
  bool constant_pressure = true;
  std::vector<PlannedPoint> points;
};

// The sweep file: a base scene and a zip over every point's N, phi, pressure (constant pressure),
// shear rate, lengths and integrator, points named by N, the pressure (or phi) and the rate.
std::string sweep_text(const PointPlan& plan);

// Three significant digits, as the double nearest to that decimal (9e-05, not
// 8.999999999999999e-05): run lengths and rates that read well in names and files.
double round3(double x);

}  // namespace jamflow::studies
