// Random initial configurations.
#include "lib/init.hpp"

#include <random>

namespace jamflow {

State random_state(std::size_t n, double phi, std::uint64_t seed) {
  State s;
  s.resize(n);
  const std::size_t n_small = n - n / 2;
  for (std::size_t i = 0; i < n; ++i) {
    const bool large = i >= n_small;
    s.species[i] = large ? 1 : 0;
    s.diameter[i] = large ? kLargeDiameter : kSmallDiameter;
  }
  s.box = Box::cubic(volume_for_phi(n, phi));
  std::mt19937_64 rng(seed);
  for (auto& p : s.pos)
    p = unit_double(rng());
  return s;
}

}  // namespace jamflow
