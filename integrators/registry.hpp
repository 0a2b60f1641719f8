// Integrator registry and typed integrator settings.
//
// Every integrator kind registers itself from its own .cpp with a namespace-scope
//   const IntegratorRegistrar registrar{"euler", make_euler, "explicit Euler, first order"};
// and everything that lists kinds (the scene parser, `--help`, studies, the contract tests)
// reads integrator_kinds(). The library is linked whole (integrators/CMakeLists.txt), so no
// registrar is dropped by the linker; the registry itself is a function-local static, so
// registration does not depend on the order of static initialisation.
#pragma once
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include <toml++/toml.h>

#include "integrators/integrator.hpp"
#include "lib/config.hpp"
#include "lib/registry.hpp"

namespace jamflow {

// The [integrator] section as typed values: what a study hands to the driver, and what the
// TOML path converts a scene's section into. Doubles are kept exactly (never printed and
// parsed back); the factories validate them with the same checks and messages as a scene.
struct IntegratorSettings {
  using Value = std::variant<bool, std::int64_t, double, std::string>;

  std::string kind;                     // a registered kind
  std::map<std::string, Value> values;  // every other key, e.g. {"dt", 0.1 / 3}

  IntegratorSettings() = default;
  explicit IntegratorSettings(std::string kind_) : kind(std::move(kind_)) {}

  IntegratorSettings& set(const std::string& key, double v);
  IntegratorSettings& set(const std::string& key, std::int64_t v);
  IntegratorSettings& set(const std::string& key, int v) { return set(key, std::int64_t{v}); }
  IntegratorSettings& set(const std::string& key, std::string v);
  IntegratorSettings& set(const std::string& key, const char* v) {
    return set(key, std::string(v));
  }
  IntegratorSettings& set(const std::string& key, bool v);

  // The value of a numeric key (integers converted), if set.
  std::optional<double> number(const std::string& key) const;

  // As an [integrator] table, `kind` included; doubles stay doubles (TOML floats).
  toml::table table() const;
  // From a scene's [integrator] table. A key of a type no setting has (array, table, date)
  // is a ConfigError naming it. `kind` is checked against the registry.
  static IntegratorSettings from_table(const toml::table& table);

  bool operator==(const IntegratorSettings&) const = default;
};

// Per-kind factory: reads the kind's own keys from the section (`kind` has been read).
using IntegratorFactory = std::unique_ptr<Integrator> (*)(ConfigSection& section);

using IntegratorKind = RegisteredKind<IntegratorFactory>;

// Adds a kind; a kind registered twice is a logic_error (two integrators claiming one name).
void register_integrator(std::string kind, IntegratorFactory factory, std::string description);

struct IntegratorRegistrar {
  IntegratorRegistrar(std::string kind, IntegratorFactory factory, std::string description) {
    register_integrator(std::move(kind), factory, std::move(description));
  }
};

// All registered kinds, sorted by name (so every listing is in the same order).
std::vector<IntegratorKind> registered_integrators();
std::vector<std::string> integrator_kinds();

// Builds an integrator from typed settings: unknown kinds, unknown keys, missing keys and
// out-of-range values are ConfigErrors naming "[integrator] key", as for a scene.
std::unique_ptr<Integrator> make_integrator(const IntegratorSettings& settings);

}  // namespace jamflow
