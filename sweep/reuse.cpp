#include "sweep/reuse.hpp"

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <system_error>

#include "driver/checkpoint.hpp"
#include "lib/text_file.hpp"
#include "sweep/execute.hpp"

namespace jamflow::sweep {
namespace fs = std::filesystem;
namespace {

std::string read_all(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream buf;
  buf << in.rdbuf();
  return buf.str();
}

// Copies `from` to `to` through a temporary file renamed into place: a reader never sees a
// half-copied run file.
void copy_atomically(const fs::path& from, const fs::path& to) {
  const fs::path tmp = to.string() + ".reuse.tmp";
  fs::copy_file(from, tmp, fs::copy_options::overwrite_existing);
  fs::rename(tmp, to);
}

bool inside(const fs::path& path, const fs::path& dir) {
  const std::string p = fs::weakly_canonical(path).string(), d = fs::weakly_canonical(dir).string();
  return p.size() >= d.size() && p.compare(0, d.size(), d) == 0 &&
         (p.size() == d.size() || p[d.size()] == '/');
}

}  // namespace

Reused reuse_finished(const Plan& plan, const std::vector<std::string>& roots) {
  Reused out;
  // The tasks still to run, by their scene text.
  std::multimap<std::string, Task> wanted;
  for (const Task& t : plan.tasks()) {
    std::error_code ec;
    const std::string file = plan.task_file(t);
    if (!fs::exists(file, ec) && !fs::exists(file + ".part", ec))
      wanted.emplace(plan.task_scene(t).text(), t);
  }
  if (wanted.empty())
    return out;
  static const std::regex kTaskScene(R"(r[0-9]+\.toml)");
  for (const auto& root : roots) {
    std::error_code ec;
    if (!fs::is_directory(root, ec))
      continue;
    for (auto it = fs::recursive_directory_iterator(
             root, fs::directory_options::skip_permission_denied, ec);
         it != fs::recursive_directory_iterator(); it.increment(ec)) {
      if (ec)
        break;
      if (it->is_directory() && inside(it->path(), plan.out_dir)) {
        it.disable_recursion_pending();  // the plan's own folder
        continue;
      }
      const fs::path scene = it->path();
      if (!std::regex_match(scene.filename().string(), kTaskScene))
        continue;
      // Compared as scenes, not bytes: a file written before floats were printed in their
      // shortest form (dt = 0.10000000000000001) holds the same scene as dt = 0.1.
      const auto range = wanted.equal_range(canonical_scene_text(read_all(scene)));
      if (range.first == range.second)
        continue;
      fs::path run = scene;
      run.replace_extension(".h5");
      if (!fs::exists(run) || !read_run_status(run.string()).is_complete())
        continue;
      for (auto w = range.first; w != range.second; ++w) {
        const Task& t = w->second;
        const fs::path dest = plan.task_file(t);
        fs::create_directories(dest.parent_path());
        fs::path log = scene;
        log.replace_extension(".log");
        fs::path dest_scene = dest;
        dest_scene.replace_extension(".toml");
        write_text_atomically(dest_scene.string(), w->first);
        std::string log_text = fs::exists(log) ? read_all(log) : std::string();
        log_text += "reused: this replica is a copy of " + fs::absolute(run).string() +
                    ", which ran the same scene\n";
        write_text_atomically(plan.task_log(t), log_text);
        copy_atomically(run, dest);
        ++out.replicas;
        out.sources.push_back(run.string());
      }
      wanted.erase(range.first, range.second);
      if (wanted.empty())
        return out;
    }
  }
  return out;
}

}  // namespace jamflow::sweep
