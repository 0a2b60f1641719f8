// The soft-rheology study's state points: constant pressure over several pressures and viscous
// numbers (phi_J(P), mu_J(P) and their exponents x, y), and constant volume above phi_J (the
// yield stress). Two sweeps: OUT/constant-pressure and OUT/constant-volume.
#pragma once
#include <string>

#include "studies/pressure_points.hpp"
#include "studies/volume_points.hpp"

namespace jamflow::studies::soft_rheology {

struct Preset {
  GridPreset pressure;  // constant pressure: sizes x pressures x J
  VolumePreset volume;  // constant volume above phi_J
};

// quick (CI: the pipeline end to end, not the physics), standard (about 2 h on 2 cores),
// paper (the seed's grid at N = 1000, Fig. 8, for a cluster).
Preset preset(const std::string& name);

}  // namespace jamflow::studies::soft_rheology
