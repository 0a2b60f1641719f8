// The studies run their points as `jamflow run` child processes (the sweep engine): tests that
// run a study from the test binary point the engine at the jamflow binary of this build, and
// check that a rerun finds the point files instead of computing them again.
#pragma once
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>

inline void use_test_jamflow() {
  ::setenv("JAMFLOW_EXE", JAMFLOW_TEST_EXE, 1);
}

// Every run file of a study's points (OUT/<stage>/runs/points/<name>/r<k>.h5[.part]) with its
// modification time.
inline std::map<std::string, std::filesystem::file_time_type> point_files(const std::string& out) {
  namespace fs = std::filesystem;
  std::map<std::string, fs::file_time_type> files;
  for (const auto& e : fs::recursive_directory_iterator(out)) {
    const std::string p = e.path().string();
    if (e.is_regular_file() && p.find("/runs/points/") != std::string::npos &&
        (p.ends_with(".h5") || p.ends_with(".h5.part")))
      files[p] = e.last_write_time();
  }
  return files;
}
