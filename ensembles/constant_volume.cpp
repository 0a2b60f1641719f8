// Constant volume: registers the kind.
#include "ensembles/constant_volume.hpp"

#include "ensembles/registry.hpp"

namespace jamflow {

std::unique_ptr<Ensemble> make_constant_volume(ConfigSection& /*section*/, double shear_rate) {
  return std::make_unique<ConstantVolume>(shear_rate);
}

namespace {
const EnsembleRegistrar registrar{"constant_volume", make_constant_volume,
                                  "NVgdot: fixed volume, P_hat measured (no keys)"};
}  // namespace

}  // namespace jamflow
