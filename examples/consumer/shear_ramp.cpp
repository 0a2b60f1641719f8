// A protocol jamflow's run driver does not have, written against the installed library: the
// default scene, made small, sheared at three rates in turn; the stress after each stage.
#include <cstdio>
#include <exception>

#include "driver/run.hpp"
#include "driver/simulation.hpp"
#include "lib/config.hpp"
#include "lib/error.hpp"

int main() {
  try {
    jamflow::Scene scene = jamflow::Scene::parse(jamflow::kDefaultScene, "the default scene");
    scene.set("system.N=64");
    scene.set("run.t_eq=0");
    scene.set("run.t_av=20");
    const jamflow::RunSpec spec = jamflow::parse_run_spec(scene);
    jamflow::Simulation sim(spec, spec.seed);
    for (const double rate : {1e-2, 3e-3, 1e-3}) {
      sim.set_shear_rate(rate);
      sim.advance_to(sim.time() + 20.0);
      const jamflow::Sample s = sim.sample();
      std::printf("gdot %.0e  t %.1f  strain %.4f  phi %.4f  sigma_xy %.4e  P %.4e\n", rate, s.time,
                  s.strain, s.phi, s.sigma_xy, s.pressure);
    }
    return 0;
  } catch (const jamflow::ConfigError& e) {
    std::fprintf(stderr, "shear_ramp: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "shear_ramp: error: %s\n", e.what());
    return 1;
  }
}
