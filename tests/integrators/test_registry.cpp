// The integrator registry: every kind registers itself (and survives linking), and the scene
// parser builds integrators through it.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "integrators/registry.hpp"
#include "lib/error.hpp"

namespace jamflow {
namespace {

TEST(IntegratorRegistry, HoldsExactlyEulerRespaCvodeRkc) {
  EXPECT_EQ(integrator_kinds(), (std::vector<std::string>{"cvode", "euler", "respa", "rkc"}));
  for (const IntegratorKind& k : registered_integrators()) {
    EXPECT_NE(k.factory, nullptr) << k.kind;
    EXPECT_FALSE(k.description.empty()) << k.kind;
  }
}

TEST(IntegratorRegistry, EachKindBuildsIntegratorOfThatName) {
  const Scene scene = Scene::parse(
      "[euler]\nkind = \"euler\"\ndt = 0.1\n[respa]\nkind = \"respa\"\ndt = 0.1\n"
      "[cvode]\nkind = \"cvode\"\n[rkc]\nkind = \"rkc\"\n",
      "registry.toml");
  for (const std::string& kind : integrator_kinds()) {
    ConfigSection sec = scene.section(kind);
    EXPECT_EQ(make_integrator(sec)->name(), kind);
  }
}

TEST(IntegratorRegistry, RegisteringAKindTwiceIsAnError) {
  EXPECT_THROW(register_integrator("euler", registered_integrators().front().factory, "again"),
               std::logic_error);
  EXPECT_EQ(integrator_kinds().size(), 4u);
}

TEST(IntegratorRegistry, UnknownKindListsRegisteredKinds) {
  IntegratorSettings s("rk4");
  try {
    make_integrator(s);
    FAIL() << "rk4 accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("allowed \"cvode\", \"euler\", \"respa\", \"rkc\""),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace jamflow
