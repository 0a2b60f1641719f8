// Shared toolkit for studies.
#include "studies/common.hpp"

#include <algorithm>

#include "analysis/seed.hpp"

namespace jamflow::studies {

double hard_sphere_phi(double j, std::int64_t n) {
  return seed::hard_sphere_phi(j, double(n));
}

double phi_start(double j, std::int64_t n, double below, double phi_max) {
  return std::clamp(hard_sphere_phi(j, n) - below, 0.3, phi_max);
}

}  // namespace jamflow::studies
