// Writing a text file so that a reader sees the old file or the new one whole, never a part.
#pragma once
#include <string>

namespace jamflow {

// Writes `text` to a temporary in the same folder (named by the process id, so processes
// writing the same file at once do not collide) and renames it to `path`. IoError on failure.
void write_text_atomically(const std::string& path, const std::string& text);

}  // namespace jamflow
