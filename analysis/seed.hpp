// The seed paper's numbers (Kawasaki, Coslovich, Ikeda & Berthier, PRE 2015), as SPEC §5 gives
// them, in one place: every analysis, report and study that compares with the paper, or starts
// from its laws, reads them from here.
#pragma once

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <string_view>

namespace jamflow::seed {

// One column of Table 2: O(N) = inf + a N^-alpha (n <= 0, a size not known, gives inf).
struct SizeLaw {
  std::string_view name;
  double inf, a, alpha;
  double at(double n) const { return n > 0.0 ? inf + a * std::pow(n, -alpha) : inf; }
};

// Table 2, in the order the paper lists its columns.
inline constexpr std::array<SizeLaw, 6> kTable2 = {{
    {"phi_J", 0.6474, -0.323, 0.852},
    {"b_phi", 0.391, 0.756, 0.505},
    {"C_phi", 0.0683, -1.15, 1.17},
    {"mu_J", 0.108, 0.279, 0.626},
    {"b_mu", 0.346, 2.93, 0.946},
    {"C_mu", 0.347, -1.44, 1.02},
}};

// The Table 2 column of one parameter ("phi_J", "b_phi", "C_phi", "mu_J", "b_mu", "C_mu").
constexpr const SizeLaw& table2(std::string_view parameter) {
  for (const SizeLaw& law : kTable2)
    if (law.name == parameter)
      return law;
  throw std::out_of_range("no Table 2 entry for " + std::string(parameter));
}

// The hard-sphere flow curve phi(J) = phi_J - C_phi J^b_phi at size N, from Table 2.
inline double hard_sphere_phi(double j, double n) {
  return table2("phi_J").at(n) - table2("C_phi").at(n) * std::pow(j, table2("b_phi").at(n));
}

// The friction coefficient mu(J) = mu_J + C_mu J^b_mu at size N, from Table 2, and the viscosity
// eta / eta_0 = mu(J) / J on the hard-sphere flow curve.
inline double hard_sphere_mu(double j, double n) {
  return table2("mu_J").at(n) + table2("C_mu").at(n) * std::pow(j, table2("b_mu").at(n));
}
inline double hard_sphere_viscosity(double j, double n) {
  return hard_sphere_mu(j, n) / j;
}

// Correlation length xi ~ J^-nu, nu = b / (alpha_O d).
inline constexpr double kNuPhi = 0.153, kNuMu = 0.184;

// Viscosity near phi_J: the asymptotic exponent 1/b_phi and the effective exponents' range,
// from (1 - b_mu)/b_phi to 1/b_phi.
inline constexpr double kViscosityExponentLow = 1.67, kViscosityExponentHigh = 2.55;

// Soft granular rheology: phi_J(P) = phi_J(0) + c_phi P^x, mu_J(P) = mu_J(0) - c_mu P^y, and the
// yield stress's leading exponent 1/x.
inline constexpr double kX = 0.75, kY = 0.56, kYieldExponent = 1.33;

// Olsson–Teitel scaling as the paper tests it (Fig. 9): phi_J, alpha and beta.
inline constexpr double kTeitelPhiJ = 0.6474, kTeitelAlpha = 1.33, kTeitelBeta = 2.55;

// The ensemble comparison (Fig. 1): N = 1000 at gdot = 3.98e-9, constant pressure P = 1e-5
// against constant volume at phi = 0.643; the block std of the viscosity is about 5 times
// smaller at constant pressure, and the std of phi over runs about 3e-4.
inline constexpr double kEnsembleRate = 3.98e-9, kEnsemblePressure = 1e-5, kEnsemblePhi = 0.643;
inline constexpr double kEnsembleStdRatio = 5.0, kEnsemblePhiSpread = 3e-4;

}  // namespace jamflow::seed
