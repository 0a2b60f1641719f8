#include "sweep/mpi.hpp"

#include <cstdlib>
#include <cstring>
#include <optional>
#include <vector>

#include "lib/error.hpp"
#include "sweep/execute.hpp"

#ifdef JAMFLOW_HAVE_MPI
#include <mpi.h>
#endif

namespace jamflow::sweep {

bool mpi_available() {
#ifdef JAMFLOW_HAVE_MPI
  return true;
#else
  return false;
#endif
}

bool mpi_launched() {
  for (const char* var : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"}) {
    if (const char* v = std::getenv(var); v && std::atoi(v) > 1)
      return true;
  }
  return false;
}

int launched_rank() {
  for (const char* var : {"OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK"}) {
    if (const char* v = std::getenv(var))
      return std::atoi(v);
  }
  return 0;
}

#ifdef JAMFLOW_HAVE_MPI

namespace {

// Messages to rank 0 (each 3 long longs: task, state, wall ms): a finished task (no answer), a
// request for the next task (answered with kAssign: a task, or -1 for none left), and leaving.
constexpr int kReport = 1, kRequest = 2, kLeave = 3, kAssign = 4;

}  // namespace

int run_mpi(const Plan& plan, int jobs, bool quiet, const std::string& exe,
            const std::atomic<int>* stop, std::atomic<bool>* checkpoint) {
  MPI_Init(nullptr, nullptr);
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  SlotOptions so;
  so.slots = jobs;
  so.exe = exe;
  so.stop = stop;
  so.checkpoint = checkpoint;
  const std::vector<Task> tasks = plan.tasks();
  int status = 0;
  if (rank == 0) {
    int prepared = 1;
    std::string error;
    try {
      prepare_out_dir(plan);
    } catch (const std::exception& e) {
      prepared = 0;
      error = e.what();
    }
    MPI_Bcast(&prepared, 1, MPI_INT, 0, MPI_COMM_WORLD);
    if (!prepared) {
      MPI_Finalize();
      throw ConfigError(error);
    }
    Coordinator co(plan, {}, jobs * size, quiet);
    co.write_manifest();
    int active = size - 1;  // workers that have not left
    auto serve = [&] {
      while (true) {
        int flag = 0;
        MPI_Status st;
        MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &st);
        if (!flag)
          return;
        long long msg[3] = {-1, 0, 0};
        MPI_Recv(msg, 3, MPI_LONG_LONG, st.MPI_SOURCE, st.MPI_TAG, MPI_COMM_WORLD,
                 MPI_STATUS_IGNORE);
        if (st.MPI_TAG == kReport) {
          const auto t = static_cast<std::size_t>(msg[0]);
          const auto s = static_cast<TaskState>(msg[1]);
          co.finished(t, s, double(msg[2]) / 1000.0,
                      s == TaskState::kFailed ? "on rank " + std::to_string(st.MPI_SOURCE) +
                                                    "; see " + plan.task_log(tasks[t])
                                              : "");
        } else if (st.MPI_TAG == kLeave) {
          --active;
        } else if (st.MPI_TAG == kRequest) {
          long long next = -1;
          if (!(stop && stop->load() != 0)) {
            if (const auto t = co.take()) {
              next = static_cast<long long>(*t);
              co.started(*t);
            }
          }
          MPI_Send(&next, 1, MPI_LONG_LONG, st.MPI_SOURCE, kAssign, MPI_COMM_WORLD);
        }
      }
    };
    const int sig = run_slots(
        plan, tasks, so, [&] { return co.take(); }, [&](std::size_t t) { co.started(t); },
        [&](std::size_t t, TaskState s, double wall, const std::string& why) {
          co.finished(t, s, wall, why);
        },
        [&] {
          serve();
          co.tick();
        },
        [&] {
          serve();
          return active == 0;
        });
    co.write_manifest();
    co.final_line();
    status = sig != 0 ? 128 + sig : co.failed() > 0 ? 1 : 0;
  } else {
    int prepared = 0;
    MPI_Bcast(&prepared, 1, MPI_INT, 0, MPI_COMM_WORLD);
    if (!prepared) {
      MPI_Finalize();
      return 2;
    }
    auto take = [&]() -> std::optional<std::size_t> {
      long long ask[3] = {-1, 0, 0}, next = -1;
      MPI_Send(ask, 3, MPI_LONG_LONG, 0, kRequest, MPI_COMM_WORLD);
      MPI_Recv(&next, 1, MPI_LONG_LONG, 0, kAssign, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
      if (next < 0)
        return std::nullopt;
      return static_cast<std::size_t>(next);
    };
    const int sig = run_slots(
        plan, tasks, so, take, [](std::size_t) {},
        [&](std::size_t t, TaskState s, double wall, const std::string&) {
          long long msg[3] = {static_cast<long long>(t), static_cast<long long>(s),
                              static_cast<long long>(wall * 1000.0)};
          MPI_Send(msg, 3, MPI_LONG_LONG, 0, kReport, MPI_COMM_WORLD);
        },
        [] {});
    long long bye[3] = {-1, 0, 0};
    MPI_Send(bye, 3, MPI_LONG_LONG, 0, kLeave, MPI_COMM_WORLD);
    status = sig != 0 ? 128 + sig : 0;
  }
  MPI_Finalize();
  return status;
}

#else

int run_mpi(const Plan&, int, bool, const std::string&, const std::atomic<int>*,
            std::atomic<bool>*) {
  throw ConfigError(
      "this jamflow was built without MPI; allowed: a local sweep (install libopenmpi-dev and "
      "rebuild to farm over MPI ranks)");
}

#endif

}  // namespace jamflow::sweep
