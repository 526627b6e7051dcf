// The HDF5 pieces the result file's writer (src/output.cpp) and its exporters (src/export.cpp)
// share: an owning handle, the error check, a file built in memory and written whole, opening a
// group, reading a dataset or an attribute as doubles.
#pragma once
#include <hdf5.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "replace_file.hpp"

namespace loosepack {

class H5 {
 public:
  H5(hid_t id, herr_t (*close)(hid_t), const std::string& what) : id_(id), close_(close) {
    if (id_ < 0) throw std::runtime_error("HDF5: cannot " + what);
  }
  ~H5() {
    if (id_ >= 0) close_(id_);
  }
  H5(const H5&) = delete;
  H5& operator=(const H5&) = delete;
  H5(H5&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
  operator hid_t() const { return id_; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

inline void check(herr_t e, const std::string& what) {
  if (e < 0) throw std::runtime_error("HDF5: cannot " + what);
}

// An HDF5 file built in memory (the core driver, no backing store): `fill(file)` writes into it,
// and its bytes come back for the caller to write, so that HDF5 never writes to a disk that may
// fill up (HDF5 1.10 kept a file whose flush had failed open, and crashed closing it again at
// exit). With `image` the file starts as those bytes (a file read whole), else empty; `name`
// names it in errors.
template <class Fill>
std::string hdf5_in_memory(const std::string& name, Fill fill, const std::string* image = nullptr) {
  H5 fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, "make the file access list of " + name);
  check(H5Pset_fapl_core(fapl, std::size_t{1} << 20, 0), "build " + name + " in memory");
  if (image)
    check(H5Pset_file_image(fapl, const_cast<char*>(image->data()), image->size()),
          "read " + name + " into memory");
  // The core driver refuses to open an image under the name of a file that exists: a name no
  // file can have.
  H5 file(image ? H5Fopen("/proc/self/loosepack-in-memory.h5", H5F_ACC_RDWR, fapl)
                : H5Fcreate(name.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl),
          H5Fclose, (image ? "open " : "create ") + name);
  fill(static_cast<hid_t>(file));
  check(H5Fflush(file, H5F_SCOPE_GLOBAL), "flush " + name);
  const ssize_t size = H5Fget_file_image(file, nullptr, 0);
  if (size < 0) throw std::runtime_error("HDF5: cannot get the bytes of " + name);
  std::string bytes(static_cast<std::size_t>(size), '\0');
  if (H5Fget_file_image(file, bytes.data(), bytes.size()) != size)
    throw std::runtime_error("HDF5: cannot get the bytes of " + name);
  return bytes;
}

// The HDF5 file `path` written whole or not at all: built in memory by `fill` (hdf5_in_memory,
// from `image` where given), then put in place by replace_file.
template <class Fill>
void replace_hdf5_file(const std::string& path, Fill fill, const std::string* image = nullptr) {
  const std::string bytes = hdf5_in_memory(path, fill, image);
  replace_file(path, [&](const std::string& tmp) { write_bytes(tmp, bytes); });
}

// The file `path`, to read, HDF5's own error printing off (the exception says what failed).
inline H5 open_to_read(const std::string& path, const std::string& what) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  return H5(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, what);
}

inline H5 open_group(hid_t parent, const std::string& name) {
  return H5(H5Gopen2(parent, name.c_str(), H5P_DEFAULT), H5Gclose, "open group " + name);
}

inline std::vector<double> doubles(hid_t loc, const std::string& name) {
  H5 set(H5Dopen2(loc, name.c_str(), H5P_DEFAULT), H5Dclose, "open dataset " + name);
  H5 space(H5Dget_space(set), H5Sclose, "get dataspace of " + name);
  const hssize_t n = H5Sget_simple_extent_npoints(space);
  std::vector<double> v(static_cast<std::size_t>(n));
  if (n > 0)
    check(H5Dread(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()),
          "read dataset " + name);
  return v;
}


// A numeric attribute `name` of `object` (below loc), as a double.
inline double double_attribute(hid_t loc, const std::string& object, const std::string& name) {
  H5 a(H5Aopen_by_name(loc, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
       "open attribute " + object + "@" + name);
  double v = 0.0;
  check(H5Aread(a, H5T_NATIVE_DOUBLE, &v), "read attribute " + name);
  return v;
}

}  // namespace loosepack
