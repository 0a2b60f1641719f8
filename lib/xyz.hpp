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

// Relative tolerance within which 2 * radius must equal a species diameter (kSmallDiameter
// or kLargeDiameter); the diameter is then set to exactly that value.
inline constexpr double kDiameterTolerance = 1e-6;

// Reads a single-frame extended XYZ file. Rules (each violation is a ConfigError):
//  - line 1: the particle count, 1 to NeighbourList::kMaxParticles, and no more than the rest
//    of the file can hold (checked before allocating);
//  - exactly that many particle rows, then only blank lines: extra rows and further frames are
//    errors;
//  - Lattice of Lees–Edwards form (a along x, b in the xy plane, c along z); pbc, if given,
//    must be "T T T";
//  - Properties with species:S:1, pos:R:3 and radius:R:1 in any order (at most 1000 columns);
//    species come from the diameters 2 * radius, which must be 1 (species 0) or 1.4 (species
//    1) within kDiameterTolerance, not from the labels;
//  - positions finite and within 1e6 cell lengths of the cell.
// If the header has Strain=, the strain is restored from it (the tilt must agree with it
// modulo remaps), otherwise strain = xy / Ly. Throws InputFileError (file cannot be opened) or
// ConfigError (naming the path, the line, the value and what is allowed).
State read_xyz(const std::string& path);

// Writes one frame, particles in id order, real-space positions wrapped into the cell. Species
// are labelled with chemical symbols (H small, He large), which ASE and OVITO accept.
void write_xyz(std::ostream& out, const State& state);

// Writes one frame to a file atomically (temporary file then rename).
void write_xyz_file(const std::string& path, const State& state);

}  // namespace jamflow
