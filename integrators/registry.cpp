// Integrator registry and typed settings.
#include "integrators/registry.hpp"

#include <algorithm>
#include <stdexcept>

#include "lib/error.hpp"

namespace jamflow {

namespace {

constexpr char kIntegrator[] = "integrator";
using Integrators = Registry<IntegratorFactory, kIntegrator>;

}  // namespace

IntegratorSettings& IntegratorSettings::set(const std::string& key, double v) {
  values[key] = v;
  return *this;
}
IntegratorSettings& IntegratorSettings::set(const std::string& key, std::int64_t v) {
  values[key] = v;
  return *this;
}
IntegratorSettings& IntegratorSettings::set(const std::string& key, std::string v) {
  values[key] = std::move(v);
  return *this;
}
IntegratorSettings& IntegratorSettings::set(const std::string& key, bool v) {
  values[key] = v;
  return *this;
}

std::optional<double> IntegratorSettings::number(const std::string& key) const {
  const auto it = values.find(key);
  if (it == values.end())
    return std::nullopt;
  if (const auto* d = std::get_if<double>(&it->second))
    return *d;
  if (const auto* i = std::get_if<std::int64_t>(&it->second))
    return double(*i);
  return std::nullopt;
}

toml::table IntegratorSettings::table() const {
  toml::table t;
  t.insert("kind", kind);
  for (const auto& [key, value] : values)
    std::visit([&t, &key = key](const auto& v) { t.insert_or_assign(key, v); }, value);
  return t;
}

IntegratorSettings IntegratorSettings::from_table(const toml::table& table) {
  ConfigSection section("integrator", &table);
  IntegratorSettings s(section.choice("kind", integrator_kinds()));
  for (const auto& [k, node] : table) {
    const std::string key(k.str());
    if (key == "kind")
      continue;
    if (const auto* d = node.as_floating_point())
      s.values[key] = d->get();
    else if (const auto* i = node.as_integer())
      s.values[key] = i->get();
    else if (const auto* str = node.as_string())
      s.values[key] = str->get();
    else if (const auto* b = node.as_boolean())
      s.values[key] = b->get();
    else
      throw ConfigError(section.label(key) + " is not a number, string or boolean");
  }
  return s;
}

void register_integrator(std::string kind, IntegratorFactory factory, std::string description) {
  Integrators::add(std::move(kind), factory, std::move(description));
}

std::vector<IntegratorKind> registered_integrators() {
  return Integrators::entries();
}

std::vector<std::string> integrator_kinds() {
  return Integrators::kinds();
}

std::unique_ptr<Integrator> make_integrator(ConfigSection& section) {
  const std::string kind = section.choice("kind", integrator_kinds());
  std::unique_ptr<Integrator> integ = Integrators::factory(kind)(section);
  section.finish();
  return integ;
}

std::unique_ptr<Integrator> make_integrator(const IntegratorSettings& settings) {
  const toml::table t = settings.table();
  ConfigSection section("integrator", &t);
  return make_integrator(section);
}

}  // namespace jamflow
