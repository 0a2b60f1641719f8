// Owns one HDF5 identifier and closes it with the function for its kind of object (H5Fclose,
// H5Gclose, H5Aclose, ...). The one such handle: the HDF5 layer (lib/h5.cpp) and the run-file
// module's reader (driver/run_summary.cpp) and the H5MD trajectory writer (lib/h5md.cpp) use it.
#pragma once
#include <hdf5.h>

#include <utility>

namespace jamflow {

class H5Handle {
 public:
  H5Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~H5Handle() {
    if (id_ >= 0)
      close_(id_);
  }
  H5Handle(H5Handle&& other) noexcept
      : id_(std::exchange(other.id_, H5I_INVALID_HID)), close_(other.close_) {}
  H5Handle(const H5Handle&) = delete;
  H5Handle& operator=(const H5Handle&) = delete;
  H5Handle& operator=(H5Handle&&) = delete;
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

}  // namespace jamflow
