// Thin RAII layer over the HDF5 C API: what jamflow writes and reads, nothing more.
//
// Writing goes to "<path><temp suffix>" (".part" unless given); commit() flushes the file to
// disk and renames it to <path>, so a crash, a failure or an interruption never leaves a file
// that looks complete, and never tears the file that was at <path> before.
#pragma once
#include <hdf5.h>

#include <cstdint>
#include <string>
#include <vector>

#include "lib/attributes.hpp"

namespace jamflow {

// Once per process before HDF5's first use (H5Writer and H5Reader call it): no automatic error
// printing (our errors are one line) and no exit-time cleanup by libhdf5 (a file whose close
// failed on a full disk would crash it).
void hdf5_setup();

class H5Writer {
 public:
  explicit H5Writer(std::string path, std::string temp_suffix = ".part");
  ~H5Writer();
  H5Writer(const H5Writer&) = delete;
  H5Writer& operator=(const H5Writer&) = delete;

  const std::string& path() const { return path_; }
  std::string part_path() const { return path_ + suffix_; }

  // Creates intermediate groups as needed ("/a/b/c" makes /a and /a/b). dims empty means
  // 1-D of data.size(); otherwise the product of dims must equal data.size() (row-major).
  void dataset(const std::string& path, const std::vector<double>& data,
               const std::vector<std::size_t>& dims = {});
  void dataset(const std::string& path, const std::vector<std::int64_t>& data,
               const std::vector<std::size_t>& dims = {});
  void dataset(const std::string& path, const std::vector<std::uint32_t>& data,
               const std::vector<std::size_t>& dims = {});
  // 1-D, variable-length UTF-8 strings (h5py: f[path].asstr()[()]).
  void dataset(const std::string& path, const std::vector<std::string>& data);
  // A group; with `creation_order` its links are listed in the order they are created (h5py
  // iterates it so, as a table's columns), not by name.
  void group(const std::string& path, bool creation_order = false);

  // Scalar attributes on an existing object (group or dataset; "/" is the root).
  void attr(const std::string& object, const std::string& name, double value);
  void attr(const std::string& object, const std::string& name, std::int64_t value);
  void attr(const std::string& object, const std::string& name, const std::string& value);
  void attr(const std::string& object, const std::string& name, const char* value) {
    attr(object, name, std::string(value));
  }
  // A 1-D array of variable-length UTF-8 strings (h5py: a numpy array of str).
  void attr(const std::string& object, const std::string& name,
            const std::vector<std::string>& values);
  void attrs(const std::string& object, const Attributes& list);

  // Write the file (it is built in memory) to the temporary file, flush it to disk (fsync) and
  // atomically rename it to <path>.
  void commit();
  // Close, keep <path>.part and record why it is incomplete in a root attribute "status".
  void keep_partial(const std::string& status);

 private:
  void write_out();

  std::string path_, suffix_;
  hid_t file_ = -1;
  int fd_ = -1;  // the temporary file, open from the constructor on
  bool done_ = false;
};

class H5Reader {
 public:
  explicit H5Reader(const std::string& path);
  ~H5Reader();
  H5Reader(const H5Reader&) = delete;
  H5Reader& operator=(const H5Reader&) = delete;

  bool exists(const std::string& path) const;
  bool has_attr(const std::string& object, const std::string& name) const;
  std::vector<double> read_doubles(const std::string& path) const;
  std::vector<std::int64_t> read_ints(const std::string& path) const;
  // Integers that must fit 32 unsigned bits (an IoError otherwise).
  std::vector<std::uint32_t> read_uint32s(const std::string& path) const;
  // A 1-D string dataset (variable or fixed length), one string per element.
  std::vector<std::string> read_strings(const std::string& path) const;
  std::vector<std::size_t> dims(const std::string& path) const;
  // Whether `path` exists and is a group (not a dataset).
  bool is_group(const std::string& path) const;
  double attr_double(const std::string& object, const std::string& name) const;
  std::int64_t attr_int(const std::string& object, const std::string& name) const;
  std::string attr_string(const std::string& object, const std::string& name) const;
  // A string attribute of any number of elements (a scalar one gives one string).
  std::vector<std::string> attr_strings(const std::string& object, const std::string& name) const;
  std::vector<std::string> attr_names(const std::string& object) const;
  std::vector<std::string> children(const std::string& group) const;

 private:
  std::string path_;
  hid_t file_ = -1;
};

}  // namespace jamflow
