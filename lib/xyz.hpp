// Extended XYZ (the format OVITO and ASE read) for initial and final configurations.
//
// Header line:  Lattice="ax ay az bx by bz cx cy cz" Properties=species:S:1:pos:R:3:radius:R:1
//               Time=<t> Strain=<total strain> pbc="T T T"
// Rows of Lattice are the lattice vectors; the Lees–Edwards tilt appears as b = (xy, Ly, 0).
#pragma once
#include <iosfwd>
#include <string>

#include "lib/state.hpp"

namespace jamflow {

// Reads the first frame of an extended XYZ file. Diameters are 2 * radius; species 0 is given
// to the smaller diameters. The cell must be of Lees–Edwards form (a along x, b in the xy
// plane, c along z). If the header has Strain=, the strain is restored from it (the tilt must
// agree with it modulo remaps), otherwise strain = xy / Ly. Throws IoError (file cannot be
// opened) or ConfigError (malformed content, naming the path, the line and what is wrong).
State read_xyz(const std::string& path);

// Writes one frame, particles in id order, real-space positions wrapped into the cell.
void write_xyz(std::ostream& out, const State& state);

// Writes one frame to a file atomically (temporary file then rename).
void write_xyz_file(const std::string& path, const State& state);

}  // namespace jamflow
