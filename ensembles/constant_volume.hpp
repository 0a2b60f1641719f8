// Constant volume under steady shear (NVgdot): V fixed, phi given, P_hat measured (SPEC §2).
#pragma once
#include <memory>

#include "ensembles/ensemble.hpp"

namespace jamflow {

class ConstantVolume final : public Ensemble {
 public:
  explicit ConstantVolume(double shear_rate) : Ensemble(shear_rate) {}
  std::string name() const override { return "constant_volume"; }
};

// Reads no keys.
std::unique_ptr<Ensemble> make_constant_volume(ConfigSection& section, double shear_rate);

}  // namespace jamflow
