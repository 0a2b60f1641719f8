// Ensemble registry and the [ensemble] factory.
#include "ensembles/registry.hpp"

#include <map>
#include <stdexcept>

namespace jamflow {

namespace {

std::map<std::string, EnsembleKind>& mutable_registry() {
  static std::map<std::string, EnsembleKind> kinds;
  return kinds;
}

}  // namespace

void register_ensemble(std::string kind, EnsembleFactory factory, std::string description) {
  auto& kinds = mutable_registry();
  if (kinds.count(kind))
    throw std::logic_error("ensemble kind '" + kind + "' registered twice");
  EnsembleKind entry{kind, std::move(description), factory};
  kinds.emplace(std::move(kind), std::move(entry));
}

std::vector<EnsembleKind> registered_ensembles() {
  std::vector<EnsembleKind> out;
  for (const auto& [name, entry] : mutable_registry())
    out.push_back(entry);
  return out;
}

std::vector<std::string> ensemble_kinds() {
  std::vector<std::string> out;
  for (const auto& [name, entry] : mutable_registry())
    out.push_back(name);
  return out;
}

std::unique_ptr<Ensemble> make_ensemble(ConfigSection& section, double shear_rate) {
  const std::string kind = section.choice("kind", ensemble_kinds());
  std::unique_ptr<Ensemble> e = mutable_registry().at(kind).factory(section, shear_rate);
  section.finish();
  return e;
}

}  // namespace jamflow
