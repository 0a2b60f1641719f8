// Ensemble registry and the [ensemble] factory.
#include "ensembles/registry.hpp"

namespace jamflow {

namespace {

constexpr char kEnsemble[] = "ensemble";
using Ensembles = Registry<EnsembleFactory, kEnsemble>;

}  // namespace

void register_ensemble(std::string kind, EnsembleFactory factory, std::string description) {
  Ensembles::add(std::move(kind), factory, std::move(description));
}

std::vector<EnsembleKind> registered_ensembles() {
  return Ensembles::entries();
}

std::vector<std::string> ensemble_kinds() {
  return Ensembles::kinds();
}

std::unique_ptr<Ensemble> make_ensemble(ConfigSection& section, double shear_rate) {
  const std::string kind = section.choice("kind", ensemble_kinds());
  std::unique_ptr<Ensemble> e = Ensembles::factory(kind)(section, shear_rate);
  section.finish();
  return e;
}

}  // namespace jamflow
