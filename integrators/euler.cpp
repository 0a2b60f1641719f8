// Explicit Euler.
#include "integrators/euler.hpp"

#include "integrators/registry.hpp"
#include "lib/error.hpp"

namespace jamflow {

Euler::Euler(double dt) : dt_(dt) {
  if (!(dt > 0.0))
    throw ConfigError("[integrator] dt = " + fmt(dt) + "; allowed > 0");
}

void Euler::advance(Model& model, const Ensemble& ensemble, double t_end) {
  // The last step is shortened to land exactly on t_end; a remainder below 1e-9 dt is
  // absorbed into the previous step rather than taken as a tiny step.
  while (model.state().time < t_end && !interrupted()) {
    model.prepare_step();
    const double t = model.state().time;
    const double h = (t_end - t <= dt_ * (1.0 + 1e-9)) ? t_end - t : dt_;
    if (!ensemble.has_piston()) {
      // The new cell does not depend on this step's forces: the drift is asked of the force
      // backend as part of its pass (the same bits as the sequence below).
      Box next = model.state().box;
      next.strain += ensemble.shear_rate() * h;
      model.evaluate_and_drift(Drift::of(next.h_inv(), h / kXiS), next);
    } else {
      const Evaluation& ev = model.evaluate();
      const double v_new = model.state().box.volume() + h * ensemble.volume_rate(ev.pressure);
      model.modify([&](State& s) {
        move_cell(s, ensemble.shear_rate() * h, v_new);
        // Forces of the old configuration, displacement mapped with the new cell: r advances by
        // exactly dt F / xi_s on top of the affine flow.
        drift_particles(s, ev.forces.force, h, model.force_field().threads());
      });
    }
    model.set_time(h == dt_ ? t + h : t_end);
    ++steps_;
  }
}

double Euler::force_passes_per_time(const Ensemble& /*ensemble*/) const {
  return 1.0 / dt_;
}

std::vector<std::pair<std::string, double>> Euler::statistics() const {
  return {{"steps", double(steps_)}};
}

std::unique_ptr<Integrator> make_euler(ConfigSection& section) {
  return std::make_unique<Euler>(section.number("dt", Range::positive()));
}

namespace {
const IntegratorRegistrar registrar{"euler", make_euler, "explicit Euler, first order (dt)"};
}  // namespace

}  // namespace jamflow
