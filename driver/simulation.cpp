// A run under the caller's control (driver/simulation.hpp).
#include "driver/simulation.hpp"

#include <cmath>
#include <utility>

#include "lib/error.hpp"

namespace jamflow {

ModelOptions Simulation::model_options(const RunSpec& spec) {
  ModelOptions mo;
  mo.alpha = spec.alpha;
  mo.skin = spec.skin;
  mo.threads = spec.threads;
  return mo;
}

Simulation::Simulation(const RunSpec& spec, std::uint64_t seed)
    : spec_(spec),
      seed_(seed),
      model_(initial_state(spec, seed), model_options(spec)),
      integrator_(spec.make_integrator()),
      ensemble_(spec.ensemble) {
  t_start_ = model_.state().time;
}

Simulation::Simulation(const RunSpec& spec, std::uint64_t seed, State start,
                       const ModelOptions& options)
    : spec_(spec),
      seed_(seed),
      model_(std::move(start), options),
      integrator_(spec.make_integrator()),
      ensemble_(spec.ensemble) {
  t_start_ = model_.state().time;
}

bool Simulation::run(double sample_every, long long k_first,
                     const std::vector<LoopObserver*>& observers, std::atomic<bool>* attention) {
  const auto attend = [&] {
    if (attention)
      attention->store(false);
    bool stop = false;
    for (LoopObserver* o : observers)
      stop = o->attend(*this) || stop;
    return stop;
  };
  integrator_->set_interrupt(attention);
  struct Unset {
    Integrator& integrator;
    ~Unset() { integrator.set_interrupt(nullptr); }
  } unset{*integrator_};
  for (long long k = k_first;; ++k) {
    for (LoopObserver* o : observers)
      if (!o->proceed(*this, k))
        return true;
    const double t = double(k) * sample_every;
    const double t_end = t_start_ + t;
    integrator_->advance(model_, *ensemble_, t_end);
    while (model_.state().time < t_end) {
      // Interrupted between steps: attend, then go on to the same sample.
      if (attend())
        return false;
      integrator_->advance(model_, *ensemble_, t_end);
    }
    for (LoopObserver* o : observers)
      o->sampled(*this, k, t);
    if (attention && attention->load() && attend())
      return false;
  }
}

bool Simulation::advance_to(double t_end, const std::atomic<bool>* stop) {
  if (!(t_end >= time())) {
    throw ConfigError("time " + fmt(t_end) + " is before the simulation's time " + fmt(time()) +
                      "; allowed at least that");
  }
  integrator_->set_interrupt(stop);
  integrator_->advance(model_, *ensemble_, t_start_ + t_end);
  integrator_->set_interrupt(nullptr);
  return model_.state().time >= t_start_ + t_end;
}

Sample Simulation::sample() {
  const Evaluation& ev = model_.evaluate();
  const State& s = model_.state();
  return Sample{s.time - t_start_,
                s.box.strain,
                ev.volume,
                ev.phi,
                ev.pressure,
                ev.sigma_xy,
                ev.forces.energy,
                ev.dissipation,
                ensemble_->piston_dissipation(ev.pressure)};
}

std::vector<double> Simulation::forces() {
  const Evaluation& ev = model_.evaluate();
  const State& s = model_.state();
  const std::size_t n = s.size();
  // The force field's layout is that of the state: structure of arrays, memory order.
  std::vector<double> out(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto id = static_cast<std::size_t>(s.id[i]);
    for (std::size_t c = 0; c < 3; ++c)
      out[3 * id + c] = ev.forces.force[c * n + i];
  }
  return out;
}

void Simulation::set_shear_rate(double rate) {
  if (!(rate >= 0.0) || !std::isfinite(rate))
    throw ConfigError("[shear] rate = " + fmt(rate) + " is out of range; allowed >= 0");
  Scene scene = Scene::parse(spec_.scene_text, "the simulation's scene");
  scene.set_value("shear.rate", toml::value<double>(rate));
  ConfigSection section = scene.section("ensemble");
  ensemble_ = make_ensemble(section, rate);
  spec_.shear_rate = rate;
  spec_.ensemble = ensemble_;
  spec_.scene_text = scene.text();
  integrator_->reset();
}

std::vector<std::pair<std::string, double>> Simulation::statistics() const {
  auto stats = integrator_->statistics();
  stats.emplace_back("force_evaluations", double(model_.force_evaluations()));
  stats.emplace_back("neighbour_list_builds", double(model_.list_builds()));
  return stats;
}

}  // namespace jamflow
