// The hard-sphere study's state points: constant pressure, a grid of pressures P and viscous
// numbers J = gdot xi_s / P for each N, as a sweep (sweep/): the points of a preset are written
// as a sweep file, so they run on local cores, MPI ranks or a Slurm array like any sweep, and
// a rerun finds the finished ones. The finite-size study uses the same points over more sizes.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <toml++/toml.h>

#include "integrators/registry.hpp"
#include "lib/table.hpp"

namespace jamflow::studies {

struct GridPreset {
  std::string name;
  std::string study = "hard-sphere";  // names the sweep file's header
  std::vector<std::int64_t> sizes;
  std::vector<double> pressures;
  std::vector<double> js;  // viscous numbers, for every pressure and size
  double gdot_min = 0.0;   // points with a smaller gdot = J P are left out (cost)
  int replicas = 3;
  // Run length in strain: t_eq = strain_eq / gdot, t_av = strain_av / gdot, with floors in
  // tau_0. The random start compacts on the time scale xi_s a / P (forces of order P a^2 move
  // particles by a in that time): at N = 1000, P = 3e-4, J = 1 phi rose from 0.39 (the start's
  // overlaps pushed it out) to within 0.002 of its steady value by t = 1.5 / P, so t_eq is also
  // at least relax_pressure / P.
  double strain_eq = 1.0, strain_av = 3.0;
  bool t_av_is_t_eq = false;  // t_av = t_eq, as the seed does (then strain_av is unused)
  double relax_pressure = 5.0;
  double t_eq_min = 500.0, t_av_min = 1000.0;
  int samples = 1000;  // per averaging window (20 blocks of 50)
  std::string why;     // one line: what the preset is for
  // Points beyond the grid: every size x pressure x J of each extension whose gdot = J P is at
  // least the extension's own gdot_min (a point the grid has already is not repeated).
  struct Extension {
    std::vector<std::int64_t> sizes;
    std::vector<double> pressures, js;
    double gdot_min = 0.0;
  };
  std::vector<Extension> extensions;
};

// quick (CI: the pipeline end to end, not the physics), standard (about 6 CPU-hours: N = 1000
// at P = 3e-5 and 1e-5, J from 1 to 3e-4), paper (the seed's grid, for a cluster).
GridPreset grid_preset(const std::string& preset);
// The finite-size study's sizes over the same grid.
GridPreset finite_size_preset(const std::string& preset);

// The integrator of a point (the timestep study's findings, SPEC §4, benchmarks/README.md):
// RKC at atol = 0.1 delta near jamming (P <= 1e-4), else RESPA with the particles on the inner
// level at dt = 1 (stable at N >= 500), dt = 0.5 for 250 <= N < 500, and below N = 250 RESPA with
// the piston on the inner level (8 sub-steps) at dt = 0.1: the piston's rate K / (V xi_V) is large
// in small boxes (explicit Euler at dt = 0.1 oscillated at N = 64, P = 1e-2: force-step correlation
// -0.53, energy balance 0.002), and dt = 0.1 is the seed's small-N step (lanes at dt >= 0.3).
struct PointIntegrator {
  IntegratorSettings settings;  // the [integrator] section the point runs with
  std::string why;
};
PointIntegrator integrator_for(std::int64_t n, double pressure);

// Writes the preset's sweep file (base scene and the zip of every point) and returns its text.
std::string pressure_sweep_text(const GridPreset& preset);

// An integrator as reports name it, from the table's integrator column (what the point ran):
// the kind and its step ("respa dt 0.5"), RKC by its tolerance in units of delta = P at
// constant pressure; in a table collected before that column existed, as the grid presets
// choose it (studies/pressure_points.hpp integrator_for), or "?" at constant volume.
std::string integrator_label(const Table& table, std::size_t r);
// Every integrator of the table with its count of points: "rkc atol=0.1 delta (19), cvode (3)".
std::string integrators_line(const Table& table);

}  // namespace jamflow::studies
