// Provenance written into every output file and printed by `jamflow --version`.
#pragma once

namespace jamflow {

// The commit the binary was built from (12 hex digits, "-dirty" when tracked files differed
// from it, "unknown" outside a git checkout). Generated at build time (cmake/git_commit.cmake).
const char* git_commit();

}  // namespace jamflow
