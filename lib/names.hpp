// The one name of each state quantity that crosses layers: the run file's /summary, the
// collected sweep table, the analyses' tables and JSON, the studies' HDF5 and Python all spell
// them so. In a scene they are the TOML keys [shear] rate and [ensemble] pressure.
#pragma once
#include <string_view>
#include <utility>

namespace jamflow::names {

inline constexpr std::string_view kShearRate = "shear_rate";              // 1/tau_0
inline constexpr std::string_view kImposedPressure = "imposed_pressure";  // eps/a^3

// Names earlier versions wrote in tables, still read (with a deprecation warning) where users
// give tables to jamflow: {old, current}.
inline constexpr std::pair<std::string_view, std::string_view> kDeprecatedColumns[] = {
    {"gdot", kShearRate},
    {"P", kImposedPressure},
};

}  // namespace jamflow::names
