// A registry of named kinds, each with a one-line description and a factory, filled by
// namespace-scope registrars in the kinds' own translation units (ensembles/registry.hpp,
// integrators/registry.hpp). The table is a function-local static, so registration does not
// depend on the order of static initialisation; kinds are listed sorted by name.
#pragma once
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace jamflow {

template <class Factory>
struct RegisteredKind {
  std::string kind;
  std::string description;  // one line, for --help and error messages
  Factory factory = nullptr;
};

// `Tag` names what is registered ("ensemble", "integrator") and keeps the tables apart.
template <class Factory, const char* Tag>
class Registry {
 public:
  using Entry = RegisteredKind<Factory>;
  // Adds a kind; a kind registered twice is a logic_error (two parts claiming one name).
  static void add(std::string kind, Factory factory, std::string description) {
    auto& kinds = table();
    if (kinds.count(kind))
      throw std::logic_error(std::string(Tag) + " kind '" + kind + "' registered twice");
    Entry entry{kind, std::move(description), factory};
    kinds.emplace(std::move(kind), std::move(entry));
  }
  static std::vector<Entry> entries() {
    std::vector<Entry> out;
    for (const auto& [name, entry] : table())
      out.push_back(entry);
    return out;
  }
  static std::vector<std::string> kinds() {
    std::vector<std::string> out;
    for (const auto& [name, entry] : table())
      out.push_back(name);
    return out;
  }
  // The factory of a registered kind (std::out_of_range otherwise).
  static Factory factory(const std::string& kind) { return table().at(kind).factory; }

 private:
  static std::map<std::string, Entry>& table() {
    static std::map<std::string, Entry> kinds;
    return kinds;
  }
};

}  // namespace jamflow
