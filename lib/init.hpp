// Initial configurations: random positions at a given packing fraction (seeded).
#pragma once
#include <cstdint>

#include "lib/state.hpp"

namespace jamflow {

// Equimolar 1 : 1.4 mixture (SPEC §1): the first ceil(n/2) particles are small, the rest
// large; uniform random scaled positions in a cubic cell at packing fraction phi.
State random_state(std::size_t n, double phi, std::uint64_t seed);

// Portable uniform double in [0, 1) from a 64-bit generator output (53 random bits), so the
// same seed gives the same configuration with any standard library.
inline double unit_double(std::uint64_t bits) {
  return static_cast<double>(bits >> 11) * 0x1.0p-53;
}

}  // namespace jamflow
