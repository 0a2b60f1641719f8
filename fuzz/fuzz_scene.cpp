// Scene TOML: Scene::parse and parse_run_spec on arbitrary text. ConfigError and IoError (an
// init file that does not exist) are the expected outcomes of bad input; anything else
// escaping, a crash, a sanitizer report, a hang or a leak is a finding.
#include <cstdint>
#include <string_view>

#include "driver/run.hpp"
#include "lib/config.hpp"
#include "lib/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const jamflow::Scene scene = jamflow::Scene::parse(text, "fuzz.toml");
    (void)scene.text();
    const jamflow::RunSpec spec = jamflow::parse_run_spec(scene);
    (void)spec.make_integrator();
  } catch (const jamflow::ConfigError&) {
  } catch (const jamflow::IoError&) {
  }
  return 0;
}
