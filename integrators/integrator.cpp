// Integrator factory and shared building blocks.
#include "integrators/integrator.hpp"

#include <cmath>

#include "integrators/euler.hpp"
#include "lib/error.hpp"

namespace jamflow {

void move_cell(State& state, double dstrain, double new_volume) {
  state.box.strain += dstrain;
  if (new_volume != state.box.volume())
    state.box.set_volume(new_volume);
}

void drift_particles(State& state, const std::vector<double>& force, double dt, int threads) {
  const std::size_t n = state.size();
  const Drift drift = Drift::of(state.box.h_inv(), dt / kXiS);
  double* x = state.x();
  double* y = state.y();
  double* z = state.z();
  const double* fx = force.data();
  const double* fy = fx + n;
  const double* fz = fx + 2 * n;
#pragma omp parallel for simd schedule(static) num_threads(threads) if (threads > 1)
  for (std::size_t i = 0; i < n; ++i)
    drift.apply(x[i], y[i], z[i], fx[i], fy[i], fz[i]);
}

std::unique_ptr<Integrator> make_euler(ConfigSection& section) {
  return std::make_unique<Euler>(section.number("dt", Range::positive()));
}

std::unique_ptr<Integrator> make_integrator(ConfigSection& section) {
  const std::string kind = section.choice("kind", {"euler", "respa", "cvode"});
  std::unique_ptr<Integrator> integ;
  if (kind == "euler") {
    integ = make_euler(section);
  } else if (kind == "respa") {
    integ = make_respa(section);
  } else {
    integ = make_cvode(section);
  }
  section.finish();
  return integ;
}

}  // namespace jamflow
