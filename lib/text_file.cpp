#include "lib/text_file.hpp"

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "lib/error.hpp"

namespace jamflow {

void write_text_atomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    out.flush();
    if (!out)
      throw IoError("cannot write '" + tmp + "'");
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec)
    throw IoError("cannot rename '" + tmp + "' to '" + path + "': " + ec.message());
}

}  // namespace jamflow
