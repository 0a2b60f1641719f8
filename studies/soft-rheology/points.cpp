#include "studies/soft-rheology/points.hpp"

#include "lib/error.hpp"

namespace jamflow::studies::soft_rheology {

Preset preset(const std::string& name) {
  Preset p;
  // The constant-pressure grid starts from the hard-sphere study's preset of the same name
  // (run lengths, samples, replicas) and changes the grid.
  p.pressure = grid_preset(name);
  p.pressure.study = "soft-rheology";
  p.volume.study = "soft-rheology";
  p.volume.name = name;
  if (name == "quick") {
    // The joint fit needs 8 points at 3 pressures or more; four pressures keep it possible
    // when a few points fail their verdicts. Not above 1e-2: at P = 3e-2 RESPA at dt = 0.5
    // was not stable at N = 256 (3 of 4 points).
    p.pressure.pressures = {1e-2, 5e-3, 2e-3, 1e-3};
    p.pressure.js = {1.0, 0.3, 0.1, 0.03};
    p.pressure.gdot_min = 5e-5;  // leaves out P = 1e-3, J = 0.03: half the cost alone
    p.pressure.strain_eq = 0.5;
    p.pressure.strain_av = 1.0;
    p.pressure.relax_pressure = 2.0;
    p.pressure.why = "N = 256, four pressures and four J: the pipeline in about a CPU-minute";
    p.volume.sizes = {256};
    p.volume.phis = {0.66, 0.68, 0.70};
    p.volume.rates = {1e-3, 1e-4};
    p.volume.replicas = 2;
    p.volume.strain_eq = 0.5;
    p.volume.strain_av = 1.0;
    p.volume.t_eq_min = 100.0;
    p.volume.t_av_min = 200.0;
    p.volume.samples = 200;
    p.volume.why = "N = 256, three phi above phi_J at two rates: the pipeline, not the physics";
  } else if (name == "standard") {
    // The lever arm for x and y is the pressure range: 3.5 decades, P = 3e-2 down to 1e-5, so
    // that x and y are fitted over three or more decades (the pressure-window systematic drops
    // either end and still leaves 2.5-3 decades). J is kept where gdot = J P >= 1e-6, so P = 1e-5
    // has only J = 0.3 and 0.1, P = 3e-5 J >= 0.03. P = 3e-2 ran
    // unstable with RESPA at dt = 0.5 at N = 256 (the quick preset); at N = 1000 the integrator
    // is integrator_for's choice for that pressure.
    p.pressure.sizes = {1000};
    p.pressure.pressures = {3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5};
    p.pressure.js = {0.3, 0.1, 0.03, 0.01, 3e-3};
    p.pressure.gdot_min = 1e-6;
    p.pressure.replicas = 2;
    p.pressure.why =
        "N = 1000, P from 3e-2 to 1e-5 (3.5 decades), J from 0.3 down to "
        "gdot = 1e-6, two replicas";
    p.volume.sizes = {1000};
    p.volume.phis = {0.655, 0.66, 0.67, 0.68, 0.70};
    p.volume.rates = {1e-4, 1e-5};
    p.volume.replicas = 2;
    p.volume.why = "N = 1000, five phi above phi_J at gdot = 1e-4 and 1e-5";
  } else if (name == "paper") {
    p.pressure.sizes = {1000};  // the seed's Fig. 8 is at N = 1000
    p.pressure.why = "the seed's grid at N = 1000: P from 1e-2 to 1e-5, gdot down to 4e-9";
    p.volume.sizes = {1000};
    p.volume.phis = {0.65, 0.655, 0.66, 0.67, 0.68, 0.70, 0.72};
    p.volume.rates = {1e-5, 1e-6, 1e-7};
    p.volume.replicas = 3;
    p.volume.why = "N = 1000, seven phi above phi_J down to gdot = 1e-7";
  }
  return p;  // an unknown name was refused by grid_preset
}

}  // namespace jamflow::studies::soft_rheology
