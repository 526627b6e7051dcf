// libFuzzer target for the result-file readers (`loosepack summary`, `loosepack analyse`,
// `loosepack merge` and `loosepack export`, src/output.cpp, src/shards.cpp and src/export.cpp). A
// valid result file of a small scan (protocols A and C, three seeds), written as the one shard of
// its scan, is computed once; each input is a list of edits applied to a copy of it through HDF5,
// so that the file stays a valid HDF5 file (the readers' checks are fuzzed, not HDF5's own parser):
// remove a dataset or an attribute, give a dataset another length, set an element or an attribute
// to any double (NaN, infinities, 1e300, negative counts), or replace a string. The readers must
// print or write a file, or refuse with std::runtime_error (export also with std::invalid_argument,
// for a selection); any other exception, crash, sanitizer report or huge allocation is a bug.
#include <hdf5.h>
#include <unistd.h>

#include <Kokkos_Core.hpp>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "loosepack/export.hpp"
#include "loosepack/output.hpp"
#include "loosepack/protocols.hpp"
#include "loosepack/scan.hpp"
#include "loosepack/shards.hpp"

namespace {

namespace fs = std::filesystem;

struct Template {
  std::string path, work, out;
  std::vector<std::string> datasets;                         // every dataset, by path
  std::vector<std::pair<std::string, std::string>> attributes;  // (object, name)
};

herr_t collect_attribute(hid_t, const char* name, const H5A_info_t*, void* data) {
  auto* t = static_cast<std::pair<Template*, std::string>*>(data);
  t->first->attributes.emplace_back(t->second, name);
  return 0;
}

herr_t collect(hid_t root, const char* name, const H5O_info_t* info, void* data) {
  auto* t = static_cast<Template*>(data);
  const std::string object = std::string("/") + (std::strcmp(name, ".") == 0 ? "" : name);
  if (info->type == H5O_TYPE_DATASET) t->datasets.push_back(object);
  hid_t obj = H5Oopen(root, name, H5P_DEFAULT);
  std::pair<Template*, std::string> ctx{t, object};
  H5Aiterate2(obj, H5_INDEX_NAME, H5_ITER_INC, nullptr, collect_attribute, &ctx);
  H5Oclose(obj);
  return 0;
}

Template& make_template() {
  static Template t = [] {
    Template t;
    const fs::path dir =
        fs::temp_directory_path() / ("loosepack-fuzz-results-" + std::to_string(getpid()));
    fs::create_directories(dir);
    t.path = (dir / "template.h5").string();
    t.work = (dir / "work.h5").string();
    t.out = (dir / "out.h5").string();
    loosepack::Scan scan = loosepack::parse_scan(
        "[scan]\nseeds = 3\nprotocol = [\"A\", \"C\"]\n[system]\nwidth = 8\nheight = 10\n"
        "bond_number = 100\n[observables]\ntrajectory_every = 2\n",
        "fuzz.toml");
    const auto members = loosepack::members_of(scan);
    loosepack::resolve_backend_defaults(scan, members.size());
    const auto results = loosepack::run_members(scan, members);
    loosepack::RunInfo info;
    info.shard = 0;
    info.shards = 1;
    loosepack::write_member_results(t.path, scan, info, results, true);
    hid_t f = H5Fopen(t.path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    H5Ovisit(f, H5_INDEX_NAME, H5_ITER_INC, collect, &t);
    H5Fclose(f);
    return t;
  }();
  return t;
}

class Input {
 public:
  Input(const std::uint8_t* d, std::size_t n) : d_(d), n_(n) {}
  bool more() const { return at_ < n_; }
  std::uint8_t byte() { return at_ < n_ ? d_[at_++] : 0; }
  double value() {
    double v = 0.0;
    std::uint8_t b[sizeof v] = {};
    for (auto& x : b) x = byte();
    std::memcpy(&v, b, sizeof v);
    return v;
  }

 private:
  const std::uint8_t* d_;
  std::size_t n_, at_ = 0;
};

// Writes `values` as dataset `name` (a replacement of another length or type).
void put_dataset(hid_t file, const std::string& name, const std::vector<double>& values) {
  H5Ldelete(file, name.c_str(), H5P_DEFAULT);
  const hsize_t n = values.size();
  hid_t space = H5Screate_simple(1, &n, nullptr);
  hid_t set = H5Dcreate2(file, name.c_str(), H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT,
                         H5P_DEFAULT);
  if (set >= 0) {
    if (n > 0) H5Dwrite(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data());
    H5Dclose(set);
  }
  H5Sclose(space);
}

std::vector<double> values_of(hid_t file, const std::string& name) {
  std::vector<double> v;
  hid_t set = H5Dopen2(file, name.c_str(), H5P_DEFAULT);
  if (set < 0) return v;
  hid_t space = H5Dget_space(set);
  const hssize_t n = H5Sget_simple_extent_npoints(space);
  hid_t type = H5Dget_type(set);
  if (n > 0 && H5Tget_class(type) != H5T_STRING) {
    v.resize(static_cast<std::size_t>(n));
    if (H5Dread(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0) v.clear();
  }
  H5Tclose(type);
  H5Sclose(space);
  H5Dclose(set);
  return v;
}

void put_attribute(hid_t file, const std::string& object, const std::string& name, double v) {
  H5Adelete_by_name(file, object.c_str(), name.c_str(), H5P_DEFAULT);
  hid_t space = H5Screate(H5S_SCALAR);
  hid_t a = H5Acreate_by_name(file, object.c_str(), name.c_str(), H5T_IEEE_F64LE, space,
                              H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (a >= 0) {
    H5Awrite(a, H5T_NATIVE_DOUBLE, &v);
    H5Aclose(a);
  }
  H5Sclose(space);
}

void edit(hid_t file, const Template& t, Input& in) {
  const std::uint8_t op = in.byte() % 6;
  const std::size_t nd = t.datasets.size(), na = t.attributes.size();
  const std::size_t k = static_cast<std::size_t>(in.byte()) * 256 + in.byte();
  const std::string& set = t.datasets[k % nd];
  const auto& [object, name] = t.attributes[k % na];
  switch (op) {
    case 0:
      H5Ldelete(file, set.c_str(), H5P_DEFAULT);
      break;
    case 1: {  // another length, every element one value
      const std::size_t n = in.byte();
      put_dataset(file, set, std::vector<double>(n, in.value()));
      break;
    }
    case 2: {  // one element
      std::vector<double> v = values_of(file, set);
      if (!v.empty()) v[in.byte() % v.size()] = in.value();
      put_dataset(file, set, v);
      break;
    }
    case 3:
      H5Adelete_by_name(file, object.c_str(), name.c_str(), H5P_DEFAULT);
      break;
    case 4:
      put_attribute(file, object, name, in.value());
      break;
    default: {  // the scan text: a valid prefix of it, or bytes of the input
      std::string text = loosepack::read_scan_text(t.path);
      text.resize(text.size() * in.byte() / 255);
      H5Ldelete(file, "scan_text", H5P_DEFAULT);
      hid_t type = H5Tcopy(H5T_C_S1);
      H5Tset_size(type, text.size() + 1);
      hid_t space = H5Screate(H5S_SCALAR);
      hid_t d = H5Dcreate2(file, "scan_text", type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
      if (d >= 0) {
        H5Dwrite(d, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, text.c_str());
        H5Dclose(d);
      }
      H5Sclose(space);
      H5Tclose(type);
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  Kokkos::initialize(*argc, *argv);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  make_template();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const Template& t = make_template();
  fs::copy_file(t.path, t.work, fs::copy_options::overwrite_existing);
  Input in(data, size);
  {
    hid_t file = H5Fopen(t.work.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    for (int n = 0; n < 8 && in.more(); ++n) edit(file, t, in);
    H5Fclose(file);
  }
  try {
    std::ostringstream sink;
    loosepack::print_summary(t.work, sink);
  } catch (const std::runtime_error&) {
  }
  try {
    loosepack::reanalyse(t.work, t.out);
  } catch (const std::runtime_error&) {
  }
  try {
    loosepack::read_parts({t.work});
  } catch (const std::runtime_error&) {
  }
  for (auto format : {loosepack::ExportFormat::Xdmf, loosepack::ExportFormat::Extxyz}) {
    try {
      loosepack::export_viewer_files(t.work, format);
    } catch (const std::runtime_error&) {
    } catch (const std::invalid_argument&) {
    }
  }
  return 0;
}
