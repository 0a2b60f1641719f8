// The one plain value that evolves: particles in scaled coordinates plus the cell and time.
// A copy of a State is a complete checkpoint.
#pragma once
#include <Eigen/Dense>
#include <cstdint>
#include <string>
#include <vector>

#include "lib/box.hpp"

namespace jamflow {

struct State {
  // Scaled coordinates s = h^-1 r, structure of arrays: [x_0..x_{n-1}, y_0.., z_0..].
  // Wrapped into [0, 1) whenever the neighbour list is rebuilt; between rebuilds they move
  // continuously so that the list's image shifts stay valid.
  std::vector<double> pos;
  // Periodic image counters (same layout): unwrapped scaled position = pos + image.
  std::vector<std::int32_t> image;
  std::vector<double> diameter;
  std::vector<std::uint8_t> species;  // 0 = small (a), 1 = large (1.4 a)
  // Particle identity: particles are reordered in memory for locality, outputs use id order.
  std::vector<std::int64_t> id;
  Box box;
  double time = 0.0;

  std::size_t size() const { return diameter.size(); }
  void resize(std::size_t n);

  double* x() { return pos.data(); }
  double* y() { return pos.data() + size(); }
  double* z() { return pos.data() + 2 * size(); }
  const double* x() const { return pos.data(); }
  const double* y() const { return pos.data() + size(); }
  const double* z() const { return pos.data() + 2 * size(); }

  Eigen::Vector3d scaled(std::size_t i) const { return {x()[i], y()[i], z()[i]}; }
  Eigen::Vector3d real(std::size_t i) const { return box.h() * scaled(i); }

  // Real-space positions unwrapped by the image counters, by particle id (id-major: x, y, z of
  // id 0, then id 1, ...): what follows a particle across wraps, for comparing trajectories.
  std::vector<double> unwrapped_by_id() const;

  // Packing fraction pi sum d^3 / (6 V) (SPEC §3: the seed's formula lost the pi).
  double packing_fraction() const;
  // Sum of particle volumes, pi sum d^3 / 6.
  double particle_volume() const;

  // Wrap scaled coordinates into [0, 1), updating the image counters.
  void wrap();
  // Apply the discrete Lees–Edwards remap b -> b - dir a (dir times b -> b - a, any whole
  // number); positions are unchanged in space. Scaled x is left unwrapped.
  void remap(std::int64_t dir);
};

// Diameters of the two species (SPEC §1).
inline constexpr double kSmallDiameter = 1.0;
inline constexpr double kLargeDiameter = 1.4;

// Cell volume that gives packing fraction phi for the equimolar mixture of n particles.
double volume_for_phi(std::size_t n, double phi);

}  // namespace jamflow
