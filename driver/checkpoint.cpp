// Checkpoint layout (driver/checkpoint.hpp): plain datasets and attributes, so that h5py shows
// what a run will continue from. Doubles are stored as IEEE binary64, so a continued run starts
// from exactly the bits the interrupted one held.
#include "driver/checkpoint.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>

#include "lib/config.hpp"
#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "lib/state.hpp"

namespace jamflow {

namespace {

std::vector<double> flat(const Eigen::Matrix3d& m) {
  std::vector<double> v(9);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      v[3 * a + b] = m(a, b);
  return v;
}

Eigen::Matrix3d matrix(const std::vector<double>& v, const std::string& what) {
  if (v.size() != 9)
    throw IoError(what + " holds " + std::to_string(v.size()) + " values, not 9");
  Eigen::Matrix3d m;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      m(a, b) = v[3 * a + b];
  return m;
}

template <class To, class From>
std::vector<To> convert(const std::vector<From>& v) {
  return std::vector<To>(v.begin(), v.end());
}

void write_state(H5Writer& w, const std::string& g, const State& s) {
  w.dataset(g + "/pos", s.pos);
  w.dataset(g + "/image", convert<std::int64_t>(s.image));
  w.dataset(g + "/diameter", s.diameter);
  w.dataset(g + "/species", convert<std::int64_t>(s.species));
  w.dataset(g + "/id", s.id);
  for (const char* name : {"pos", "image", "diameter", "species", "id"})
    write_unit(w, g + "/" + name);
  w.attr(g, "lx", s.box.lx);
  w.attr(g, "ly", s.box.ly);
  w.attr(g, "lz", s.box.lz);
  w.attr(g, "strain", s.box.strain);
  w.attr(g, "flips", s.box.flips);
  w.attr(g, "time", s.time);
}

State read_state(const H5Reader& r, const std::string& g) {
  State s;
  const std::vector<double> diameter = r.read_doubles(g + "/diameter");
  const std::size_t n = diameter.size();
  s.resize(n);
  s.diameter = diameter;
  s.pos = r.read_doubles(g + "/pos");
  const auto image = r.read_ints(g + "/image");
  const auto species = r.read_ints(g + "/species");
  s.id = r.read_ints(g + "/id");
  if (s.pos.size() != 3 * n || image.size() != 3 * n || species.size() != n || s.id.size() != n)
    throw IoError(g + ": positions, images, species and ids are not all of " + std::to_string(n) +
                  " particles");
  for (std::size_t k = 0; k < 3 * n; ++k)
    s.image[k] = static_cast<std::int32_t>(image[k]);
  for (std::size_t k = 0; k < n; ++k)
    s.species[k] = static_cast<std::uint8_t>(species[k]);
  s.box.lx = r.attr_double(g, "lx");
  s.box.ly = r.attr_double(g, "ly");
  s.box.lz = r.attr_double(g, "lz");
  s.box.strain = r.attr_double(g, "strain");
  s.box.flips = r.attr_int(g, "flips");
  s.time = r.attr_double(g, "time");
  return s;
}

void write_list(H5Writer& w, const std::string& g, const NeighbourList::Snapshot& l) {
  w.group(g);
  w.attr(g, "skin", l.skin);
  w.attr(g, "inner_skin", l.inner_skin);
  w.attr(g, "built", std::int64_t(l.built));
  w.attr(g, "builds", std::int64_t(l.builds));
  w.attr(g, "inner_builds", std::int64_t(l.inner_builds));
  w.attr(g, "a_min", l.a_min);
  w.attr(g, "a_max", l.a_max);
  if (!l.built)
    return;
  w.dataset(g + "/start", l.start);
  w.dataset(g + "/entries", l.entries);
  w.dataset(g + "/inner_start", l.inner_start);
  w.dataset(g + "/inner_entries", l.inner_entries);
  w.dataset(g + "/ref_pos", l.ref_pos);
  w.dataset(g + "/inner_ref_pos", l.inner_ref_pos);
  w.dataset(g + "/h_ref_inv", flat(l.h_ref_inv), {3, 3});
  w.dataset(g + "/inner_h_ref_inv", flat(l.inner_h_ref_inv), {3, 3});
  for (const char* name : {"start", "entries", "inner_start", "inner_entries", "ref_pos",
                           "inner_ref_pos", "h_ref_inv", "inner_h_ref_inv"})
    write_unit(w, g + "/" + name);
}

NeighbourList::Snapshot read_list(const H5Reader& r, const std::string& g) {
  NeighbourList::Snapshot l;
  l.skin = r.attr_double(g, "skin");
  l.inner_skin = r.attr_double(g, "inner_skin");
  l.built = r.attr_int(g, "built") != 0;
  l.builds = static_cast<std::size_t>(r.attr_int(g, "builds"));
  l.inner_builds = static_cast<std::size_t>(r.attr_int(g, "inner_builds"));
  l.a_min = r.attr_double(g, "a_min");
  l.a_max = r.attr_double(g, "a_max");
  if (!l.built)
    return l;
  l.start = r.read_uint32s(g + "/start");
  l.entries = r.read_uint32s(g + "/entries");
  l.inner_start = r.read_uint32s(g + "/inner_start");
  l.inner_entries = r.read_uint32s(g + "/inner_entries");
  l.ref_pos = r.read_doubles(g + "/ref_pos");
  l.inner_ref_pos = r.read_doubles(g + "/inner_ref_pos");
  l.h_ref_inv = matrix(r.read_doubles(g + "/h_ref_inv"), g + "/h_ref_inv");
  l.inner_h_ref_inv = matrix(r.read_doubles(g + "/inner_h_ref_inv"), g + "/inner_h_ref_inv");
  return l;
}

}  // namespace

bool timeseries_has(const RunSpec& spec, std::string_view column) {
  return column != "piston_dissipation" || spec.ensemble->has_piston();
}

std::string checkpoint_digest(const std::string& scene_text, const std::string& version,
                              const std::vector<ReplicaResult>& replicas) {
  Scene scene = Scene::parse(scene_text, "scene");
  for (const char* key : {"run.threads", "output.file", "run.t_av", "run.target_error",
                          "run.max_time", "output.checkpoint_every"})
    scene.set_value(key, toml::value<std::string>("*"));
  // The legacy text: a digest written before floats were printed short still matches.
  std::string text = scene.legacy_text() + "\nversion " + version + "\n";
  auto bits = [](double v) {
    std::uint64_t b;
    std::memcpy(&b, &v, sizeof b);
    return std::to_string(b);
  };
  for (const auto& r : replicas) {
    const State& s = r.end.state;
    text += std::to_string(s.size()) + " " + std::to_string(r.series.samples.size()) + " " +
            bits(s.time) + " " + bits(s.box.lx) + " " + bits(s.box.ly) + " " + bits(s.box.lz) +
            "\n";
  }
  std::uint64_t h = 14695981039346656037ull;
  for (const unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ull;
  }
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return hex;
}

void write_checkpoint(H5Writer& w, const RunSpec& spec, const std::vector<ReplicaResult>& replicas,
                      const std::vector<std::string>& timeseries) {
  w.group("/checkpoint");
  w.attr("/checkpoint", "format", kCheckpointFormat);
  w.attr("/checkpoint", "digest", checkpoint_digest(spec.scene_text, JAMFLOW_VERSION, replicas));
  w.attr("/checkpoint", "replicas", static_cast<std::int64_t>(replicas.size()));
  for (std::size_t k = 0; k < replicas.size(); ++k) {
    const ReplicaResult& res = replicas[k];
    const std::string g = "/checkpoint/replicas/" + std::to_string(k);
    // The series is the run's own timeseries group: stored once, named here. Only what that
    // group lacks (piston_dissipation without a piston, zeros) is stored in the checkpoint.
    w.group(g);
    w.attr(g, "series", timeseries.at(k));
    for (const auto& [name, field] : kSeriesFields) {
      if (!timeseries_has(spec, name)) {
        w.dataset(g + "/series/" + name, res.series.column(field));
        write_unit(w, g + "/series/" + name);
      }
    }
    w.attr(g, "seed", static_cast<std::int64_t>(res.seed));
    w.attr(g, "status", res.status.text());
    w.attr(g, "wall_seconds", res.wall_seconds);
    w.attr(g, "cpu_seconds", res.cpu_seconds);
    w.attr(g, "cpu_from_wall", std::int64_t(res.cpu_from_wall));
    w.attr(g, "trajectory_bytes", res.trajectory_bytes);
    w.attr(g, "kernel", res.kernel);
    w.attr(g, "kernel_target", res.kernel_target);
    w.attr(g, "threads", std::int64_t(res.threads));
    w.attr(g, "resumes", res.resumes);
    w.attr(g, "history", res.history);
    w.attr(g, "t_start", res.t_start);
    w.attr(g, "horizon", res.horizon);
    w.attr(g, "step_cross", res.steps.cross);
    w.attr(g, "step_norm", res.steps.norm);
    w.attr(g, "step_pairs", res.steps.pairs);
    w.group(g + "/integrator");
    for (const auto& [name, v] : res.integrator_stats)
      w.attr(g + "/integrator", name, v);
    const Model::Snapshot& m = res.end;
    const std::string mg = g + "/model";
    w.group(mg);
    w.attr(mg, "evaluations", std::int64_t(m.evaluations));
    w.attr(mg, "builds_at_last_sort", std::int64_t(m.builds_at_last_sort));
    w.attr(mg, "sorted_once", std::int64_t(m.sorted_once));
    w.attr(mg, "evaluated", std::int64_t(m.evaluated));
    w.attr(mg, "particle_volume", m.particle_volume);
    write_state(w, mg + "/state", m.state);
    write_list(w, mg + "/list", m.list);
  }
}

std::vector<ReplicaResult> read_checkpoint(const H5Reader& r) {
  if (!r.exists("/checkpoint"))
    throw IoError("no /checkpoint group: not a jamflow run file, or written before checkpoints");
  const std::int64_t format = r.attr_int("/checkpoint", "format");
  if (format != kCheckpointFormat)
    throw IoError("/checkpoint format " + std::to_string(format) + "; this jamflow reads " +
                  std::to_string(kCheckpointFormat));
  const std::int64_t count = r.attr_int("/checkpoint", "replicas");
  std::vector<ReplicaResult> out;
  for (std::int64_t k = 0; k < count; ++k) {
    const std::string g = "/checkpoint/replicas/" + std::to_string(k);
    ReplicaResult res;
    // Each column from the checkpoint's own series (files written before the series was stored
    // once hold every column there), else from the timeseries group it names.
    const std::string elsewhere = r.has_attr(g, "series") ? r.attr_string(g, "series") : "";
    std::vector<std::vector<double>> columns;
    for (const auto& [name, field] : kSeriesFields) {
      (void)field;
      const std::string own = g + "/series/" + name;
      if (r.exists(own) || elsewhere.empty())
        columns.push_back(r.read_doubles(own));
      else
        columns.push_back(r.read_doubles(elsewhere + "/" + name));
      if (columns.back().size() != columns.front().size())
        throw IoError(g + "/series: columns of different lengths");
    }
    res.series.samples.resize(columns.front().size());
    for (std::size_t c = 0; c < columns.size(); ++c)
      for (std::size_t s = 0; s < columns[c].size(); ++s)
        res.series.samples[s].*(kSeriesFields[c].field) = columns[c][s];
    res.seed = static_cast<std::uint64_t>(r.attr_int(g, "seed"));
    res.status = RunStatus::parse(r.attr_string(g, "status"));
    res.wall_seconds = r.attr_double(g, "wall_seconds");
    // A checkpoint written before CPU time was recorded: its wall seconds stand in.
    res.cpu_from_wall = !r.has_attr(g, "cpu_seconds") ||
                        (r.has_attr(g, "cpu_from_wall") && r.attr_int(g, "cpu_from_wall") != 0);
    res.cpu_seconds =
        r.has_attr(g, "cpu_seconds") ? r.attr_double(g, "cpu_seconds") : res.wall_seconds;
    res.trajectory_bytes = r.attr_int(g, "trajectory_bytes");
    res.kernel = r.attr_string(g, "kernel");
    res.kernel_target = r.attr_string(g, "kernel_target");
    res.threads = static_cast<int>(r.attr_int(g, "threads"));
    res.resumes = r.attr_int(g, "resumes");
    res.history = r.attr_string(g, "history");
    res.t_start = r.attr_double(g, "t_start");
    res.horizon = r.attr_double(g, "horizon");
    res.steps.cross = r.attr_double(g, "step_cross");
    res.steps.norm = r.attr_double(g, "step_norm");
    res.steps.pairs = r.attr_int(g, "step_pairs");
    for (const auto& name : r.attr_names(g + "/integrator"))
      res.integrator_stats.emplace_back(name, r.attr_double(g + "/integrator", name));
    const std::string mg = g + "/model";
    Model::Snapshot& m = res.end;
    m.evaluations = static_cast<std::size_t>(r.attr_int(mg, "evaluations"));
    m.builds_at_last_sort = static_cast<std::size_t>(r.attr_int(mg, "builds_at_last_sort"));
    m.sorted_once = r.attr_int(mg, "sorted_once") != 0;
    m.evaluated = r.attr_int(mg, "evaluated") != 0;
    m.particle_volume = r.attr_double(mg, "particle_volume");
    m.state = read_state(r, mg + "/state");
    m.list = read_list(r, mg + "/list");
    res.final_state = m.state;
    out.push_back(std::move(res));
  }
  return out;
}

namespace {

Summary read_summary(const H5Reader& r, const std::string& g) {
  Summary s;
  if (!r.exists(g))
    return s;  // a replica stopped before its summary (the budget) has no numbers: not computed
  for (const auto& name : r.attr_names(g)) {
    if (name.rfind("verdict_", 0) == 0) {
      if (Verdict* v = s.verdict(name.substr(8)))
        *v = Verdict::parse(r.attr_string(g, name));
    } else if (name == "run_length" || name == "t_eq_method") {
      (name == "run_length" ? s.run_length : s.t_eq_method) = r.attr_string(g, name);
    } else {
      // The summary's numbers (Summary::set); the attributes that describe the run (N, alpha,
      // the ensemble's, the integrator's, the times) and the verdicts' values are not set.
      try {
        s.set(name, r.attr_double(g, name));
      } catch (const std::exception&) {
        // text attributes (ensemble, status) are not summary values
      }
    }
  }
  return s;
}

}  // namespace

RunFile read_run_file(const std::string& path, bool everything) {
  const H5Reader r(path);
  RunFile f;
  f.scene = r.has_attr("/", "scene") ? r.attr_string("/", "scene") : "";
  f.status = r.has_attr("/", "status") ? RunStatus::parse(r.attr_string("/", "status"))
                                       : RunStatus::unreadable("no status attribute");
  const std::int64_t count = r.has_attr("/", "replicas") ? r.attr_int("/", "replicas") : 1;
  if (everything) {
    f.replicas = read_checkpoint(r);
  } else {
    f.replicas.resize(static_cast<std::size_t>(std::max<std::int64_t>(count, 0)));
  }
  if (static_cast<std::int64_t>(f.replicas.size()) != count)
    throw IoError(
        "'" + path + "': " + std::to_string(f.replicas.size()) +
        " replicas in /checkpoint, but the root attribute replicas = " + std::to_string(count));
  for (std::size_t k = 0; k < f.replicas.size(); ++k) {
    const std::string g = count > 1 ? "/replicas/" + std::to_string(k) + "/summary" : "/summary";
    ReplicaResult& res = f.replicas[k];
    res.summary = read_summary(r, g);
    if (!everything) {
      res.status =
          r.has_attr(g, "status") ? RunStatus::parse(r.attr_string(g, "status")) : f.status;
      if (r.has_attr(g, "wall_seconds"))
        res.wall_seconds = r.attr_double(g, "wall_seconds");
      // A file written before CPU time was recorded: its wall seconds stand in.
      res.cpu_from_wall = !r.has_attr(g, "cpu_seconds") || r.has_attr(g, "cpu_seconds_note");
      res.cpu_seconds =
          r.has_attr(g, "cpu_seconds") ? r.attr_double(g, "cpu_seconds") : res.wall_seconds;
      if (r.exists(g)) {
        for (const auto& name : r.attr_names(g)) {
          if (name.rfind("integrator_", 0) != 0)
            continue;
          try {
            res.integrator_stats.emplace_back(name.substr(11), r.attr_double(g, name));
          } catch (const std::exception&) {
            // the integrator's kind is text
          }
        }
      }
    }
  }
  return f;
}

Continuation read_continuation(const std::string& path, const std::string& option) {
  Continuation c;
  {
    const H5Reader r(path);
    c.scene = r.attr_string("/", "scene");
    c.status = RunStatus::parse(r.attr_string("/", "status"));
    c.replicas = read_checkpoint(r);
    check_checkpoint_matches(r, c.replicas, option, path);
  }
  const RunFile file = read_run_file(path, false);
  for (std::size_t k = 0; k < c.replicas.size() && k < file.replicas.size(); ++k)
    if (c.replicas[k].status.is_complete())
      c.replicas[k].summary = file.replicas[k].summary;
  return c;
}

RunStatus read_run_status(const std::string& path) {
  try {
    const H5Reader r(path);
    return r.has_attr("/", "status") ? RunStatus::parse(r.attr_string("/", "status"))
                                     : RunStatus::unreadable("no status attribute");
  } catch (const std::exception& e) {
    return RunStatus::unreadable(e.what());
  }
}

void check_checkpoint_matches(const H5Reader& r, const std::vector<ReplicaResult>& replicas,
                              const std::string& option, const std::string& file) {
  const std::string scene_text = r.attr_string("/", "scene");
  const std::string allowed =
      "; allowed the file as the run wrote it (" + option + " takes its scene; " +
      (option == "--resume" ? "only --set run.threads=N may change it)"
                            : "--set may change only run.t_av, run.target_error, run.max_time, "
                              "run.threads and output.checkpoint_every)");
  if (r.has_attr("/checkpoint", "digest")) {
    const std::string version = r.has_attr("/", "version") ? r.attr_string("/", "version") : "";
    if (checkpoint_digest(scene_text, version, replicas) != r.attr_string("/checkpoint", "digest"))
      throw ConfigError(option + " '" + file +
                        "': its scene or version attribute does not match its checkpoint "
                        "(digest)" +
                        allowed);
    return;
  }
  // Written before the digest: what the state itself tells.
  const Scene scene = Scene::parse(scene_text, file);
  const toml::table* sys = scene.table("system");
  const toml::node* n = sys ? sys->get("N") : nullptr;
  const bool from_init = sys && sys->get("init");
  for (const auto& rep : replicas) {
    if (n && !from_init && n->is_integer() &&
        static_cast<std::int64_t>(rep.end.state.size()) != n->as_integer()->get())
      throw ConfigError(option + " '" + file + "': its scene says N = " +
                        std::to_string(n->as_integer()->get()) + ", its checkpoint holds " +
                        std::to_string(rep.end.state.size()) + " particles" + allowed);
    const toml::table* ens = scene.table("ensemble");
    const toml::node* kind = ens ? ens->get("kind") : nullptr;
    if (kind && kind->is_string() && kind->as_string()->get() == "constant_volume") {
      // Every sample, and the state where it stopped against the cell its scene starts from
      // (a checkpoint stopped early holds one sample or none, but a state that has moved on).
      const auto& s = rep.series.samples;
      bool end_moved = !s.empty() && rep.end.state.box.volume() != s.front().volume;
      const toml::node* phi = sys ? sys->get("phi") : nullptr;
      if (!from_init && phi && phi->is_number() && n && n->is_integer()) {
        const double v0 =
            Box::cubic(volume_for_phi(static_cast<std::size_t>(n->as_integer()->get()),
                                      phi->value<double>().value_or(0.0)))
                .volume();
        end_moved = end_moved || std::abs(rep.end.state.box.volume() - v0) > 1e-12 * v0;
      }
      for (const auto& sample : s) {
        if (end_moved || sample.volume != s.front().volume)
          throw ConfigError(option + " '" + file +
                            "': its scene says constant_volume, but the cell volume of its "
                            "checkpoint changes (a constant-pressure run)" +
                            allowed);
      }
    }
  }
}

bool replica_finished(const RunSpec& spec, const ReplicaResult& r) {
  const auto k_max =
      static_cast<std::size_t>(std::floor((spec.t_eq + spec.t_av) / spec.sample_every + 1e-9));
  return r.status.is_complete() &&
         (spec.auto_eq || spec.auto_av || r.series.samples.size() > k_max);
}

void check_continuation(const RunSpec& spec, const std::vector<ReplicaResult>& replicas,
                        const std::string& option, const std::string& file) {
  if (replicas.empty() || static_cast<std::int64_t>(replicas.size()) < spec.replicas)
    return;  // a replica still to start
  for (const auto& r : replicas)
    if (!replica_finished(spec, r))
      return;
  if (option == "--resume")
    throw ConfigError("--resume '" + file +
                      "': the run is finished (status complete); allowed a stopped run's "
                      "checkpoint (a finished run is lengthened with --extend)");
  if (spec.auto_eq || spec.auto_av)
    throw ConfigError("--extend '" + file +
                      "': the run's window was found from its data (t_eq or t_av = \"auto\"); "
                      "allowed --set run.t_av=T with a fixed t_eq, at least one sample longer");
  const auto& s = replicas.front().series.samples;
  const double reached = s.empty() ? 0.0 : s.back().time;
  throw ConfigError("--extend '" + file + "': [run] t_eq + t_av = " + fmt(spec.t_eq + spec.t_av) +
                    " does not lengthen the run, which has reached t = " + fmt(reached) +
                    "; allowed --set run.t_av=T with t_eq + T at least one sample_every (" +
                    fmt(spec.sample_every) + ") beyond that");
}

std::string write_run_file_elsewhere(const RunSpec& spec,
                                     const std::vector<ReplicaResult>& replicas, std::string* why) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path tmp = fs::temp_directory_path(ec);
  const fs::path out = fs::absolute(spec.file, ec).parent_path();
  if (tmp.empty() || fs::equivalent(tmp, out, ec)) {
    if (why)
      *why = "the temporary folder is the output's own";
    return "";
  }
  const std::string path =
      (tmp / (fs::path(spec.file).stem().string() + "." + std::to_string(::getpid()) + ".h5"))
          .string();
  try {
    write_run_file(spec, replicas, path);
    return path;
  } catch (const std::exception& e) {
    if (why)
      *why = e.what();
    return "";
  }
}

std::string kept_message(const std::string& file, const std::string& write_error,
                         const std::string& kept_in) {
  if (!kept_in.empty())
    return write_error + "; the finished run is written to " + kept_in + " instead (" + file +
           ".part holds only the last checkpoint before it)";
  return write_error + "; it could not be written elsewhere either, and only " + file +
         ".part is kept: the last checkpoint written before (continue it with --resume " + file +
         ".part)";
}

}  // namespace jamflow
