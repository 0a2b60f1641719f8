// The Olsson–Teitel study's state points: constant volume on both sides of phi_J, over at least
// three decades of gdot at the standard and paper presets (the seed's Fig. 9).
#pragma once
#include <string>

#include "studies/volume_points.hpp"

namespace jamflow::studies::olsson_teitel {

// quick (CI: the pipeline end to end, two decades of gdot), standard (about 2 h on 2 cores),
// paper (the seed's N = 1e4 over five decades, for a cluster).
VolumePreset preset(const std::string& name);

}  // namespace jamflow::studies::olsson_teitel
