// Shared output of the ensembles (the factory is in registry.cpp).
#include "ensembles/ensemble.hpp"

#include "lib/h5.hpp"

namespace jamflow {

void Ensemble::describe(H5Writer& out, const std::string& object) const {
  out.attr(object, "ensemble", name());
  out.attr(object, "shear_rate", shear_rate());
}

}  // namespace jamflow
