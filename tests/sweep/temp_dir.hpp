// A fresh folder for a sweep test (mkdtemp under the temporary directory, named by `prefix`),
// removed at the end.
#pragma once
#include <stdlib.h>

#include <filesystem>
#include <string>

namespace jamflow::sweep::testing_support {

struct TempDir {
  std::filesystem::path path;
  explicit TempDir(const std::string& prefix = "jamflow-sweep-test") {
    std::string t = (std::filesystem::temp_directory_path() / (prefix + "-XXXXXX")).string();
    path = ::mkdtemp(t.data());
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
};

}  // namespace jamflow::sweep::testing_support
