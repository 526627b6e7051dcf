// Viewer files from a result file (include/loosepack/export.hpp; docs/OUTPUT.md, "Viewers").
#include "loosepack/export.hpp"

#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <utility>

#include "hdf5.hpp"
#include "loosepack/output.hpp"

namespace loosepack {

namespace {

namespace fs = std::filesystem;

// One member's data in the file: a snapshot (final or at a failure) or a trajectory.
struct MemberData {
  std::string point;  // "0001"
  int seed = 0;
  std::string kind;   // "snapshot", "failure" or "trajectory"
  std::string group;  // "/points/0001/members/snapshot_2"
  double width = 0.0, height = 0.0;
};

// A selection that names no point or seed of the file: std::invalid_argument with the file's.
void check_selection(hid_t file, const std::string& path, const ExportSelection& sel) {
  const std::vector<std::string> points = children(file, "points");
  if (sel.point >= 0 && std::none_of(points.begin(), points.end(), [&](const std::string& p) {
        return group_number(p, "/points/" + p) == sel.point;
      })) {
    std::string present;  // the points the file holds (a file of some members holds some)
    for (const auto& p : points) present += (present.empty() ? "" : ", ") + p;
    throw std::invalid_argument("--point " + std::to_string(sel.point) + ": " + path +
                                " has the points " + (present.empty() ? "(none)" : present));
  }
  const double seeds = double_attribute(file, "/", "seeds");
  if (sel.seed >= 0 && sel.seed >= seeds)
    throw std::invalid_argument("--seed " + std::to_string(sel.seed) + ": " + path +
                                " has the seeds 0 to " + std::to_string(std::lround(seeds) - 1));
}

std::size_t length(hid_t file, const std::string& name) {
  H5 set(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose, "open dataset " + name);
  H5 space(H5Dget_space(set), H5Sclose, "get dataspace of " + name);
  return static_cast<std::size_t>(H5Sget_simple_extent_npoints(space));
}

// The snapshots, failure snapshots and trajectories of the selection. A failed member's
// snapshot_K (in files written before 2026-12-02, the same state as its failure_K) is no deposit:
// its failure_K is exported. A trajectory without samples (a member without dynamics: protocol
// B, or A at Bo = inf) is nothing to view.
std::vector<MemberData> members_in(hid_t file, const ExportSelection& sel) {
  std::vector<MemberData> out;
  for (const auto& point : children(file, "points")) {
    if (sel.point >= 0 && group_number(point, "/points/" + point) != sel.point) continue;
    const std::string pg = "points/" + point;
    const std::vector<std::string> held = children(file, pg + "/members");
    const std::set<std::string> names(held.begin(), held.end());
    for (const auto& child : held) {
      for (const char* kind : {"snapshot", "failure", "trajectory"}) {
        const std::string prefix = std::string(kind) + "_";
        if (child.rfind(prefix, 0) != 0) continue;
        if (prefix == "snapshot_" && names.count("failure_" + child.substr(prefix.size())))
          continue;
        MemberData m{point,
                     group_number(child.substr(prefix.size()), "/" + pg + "/members/" + child),
                     kind,
                     "/" + pg + "/members/" + child,
                     double_attribute(file, pg, "width"),
                     double_attribute(file, pg, "height")};
        if (m.kind == "trajectory" && length(file, m.group + "/time") == 0) continue;
        if (sel.seed < 0 || m.seed == sel.seed) out.push_back(m);
      }
    }
  }
  return out;
}

// A selection with nothing to export: when the file holds snapshots or trajectories of other
// members (a file of some members, a seed that failed without a snapshot), std::invalid_argument
// naming them; else std::runtime_error saying how to record some.
[[noreturn]] void refuse_empty_selection(const std::vector<MemberData>& every,
                                         const std::string& path,
                                         const ExportSelection& selection) {
  std::set<std::pair<std::string, int>> held;
  bool final_snapshots = false;  // not only failures' snapshots
  for (const auto& m : every) {
    held.insert({m.point, m.seed});
    final_snapshots = final_snapshots || m.kind == "snapshot";
  }
  const std::string how = "run with --snapshots or observables.trajectory_every";
  if (held.empty())
    throw std::runtime_error(path +
                             " holds no snapshot, failure snapshot or trajectory with samples "
                             "(protocol B and A at Bo = inf have no dynamics to trace): " +
                             how);
  constexpr std::size_t kNamed = 8;
  std::string named;
  std::size_t n = 0;
  for (auto it = held.begin(); it != held.end() && n < kNamed; ++it, ++n)
    named += (n > 0 ? ", point " : "point ") + it->first + " seed " + std::to_string(it->second);
  if (held.size() > kNamed) named += " and " + std::to_string(held.size() - kNamed) + " more";
  std::string asked = selection.point >= 0 ? "--point " + std::to_string(selection.point) : "";
  if (selection.seed >= 0)
    asked += (asked.empty() ? "--seed " : " --seed ") + std::to_string(selection.seed);
  throw std::invalid_argument(asked + ": " + path + " holds no snapshot or trajectory of it, " +
                              "only those of " + named +
                              (final_snapshots ? "" : " (" + how + " for every member's)"));
}

std::string number(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

// Refuses a member whose datasets no run writes: lengths that differ within a set (the disks',
// the contacts', a trajectory's samples), contact indices that name no disk.
void check_member(hid_t file, const MemberData& m) {
  const std::string& g = m.group;
  auto same_lengths = [&](const std::vector<std::string>& names) {
    const std::size_t n = length(file, g + "/" + names.front());
    for (const auto& name : names)
      if (const std::size_t k = length(file, g + "/" + name); k != n)
        throw std::runtime_error(g + "/" + name + " has " + std::to_string(k) + " values, " +
                                 names.front() + " " + std::to_string(n));
    return n;
  };
  if (m.kind == "trajectory") {
    same_lengths({"time", "x", "y", "disk"});
    return;
  }
  std::vector<std::string> disks = {"x", "y_i", "y_e", "radius"};
  if (m.kind == "failure") disks.insert(disks.end(), {"vx", "vy", "w"});
  const std::size_t n = same_lengths(disks);
  same_lengths(
      {"contact_i", "contact_j", "contact_normal", "contact_tangential", "contact_moment"});
  for (const auto& [name, lowest] : {std::pair("contact_i", 0.0), std::pair("contact_j", -1.0)})
    for (double v : doubles(file, g + "/" + name))
      if (!(v >= lowest && v < static_cast<double>(n) && v == std::floor(v)))
        throw std::runtime_error(g + "/" + name + " holds " + number(v) + ", not a disk of the " +
                                 std::to_string(n) + " (" +
                                 (lowest < 0 ? "-1: the floor, or " : "") + "0 to n - 1)");
}

std::string stem_name(const MemberData& m) {
  std::string name = "_p" + m.point + "_s" + std::to_string(m.seed);
  if (m.kind != "snapshot") name += "_" + m.kind;
  return name;
}

// --- XDMF ---------------------------------------------------------------------------------

// `text` as XML character data: a file's name may hold &, < or >.
std::string xml_text(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '&')
      out += "&amp;";
    else if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else
      out += c;
  }
  return out;
}

// A DataItem reading dataset `name` of `file` ([n] values, or a hyperslab of it).
std::string item(const std::string& file, const std::string& name, std::size_t n,
                 bool integer = false) {
  std::ostringstream o;
  o << "<DataItem Dimensions=\"" << n << "\" NumberType=\"" << (integer ? "Int" : "Float")
    << "\" Precision=\"8\" Format=\"HDF\">" << xml_text(file) << ":" << name << "</DataItem>";
  return o.str();
}
std::string slab(const std::string& file, const std::string& name, std::size_t total,
                 std::size_t start, std::size_t count, bool integer = false) {
  std::ostringstream o;
  o << "<DataItem ItemType=\"HyperSlab\" Dimensions=\"" << count << "\">"
    << "<DataItem Dimensions=\"3 1\" Format=\"XML\">" << start << " 1 " << count << "</DataItem>"
    << item(file, name, total, integer) << "</DataItem>";
  return o.str();
}
std::string function(const std::string& expr, std::size_t n, const std::string& inner) {
  return "<DataItem ItemType=\"Function\" Function=\"" + expr + "\" Dimensions=\"" +
         std::to_string(n) + "\">" + inner + "</DataItem>";
}
std::string attribute(const std::string& name, const std::string& centre,
                      const std::string& data) {
  return "<Attribute Name=\"" + name + "\" AttributeType=\"Scalar\" Center=\"" + centre + "\">" +
         data + "</Attribute>\n";
}

// The contacts as line segments [2 x contacts][x, y]: from disk i's centre to disk j's image
// nearest to it across the periodic seam, or to the floor below disk i (j = -1). The result
// file holds the disks and the contacts' indices, not these lines: they go to the sidecar.
std::vector<double> contact_lines(hid_t file, const std::string& g, double width) {
  const std::vector<double> ci = doubles(file, g + "/contact_i"),
                            cj = doubles(file, g + "/contact_j"), x = doubles(file, g + "/x"),
                            y = doubles(file, g + "/y_e");
  std::vector<double> out;
  for (std::size_t k = 0; k < ci.size(); ++k) {
    const auto i = static_cast<std::size_t>(ci[k]);
    out.insert(out.end(), {x[i], y[i]});
    if (cj[k] < 0) {
      out.insert(out.end(), {x[i], 0.0});
      continue;
    }
    const auto j = static_cast<std::size_t>(cj[k]);
    double dx = x[j] - x[i];
    dx -= width * std::round(dx / width);
    out.insert(out.end(), {x[i] + dx, y[j]});
  }
  return out;
}

// A dataset of the sidecar file, [rows x columns], its groups created on the way.
template <class T>
void sidecar_dataset(hid_t sidecar, const std::string& name, const std::vector<T>& v,
                     hsize_t columns, hid_t file_type, hid_t memory_type) {
  const hsize_t dims[2] = {v.size() / columns, columns};
  H5 lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose, "create link property list");
  check(H5Pset_create_intermediate_group(lcpl, 1), "set intermediate groups");
  H5 space(H5Screate_simple(2, dims, nullptr), H5Sclose, "create dataspace");
  H5 set(H5Dcreate2(sidecar, name.c_str(), file_type, space, lcpl, H5P_DEFAULT, H5P_DEFAULT),
         H5Dclose, "create dataset " + name);
  if (!v.empty())
    check(H5Dwrite(set, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()),
          "write dataset " + name);
}

// What a snapshot's sidecar file holds: its contacts as lines and their end points' indices.
struct Sidecar {
  std::string group;
  std::vector<double> lines;
  std::vector<long long> ends;
};
Sidecar sidecar_of(hid_t file, const MemberData& m) {
  Sidecar out{m.group, contact_lines(file, m.group, m.width), {}};
  out.ends.resize(out.lines.size() / 2);
  for (std::size_t k = 0; k < out.ends.size(); ++k) out.ends[k] = static_cast<long long>(k);
  return out;
}
void write_sidecar(hid_t sidecar, const Sidecar& c) {
  sidecar_dataset(sidecar, c.group + "/lines", c.lines, 2, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE);
  sidecar_dataset(sidecar, c.group + "/connectivity", c.ends, 2, H5T_STD_I64LE, H5T_NATIVE_LLONG);
}

// A snapshot's nc contacts as lines (their ends in the sidecar file `side`) with their forces.
std::string xdmf_contacts(const std::string& h5, const std::string& g, std::size_t nc,
                          const std::string& side) {
  std::ostringstream o;
  o << "<Grid Name=\"contacts\" GridType=\"Uniform\">\n"
    << "<Topology TopologyType=\"Polyline\" NumberOfElements=\"" << nc
    << "\" NodesPerElement=\"2\"><DataItem Dimensions=\"" << nc
    << " 2\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">" << xml_text(side) << ":" << g
    << "/connectivity</DataItem></Topology>\n"
    << "<Geometry GeometryType=\"XY\"><DataItem Dimensions=\"" << 2 * nc
    << " 2\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << xml_text(side) << ":" << g
    << "/lines</DataItem></Geometry>\n";
  for (const char* a : {"normal", "tangential", "moment"})
    o << attribute(a, "Cell", item(h5, g + "/contact_" + std::string(a), nc));
  o << "</Grid>\n";
  return o.str();
}

// A snapshot: the disks as points (radius, y_i, y_e, Delta y, velocities at a failure) and
// the contacts as lines with their forces (those in the sidecar file `side`).
std::string xdmf_snapshot(hid_t file, const MemberData& m, const std::string& h5,
                          const std::string& side) {
  const std::string& g = m.group;
  const std::size_t n = length(file, g + "/x"), nc = length(file, g + "/contact_i");
  const std::string x = item(h5, g + "/x", n), ye = item(h5, g + "/y_e", n);
  std::ostringstream o;
  o << "<Grid Name=\"disks\" GridType=\"Uniform\">\n"
    << "<Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << n
    << "\" NodesPerElement=\"1\"/>\n"
    << "<Geometry GeometryType=\"X_Y\">" << x << ye << "</Geometry>\n";
  for (const char* a : {"radius", "y_i", "y_e"}) o << attribute(a, "Node", item(h5, g + "/" + a, n));
  o << attribute("delta_y", "Node", function("$0 - $1", n, ye + item(h5, g + "/y_i", n)));
  if (m.kind == "failure")
    for (const char* a : {"vx", "vy", "w"}) o << attribute(a, "Node", item(h5, g + "/" + a, n));
  o << "</Grid>\n";
  // A deposit without contacts (protocol B, Bo = inf) has no contacts grid: one of no lines
  // reading an empty dataset is an error to ParaView's XDMF reader.
  if (nc > 0) o << xdmf_contacts(h5, g, nc, side);
  return "<Grid Name=\"point " + m.point + " seed " + std::to_string(m.seed) +
         "\" GridType=\"Collection\" CollectionType=\"Spatial\">\n" + o.str() + "</Grid>\n";
}

// A time as written, to the last digit stored: a trajectory's time counts disks deposited or
// steps, which pass a million in a long collapse (6 digits would write 1.23457e+06).
constexpr int kTimeDigits = std::numeric_limits<double>::max_digits10;

// The samples of a trajectory: [first, end) of each time.
std::vector<std::pair<std::size_t, std::size_t>> samples(const std::vector<double>& time) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (std::size_t k = 0; k < time.size(); ++k)
    if (k == 0 || time[k] != time[k - 1]) out.emplace_back(k, k + 1);
    else out.back().second = k + 1;
  return out;
}

// A trajectory: one grid per sample, in a temporal collection.
std::string xdmf_trajectory(hid_t file, const MemberData& m, const std::string& h5) {
  const std::string& g = m.group;
  const std::vector<double> time = doubles(file, g + "/time");
  const std::size_t total = time.size();
  std::ostringstream o;
  o << std::setprecision(kTimeDigits);
  o << "<Grid Name=\"point " << m.point << " seed " << m.seed
    << " trajectory\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const auto& [first, end] : samples(time)) {
    const std::size_t n = end - first;
    const std::string x = slab(h5, g + "/x", total, first, n);
    o << "<Grid Name=\"sample\" GridType=\"Uniform\"><Time Value=\"" << time[first] << "\"/>\n"
      << "<Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << n
      << "\" NodesPerElement=\"1\"/>\n<Geometry GeometryType=\"X_Y\">" << x
      << slab(h5, g + "/y", total, first, n) << "</Geometry>\n"
      << attribute("disk", "Node", slab(h5, g + "/disk", total, first, n, true)) << "</Grid>\n";
  }
  return o.str() + "</Grid>\n";
}

std::string xdmf_document(const std::string& grids) {
  return "<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
         "<Xdmf Version=\"2.0\">\n<Domain>\n" +
         grids + "</Domain>\n</Xdmf>\n";
}

// --- extended XYZ -------------------------------------------------------------------------

// One frame: the box (periodic in x), the time and the properties of each disk; the species
// is X, the dummy element (ASE reads only element names; OVITO any).
void extxyz_frame(std::ostream& o, const MemberData& m, double time,
                  const std::vector<std::vector<double>>& columns, const std::string& properties) {
  const std::size_t n = columns.front().size();
  o << std::setprecision(kTimeDigits);
  o << n << "\nLattice=\"" << m.width << " 0 0 0 " << m.height << " 0 0 0 1\" pbc=\"T F F\" "
    << "Time=" << time << " Properties=species:S:1:pos:R:3" << properties << "\n";
  o << std::setprecision(10);
  for (std::size_t k = 0; k < n; ++k) {
    o << "X " << columns[0][k] << " " << columns[1][k] << " 0";
    for (std::size_t c = 2; c < columns.size(); ++c) o << " " << columns[c][k];
    o << "\n";
  }
}

std::string extxyz_member(hid_t file, const MemberData& m) {
  const std::string& g = m.group;
  std::ostringstream o;
  if (m.kind == "trajectory") {
    const std::vector<double> time = doubles(file, g + "/time"), x = doubles(file, g + "/x"),
                              y = doubles(file, g + "/y"), disk = doubles(file, g + "/disk");
    for (const auto& sample : samples(time)) {
      const std::size_t first = sample.first, end = sample.second;  // nvcc: no captured bindings
      auto part = [&](const std::vector<double>& v) {
        return std::vector<double>(v.begin() + static_cast<std::ptrdiff_t>(first),
                                   v.begin() + static_cast<std::ptrdiff_t>(end));
      };
      extxyz_frame(o, m, time[first], {part(x), part(y), part(disk)}, ":disk:I:1");
    }
    return o.str();
  }
  const std::vector<double> x = doubles(file, g + "/x"), ye = doubles(file, g + "/y_e"),
                            yi = doubles(file, g + "/y_i"), r = doubles(file, g + "/radius");
  std::vector<double> dy(x.size());
  for (std::size_t k = 0; k < x.size(); ++k) dy[k] = ye[k] - yi[k];
  extxyz_frame(o, m, 0.0, {x, ye, r, yi, dy}, ":radius:R:1:y_i:R:1:delta_y:R:1");
  return o.str();
}

// What one member's export writes: the viewer file's text and, for a snapshot in XDMF, its
// sidecar file.
struct ViewerFile {
  std::string path, text;
  std::string sidecar_path;  // empty: none
  Sidecar sidecar;
};

// The paths one member's export writes: its viewer file, and for a snapshot in XDMF the sidecar
// of its contacts (else empty).
std::pair<std::string, std::string> viewer_paths(const MemberData& m, ExportFormat format,
                                                 const std::string& base) {
  const std::string stem = base + stem_name(m);
  if (format == ExportFormat::Extxyz) return {stem + ".extxyz", ""};
  return {stem + ".xmf", m.kind == "trajectory" ? "" : stem + "_contacts.h5"};
}

// What one member's export writes, read from the file (check_member has passed).
ViewerFile viewer_file(hid_t file, const MemberData& m, ExportFormat format,
                       const std::string& base, const std::string& h5) {
  ViewerFile v;
  std::tie(v.path, v.sidecar_path) = viewer_paths(m, format, base);
  if (format == ExportFormat::Extxyz) {
    v.text = extxyz_member(file, m);
  } else if (m.kind == "trajectory") {
    v.text = xdmf_document(xdmf_trajectory(file, m, h5));
  } else {
    // A snapshot's contact lines go to a file of its own, so that exporting another selection
    // later leaves this one's files whole.
    v.sidecar = sidecar_of(file, m);
    v.text =
        xdmf_document(xdmf_snapshot(file, m, h5, fs::path(v.sidecar_path).filename().string()));
  }
  return v;
}

}  // namespace

std::vector<std::string> export_viewer_files(const std::string& path, ExportFormat format,
                                             const ExportSelection& selection) {
  const H5 file = open_to_read(path, "open " + path);
  // Reading the file, an error that is not a selection's (std::invalid_argument) is its damage.
  auto damaged = [&](const std::runtime_error& e) { return DamagedResultFile(path, e.what()); };
  std::vector<MemberData> members, every;
  try {
    check_selection(file, path, selection);
    members = members_in(file, selection);
    if (members.empty()) every = members_in(file, ExportSelection{});
    for (const auto& m : members) check_member(file, m);  // damaged data writes nothing
  } catch (const std::invalid_argument&) {
    throw;
  } catch (const std::runtime_error& e) {
    throw damaged(e);
  }
  if (members.empty()) refuse_empty_selection(every, path, selection);
  const fs::path p(path);
  // XDMF names the HDF5 file it reads as FILE:/dataset, which ParaView splits at the first ':'.
  if (format == ExportFormat::Xdmf && p.filename().string().find(':') != std::string::npos)
    throw std::invalid_argument(
        path + ": its name holds ':', which the XDMF files' references (FILE:/dataset) cannot " +
        "carry (ParaView reads the name up to the ':'): copy or link it to a name without one, " +
        "or export --format extxyz");
  const std::string base = (p.parent_path() / p.stem()).string();  // the files lie next to it
  // An earlier export's files are replaced; a result file or a directory where one would go,
  // before anything is written, is refused.
  for (const auto& m : members) {
    const auto [viewer, sidecar] = viewer_paths(m, format, base);
    for (const std::string& at : {viewer, sidecar}) {
      if (at.empty() || !fs::exists(at)) continue;
      if (!fs::is_regular_file(at))
        throw std::invalid_argument(at + " is not a file (a directory?), where export writes a " +
                                    "viewer file of " + path + ": move it away");
      if (result_file_problem(at).empty())
        throw std::invalid_argument(at + " is a loosepack result file, where export writes a " +
                                    "viewer file of " + path + ": move it away");
    }
  }
  auto build = [&](const MemberData& m) {
    try {
      return viewer_file(file, m, format, base, p.filename().string());
    } catch (const std::runtime_error& e) {
      throw damaged(e);
    }
  };
  // Every member's files built once before the first is written, so that data found damaged at
  // any member writes none; then built again and written, one member's text in memory at a time
  // (a file's trajectories and snapshots may be many times the memory of one).
  for (const auto& m : members) build(m);
  std::vector<std::string> written;
  for (const auto& m : members) {
    const ViewerFile v = build(m);
    // Each file whole or not at all (replace_file).
    if (!v.sidecar_path.empty())
      replace_hdf5_file(v.sidecar_path, [&](hid_t sidecar) { write_sidecar(sidecar, v.sidecar); });
    replace_file(v.path, [&](const std::string& tmp) { write_bytes(tmp, v.text); });
    written.push_back(v.path);
    if (!v.sidecar_path.empty()) written.push_back(v.sidecar_path);
  }
  return written;
}

}  // namespace loosepack
