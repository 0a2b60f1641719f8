// HDF5 writer and reader (lib/h5.hpp) over the C API: every return code is checked here, at
// the boundary, and turned into a one-line IoError naming the file and the object.
#include "lib/h5.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <utility>
#include <variant>

#include "lib/error.hpp"
#include "lib/h5_handle.hpp"

namespace jamflow {

void hdf5_setup() {
  // No exit-time cleanup by libhdf5: every file is closed by its owner, and a file HDF5 could
  // not close (its last writes failed: a full disk, a file-size limit) would make that cleanup
  // crash (H5F__close_cb). Only possible before the library's first use; harmless after.
  static const bool once = [] {
    H5dont_atexit();
    return true;
  }();
  (void)once;
  // HDF5 prints its whole error stack to stderr by default; users should see only our one-line
  // errors. The setting is per thread in thread-safe builds, hence thread_local.
  thread_local const bool silenced = [] {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    return true;
  }();
  (void)silenced;
}

namespace {

void silence_hdf5() {
  hdf5_setup();
}

// The most specific message on HDF5's error stack (e.g. "unable to open file: ... errno = 2,
// error message = 'No such file or directory'"). Must be called before any other HDF5 call,
// since each API call clears the stack.
std::string hdf5_reason() {
  std::string reason;
  auto walk = [](unsigned n, const H5E_error2_t* err, void* data) -> herr_t {
    auto* out = static_cast<std::string*>(data);
    if (n == 0 && err->desc != nullptr)
      *out = err->desc;
    return 0;
  };
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, walk, &reason);
  H5Eclear2(H5E_DEFAULT);
  // File-open failures embed the system's reason among driver flags; the reason is what users
  // can act on.
  const std::string marker = "error message = '";
  const std::size_t start = reason.find(marker);
  if (start != std::string::npos) {
    const std::size_t end = reason.find('\'', start + marker.size());
    if (end != std::string::npos)
      return reason.substr(start + marker.size(), end - start - marker.size());
  }
  return reason.empty() ? "HDF5 error" : reason;
}

using Handle = H5Handle;

std::string quoted(const std::string& s) {
  return "'" + s + "'";
}

// Link-creation properties that make "/a/b/c" create /a and /a/b on the way.
Handle intermediate_lcpl() {
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
  if (!lcpl.ok() || H5Pset_create_intermediate_group(lcpl.get(), 1) < 0) {
    throw IoError("HDF5: cannot create a link-creation property list: " + hdf5_reason());
  }
  return lcpl;
}

// Whether every component of an absolute or root-relative path exists (H5Lexists fails, rather
// than returning false, when an intermediate component is missing).
bool link_exists(hid_t file, const std::string& path) {
  std::size_t pos = 0;
  while (pos < path.size() && path[pos] == '/')
    ++pos;
  if (pos == path.size())
    return true;  // the root
  while (true) {
    const std::size_t slash = path.find('/', pos);
    const std::string prefix = path.substr(0, slash);
    if (H5Lexists(file, prefix.c_str(), H5P_DEFAULT) <= 0) {
      H5Eclear2(H5E_DEFAULT);
      return false;
    }
    if (slash == std::string::npos)
      return true;
    pos = slash + 1;
    while (pos < path.size() && path[pos] == '/')
      ++pos;
    if (pos == path.size())
      return true;
  }
}

// H5Oget_info's signature differs between HDF5 1.10 and 1.12; the identifier type does not.
bool is_group(hid_t file, const std::string& path) {
  const Handle obj(H5Oopen(file, path.c_str(), H5P_DEFAULT), H5Oclose);
  if (!obj.ok())
    H5Eclear2(H5E_DEFAULT);
  return obj.ok() && H5Iget_type(obj.get()) == H5I_GROUP;
}

// HDF5's own message for "/x/y" below a dataset /x is "message type not found"; name the
// culprit instead.
void require_group_parents(hid_t file, const std::string& file_path, const std::string& path) {
  std::size_t slash = path.find('/', path.find_first_not_of('/'));
  while (slash != std::string::npos) {
    const std::string prefix = path.substr(0, slash);
    if (!link_exists(file, prefix))
      return;  // created as an intermediate group
    if (!is_group(file, prefix)) {
      throw IoError(file_path + ": cannot create " + quoted(path) + ": " + quoted(prefix) +
                    " is not a group");
    }
    slash = path.find('/', slash + 1);
  }
}

struct StringVec {
  std::vector<std::string> names;
};

// Iteration callbacks must not throw through the C library: copy the name, report failure by
// return code.
herr_t collect_link(hid_t, const char* name, const H5L_info_t*, void* data) noexcept {
  try {
    static_cast<StringVec*>(data)->names.emplace_back(name);
    return 0;
  } catch (...) {
    return -1;
  }
}

herr_t collect_attr(hid_t, const char* name, const H5A_info_t*, void* data) noexcept {
  try {
    static_cast<StringVec*>(data)->names.emplace_back(name);
    return 0;
  } catch (...) {
    return -1;
  }
}

// Writes all of data to fd; errno says why not.
bool write_all(int fd, const unsigned char* data, std::size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0) {
      if (errno == EINTR)
        continue;
      return false;
    }
    data += n;
    size -= static_cast<std::size_t>(n);
  }
  return true;
}

// The file as built in memory: the image libhdf5 would have written.
std::vector<unsigned char> file_image(hid_t file, const std::string& part) {
  if (H5Fflush(file, H5F_SCOPE_GLOBAL) < 0)
    throw IoError(part + ": cannot close HDF5 file: " + hdf5_reason());
  const ssize_t size = H5Fget_file_image(file, nullptr, 0);
  if (size < 0)
    throw IoError(part + ": cannot close HDF5 file: " + hdf5_reason());
  std::vector<unsigned char> image(static_cast<std::size_t>(size));
  if (H5Fget_file_image(file, image.data(), image.size()) != size)
    throw IoError(part + ": cannot close HDF5 file: " + hdf5_reason());
  return image;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

// The file is built in memory (HDF5's core driver, no backing store) and written to disk by
// commit() in one piece. A disk that fails (full, beyond a file-size limit) then fails a plain
// write() that says why, and never an H5Fclose: libhdf5 cannot close a file whose last writes
// failed, and keeps its caches allocated for the rest of the process (about 300 kB for each
// checkpoint a full disk refused).
H5Writer::H5Writer(std::string path, std::string temp_suffix)
    : path_(std::move(path)), suffix_(std::move(temp_suffix)) {
  if (suffix_.empty())
    throw std::invalid_argument("H5Writer: the temporary suffix must not be empty");
  silence_hdf5();
  const std::string part = part_path();
  // Created now, so that a folder that cannot hold it is an error before anything is computed.
  fd_ = ::open(part.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd_ < 0)
    throw IoError(part + ": cannot create HDF5 file: " + std::strerror(errno));
  const Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  if (fapl.ok() && H5Pset_fapl_core(fapl.get(), std::size_t{1} << 20, false) >= 0)
    file_ = H5Fcreate(part.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get());
  if (file_ < 0) {
    const std::string reason = hdf5_reason();
    ::close(std::exchange(fd_, -1));
    std::remove(part.c_str());
    throw IoError(part + ": cannot create HDF5 file: " + reason);
  }
}

H5Writer::~H5Writer() {
  if (file_ >= 0 && H5Fclose(file_) < 0)  // in memory: nothing to fail but an allocation
    H5Eclear2(H5E_DEFAULT);
  if (fd_ >= 0)
    ::close(fd_);
  if (!done_)
    std::remove(part_path().c_str());
}

// Writes the image in memory to the temporary file, on disk (fsync) before it returns. An
// error leaves the file to the caller: removed by the destructor unless done_.
void H5Writer::write_out() {
  const std::string part = part_path();
  const hid_t file = std::exchange(file_, -1);
  std::vector<unsigned char> image;
  try {
    image = file_image(file, part);
  } catch (...) {
    if (H5Fclose(file) < 0)
      H5Eclear2(H5E_DEFAULT);
    throw;
  }
  if (H5Fclose(file) < 0)
    H5Eclear2(H5E_DEFAULT);
  const int fd = std::exchange(fd_, -1);
  const bool written = write_all(fd, image.data(), image.size()) && ::fsync(fd) == 0;
  const int err = errno;
  if (::close(fd) != 0 && written)
    throw IoError(part + ": cannot write HDF5 file: " + std::strerror(errno));
  if (!written)
    throw IoError(part + ": cannot write HDF5 file: " + std::strerror(err));
}

namespace {

// Variable-length UTF-8: what h5py reads back as str (fixed-length would come back as bytes).
Handle utf8_string_type(const std::string& file_path) {
  Handle t(H5Tcopy(H5T_C_S1), H5Tclose);
  if (!t.ok() || H5Tset_size(t.get(), H5T_VARIABLE) < 0 ||
      H5Tset_cset(t.get(), H5T_CSET_UTF8) < 0) {
    throw IoError(file_path + ": cannot make a string type: " + hdf5_reason());
  }
  return t;
}

template <class T>
void write_dataset(hid_t file, const std::string& file_path, const std::string& path,
                   const std::vector<T>& data, const std::vector<std::size_t>& dims_in,
                   hid_t file_type, hid_t mem_type) {
  std::vector<hsize_t> dims;
  if (dims_in.empty()) {
    dims.push_back(data.size());
  } else {
    std::size_t product = 1;
    std::string shape;
    for (std::size_t d : dims_in) {
      product *= d;
      dims.push_back(d);
      if (!shape.empty())
        shape += 'x';
      shape += std::to_string(d);
    }
    if (product != data.size()) {
      throw IoError(file_path + ": dataset " + quoted(path) + ": dims " + shape + " hold " +
                    std::to_string(product) + " values, data has " + std::to_string(data.size()));
    }
  }
  require_group_parents(file, file_path, path);
  const Handle lcpl = intermediate_lcpl();
  const Handle space(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr),
                     H5Sclose);
  if (!space.ok()) {
    throw IoError(file_path + ": dataset " + quoted(path) + ": " + hdf5_reason());
  }
  const Handle dset(
      H5Dcreate2(file, path.c_str(), file_type, space.get(), lcpl.get(), H5P_DEFAULT, H5P_DEFAULT),
      H5Dclose);
  if (!dset.ok()) {
    throw IoError(file_path + ": cannot create dataset " + quoted(path) + ": " + hdf5_reason());
  }
  if (!data.empty() &&
      H5Dwrite(dset.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data()) < 0) {
    throw IoError(file_path + ": cannot write dataset " + quoted(path) + ": " + hdf5_reason());
  }
}

}  // namespace

void H5Writer::dataset(const std::string& path, const std::vector<double>& data,
                       const std::vector<std::size_t>& dims) {
  silence_hdf5();
  if (done_ || file_ < 0)
    throw IoError(part_path() + ": dataset " + quoted(path) + ": file already closed");
  write_dataset(file_, part_path(), path, data, dims, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE);
}

void H5Writer::dataset(const std::string& path, const std::vector<std::int64_t>& data,
                       const std::vector<std::size_t>& dims) {
  silence_hdf5();
  if (done_ || file_ < 0)
    throw IoError(part_path() + ": dataset " + quoted(path) + ": file already closed");
  write_dataset(file_, part_path(), path, data, dims, H5T_STD_I64LE, H5T_NATIVE_INT64);
}

void H5Writer::dataset(const std::string& path, const std::vector<std::uint32_t>& data,
                       const std::vector<std::size_t>& dims) {
  silence_hdf5();
  if (done_ || file_ < 0)
    throw IoError(part_path() + ": dataset " + quoted(path) + ": file already closed");
  write_dataset(file_, part_path(), path, data, dims, H5T_STD_U32LE, H5T_NATIVE_UINT32);
}

void H5Writer::dataset(const std::string& path, const std::vector<std::string>& data) {
  silence_hdf5();
  if (done_ || file_ < 0)
    throw IoError(part_path() + ": dataset " + quoted(path) + ": file already closed");
  const Handle type = utf8_string_type(part_path());
  std::vector<const char*> pointers;
  for (const auto& s : data)
    pointers.push_back(s.c_str());
  write_dataset(file_, part_path(), path, pointers, {}, type.get(), type.get());
}

void H5Writer::group(const std::string& path, bool creation_order) {
  silence_hdf5();
  if (done_ || file_ < 0)
    throw IoError(part_path() + ": group " + quoted(path) + ": file already closed");
  // Idempotent, so that callers need not track which groups exist already.
  if (link_exists(file_, path)) {
    if (!is_group(file_, path)) {
      throw IoError(part_path() + ": " + quoted(path) + " exists and is not a group");
    }
    return;
  }
  require_group_parents(file_, part_path(), path);
  const Handle lcpl = intermediate_lcpl();
  const Handle gcpl(H5Pcreate(H5P_GROUP_CREATE), H5Pclose);
  if (!gcpl.ok() ||
      (creation_order &&
       H5Pset_link_creation_order(gcpl.get(), H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED) < 0)) {
    throw IoError(part_path() + ": cannot create group " + quoted(path) + ": " + hdf5_reason());
  }
  const Handle g(H5Gcreate2(file_, path.c_str(), lcpl.get(), gcpl.get(), H5P_DEFAULT), H5Gclose);
  if (!g.ok()) {
    throw IoError(part_path() + ": cannot create group " + quoted(path) + ": " + hdf5_reason());
  }
}

namespace {

// Writes (or replaces) a scalar attribute; `value` points at the memory representation.
// With `count`, a 1-D attribute of *count elements instead.
void write_attr(hid_t file, const std::string& file_path, const std::string& object,
                const std::string& name, hid_t file_type, hid_t mem_type, const void* value,
                const hsize_t* count = nullptr) {
  const std::string what = "attribute " + quoted(name) + " on " + quoted(object);
  if (!link_exists(file, object)) {
    throw IoError(file_path + ": cannot write " + what + ": no such object");
  }
  const Handle obj(H5Oopen(file, object.c_str(), H5P_DEFAULT), H5Oclose);
  if (!obj.ok())
    throw IoError(file_path + ": cannot write " + what + ": " + hdf5_reason());
  const htri_t exists = H5Aexists(obj.get(), name.c_str());
  if (exists < 0 || (exists > 0 && H5Adelete(obj.get(), name.c_str()) < 0)) {
    throw IoError(file_path + ": cannot replace " + what + ": " + hdf5_reason());
  }
  const Handle space(count ? H5Screate_simple(1, count, nullptr) : H5Screate(H5S_SCALAR), H5Sclose);
  if (!space.ok())
    throw IoError(file_path + ": " + what + ": " + hdf5_reason());
  const Handle attr(
      H5Acreate2(obj.get(), name.c_str(), file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT),
      H5Aclose);
  if (!attr.ok())
    throw IoError(file_path + ": cannot create " + what + ": " + hdf5_reason());
  if ((count == nullptr || *count > 0) && H5Awrite(attr.get(), mem_type, value) < 0) {
    throw IoError(file_path + ": cannot write " + what + ": " + hdf5_reason());
  }
}

}  // namespace

void H5Writer::attr(const std::string& object, const std::string& name, double value) {
  silence_hdf5();
  if (done_ || file_ < 0)
    throw IoError(part_path() + ": attribute " + quoted(name) + ": file already closed");
  write_attr(file_, part_path(), object, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &value);
}

void H5Writer::attr(const std::string& object, const std::string& name, std::int64_t value) {
  silence_hdf5();
  if (done_ || file_ < 0)
    throw IoError(part_path() + ": attribute " + quoted(name) + ": file already closed");
  write_attr(file_, part_path(), object, name, H5T_STD_I64LE, H5T_NATIVE_INT64, &value);
}

void H5Writer::attr(const std::string& object, const std::string& name, const std::string& value) {
  silence_hdf5();
  if (done_ || file_ < 0)
    throw IoError(part_path() + ": attribute " + quoted(name) + ": file already closed");
  const Handle type = utf8_string_type(part_path());
  const char* c_str = value.c_str();
  write_attr(file_, part_path(), object, name, type.get(), type.get(), &c_str);
}

void H5Writer::attr(const std::string& object, const std::string& name,
                    const std::vector<std::string>& values) {
  silence_hdf5();
  if (done_ || file_ < 0)
    throw IoError(part_path() + ": attribute " + quoted(name) + ": file already closed");
  const Handle type = utf8_string_type(part_path());
  std::vector<const char*> pointers;
  for (const auto& s : values)
    pointers.push_back(s.c_str());
  const hsize_t n = pointers.size();
  write_attr(file_, part_path(), object, name, type.get(), type.get(), pointers.data(), &n);
}

void H5Writer::attrs(const std::string& object, const Attributes& list) {
  for (const auto& [name, value] : list)
    std::visit([&, &name = name](const auto& v) { attr(object, name, v); }, value);
}

void H5Writer::commit() {
  silence_hdf5();
  if (done_ || file_ < 0)
    throw IoError(part_path() + ": commit: file already closed");
  write_out();  // on disk before the rename, so that a crash cannot leave a renamed empty file
  // The data is complete even if the rename fails; keep it rather than delete it.
  done_ = true;
  const std::string part = part_path();
  if (std::rename(part.c_str(), path_.c_str()) != 0) {
    throw IoError("cannot rename " + part + " to " + path_ + ": " + std::strerror(errno) +
                  " (the data is kept in " + part + ")");
  }
}

void H5Writer::keep_partial(const std::string& status) {
  silence_hdf5();
  if (done_ || file_ < 0)
    throw IoError(part_path() + ": keep_partial: file already closed");
  // Keep the file whatever happens below: it is the only record of the failed run (a write
  // that fails half-way leaves a file HDF5 refuses to open, not one that looks complete).
  done_ = true;
  std::string error;
  try {
    const Handle type = utf8_string_type(part_path());
    const char* c_str = status.c_str();
    write_attr(file_, part_path(), "/", "status", type.get(), type.get(), &c_str);
  } catch (const IoError& e) {
    error = e.what();
  }
  try {
    write_out();
  } catch (const IoError& e) {
    if (error.empty())
      error = e.what();
  }
  if (!error.empty())
    throw IoError(error);
}

// ---------------------------------------------------------------------------------------------

H5Reader::H5Reader(const std::string& path) : path_(path) {
  silence_hdf5();
  file_ = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (file_ < 0)
    throw IoError(path + ": cannot open HDF5 file: " + hdf5_reason());
}

H5Reader::~H5Reader() {
  if (file_ >= 0)
    H5Fclose(file_);
}

bool H5Reader::exists(const std::string& path) const {
  silence_hdf5();
  return link_exists(file_, path);
}

bool H5Reader::has_attr(const std::string& object, const std::string& name) const {
  silence_hdf5();
  if (!link_exists(file_, object))
    return false;
  const htri_t r = H5Aexists_by_name(file_, object.c_str(), name.c_str(), H5P_DEFAULT);
  if (r < 0) {
    throw IoError(path_ + ": cannot query attribute " + quoted(name) + " on " + quoted(object) +
                  ": " + hdf5_reason());
  }
  return r > 0;
}

namespace {

Handle open_dataset(hid_t file, const std::string& file_path, const std::string& path) {
  if (!link_exists(file, path))
    throw IoError(file_path + ": no dataset " + quoted(path));
  Handle d(H5Dopen2(file, path.c_str(), H5P_DEFAULT), H5Dclose);
  if (!d.ok()) {
    throw IoError(file_path + ": cannot open dataset " + quoted(path) + ": " + hdf5_reason());
  }
  return d;
}

std::vector<hsize_t> extent(hid_t space, const std::string& what) {
  const int rank = H5Sget_simple_extent_ndims(space);
  if (rank < 0)
    throw IoError(what + ": cannot read the shape: " + hdf5_reason());
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  if (rank > 0 && H5Sget_simple_extent_dims(space, dims.data(), nullptr) < 0) {
    throw IoError(what + ": cannot read the shape: " + hdf5_reason());
  }
  return dims;
}

// Reads a whole dataset converted to T; `accept` says which stored type classes are allowed
// (an integer dataset reads exactly as doubles, a floating one would be truncated to ints).
template <class T>
std::vector<T> read_dataset(hid_t file, const std::string& file_path, const std::string& path,
                            hid_t mem_type, bool accept_float) {
  const std::string what = file_path + ": dataset " + quoted(path);
  const Handle d = open_dataset(file, file_path, path);
  const Handle type(H5Dget_type(d.get()), H5Tclose);
  const H5T_class_t cls = type.ok() ? H5Tget_class(type.get()) : H5T_NO_CLASS;
  if (cls != H5T_INTEGER && !(accept_float && cls == H5T_FLOAT)) {
    throw IoError(what + " has the wrong type (want " + (accept_float ? "a number" : "an integer") +
                  ")");
  }
  const Handle space(H5Dget_space(d.get()), H5Sclose);
  if (!space.ok())
    throw IoError(what + ": " + hdf5_reason());
  const hssize_t count = H5Sget_simple_extent_npoints(space.get());
  if (count < 0)
    throw IoError(what + ": cannot read the size: " + hdf5_reason());
  std::vector<T> out(static_cast<std::size_t>(count));
  if (count > 0 && H5Dread(d.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0) {
    throw IoError(what + ": cannot read: " + hdf5_reason());
  }
  return out;
}

// Every element of a string dataset or attribute (`read` reads the whole of it into a buffer
// of the given memory type): variable-length strings as the library allocates them, freed
// here; fixed-length ones as raw bytes with the writer's padding undone.
std::vector<std::string> read_string_elements(hid_t type, hid_t space, const std::string& what,
                                              const std::function<herr_t(hid_t, void*)>& read) {
  if (type < 0 || H5Tget_class(type) != H5T_STRING)
    throw IoError(what + " is not a string");
  const hssize_t count = H5Sget_simple_extent_npoints(space);
  if (count < 0)
    throw IoError(what + ": cannot read the size: " + hdf5_reason());
  const auto n = static_cast<std::size_t>(count);
  std::vector<std::string> out;
  out.reserve(n);
  const htri_t variable = H5Tis_variable_str(type);
  if (variable < 0)
    throw IoError(what + ": " + hdf5_reason());
  if (variable > 0) {
    Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
    if (!mem.ok() || H5Tset_size(mem.get(), H5T_VARIABLE) < 0 ||
        H5Tset_cset(mem.get(), H5Tget_cset(type)) < 0) {
      throw IoError(what + ": " + hdf5_reason());
    }
    std::vector<char*> buf(n, nullptr);
    if (n > 0 && read(mem.get(), buf.data()) < 0)
      throw IoError(what + ": cannot read: " + hdf5_reason());
    for (char* c : buf) {
      out.emplace_back(c != nullptr ? c : "");
      H5free_memory(c);
    }
    return out;
  }
  const std::size_t size = H5Tget_size(type);
  if (size == 0)
    throw IoError(what + ": " + hdf5_reason());
  std::string buf(size * n, '\0');
  if (n > 0 && read(type, buf.data()) < 0)
    throw IoError(what + ": cannot read: " + hdf5_reason());
  const bool space_padded = H5Tget_strpad(type) == H5T_STR_SPACEPAD;
  for (std::size_t k = 0; k < n; ++k) {
    std::string one = buf.substr(k * size, size);
    if (space_padded) {
      one.erase(one.find_last_not_of(' ') + 1);
    } else {
      const std::size_t nul = one.find('\0');
      if (nul != std::string::npos)
        one.erase(nul);
    }
    out.push_back(std::move(one));
  }
  return out;
}

}  // namespace

std::vector<double> H5Reader::read_doubles(const std::string& path) const {
  silence_hdf5();
  return read_dataset<double>(file_, path_, path, H5T_NATIVE_DOUBLE, true);
}

std::vector<std::int64_t> H5Reader::read_ints(const std::string& path) const {
  silence_hdf5();
  return read_dataset<std::int64_t>(file_, path_, path, H5T_NATIVE_INT64, false);
}

std::vector<std::uint32_t> H5Reader::read_uint32s(const std::string& path) const {
  const std::vector<std::int64_t> wide = read_ints(path);
  std::vector<std::uint32_t> out(wide.size());
  for (std::size_t k = 0; k < wide.size(); ++k) {
    if (wide[k] < 0 || wide[k] > std::int64_t(UINT32_MAX))
      throw IoError(path_ + ": dataset " + quoted(path) + ": value " + std::to_string(wide[k]) +
                    " at " + std::to_string(k) + " does not fit 32 unsigned bits");
    out[k] = static_cast<std::uint32_t>(wide[k]);
  }
  return out;
}

std::vector<std::string> H5Reader::read_strings(const std::string& path) const {
  silence_hdf5();
  const std::string what = path_ + ": dataset " + quoted(path);
  const Handle d = open_dataset(file_, path_, path);
  const Handle type(H5Dget_type(d.get()), H5Tclose);
  const Handle space(H5Dget_space(d.get()), H5Sclose);
  if (!space.ok())
    throw IoError(what + ": " + hdf5_reason());
  return read_string_elements(type.get(), space.get(), what, [&](hid_t mem, void* buf) {
    return H5Dread(d.get(), mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf);
  });
}

bool H5Reader::is_group(const std::string& path) const {
  silence_hdf5();
  return link_exists(file_, path) && jamflow::is_group(file_, path);
}

std::vector<std::size_t> H5Reader::dims(const std::string& path) const {
  silence_hdf5();
  const Handle d = open_dataset(file_, path_, path);
  const Handle space(H5Dget_space(d.get()), H5Sclose);
  const std::string what = path_ + ": dataset " + quoted(path);
  if (!space.ok())
    throw IoError(what + ": " + hdf5_reason());
  std::vector<std::size_t> out;
  for (hsize_t n : extent(space.get(), what))
    out.push_back(static_cast<std::size_t>(n));
  return out;
}

namespace {

// Opens a single-valued attribute.
Handle open_attr(hid_t file, const std::string& file_path, const std::string& object,
                 const std::string& name) {
  const std::string what = file_path + ": attribute " + quoted(name) + " on " + quoted(object);
  if (!link_exists(file, object))
    throw IoError(file_path + ": no object " + quoted(object) + " (looking for attribute " +
                  quoted(name) + ")");
  const htri_t exists = H5Aexists_by_name(file, object.c_str(), name.c_str(), H5P_DEFAULT);
  if (exists <= 0)
    throw IoError(what + " does not exist");
  Handle a(H5Aopen_by_name(file, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a.ok())
    throw IoError(what + ": cannot open: " + hdf5_reason());
  const Handle space(H5Aget_space(a.get()), H5Sclose);
  if (!space.ok() || H5Sget_simple_extent_npoints(space.get()) != 1) {
    throw IoError(what + " is not a single value");
  }
  return a;
}

template <class T>
T read_number_attr(hid_t file, const std::string& file_path, const std::string& object,
                   const std::string& name, hid_t mem_type, bool accept_float) {
  const std::string what = file_path + ": attribute " + quoted(name) + " on " + quoted(object);
  const Handle a = open_attr(file, file_path, object, name);
  const Handle type(H5Aget_type(a.get()), H5Tclose);
  const H5T_class_t cls = type.ok() ? H5Tget_class(type.get()) : H5T_NO_CLASS;
  if (cls != H5T_INTEGER && !(accept_float && cls == H5T_FLOAT)) {
    throw IoError(what + " has the wrong type (want " + (accept_float ? "a number" : "an integer") +
                  ")");
  }
  T value{};
  if (H5Aread(a.get(), mem_type, &value) < 0) {
    throw IoError(what + ": cannot read: " + hdf5_reason());
  }
  return value;
}

}  // namespace

double H5Reader::attr_double(const std::string& object, const std::string& name) const {
  silence_hdf5();
  return read_number_attr<double>(file_, path_, object, name, H5T_NATIVE_DOUBLE, true);
}

std::int64_t H5Reader::attr_int(const std::string& object, const std::string& name) const {
  silence_hdf5();
  return read_number_attr<std::int64_t>(file_, path_, object, name, H5T_NATIVE_INT64, false);
}

std::string H5Reader::attr_string(const std::string& object, const std::string& name) const {
  silence_hdf5();
  const std::string what = path_ + ": attribute " + quoted(name) + " on " + quoted(object);
  const Handle a = open_attr(file_, path_, object, name);
  const Handle type(H5Aget_type(a.get()), H5Tclose);
  if (!type.ok() || H5Tget_class(type.get()) != H5T_STRING) {
    throw IoError(what + " is not a string");
  }
  const htri_t variable = H5Tis_variable_str(type.get());
  if (variable < 0)
    throw IoError(what + ": " + hdf5_reason());

  if (variable > 0) {
    // h5py's default: the library allocates the string, we free it with H5free_memory.
    Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
    if (!mem.ok() || H5Tset_size(mem.get(), H5T_VARIABLE) < 0 ||
        H5Tset_cset(mem.get(), H5Tget_cset(type.get())) < 0) {
      throw IoError(what + ": " + hdf5_reason());
    }
    char* buf = nullptr;
    if (H5Aread(a.get(), mem.get(), &buf) < 0) {
      throw IoError(what + ": cannot read: " + hdf5_reason());
    }
    std::string value = buf != nullptr ? buf : "";
    H5free_memory(buf);
    return value;
  }

  // Fixed length: read the raw bytes, then undo the padding the writer chose.
  const std::size_t size = H5Tget_size(type.get());
  if (size == 0)
    throw IoError(what + ": " + hdf5_reason());
  std::string buf(size, '\0');
  if (H5Aread(a.get(), type.get(), buf.data()) < 0) {
    throw IoError(what + ": cannot read: " + hdf5_reason());
  }
  if (H5Tget_strpad(type.get()) == H5T_STR_SPACEPAD) {
    buf.erase(buf.find_last_not_of(' ') + 1);
  } else {
    const std::size_t nul = buf.find('\0');
    if (nul != std::string::npos)
      buf.erase(nul);
  }
  return buf;
}

std::vector<std::string> H5Reader::attr_strings(const std::string& object,
                                                const std::string& name) const {
  silence_hdf5();
  const std::string what = path_ + ": attribute " + quoted(name) + " on " + quoted(object);
  if (!link_exists(file_, object))
    throw IoError(path_ + ": no object " + quoted(object) + " (looking for attribute " +
                  quoted(name) + ")");
  if (H5Aexists_by_name(file_, object.c_str(), name.c_str(), H5P_DEFAULT) <= 0)
    throw IoError(what + " does not exist");
  const Handle a(H5Aopen_by_name(file_, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT),
                 H5Aclose);
  if (!a.ok())
    throw IoError(what + ": cannot open: " + hdf5_reason());
  const Handle type(H5Aget_type(a.get()), H5Tclose);
  const Handle space(H5Aget_space(a.get()), H5Sclose);
  if (!space.ok())
    throw IoError(what + ": " + hdf5_reason());
  return read_string_elements(type.get(), space.get(), what,
                              [&](hid_t mem, void* buf) { return H5Aread(a.get(), mem, buf); });
}

std::vector<std::string> H5Reader::attr_names(const std::string& object) const {
  silence_hdf5();
  if (!link_exists(file_, object))
    throw IoError(path_ + ": no object " + quoted(object));
  const Handle obj(H5Oopen(file_, object.c_str(), H5P_DEFAULT), H5Oclose);
  if (!obj.ok()) {
    throw IoError(path_ + ": cannot open " + quoted(object) + ": " + hdf5_reason());
  }
  StringVec out;
  hsize_t idx = 0;
  if (H5Aiterate2(obj.get(), H5_INDEX_NAME, H5_ITER_INC, &idx, collect_attr, &out) < 0) {
    throw IoError(path_ + ": cannot list the attributes of " + quoted(object) + ": " +
                  hdf5_reason());
  }
  return out.names;
}

std::vector<std::string> H5Reader::children(const std::string& group) const {
  silence_hdf5();
  if (!link_exists(file_, group))
    throw IoError(path_ + ": no group " + quoted(group));
  const Handle g(H5Gopen2(file_, group.c_str(), H5P_DEFAULT), H5Gclose);
  if (!g.ok()) {
    throw IoError(path_ + ": " + quoted(group) + " is not a group: " + hdf5_reason());
  }
  StringVec out;
  hsize_t idx = 0;
  if (H5Literate(g.get(), H5_INDEX_NAME, H5_ITER_INC, &idx, collect_link, &out) < 0) {
    throw IoError(path_ + ": cannot list " + quoted(group) + ": " + hdf5_reason());
  }
  return out.names;
}

}  // namespace jamflow
