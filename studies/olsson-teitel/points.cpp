#include "studies/olsson-teitel/points.hpp"

#include "lib/error.hpp"

namespace jamflow::studies::olsson_teitel {

VolumePreset preset(const std::string& name) {
  VolumePreset p;
  p.study = "olsson-teitel";
  p.name = name;
  if (name == "quick") {
    // phi_J at N = 256 is about 0.6445 (Table 2's size law): three curves below, three above,
    // close enough that at the seed's exponents most points have a neighbouring curve in
    // scaled variables (the collapse measure needs half of them to).
    p.sizes = {256};
    p.phis = {0.62, 0.63, 0.64, 0.655, 0.66, 0.67};
    p.rates = {1e-2, 3e-3, 1e-3, 3e-4};
    p.replicas = 2;
    p.strain_eq = 0.5;
    p.strain_av = 1.0;
    p.t_eq_min = 100.0;
    p.t_av_min = 200.0;
    p.samples = 200;
    p.why = "N = 256, six phi, gdot from 1e-2 to 3e-4: the pipeline, not the physics";
  } else if (name == "standard") {
    p.sizes = {1000};
    p.phis = {0.62, 0.63, 0.64, 0.645, 0.65, 0.655, 0.66, 0.67, 0.68};
    p.rates = {1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6};
    p.replicas = 2;
    p.why =
        "N = 1000, nine phi from 0.62 to 0.68, gdot from 1e-2 to 3e-6 (3.5 decades), two "
        "replicas";
  } else if (name == "paper") {
    p.sizes = {10000};  // the seed's Fig. 9 is at N = 1e4
    p.phis = {0.60, 0.62, 0.63, 0.64, 0.645, 0.65, 0.655, 0.66, 0.67, 0.68, 0.70};
    p.rates = {1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 3e-7, 1e-7, 3e-8, 1e-8};
    p.replicas = 3;
    p.why = "the seed's N = 1e4, eleven phi from 0.60 to 0.70, gdot from 1e-3 to 1e-8";
  } else {
    throw ConfigError("--preset " + name + "; allowed quick, standard, paper");
  }
  return p;
}

}  // namespace jamflow::studies::olsson_teitel
