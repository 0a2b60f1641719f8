// A sweep farmed over MPI ranks (`mpirun -n R jamflow sweep SWEEP.toml`): rank 0 keeps the
// bookkeeping and hands out tasks one at a time, expected-longest first, to whichever rank asks
// (dynamic load balancing); every rank, rank 0 included, runs its tasks as `jamflow run` child
// processes exactly as a local sweep does, so each point's file is the same bits.
#pragma once
#include <atomic>
#include <string>

#include "sweep/plan.hpp"

namespace jamflow::sweep {

// True when this build has MPI.
bool mpi_available();
// True when this process was started by an MPI launcher with more than one rank (Open MPI's
// OMPI_COMM_WORLD_SIZE, or PMI_SIZE / PMIX_SIZE), so `jamflow sweep` should farm over ranks.
bool mpi_launched();
// This process's rank as the launcher's environment gives it (0 when not launched by one).
int launched_rank();

// Runs the sweep over MPI_COMM_WORLD with `jobs` tasks at a time per rank. Returns this rank's
// exit status (rank 0: 0 all done, 1 some failed, 128 + signal when stopped).
int run_mpi(const Plan& plan, int jobs, bool quiet, const std::string& exe,
            const std::atomic<int>* stop, std::atomic<bool>* checkpoint);

}  // namespace jamflow::sweep
