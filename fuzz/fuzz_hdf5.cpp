// HDF5 run files of `jamflow analyze`: the fuzz input written to a file and opened by both
// table readers (each reads the run summary, then checks it for its analyses). InputError is the
// expected outcome of bad input; anything else is a finding.
#include <cstdint>
#include <cstdlib>

#include "analysis/data.hpp"
#include "analysis/errors.hpp"
#include "fuzz/fuzz_input_file.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  setenv("HDF5_USE_FILE_LOCKING", "FALSE", 1);  // scratch file, one reader
  // libhdf5 in this process, not in the child that jamflow analyze reads each file in: the
  // fuzzer needs the reader's coverage, and a sanitizer report there is a finding.
  jamflow::analysis::set_hdf5_isolation(jamflow::analysis::Hdf5Isolation::kInProcess);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = jamflow::fuzz::write_input(data, size, ".h5");
  try {
    (void)jamflow::analysis::read_shear({path});
  } catch (const jamflow::analysis::InputError&) {
  }
  try {
    (void)jamflow::analysis::read_granular({path});
  } catch (const jamflow::analysis::InputError&) {
  }
  return 0;
}
