// The ensemble registry: every kind registers itself (and survives linking), and the scene
// parser builds ensembles through it.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "ensembles/registry.hpp"
#include "lib/error.hpp"

namespace jamflow {
namespace {

TEST(EnsembleRegistry, HoldsExactlyConstantVolumeAndConstantPressure) {
  EXPECT_EQ(ensemble_kinds(), (std::vector<std::string>{"constant_pressure", "constant_volume"}));
  for (const EnsembleKind& k : registered_ensembles()) {
    EXPECT_NE(k.factory, nullptr) << k.kind;
    EXPECT_FALSE(k.description.empty()) << k.kind;
  }
}

TEST(EnsembleRegistry, EachKindBuildsEnsembleOfThatName) {
  const Scene scene = Scene::parse(
      "[constant_volume]\nkind = \"constant_volume\"\n"
      "[constant_pressure]\nkind = \"constant_pressure\"\npressure = 1e-3\n",
      "registry.toml");
  for (const std::string& kind : ensemble_kinds()) {
    ConfigSection sec = scene.section(kind);
    const auto e = make_ensemble(sec, 1e-3);
    EXPECT_EQ(e->name(), kind);
    EXPECT_EQ(e->shear_rate(), 1e-3);
  }
}

TEST(EnsembleRegistry, RegisteringAKindTwiceIsAnError) {
  EXPECT_THROW(register_ensemble("constant_volume", registered_ensembles().front().factory, "x"),
               std::logic_error);
  EXPECT_EQ(ensemble_kinds().size(), 2u);
}

}  // namespace
}  // namespace jamflow
