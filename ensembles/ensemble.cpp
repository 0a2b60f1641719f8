// Ensemble factory and shared output.
#include "ensembles/ensemble.hpp"

#include "ensembles/constant_pressure.hpp"
#include "ensembles/constant_volume.hpp"
#include "lib/h5.hpp"

namespace jamflow {

void Ensemble::describe(H5Writer& out, const std::string& object) const {
  out.attr(object, "ensemble", name());
  out.attr(object, "shear_rate", shear_rate());
}

std::unique_ptr<Ensemble> make_ensemble(ConfigSection& section, double shear_rate) {
  const std::string kind = section.choice("kind", {"constant_volume", "constant_pressure"});
  std::unique_ptr<Ensemble> e;
  if (kind == "constant_volume") {
    e = std::make_unique<ConstantVolume>(shear_rate);
  } else {
    e = make_constant_pressure(section, shear_rate);
  }
  section.finish();
  return e;
}

}  // namespace jamflow
