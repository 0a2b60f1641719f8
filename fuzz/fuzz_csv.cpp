// CSV tables of `jamflow analyze`: both readers (granular and flow-curve) on arbitrary bytes.
// InputError is the expected outcome of bad input; anything else is a finding.
#include <cstdint>

#include "analysis/data.hpp"
#include "analysis/errors.hpp"
#include "fuzz/fuzz_input_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // A leading HDF5 signature would send the readers to the HDF5 path (fuzz_hdf5's job).
  if (size >= 1 && data[0] == 0x89)
    return -1;
  const std::string& path = jamflow::fuzz::write_input(data, size, ".csv");
  try {
    (void)jamflow::analysis::read_granular({path});
  } catch (const jamflow::analysis::InputError&) {
  }
  try {
    (void)jamflow::analysis::read_shear({path});
  } catch (const jamflow::analysis::InputError&) {
  }
  return 0;
}
