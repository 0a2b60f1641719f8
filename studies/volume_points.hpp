// Constant-volume state points as a sweep (sweep/): a grid of packing fractions phi and shear
// rates gdot for each N, on either side of jamming. The soft-rheology study takes its points
// above phi_J from here (the yield stress), the Olsson–Teitel study all of its points.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace jamflow::studies {

struct VolumePreset {
  std::string study;  // names the sweep file's header
  std::string name;   // quick | standard | paper
  std::vector<std::int64_t> sizes;
  std::vector<double> phis;
  std::vector<double> rates;
  int replicas = 2;
  // Run length in strain, with floors in tau_0, as the constant-pressure grids: t_eq =
  // max(strain_eq / gdot, relax_pressure / P_expected, t_eq_min), t_av = max(strain_av / gdot,
  // t_av_min), P_expected from expected_pressure (a dense start relaxes on xi_s a / P).
  double strain_eq = 1.0, strain_av = 3.0;
  double relax_pressure = 5.0;
  double t_eq_min = 500.0, t_av_min = 1000.0;
  int samples = 1000;  // per averaging window (20 blocks of 50)
  std::string why;
};

// The pressure the soft granular rheology predicts at (phi, gdot), with the seed's exponents
// and Table 2's N -> infinity parameters (c_phi = c_mu = 0.3, our guess: the seed gives no
// prefactors). Used only to choose each point's integrator and run length; never in an analysis.
double expected_pressure(double phi, double gdot);

// The preset's sweep file (base scene and the zip of every point). Each point's integrator is
// integrator_for(N, expected_pressure) (the timestep study's findings); sizes
// below 250 are refused (that choice is for a piston, which a constant volume has not).
std::string volume_sweep_text(const VolumePreset& preset);

}  // namespace jamflow::studies
