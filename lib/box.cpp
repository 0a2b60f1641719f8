// Lees–Edwards deforming cell (SPEC §2).
#include "lib/box.hpp"

#include <cmath>
#include <string>

#include "lib/error.hpp"

namespace jamflow {

Box Box::cubic(double volume) {
  Box b;
  const double l = std::cbrt(volume);
  b.lx = b.ly = b.lz = l;
  return b;
}

Eigen::Matrix3d Box::h() const {
  Eigen::Matrix3d m;
  m << lx, xy(), 0.0, 0.0, ly, 0.0, 0.0, 0.0, lz;
  return m;
}

Eigen::Matrix3d Box::h_inv() const {
  Eigen::Matrix3d m;
  const double t = tilt();
  m << 1.0 / lx, -t / lx, 0.0, 0.0, 1.0 / ly, 0.0, 0.0, 0.0, 1.0 / lz;
  return m;
}

void Box::set_volume(double volume) {
  const double v0 = this->volume();
  if (!(volume > 0.0) || !std::isfinite(volume)) {
    throw IntegrationError("cell volume became " + std::to_string(volume) + " (from " +
                           std::to_string(v0) +
                           "): the piston step is unstable; reduce dt or raise xi_V");
  }
  const double scale = std::cbrt(volume / v0);
  lx *= scale;
  ly *= scale;
  lz *= scale;
}

Eigen::Vector3d Box::perpendicular_widths() const {
  const Eigen::Matrix3d m = h();
  const Eigen::Vector3d a = m.col(0), b = m.col(1), c = m.col(2);
  const double v = volume();
  return {v / b.cross(c).norm(), v / c.cross(a).norm(), v / a.cross(b).norm()};
}

int Box::remap_direction() const {
  const double t = tilt();
  const double half = 0.5 * lx / ly;
  if (t > half)
    return +1;
  if (t < -half)
    return -1;
  return 0;
}

std::int64_t Box::remaps_due() const {
  const int dir = remap_direction();
  if (dir == 0)
    return 0;
  const double whole = std::nearbyint(tilt() * ly / lx);
  if (!(std::abs(whole) <= 0x1p52)) {
    throw IntegrationError("the cell's tilt became " + std::to_string(tilt()) + " (strain " +
                           std::to_string(strain) +
                           "): too large to reduce by remaps; lower the shear rate or dt");
  }
  // At the threshold itself the rounding may say 0 where remap_direction() says 1.
  return whole == 0.0 ? dir : static_cast<std::int64_t>(whole);
}

}  // namespace jamflow
