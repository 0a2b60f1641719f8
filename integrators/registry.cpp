// Integrator registry and typed settings.
#include "integrators/registry.hpp"

#include <algorithm>
#include <stdexcept>

#include "lib/error.hpp"

namespace jamflow {

namespace {

std::map<std::string, IntegratorKind>& mutable_registry() {
  static std::map<std::string, IntegratorKind> kinds;
  return kinds;
}

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
  auto& kinds = mutable_registry();
  if (kinds.count(kind))
    throw std::logic_error("integrator kind '" + kind + "' registered twice");
  IntegratorKind entry{kind, std::move(description), factory};
  kinds.emplace(std::move(kind), std::move(entry));
}

std::vector<IntegratorKind> registered_integrators() {
  std::vector<IntegratorKind> out;
  for (const auto& [name, entry] : mutable_registry())
    out.push_back(entry);
  return out;
}

std::vector<std::string> integrator_kinds() {
  std::vector<std::string> out;
  for (const auto& [name, entry] : mutable_registry())
    out.push_back(name);
  return out;
}

std::unique_ptr<Integrator> make_integrator(ConfigSection& section) {
  const std::string kind = section.choice("kind", integrator_kinds());
  std::unique_ptr<Integrator> integ = mutable_registry().at(kind).factory(section);
  section.finish();
  return integ;
}

std::unique_ptr<Integrator> make_integrator(const IntegratorSettings& settings) {
  const toml::table t = settings.table();
  ConfigSection section("integrator", &t);
  return make_integrator(section);
}

}  // namespace jamflow
