#include "sweep/plan.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "driver/run.hpp"
#include "lib/error.hpp"

namespace jamflow::sweep {
namespace fs = std::filesystem;

namespace {

// Keys the sweep sets itself for every task.
const std::set<std::string> kManagedKeys = {"output.file", "run.replicas", "run.threads"};

std::string value_text(const toml::node& v) {
  if (const auto* d = v.as_floating_point())
    return fmt(d->get());
  if (const auto* i = v.as_integer())
    return std::to_string(i->get());
  if (const auto* s = v.as_string())
    return s->get();
  if (const auto* b = v.as_boolean())
    return b->get() ? "true" : "false";
  if (const auto* t = v.as_table()) {
    std::string out;
    for (const auto& [k, x] : *t)
      out.append(out.empty() ? "" : "_").append(k.str()).append(value_text(x));
    return out;
  }
  return "?";
}

// A value as it may appear in a file name: letters, digits and . + - kept, others '_'.
std::string name_part(const std::string& s) {
  std::string out;
  for (char c : s) {
    const bool keep = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                      c == '.' || c == '+' || c == '-';
    out += keep ? c : '_';
  }
  return out;
}

struct Axis {
  std::string key;
  std::vector<const toml::node*> values;
};

// The axes of [sweep.grid] or [sweep.zip]: "section.key" = [values], or nested tables
// [sweep.grid.section] key = [values]. A grid's values must be distinct.
std::vector<Axis> read_axes(const toml::table& table, const std::string& where, bool distinct) {
  std::vector<Axis> axes;
  auto add = [&](const std::string& key, const toml::node& node) {
    const auto* arr = node.as_array();
    if (!arr || arr->empty()) {
      throw ConfigError(where + " \"" + key + "\": allowed a non-empty list of values");
    }
    // A key without a dot names a whole section, replaced by each value (an inline table):
    // how points differ in the keys a section has, e.g. integrator = [{kind = "respa", dt = 1.0},
    // {kind = "cvode", rtol = 1e-5}].
    const bool section = key.find('.') == std::string::npos;
    if (section && (key == "output" || key == "run"))
      throw ConfigError(where + " \"" + key + "\": the sweep sets keys of [" + key +
                        "]; allowed its other keys one by one (\"" + key + ".KEY\")");
    if (!section && (key.front() == '.' || key.back() == '.'))
      throw ConfigError(where + " \"" + key + "\": allowed a scene key section.key");
    if (kManagedKeys.count(key)) {
      throw ConfigError(where + " \"" + key +
                        "\": set by the sweep for each task; allowed any other scene key "
                        "([sweep] replicas gives the replica count)");
    }
    Axis a{key, {}};
    std::set<std::string> seen;
    for (const auto& v : *arr) {
      if (section ? !v.is_table() : !(v.is_number() || v.is_string() || v.is_boolean())) {
        throw ConfigError(where + " \"" + key +
                          (section ? "\": allowed inline tables {key = value, ...} in the list "
                                     "(a whole section)"
                                   : "\": allowed numbers, strings or booleans in the list"));
      }
      if (distinct && !seen.insert(value_text(v)).second) {
        throw ConfigError(where + " \"" + key + "\": value " + value_text(v) +
                          " appears twice; allowed distinct values");
      }
      a.values.push_back(&v);
    }
    axes.push_back(std::move(a));
  };
  for (const auto& [k, v] : table) {
    const std::string key(k.str());
    if (const auto* sub = v.as_table()) {
      for (const auto& [k2, v2] : *sub) {
        if (v2.is_table())
          throw ConfigError(where + " \"" + key + "." + std::string(k2.str()) +
                            "\": allowed a scene key section.key");
        add(key + "." + std::string(k2.str()), v2);
      }
    } else {
      add(key, v);
    }
  }
  return axes;
}

// A relative `system.init` path is made absolute against `dir` (where the scene that named
// it lives), so that a task finds its start wherever it runs.
void anchor_init(Scene& scene, const fs::path& dir) {
  const toml::table* sys = scene.table("system");
  if (!sys)
    return;
  const toml::node* init = sys->get("init");
  if (!init || !init->is_string())
    return;
  const fs::path p(init->as_string()->get());
  if (p.empty() || p.is_absolute())
    return;
  scene.set_value("system.init", toml::value<std::string>((dir / p).lexically_normal().string()));
}

}  // namespace

Scene load_base_scene(const toml::node* file_key, const toml::table* inline_scene,
                      const std::string& dir, const std::string& source,
                      const std::string& file_key_name, const std::string& inline_name,
                      const std::string& relative_to) {
  const fs::path base(dir.empty() ? "." : dir);
  Scene scene;
  if (file_key) {
    if (!file_key->is_string())
      throw ConfigError(source + ": " + file_key_name + " must be a file name (a string)");
    fs::path p(file_key->as_string()->get());
    if (p.is_relative())
      p = base / p;
    try {
      scene = Scene::load(p.lexically_normal().string());
    } catch (const InputFileError& e) {
      throw ConfigError(source + ": " + file_key_name + " = \"" + file_key->as_string()->get() +
                        "\" (relative to " + relative_to + "): " + e.what());
    }
    anchor_init(scene, p.parent_path());
  } else if (inline_scene) {
    std::ostringstream os;
    os << *inline_scene << "\n";
    scene = Scene::parse(os.str(), source + " " + inline_name);
    anchor_init(scene, base);
  } else {
    throw ConfigError(source + ": no base scene; allowed " + file_key_name + " = \"FILE\" or a " +
                      inline_name + " table");
  }
  return scene;
}

namespace {

// Expected CPU seconds of one replica: N x (t_eq + t_av, or max_time) x the integrator's
// measured CPU seconds per particle and unit time (Integrator::cpu_seconds_per_particle_time)
// at the run's imposed pressure and shear rate; 1e-4 stands in for the pressure at constant
// volume, where it is known only once the run ran. At most the run's budget: N x [run]
// max_force_evaluations force passes at kCpuSecondsPerParticlePass.
double expected_cost(const RunSpec& spec) {
  const double n = spec.init_state ? double(spec.init_state->size()) : double(spec.n);
  const double length = spec.auto_av ? spec.max_time : spec.t_eq + spec.t_av;
  Integrator::CostPoint at;
  at.pressure = spec.ensemble->imposed_pressure().value_or(1e-4);
  at.shear_rate = spec.shear_rate;
  at.alpha = spec.alpha;
  const double cost =
      n * length * spec.make_integrator()->cpu_seconds_per_particle_time(*spec.ensemble, at);
  return spec.max_force_evaluations > 0
             ? std::min(cost, n * double(spec.max_force_evaluations) * kCpuSecondsPerParticlePass)
             : cost;
}

}  // namespace

std::string Plan::point_dir(const Point& p) const {
  return (fs::path(out_dir) / "points" / p.name).string();
}
std::string Plan::task_stem(const Task& t) {
  std::string s = "r";
  return s.append(std::to_string(t.replica));
}
std::string Plan::task_file(const Task& t) const {
  return (fs::path(point_dir(points[t.point])) / (task_stem(t) + ".h5")).string();
}
std::string Plan::task_log(const Task& t) const {
  return (fs::path(point_dir(points[t.point])) / (task_stem(t) + ".log")).string();
}
std::string Plan::scene_file(const Point& p) const {
  return (fs::path(point_dir(p)) / "scene.toml").string();
}

Scene Plan::task_scene(const Task& t) const {
  Scene s = points[t.point].scene;
  // Relative to the point's folder, where the task runs (execute.cpp).
  s.set_value("output.file", toml::value<std::string>(task_stem(t) + ".h5"));
  s.set_value("system.seed", toml::value<std::int64_t>(static_cast<std::int64_t>(t.seed)));
  s.set_value("run.replicas", toml::value<std::int64_t>(1));
  s.set_value("run.threads", toml::value<std::int64_t>(1));
  return s;
}

std::vector<Task> Plan::tasks() const {
  std::vector<Task> out;
  for (const auto& p : points) {
    const toml::table* sys = p.scene.table("system");
    const toml::node* seed_node = sys ? sys->get("seed") : nullptr;
    const std::int64_t seed =
        seed_node && seed_node->is_integer() ? seed_node->as_integer()->get() : 1;
    for (std::int64_t k = 0; k < replicas; ++k)
      out.push_back({p.index, k, static_cast<std::uint64_t>(seed + k), p.cost});
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const Task& a, const Task& b) { return a.cost > b.cost; });
  return out;
}

namespace {

// The expansion of a [sweep] table's replicas, grid, zip, names_from and names over the base
// `scene` into plan.replicas, plan.axes and plan.points, each point checked as `jamflow run`
// checks a scene: one for sweep files (parse_plan) and plans built in code (make_plan). Errors
// name `source`; a relative system.init among the values is taken relative to `base`.
void expand(Plan& plan, const Scene& scene, const toml::table& sw, const std::string& source,
            const fs::path& base) {
  // Replicas: [sweep] replicas, else the scene's [run] replicas, else 1.
  plan.replicas = 1;
  if (const toml::table* run = scene.table("run")) {
    if (const toml::node* r = run->get("replicas"); r && r->is_integer())
      plan.replicas = r->as_integer()->get();
  }
  if (const toml::node* r = sw.get("replicas")) {
    if (!r->is_integer() || r->as_integer()->get() < 1 || r->as_integer()->get() > 10000) {
      throw ConfigError(source + ": [sweep] replicas = " + value_text(*r) +
                        "; allowed an integer in [1, 10000]");
    }
    plan.replicas = r->as_integer()->get();
  }

  std::vector<Axis> grid, zip;
  if (const toml::node* g = sw.get("grid")) {
    if (!g->is_table())
      throw ConfigError(source + ": [sweep] grid must be a table [sweep.grid]");
    grid = read_axes(*g->as_table(), source + ": [sweep.grid]", true);
  }
  if (const toml::node* z = sw.get("zip")) {
    if (!z->is_table())
      throw ConfigError(source + ": [sweep] zip must be a table [sweep.zip]");
    // A zip's lists may repeat values (points are told apart by all of them together).
    zip = read_axes(*z->as_table(), source + ": [sweep.zip]", false);
    for (const auto& a : zip) {
      if (a.values.size() != zip.front().values.size()) {
        throw ConfigError(source + ": [sweep.zip] \"" + a.key + "\" has " +
                          std::to_string(a.values.size()) + " values and \"" + zip.front().key +
                          "\" has " + std::to_string(zip.front().values.size()) +
                          "; allowed lists of equal length");
      }
    }
  }
  std::set<std::string> keys;
  for (const auto* axes : {&grid, &zip}) {
    for (const auto& a : *axes) {
      if (!keys.insert(a.key).second)
        throw ConfigError(source + ": \"" + a.key +
                          "\" is varied twice; allowed once, in "
                          "[sweep.grid] or [sweep.zip]");
      plan.axes.push_back(a.key);
    }
  }
  // The keys that name points: all varied keys, or those of [sweep] names_from (which must
  // still tell every point apart; checked below).
  std::set<std::string> naming(keys.begin(), keys.end());
  if (const toml::node* nf = sw.get("names_from")) {
    const auto* arr = nf->as_array();
    if (!arr || arr->empty())
      throw ConfigError(source + ": [sweep] names_from: allowed a non-empty list of varied keys");
    naming.clear();
    for (const auto& k : *arr) {
      const std::string key = k.is_string() ? k.as_string()->get() : value_text(k);
      if (!k.is_string() || !keys.count(key))
        throw ConfigError(source + ": [sweep] names_from \"" + key +
                          "\": allowed keys varied in [sweep.grid] or [sweep.zip]");
      naming.insert(key);
    }
  }
  // Or the points' names given one by one, in point order (how a study names its points).
  std::vector<std::string> given_names;
  if (const toml::node* gn = sw.get("names")) {
    if (sw.get("names_from"))
      throw ConfigError(source + ": both [sweep] names and names_from; allowed one of them");
    const auto* arr = gn->as_array();
    if (!arr || arr->empty())
      throw ConfigError(source + ": [sweep] names: allowed a non-empty list of strings");
    for (const auto& n : *arr) {
      if (!n.is_string() || n.as_string()->get().empty())
        throw ConfigError(source + ": [sweep] names: " + value_text(n) +
                          "; allowed non-empty strings");
      given_names.push_back(name_part(n.as_string()->get()));
    }
  }
  // Short names: the key's last part, unless two axes share it.
  std::map<std::string, int> last_count;
  auto last = [](const std::string& k) { return k.substr(k.rfind('.') + 1); };
  for (const auto& k : plan.axes) {
    if (naming.count(k))
      ++last_count[last(k)];
  }
  auto short_name = [&](const std::string& k) {
    if (last_count[last(k)] == 1)
      return name_part(last(k));
    std::string s = k;
    std::replace(s.begin(), s.end(), '.', '-');
    return name_part(s);
  };

  // The points: the grid axes (first slowest), then the zip as one more axis.
  std::vector<std::size_t> sizes;
  for (const auto& a : grid)
    sizes.push_back(a.values.size());
  if (!zip.empty())
    sizes.push_back(zip.front().values.size());
  std::size_t count = 1;
  for (auto s : sizes) {
    count *= s;
    if (count > 100000)
      throw ConfigError(source + ": the sweep has more than 100000 points; allowed at most that");
  }
  if (!given_names.empty() && given_names.size() != count)
    throw ConfigError(source + ": [sweep] names has " + std::to_string(given_names.size()) +
                      " names for " + std::to_string(count) +
                      " points; allowed one name per point");
  std::set<std::string> names;
  for (std::size_t i = 0; i < count; ++i) {
    Point p;
    p.index = i;
    p.scene = scene;
    std::vector<std::size_t> at(sizes.size());
    std::size_t rest = i;
    for (std::size_t d = sizes.size(); d-- > 0;) {
      at[d] = rest % sizes[d];
      rest /= sizes[d];
    }
    auto apply = [&](const Axis& a, std::size_t k) {
      const toml::node& v = *a.values[k];
      if (a.key.find('.') == std::string::npos)
        p.scene.set_section(a.key, *v.as_table());
      else
        p.scene.set_value(a.key, v);
      p.values.emplace_back(a.key, value_text(v));
      if (a.key == "system.init")
        anchor_init(p.scene, base);
    };
    for (std::size_t d = 0; d < grid.size(); ++d)
      apply(grid[d], at[d]);
    for (const auto& a : zip)
      apply(a, at.back());
    if (!given_names.empty())
      p.name = given_names[i];
    for (const auto& [k, v] : p.values) {
      if (!given_names.empty() || !naming.count(k))
        continue;
      if (!p.name.empty())
        p.name += '_';
      p.name.append(short_name(k)).append("-").append(name_part(v));
    }
    if (p.name.empty())
      p.name = "point";
    if (p.name.size() > 200)
      throw ConfigError(source + ": point name '" + p.name.substr(0, 60) +
                        "...' is longer than 200 characters; allowed fewer or shorter values");
    if (!names.insert(p.name).second) {
      throw ConfigError(source + ": two points are both named '" + p.name +
                        "' (values that differ only in characters a file name cannot hold, or "
                        "[sweep] names_from leaves out a key that tells them apart); allowed "
                        "distinct names");
    }
    plan.points.push_back(std::move(p));
  }

  // Every point through the checks of `jamflow run`, before anything runs.
  for (auto& p : plan.points) {
    try {
      const RunSpec spec = parse_run_spec(plan.task_scene({p.index, 0, 1, 0.0}));
      p.n = spec.init_state ? static_cast<std::int64_t>(spec.init_state->size()) : spec.n;
      p.cost = expected_cost(spec);
    } catch (const ConfigError& e) {
      throw ConfigError("sweep point " + p.name + ": " + e.what());
    } catch (const InputFileError& e) {
      throw ConfigError("sweep point " + p.name + ": " + e.what());
    }
  }
}

}  // namespace

Plan parse_plan(const std::string& text, const std::string& source, const std::string& base_dir,
                const std::string& out_dir) {
  const Scene file = Scene::parse(text, source);
  file.check_sections({"sweep", "scene"});
  const toml::table* sw = file.table("sweep");
  if (!sw)
    throw ConfigError(source + ": no [sweep] section; allowed a sweep file with [sweep]");
  for (const auto& [k, v] : *sw) {
    const std::string key(k.str());
    if (key != "scene" && key != "replicas" && key != "grid" && key != "zip" &&
        key != "names_from" && key != "names")
      throw ConfigError(source + ": unknown key [sweep] " + key +
                        "; allowed scene, replicas, grid, zip, names_from, names");
  }
  Plan plan;
  plan.path = source;
  plan.name = fs::path(source).stem().string();
  const fs::path base(base_dir.empty() ? "." : base_dir);
  plan.out_dir =
      out_dir.empty() ? (base / (plan.name + ".sweep")).lexically_normal().string() : out_dir;

  // The base scene: a file (relative to the sweep file) or the inline [scene] table.
  const toml::node* scene_key = sw->get("scene");
  if (scene_key && file.table("scene"))
    throw ConfigError(source + ": both [sweep] scene and a [scene] table; allowed one of them");
  Scene scene = load_base_scene(scene_key, file.table("scene"), base.string(), source,
                                "[sweep] scene", "[scene]", "the sweep file");
  expand(plan, scene, *sw, source, base);
  return plan;
}

Plan make_plan(const Scene& scene, const Grid& grid, const std::string& out_dir,
               std::int64_t replicas) {
  if (out_dir.empty())
    throw ConfigError("a sweep without a sweep file needs an output folder; allowed a folder name");
  Plan plan;  // path stays empty: no sweep file
  fs::path out = fs::path(out_dir).lexically_normal();
  if (!out.has_filename())
    out = out.parent_path();
  plan.name = out.filename().string();
  if (plan.name.size() > 6 && plan.name.ends_with(".sweep"))
    plan.name.resize(plan.name.size() - 6);
  if (plan.name.empty() || plan.name == "." || plan.name == "..")
    plan.name = "sweep";
  plan.out_dir = out_dir;
  // The same [sweep] table a file would hold: grid and replicas.
  toml::table sw;
  toml::table axes;
  for (const auto& [key, values] : grid) {
    toml::array a = values;
    // Tables (whole sections) inline, as a file's [{...}, ...] are: a point's scene then prints
    // as the file's point does, so that either resumes the other's folder (prepare_out_dir).
    for (auto& v : a) {
      if (auto* t = v.as_table())
        t->is_inline(true);
    }
    axes.insert(key, std::move(a));
  }
  sw.insert("grid", std::move(axes));
  if (replicas != 0)
    sw.insert("replicas", replicas);
  // A relative system.init (in the scene or among the values) is where this process runs.
  const fs::path here = fs::current_path();
  Scene base = scene;
  anchor_init(base, here);
  expand(plan, base, sw, "the grid", here);
  return plan;
}

Plan load_plan(const std::string& path, const std::string& out_dir) {
  std::error_code ec;
  if (fs::is_directory(path, ec))
    throw InputFileError("sweep file '" + path + "' is a directory; allowed: a TOML file");
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw InputFileError("cannot open sweep file '" + path + "': " + std::strerror(errno) +
                         "; allowed: a readable TOML file");
  std::ostringstream buf;
  buf << in.rdbuf();
  if (in.bad())
    throw InputFileError("cannot read sweep file '" + path + "'; allowed: a readable TOML file");
  return parse_plan(buf.str(), path, fs::path(path).parent_path().string(), out_dir);
}

std::vector<std::size_t> array_share(const std::vector<Task>& tasks, int task_id, int size) {
  std::vector<double> load(static_cast<std::size_t>(size), 0.0);
  std::vector<std::size_t> mine;
  for (std::size_t i = 0; i < tasks.size(); ++i) {
    const auto best =
        static_cast<std::size_t>(std::min_element(load.begin(), load.end()) - load.begin());
    load[best] += tasks[i].cost;
    if (static_cast<int>(best) == task_id)
      mine.push_back(i);
  }
  return mine;
}

}  // namespace jamflow::sweep
