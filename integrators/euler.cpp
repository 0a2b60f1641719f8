// Explicit Euler.
#include "integrators/euler.hpp"

#include "integrators/motion.hpp"
#include "integrators/registry.hpp"
#include "lib/error.hpp"

namespace jamflow {

Euler::Euler(double dt) : dt_(dt) {
  if (!(dt > 0.0))
    throw ConfigError("[integrator] dt = " + fmt(dt) + "; allowed > 0");
}

void Euler::advance(Model& model, const Ensemble& ensemble, double t_end) {
  const StateEquation motion(ensemble);
  // The last step is shortened to land exactly on t_end; a remainder below 1e-9 dt is
  // absorbed into the previous step rather than taken as a tiny step.
  while (model.state().time < t_end && !interrupted()) {
    model.prepare_step();
    const double t = model.state().time;
    const double h = (t_end - t <= dt_ * (1.0 + 1e-9)) ? t_end - t : dt_;
    motion.euler_step(model, h);
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
