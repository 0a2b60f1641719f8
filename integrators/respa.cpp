// RESPA (placeholder until the RESPA integrator lands).
#include "integrators/integrator.hpp"
#include "lib/error.hpp"

namespace jamflow {
std::unique_ptr<Integrator> make_respa(ConfigSection&) {
  throw ConfigError("[integrator] kind = \"respa\" is not available in this build");
}
}  // namespace jamflow
