// Ensemble registry. Every ensemble kind registers itself from its own .cpp with a
// namespace-scope
//   const EnsembleRegistrar registrar{"constant_volume", make_constant_volume, "NVgdot: ..."};
// and everything that lists kinds (the scene parser, `--help`, the contract tests) reads
// ensemble_kinds(). The library is linked whole (ensembles/CMakeLists.txt), so no registrar is
// dropped; the registry is a function-local static, so the order of static initialisation
// does not matter.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "ensembles/ensemble.hpp"
#include "lib/config.hpp"
#include "lib/registry.hpp"

namespace jamflow {

// Per-kind factory: reads the kind's own keys from the section (`kind` has been read).
using EnsembleFactory = std::unique_ptr<Ensemble> (*)(ConfigSection& section, double shear_rate);

using EnsembleKind = RegisteredKind<EnsembleFactory>;

// Adds a kind; a kind registered twice is a logic_error.
void register_ensemble(std::string kind, EnsembleFactory factory, std::string description);

struct EnsembleRegistrar {
  EnsembleRegistrar(std::string kind, EnsembleFactory factory, std::string description) {
    register_ensemble(std::move(kind), factory, std::move(description));
  }
};

// All registered kinds, sorted by name.
std::vector<EnsembleKind> registered_ensembles();
std::vector<std::string> ensemble_kinds();

}  // namespace jamflow
