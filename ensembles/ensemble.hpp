// Ensembles own the collective degrees of freedom of the cell: the imposed shear (tilt rate)
// and, at constant pressure, the piston's dV/dt. They never choose a time step.
#pragma once
#include <memory>
#include <optional>
#include <string>

#include "lib/attributes.hpp"
#include "lib/config.hpp"
#include "lib/model.hpp"

namespace jamflow {

class Ensemble {
 public:
  virtual ~Ensemble() = default;

  virtual std::string name() const = 0;  // the scene's `kind`
  double shear_rate() const { return shear_rate_; }

  // Whether the volume is a dynamical variable.
  virtual bool has_piston() const { return false; }
  // dV/dt for the given instantaneous pressure and volume (0 without a piston).
  virtual double volume_rate(double /*p_hat*/) const { return 0.0; }
  // d(dV/dt)/dP_hat at p_hat (the piston's entry of an integrator's Jacobian). Default: a
  // central difference of volume_rate() over 1e-4 of the pressure's scale (|p_hat|, else the
  // imposed pressure, else 1), for any law; a piston whose law has a closed-form slope
  // overrides it.
  virtual double volume_rate_slope(double p_hat) const;
  // xi_V (only with a piston).
  virtual double piston_friction() const { return 0.0; }
  // Power dissipated by the piston, xi_V (dV/dt)^2 (SPEC §3 energy balance).
  double piston_dissipation(double p_hat) const {
    const double vdot = volume_rate(p_hat);
    return has_piston() ? piston_friction() * vdot * vdot : 0.0;
  }
  // The pressure that defines mu and J: the imposed one, or none (then the measured P_hat).
  virtual std::optional<double> imposed_pressure() const { return std::nullopt; }

  // Ensemble-specific attributes of the output summary, appended to `out`.
  virtual void describe(Attributes& out) const;

 protected:
  explicit Ensemble(double shear_rate) : shear_rate_(shear_rate) {}

 private:
  double shear_rate_;
};

// Builds the ensemble named by [ensemble] kind, reading only that kind's keys.
// The kinds are those registered (ensembles/registry.hpp).
std::unique_ptr<Ensemble> make_ensemble(ConfigSection& section, double shear_rate);

}  // namespace jamflow
