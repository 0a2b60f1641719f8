// H5MD 1.1 trajectories (lib/h5md.hpp) over the HDF5 C API.
#include "lib/h5md.hpp"

#include <cmath>
#include <utility>
#include <vector>

#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "lib/h5_handle.hpp"

#ifndef JAMFLOW_VERSION
#define JAMFLOW_VERSION "unknown"
#endif

namespace jamflow {

namespace {

using Id = H5Handle;  // lib/h5_handle.hpp

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  H5Eclear2(H5E_DEFAULT);
  throw IoError("H5MD trajectory '" + path + "': cannot " + what);
}

void check(herr_t status, const std::string& path, const std::string& what) {
  if (status < 0)
    fail(path, what);
}

Id group(hid_t parent, const char* name, const std::string& path) {
  Id g(H5Gcreate2(parent, name, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
  if (!g.ok())
    fail(path, std::string("create group ") + name);
  return g;
}

void attr_string(hid_t object, const char* name, const std::string& value,
                 const std::string& path) {
  Id type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type.get(), value.size() + 1);
  H5Tset_strpad(type.get(), H5T_STR_NULLTERM);
  Id space(H5Screate(H5S_SCALAR), H5Sclose);
  Id a(H5Acreate2(object, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a.ok())
    fail(path, std::string("write attribute ") + name);
  check(H5Awrite(a.get(), type.get(), value.c_str()), path, std::string("write ") + name);
}

void attr_ints(hid_t object, const char* name, const std::vector<int>& values,
               const std::string& path) {
  const hsize_t dims[1] = {values.size()};
  Id space(values.size() == 1 ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, dims, nullptr),
           H5Sclose);
  Id a(H5Acreate2(object, name, H5T_STD_I32LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a.ok())
    fail(path, std::string("write attribute ") + name);
  check(H5Awrite(a.get(), H5T_NATIVE_INT, values.data()), path, std::string("write ") + name);
}

// A fixed dataset of `data` with shape `dims`.
void fixed(hid_t parent, const char* name, hid_t file_type, hid_t mem_type, const void* data,
           std::vector<hsize_t> dims, const std::string& path) {
  Id space(H5Screate_simple(int(dims.size()), dims.data(), nullptr), H5Sclose);
  Id d(H5Dcreate2(parent, name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
       H5Dclose);
  if (!d.ok())
    fail(path, std::string("create ") + name);
  check(H5Dwrite(d.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), path,
        std::string("write ") + name);
}

// An extendable dataset of frames x `inner` (H5MD "value", "step", "time").
void extendable(hid_t parent, const char* name, hid_t type, const std::vector<hsize_t>& inner,
                const std::string& path) {
  std::vector<hsize_t> dims{0}, max{H5S_UNLIMITED}, chunk{1};
  for (hsize_t d : inner) {
    dims.push_back(d);
    max.push_back(d);
    chunk.push_back(d);
  }
  if (inner.empty())
    chunk[0] = 1024;  // steps and times: many frames per chunk
  Id space(H5Screate_simple(int(dims.size()), dims.data(), max.data()), H5Sclose);
  Id plist(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  check(H5Pset_chunk(plist.get(), int(chunk.size()), chunk.data()), path, "set chunks");
  Id d(H5Dcreate2(parent, name, type, space.get(), H5P_DEFAULT, plist.get(), H5P_DEFAULT),
       H5Dclose);
  if (!d.ok())
    fail(path, std::string("create ") + name);
}

// A time-dependent H5MD element: a group with step, time and value.
void element(hid_t parent, const char* name, const std::vector<hsize_t>& inner,
             const std::string& path) {
  Id g = group(parent, name, path);
  extendable(g.get(), "step", H5T_STD_I64LE, {}, path);
  extendable(g.get(), "time", H5T_IEEE_F64LE, {}, path);
  extendable(g.get(), "value", H5T_IEEE_F64LE, inner, path);
}

// Sets the number of frames of dataset `name` to `frames` and, with data, writes frame
// frames - 1.
void write_frame(hid_t file, const std::string& name, std::int64_t frames, hid_t mem_type,
                 const void* data, const std::string& path) {
  Id d(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!d.ok())
    fail(path, "open " + name);
  Id space0(H5Dget_space(d.get()), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space0.get());
  std::vector<hsize_t> dims(rank);
  H5Sget_simple_extent_dims(space0.get(), dims.data(), nullptr);
  dims[0] = hsize_t(frames);
  check(H5Dset_extent(d.get(), dims.data()), path, "extend " + name);
  if (!data)
    return;
  Id space(H5Dget_space(d.get()), H5Sclose);
  std::vector<hsize_t> start(rank, 0), count = dims;
  start[0] = hsize_t(frames - 1);
  count[0] = 1;
  check(H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(),
                            nullptr),
        path, "select a frame of " + name);
  Id mem(H5Screate_simple(rank, count.data(), nullptr), H5Sclose);
  check(H5Dwrite(d.get(), mem_type, mem.get(), space.get(), H5P_DEFAULT, data), path,
        "write " + name);
}

// /parameters (H5MD's group for simulation parameters, created if missing): the attributes
// `scene` (the run's scene, TOML) and `seed` (this replica's seed), replacing any there.
void write_parameters(hid_t file, const std::string& scene, std::uint64_t seed,
                      const std::string& path) {
  const htri_t there = H5Lexists(file, "parameters", H5P_DEFAULT);
  if (there < 0)
    fail(path, "look for /parameters");
  Id g(there > 0 ? H5Gopen2(file, "parameters", H5P_DEFAULT)
                 : H5Gcreate2(file, "parameters", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
       H5Gclose);
  if (!g.ok())
    fail(path, "open or create /parameters");
  for (const char* name : {"scene", "seed"}) {
    const htri_t has = H5Aexists(g.get(), name);
    if (has < 0 || (has > 0 && H5Adelete(g.get(), name) < 0))
      fail(path, std::string("replace /parameters ") + name);
  }
  {
    // Variable-length UTF-8, as the run file's scene: h5py reads it as str (not bytes).
    Id type(H5Tcopy(H5T_C_S1), H5Tclose);
    if (H5Tset_size(type.get(), H5T_VARIABLE) < 0 || H5Tset_cset(type.get(), H5T_CSET_UTF8) < 0)
      fail(path, "make a string type");
    Id space(H5Screate(H5S_SCALAR), H5Sclose);
    Id a(H5Acreate2(g.get(), "scene", type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    const char* text = scene.c_str();
    if (!a.ok() || H5Awrite(a.get(), type.get(), &text) < 0)
      fail(path, "write attribute scene");
  }
  Id space(H5Screate(H5S_SCALAR), H5Sclose);
  Id a(H5Acreate2(g.get(), "seed", H5T_STD_U64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a.ok())
    fail(path, "write attribute seed");
  check(H5Awrite(a.get(), H5T_NATIVE_UINT64, &seed), path, "write seed");
}

const char* const kElements[] = {"/particles/all/position", "/particles/all/box/edges",
                                 "/observables/strain"};

}  // namespace

H5mdTrajectory::H5mdTrajectory(const std::string& path, const State& state,
                               const std::string& scene, std::uint64_t seed,
                               std::int64_t keep_frames)
    : path_(path), n_(std::int64_t(state.size())) {
  hdf5_setup();
  if (keep_frames >= 0) {
    file_ = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    if (file_ < 0)
      fail(path, "open it to continue");
    frames_ = keep_frames;
    for (const char* e : kElements) {
      for (const char* part : {"/step", "/time", "/value"})
        write_frame(file_, std::string(e) + part, frames_, H5T_NATIVE_DOUBLE, nullptr, path_);
    }
    write_parameters(file_, scene, seed, path);  // a file written before it had none
    return;
  }
  file_ = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (file_ < 0)
    fail(path, "create it");
  {
    Id h5md = group(file_, "h5md", path);
    attr_ints(h5md.get(), "version", {1, 1}, path);
    Id author = group(h5md.get(), "author", path);
    attr_string(author.get(), "name", "jamflow", path);
    Id creator = group(h5md.get(), "creator", path);
    attr_string(creator.get(), "name", "jamflow", path);
    attr_string(creator.get(), "version", JAMFLOW_VERSION, path);
  }
  Id particles = group(file_, "particles", path);
  Id all = group(particles.get(), "all", path);
  {
    Id box = group(all.get(), "box", path);
    attr_ints(box.get(), "dimension", {3}, path);
    // boundary: a string array of three "periodic".
    Id type(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(type.get(), 9);
    H5Tset_strpad(type.get(), H5T_STR_NULLTERM);
    const hsize_t three[1] = {3};
    Id space(H5Screate_simple(1, three, nullptr), H5Sclose);
    Id a(H5Acreate2(box.get(), "boundary", type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT),
         H5Aclose);
    const char periodic[3][9] = {"periodic", "periodic", "periodic"};
    if (!a.ok() || H5Awrite(a.get(), type.get(), periodic) < 0)
      fail(path, "write box boundary");
    element(box.get(), "edges", {3, 3}, path);
  }
  element(all.get(), "position", {hsize_t(n_), 3}, path);
  std::vector<std::int64_t> species(state.size());
  std::vector<double> diameter(state.size());
  for (std::size_t i = 0; i < state.size(); ++i) {
    const auto id = std::size_t(state.id[i]);
    species[id] = state.species[i];
    diameter[id] = state.diameter[i];
  }
  fixed(all.get(), "species", H5T_STD_I64LE, H5T_NATIVE_INT64, species.data(), {hsize_t(n_)}, path);
  fixed(all.get(), "diameter", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, diameter.data(), {hsize_t(n_)},
        path);
  Id observables = group(file_, "observables", path);
  element(observables.get(), "strain", {}, path);
  write_parameters(file_, scene, seed, path);
}

H5mdTrajectory::~H5mdTrajectory() {
  if (file_ >= 0)
    H5Fclose(file_);
}

void H5mdTrajectory::append(const State& state, std::int64_t step, double time) {
  if (std::int64_t(state.size()) != n_)
    throw IoError("H5MD trajectory '" + path_ + "': the particle count changed");
  const std::size_t n = state.size();
  std::vector<double> pos(3 * n);
  const Eigen::Matrix3d h = state.box.h();
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Vector3d s = state.scaled(i);
    for (int d = 0; d < 3; ++d) {
      s[d] -= std::floor(s[d]);
      if (s[d] >= 1.0)
        s[d] = 0.0;  // a tiny negative value can round up to 1
    }
    const Eigen::Vector3d r = h * s;
    const auto id = std::size_t(state.id[i]);
    for (int d = 0; d < 3; ++d)
      pos[3 * id + std::size_t(d)] = r[d];
  }
  double edges[9];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      edges[3 * a + b] = h(b, a);  // row a = lattice vector a (column a of h)
  ++frames_;
  const std::int64_t steps[1] = {step};
  const double times[1] = {time};
  for (const char* e : kElements) {
    write_frame(file_, std::string(e) + "/step", frames_, H5T_NATIVE_INT64, steps, path_);
    write_frame(file_, std::string(e) + "/time", frames_, H5T_NATIVE_DOUBLE, times, path_);
  }
  write_frame(file_, "/particles/all/position/value", frames_, H5T_NATIVE_DOUBLE, pos.data(),
              path_);
  write_frame(file_, "/particles/all/box/edges/value", frames_, H5T_NATIVE_DOUBLE, edges, path_);
  write_frame(file_, "/observables/strain/value", frames_, H5T_NATIVE_DOUBLE, &state.box.strain,
              path_);
}

void H5mdTrajectory::flush() {
  check(H5Fflush(file_, H5F_SCOPE_GLOBAL), path_, "flush it");
}

void H5mdTrajectory::close() {
  if (file_ < 0)
    return;
  const hid_t f = std::exchange(file_, -1);
  check(H5Fclose(f), path_, "close it");
}

}  // namespace jamflow
