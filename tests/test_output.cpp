// The result file: what was computed round trips, rewrites are atomic; final contact forces
// and trajectories.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <sstream>
#include <vector>

#include "loosepack/observables.hpp"
#include "loosepack/output.hpp"
#include "loosepack/protocols.hpp"
#include "tests/run_helpers.hpp"

using namespace loosepack;
using namespace loosepack::run_helpers;

// The output file holds what was computed; a rewrite replaces it whole, and a failed write
// raises and leaves no temporary file behind. (That a refused run leaves an earlier file
// untouched is checked on the command line, tests/cli_test.sh.)
TEST(Output, RoundTripAndAtomicReplace) {
  const auto scan = scan_of(R"(
[scan]
name = "roundtrip"
protocol = "B"
seeds = 2
[system]
width = 30.0
height = 30.0
capture_radius = [1.0, 2.0]
[observables]
lower_half_from = 3.0
)");
  const auto members = run_all(scan);
  const auto points = aggregate(scan, members);
  const TempDir dir;
  const std::string path = dir / "out.h5";
  RunInfo info;
  info.start_time = "t0";
  info.end_time = "t1";
  write_results(path, scan, info, points, analyse(scan, points), members, true);
  EXPECT_EQ(read_attribute_string(path, "/", "scan_name"), "roundtrip");
  EXPECT_EQ(read_scan_text(path), scan.text);
  EXPECT_EQ(read_attribute_string(path, "points/0001", "protocol"), "B");
  EXPECT_EQ(read_attribute_double(path, "points/0001", "capture_radius"), 2.0);
  EXPECT_EQ(read_dataset(path, "points/0000/nu/mean"), points[0].nu.mean);
  EXPECT_EQ(read_attribute_double(path, "points/0000", "nu_lower_half_mean"),
            points[0].nu_lower_half.mean);
  EXPECT_EQ(read_dataset(path, "points/0001/members/snapshot_1/y_e"), members[3].y_e);
  // Rewriting replaces the whole file: the snapshots written before are gone.
  auto renamed = scan;
  renamed.name = "second";
  write_results(path, renamed, info, points, analyse(renamed, points), members, false);
  EXPECT_EQ(read_attribute_string(path, "/", "scan_name"), "second");
  EXPECT_THROW(read_dataset(path, "points/0001/members/snapshot_1/y_e"), std::runtime_error);
  // A write that cannot happen raises; nothing but the result file is in the directory.
  EXPECT_THROW(write_results(dir / "missing/out.h5", scan, info, points, analyse(scan, points),
                             members, false),
               std::runtime_error);
  int files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir.path)) {
    EXPECT_EQ(e.path().filename(), "out.h5");
    ++files;
  }
  EXPECT_EQ(files, 1);
}

namespace {
// dir/good.h5: the result file of a small protocol-A scan (12 R x 12 R, Bo = 10, two seeds).
std::string small_result_file(const TempDir& dir) {
  const auto scan = scan_of(R"(
[scan]
protocol = "A"
seeds = 2
[system]
width = 12.0
height = 12.0
bond_number = 10.0
[observables]
lower_half_from = 2.0
)");
  const auto members = run_all(scan);
  const auto points = aggregate(scan, members);
  const std::string good = dir / "good.h5";
  write_results(good, scan, RunInfo{}, points, analyse(scan, points), members, false);
  return good;
}
}  // namespace

// A result file's metadata carries checksums (HDF5's 1.8 format, superblock version 2): a byte
// damaged in a point's object header is refused, naming the file, where HDF5 1.10 read the 1.6
// format's damaged headers unchecked and could crash. Its groups copy with H5Ocopy (h5copy,
// h5repack, h5py's copy), which crashed on a group of many string attributes in the 1.8
// format's dense storage before HDF5 1.14.4.
TEST(Output, DamagedMetadataIsRefusedAndGroupsCopy) {
  const TempDir dir;
  const std::string good = small_result_file(dir);
  std::string bytes;
  {
    std::ifstream in(good, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  ASSERT_GT(bytes.size(), 48u);
  EXPECT_EQ(bytes[8], 2) << "superblock version";
  haddr_t header = 0;
  {
    const hid_t file = H5Fopen(good.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    ASSERT_GE(file, 0);
    H5O_info_t info;
    ASSERT_GE(H5Oget_info_by_name2(file, "points/0000", &info, H5O_INFO_BASIC, H5P_DEFAULT), 0);
    header = info.addr;
    const hid_t copy =
        H5Fcreate((dir / "copy.h5").c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(copy, 0);
    for (const auto& [object, as] :
         {std::pair("points/0000", "point"), std::pair("settings", "settings"),
          std::pair("analysis", "analysis")})
      EXPECT_GE(H5Ocopy(file, object, copy, as, H5P_DEFAULT, H5P_DEFAULT), 0) << object;
    H5Fclose(copy);
    H5Fclose(file);
  }
  ASSERT_LT(header + 8, bytes.size());
  bytes[header + 8] = static_cast<char>(bytes[header + 8] ^ 0x5a);
  const std::string bad = dir / "bad.h5";
  std::ofstream(bad, std::ios::binary) << bytes;
  for (const auto& read :
       std::vector<std::function<void()>>{[&] { reanalyse(bad, dir / "out.h5"); },
                                          [&] {
                                            std::ostringstream text;
                                            print_summary(bad, text);
                                          }}) {
    try {
      read();
      ADD_FAILURE() << "a file with a damaged object header was read";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    }
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "out.h5"));
}

// Final contact forces and trajectories: the floor carries the whole weight of a deposit at
// rest (Bo = 0, so no cohesive pre-stress), and a trajectory ends where its disk ends.
TEST(Snapshots, ContactForcesCarryTheWeightAndTrajectoriesEndAtFinalPositions) {
  const auto scan = scan_of(R"(
[scan]
protocol = "A"
seeds = 1
[system]
width = 10.0
height = 10.0
bond_number = 0
[solver]
tolerance = 1e-5
max_sweeps = 20000
[observables]
trajectory_every = 3
lower_half_from = 1.0
)");
  const auto r = run_all(scan).at(0);
  ASSERT_TRUE(r.ok());
  expect_floor_carries_the_weight(r, scan);
  expect_trajectories_end_at_final_positions(r, 3);
}

// A scan file over HDF5's 64 KiB attribute limit (here 100 KB of comments) is stored whole, and
// `analyse` reads it back from the file.
TEST(Output, ScanTextOfAnySizeRoundTrips) {
  std::string text =
      "[scan]\nprotocol = \"B\"\n[system]\nwidth = 12.0\nheight = 12.0\n"
      "[observables]\nlower_half_from = 2.0\n";
  while (text.size() < 100000) text += "# a long comment line to make the scan file large\n";
  const auto scan = scan_of(text);
  const auto members = run_all(scan);
  const auto points = aggregate(scan, members);
  const TempDir dir;
  const std::string path = dir / "big.h5";
  write_results(path, scan, RunInfo{}, points, analyse(scan, points), members, false);
  EXPECT_EQ(read_scan_text(path), text);
  EXPECT_NO_THROW(reanalyse(path, dir / "again.h5"));
  EXPECT_EQ(read_scan_text(dir / "again.h5"), text);
}

namespace {
// Replaces dataset `name` of result file `path` by one of `values` (a damaged or edited file).
void replace_dataset(const std::string& path, const std::string& name,
                     const std::vector<double>& values) {
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  ASSERT_GE(H5Ldelete(file, name.c_str(), H5P_DEFAULT), 0);
  const hsize_t n = values.size();
  const hid_t space = H5Screate_simple(1, &n, nullptr);
  const hid_t set =
      H5Dcreate2(file, name.c_str(), H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  if (n > 0) H5Dwrite(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data());
  H5Dclose(set);
  H5Sclose(space);
  H5Fclose(file);
}
}  // namespace

// `analyse` refuses a file whose datasets disagree in length (an empty nu/mean, a short sem or
// count, a histogram whose edges do not bound its counts), naming the dataset, and writes
// nothing back: the file stays as it was.
TEST(Output, AnalyseRefusesInconsistentFiles) {
  const TempDir dir;
  const std::string good = small_result_file(dir);
  const std::vector<std::pair<std::string, std::size_t>> damages = {
      {"points/0000/nu/mean", 0},
      {"points/0000/nu_deposition/sem", 1},
      {"points/0000/avalanche_by_yi/count", 1},
      {"points/0000/abs_dy_histogram/counts", 1}};
  for (const auto& [name, keep] : damages) {
    SCOPED_TRACE(name);
    const std::string bad = dir / "bad.h5";
    std::filesystem::copy_file(good, bad, std::filesystem::copy_options::overwrite_existing);
    std::vector<double> values = read_dataset(bad, name);
    ASSERT_GT(values.size(), keep);
    values.resize(keep);
    replace_dataset(bad, name, values);
    const auto before = std::filesystem::last_write_time(bad);
    try {
      reanalyse(bad, bad);
      ADD_FAILURE() << "an inconsistent file was analysed";
    } catch (const std::runtime_error& e) {
      const std::string dataset = name.substr(name.find_last_of('/') + 1);
      EXPECT_NE(std::string(e.what()).find(dataset), std::string::npos) << e.what();
    }
    EXPECT_EQ(std::filesystem::last_write_time(bad), before);
    EXPECT_EQ(read_dataset(bad, name), values);
  }
  // A fit marked valid without its coefficients (found by fuzz/fuzz_results.cpp): summary
  // refuses the file naming the dataset, and prints nothing of it.
  const std::string bad = dir / "bad.h5";
  std::filesystem::copy_file(good, bad, std::filesystem::copy_options::overwrite_existing);
  for (const char* d : {"points/0000/avalanche_by_ye/fit/coef", "points/0000/avalanche_by_ye/fit/error"})
    replace_dataset(bad, d, {});
  {
    const hid_t file = H5Fopen(bad.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(file, 0);
    const char* fit = "points/0000/avalanche_by_ye/fit";
    ASSERT_GE(H5Adelete_by_name(file, fit, "valid", H5P_DEFAULT), 0);
    const hid_t space = H5Screate(H5S_SCALAR);
    const hid_t valid = H5Acreate_by_name(file, fit, "valid", H5T_IEEE_F64LE, space, H5P_DEFAULT,
                                          H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(valid, 0);
    const double one = 1.0;
    ASSERT_GE(H5Awrite(valid, H5T_NATIVE_DOUBLE, &one), 0);
    H5Aclose(valid);
    H5Sclose(space);
    H5Fclose(file);
  }
  std::ostringstream text;
  try {
    print_summary(bad, text);
    ADD_FAILURE() << "a fit without coefficients was printed: " << text.str();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("avalanche_by_ye/fit/coef"), std::string::npos)
        << e.what();
  }
}
