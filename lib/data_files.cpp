// Installed data files, found relative to the binary (see data_files.hpp).
#include "lib/data_files.hpp"

#include <filesystem>
#include <mutex>

#ifndef JAMFLOW_BIN_TO_DATA
#define JAMFLOW_BIN_TO_DATA "../share/jamflow"
#endif

namespace jamflow {

namespace {
namespace fs = std::filesystem;

std::mutex root_mutex;
bool root_registered = false;
std::string registered_root;

// The installed data root next to the running binary, or empty.
std::string binary_root() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec)
    return {};
  const fs::path root = (exe.parent_path() / JAMFLOW_BIN_TO_DATA).lexically_normal();
  return fs::is_directory(root, ec) ? root.string() : std::string();
}

}  // namespace

void set_data_root(std::string root) {
  std::lock_guard<std::mutex> lock(root_mutex);
  root_registered = true;
  registered_root = std::move(root);
}

std::string data_dir(const std::string& relative, const std::string& source_dir) {
  std::string root;
  bool registered = false;
  {
    std::lock_guard<std::mutex> lock(root_mutex);
    std::error_code ec;
    registered = root_registered;
    if (registered && fs::is_directory(registered_root, ec))
      root = registered_root;
  }
  if (!registered)
    root = binary_root();
  if (root.empty())
    return source_dir;
  return (fs::path(root) / relative).string();
}

}  // namespace jamflow
