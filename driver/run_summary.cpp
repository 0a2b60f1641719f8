#include "driver/run_summary.hpp"

#include <hdf5.h>

#include <cmath>
#include <string>

#include "lib/error.hpp"
#include "lib/h5.hpp"
#include "lib/h5_handle.hpp"

namespace jamflow {

namespace {

using Handle = H5Handle;

bool has_attribute(hid_t obj, const char* name) {
  return H5Aexists(obj, name) > 0;
}

double read_double_attr(hid_t obj, const char* name, const std::string& where) {
  if (!has_attribute(obj, name))
    throw InputFileError(where + ": missing attribute '" + name + "'");
  Handle attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(attr.get()), H5Tclose);
  Handle space(H5Aget_space(attr.get()), H5Sclose);
  H5T_class_t cls = H5Tget_class(type.get());
  if ((cls != H5T_FLOAT && cls != H5T_INTEGER) || H5Sget_simple_extent_npoints(space.get()) != 1) {
    throw InputFileError(where + ": attribute '" + name + "' is not a numeric scalar");
  }
  double value = 0.0;
  if (H5Aread(attr.get(), H5T_NATIVE_DOUBLE, &value) < 0) {
    throw InputFileError(where + ": cannot read attribute '" + name + "'");
  }
  return value;
}

std::int64_t read_int_attr(hid_t obj, const char* name, const std::string& where) {
  if (!has_attribute(obj, name))
    throw InputFileError(where + ": missing attribute '" + name + "'");
  Handle attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(attr.get()), H5Tclose);
  Handle space(H5Aget_space(attr.get()), H5Sclose);
  if (H5Tget_class(type.get()) != H5T_INTEGER || H5Sget_simple_extent_npoints(space.get()) != 1) {
    throw InputFileError(where + ": attribute '" + name + "' is not an integer scalar");
  }
  std::int64_t value = 0;
  if (H5Aread(attr.get(), H5T_NATIVE_INT64, &value) < 0) {
    throw InputFileError(where + ": cannot read attribute '" + name + "'");
  }
  return value;
}

// Longest fixed-length string attribute read (scenes are a few kB): a corrupt size field must
// not become an allocation.
constexpr std::size_t kMaxStringBytes = std::size_t{1} << 24;

// Reads a string attribute stored either as variable- or fixed-length, one string.
std::string read_string_attr(hid_t obj, const char* name, const std::string& where) {
  if (!has_attribute(obj, name))
    throw InputFileError(where + ": missing attribute '" + name + "'");
  Handle attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  Handle type(H5Aget_type(attr.get()), H5Tclose);
  if (H5Tget_class(type.get()) != H5T_STRING) {
    throw InputFileError(where + ": attribute '" + name + "' is not a string");
  }
  // H5Aread writes every element: the buffers below hold one string.
  Handle space(H5Aget_space(attr.get()), H5Sclose);
  const hssize_t count = H5Sget_simple_extent_npoints(space.get());
  if (count != 1) {
    throw InputFileError(where + ": attribute '" + name + "' holds " + std::to_string(count) +
                         " strings; allowed: one string");
  }
  if (H5Tis_variable_str(type.get()) > 0) {
    Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mem.get(), H5T_VARIABLE);
    H5Tset_cset(mem.get(), H5Tget_cset(type.get()));
    char* raw = nullptr;
    if (H5Aread(attr.get(), mem.get(), &raw) < 0) {
      throw InputFileError(where + ": cannot read string attribute '" + name + "'");
    }
    std::string out = raw ? raw : "";
    H5free_memory(raw);
    return out;
  }
  const std::size_t size = H5Tget_size(type.get());
  if (size == 0 || size > kMaxStringBytes) {
    throw InputFileError(where + ": attribute '" + name + "' is a string of " +
                         std::to_string(size) + " bytes; allowed: 1 to " +
                         std::to_string(kMaxStringBytes));
  }
  std::string buf(size + 1, '\0');
  Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(mem.get(), size + 1);
  H5Tset_strpad(mem.get(), H5T_STR_NULLTERM);
  if (H5Aread(attr.get(), mem.get(), buf.data()) < 0) {
    throw InputFileError(where + ": cannot read string attribute '" + name + "'");
  }
  buf.resize(std::char_traits<char>::length(buf.c_str()));
  return buf;
}

std::string optional_root_string(hid_t file, const char* name, const std::string& where) {
  if (!has_attribute(file, name))
    return "";
  return read_string_attr(file, name, where);
}

}  // namespace

RunFileSummary read_run_file_summary(const std::string& path) {
  hdf5_setup();  // our one-line errors, not HDF5's printed stack
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.ok())
    throw InputFileError(path + ": cannot open as an HDF5 file");
  if (H5Lexists(file.get(), "summary", H5P_DEFAULT) <= 0) {
    throw InputFileError(path + ": no /summary group (not a completed `jamflow run` output?)");
  }
  Handle group(H5Gopen2(file.get(), "summary", H5P_DEFAULT), H5Gclose);
  if (!group.ok())
    throw InputFileError(path + ": /summary is not a group");
  const std::string where = path + ": /summary";
  RunFileSummary s;
  s.path = path;
  s.scene = optional_root_string(file.get(), "scene", path);
  s.version = optional_root_string(file.get(), "version", path);
  s.git_commit = optional_root_string(file.get(), "git_commit", path);
  s.created = optional_root_string(file.get(), "created", path);
  const hid_t g = group.get();
  s.ensemble = read_string_attr(g, "ensemble", where);
  if (s.ensemble != "constant_volume" && s.ensemble != "constant_pressure") {
    throw InputFileError(where + ": attribute 'ensemble' = '" + s.ensemble +
                         "' (allowed: constant_volume, constant_pressure)");
  }
  s.n = read_int_attr(g, "N", where);
  s.sigma_xy = read_double_attr(g, "sigma_xy", where);
  s.sigma_xy_err = read_double_attr(g, "sigma_xy_err", where);
  s.pressure = read_double_attr(g, "pressure", where);
  s.pressure_err = read_double_attr(g, "pressure_err", where);
  s.phi = read_double_attr(g, "phi", where);
  s.phi_err = read_double_attr(g, "phi_err", where);
  s.eta = read_double_attr(g, "eta", where);
  s.eta_err = read_double_attr(g, "eta_err", where);
  s.mu = read_double_attr(g, "mu", where);
  s.mu_err = read_double_attr(g, "mu_err", where);
  s.j = read_double_attr(g, "J", where);
  s.energy_balance = read_double_attr(g, "energy_balance", where);
  s.shear_rate = read_double_attr(g, "shear_rate", where);
  s.alpha = read_double_attr(g, "alpha", where);
  // Written by combine_replicas with several replicas only.
  if (has_attribute(g, "replicas"))
    s.replicas = read_double_attr(g, "replicas", where);
  const double nan = std::nan("");
  auto optional = [&](const char* name) {
    return has_attribute(g, name) ? read_double_attr(g, name, where) : nan;
  };
  s.sigma_xy_replica_err = optional("sigma_xy_replica_err");
  s.pressure_replica_err = optional("pressure_replica_err");
  s.phi_replica_err = optional("phi_replica_err");
  s.mu_replica_err = optional("mu_replica_err");
  if (s.ensemble == "constant_pressure") {
    s.imposed_pressure = read_double_attr(g, "imposed_pressure", where);
    s.has_imposed_pressure = true;
  }
  if (s.n < 1)
    throw InputFileError(where + ": N = " + std::to_string(s.n) +
                         " is out of range (must be >= 1)");
  return s;
}

}  // namespace jamflow
