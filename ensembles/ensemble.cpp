// Shared output of the ensembles (the factory is in registry.cpp).
#include "ensembles/ensemble.hpp"

#include <cmath>
#include <string>

#include "lib/names.hpp"

namespace jamflow {

double Ensemble::volume_rate_slope(double p_hat) const {
  if (!has_piston())
    return 0.0;
  double scale = std::abs(p_hat);
  if (!(scale > 0.0) || !std::isfinite(scale))
    scale = std::abs(imposed_pressure().value_or(1.0));
  if (!(scale > 0.0) || !std::isfinite(scale))
    scale = 1.0;
  const double dp = 1e-4 * scale;
  return (volume_rate(p_hat + dp) - volume_rate(p_hat - dp)) / (2.0 * dp);
}

void Ensemble::describe(Attributes& out) const {
  out.emplace_back("ensemble", name());
  out.emplace_back(std::string(names::kShearRate), shear_rate());
}

}  // namespace jamflow
