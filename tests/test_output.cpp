// The result file: what was computed round trips, rewrites are atomic; final contact forces
// and trajectories.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>

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
  const auto [floor, weight] = floor_force_and_weight(r);
  EXPECT_NEAR(floor, weight, 1e-3 * weight);
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
