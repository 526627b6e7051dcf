// HDF5 output through the C API, with a small RAII handle.
#include "loosepack/output.hpp"

#include <hdf5.h>

#include <Kokkos_Core.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include "hdf5.hpp"
#include "loosepack/checkpoint.hpp"
#include "loosepack/settings.hpp"
#include "loosepack_git_commit.hpp"

namespace loosepack {

namespace {

H5 group(hid_t parent, const std::string& name) {
  return H5(H5Gcreate2(parent, name.c_str(), H5P_DEFAULT, compact_attributes(H5P_GROUP_CREATE),
                       H5P_DEFAULT),
            H5Gclose, "create group " + name);
}

// What a dataset holds, by its name and its group's name (docs/OUTPUT.md): its `units` and
// `long_name` attributes, and whether it is a count or an index (stored as 64-bit integers).
struct DatasetMeta {
  std::string units, long_name;
  bool integer = false;
};

bool is_count(const std::string& name) {
  static const std::string kCounts =
      " count members counts counts_cut member_counts member_counts_cut downward_counts"
      " moved_counts steps_counts member_downward_counts member_moved_counts member_steps_counts"
      " member_count seed_index disks steps sweeps failure capped scan_points"
      " contact_i contact_j disk time ";
  return !name.empty() && kCounts.find(" " + name + " ") != std::string::npos;
}

DatasetMeta dataset_meta(const std::string& group, const std::string& name) {
  const bool density = group == "nu" || group == "nu_deposition";
  const bool avalanche = group.rfind("avalanche_by_", 0) == 0;
  const std::string profile = group == "nu" ? "volume fraction nu(y) of the final deposit"
                              : group == "nu_deposition" ? "deposition density nu_d(y_i)"
                              : avalanche ? "Delta y = y_e - y_i binned by y_" + group.substr(14)
                                          : group;
  if (name == "time")
    return {"", "disks deposited (protocol A) or step of the collapse (C) at the sample", true};
  if (is_count(name)) {
    if (name == "contact_i" || name == "contact_j")
      return {"", "disk index in deposition order (-1: the floor)", true};
    if (name == "disk") return {"", "disk index in deposition order", true};
    if (name == "failure") return {"", "0 finished; else the failure (docs/OUTPUT.md)", true};
    if (name == "scan_points")
      return {"", "the scan points the fit went through (K of points/K)", true};
    return {"", group + " " + name, true};
  }
  if (density && (name == "mean" || name == "sem" || name == "member_mean"))
    return {"1", profile + ": " + (name == "mean" ? "ensemble mean" : name == "sem"
                                                                          ? "standard error"
                                                                          : "one row per member")};
  if (group == "nu" && name == "predicted")
    return {"1", "final volume fraction predicted from the deposition density and Delta y(y_e)"};
  if (group == "nu" && name == "deviation")
    return {"1", "predicted minus measured final volume fraction"};
  if (density && name == "rel_fluctuation")
    return {"1", profile + ": standard deviation over mean across members"};
  if (avalanche && (name == "mean" || name == "stddev" || name == "sem" || name == "member_mean"))
    return {"R", profile + ": " + name};
  if (name == "centre" || name == "position" || name == "member_position")
    return {"R", group + " " + name + " (height)"};
  if (name == "contact_normal") return {"m g", "normal contact force (> 0 compressive)"};
  if (name == "contact_tangential") return {"m g", "tangential contact force"};
  if (name == "contact_moment") return {"m g R", "rolling moment of the contact"};
  if (name == "vx" || name == "vy") return {"sqrt(g R)", "velocity component"};
  if (name == "w") return {"sqrt(g / R)", "angular velocity"};
  if (name == "wall_time") return {"s", "seconds the member held its batch slot"};
  if (name == "nu_lower_half")
    return {
        "1",
        "mean volume fraction in [lower_half_from, H/2) (A, B) or [lower_half_from, top/2) (C)"};
  if (name == "mean_abs_dy") return {"R", "mean abs(Delta y) of the member's disks"};
  if (name == "nu_initial")
    return {"1", "volume fraction of the ballistic deposit in [lower_half_from, top/2) (C)"};
  if (group == "events" && name == "edges")
    return {"", "logarithmic bin edges (R for displacements, disks, steps)"};
  for (const char* n : {"x", "y", "y_i", "y_e", "radius", "top", "depth", "edges"})
    if (name == n) return {"R", group + " " + name};
  return {"", group + " " + name};
}

std::string leaf_name(hid_t obj) {
  const ssize_t n = H5Iget_name(obj, nullptr, 0);
  std::string path(static_cast<std::size_t>(std::max<ssize_t>(n, 0)) + 1, '\0');
  if (n > 0) H5Iget_name(obj, path.data(), path.size());
  path.resize(static_cast<std::size_t>(std::max<ssize_t>(n, 0)));
  return path.substr(path.find_last_of('/') + 1);
}

void string_attribute_on(hid_t obj, const std::string& name, const std::string& v);

// A dataset of shape dims (1 or 2) with its units and long name; counts and indices as
// integers.
void write_dataset(hid_t parent, const std::string& name, const std::vector<double>& v, int rank,
                   const hsize_t* dims) {
  const std::size_t slash = name.find_last_of('/');
  const std::string leaf = slash == std::string::npos ? name : name.substr(slash + 1);
  const std::string group =
      slash == std::string::npos ? leaf_name(parent) : name.substr(0, slash);
  const DatasetMeta meta = dataset_meta(group, leaf);
  H5 space(H5Screate_simple(rank, dims, nullptr), H5Sclose, "create dataspace");
  H5 set(H5Dcreate2(parent, name.c_str(), meta.integer ? H5T_STD_I64LE : H5T_IEEE_F64LE, space,
                    H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
         H5Dclose, "create dataset " + name);
  if (!v.empty()) {
    if (meta.integer) {
      std::vector<long long> n(v.size());
      for (std::size_t k = 0; k < v.size(); ++k) n[k] = std::llround(v[k]);
      check(H5Dwrite(set, H5T_NATIVE_LLONG, H5S_ALL, H5S_ALL, H5P_DEFAULT, n.data()),
            "write dataset " + name);
    } else {
      check(H5Dwrite(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()),
            "write dataset " + name);
    }
  }
  if (!meta.units.empty()) string_attribute_on(set, "units", meta.units);
  string_attribute_on(set, "long_name", meta.long_name);
}

void dataset(hid_t parent, const std::string& name, const std::vector<double>& v) {
  const hsize_t n = v.size();
  write_dataset(parent, name, v, 1, &n);
}

// Rows of equal length as a 2-D dataset [rows x columns].
void dataset(hid_t parent, const std::string& name, const std::vector<std::vector<double>>& rows) {
  const hsize_t dims[2] = {rows.size(), rows.empty() ? 0 : rows.front().size()};
  std::vector<double> flat;
  for (const auto& r : rows) {
    if (r.size() != dims[1]) throw std::logic_error("dataset " + name + ": rows of unequal length");
    flat.insert(flat.end(), r.begin(), r.end());
  }
  write_dataset(parent, name, flat, 2, dims);
}

void attribute(hid_t obj, const std::string& name, double v) {
  H5 space(H5Screate(H5S_SCALAR), H5Sclose, "create dataspace");
  H5 a(H5Acreate2(obj, name.c_str(), H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
       "create attribute " + name);
  check(H5Awrite(a, H5T_NATIVE_DOUBLE, &v), "write attribute " + name);
}

// A count or an index as a 64-bit integer attribute.
void count(hid_t obj, const std::string& name, long long v) {
  H5 space(H5Screate(H5S_SCALAR), H5Sclose, "create dataspace");
  H5 a(H5Acreate2(obj, name.c_str(), H5T_STD_I64LE, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
       "create attribute " + name);
  check(H5Awrite(a, H5T_NATIVE_LLONG, &v), "write attribute " + name);
}

// Strings are variable-length UTF-8 (Python reads them as str).
H5 utf8_string_type() {
  H5 type(H5Tcopy(H5T_C_S1), H5Tclose, "copy string type");
  check(H5Tset_size(type, H5T_VARIABLE), "set string size");
  check(H5Tset_cset(type, H5T_CSET_UTF8), "set string encoding");
  return type;
}

void string_attribute_on(hid_t obj, const std::string& name, const std::string& v) {
  H5 type = utf8_string_type();
  H5 space(H5Screate(H5S_SCALAR), H5Sclose, "create dataspace");
  H5 a(H5Acreate2(obj, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
       "create attribute " + name);
  const char* p = v.c_str();
  check(H5Awrite(a, type, &p), "write attribute " + name);
}

void attribute(hid_t obj, const std::string& name, const std::string& v) {
  string_attribute_on(obj, name, v);
}

// A text as a scalar string dataset (unlike an attribute, 64 KiB at most, of any length) with its
// long name. Of fixed length, not variable: a variable-length string's reference into HDF5's
// global heap would lie in the dataset's raw data, which no checksum covers, and a damaged one
// made HDF5 1.10 read out of bounds. (An attribute's reference lies in its object header,
// which the file format checksums.)
void string_dataset(hid_t parent, const std::string& name, const std::string& v,
                    const std::string& long_name) {
  H5 type(H5Tcopy(H5T_C_S1), H5Tclose, "copy string type");
  check(H5Tset_size(type, std::max<std::size_t>(v.size(), 1)), "set string size");
  check(H5Tset_strpad(type, H5T_STR_NULLPAD), "set string padding");
  check(H5Tset_cset(type, H5T_CSET_UTF8), "set string encoding");
  H5 space(H5Screate(H5S_SCALAR), H5Sclose, "create dataspace");
  H5 set(H5Dcreate2(parent, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
         H5Dclose, "create dataset " + name);
  std::string padded = v;
  padded.resize(std::max<std::size_t>(v.size(), 1), '\0');
  check(H5Dwrite(set, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, padded.data()), "write dataset " + name);
  string_attribute_on(set, "long_name", long_name);
}

// Opaque bytes as a one-dimensional dataset of unsigned 8-bit integers, with its long name.
void bytes_dataset(hid_t parent, const std::string& name, const std::string& bytes,
                   const std::string& long_name) {
  const hsize_t n = bytes.size();
  H5 space(H5Screate_simple(1, &n, nullptr), H5Sclose, "create dataspace for " + name);
  H5 set(
      H5Dcreate2(parent, name.c_str(), H5T_STD_U8LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
      H5Dclose, "create dataset " + name);
  if (n > 0)
    check(H5Dwrite(set, H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT, bytes.data()),
          "write dataset " + name);
  string_attribute_on(set, "long_name", long_name);
}

void scalar(hid_t obj, const std::string& name, const Scalar& s) {
  attribute(obj, name + "_mean", s.mean);
  attribute(obj, name + "_sem", s.sem);
  count(obj, name + "_n", s.n);
}

// The datasets of a profile and of a binned statistic: one list for writing and reading.
template <class T>
using Field = std::pair<const char*, std::vector<double> T::*>;
const Field<EnsembleProfile> kProfileFields[] = {
    {"centre", &EnsembleProfile::centre},
    {"mean", &EnsembleProfile::mean},
    {"sem", &EnsembleProfile::sem},
    {"members", &EnsembleProfile::members},
    {"rel_fluctuation", &EnsembleProfile::rel_fluctuation}};
const Field<BinnedStat> kBinnedFields[] = {
    {"centre", &BinnedStat::centre}, {"position", &BinnedStat::position},
    {"mean", &BinnedStat::mean},     {"stddev", &BinnedStat::stddev},
    {"count", &BinnedStat::count},   {"sem", &BinnedStat::sem}};
// Per-member rows of a binned statistic: 2-D datasets [members x bins].
const std::pair<const char*, std::vector<std::vector<double>> BinnedStat::*> kBinnedMemberFields[] =
    {{"member_position", &BinnedStat::member_position},
     {"member_mean", &BinnedStat::member_mean},
     {"member_count", &BinnedStat::member_count}};

// A group `name` with one dataset per field of v.
template <class T, std::size_t N>
void fields(hid_t parent, const std::string& name, const T& v, const Field<T> (&list)[N]) {
  H5 g = group(parent, name);
  for (const auto& [field, member] : list) dataset(g, field, v.*member);
}

// An avalanche profile: its fields and its per-member rows.
void binned_stat(hid_t parent, const std::string& name, const BinnedStat& b) {
  fields(parent, name, b, kBinnedFields);
  H5 g = open_group(parent, name);
  for (const auto& [field, member] : kBinnedMemberFields) dataset(g, field, b.*member);
}

// A point's system parameters as its attributes (name, value), in the order they are written.
std::vector<std::pair<const char*, double>> param_attributes(const SystemParams& p) {
  return {{"width", p.width},
          {"height", p.height},
          {"radius", p.radius},
          {"polydispersity", p.polydispersity},
          {"disk_density", p.disk_density},
          {"gravity", p.gravity},
          {"bond_number", p.bond_number},
          {"cohesive_force", p.cohesive_force()},
          {"cohesion_range", p.cohesion_range},
          {"floor_cohesion", p.floor_cohesion ? 1.0 : 0.0},
          {"friction", p.friction},
          {"rolling_friction", p.rolling_friction},
          {"time_step", p.time_step},
          {"capture_radius", p.capture_radius}};
}

void params(hid_t g, const SystemParams& p) {
  for (const auto& [name, value] : param_attributes(p)) attribute(g, name, value);
}

// A fit: datasets coef and error (parameter k and its standard error), attributes valid,
// chi2, dof, points, reduced_chi2.
void fit(hid_t parent, const std::string& name, const Fit& f) {
  H5 g = group(parent, name);
  attribute(g, "valid", f.valid() ? 1.0 : 0.0);
  dataset(g, "coef", f.valid() ? f.coef : std::vector<double>{});
  dataset(g, "error", f.valid() ? f.error : std::vector<double>{});
  attribute(g, "chi2", f.valid() ? f.chi2 : NAN);
  count(g, "dof", f.dof);
  count(g, "points", f.points);
  attribute(g, "reduced_chi2", f.valid() ? f.reduced_chi2() : NAN);
  attribute(g, "next_term_t", f.valid() ? f.next_term_t : NAN);
}

void histogram_shape(hid_t parent, const std::string& name, const HistogramShape& h) {
  H5 g = group(parent, name);
  attribute(g, "preferred", h.preferred);
  attribute(g, "member_errors", h.member_errors ? 1.0 : 0.0);
  attribute(g, "decay_length", h.decay_length);
  attribute(g, "gaussian_mean", h.gaussian_mean);
  attribute(g, "gaussian_width", h.gaussian_width);
  attribute(g, "quadratic_chi2", h.quadratic_chi2);
  count(g, "members", static_cast<long long>(h.gaussian.replicas.size()));  // the verdict's
  fit(g, "exponential", h.exponential);
  fit(g, "gaussian", h.gaussian);
  for (const auto& [shape, f, acceptable] :
       {std::tuple("exponential", &h.exponential, h.exponential_acceptable),
        std::tuple("gaussian", &h.gaussian, h.gaussian_acceptable)}) {
    H5 s = open_group(g, shape);
    attribute(s, "second_term_t", f->valid() ? f->second_term_t : NAN);
    attribute(s, "acceptable", acceptable ? 1.0 : 0.0);
  }
}

// The analysis of one point (docs/OUTPUT.md, "Analysis"): fits inside the groups of the data
// they fit, which must exist.
void point_analysis(hid_t g, Protocol protocol, const PointAnalysis& an) {
  {
    H5 nu = open_group(g, "nu");
    dataset(nu, "predicted", an.nu_predicted);
    dataset(nu, "deviation", an.nu_deviation);
    attribute(nu, "rms_deviation", an.nu_rms_deviation);
    const auto& t = an.nu_deviation_terms;
    H5 d = group(nu, "deviation_terms");
    for (const auto& [name, v] :
         {std::pair("mean", t.mean), std::pair("mean_error", t.mean_error),
          std::pair("slope", t.slope), std::pair("slope_error", t.slope_error),
          std::pair("from", t.from), std::pair("to", t.to)})
      attribute(d, name, v);
    count(d, "strips", t.strips);
    count(d, "members", t.members);
  }
  fit(open_group(g, "nu_deposition"), "power_law", an.deposition_power_law);
  fit(open_group(g, "avalanche_by_yi"), "fit", an.dy_by_yi);
  {
    H5 ye = open_group(g, "avalanche_by_ye");
    fit(ye, "fit", an.dy_by_ye);
    if (protocol == Protocol::A) fit(ye, "slice_parabola", an.slice_parabola);
  }
  {
    H5 h = open_group(g, "abs_dy_histogram");
    histogram_shape(h, "shape", an.abs_dy);
    histogram_shape(h, "shape_cut", an.abs_dy_cut);
  }
  if (protocol == Protocol::C) {
    H5 c = group(g, "collapse_identity");
    attribute(c, "b_prime", an.b_prime);
    attribute(c, "b_prime_error", an.b_prime_error);
    attribute(c, "b_prime_predicted", an.b_prime_predicted);
    attribute(c, "b_prime_predicted_error", an.b_prime_predicted_error);
    attribute(c, "a_prime", an.a_prime);
    attribute(c, "a_prime_error", an.a_prime_error);
    attribute(c, "a_prime_predicted", an.a_prime_predicted);
    attribute(c, "a_prime_predicted_error", an.a_prime_predicted_error);
    attribute(c, "slope_increase", an.slope_increase);
    attribute(c, "slope_increase_error", an.slope_increase_error);
    attribute(c, "b_prime_difference", an.b_prime_difference);
    attribute(c, "b_prime_difference_error", an.b_prime_difference_error);
    attribute(c, "a_prime_difference", an.a_prime_difference);
    attribute(c, "a_prime_difference_error", an.a_prime_difference_error);
  }
}

// Every object point_analysis writes, removed where present (a file of an older program may
// lack some). HDF5 does not give the freed space back; the file keeps its size.
void remove_point_analysis(hid_t g) {
  for (const char* name :
       {"nu/predicted", "nu/deviation", "nu/deviation_terms", "nu_deposition/power_law",
        "avalanche_by_yi/fit", "avalanche_by_ye/fit", "avalanche_by_ye/slice_parabola",
        "abs_dy_histogram/shape", "abs_dy_histogram/shape_cut", "collapse_identity"})
    if (H5Lexists(g, name, H5P_DEFAULT) > 0)
      check(H5Ldelete(g, name, H5P_DEFAULT), std::string("remove ") + name);
  if (H5Aexists_by_name(g, "nu", "rms_deviation", H5P_DEFAULT) > 0)
    check(H5Adelete_by_name(g, "nu", "rms_deviation", H5P_DEFAULT), "remove nu@rms_deviation");
}

// The fits across scan points.
void scan_analysis(hid_t file, const ScanAnalysis& s) {
  H5 g = group(file, "analysis");
  const auto across = [&](const std::string& name, const Fit& f) {
    fit(g, name, f);
    H5 fg = open_group(g, name);
    dataset(fg, "scan_points", std::vector<double>(f.scan_points.begin(), f.scan_points.end()));
  };
  across("increase_vs_log_height", s.increase_vs_log_height);
  across("increase_vs_nu_initial", s.increase_vs_nu_initial);
  across("quadratic_vs_height", s.quadratic_vs_height);
  across("slice_vs_height", s.slice_vs_height);
}

std::string point_name(int k) {
  std::ostringstream o;
  o << "points/" << std::setw(4) << std::setfill('0') << k;
  return o.str();
}

// A member's disks (x, y_i, y_e, r) and contact forces.
void snapshot(hid_t g, const MemberResult& r) {
  dataset(g, "x", r.x);
  dataset(g, "y_i", r.y_i);
  dataset(g, "y_e", r.y_e);
  dataset(g, "radius", r.radius);
  std::vector<double> ci, cj, cn, ct, cm;
  for (const auto& c : r.contacts) {
    ci.push_back(c.i);
    cj.push_back(c.j);
    cn.push_back(c.normal);
    ct.push_back(c.tangential);
    cm.push_back(c.moment);
  }
  dataset(g, "contact_i", ci);
  dataset(g, "contact_j", cj);
  dataset(g, "contact_normal", cn);
  dataset(g, "contact_tangential", ct);
  dataset(g, "contact_moment", cm);
}

// The file's provenance (program, build, run) and the scan's own values and settings.
void write_header(hid_t file, const Scan& scan, const RunInfo& info) {
  attribute(file, "program", std::string("loosepack"));
  attribute(file, "version", std::string(LOOSEPACK_VERSION));
  attribute(file, "git_commit", std::string(LOOSEPACK_GIT_COMMIT));
  attribute(file, "compiler", std::string(LOOSEPACK_COMPILER));
  attribute(file, "cxx_flags", std::string(LOOSEPACK_CXX_FLAGS));
  attribute(file, "kokkos_execution_space", std::string(Kokkos::DefaultExecutionSpace::name()));
  attribute(file, "kokkos_version", static_cast<double>(KOKKOS_VERSION));
  const bool unit_radius = std::all_of(scan.points.begin(), scan.points.end(),
                                       [](const ScanPoint& p) { return p.params.radius == 1.0; });
  attribute(file, "units",
            std::string(unit_radius ? "disk radius R = 1, disk mass m = 1 (R = 1), g = 1, "
                                      "time sqrt(R/g); lengths in R"
                                    : "lengths in the scan file's unit, in which a point's mean "
                                      "disk radius is its attribute radius; a disk of radius r "
                                      "has mass r^2, g = 1, time sqrt(unit/g)"));
  attribute(file, "start_time", info.start_time);
  attribute(file, "end_time", info.end_time);
  attribute(file, "wall_seconds", info.wall_seconds);
  count(file, "mpi_ranks", info.ranks);
  count(file, "members_unfinished", info.members_unfinished);
  if (info.shards > 0) {
    count(file, "shard", info.shard);
    count(file, "shards", info.shards);
  }
  if (!info.merged_from.empty()) {
    std::string parts;
    for (const auto& p : info.merged_from) parts += (parts.empty() ? "" : "\n") + p;
    attribute(file, "merged_from", parts);
  }
  attribute(file, "scan_file", scan.file);
  string_dataset(file, "scan_text", scan.text, "the scan file the results came from, as read");
  attribute(file, "scan_name", scan.name);
  {
    H5 space(H5Screate(H5S_SCALAR), H5Sclose, "create dataspace");
    H5 a(H5Acreate2(file, "seed", H5T_STD_U64LE, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
         "create attribute seed");
    check(H5Awrite(a, H5T_NATIVE_UINT64, &scan.seed), "write attribute seed");
  }
  count(file, "seeds", scan.seeds);
  count(file, "batch_size", scan.batch_size);
  H5 g = group(file, "settings");
  for (const auto& key : setting_keys()) {
    if (key.stored && !key.stored(scan)) continue;
    if (key.type == SettingKey::Type::Choice)
      attribute(g, key.attribute, key.name(scan));
    else
      attribute(g, key.attribute, key.get(scan));
  }
}

// A point's ensemble: its settings, profiles, histograms, events and the analysis of it.
void write_point(hid_t g, const Scan& scan, const PointResult& pr, const PointAnalysis& an) {
  attribute(g, "protocol", protocol_name(pr.point.protocol));
  attribute(g, "solver_tolerance", scan.tolerance(pr.point.protocol));
  attribute(g, "solver_max_sweeps",
            static_cast<double>(scan.max_sweeps(pr.point.protocol, pr.point.params)));
  attribute(g, "solver_newton_every", static_cast<double>(scan.newton_every(pr.point.params)));
  params(g, pr.point.params);
  const double H = pr.point.params.height;
  attribute(g, "lower_half_from", scan.observables.lower_half_from_at(H));
  attribute(g, "cut_bottom", scan.observables.cut_bottom_at(H));
  attribute(g, "cut_top", scan.observables.cut_top_at(H));
  count(g, "members", pr.members);
  count(g, "failed", pr.failed);
  scalar(g, "nu_lower_half", pr.nu_lower_half);
  scalar(g, "mean_abs_dy", pr.mean_abs_dy);
  fields(g, "nu", pr.nu, kProfileFields);
  dataset(g, "nu/member_mean", pr.nu_member_rows);
  std::vector<double> depth;
  for (double c : pr.nu.centre) depth.push_back(pr.point.params.height - c);
  dataset(g, "nu/depth", depth);
  fields(g, "nu_deposition", pr.nu_deposition, kProfileFields);
  dataset(g, "nu_deposition/member_mean", pr.nu_deposition_member_rows);
  binned_stat(g, "avalanche_by_yi", pr.dy_by_yi);
  binned_stat(g, "avalanche_by_ye", pr.dy_by_ye);
  {
    H5 h = group(g, "abs_dy_histogram");
    dataset(h, "edges", pr.abs_dy_edges);
    dataset(h, "counts", pr.abs_dy_counts);
    dataset(h, "counts_cut", pr.abs_dy_counts_cut);
    dataset(h, "member_counts", pr.abs_dy_member_counts);
    dataset(h, "member_counts_cut", pr.abs_dy_member_counts_cut);
  }
  if (pr.point.protocol == Protocol::C) {
    scalar(g, "nu_initial", pr.nu_initial);
    scalar(g, "nu_final", pr.nu_final);
    scalar(g, "relative_increase", pr.relative_increase);
  }
  point_analysis(g, pr.point.protocol, an);
  if (pr.point.protocol == Protocol::A) {
    H5 e = group(g, "events");
    dataset(e, "edges", pr.event_edges);
    dataset(e, "downward_counts", pr.event_downward_counts);
    dataset(e, "moved_counts", pr.event_moved_counts);
    dataset(e, "steps_counts", pr.event_steps_counts);
    dataset(e, "member_downward_counts", pr.event_member_downward_counts);
    dataset(e, "member_moved_counts", pr.event_member_moved_counts);
    dataset(e, "member_steps_counts", pr.event_member_steps_counts);
    count(e, "without_motion", std::llround(pr.events_without_motion));
  }
}

// A point's members: their values, trajectories, snapshots (if asked) and every failed member's
// state at its failure.
void write_members(hid_t m, const Scan& scan, const PointResult& pr,
                   const std::vector<MemberResult>& members, bool snapshots) {
  dataset(m, "seed_index", pr.m_seed_index);
  dataset(m, "disks", pr.m_disks);
  dataset(m, "top", pr.m_top);
  dataset(m, "nu_lower_half", pr.m_nu_lower_half);
  dataset(m, "mean_abs_dy", pr.m_mean_abs_dy);
  if (pr.point.protocol == Protocol::C) dataset(m, "nu_initial", pr.m_nu_initial);
  dataset(m, "steps", pr.m_steps);
  dataset(m, "sweeps", pr.m_sweeps);
  dataset(m, "wall_time", pr.m_wall_time);
  dataset(m, "failure", pr.m_failure);
  dataset(m, "capped", pr.m_capped);
  if (scan.observables.trajectory_every > 0) {
    for (const auto& r : members) {
      if (r.member.point != pr.point.index) continue;
      H5 t = group(m, "trajectory_" + std::to_string(r.member.seed_index));
      dataset(t, "time", r.trajectory_time);
      dataset(t, "disk", r.trajectory_disk);
      dataset(t, "x", r.trajectory_x);
      dataset(t, "y", r.trajectory_y);
    }
  }
  for (const auto& r : members) {
    if (r.member.point != pr.point.index) continue;
    // A failed member left no deposit: its state is the failure snapshot below, written once.
    if (snapshots && r.ok())
      snapshot(group(m, "snapshot_" + std::to_string(r.member.seed_index)), r);
    if (r.ok()) continue;
    // A failed member's state at the failure, always: its diagnostic snapshot.
    H5 f = group(m, "failure_" + std::to_string(r.member.seed_index));
    snapshot(f, r);
    count(f, "member", r.member.id);
    attribute(f, "failure", failure_message(r.failure));
    dataset(f, "vx", r.vx);
    dataset(f, "vy", r.vy);
    dataset(f, "w", r.w);
  }
}

}  // namespace

void write_results(const std::string& path, const Scan& scan, const RunInfo& info,
                   const std::vector<PointResult>& points, const Analysis& analysis,
                   const std::vector<MemberResult>& members, bool snapshots) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors become exceptions with our messages
  replace_hdf5_file(path, [&](hid_t file) {
    write_header(file, scan, info);
    scan_analysis(file, analysis.scan);
    H5 all = group(file, "points");
    for (std::size_t pk = 0; pk < points.size(); ++pk) {
      const PointResult& pr = points[pk];
      H5 g = group(file, point_name(pr.point.index));
      write_point(g, scan, pr, analysis.points.at(pk));
      write_members(group(g, "members"), scan, pr, members, snapshots);
    }
    if (info.shards > 0 || members.size() < members_of(scan).size())
      bytes_dataset(file, "members_encoded", checkpoint_part_bytes(scan_fingerprint(scan), members),
                    "the file's members as a checkpoint part (loosepack merge)");
  });
}

std::vector<PointResult> write_member_results(const std::string& path, const Scan& scan,
                                              const RunInfo& info,
                                              const std::vector<MemberResult>& members,
                                              bool snapshots) {
  auto points = aggregate(scan, members);
  points.erase(std::remove_if(points.begin(), points.end(),
                                [](const PointResult& p) { return p.members == 0; }),
                 points.end());
  write_results(path, scan, info, points, analyse(scan, points), members, snapshots);
  return points;
}

std::string members_left_out_note(int point, Protocol protocol, int over, int finished) {
  if (over >= finished) return "";
  std::ostringstream o;
  o << "point " << std::setw(4) << std::setfill('0') << point << std::setfill(' ')
    << ": nu_lower_half" << (protocol == Protocol::C ? ", nu_initial and dnu/nu_i" : "") << " over "
    << over << " of " << finished
    << " finished members: the others' final band was empty (a collapse below 2 "
       "lower_half_from; a lower observables.lower_half_from keeps them; docs/MODEL.md, "
       "\"Observables\")";
  return o.str();
}

std::string capped_collapses_note(int point, const std::vector<double>& failure,
                                  const std::vector<double>& capped) {
  int finished = 0, stopped = 0;
  for (std::size_t k = 0; k < failure.size() && k < capped.size(); ++k) {
    if (failure[k] != 0.0) continue;
    ++finished;
    stopped += capped[k] > 0.0 ? 1 : 0;
  }
  if (stopped == 0) return "";
  std::ostringstream o;
  o << "point " << std::setw(4) << std::setfill('0') << point << std::setfill(' ')
    << ": the collapse of " << stopped << " of " << finished
    << " finished members was stopped at protocol.max_collapse_time while still moving; their "
       "final states enter nu_lower_half, dnu/nu_i and the profiles as they were (a larger "
       "max_collapse_time lets them come to rest)";
  return o.str();
}

namespace {

// A 2-D dataset as its rows.
std::vector<std::vector<double>> rows(hid_t loc, const std::string& name) {
  H5 set(H5Dopen2(loc, name.c_str(), H5P_DEFAULT), H5Dclose, "open dataset " + name);
  H5 space(H5Dget_space(set), H5Sclose, "get dataspace of " + name);
  hsize_t dims[2] = {0, 0};
  if (H5Sget_simple_extent_ndims(space) != 2)
    throw std::runtime_error("dataset " + name + " is not two-dimensional");
  H5Sget_simple_extent_dims(space, dims, nullptr);
  std::vector<double> flat(static_cast<std::size_t>(dims[0] * dims[1]));
  if (!flat.empty())
    check(H5Dread(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, flat.data()),
          "read dataset " + name);
  std::vector<std::vector<double>> out;
  for (hsize_t r = 0; r < dims[0]; ++r)
    out.emplace_back(flat.begin() + static_cast<std::ptrdiff_t>(r * dims[1]),
                     flat.begin() + static_cast<std::ptrdiff_t>((r + 1) * dims[1]));
  return out;
}

// A scalar string of an attribute or a dataset, variable-length (attributes; /scan_text of files
// from 2026-11-25 to 2026-12-05) or of fixed length (/scan_text from 2026-12-05 on, and older
// files); `read` reads it into memory of the given type.
template <class Read>
std::string read_string(hid_t type, const std::string& what, Read&& read) {
  if (H5Tget_class(type) != H5T_STRING) throw std::runtime_error(what + " is not a string");
  if (H5Tis_variable_str(type) > 0) {
    H5 mem = utf8_string_type();
    char* p = nullptr;
    check(read(static_cast<hid_t>(mem), static_cast<void*>(&p)), "read " + what);
    std::string s = p ? p : "";
    H5free_memory(p);
    return s;
  }
  const std::size_t n = H5Tget_size(type);
  std::string s(n, '\0');
  // The file's own type: a conversion would cut a null-padded string's last character to fit a
  // terminator, and HDF5 converts no ASCII to UTF-8.
  H5 mem(H5Tcopy(type), H5Tclose, "copy string type");
  check(read(static_cast<hid_t>(mem), static_cast<void*>(s.data())), "read " + what);
  while (!s.empty() && s.back() == '\0') s.pop_back();
  return s;
}

std::string string_attribute(hid_t loc, const std::string& object, const std::string& name) {
  H5 a(H5Aopen_by_name(loc, object.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
       "open attribute " + object + "@" + name);
  H5 type(H5Aget_type(a), H5Tclose, "get attribute type");
  return read_string(type, "attribute " + name,
                     [&](hid_t mem, void* buf) { return H5Aread(a, mem, buf); });
}

std::string string_of_dataset(hid_t loc, const std::string& name) {
  H5 set(H5Dopen2(loc, name.c_str(), H5P_DEFAULT), H5Dclose, "open dataset " + name);
  H5 type(H5Dget_type(set), H5Tclose, "get dataset type");
  return read_string(type, "dataset " + name, [&](hid_t mem, void* buf) {
    return H5Dread(set, mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf);
  });
}

// The scan file a result file was computed from: the dataset /scan_text, or the root attribute
// of that name in files written before it became a dataset.
std::string scan_text_of(hid_t file) {
  if (H5Lexists(file, "scan_text", H5P_DEFAULT) > 0) return string_of_dataset(file, "scan_text");
  if (H5Aexists(file, "scan_text") > 0) return string_attribute(file, "/", "scan_text");
  throw std::runtime_error("no /scan_text (the scan file the results came from)");
}

// A count stored as a double attribute, checked before it becomes an int.
int count_attribute(hid_t loc, const std::string& name) {
  const double v = double_attribute(loc, ".", name);
  if (!(v >= 0.0 && v <= 1e9) || v != std::floor(v))
    throw std::runtime_error("attribute " + name + " = " + std::to_string(v) + " is not a count");
  return static_cast<int>(v);
}

// The datasets of one group read back must agree in length (one entry per strip or bin), and
// hold at least one: a damaged or hand-edited file is refused, never analysed out of bounds.
void check_lengths(const std::string& group,
                   const std::vector<std::pair<std::string, std::size_t>>& sizes) {
  for (const auto& [name, n] : sizes)
    if (n != sizes.front().second || n == 0)
      throw std::runtime_error(group + "/" + name + " has " + std::to_string(n) + " values, " +
                               group + "/" + sizes.front().first + " " +
                               std::to_string(sizes.front().second));
}

// A point's per-member rows: one per member of the point (`members`, its failed ones included).
void check_member_rows(const std::string& what, std::size_t rows, int members) {
  if (rows != static_cast<std::size_t>(members))
    throw std::runtime_error(what + " has " + std::to_string(rows) + " rows, one per member of " +
                             std::to_string(members));
}

// What write_results stored of a point's aggregates, as far as the analysis reads them.
PointResult read_point(hid_t file, const ScanPoint& point) {
  const std::string n = point_name(point.index);
  if (H5Lexists(file, "points", H5P_DEFAULT) <= 0 || H5Lexists(file, n.c_str(), H5P_DEFAULT) <= 0)
    throw std::runtime_error("no such group, though its scan_text has this point");
  H5 g = open_group(file, n);
  PointResult pr;
  pr.point = point;
  pr.members = count_attribute(g, "members");
  pr.failed = count_attribute(g, "failed");
  auto scalar_of = [&](const std::string& name) {
    Scalar s;
    s.mean = double_attribute(g, ".", name + "_mean");
    s.sem = double_attribute(g, ".", name + "_sem");
    s.n = count_attribute(g, name + "_n");
    return s;
  };
  auto read = [&](const std::string& name, auto& v, const auto& list) {
    std::vector<std::pair<std::string, std::size_t>> sizes;
    for (const auto& [field, member] : list) {
      v.*member = doubles(g, name + "/" + field);
      sizes.emplace_back(field, (v.*member).size());
    }
    check_lengths(n + "/" + name, sizes);
  };
  pr.nu_lower_half = scalar_of("nu_lower_half");
  pr.mean_abs_dy = scalar_of("mean_abs_dy");
  read("nu", pr.nu, kProfileFields);
  read("nu_deposition", pr.nu_deposition, kProfileFields);
  for (auto [name, b] :
       {std::pair("avalanche_by_yi", &pr.dy_by_yi), std::pair("avalanche_by_ye", &pr.dy_by_ye)}) {
    read(name, *b, kBinnedFields);
    for (const auto& [field, member] : kBinnedMemberFields) {
      // Files of programs before the per-member rows lack them: the fits then take their
      // errors from the residual scatter.
      const std::string path = std::string(name) + "/" + field;
      if (H5Lexists(g, path.c_str(), H5P_DEFAULT) <= 0) continue;
      (*b).*member = rows(g, path);
      check_member_rows(path, ((*b).*member).size(), pr.members);
      for (const auto& row : (*b).*member)
        check_lengths(n + "/" + name, {{"centre", b->centre.size()}, {field, row.size()}});
    }
  }
  pr.abs_dy_edges = doubles(g, "abs_dy_histogram/edges");
  pr.abs_dy_counts = doubles(g, "abs_dy_histogram/counts");
  pr.abs_dy_counts_cut = doubles(g, "abs_dy_histogram/counts_cut");
  check_lengths(n + "/abs_dy_histogram",
                {{"counts", pr.abs_dy_counts.size()},
                 {"counts_cut", pr.abs_dy_counts_cut.size()},
                 {"edges less one", pr.abs_dy_edges.empty() ? 0 : pr.abs_dy_edges.size() - 1}});
  // Files of programs before the per-member counts lack them: the shapes' chi2 is then Pearson's.
  for (auto [name, member] : {std::pair("member_counts", &pr.abs_dy_member_counts),
                              std::pair("member_counts_cut", &pr.abs_dy_member_counts_cut)}) {
    const std::string path = std::string("abs_dy_histogram/") + name;
    if (H5Lexists(g, path.c_str(), H5P_DEFAULT) <= 0) continue;
    *member = rows(g, path);
    check_member_rows(path, member->size(), pr.members);
    for (const auto& row : *member)
      check_lengths(n + "/abs_dy_histogram",
                    {{"counts", pr.abs_dy_counts.size()}, {name, row.size()}});
  }
  if (point.protocol == Protocol::C) {
    pr.nu_initial = scalar_of("nu_initial");
    pr.nu_final = scalar_of("nu_final");
    pr.relative_increase = scalar_of("relative_increase");
  }
  // What the analysis takes per member where a file has it (older programs' files may not): the
  // members that did not fail and their tops, their density profiles, and their nu_f and nu_i
  // (the covariance of a C point's nu_i and dnu/nu_i).
  for (auto [path, member] :
       {std::pair("nu/member_mean", &pr.nu_member_rows),
        std::pair("nu_deposition/member_mean", &pr.nu_deposition_member_rows)})
    if (H5Lexists(g, path, H5P_DEFAULT) > 0) {
      *member = rows(g, path);
      check_member_rows(std::string(n) + "/" + path, member->size(), pr.members);
    }
  if (H5Lexists(g, "members", H5P_DEFAULT) > 0)
    for (auto [path, member] :
         {std::pair("members/failure", &pr.m_failure), std::pair("members/top", &pr.m_top),
          std::pair("members/nu_lower_half", &pr.m_nu_lower_half),
          std::pair("members/nu_initial", &pr.m_nu_initial)})
      if (H5Lexists(g, path, H5P_DEFAULT) > 0) {
        *member = doubles(g, path);
        check_member_rows(std::string(n) + "/" + path, member->size(), pr.members);
      }
  return pr;
}

}  // namespace

void reanalyse(const std::string& in, const std::string& out) {
  Scan scan;
  std::vector<PointResult> points;
  try {
    const H5 file = open_to_read(in, "open it (not an HDF5 file written by loosepack?)");
    scan = parse_scan(scan_text_of(file), in + " (scan_text)");
    for (const auto& p : scan.points) {
      // A file of some members (one member, a shard, the finished ones) has their points only.
      if (H5Lexists(file, "points", H5P_DEFAULT) > 0 &&
          H5Lexists(file, point_name(p.index).c_str(), H5P_DEFAULT) <= 0)
        continue;
      try {
        points.push_back(read_point(file, p));
      } catch (const std::runtime_error& e) {
        throw std::runtime_error(point_name(p.index) + ": " + e.what());
      }
    }
    if (points.empty()) throw std::runtime_error("no scan point of its scan_text");
  } catch (const ScanError&) {
    throw;
  } catch (const std::runtime_error& e) {
    throw DamagedResultFile(in, e.what());
  }
  const Analysis analysis = analyse(scan, points);
  const std::string image = read_bytes(in);
  replace_hdf5_file(
      out,
      [&](hid_t file) {
        // The copy's old analysis goes first: an error there is the input's damage, one while
        // writing the new analysis the output's.
        std::vector<H5> groups;
        try {
          if (H5Lexists(file, "analysis", H5P_DEFAULT) > 0)
            check(H5Ldelete(file, "analysis", H5P_DEFAULT), "remove analysis");
          for (const auto& p : points) {
            groups.push_back(open_group(file, point_name(p.point.index)));
            remove_point_analysis(groups.back());
          }
        } catch (const std::runtime_error& e) {
          throw DamagedResultFile(in, e.what());
        }
        scan_analysis(file, analysis.scan);
        for (std::size_t k = 0; k < points.size(); ++k)
          point_analysis(groups[k], points[k].point.protocol, analysis.points[k]);
      },
      &image);
}

std::vector<double> read_dataset(const std::string& path, const std::string& name) {
  const H5 file = open_to_read(path, "open " + path);
  return doubles(file, name);
}

double read_attribute_double(const std::string& path, const std::string& object,
                             const std::string& name) {
  const H5 file = open_to_read(path, "open " + path);
  return double_attribute(file, object, name);
}

std::string read_scan_text(const std::string& path) {
  const H5 file = open_to_read(path, "open " + path);
  return scan_text_of(file);
}

std::string read_attribute_string(const std::string& path, const std::string& object,
                                  const std::string& name) {
  const H5 file = open_to_read(path, "open " + path);
  return string_attribute(file, object, name);
}

std::string result_file_problem(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const std::string not_hdf5 = path +
                               " is not an HDF5 file that can be opened (not a loosepack result "
                               "file, or damaged: truncated by a copy or a full disk?)";
  if (H5Fis_hdf5(path.c_str()) <= 0) return not_hdf5;
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);  // a truncated file fails
  if (file < 0) return not_hdf5;
  // The scan text is a dataset, or in files written before 2026-11-25 a root attribute.
  const bool result =
      H5Lexists(file, "points", H5P_DEFAULT) > 0 &&
      (H5Lexists(file, "scan_text", H5P_DEFAULT) > 0 || H5Aexists(file, "scan_text") > 0);
  H5Fclose(file);
  return result ? ""
                : path +
                      " is an HDF5 file but not a loosepack result file (no /points or "
                      "/scan_text): give the file `loosepack run` wrote";
}

PartFile read_part_file(const std::string& path) {
  if (const std::string problem = result_file_problem(path); !problem.empty())
    throw std::runtime_error(problem);
  PartFile out;
  out.path = path;
  try {
    const H5 file = open_to_read(path, "open it (not an HDF5 file written by loosepack?)");
    if (H5Lexists(file, "shard_members", H5P_DEFAULT) > 0)  // what earlier builds wrote
      throw std::runtime_error(
          "a shard's file of an earlier build: merge it with the loosepack build that ran it "
          "(its git_commit attribute; loosepack --version)");
    if (H5Lexists(file, "members_encoded", H5P_DEFAULT) <= 0)
      throw std::runtime_error(
          "holds no encoded members: a file of a whole scan, or one of an earlier build (merge "
          "takes the files of loosepack run SCAN --shard K/N, --member N or --resume "
          "--finished-only, and partial merges, of one build)");
    out.scan_text = scan_text_of(file);
    out.scan_file = string_attribute(file, "/", "scan_file");
    if (H5Lexists(file, "points", H5P_DEFAULT) > 0)
      for (const std::string& point : children(file, "points")) {
        const std::string members = "points/" + point + "/members";
        if (H5Lexists(file, members.c_str(), H5P_DEFAULT) <= 0) continue;
        for (const std::string& child : children(file, members))
          out.snapshots = out.snapshots || child.rfind("snapshot_", 0) == 0;
      }
    out.info.start_time = string_attribute(file, "/", "start_time");
    out.info.end_time = string_attribute(file, "/", "end_time");
    out.info.wall_seconds = double_attribute(file, "/", "wall_seconds");
    out.info.ranks = count_attribute(file, "mpi_ranks");
    if (H5Aexists(file, "shards") > 0) {
      out.info.shard = count_attribute(file, "shard");
      out.info.shards = count_attribute(file, "shards");
    }
    H5 set(H5Dopen2(file, "members_encoded", H5P_DEFAULT), H5Dclose,
           "open dataset members_encoded");
    H5 type(H5Dget_type(set), H5Tclose, "get the type of members_encoded");
    H5 space(H5Dget_space(set), H5Sclose, "get dataspace of members_encoded");
    if (H5Tget_class(type) != H5T_INTEGER || H5Tget_size(type) != 1 ||
        H5Sget_simple_extent_ndims(space) != 1)
      throw std::runtime_error("members_encoded is not a one-dimensional dataset of bytes");
    // No more bytes than the file holds: a damaged extent is refused, not allocated.
    const hssize_t n = H5Sget_simple_extent_npoints(space);
    std::error_code ec;
    const auto size = std::filesystem::file_size(path, ec);
    if (n < 0 || ec || static_cast<std::uintmax_t>(n) > size)
      throw std::runtime_error("members_encoded has a length the file cannot hold");
    out.members.resize(static_cast<std::size_t>(n));
    if (!out.members.empty())
      check(H5Dread(set, H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.members.data()),
            "read dataset members_encoded");
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  return out;
}

namespace {
// Reads the fits of the analysis from a result file as the summary prints them.
struct FitReader {
  hid_t file;

  bool exists(const std::string& object) const {
    return H5Lexists(file, object.c_str(), H5P_DEFAULT) > 0 &&
           H5Oexists_by_name(file, object.c_str(), H5P_DEFAULT) > 0;
  }
  double attribute(const std::string& object, const char* name) const {
    return double_attribute(file, object, name);
  }
  // An attribute that files of older programs lack: NaN there.
  double newer_attribute(const std::string& object, const char* name) const {
    return H5Aexists_by_name(file, object.c_str(), name, H5P_DEFAULT) > 0 ? attribute(object, name)
                                                                          : NAN;
  }
  // A valid fit's coefficients and errors, at least `n` of each (else the file is refused).
  std::pair<std::vector<double>, std::vector<double>> coefficients(const std::string& object,
                                                                   std::size_t n) const {
    auto c = doubles(file, object + "/coef"), e = doubles(file, object + "/error");
    check_lengths(object, {{"coef", c.size()}, {"error", e.size()}});
    if (c.size() < n)
      throw std::runtime_error(object + "/coef has " + std::to_string(c.size()) +
                               " values, fewer than its model has (the file is damaged or was "
                               "edited)");
    return {c, e};
  }
  bool valid(const std::string& object) const {
    return exists(object) && attribute(object, "valid") != 0.0;
  }
  // A polynomial in `var`, or "" where the file has no valid fit.
  std::string fit_text(const std::string& object, const char* var) const {
    if (!valid(object)) return std::string();
    const auto [c, e] = coefficients(object, 1);
    std::ostringstream o;
    o << std::setprecision(3);
    for (std::size_t k = 0; k < c.size(); ++k) {
      o << (k ? " + " : "") << "(" << c[k] << " +- " << e[k] << ")";
      if (k == 1) o << " " << var;
      if (k > 1) o << " " << var << "^" << k;
    }
    o << "  [chi2/dof " << attribute(object, "reduced_chi2");
    const double t = newer_attribute(object, "next_term_t");  // files from 2026-12-02 on
    if (std::isfinite(t)) o << ", next term t " << t;
    o << "]";
    return o.str();
  }
  // A power law A x^p, fitted as ln A + p ln x: the error of A is A times that of ln A.
  std::string power_text(const std::string& object) const {
    if (!valid(object)) return std::string();
    const auto [c, e] = coefficients(object, 2);
    std::ostringstream o;
    o << std::setprecision(3) << "A = " << std::exp(c[0]) << " +- " << std::exp(c[0]) * e[0]
      << ", p = " << c[1] << " +- " << e[1] << "  [chi2/dof " << attribute(object, "reduced_chi2")
      << "]";
    return o.str();
  }
  // A histogram's preferred shape, or "none".
  std::string verdict(const std::string& point, const char* which) const {
    const std::string h = point + "/abs_dy_histogram/" + which;
    return exists(h) ? string_attribute(file, h, "preferred") : std::string("none");
  }
};

// Protocol C's identity between the collapse's line and the deposition's (docs/OUTPUT.md).
void print_collapse_identity(const FitReader& f, const std::string& n, std::ostream& out) {
  const std::string id = n + "/collapse_identity";
  const auto c = [&](const char* a) { return f.attribute(id, a); };
  if (!f.exists(id) || !std::isfinite(c("b_prime"))) return;
  out << "  b' = " << c("b_prime") << " +- " << c("b_prime_error")
      << ", from b/(1+b): " << c("b_prime_predicted") << " +- " << c("b_prime_predicted_error")
      << "; a' = " << c("a_prime") << " +- " << c("a_prime_error")
      << ", from a/(1+b): " << c("a_prime_predicted") << " +- " << c("a_prime_predicted_error")
      << "; -dDelta y/dy_e = " << c("slope_increase") << " +- " << c("slope_increase_error")
      << " vs dnu/nu_i = " << f.attribute(n, "relative_increase_mean") << " +- "
      << f.attribute(n, "relative_increase_sem") << "\n";
  // The jackknife of the differences: files from 2026-11-25 on.
  if (H5Aexists_by_name(f.file, id.c_str(), "b_prime_difference", H5P_DEFAULT) > 0)
    out << "  b' - b/(1+b) = " << c("b_prime_difference") << " +- " << c("b_prime_difference_error")
        << ", a' - a/(1+b) = " << c("a_prime_difference") << " +- " << c("a_prime_difference_error")
        << " (jackknife of the differences)\n";
}

// The fits of scan point `n` (points/NNNN), under a header printed once (`header`).
void print_point_fits(const FitReader& f, const std::string& n, bool& header, std::ostream& out) {
  const std::string yi = f.fit_text(n + "/avalanche_by_yi/fit", "y_i");
  const std::string ye = f.fit_text(n + "/avalanche_by_ye/fit", "y_e");
  if (yi.empty() && ye.empty() && f.verdict(n, "shape") == "none" &&
      f.verdict(n, "shape_cut") == "none")
    return;
  if (!header) out << "# fits (docs/OUTPUT.md, analysis)\n";
  header = true;
  out << n.substr(7) << ":\n";
  if (!yi.empty()) out << "  Delta y(y_i) = " << yi << "\n";
  if (!ye.empty()) out << "  Delta y(y_e) = " << ye << "\n";
  const std::string slice = n + "/avalanche_by_ye/slice_parabola";
  if (f.valid(slice)) {
    const auto [c, e] = f.coefficients(slice, 1);
    out << "  slice model Delta y(y_e) = -a y_e (1 - y_e/H): a = " << c[0] << " +- " << e[0]
        << "\n";
  }
  print_collapse_identity(f, n, out);
  const std::string nud = f.power_text(n + "/nu_deposition/power_law");
  if (!nud.empty()) out << "  deposition density nu_d = A y_i^p: " << nud << "\n";
  const double rms = f.attribute(n + "/nu", "rms_deviation");
  if (std::isfinite(rms))
    out << "  nu predicted from the deposition density: rms deviation " << rms << "\n";
  for (const char* which : {"shape", "shape_cut"}) {
    const std::string h = n + "/abs_dy_histogram/" + which, pref = f.verdict(n, which);
    if (pref == "none") continue;
    std::ostringstream line;  // three digits, as the fits' lines above
    line << std::setprecision(3) << "  |Delta y| histogram"
         << (which == std::string("shape") ? "" : " (top and bottom cut)") << ": " << pref
         << " (chi2/dof gaussian " << f.attribute(h + "/gaussian", "reduced_chi2")
         << ", exponential " << f.attribute(h + "/exponential", "reduced_chi2");
    // With errors from the members' scatter: the quadratic term's t, which chose between the
    // shapes (files from 2026-12-02 on), the cubic's and the quartic's, the terms that judge them
    // (the quartic's in files from 2026-12-03 on).
    const double t2 = f.newer_attribute(h + "/exponential", "next_term_t");
    const double t3 = f.newer_attribute(h + "/gaussian", "next_term_t");
    const double t4 = f.newer_attribute(h + "/gaussian", "second_term_t");
    if (std::isfinite(t2)) line << "; t of the quadratic term " << t2;
    if (std::isfinite(t3)) line << ", of the cubic " << t3;
    if (std::isfinite(t4)) line << ", of the quartic " << t4;
    out << line.str() << ")\n";
  }
}

// The scan points a fit across points went through (`scan_points`, in files from 2026-11-26 on):
// a scan of a grid has several groups that differ only in one variable, and the fit takes one.
std::string fitted_points(const FitReader& f, const std::string& object) {
  if (!f.exists(object + "/scan_points")) return "";
  const std::vector<double> points = doubles(f.file, object + "/scan_points");
  if (points.empty()) return "";
  std::ostringstream o;
  o << "  [points";
  for (double k : points) o << " " << std::setw(4) << std::setfill('0') << static_cast<long>(k);
  o << "]";
  return o.str();
}

// The fits across scan points, where the scan has the points for them; a fit tried through
// points that did not settle says so.
void print_fits_across(const FitReader& f, std::ostream& out) {
  auto text = [&](const std::string& fit, const std::string& object) {
    const std::string points = fitted_points(f, object);
    if (fit.empty()) return points.empty() ? points : "no fit (did not settle)" + points;
    return fit + points;
  };
  const std::string log_h = text(f.fit_text("analysis/increase_vs_log_height", "ln H"),
                                 "analysis/increase_vs_log_height");
  const std::string nu_i =
      text(f.power_text("analysis/increase_vs_nu_initial"), "analysis/increase_vs_nu_initial");
  const std::string c_h =
      text(f.power_text("analysis/quadratic_vs_height"), "analysis/quadratic_vs_height");
  const std::string a_h =
      text(f.power_text("analysis/slice_vs_height"), "analysis/slice_vs_height");
  if (log_h.empty() && nu_i.empty() && c_h.empty() && a_h.empty()) return;
  out << "# fits across points\n";
  if (!log_h.empty()) out << "  dnu/nu_i = " << log_h << "\n";
  if (!nu_i.empty()) out << "  dnu/nu_i = A nu_i^p: " << nu_i << "\n";
  if (!c_h.empty()) out << "  c2 of Delta y(y_e) = A H^p: " << c_h << "\n";
  if (!a_h.empty()) out << "  slice model a = A H^p: " << a_h << "\n";
}

// Reads what the summary prints of point group n ("points/0001"): an error names the group.
template <class Read>
void in_point(const std::string& n, Read read) {
  try {
    read();
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(n + ": " + e.what());
  }
}
}  // namespace

// The fits of the analysis under the summary's table, where the file has them.
static void print_fits(hid_t file, const std::vector<std::string>& names, std::ostream& out) {
  const FitReader f{file};
  bool header = false;
  for (const auto& n : names) in_point(n, [&] { print_point_fits(f, n, header, out); });
  print_fits_across(f, out);
}

namespace {

// The groups under /points of a result file, as points/NNNN in order; a group of another name is
// the file's damage (std::runtime_error naming it).
std::vector<std::string> point_groups(hid_t file) {
  std::vector<std::pair<int, std::string>> numbered;  // by number: 9999 before 10000
  for (const std::string& child : children(file, "points"))
    numbered.emplace_back(group_number(child, "/points/" + child), "points/" + child);
  std::sort(numbered.begin(), numbered.end());
  std::vector<std::string> names;
  for (auto& [number, name] : numbered) names.push_back(std::move(name));
  return names;
}

// The summary's first line: the scan, its points, the run's time, and the members the file lacks.
void print_summary_head(hid_t file, const std::string& path, std::size_t points,
                        std::ostream& out) {
  out << "# " << path << ": scan '" << string_attribute(file, "/", "scan_name") << "', " << points
      << " points, " << double_attribute(file, "/", "wall_seconds")
      << (H5Aexists(file, "merged_from") > 0 ? " s of the runs merged"
                                             : " s of the run that wrote it");
  double unfinished = 0.0;
  if (H5Aexists(file, "members_unfinished") > 0) {
    unfinished = double_attribute(file, "/", "members_unfinished");
    if (unfinished > 0)
      out << "; " << unfinished << " members not in this file ("
          << (H5Aexists(file, "merged_from") > 0 ? "files not merged, or merged unfinished"
                                                 : "an unfinished run")
          << ")";
  }
  if (H5Aexists(file, "shards") > 0)
    out << "; shard " << count_attribute(file, "shard") << " of " << count_attribute(file, "shards")
        << " of the scan (loosepack merge joins the shards' files)";
  else if (unfinished == 0 && H5Lexists(file, "members_encoded", H5P_DEFAULT) > 0)
    out << "; some of the scan's members (loosepack merge joins the files of its members)";
  out << "\n";
}

// Whether points equal in their protocol and every other system parameter differ in the time
// step (a time step axis): its default follows the others (Bo, d_c, g), so a scan over Bo alone
// has none.
bool time_step_axis(hid_t file, const std::vector<std::string>& names) {
  std::map<std::pair<std::string, std::vector<double>>, std::set<double>> steps_of;
  for (const auto& n : names) {
    const auto has = [&](const char* a) {
      return H5Aexists_by_name(file, n.c_str(), a, H5P_DEFAULT) > 0;
    };
    if (!has("time_step")) continue;
    std::vector<double> others;
    for (const auto& [a, unused] : param_attributes(SystemParams{}))
      if (std::string(a) != "time_step" && has(a)) others.push_back(double_attribute(file, n, a));
    // (A point without its protocol is named by its row, which reads it.)
    auto& steps = steps_of[{has("protocol") ? string_attribute(file, n, "protocol") : "", others}];
    steps.insert(double_attribute(file, n, "time_step"));
    if (steps.size() > 1) return true;
  }
  return false;
}

// Scan parameters without a column of their own get one where the points differ in them, so that
// a scan over widths, radii or time steps does not read as repeated rows: (attribute, column
// title).
using ExtraColumns = std::vector<std::pair<const char*, const char*>>;
ExtraColumns extra_columns(hid_t file, const std::vector<std::string>& names) {
  // The point's system attributes (param_attributes) but those of the fixed columns, the
  // cohesive force (it follows Bo) and the time step (below), each with its column's title.
  const std::map<std::string, const char*> titles = {{"width", "L_x"},
                                                     {"radius", "R"},
                                                     {"polydispersity", "sd_R/R"},
                                                     {"cohesion_range", "d_c"},
                                                     {"floor_cohesion", "floor_coh"}};
  ExtraColumns extras;
  for (const auto& [attribute, unused] : param_attributes(SystemParams{})) {
    const auto title = titles.find(attribute);
    if (title == titles.end()) continue;
    std::set<double> values;
    for (const auto& n : names)
      if (H5Aexists_by_name(file, n.c_str(), attribute, H5P_DEFAULT) > 0)
        values.insert(double_attribute(file, n, attribute));
    if (values.size() > 1) extras.emplace_back(attribute, title->second);
  }
  if (time_step_axis(file, names)) extras.emplace_back("time_step", "h");
  return extras;
}

// Point n's row of the table, and into `notes` what is said under it: means over fewer than the
// finished members, collapses stopped while moving.
void print_point_row(hid_t file, const std::string& n, const ExtraColumns& extras,
                     std::ostream& out, std::ostream& notes) {
  auto d = [&](const char* a) { return double_attribute(file, n, a); };
  // A mean of one member has no error: "nan", never a zero that reads as an exact value.
  auto pm = [](double m, double s) {
    std::ostringstream o;
    o << std::fixed << std::setprecision(4) << m << " +- " << std::setprecision(4) << s;
    return o.str();
  };
  const int point = group_number(n.substr(7), "/" + n);
  const std::string prot = string_attribute(file, n, "protocol");
  std::string rel = "-";
  if (prot == "C") rel = pm(d("relative_increase_mean"), d("relative_increase_sem"));
  const H5 g = open_group(file, n);
  const int members = count_attribute(g, "members"), failed = count_attribute(g, "failed");
  // Each line whole or not at all: an attribute that cannot be read stops before it. A value
  // wider than its column keeps a space before the next.
  std::ostringstream line;
  line << std::left;
  const auto cell = [&line](int width, double value) {
    std::ostringstream v;
    v << std::setprecision(6) << value;
    line << std::setw(width) << v.str() + " ";
  };
  line << std::setw(12) << n.substr(7) << std::setw(6) << prot;
  cell(10, d("bond_number"));
  for (const char* a : {"capture_radius", "height", "friction", "rolling_friction"}) cell(8, d(a));
  for (const auto& [attribute, title] : extras) cell(10, d(attribute));
  line << std::setw(22) << pm(d("nu_lower_half_mean"), d("nu_lower_half_sem")) << std::setw(20)
       << pm(d("mean_abs_dy_mean"), d("mean_abs_dy_sem")) << std::setw(22) << rel << members << "("
       << failed << ")\n";
  out << line.str();
  if (H5Aexists(g, "nu_lower_half_n") > 0) {
    const std::string note =
        members_left_out_note(point, prot == "C" ? Protocol::C : Protocol::A,
                              count_attribute(g, "nu_lower_half_n"), members - failed);
    if (!note.empty()) notes << "# " << note << "\n";
  }
  if (prot == "C" && H5Lexists(g, "members", H5P_DEFAULT) > 0 &&
      H5Lexists(g, "members/capped", H5P_DEFAULT) > 0) {
    const std::string note = capped_collapses_note(point, doubles(file, n + "/members/failure"),
                                                   doubles(file, n + "/members/capped"));
    if (!note.empty()) notes << "# " << note << "\n";
  }
}

void write_summary(const std::string& path, std::ostream& out) {
  const H5 file = open_to_read(path, "open " + path + " (not an HDF5 file written by loosepack?)");
  const std::vector<std::string> names = point_groups(file);
  print_summary_head(file, path, names.size(), out);
  const ExtraColumns extras = extra_columns(file, names);
  out << std::left << std::setw(12) << "point" << std::setw(6) << "prot" << std::setw(10) << "Bo"
      << std::setw(8) << "r_capt" << std::setw(8) << "H" << std::setw(8) << "mu" << std::setw(8)
      << "mu_r";
  for (const auto& [attribute, title] : extras) out << std::setw(10) << title;
  out << std::setw(22) << "nu_lower_half" << std::setw(20) << "<|dy|> [R]" << std::setw(22)
      << "dnu/nu_i"
      << "members(failed)\n";
  std::ostringstream notes;  // said under the table
  for (const auto& n : names) in_point(n, [&] { print_point_row(file, n, extras, out, notes); });
  out << notes.str();
  print_fits(file, names, out);
}

}  // namespace

void print_summary(const std::string& path, std::ostream& out) {
  try {
    write_summary(path, out);
  } catch (const DamagedResultFile&) {
    throw;
  } catch (const std::runtime_error& e) {  // the file opened as a result file (main.cpp)
    throw DamagedResultFile(path, e.what());
  }
}

}  // namespace loosepack
