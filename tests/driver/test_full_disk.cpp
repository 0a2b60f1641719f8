// A run whose output cannot be written to the end (a full disk, a file-size limit): the
// process ends with a one-line error and exit status 1, never a crash in libhdf5's exit
// cleanup; the finished run is written to the temporary folder instead when it can be (and the
// message says where), else the message says exactly what is kept (OUT.part, the last
// checkpoint); no file that looks finished is left beside the output.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "lib/h5.hpp"
#include "tests/driver/temp_dir.hpp"

namespace jamflow {
namespace {

namespace fs = std::filesystem;

class TempDir : public testing_support::TempDir {
 public:
  TempDir() : testing_support::TempDir("jamflow-disk-") {}
};

// 31 001 samples: a final file of about 4.5 MB (the series twice, in /timeseries and in
// /checkpoint), while the first checkpoints take a few tens of kB.
std::string scene(const std::string& file) {
  return "[system]\nN = 200\nphi = 0.62\nseed = 3\n[ensemble]\nkind = \"constant_volume\"\n"
         "[shear]\nrate = 1e-3\n[integrator]\nkind = \"euler\"\ndt = 0.1\n[run]\nt_eq = 100.0\n"
         "t_av = 3000.0\nsample_every = 0.1\n[output]\nfile = \"" +
         file + "\"\ncheckpoint_every = 0.02\n";
}

std::size_t occurrences(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1))
    ++n;
  return n;
}

struct Ended {
  int exit_status = -1;  // -1: killed by a signal
  int signal = 0;
  std::string out, err;
};

std::string read_all(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Runs the command line with stdout and stderr to files, TMPDIR set, and optionally a limit on
// the size of any file it writes (SIGXFSZ ignored, so a write beyond it fails with EFBIG).
Ended run_cli(const std::vector<std::string>& args, const TempDir& dir, const std::string& tmpdir,
              rlim_t file_size_limit = RLIM_INFINITY) {
  const std::string out = dir.file("stdout"), err = dir.file("stderr");
  const pid_t pid = ::fork();
  if (pid == 0) {
    if (file_size_limit != RLIM_INFINITY) {
      ::signal(SIGXFSZ, SIG_IGN);
      const rlimit lim{file_size_limit, file_size_limit};
      ::setrlimit(RLIMIT_FSIZE, &lim);
    }
    ::setenv("TMPDIR", tmpdir.c_str(), 1);
    if (!std::freopen(out.c_str(), "w", stdout) || !std::freopen(err.c_str(), "w", stderr))
      ::_exit(99);
    std::vector<char*> argv;
    std::string exe = JAMFLOW_CLI;
    argv.push_back(exe.data());
    std::vector<std::string> copy = args;
    for (auto& a : copy)
      argv.push_back(a.data());
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(98);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  Ended e;
  if (WIFEXITED(status))
    e.exit_status = WEXITSTATUS(status);
  else if (WIFSIGNALED(status))
    e.signal = WTERMSIG(status);
  e.out = read_all(out);
  e.err = read_all(err);
  return e;
}

// A small tmpfs, unmounted at the end; not available without the right to mount.
class Tmpfs {
 public:
  Tmpfs(const std::string& path, const char* size) : path_(path) {
    fs::create_directories(path);
    const std::string options = std::string("size=") + size;
    if (::mount("tmpfs", path.c_str(), "tmpfs", 0, options.c_str()) == 0)
      mounted_ = true;
    else
      why_ = std::strerror(errno);
  }
  ~Tmpfs() {
    if (mounted_)
      ::umount2(path_.c_str(), MNT_DETACH);
  }
  bool mounted() const { return mounted_; }
  const std::string& why() const { return why_; }

 private:
  std::string path_, why_;
  bool mounted_ = false;
};

// Nothing beside the output looks finished: no OUT, no .final.xyz, no temporary left.
void expect_nothing_finished(const std::string& folder) {
  for (const auto& e : fs::directory_iterator(folder)) {
    const std::string name = e.path().filename().string();
    EXPECT_TRUE(name == "x.h5.part") << "left beside the output: " << name;
  }
}

TEST(FullDisk, FinalWriteFailsCleanlyAndTheRunIsWrittenElsewhere) {
  TempDir dir;
  const std::string disk = dir.file("disk"), tmp = dir.file("tmp");
  fs::create_directories(tmp);
  const Tmpfs small(disk, "2m");
  if (!small.mounted())
    GTEST_SKIP() << "cannot mount a 2 MB tmpfs here (" << small.why()
                 << "); FullDisk.FileSizeLimit covers a write that fails";
  const std::string out = disk + "/x.h5";
  std::ofstream(dir.file("x.toml")) << scene(out);
  const Ended e = run_cli({"run", dir.file("x.toml"), "-q"}, dir, tmp);
  EXPECT_EQ(e.signal, 0) << e.err;
  EXPECT_EQ(e.exit_status, 1) << e.err;
  // A checkpoint that did not fit was a warning; the run went on and printed its summary.
  EXPECT_NE(e.err.find("warning: checkpoint not written"), std::string::npos) << e.err;
  // Said once, however many are refused (they are retried at growing intervals).
  EXPECT_EQ(occurrences(e.err, "checkpoint not written:"), 1u) << e.err;
  EXPECT_NE(e.out.find("eta"), std::string::npos) << e.out;
  // The error names the place the finished run went to.
  const std::string marker = "the finished run is written to ";
  const auto at = e.err.find(marker);
  ASSERT_NE(at, std::string::npos) << e.err;
  const std::string kept =
      e.err.substr(at + marker.size(), e.err.find(' ', at + marker.size()) - at - marker.size());
  EXPECT_EQ(fs::path(kept).parent_path(), fs::path(tmp)) << kept;
  ASSERT_TRUE(fs::exists(kept)) << kept;
  {
    const H5Reader r(kept);
    EXPECT_EQ(r.attr_string("/", "status"), "complete");
    EXPECT_EQ(r.read_doubles("/timeseries/time").size(), 31001u);
    EXPECT_TRUE(std::isfinite(r.attr_double("/summary", "eta")));
  }
  expect_nothing_finished(disk);
  // The .part is a readable checkpoint of the same run.
  const H5Reader part(out + ".part");
  EXPECT_EQ(part.attr_string("/", "status"), "running");
}

TEST(FullDisk, FileSizeLimitEndsCleanlyAndSaysWhatIsKept) {
  TempDir dir;
  const std::string disk = dir.file("disk"), tmp = dir.file("tmp");
  fs::create_directories(disk);
  fs::create_directories(tmp);
  const std::string out = disk + "/x.h5";
  std::ofstream(dir.file("x.toml")) << scene(out);
  // 1 MB per file: the first checkpoints fit, the final file (here and in TMPDIR) does not.
  const Ended e = run_cli({"run", dir.file("x.toml"), "-q"}, dir, tmp, 1 << 20);
  EXPECT_EQ(e.signal, 0) << e.err;
  EXPECT_EQ(e.exit_status, 1) << e.err;
  EXPECT_NE(e.out.find("eta"), std::string::npos) << e.out;
  EXPECT_LE(occurrences(e.err, "checkpoint not written:"), 1u) << e.err;
  EXPECT_NE(e.err.find("could not be written elsewhere either, and only " + out +
                       ".part is kept: the last checkpoint"),
            std::string::npos)
      << e.err;
  expect_nothing_finished(disk);
  EXPECT_TRUE(fs::is_empty(tmp));
  const H5Reader part(out + ".part");
  EXPECT_EQ(part.attr_string("/", "status"), "running");
}

}  // namespace
}  // namespace jamflow
