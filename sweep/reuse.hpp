// Reusing finished runs across sweeps: a replica whose scene is exactly the scene of a finished
// replica elsewhere (the same text: the same physics, seed and output name, hence the same
// bits from the same binary) is copied in instead of being run again. `jamflow study paper`
// uses it so that studies sharing state points run them once; `jamflow sweep --reuse DIR`
// offers it to any sweep.
#pragma once
#include <string>
#include <vector>

#include "sweep/plan.hpp"

namespace jamflow::sweep {

struct Reused {
  std::size_t replicas = 0;
  std::vector<std::string> sources;  // the run files copied, one per replica
};

// For every task of the plan that has no file yet, looks under `roots` (recursively, skipping
// the plan's own folder) for a finished r<k>.h5 whose r<k>.toml has the task's scene text, and
// copies it (and its scene and log) into the task's place, atomically. A root that does not
// exist is skipped.
Reused reuse_finished(const Plan& plan, const std::vector<std::string>& roots);

}  // namespace jamflow::sweep
