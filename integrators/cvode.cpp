// CVODE (placeholder until the CVODE integrator lands).
#include "integrators/integrator.hpp"
#include "lib/error.hpp"

namespace jamflow {
std::unique_ptr<Integrator> make_cvode(ConfigSection&) {
  throw ConfigError("[integrator] kind = \"cvode\" is not available in this build");
}
}  // namespace jamflow
