// Test fixture shared by the integrator tests: two small spheres (diameter 1) on a line along
// x in the middle of a cubic cell. For a separation below 1 they overlap by delta = 1 - r, and
// with xi_s = eps = a = 1 the overlap obeys d delta/dt = -2 delta^(alpha_r - 1); harmonic:
// delta(t) = delta_0 exp(-2 t).
#pragma once
#include "lib/state.hpp"

namespace jamflow::fixtures {

inline State two_spheres(double separation, double volume = 1000.0) {
  State s;
  s.resize(2);
  s.box = Box::cubic(volume);
  const double l = s.box.lx;
  s.x()[0] = 0.5;
  s.x()[1] = 0.5 + separation / l;
  s.y()[0] = s.y()[1] = 0.5;
  s.z()[0] = s.z()[1] = 0.5;
  return s;
}

}  // namespace jamflow::fixtures
