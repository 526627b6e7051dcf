// The HDF5 pieces the result file's writer (src/output.cpp) and its exporters (src/export.cpp)
// share: an owning handle, the error check, a file built in memory and written whole, opening a
// group, listing it and reading its groups' numbers, reading a dataset or an attribute as doubles.
#pragma once
#include <hdf5.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>
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
  // Closes it now: HDF5's status (negative: the close failed).
  herr_t close() {
    const herr_t e = id_ >= 0 ? close_(id_) : 0;
    id_ = -1;
    return e;
  }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

inline void check(herr_t e, const std::string& what) {
  if (e < 0) throw std::runtime_error("HDF5: cannot " + what);
}

// The bytes of a file that the core driver holds, taken as HDF5 frees them on closing the file,
// when the superblock has been written whole. (H5Fget_file_image on an open file clears the
// superblock's status flags but, before HDF5 2.0, leaves the 1.8 format's checksum over them
// stale, and the image does not open: HDFGroup/hdf5#5489.) `size` is the file's size, its end of
// allocation before the close; the driver's buffer is at least that long.
class ClosedFileImage {
 public:
  std::string bytes;
  std::size_t size = 0;

  H5FD_file_image_callbacks_t callbacks() {
    return {&allocate, &copy, &reallocate, &release, &same, &keep, this};
  }

 private:
  static void* allocate(std::size_t n, H5FD_file_image_op_t, void*) { return std::malloc(n); }
  static void* copy(void* to, const void* from, std::size_t n, H5FD_file_image_op_t, void*) {
    return std::memcpy(to, from, n);
  }
  static void* reallocate(void* p, std::size_t n, H5FD_file_image_op_t, void*) {
    return std::realloc(p, n);
  }
  static herr_t release(void* p, H5FD_file_image_op_t op, void* self_) {
    auto* self = static_cast<ClosedFileImage*>(self_);
    if (op == H5FD_FILE_IMAGE_OP_FILE_CLOSE && p)
      self->bytes.assign(static_cast<const char*>(p), self->size);
    std::free(p);
    return 0;
  }
  static void* same(void* self) { return self; }
  static herr_t keep(void*) { return 0; }
};

// The end-of-file address a 1.8-format superblock (version 2 or 3) records, or 0 for another
// superblock: its fixed layout has 8-byte addresses at offsets 12 (base), 20 (extension), 28 (end
// of file).
inline std::size_t superblock_end_of_file(const std::string& b) {
  const bool v2 = b.size() >= 48 && b.compare(0, 8, "\x89HDF\r\n\x1a\n") == 0 &&
                  (b[8] == 2 || b[8] == 3) && b[9] == 8;
  if (!v2) return 0;
  std::uint64_t eof = 0;
  for (int k = 7; k >= 0; --k) eof = (eof << 8) | static_cast<unsigned char>(b[28 + k]);
  return static_cast<std::size_t>(eof);
}

// A creation list of class `cls` (groups, the file's root group) that keeps an object's
// attributes in its header however many it has, as the 1.6 format did: the 1.8 format moves
// more than 8 into dense storage, and HDF5 before 1.14.4 crashes copying an object whose
// variable-length string attributes lie there (H5Ocopy: h5copy, h5repack, h5py's copy;
// HDFGroup/hdf5#2414).
inline H5 compact_attributes(hid_t cls) {
  H5 list(H5Pcreate(cls), H5Pclose, "make a creation list");
  check(H5Pset_attr_phase_change(list, 65535, 0), "keep attributes compact");
  return list;
}

// An HDF5 file built in memory (the core driver, no backing store): `fill(file)` writes into it,
// and its bytes come back for the caller to write, so that HDF5 never writes to a disk that may
// fill up (HDF5 1.10 kept a file whose flush had failed open, and crashed closing it again at
// exit). With `image` the file starts as those bytes (a file read whole), else empty; `name`
// names it in errors. New files have the 1.8 format, whose superblock, object headers and group
// indices carry checksums: damage there is an error on reading (the 1.6 format's damaged object
// headers could crash HDF5 1.10's reader; the global heap of variable-length strings has no
// checksum in any format); HDF5 1.8 and later read it.
template <class Fill>
std::string hdf5_in_memory(const std::string& name, Fill fill, const std::string* image = nullptr) {
  ClosedFileImage closed;
  {
    H5 fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, "make the file access list of " + name);
    check(H5Pset_fapl_core(fapl, std::size_t{1} << 20, 0), "build " + name + " in memory");
    // New objects in the 1.8 format; a file opened from its image may have a later one (a copy
    // made by h5repack --latest), which a high bound of V18 refuses to open for writing.
    check(H5Pset_libver_bounds(fapl, H5F_LIBVER_V18, image ? H5F_LIBVER_LATEST : H5F_LIBVER_V18),
          "choose the file format of " + name);
    // Every object of the file closes with it, so that the bytes are taken inside H5Fclose.
    check(H5Pset_fclose_degree(fapl, H5F_CLOSE_STRONG), "close " + name + " whole");
    H5FD_file_image_callbacks_t callbacks = closed.callbacks();
    check(H5Pset_file_image_callbacks(fapl, &callbacks), "keep the bytes of " + name);
    if (image)
      check(H5Pset_file_image(fapl, const_cast<char*>(image->data()), image->size()),
            "read " + name + " into memory");
    // The core driver refuses to open an image under the name of a file that exists: a name no
    // file can have.
    H5 file(image
                ? H5Fopen("/proc/self/loosepack-in-memory.h5", H5F_ACC_RDWR, fapl)
                : H5Fcreate(name.c_str(), H5F_ACC_TRUNC, compact_attributes(H5P_FILE_CREATE), fapl),
            H5Fclose, (image ? "open " : "create ") + name);
    fill(static_cast<hid_t>(file));
    check(H5Fflush(file, H5F_SCOPE_GLOBAL), "flush " + name);
    const ssize_t size = H5Fget_file_image(file, nullptr, 0);
    if (size < 0) throw std::runtime_error("HDF5: cannot get the size of " + name);
    closed.size = static_cast<std::size_t>(size);
    check(file.close(), "close " + name);
  }
  // The close can give back free space at the file's end: a 1.8-format file ends where its
  // superblock says.
  const std::size_t eof = superblock_end_of_file(closed.bytes);
  if (closed.bytes.size() != closed.size || eof > closed.size)
    throw std::runtime_error("HDF5: cannot get the bytes of " + name);
  if (eof != 0) closed.bytes.resize(eof);
  return std::move(closed.bytes);
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

// The names of the links in group `name` (below loc), in name order.
inline std::vector<std::string> children(hid_t loc, const std::string& name) {
  H5 g = open_group(loc, name);
  H5G_info_t info;
  check(H5Gget_info(g, &info), "list group " + name);
  std::vector<std::string> out;
  for (hsize_t k = 0; k < info.nlinks; ++k) {
    const ssize_t n =
        H5Lget_name_by_idx(g, ".", H5_INDEX_NAME, H5_ITER_INC, k, nullptr, 0, H5P_DEFAULT);
    if (n < 0) throw std::runtime_error("HDF5: cannot list group " + name);
    std::string child(static_cast<std::size_t>(n) + 1, '\0');
    H5Lget_name_by_idx(g, ".", H5_INDEX_NAME, H5_ITER_INC, k, child.data(), child.size(),
                       H5P_DEFAULT);
    child.resize(static_cast<std::size_t>(n));
    out.push_back(child);
  }
  return out;
}

// The number in a group's name ("0003" of points/0003, "2" of snapshot_2), as the program writes
// them: digits only; std::runtime_error (the file's damage) naming the group otherwise.
inline int group_number(const std::string& digits, const std::string& group) {
  const bool numbered =
      !digits.empty() && digits.size() <= 9 &&
      std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; });
  if (!numbered) throw std::runtime_error(group + ": not a group name the program writes");
  return std::stoi(digits);
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
