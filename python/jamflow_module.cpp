// The Python module `jamflow` (pybind11): scenes, runs, simulations under a Python protocol
// loop, sweeps and analyses. Every run goes through the run driver (driver/run.hpp) and every
// simulation through driver/simulation.hpp: this file only converts between Python and C++.
//
// While the engine runs, the GIL is released and the engine works in a thread of its own; the
// calling thread wakes every 50 ms to let Python handle signals, and a KeyboardInterrupt
// (Ctrl-C) raises the engine's stop flag: the run stops at the end of a step, keeps its
// checkpoint (OUT.h5.part) as the command line does, and the KeyboardInterrupt propagates.
#include <dlfcn.h>
#include <pybind11/eval.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "analysis/analyze_cli.hpp"
#include "driver/checkpoint.hpp"
#include "driver/run.hpp"
#include "driver/simulation.hpp"
#include "lib/config.hpp"
#include "lib/data_files.hpp"
#include "lib/error.hpp"
#include "lib/table.hpp"
#include "sweep/collect.hpp"
#include "sweep/engine.hpp"
#include "sweep/plan.hpp"

#ifndef JAMFLOW_VERSION
#define JAMFLOW_VERSION "unknown"
#endif
#ifndef JAMFLOW_MODULE_TO_BIN
#define JAMFLOW_MODULE_TO_BIN "../../../bin"
#endif
#ifndef JAMFLOW_BIN_TO_DATA
#define JAMFLOW_BIN_TO_DATA "../share/jamflow"
#endif

namespace py = pybind11;
namespace fs = std::filesystem;
using jamflow::ConfigError;

namespace {

std::string one_line(std::string text) {
  for (char& c : text) {
    if (c == '\n' || c == '\r')
      c = ' ';
  }
  while (!text.empty() && text.back() == ' ')
    text.pop_back();
  return text;
}

// Runs `work` (which polls `stop`) in a thread of its own with the GIL released; the calling
// thread lets Python handle signals every 50 ms. A KeyboardInterrupt (or any exception a signal
// handler raises) sets `stop`, waits for the work to end and propagates.
// `poll`, if given, is called with the GIL held at each wake and once after the work has ended
// (the progress callback); an exception it raises stops the work as Ctrl-C does.
template <class Work>
void run_released(Work&& work, std::atomic<bool>& stop, const std::function<void()>& poll = {}) {
  std::mutex mutex;
  std::condition_variable done_cv;
  bool done = false, interrupted = false;
  std::exception_ptr error;
  {
    py::gil_scoped_release release;
    std::thread worker([&] {
      try {
        work();
      } catch (...) {
        error = std::current_exception();
      }
      std::lock_guard<std::mutex> lock(mutex);
      done = true;
      done_cv.notify_all();
    });
    std::unique_lock<std::mutex> lock(mutex);
    while (!done) {
      done_cv.wait_for(lock, std::chrono::milliseconds(50));
      if (done || interrupted)
        continue;
      lock.unlock();
      {
        py::gil_scoped_acquire acquire;
        if (PyErr_CheckSignals() != 0) {
          interrupted = true;  // the exception stays set for this thread
          stop.store(true);
        } else if (poll) {
          try {
            poll();
          } catch (py::error_already_set& e) {
            e.restore();  // set again for this thread, raised below
            interrupted = true;
            stop.store(true);
          }
        }
      }
      lock.lock();
    }
    lock.unlock();
    worker.join();
  }
  if (interrupted)
    throw py::error_already_set();
  if (poll)
    poll();  // what arrived after the last wake
  if (error)
    std::rethrow_exception(error);
}

// Progress reports from the run's thread, handed to a Python callable in the calling thread
// (with the GIL, at most every 50 ms): only the latest report of a running replica is kept,
// and every replica's last (finished) report is delivered.
class ProgressRelay {
 public:
  explicit ProgressRelay(py::object callback) : callback_(std::move(callback)) {}
  bool active() const { return !callback_.is_none(); }
  void push(const jamflow::ProgressReport& r) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!queue_.empty() && !queue_.back().finished && queue_.back().label == r.label)
      queue_.back() = r;
    else
      queue_.push_back(r);
  }
  void deliver() {
    std::vector<jamflow::ProgressReport> reports;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      reports.swap(queue_);
    }
    for (const auto& r : reports) {
      py::dict d;
      d["label"] = r.label;
      d["time"] = r.time;
      d["total"] = r.total;
      d["fraction"] = r.fraction;
      d["elapsed"] = r.elapsed;
      d["eta"] = r.eta;
      d["extra"] = r.extra;
      d["finished"] = r.finished;
      callback_(d);
    }
  }

 private:
  py::object callback_;
  std::mutex mutex_;
  std::vector<jamflow::ProgressReport> queue_;
};

// progress=True: the module's display (tqdm if installed, else a line on sys.stderr); a
// callable: itself; False or None: none.
py::object progress_callback(py::object progress) {
  if (progress.is_none() || (py::isinstance<py::bool_>(progress) && !progress.cast<bool>()))
    return py::none();
  if (py::isinstance<py::bool_>(progress))
    return py::module_::import("jamflow").attr("_ProgressDisplay")();
  if (!PyCallable_Check(progress.ptr()))
    throw ConfigError("progress = " + py::repr(progress).cast<std::string>() +
                      "; allowed True, False or a callable taking a dict");
  return progress;
}

// ---- Python values <-> TOML ----------------------------------------------------------------

std::string text_of(py::handle v) {
  return py::repr(v).cast<std::string>();
}

std::unique_ptr<toml::node> to_toml(py::handle v, const std::string& key);

toml::table to_table(const py::dict& d, const std::string& where) {
  toml::table t;
  for (auto [k, v] : d) {
    if (!py::isinstance<py::str>(k)) {
      throw ConfigError(where + " key " + text_of(k) + " is not a string; allowed string keys");
    }
    const std::string key = k.cast<std::string>();
    const std::string path = where.empty() ? key : where + "." + key;
    to_toml(v, path)->visit([&](auto&& node) { t.insert_or_assign(key, std::move(node)); });
  }
  return t;
}

// A Python int as a scene integer: one beyond 64 bits is the scene's error (ConfigError, as
// any out-of-range value), not pybind11's "Unable to cast".
std::int64_t scene_integer(py::handle v, const std::string& key) {
  int overflow = 0;
  const long long x = PyLong_AsLongLongAndOverflow(v.ptr(), &overflow);
  if (overflow != 0) {
    throw ConfigError(key + " = " + text_of(v) +
                      " is out of range; allowed integers of at most 9223372036854775807 in "
                      "magnitude (and the key's own range)");
  }
  if (x == -1 && PyErr_Occurred())
    throw py::error_already_set();
  return x;
}

std::unique_ptr<toml::node> to_toml(py::handle v, const std::string& key) {
  if (py::isinstance<py::bool_>(v))
    return std::make_unique<toml::value<bool>>(v.cast<bool>());
  if (PyLong_Check(v.ptr()))
    return std::make_unique<toml::value<std::int64_t>>(scene_integer(v, key));
  if (PyFloat_Check(v.ptr()))
    return std::make_unique<toml::value<double>>(v.cast<double>());
  if (py::isinstance<py::str>(v))
    return std::make_unique<toml::value<std::string>>(v.cast<std::string>());
  if (py::isinstance<py::dict>(v))
    return std::make_unique<toml::table>(to_table(v.cast<py::dict>(), key));
  if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v)) {
    auto a = std::make_unique<toml::array>();
    for (py::handle item : v)
      to_toml(item, key)->visit([&](auto&& node) { a->push_back(std::move(node)); });
    return a;
  }
  // numpy scalars (numpy.float64 is a float, but numpy.int64, numpy.float32 and numpy.bool_
  // are not int, float or bool) and arrays: their Python value, a number or a list.
  if (py::hasattr(v, "dtype") && py::hasattr(v, "tolist"))
    return to_toml(v.attr("tolist")(), key);
  if (py::hasattr(v, "__fspath__"))
    return std::make_unique<toml::value<std::string>>(
        py::module_::import("os").attr("fspath")(v).cast<std::string>());
  // other numbers
  if (py::hasattr(v, "__index__")) {
    const py::object index = py::reinterpret_steal<py::object>(PyNumber_Index(v.ptr()));
    if (!index)
      throw py::error_already_set();
    return std::make_unique<toml::value<std::int64_t>>(scene_integer(index, key));
  }
  if (py::hasattr(v, "__float__"))
    return std::make_unique<toml::value<double>>(
        py::float_(py::reinterpret_borrow<py::object>(v)).cast<double>());
  throw ConfigError(key + " = " + text_of(v) +
                    " is not a scene value; allowed numbers, strings, booleans, lists and tables");
}

py::object to_python(const toml::node& n) {
  if (auto t = n.as_table()) {
    py::dict d;
    for (const auto& [k, v] : *t)
      d[py::str(std::string(k.str()))] = to_python(v);
    return d;
  }
  if (auto a = n.as_array()) {
    py::list l;
    for (const auto& v : *a)
      l.append(to_python(v));
    return l;
  }
  if (auto v = n.as_boolean())
    return py::bool_(v->get());
  if (auto v = n.as_integer())
    return py::int_(v->get());
  if (auto v = n.as_floating_point())
    return py::float_(v->get());
  if (auto v = n.as_string())
    return py::str(v->get());
  return py::none();  // dates and times: not in scenes
}

// ---- Scene ---------------------------------------------------------------------------------

// A scene and its validation: every change is checked as `jamflow run` checks a scene.
class PyScene {
 public:
  explicit PyScene(jamflow::Scene scene) : scene_(std::move(scene)) { check(); }

  static PyScene from_text(const std::string& text, const std::string& source) {
    return PyScene(jamflow::Scene::parse(text, source));
  }
  static PyScene from_file(const std::string& path) { return PyScene(jamflow::Scene::load(path)); }
  static PyScene from_dict(const py::dict& d) {
    jamflow::Scene scene = jamflow::Scene::parse("", "the scene dict");
    for (auto [k, v] : d) {
      const std::string name = py::str(k).cast<std::string>();
      if (!py::isinstance<py::dict>(v)) {
        throw ConfigError("scene dict entry '" + name + "' = " + text_of(v) +
                          " is not a table; allowed a dict per section, such as {\"shear\": "
                          "{\"rate\": 1e-4}}");
      }
      scene.set_section(name, to_table(v.cast<py::dict>(), name));
    }
    return PyScene(std::move(scene));
  }
  // A dict, a path (str without TOML syntax, or os.PathLike) or TOML text.
  static PyScene from_any(py::handle source) {
    if (py::isinstance<PyScene>(source))
      return source.cast<PyScene>();
    if (py::isinstance<py::dict>(source))
      return from_dict(source.cast<py::dict>());
    if (py::hasattr(source, "__fspath__"))
      return from_file(py::module_::import("os").attr("fspath")(source).cast<std::string>());
    if (py::isinstance<py::str>(source)) {
      const std::string s = source.cast<std::string>();
      if (s.find_first_of("\n=[") != std::string::npos)
        return from_text(s, "the scene string");
      return from_file(s);
    }
    throw ConfigError("scene " + text_of(source) +
                      " is not a scene; allowed a jamflow.Scene, a dict, TOML text or a path");
  }

  void set(const std::string& key, py::handle value) {
    jamflow::Scene changed = scene_;
    changed.set_value(key, *to_toml(value, key));
    check(changed);
    scene_ = std::move(changed);
  }
  // Several keys at once, checked together (e.g. a new ensemble kind and its pressure).
  void update(const py::dict& values) {
    jamflow::Scene changed = scene_;
    for (auto [k, v] : values) {
      const std::string key = py::str(k).cast<std::string>();
      changed.set_value(key, *to_toml(v, key));
    }
    check(changed);
    scene_ = std::move(changed);
  }
  py::object get(const std::string& key) const {
    const auto dot = key.find('.');
    const std::string section = key.substr(0, dot);
    const toml::table* t = scene_.table(section);
    if (!t)
      throw py::key_error(key);
    if (dot == std::string::npos)
      return to_python(*t);
    const toml::node* n = t->at_path(key.substr(dot + 1)).node();
    if (!n)
      throw py::key_error(key);
    return to_python(*n);
  }
  py::dict to_dict() const {
    py::dict d;
    for (const char* name : {"system", "ensemble", "shear", "integrator", "run", "output"}) {
      if (const toml::table* t = scene_.table(name))
        d[name] = to_python(*t);
    }
    return d;
  }
  std::string text() const { return scene_.text(); }
  const jamflow::Scene& scene() const { return scene_; }
  jamflow::RunSpec spec() const { return jamflow::parse_run_spec(scene_); }

 private:
  static void check(const jamflow::Scene& scene) { (void)jamflow::parse_run_spec(scene); }
  void check() const { check(scene_); }
  jamflow::Scene scene_;
};

// ---- Results -------------------------------------------------------------------------------

py::array_t<double> array(const std::vector<double>& v, std::vector<py::ssize_t> shape = {}) {
  if (shape.empty())
    shape = {py::ssize_t(v.size())};
  py::array_t<double> a(shape);
  if (!v.empty())
    std::memcpy(a.mutable_data(), v.data(), v.size() * sizeof(double));
  return a;
}

py::array_t<std::int64_t> array(const std::vector<std::int64_t>& v) {
  py::array_t<std::int64_t> a(py::ssize_t(v.size()));
  if (!v.empty())
    std::memcpy(a.mutable_data(), v.data(), v.size() * sizeof(std::int64_t));
  return a;
}

py::dict configuration_dict(const jamflow::Configuration& c) {
  const auto n = py::ssize_t(c.diameters.size());
  py::dict d;
  d["positions"] = array(c.positions, {n, 3});
  d["diameters"] = array(c.diameters);
  d["species"] = array(c.species);
  d["cell"] = array(c.cell, {3, 3});
  d["strain"] = c.strain;
  d["time"] = c.time;
  return d;
}

py::dict timeseries_dict(const jamflow::RunSpec& spec, const jamflow::Series& s) {
  using jamflow::Sample;
  py::dict d;
  d["time"] = array(s.column(&Sample::time));
  d["strain"] = array(s.column(&Sample::strain));
  d["volume"] = array(s.column(&Sample::volume));
  d["phi"] = array(s.column(&Sample::phi));
  d["pressure"] = array(s.column(&Sample::pressure));
  d["sigma_xy"] = array(s.column(&Sample::sigma_xy));
  d["energy"] = array(s.column(&Sample::energy));
  d["dissipation"] = array(s.column(&Sample::dissipation));
  if (spec.ensemble->has_piston())
    d["piston_dissipation"] = array(s.column(&Sample::piston_dissipation));
  return d;
}

// An empty jamflow._Named: a dict whose keys are the current names, indexed also by the former
// names of the shear rate and the imposed pressure (with a DeprecationWarning).
py::dict named() {
  return py::module_::import("jamflow").attr("_Named")();
}

// The /summary attributes of the run file (jamflow::summary_attributes), as a dict.
py::dict summary_dict(const jamflow::RunSpec& spec, const jamflow::ReplicaResult& r,
                      const jamflow::ReplicaResult* summary = nullptr) {
  py::dict d = named();
  for (const auto& [k, v] : jamflow::summary_attributes(spec, r, summary))
    std::visit([&d, &k = k](const auto& x) { d[py::str(k)] = x; }, v);
  return d;
}

struct RunResult {
  py::dict summary, timeseries, final_;
  py::list warnings, replicas;
  py::object file = py::none();
  std::string status, scene;
  std::uint64_t seed = 0;
};

RunResult replica_result(const jamflow::RunSpec& spec, const jamflow::ReplicaResult& r) {
  RunResult out;
  out.summary = summary_dict(spec, r);
  out.timeseries = timeseries_dict(spec, r.series);
  out.final_ = configuration_dict(jamflow::configuration_of(r.final_state));
  for (const auto& w : r.summary.warnings)
    out.warnings.append(w);
  out.status = r.status.text();
  out.scene = spec.scene_text;
  out.seed = r.seed;
  return out;
}

RunResult run(py::handle scene_source, py::object out, bool force, py::object progress) {
  jamflow::Scene scene = PyScene::from_any(scene_source).scene();
  jamflow::OutputOptions output;
  output.force = force;
  output.write = !out.is_none();
  if (output.write) {
    // As `jamflow run -o OUT`: the stored scene names the file.
    const std::string file = py::module_::import("os").attr("fspath")(out).cast<std::string>();
    scene.set_value("output.file", toml::value<std::string>(file));
  }
  const jamflow::RunSpec spec = jamflow::parse_run_spec(scene);
  std::atomic<bool> stop{false};
  jamflow::RunOptions options;
  ProgressRelay relay(progress_callback(progress));
  options.quiet = !relay.active();
  if (relay.active())
    options.progress = [&relay](const jamflow::ProgressReport& r) { relay.push(r); };
  options.stop = &stop;
  jamflow::RunOutcome outcome;
  run_released([&] { outcome = jamflow::run_replicas(spec, options, output); }, stop,
               [&] { relay.deliver(); });
  if (outcome.code != 0) {
    const std::string status =
        outcome.replicas.empty() ? "" : outcome.replicas.back().status.text();
    if (outcome.code == 130) {  // stopped through `stop`
      PyErr_SetString(PyExc_KeyboardInterrupt, status.c_str());
      throw py::error_already_set();
    }
    throw jamflow::IntegrationError(
        status + (output.write ? "; the data is kept in " + spec.file + ".part" : std::string()));
  }
  if (!outcome.write_error.empty())
    throw jamflow::IoError(jamflow::kept_message(spec.file, outcome.write_error, outcome.kept_in));
  const auto& reps = outcome.replicas;
  RunResult result = replica_result(spec, reps.front());
  if (reps.size() > 1) {
    const jamflow::ReplicaResult all = jamflow::replicas_summary(reps);
    result.summary = summary_dict(spec, reps.front(), &all);
    for (const auto& r : reps)
      result.replicas.append(py::cast(replica_result(spec, r)));
    result.warnings = py::list();
    for (const auto& w : all.summary.warnings)
      result.warnings.append(w);
  }
  if (output.write)
    result.file = py::str(spec.file);
  return result;
}

// ---- Simulation ----------------------------------------------------------------------------

class PySimulation {
 public:
  PySimulation(py::handle scene_source, py::object seed) {
    PyScene scene = PyScene::from_any(scene_source);
    const jamflow::RunSpec spec = scene.spec();
    const std::uint64_t s = seed.is_none() ? spec.seed : seed.cast<std::uint64_t>();
    sim_ = std::make_unique<jamflow::Simulation>(spec, s);
  }
  void advance_to(double t_end) {
    if (!std::isfinite(t_end))
      throw ConfigError("time " + jamflow::fmt(t_end) + " is not finite; allowed a finite time");
    std::atomic<bool> stop{false};
    run_released([&] { sim_->advance_to(t_end, &stop); }, stop);
  }
  void advance(double duration) {
    if (!(duration >= 0.0) || !std::isfinite(duration)) {
      throw ConfigError("duration " + jamflow::fmt(duration) +
                        " is out of range; allowed a finite time >= 0");
    }
    advance_to(sim_->time() + duration);
  }
  py::dict observables() {
    const jamflow::Sample s = sim_->sample();
    py::dict d;
    d["time"] = s.time;
    d["strain"] = s.strain;
    d["volume"] = s.volume;
    d["phi"] = s.phi;
    d["pressure"] = s.pressure;
    d["sigma_xy"] = s.sigma_xy;
    d["energy"] = s.energy;
    d["dissipation"] = s.dissipation;
    if (sim_->spec().ensemble->has_piston())
      d["piston_dissipation"] = s.piston_dissipation;
    return d;
  }
  py::array_t<double> positions() const {
    const auto c = sim_->configuration();
    return array(c.positions, {py::ssize_t(c.diameters.size()), 3});
  }
  py::array_t<double> forces() {
    const auto f = sim_->forces();
    return array(f, {py::ssize_t(f.size() / 3), 3});
  }
  py::dict configuration() const { return configuration_dict(sim_->configuration()); }
  py::dict statistics() const {
    py::dict d;
    for (const auto& [k, v] : sim_->statistics())
      d[py::str(k)] = v;
    return d;
  }
  jamflow::Simulation& sim() { return *sim_; }
  const jamflow::Simulation& sim() const { return *sim_; }

 private:
  std::unique_ptr<jamflow::Simulation> sim_;
};

// ---- Sweeps --------------------------------------------------------------------------------

// The jamflow binary that runs a sweep's points: $JAMFLOW_EXE, else the one beside this module
// (the build folder), else the installed one (the module's install folder -> bin).
std::string jamflow_exe_for_module() {
  if (const char* e = std::getenv("JAMFLOW_EXE"); e && *e)
    return e;
  Dl_info info{};
  if (::dladdr(reinterpret_cast<void*>(&jamflow_exe_for_module), &info) && info.dli_fname) {
    const fs::path here = fs::path(info.dli_fname).parent_path();
    for (const fs::path& p : {here / "jamflow", here / JAMFLOW_MODULE_TO_BIN / "jamflow"}) {
      std::error_code ec;
      if (fs::is_regular_file(p, ec) && ::access(p.c_str(), X_OK) == 0)
        return fs::weakly_canonical(p, ec).string();
    }
  }
  throw jamflow::IoError(
      "the jamflow binary was not found beside the module or in its install folder; allowed: "
      "set JAMFLOW_EXE to its path");
}

// The installed data (plot scripts) of the tree this module is installed in: the module, not
// the interpreter, says where that is. In a build folder it does not exist, and the source
// tree's scripts are used.
void register_data_root() {
  Dl_info info{};
  if (::dladdr(reinterpret_cast<void*>(&register_data_root), &info) && info.dli_fname) {
    std::error_code ec;
    const fs::path here = fs::absolute(info.dli_fname, ec).parent_path();
    jamflow::set_data_root(
        (here / JAMFLOW_MODULE_TO_BIN / JAMFLOW_BIN_TO_DATA).lexically_normal().string());
  }
}

// A table's text cells as {column: numpy array}: numbers (empty cells NaN) where every cell
// is one, else str.
py::dict table_columns(const std::vector<std::string>& header,
                       const std::vector<std::vector<std::string>>& rows) {
  auto numpy = py::module_::import("numpy");
  py::dict table = named();
  for (std::size_t c = 0; c < header.size(); ++c) {
    std::vector<double> numbers;
    std::vector<std::string> texts;
    bool numeric = true;
    for (const auto& row : rows) {
      const std::string& cell = row[c];
      texts.push_back(cell);
      if (!numeric)
        continue;
      if (cell.empty()) {
        numbers.push_back(std::nan(""));
        continue;
      }
      char* end = nullptr;
      const double v = std::strtod(cell.c_str(), &end);
      numeric = end != cell.c_str() && *end == '\0';
      numbers.push_back(v);
    }
    if (numeric)
      table[py::str(header[c])] = array(numbers);
    else
      table[py::str(header[c])] = numpy.attr("array")(py::cast(texts), py::arg("dtype") = "str");
  }
  return table;
}

// A grid's values for one key: a list, tuple, range, numpy array or other iterable (not a
// string or a dict), each value as a scene value.
toml::array grid_values(py::handle values, const std::string& key) {
  if (py::hasattr(values, "dtype") && py::hasattr(values, "tolist"))
    return grid_values(values.attr("tolist")(), key);
  if (py::isinstance<py::str>(values) || py::isinstance<py::bytes>(values) ||
      py::isinstance<py::dict>(values) || !py::isinstance<py::iterable>(values))
    throw ConfigError("grid \"" + key + "\" = " + text_of(values) +
                      " is not a list; allowed a list (or numpy array) of values");
  toml::array a;
  for (py::handle v : values)
    to_toml(v, key)->visit([&](auto&& node) { a.push_back(std::move(node)); });
  return a;
}

py::dict sweep(py::object source, py::object out, py::object grid, py::object replicas, int jobs,
               bool progress, bool strict, py::object path) {
  auto os = py::module_::import("os");
  if (!path.is_none()) {  // the argument's name before grids
    if (!source.is_none())
      throw ConfigError(
          "jamflow.sweep got both source and path; allowed one (path is source's "
          "former name)");
    source = path;
  }
  if (source.is_none())
    throw ConfigError(
        "jamflow.sweep needs a source; allowed a sweep file's path, or a scene "
        "with grid={key: [values]}");
  std::string out_dir = out.is_none() ? std::string() : os.attr("fspath")(out).cast<std::string>();
  jamflow::sweep::Plan plan;
  if (grid.is_none()) {
    if (py::isinstance<PyScene>(source) || py::isinstance<py::dict>(source))
      throw ConfigError(
          "jamflow.sweep of a scene needs grid={key: [values]}; allowed a scene "
          "with grid=, or a sweep file's path");
    if (!replicas.is_none())
      throw ConfigError("replicas = " + text_of(replicas) +
                        " with a sweep file; allowed with grid= only (a sweep file sets "
                        "[sweep] replicas)");
    plan = jamflow::sweep::load_plan(os.attr("fspath")(source).cast<std::string>(), out_dir);
  } else {
    if (!py::isinstance<py::dict>(grid))
      throw ConfigError("grid = " + text_of(grid) +
                        " is not a dict; allowed {\"section.key\": [values], ...}");
    const PyScene scene = PyScene::from_any(source);
    jamflow::sweep::Grid axes;
    for (auto [k, v] : grid.cast<py::dict>()) {
      if (!py::isinstance<py::str>(k))
        throw ConfigError("grid key " + text_of(k) + " is not a string; allowed scene keys " +
                          "such as \"shear.rate\"");
      const std::string key = k.cast<std::string>();
      axes[key] = grid_values(v, key);
    }
    std::int64_t count = 0;  // the scene's [run] replicas
    if (!replicas.is_none()) {
      const py::object index =
          py::isinstance<py::bool_>(replicas)
              ? py::object()
              : py::reinterpret_steal<py::object>(PyNumber_Index(replicas.ptr()));
      PyErr_Clear();
      count = index ? scene_integer(index, "replicas") : 0;
      if (count < 1)
        throw ConfigError("replicas = " + text_of(replicas) + "; allowed an integer in [1, 10000]");
    }
    std::string scratch;
    if (out_dir.empty())
      out_dir = scratch = py::module_::import("tempfile")
                              .attr("mkdtemp")(py::arg("prefix") = "jamflow-sweep-")
                              .cast<std::string>();
    try {
      plan = jamflow::sweep::make_plan(scene.scene(), axes, out_dir, count);
    } catch (...) {
      std::error_code ec;
      if (!scratch.empty())
        fs::remove(scratch, ec);  // still empty: nothing was written
      throw;
    }
  }
  jamflow::sweep::EngineOptions o;
  o.jobs = jobs;
  o.quiet = !progress;
  o.exe = jamflow_exe_for_module();
  std::atomic<int> signal{0};
  o.stop = &signal;
  std::atomic<bool> stop{false};
  // The engine polls its own flag: raise it from the Python side's stop flag.
  std::jthread relay([&](std::stop_token token) {
    while (!token.stop_requested()) {
      if (stop.load()) {
        signal.store(SIGINT);
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  // Its exit status says no more than the table's status column, which is read below.
  run_released([&] { (void)jamflow::sweep::run_plan(plan, o); }, stop);
  relay.request_stop();
  // table.csv: the finished points, as `jamflow sweep --collect`.
  jamflow::sweep::collect(plan, (fs::path(plan.out_dir) / "table.csv").string());
  jamflow::sweep::PointTable t = jamflow::sweep::point_table(plan);
  // Here the folder is absolute: the table is used away from the sweep's folder.
  const auto folder = std::find(t.header.begin(), t.header.end(), "folder") - t.header.begin();
  for (auto& row : t.rows)
    row[std::size_t(folder)] =
        fs::absolute(fs::path(plan.out_dir) / row[std::size_t(folder)]).lexically_normal().string();
  std::string why;
  std::size_t unfinished = 0;
  for (std::size_t i = 0; i < t.status.size(); ++i) {
    if (t.status[i].is_complete())
      continue;
    if (++unfinished <= 5)
      why += (why.empty() ? "" : "; ") + plan.points[i].name + ": " + t.status[i].text();
  }
  if (unfinished > 5)
    why += "; and " + std::to_string(unfinished - 5) + " more";
  if (unfinished > 0) {
    const std::string message =
        "sweep " + plan.name + ": " + std::to_string(unfinished) + " of " +
        std::to_string(plan.points.size()) + " points did not finish (" + why +
        "); the table has them with their status and NaN results, their logs are in " +
        plan.out_dir + "/points";
    if (strict)
      throw jamflow::IntegrationError(message);
    if (PyErr_WarnEx(PyExc_RuntimeWarning, message.c_str(), 1) != 0)
      throw py::error_already_set();  // warnings as errors
  }
  return table_columns(t.header, t.rows);
}

py::list sweep_points(py::object path) {
  const std::string file = py::module_::import("os").attr("fspath")(path).cast<std::string>();
  const jamflow::sweep::Plan plan = jamflow::sweep::load_plan(file, "");
  py::list points;
  auto tomllib = py::module_::import("tomllib");
  for (const auto& p : plan.points) {
    py::dict d;
    d["name"] = p.name;
    py::dict values;
    for (const auto& [k, v] : p.values)
      values[py::str(k)] = tomllib.attr("loads")("v = " + v)["v"];
    d["values"] = values;
    d["N"] = p.n;
    d["scene"] = py::cast(PyScene(p.scene));
    points.append(d);
  }
  return points;
}

// ---- Analyses ------------------------------------------------------------------------------

// `jamflow analyze KIND DATA... -o OUT.json [options]` with stderr captured: returns the JSON
// as Python objects; a bad input is a ConfigError with the command line's one-line message.
py::object analyze(const std::string& kind, py::object data, py::object out, bool plots,
                   py::kwargs options) {
  std::vector<std::string> args{kind == "hard_sphere"     ? "hard-sphere"
                                : kind == "olsson_teitel" ? "olsson-teitel"
                                : kind == "flow_curve"    ? "flow-curve"
                                                          : kind};
  auto os = py::module_::import("os");
  if (py::isinstance<py::str>(data) || py::hasattr(data, "__fspath__")) {
    args.push_back(os.attr("fspath")(data).cast<std::string>());
  } else {
    for (py::handle d : data)
      args.push_back(os.attr("fspath")(d).cast<std::string>());
  }
  std::string json_path;
  fs::path scratch;
  if (out.is_none()) {
    char dir[] = "/tmp/jamflow-analyze-XXXXXX";
    if (!::mkdtemp(dir))
      throw jamflow::IoError("cannot create a scratch folder in /tmp");
    scratch = dir;
    json_path = (scratch / "analysis.json").string();
  } else {
    json_path = os.attr("fspath")(out).cast<std::string>();
  }
  args.insert(args.end(), {"-o", json_path});
  if (!plots)
    args.push_back("--no-plots");
  for (auto [k, v] : options) {
    std::string flag = "--" + k.cast<std::string>();
    for (char& c : flag)
      if (c == '_')
        c = '-';
    if (py::isinstance<py::bool_>(v)) {
      if (v.cast<bool>())
        args.push_back(flag);
      continue;
    }
    args.push_back(flag);
    args.push_back(py::str(v).cast<std::string>());
  }
  // stderr to a file for the call, then passed on.
  char log_name[] = "/tmp/jamflow-analyze-log-XXXXXX";
  const int log_fd = ::mkstemp(log_name);
  if (log_fd < 0)
    throw jamflow::IoError("cannot create a scratch file in /tmp");
  int code = 0;
  {
    py::gil_scoped_release release;
    std::fflush(stderr);
    const int saved = ::dup(2);
    ::dup2(log_fd, 2);
    try {
      code = jamflow::analysis::analyze_main(args);
    } catch (...) {
      code = 1;
    }
    std::fflush(stderr);
    ::dup2(saved, 2);
    ::close(saved);
  }
  ::close(log_fd);
  std::string log;
  {
    std::ifstream in(log_name);
    std::stringstream s;
    s << in.rdbuf();
    log = s.str();
  }
  ::unlink(log_name);
  std::string error;
  std::istringstream lines(log);
  for (std::string line; std::getline(lines, line);) {
    const std::string tag = "jamflow analyze: error: ";
    if (line.rfind(tag, 0) == 0 && error.empty())
      error = line.substr(tag.size());
    else if (!line.empty())
      py::print(line, py::arg("file") = py::module_::import("sys").attr("stderr"));
  }
  py::object result = py::none();
  if (code == 0 || code == 1) {
    std::ifstream in(json_path);
    if (in) {
      std::stringstream s;
      s << in.rdbuf();
      result = py::module_::import("json").attr("loads")(s.str());
    }
  }
  if (!scratch.empty()) {
    std::error_code ec;
    fs::remove_all(scratch, ec);
  }
  if (code == 2)
    throw ConfigError(error.empty() ? "jamflow analyze: bad input" : error);
  if (code != 0 || result.is_none())
    throw std::runtime_error(error.empty() ? "jamflow analyze failed" : error);
  return result;
}

}  // namespace

PYBIND11_MODULE(jamflow, m) {
  m.doc() =
      "jamflow: overdamped shear simulations of soft spheres near jamming. Scenes, runs, "
      "simulations under a Python protocol loop, sweeps and analyses; see the documentation's "
      "Python guide (docs/guide/python.md) and tutorial (docs/tutorial.md). Data: __version__ "
      "(the version), default_scene (the embedded default scene, TOML text).";
  m.attr("__version__") = JAMFLOW_VERSION;
  register_data_root();
  // What progress=True shows: a tqdm bar per replica when tqdm is installed (Debian's
  // python3-tqdm), else a line redrawn on sys.stderr; both show in Jupyter, unlike the C-level
  // stderr of the command line's progress line.
  py::dict scope;
  py::exec(R"(
class _ProgressDisplay:
    """Shows the progress reports of jamflow.run: tqdm if installed, else sys.stderr."""

    def __init__(self):
        try:
            from tqdm.auto import tqdm
        except ImportError:
            tqdm = None
        self._tqdm = tqdm
        self._bars = {}

    def __call__(self, r):
        if self._tqdm is not None:
            bar = self._bars.get(r["label"])
            if bar is None:
                bar = self._bars[r["label"]] = self._tqdm(
                    total=r["total"], desc=r["label"], unit="tau_0",
                    bar_format="{desc}: {percentage:3.0f}%|{bar}| t = {n:.6g} / {total:.6g} "
                               "[{elapsed}<{remaining}{postfix}]")
            bar.total = r["total"]
            bar.n = r["time"]
            bar.set_postfix_str(r["extra"], refresh=False)
            bar.refresh()
            if r["finished"]:
                bar.close()
                del self._bars[r["label"]]
        else:
            import sys
            sys.stderr.write("\r[%s] t = %.6g / %.6g  %5.1f%%  %s%s" % (
                r["label"], r["time"], r["total"], 100.0 * r["fraction"], r["extra"],
                "\n" if r["finished"] else ""))
            sys.stderr.flush()
)",
           scope);
  m.attr("_ProgressDisplay") = scope["_ProgressDisplay"];
  // The dict of a run's summary and of a sweep's table: its keys are the file's, exactly; the
  // former names of the shear rate and the imposed pressure still index it, with a warning.
  py::exec(R"(
class _Named(dict):
    """A dict of named values under jamflow's one name per quantity (shear_rate,
    imposed_pressure). The former names gdot, P and pressure_imposed still index it, with a
    DeprecationWarning; they are not keys (``in``, ``keys()`` and ``get`` see only the current
    names)."""

    _FORMER = {"gdot": "shear_rate", "P": "imposed_pressure",
               "pressure_imposed": "imposed_pressure"}

    def __missing__(self, key):
        current = self._FORMER.get(key) if isinstance(key, str) else None
        if current is None or not dict.__contains__(self, current):
            raise KeyError(key)
        import warnings
        warnings.warn("'%s' is deprecated; use '%s'" % (key, current), DeprecationWarning,
                      stacklevel=2)
        return self[current]
)",
           scope);
  m.attr("_Named") = scope["_Named"];
  m.attr("default_scene") = jamflow::kDefaultScene;

  static py::exception<jamflow::ConfigError> config_error(m, "ConfigError", PyExc_ValueError);
  static py::exception<jamflow::IoError> io_error(m, "IoError", PyExc_OSError);
  static py::exception<jamflow::InputFileError> input_error(m, "InputFileError", io_error.ptr());
  static py::exception<jamflow::IntegrationError> integration_error(m, "IntegrationError",
                                                                    PyExc_RuntimeError);
  config_error.attr("__doc__") =
      "A bad scene, key, value or argument (the command line's exit status 2): one line naming "
      "the key, the value and what is allowed.";
  io_error.attr("__doc__") = "A file that could not be read or written.";
  input_error.attr("__doc__") = "A scene or init file that cannot be read (an IoError).";
  integration_error.attr("__doc__") =
      "A run that failed (the integration left the physical domain), or with strict=True a "
      "sweep with points that did not finish.";
  // One line, as the command line prints it.
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p)
        std::rethrow_exception(p);
    } catch (const jamflow::ConfigError& e) {
      config_error(one_line(e.what()).c_str());
    } catch (const jamflow::InputFileError& e) {
      input_error(one_line(e.what()).c_str());
    } catch (const jamflow::IoError& e) {
      io_error(one_line(e.what()).c_str());
    } catch (const jamflow::IntegrationError& e) {
      integration_error(one_line(e.what()).c_str());
    }
  });

  py::class_<PyScene>(m, "Scene",
                      "A scene: from a TOML file (path), TOML text, a dict of sections, or the "
                      "default scene (no argument). Checked as `jamflow run` checks it; a bad "
                      "key or value raises ConfigError with the command line's one-line message.")
      .def(py::init([](py::object source) {
             if (source.is_none())
               return PyScene::from_text(jamflow::kDefaultScene, "the default scene");
             return PyScene::from_any(source);
           }),
           py::arg("source") = py::none())
      .def_static("from_text", &PyScene::from_text, py::arg("text"),
                  py::arg("source") = "the scene string",
                  "A scene from TOML text; `source` names it in error messages.")
      .def_static("from_file", &PyScene::from_file, py::arg("path"),
                  "A scene from a TOML file (a relative system.init is taken relative to it).")
      .def_static("from_dict", &PyScene::from_dict, py::arg("sections"),
                  "A scene from a dict of sections: {'system': {'N': 500, ...}, ...}.")
      .def("set", &PyScene::set, py::arg("key"), py::arg("value"),
           "Sets 'section.key' to a value and checks the scene (ConfigError: unchanged).")
      .def("update", &PyScene::update, py::arg("values"),
           "Sets several 'section.key' values, checked together.")
      .def("get", &PyScene::get, py::arg("key"),
           "The value of 'section.key' (KeyError if the scene does not set it); scene[key] "
           "too.")
      .def("__getitem__", &PyScene::get)
      .def("to_dict", &PyScene::to_dict, "The scene as a dict of sections (a copy).")
      .def(
          "copy", [](const PyScene& s) { return PyScene(s); },
          "An independent copy (set() on it leaves this scene unchanged).")
      .def_property_readonly("text", &PyScene::text,
                             "The scene as TOML text, as it is stored in run files (floats in "
                             "their shortest form that reads back exactly).")
      .def("__str__", &PyScene::text)
      .def("__repr__",
           [](const PyScene& s) { return "jamflow.Scene(" + text_of(py::str(s.text())) + ")"; });

  py::class_<RunResult>(m, "RunResult", "What jamflow.run returns.")
      .def_readonly("summary", &RunResult::summary,
                    "the /summary attributes: values, errors, verdicts, counters")
      .def_readonly("timeseries", &RunResult::timeseries, "numpy arrays per observable")
      .def_readonly("final", &RunResult::final_,
                    "final configuration: positions (N x 3), diameters, species, cell, strain")
      .def_readonly("warnings", &RunResult::warnings,
                    "one line per failed verdict (steady, stable, decorrelated), as printed")
      .def_readonly("replicas", &RunResult::replicas,
                    "with several replicas: one RunResult per replica (else empty)")
      .def_readonly("file", &RunResult::file, "the HDF5 file written, or None")
      .def_readonly("status", &RunResult::status,
                    "'complete', or why the run stopped ('budget: stopped at t = ...')")
      .def_readonly("scene", &RunResult::scene, "the scene as run (TOML)")
      .def_readonly("seed", &RunResult::seed,
                    "the random seed of the (first) replica's initial positions")
      .def("__repr__", [](const RunResult& r) {
        return "<jamflow.RunResult " + r.status + ", " +
               std::to_string(py::len(r.timeseries["time"])) + " samples>";
      });

  m.def("run", &run, py::arg("scene"), py::arg("out") = py::none(), py::kw_only(),
        py::arg("force") = false, py::arg("progress") = false,
        "Runs a scene as `jamflow run` does. With out, writes the same HDF5 and XYZ files (an "
        "existing output needs force=True); without, writes nothing. Ctrl-C stops the run "
        "(its checkpoint OUT.h5.part continues with `jamflow run --resume`). progress=True "
        "shows a tqdm bar (a line on sys.stderr without tqdm); a callable is called at most "
        "every 50 ms with a dict (label, time, total, fraction, elapsed, eta, extra, finished; "
        "total grows under \"auto\" lengths, and each replica's last report has finished=True "
        "and fraction 1); an exception it raises stops the run.");

  py::class_<PySimulation>(m, "Simulation",
                           "A scene's system under a Python protocol loop: advance, look, change "
                           "the shear rate, advance again.")
      .def(py::init<py::handle, py::object>(), py::arg("scene"), py::arg("seed") = py::none())
      .def("advance", &PySimulation::advance, py::arg("duration"),
           "Advances by `duration` (tau_0). Ctrl-C stops at the end of a step.")
      .def("advance_to", &PySimulation::advance_to, py::arg("time"),
           "Advances to the time `time` (tau_0, from the start). Ctrl-C stops at the end of a "
           "step.")
      .def_property_readonly(
          "time", [](const PySimulation& s) { return s.sim().time(); },
          "The simulation time reached (tau_0).")
      .def_property_readonly("observables", &PySimulation::observables,
                             "time, strain, volume, phi, pressure, sigma_xy, energy, "
                             "dissipation of the current configuration")
      .def_property_readonly("positions", &PySimulation::positions,
                             "N x 3 copy, id order, wrapped into the cell")
      .def_property_readonly("forces", &PySimulation::forces, "N x 3 copy, id order")
      .def_property_readonly("configuration", &PySimulation::configuration,
                             "positions (N x 3), diameters, species, cell (3 x 3, rows the "
                             "lattice vectors) and strain, copies")
      .def_property_readonly("statistics", &PySimulation::statistics,
                             "the integrator's counters (steps, force evaluations, ...)")
      .def_property_readonly(
          "n", [](const PySimulation& s) { return s.sim().model().state().size(); },
          "the number of particles N")
      .def_property_readonly(
          "seed", [](const PySimulation& s) { return s.sim().seed(); },
          "the random seed of the initial positions")
      .def_property(
          "shear_rate", [](const PySimulation& s) { return s.sim().shear_rate(); },
          [](PySimulation& s, double rate) { s.sim().set_shear_rate(rate); },
          "the shear rate, 1/tau_0; the scene's [shear] rate (settable: the next advance shears at "
          "the "
          "new rate)");

  m.def("sweep", &sweep, py::arg("source") = py::none(), py::arg("out") = py::none(), py::kw_only(),
        py::arg("grid") = py::none(), py::arg("replicas") = py::none(), py::arg("jobs") = 0,
        py::arg("progress") = false, py::arg("strict") = false, py::arg("path") = py::none(),
        "Runs a sweep as `jamflow sweep` does (each point a `jamflow run`; finished points are "
        "kept and not rerun) and returns a table of every point: {column: numpy array}, one "
        "entry per point in point order.\n\n"
        "source: a sweep file's path (TOML with [sweep]); or, with grid, the base scene (a "
        "jamflow.Scene, a dict of sections, TOML text or a scene file's path). "
        "grid: {\"section.key\": [values], ...}, the axes of [sweep.grid] (a Cartesian product, "
        "keys in alphabetical order, the first varying slowest; \"section\": [dicts] varies a "
        "whole section); values may be numpy arrays and numpy scalars, e.g. "
        "grid={\"shear.rate\": numpy.logspace(-3, -1, 3)}. replicas: with grid, the replicas "
        "per point (default: the scene's [run] replicas). out: the sweep's folder (points/, "
        "manifest.toml, table.csv); None: a sweep file's <stem>.sweep beside it, and for a grid "
        "a fresh folder made by tempfile.mkdtemp (jamflow-sweep-* in $TMPDIR or /tmp), kept, "
        "whose points the folder column names. jobs: points at once (0: the cores). progress: "
        "the engine's progress line on stderr. path: source's former name, still accepted.\n\n"
        "The columns are those of `jamflow sweep --collect` (point, the varied keys but shear.rate "
        "and ensemble.pressure, N, imposed_pressure at constant pressure, shear_rate, phi, "
        "pressure, sigma_xy, eta, mu with _err, verdicts, cost, folder, here absolute) and "
        "status: 'complete', or why a point has no results ('failed at t = ...: why', 'not "
        "run', ...). Numeric columns are float arrays, NaN where a point has no value; text "
        "columns are str arrays, so table['status'] == 'complete' selects the finished points. "
        "Points that did not finish give one RuntimeWarning naming them (strict=True raises "
        "IntegrationError instead). A bad scene, key or value in any point raises ConfigError "
        "before anything runs. Ctrl-C stops the points as `jamflow sweep` does.");
  m.def("sweep_points", &sweep_points, py::arg("path"),
        "The points of a sweep file (checked), without running them.");
  m.def(
      "_exe", [] { return jamflow_exe_for_module(); },
      "The jamflow binary this module runs points and comparisons with.");
  m.def(
      "_read_table",
      [](py::object path) {
        const auto t = jamflow::read_csv_table(
            py::module_::import("os").attr("fspath")(path).cast<std::string>());
        return table_columns(t.header, t.rows);
      },
      "A CSV table as {column: numpy array} (the one table reader, lib/table.hpp).");
  // `jamflow compare` from Python: the command line's own run (its checks, resume, Ctrl-C),
  // with its progress relayed to sys.stderr so that Jupyter shows it, and its table returned.
  for (const char* name : {"_exe", "_read_table", "ConfigError", "IntegrationError"})
    scope[name] = m.attr(name);
  py::exec(R"(
def compare(source, out=None, *, jobs=0, progress=False, plots=True, dry_run=False):
    """`jamflow compare SOURCE`: compare methods on a scene (docs/guide/compare.md).

    source: a compare file (TOML). out: the output folder (default: <stem>.compare beside the
    file). jobs: runs at once (0: the cores). progress: the command's progress lines, relayed
    to sys.stderr. plots: write the PNG plots. dry_run: count the runs and their CPU-hours,
    run nothing, and return None.

    Returns the comparison's table (DIR/table.csv: one row per setting; the reference, the
    paired errors with their floor, the cost, the verdicts, the rank) as {column: numpy array},
    as jamflow.sweep returns its table; the report is DIR/report.md. A rerun continues a
    comparison that stopped and redoes no finished run. A bad compare file raises ConfigError
    (the command's one-line error) before anything runs."""
    import os, subprocess, sys
    path = os.fspath(source)
    if out is None:
        stem = os.path.splitext(os.path.basename(path))[0]
        out = os.path.join(os.path.dirname(path), stem + ".compare")
    out = os.fspath(out)
    args = [_exe(), "compare", path, "--out", out]
    if jobs:
        args += ["-j", str(int(jobs))]
    if not plots:
        args.append("--no-plots")
    if dry_run:
        args.append("--dry-run")
    elif not progress:
        args.append("--quiet")
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines = []
    try:
        for line in proc.stderr:
            lines.append(line)
            if progress or dry_run:
                sys.stderr.write(line)
                sys.stderr.flush()
        stdout = proc.stdout.read()
        status = proc.wait()
    except KeyboardInterrupt:
        proc.wait()  # the command checkpoints its runs on the same Ctrl-C
        raise
    if dry_run and stdout:
        sys.stdout.write(stdout)
    errors = [l.strip() for l in lines if "error" in l.lower()]
    message = errors[-1] if errors else (lines[-1].strip() if lines else "exit %d" % status)
    message = message.split("jamflow: error: ", 1)[-1]
    if status == 2:
        raise ConfigError(message)
    if status != 0:
        raise IntegrationError("jamflow compare %s: exit %d: %s" % (path, status, message))
    if dry_run:
        return None
    return _read_table(os.path.join(out, "table.csv"))
)",
           scope);
  m.attr("compare") = scope["compare"];
  m.def("analyze", &analyze, py::arg("kind"), py::arg("data"), py::arg("out") = py::none(),
        py::kw_only(), py::arg("plots") = false,
        "`jamflow analyze KIND DATA...`: kind is 'hard-sphere', 'soft', 'olsson-teitel' or "
        "'flow-curve'; "
        "options as keywords (envelope_z=2, bootstrap=50). Returns the JSON result.");
  // One function per analysis, as the command line has one subcommand per analysis.
  for (const char* kind : {"hard-sphere", "soft", "olsson-teitel", "flow-curve"}) {
    std::string name = std::string("analyze_") + kind;
    for (char& c : name)
      if (c == '-')
        c = '_';
    const std::string doc = std::string("`jamflow analyze ") + kind +
                            " DATA...`: options as keywords; returns the JSON result.";
    m.def(
        name.c_str(),
        [kind = std::string(kind)](py::object data, py::object out, bool plots,
                                   py::kwargs options) {
          return analyze(kind, std::move(data), std::move(out), plots, std::move(options));
        },
        py::arg("data"), py::arg("out") = py::none(), py::kw_only(), py::arg("plots") = false,
        doc.c_str());
  }
}
