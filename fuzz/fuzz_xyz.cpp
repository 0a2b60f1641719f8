// Extended XYZ reader on arbitrary bytes. ConfigError is the expected outcome of bad input;
// anything else escaping, a crash, a sanitizer report, a hang or a leak is a finding.
#include <cstdint>

#include "fuzz/fuzz_input_file.hpp"
#include "lib/error.hpp"
#include "lib/xyz.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = jamflow::fuzz::write_input(data, size, ".xyz");
  try {
    const jamflow::State s = jamflow::read_xyz(path);
    // What a run does next with an accepted file.
    (void)s.packing_fraction();
  } catch (const jamflow::ConfigError&) {
  }
  return 0;
}
