// Shared toolkit for studies: the seed's start packing fractions, and the report helpers of
// framework/report.hpp.
#pragma once
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "driver/run.hpp"
#include "framework/report.hpp"
#include "framework/study.hpp"

namespace jamflow::studies {

// The seed's hard-sphere law phi(J) = phi_J - C_phi J^b_phi at N particles, with its finite-size
// forms O(N) = O_inf + A_O N^-alpha_O (Table 2, SPEC §5); below phi_J and at J > 0.
double hard_sphere_phi(double j, std::int64_t n);
// A start packing fraction for a constant-pressure run at viscous number J: the hard-sphere law,
// `below` lower, clamped to [0.3, phi_max]. Only the start: the piston finds the steady state;
// starting near it shortens the transient.
double phi_start(double j, std::int64_t n, double below = 0.0, double phi_max = 0.64);

}  // namespace jamflow::studies
