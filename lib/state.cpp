// State helpers: packing fraction, wrapping and the Lees–Edwards remap.
#include "lib/state.hpp"

#include <cmath>
#include <numbers>

namespace jamflow {

void State::resize(std::size_t n) {
  pos.assign(3 * n, 0.0);
  image.assign(3 * n, 0);
  diameter.assign(n, kSmallDiameter);
  species.assign(n, 0);
  id.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    id[i] = static_cast<std::int64_t>(i);
}

double State::particle_volume() const {
  double sum = 0.0;
  for (double d : diameter)
    sum += d * d * d;
  return std::numbers::pi * sum / 6.0;
}

std::vector<double> State::unwrapped_by_id() const {
  const std::size_t n = size();
  std::vector<double> out(3 * n);
  const Eigen::Matrix3d h = box.h();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d u(x()[i] + image[i], y()[i] + image[n + i], z()[i] + image[2 * n + i]);
    const Eigen::Vector3d r = h * u;
    for (int c = 0; c < 3; ++c)
      out[3 * std::size_t(id[i]) + c] = r[c];
  }
  return out;
}

double State::packing_fraction() const {
  return particle_volume() / box.volume();
}

void State::wrap() {
  for (std::size_t k = 0; k < pos.size(); ++k) {
    double f = std::floor(pos[k]);
    if (f != 0.0) {
      pos[k] -= f;
      // A tiny negative value minus floor (-1) rounds up to exactly 1.0: it belongs to this
      // image, at 0, so the image counter must not move.
      if (pos[k] >= 1.0) {
        pos[k] = 0.0;
        f += 1.0;
      }
      image[k] += static_cast<std::int32_t>(f);
    }
  }
}

void State::remap(std::int64_t dir) {
  // r = s_x a + s_y b with b' = b - dir a  =>  s_x' = s_x + dir s_y. Unwrapped coordinates
  // transform the same way, so the x image counter absorbs dir * (y image).
  const std::size_t n = size();
  const double d = static_cast<double>(dir);
  for (std::size_t i = 0; i < n; ++i) {
    pos[i] += d * pos[n + i];
    // Modulo 2^32, as the counters wrap after that many cell lengths anyway (no overflow).
    image[i] = static_cast<std::int32_t>(static_cast<std::uint32_t>(image[i]) +
                                         static_cast<std::uint32_t>(dir) *
                                             static_cast<std::uint32_t>(image[n + i]));
  }
  box.flips += dir;
}

double volume_for_phi(std::size_t n, double phi) {
  const std::size_t n_large = n / 2;
  const std::size_t n_small = n - n_large;
  const double sum = n_small * std::pow(kSmallDiameter, 3) + n_large * std::pow(kLargeDiameter, 3);
  return std::numbers::pi * sum / (6.0 * phi);
}

}  // namespace jamflow
