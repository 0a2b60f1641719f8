// Lees–Edwards deforming cell (SPEC §2).
//
// Lattice vectors are the columns of h = [[Lx, t Ly, 0], [0, Ly, 0], [0, 0, Lz]], where the
// tilt factor t = strain - flips * Lx / Ly is the accumulated shear strain reduced to
// [-1/2, 1/2] by discrete remaps (b -> b - a). The image of the cell at +Ly is displaced by
// t Ly along x, i.e. by strain * Ly modulo Lx, which is simple shear u = gdot y e_x. The
// strain, not the absolute offset, is the state variable, so an isotropic dilation keeps it.
#pragma once
#include <Eigen/Dense>
#include <cstdint>

namespace jamflow {

struct Box {
  double lx = 1.0, ly = 1.0, lz = 1.0;
  double strain = 0.0;     // integral of gdot dt since the start of the run history
  std::int64_t flips = 0;  // number of b -> b - a remaps applied

  static Box cubic(double volume);

  double volume() const { return lx * ly * lz; }
  double tilt() const { return strain - static_cast<double>(flips) * lx / ly; }
  double xy() const { return tilt() * ly; }  // Lees–Edwards offset of the +y image

  Eigen::Matrix3d h() const;      // columns are lattice vectors
  Eigen::Matrix3d h_inv() const;  // inverse of h

  // Isotropic dilation to a new volume; scaled coordinates and strain are unchanged.
  void set_volume(double volume);

  // Distance between opposite faces along each scaled direction: a sphere of radius r fits
  // in the cell without touching its own images iff 2 r < min(widths).
  Eigen::Vector3d perpendicular_widths() const;

  // Whether |tilt| exceeds 1/2 so that a remap is due, and the remap direction (+1: b -> b - a).
  int remap_direction() const;
  // How many remaps (+1 each: b -> b - a) bring the tilt back into [-1/2, 1/2] Lx / Ly: 0 when
  // none is due, remap_direction() when one suffices, and more after a strain of more than one
  // cell length since the last remap (gdot dt > 1 within one step). An IntegrationError when the
  // tilt is not finite or beyond 2^52 cell lengths, where round-off has lost its fraction.
  std::int64_t remaps_due() const;
  // The tilt as a fraction of Lx, xy / Lx: the x offset of the +y image in scaled units.
  double tilt_fraction() const { return xy() / lx; }
};

}  // namespace jamflow
