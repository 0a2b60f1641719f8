// Kolb–Dünweg piston (SPEC §2).
#include "ensembles/constant_pressure.hpp"

#include "ensembles/registry.hpp"
#include "lib/error.hpp"
#include "lib/names.hpp"

namespace jamflow {

ConstantPressure::ConstantPressure(double shear_rate, double pressure, double xi_v)
    : Ensemble(shear_rate), pressure_(pressure), xi_v_(xi_v) {
  if (!(pressure > 0.0))
    throw ConfigError("[ensemble] pressure = " + fmt(pressure) + "; allowed > 0");
  if (!(xi_v > 0.0))
    throw ConfigError("[ensemble] xi_V = " + fmt(xi_v) + "; allowed > 0");
}

void ConstantPressure::describe(Attributes& out) const {
  Ensemble::describe(out);
  out.emplace_back(std::string(names::kImposedPressure), pressure_);
  out.emplace_back("xi_V", xi_v_);
}

std::unique_ptr<Ensemble> make_constant_pressure(ConfigSection& section, double shear_rate) {
  const double p = section.number("pressure", Range::positive());
  const double xi_v = section.number("xi_V", 1e-4, Range::positive());
  return std::make_unique<ConstantPressure>(shear_rate, p, xi_v);
}

namespace {
const EnsembleRegistrar registrar{"constant_pressure", make_constant_pressure,
                                  "NPgdot: Kolb-Duenweg piston (pressure, xi_V)"};
}  // namespace

}  // namespace jamflow
