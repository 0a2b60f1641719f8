// RESPA: Strang splitting of the collective (cell) and particle flows; see respa.hpp.
#include "integrators/respa.hpp"

#include <algorithm>
#include <cmath>

#include "integrators/motion.hpp"
#include "integrators/registry.hpp"
#include "lib/error.hpp"

namespace jamflow {

namespace {

int scheme_order(RespaOptions::Scheme s) {
  return s == RespaOptions::Scheme::kHeun ? 2 : 1;
}

// Force passes of one sub-step of a level that evaluates forces.
double scheme_passes(RespaOptions::Scheme s) {
  return s == RespaOptions::Scheme::kHeun ? 2.0 : 1.0;
}

RespaOptions::Scheme parse_scheme(const std::string& s) {
  return s == "heun" ? RespaOptions::Scheme::kHeun : RespaOptions::Scheme::kEuler;
}

}  // namespace

Respa::Respa(const RespaOptions& options) : options_(options) {
  if (!(options.dt > 0.0) || !std::isfinite(options.dt))
    throw ConfigError("[integrator] dt = " + fmt(options.dt) + "; allowed > 0");
  if (options.n_inner < 1)
    throw ConfigError("[integrator] n_inner = " + std::to_string(options.n_inner) +
                      "; allowed an integer >= 1");
}

int Respa::order() const {
  return std::min({2, scheme_order(options_.inner_scheme), scheme_order(options_.outer_scheme)});
}

int Respa::order(const Ensemble& ensemble) const {
  if (ensemble.has_piston())
    return order();
  // Without a piston the collective level is exact: only the particle level's scheme counts.
  const bool particles_inner = options_.inner == RespaOptions::Level::kParticles;
  return std::min(2, scheme_order(particles_inner ? options_.inner_scheme : options_.outer_scheme));
}

double Respa::force_passes_per_time(const Ensemble& ensemble) const {
  // A particle level always evaluates forces; a collective level only with a piston (the
  // virial of its state). One pass per Euler sub-step, two per Heun sub-step. The inner level
  // takes n_inner sub-steps per step, the outer level two half-steps.
  const bool particles_inner = options_.inner == RespaOptions::Level::kParticles;
  const bool inner_costs = particles_inner || ensemble.has_piston();
  const bool outer_costs = !particles_inner || ensemble.has_piston();
  const double inner =
      inner_costs ? double(options_.n_inner) * scheme_passes(options_.inner_scheme) : 0.0;
  const double outer = outer_costs ? 2.0 * scheme_passes(options_.outer_scheme) : 0.0;
  return (inner + outer) / options_.dt;
}

void Respa::step(Model& model, const StateEquation& motion, double h) {
  const int n = options_.n_inner;
  const double hi = h / double(n);
  // The split: the particle field S and the cell field C of the one equation of motion
  // (integrators/motion.hpp), each stepped with its level's scheme.
  const auto particles = [&](Scheme scheme, double dt) {
    motion.particle_step(model, scheme, dt, force0_);
  };
  const auto cell = [&](Scheme scheme, double dt) { motion.cell_step(model, scheme, dt); };
  if (options_.inner == RespaOptions::Level::kParticles) {
    cell(options_.outer_scheme, 0.5 * h);
    for (int k = 0; k < n; ++k)
      particles(options_.inner_scheme, hi);
    cell(options_.outer_scheme, 0.5 * h);
  } else {
    particles(options_.outer_scheme, 0.5 * h);
    for (int k = 0; k < n; ++k)
      cell(options_.inner_scheme, hi);
    particles(options_.outer_scheme, 0.5 * h);
  }
  inner_steps_ += n;
}

void Respa::advance(Model& model, const Ensemble& ensemble, double t_end) {
  const double dt = options_.dt;
  const StateEquation motion(ensemble);
  // As in Euler: the last step is shortened to land exactly on t_end, and a remainder below
  // 1e-9 dt is absorbed into the previous step.
  while (model.state().time < t_end && !interrupted()) {
    model.prepare_step();  // no history to drop: every step starts from the state alone
    const double t = model.state().time;
    const double h = (t_end - t <= dt * (1.0 + 1e-9)) ? t_end - t : dt;
    step(model, motion, h);
    model.set_time(h == dt ? t + h : t_end);
    ++steps_;
  }
}

std::vector<std::pair<std::string, double>> Respa::statistics() const {
  return {{"steps", double(steps_)}, {"inner_steps", double(inner_steps_)}};
}

std::unique_ptr<Integrator> make_respa(ConfigSection& section) {
  RespaOptions o;
  o.dt = section.number("dt", Range::positive());
  o.n_inner = static_cast<int>(section.integer("n_inner", 4, 1, 100000));
  o.inner = section.choice("inner", "particles", {"particles", "piston"}) == "piston"
                ? RespaOptions::Level::kPiston
                : RespaOptions::Level::kParticles;
  const std::string inner_scheme = section.choice("inner_scheme", "euler", {"euler", "heun"});
  o.inner_scheme = parse_scheme(inner_scheme);
  o.outer_scheme = parse_scheme(section.choice("outer_scheme", inner_scheme, {"euler", "heun"}));
  return std::make_unique<Respa>(o);
}

namespace {
const IntegratorRegistrar registrar{"respa", make_respa,
                                    "RESPA splitting, order 1 or 2 (dt, n_inner, inner, ...)"};
}  // namespace

}  // namespace jamflow
