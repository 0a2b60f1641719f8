// Constant pressure under steady shear (NPgdot) with a Kolb–Dünweg piston (SPEC §2):
//   xi_V dV/dt = P_hat - P
// (the seed prints the opposite sign, which is unstable). The cell dilates isotropically and
// particles follow affinely; the strain is preserved.
#pragma once
#include <memory>

#include "ensembles/ensemble.hpp"

namespace jamflow {

class ConstantPressure final : public Ensemble {
 public:
  ConstantPressure(double shear_rate, double pressure, double xi_v);
  std::string name() const override { return "constant_pressure"; }
  bool has_piston() const override { return true; }
  double volume_rate(double p_hat) const override { return (p_hat - pressure_) / xi_v_; }
  // The law is affine, so its slope 1 / xi_V is that of any secant. It is taken over [0, 1]
  // (equal to 1 / xi_V up to rounding), the form CVODE's Jacobian has always used, so that
  // CVODE's runs keep their bits.
  double volume_rate_slope(double /*p_hat*/) const override {
    return volume_rate(1.0) - volume_rate(0.0);
  }
  double piston_friction() const override { return xi_v_; }
  std::optional<double> imposed_pressure() const override { return pressure_; }
  void describe(Attributes& out) const override;

  double pressure() const { return pressure_; }

 private:
  double pressure_;
  double xi_v_;
};

// Reads [ensemble] pressure (> 0) and xi_V (> 0, default 1e-4, the seed's value).
std::unique_ptr<Ensemble> make_constant_pressure(ConfigSection& section, double shear_rate);

}  // namespace jamflow
