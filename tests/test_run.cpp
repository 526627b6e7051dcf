// Running scans: results independent of the batch size, the progress behind the ETA, a member
// that fails alone.
#include <gtest/gtest.h>

#include <Kokkos_Core.hpp>
#include <algorithm>
#include <cmath>
#include <csignal>
#include <fstream>

#include "loosepack/observables.hpp"
#include "loosepack/output.hpp"
#include "loosepack/protocols.hpp"
#include "tests/run_helpers.hpp"

using namespace loosepack;
using namespace loosepack::run_helpers;

// The same scan gives identical results whatever the batch size.
TEST(Reproducibility, BatchSizeDoesNotChangeResults) {
  const std::string text = R"(
[scan]
protocol = ["A", "B", "C"]
seeds = 3
[system]
width = 12.0
height = 12.0
bond_number = 50
[observables]
lower_half_from = 2.0
)";
  const auto runs = run_alone_and_batched(text, 6);
  const auto &one = runs.one, &many = runs.many;
  const auto &a = runs.alone, &b = runs.batched;
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].y_e, b[k].y_e) << "member " << k;
    EXPECT_EQ(a[k].x, b[k].x) << "member " << k;
    EXPECT_EQ(a[k].steps, b[k].steps);
  }
  // And in the files: every dataset but the wall times is identical.
  const TempDir dir;
  const std::string fa = dir / "a.h5", fb = dir / "b.h5";
  const auto pa = aggregate(one, a), pb = aggregate(many, b);
  write_results(fa, one, RunInfo{}, pa, analyse(one, pa), a, true);
  write_results(fb, many, RunInfo{}, pb, analyse(many, pb), b, true);
  for (const char* point : {"points/0000", "points/0001", "points/0002"})
    for (const char* set :
         {"nu/mean", "nu/sem", "nu_deposition/mean", "avalanche_by_yi/mean", "avalanche_by_ye/sem",
          "abs_dy_histogram/counts", "members/steps", "members/sweeps", "members/disks",
          "members/snapshot_2/y_e", "members/snapshot_0/contact_normal"}) {
      const std::string name = std::string(point) + "/" + set;
      EXPECT_EQ(read_dataset(fa, name), read_dataset(fb, name)) << name;
    }
}

// A member's relaxation regions do not depend on the scan's other points: the reach of a region's
// moving disks comes from the member's own height, not the tallest of the scan. Member 0 (H =
// 40 R) alone in its scan and in one with a point at H = 90 R gives the same results; the time
// step 0.045 makes the fall speed set the detection margin (above its floor of R/2) at both
// heights.
TEST(Reproducibility, RegionsDoNotDependOnTheScansOtherPoints) {
  auto scan_of = [](const std::string& heights) {
    return parse_scan(R"(
[scan]
protocol = "A"
seed = 4
[system]
width = 12.0
height = )" + heights + R"(
bond_number = 0
time_step = 0.045
[protocol]
region_radius = 5.0
[observables]
lower_half_from = 2.0
)",
                      "regions.toml");
  };
  const Scan low = scan_of("40.0"), mixed = scan_of("[40.0, 90.0]");
  const auto a = run_members(low, {members_of(low).at(0)});
  const auto b = run_members(mixed, {members_of(mixed).at(0)});
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_EQ(a[0].steps, b[0].steps);
  EXPECT_EQ(a[0].y_e, b[0].y_e);
  EXPECT_EQ(a[0].x, b[0].x);
}

namespace {
// Protocol A with relaxation regions (a second batch) and with the whole system, and C's
// collapse, on 3 slots for 4 members (a finished member's slot takes the next while the others
// are inside their steps); the team solver's whole solves in the staged step.
const char* const kSlotsScan = R"(
[scan]
protocol = ["A", "C"]
seeds = 2
batch_size = 3
[system]
width = 12.0
height = 12.0
bond_number = 50
[solver]
kind = "coloured_accelerated_gauss_seidel"
sweeps_per_launch = 0
fused_step = false
[protocol]
region_radius = 6.0
[observables]
lower_half_from = 2.0
)";

void expect_same_members(const std::vector<MemberResult>& a, const std::vector<MemberResult>& b,
                         const std::string& label) {
  ASSERT_EQ(a.size(), b.size()) << label;
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].y_e, b[k].y_e) << label << " member " << k;
    EXPECT_EQ(a[k].x, b[k].x) << label << " member " << k;
    EXPECT_EQ(a[k].steps, b[k].steps) << label << " member " << k;
    EXPECT_EQ(a[k].sweeps, b[k].sweeps) << label << " member " << k;
    EXPECT_EQ(a[k].events.size(), b[k].events.size()) << label << " member " << k;
  }
}

// The batches (the members' and the regions') whose stage `stage` ran, with steps that went on
// over launches.
int batches_over_launches(const std::vector<StageCost>& costs, const std::string& stage) {
  int n = 0;
  for (const auto& cost : costs)
    if (cost.name == stage || cost.name == "region " + stage)
      n += cost.steps > 0 && cost.finished_steps < cost.system_steps ? 1 : 0;
  return n;
}
}  // namespace

// A step's solve split over launches (solver.sweeps_per_launch) gives every member the same
// steps as whole solves: the slowest system no longer holds the others in a launch, and the
// scheduler acts on a member only once its step has ended (kSlotsScan).
TEST(Reproducibility, SweepsPerLaunchDoNotChangeResults) {
  const Scan whole = scan_of(kSlotsScan);
  Scan split = whole;
  split.solver.sweeps_per_launch = 4;
  std::vector<StageCost> costs;
  RunHooks hooks;
  hooks.stage_costs = &costs;
  expect_same_members(run_members(whole, members_of(whole)),
                      run_members(split, members_of(split), hooks), "split");
  EXPECT_EQ(batches_over_launches(costs, "solve"), 2);  // the batch's solves and the regions'
}

// A fused step (solver.fused_step: every stage of a system's step in its team, one launch a
// step) gives every member the same results as the staged step (kSlotsScan), with the team
// solver's solve split over launches and with the accelerated solver's Newton rounds between
// launches, in the members' batch and the regions'.
TEST(Reproducibility, FusedStepDoesNotChangeResults) {
  for (const SolverKind kind :
       {SolverKind::ColouredAcceleratedGaussSeidel, SolverKind::AcceleratedGaussSeidel}) {
    Scan staged = scan_of(kSlotsScan);
    staged.solver.kind = kind;
    staged.solver.newton_every = 1;  // rounds wherever a solve takes more than two sweeps
    staged.newton_every_given = true;
    Scan fused = staged;
    fused.solver.fused_step = true;
    if (kind == SolverKind::ColouredAcceleratedGaussSeidel) fused.solver.sweeps_per_launch = 4;
    std::vector<StageCost> costs;
    RunHooks hooks;
    hooks.stage_costs = &costs;
    const std::string name = solver_kind_name(kind);
    expect_same_members(run_members(staged, members_of(staged)),
                        run_members(fused, members_of(fused), hooks), name);
    EXPECT_EQ(batches_over_launches(costs, "system_step"), 2) << name;
  }
}

// The ETA is the time left at the rate since the run started: a run that went on from snapshots
// at 70 % and reached 80 % in 100 s has 200 s left (not 25 s, as the rate over the whole
// fraction would say); none before 1 % of progress.
TEST(Progress, EtaCountsTheRateSinceTheStart) {
  Progress p;
  p.start_fraction = 0.7;
  p.fraction = 0.8;
  EXPECT_NEAR(progress_eta(p, 100.0), 200.0, 1e-9);
  p.start_fraction = 0.0;
  p.fraction = 0.5;
  EXPECT_NEAR(progress_eta(p, 10.0), 10.0, 1e-9);
  p.start_fraction = 0.495;
  EXPECT_LT(progress_eta(p, 10.0), 0.0);
  p.fraction = 1.0;
  p.start_fraction = 0.0;
  EXPECT_LT(progress_eta(p, 10.0), 0.0);
}

// Under mpirun the run ends with its slowest rank: with one rank done and the other half way
// after 100 s, 100 s are left, not the 33 s that the whole run's 75 % would say; with both
// running, the slower one's; while a running rank has no estimate, the whole run's.
TEST(Progress, EtaIsTheSlowestRanks) {
  std::vector<Progress> ranks(2);
  ranks[0].fraction = 1.0;
  ranks[1].fraction = 0.5;
  Progress all;
  all.fraction = 0.75;
  EXPECT_NEAR(run_eta(ranks, {1, 0}, all, 100.0), 100.0, 1e-9);
  EXPECT_NEAR(progress_eta(all, 100.0), 100.0 / 3.0, 1e-9);
  ranks[0].fraction = 0.8;
  EXPECT_NEAR(run_eta(ranks, {0, 0}, all, 100.0), 100.0, 1e-9);
  ranks[1].fraction = 0.9;
  EXPECT_NEAR(run_eta(ranks, {0, 0}, all, 100.0), 25.0, 1e-9);
  ranks[1].fraction = 0.005;
  EXPECT_NEAR(run_eta(ranks, {0, 0}, all, 100.0), 100.0 / 3.0, 1e-9);
  // A finished rank counts for nothing whatever it reported last, and so does one with no
  // members (0 of 0); a running rank at 100 % of the model's cost leaves no estimate, and so
  // does a run with no rank running.
  ranks[0].fraction = 0.9;
  ranks[1].fraction = 0.5;
  EXPECT_NEAR(run_eta(ranks, {1, 0}, all, 100.0), 100.0, 1e-9);
  ranks[0].fraction = std::nan("");
  EXPECT_NEAR(run_eta(ranks, {0, 0}, all, 100.0), 100.0, 1e-9);
  ranks[0].fraction = 1.0;
  EXPECT_LT(run_eta(ranks, {0, 0}, all, 100.0), 0.0);
  EXPECT_LT(run_eta(ranks, {1, 1}, all, 100.0), 0.0);
}

namespace {

// A run of `scan` stopped at its first snapshot after `reports` progress reports: the snapshots,
// and the share done the run had reported when they were taken.
struct Stopped {
  std::vector<MemberSnapshot> snaps;
  double reached = 0.0;
};
Stopped stopped_after(const Scan& scan, long reports) {
  volatile std::sig_atomic_t stop = 0;
  long n = 0;
  Stopped out;
  RunHooks hooks;
  hooks.stop = &stop;
  hooks.progress = [&](const Progress& p) {
    ++n;
    if (out.snaps.empty()) out.reached = p.fraction;
  };
  hooks.snapshot_wanted = [&] { return n >= reports; };
  hooks.snapshots = [&](std::vector<MemberSnapshot> s) {
    out.snaps = std::move(s);
    stop = 1;
  };
  run_members(scan, members_of(scan), hooks);
  return out;
}

// One member of protocol A at Bo = 1e2 in a 24 R x 24 R box with the paper's stop rule.
Scan papers_rule_scan() {
  return scan_of(R"(
[scan]
protocol = "A"
seeds = 1
[system]
width = 24.0
height = 24.0
bond_number = 100.0
[protocol]
stop_rule = "no_room"
[observables]
lower_half_from = 0.0
)");
}

}  // namespace

// A member that goes on from its snapshot has its share done and its disks from the first report
// on: the resumed run's start_fraction is that first report's fraction, at least what the stopped
// run had reported when the snapshot was taken.
TEST(Progress, ResumedMembersCountAsStartedDone) {
  const auto scan = scan_of(R"(
[scan]
protocol = "A"
seeds = 1
[system]
width = 12.0
height = 16.0
bond_number = 50
[observables]
lower_half_from = 2.0
)");
  const auto members = members_of(scan);
  const auto [snaps, reached] = stopped_after(scan, 200);
  ASSERT_EQ(snaps.size(), 1u);
  std::vector<Progress> seen;
  RunHooks second;
  second.progress = [&](const Progress& p) { seen.push_back(p); };
  run_members(scan, members, second, snaps);
  ASSERT_FALSE(seen.empty());
  EXPECT_GT(reached, 0.0);
  EXPECT_GE(seen.front().start_fraction, reached);
  for (const auto& p : seen) EXPECT_EQ(p.start_fraction, seen.front().fraction);
  EXPECT_NEAR(seen.back().fraction, 1.0, 1e-12);
  // Its disks count from the snapshot's on (the progress line's rate leaves those out): the
  // resumed run ends at the count of a run that was never stopped.
  EXPECT_GT(snaps[0].stage.deposited, 0);
  for (const auto& p : seen) EXPECT_EQ(p.disks_before, snaps[0].stage.deposited);
  long whole = 0;
  RunHooks third;
  third.progress = [&](const Progress& p) { whole = p.disks_deposited; };
  run_members(scan, members, third);
  EXPECT_EQ(seen.back().disks_deposited, whole);
}

// The progress fraction behind the ETA: it never falls (a running member counts the share of its
// expected cost that a member as tall as its deposit so far would cost, and a finished one counts
// whole), it moves while members run, not only when they finish, and it ends at 1; collapses
// running are counted.
TEST(Progress, FractionNeverFallsAndEndsAtOne) {
  const auto scan = scan_of(R"(
[scan]
protocol = ["A", "B", "C"]
seeds = 2
batch_size = 2
[system]
width = 12.0
height = 16.0
bond_number = 50
[observables]
lower_half_from = 2.0
)");
  std::vector<Progress> seen;
  RunHooks hooks;
  hooks.progress = [&](const Progress& p) { seen.push_back(p); };
  run_members(scan, members_of(scan), hooks);
  ASSERT_FALSE(seen.empty());
  std::size_t distinct = 1;
  for (std::size_t k = 1; k < seen.size(); ++k) {
    EXPECT_GE(seen[k].fraction, seen[k - 1].fraction - 1e-12) << "report " << k;
    EXPECT_GE(seen[k].members_done, seen[k - 1].members_done);
    if (seen[k].fraction > seen[k - 1].fraction + 1e-12) ++distinct;
  }
  EXPECT_GE(seen.front().fraction, 0.0);
  EXPECT_NEAR(seen.back().fraction, 1.0, 1e-12);
  EXPECT_EQ(seen.back().members_done, 6);
  // Over four rises per member: the fraction rises while members run (every new disk of A that
  // tops the deposit, every ballistic disk), not only when one finishes.
  EXPECT_GT(distinct, 6u * 4);
  // The two protocol-C members' collapses are reported while they run (a collapse deposits
  // nothing, so the line would look stalled), with the steps of the longest so far; none at the
  // end.
  int most = 0;
  long longest = 0;
  for (const auto& p : seen) {
    most = std::max(most, p.collapsing);
    if (p.collapsing > 0) longest = std::max(longest, p.collapse_steps);
    if (p.collapsing == 0) {
      EXPECT_EQ(p.collapse_steps, 0);
    }
  }
  EXPECT_GE(most, 1);
  EXPECT_LE(most, 2);
  EXPECT_GT(longest, 10);
  EXPECT_EQ(seen.back().collapsing, 0);
  std::printf("%zu progress reports, %zu rises, collapses reported up to %ld steps\n", seen.size(),
              distinct, longest);
}

// A collapse counts as done by its steps against collapse_steps, the top of the column falling
// freely through two thirds of its height: a column 40 R x 60 R at Bo = 1e3 (the reduced fig.
// 14-15 scene) collapses within a factor of two of that, and the fraction behind the ETA rises
// while it collapses (a share fixed at the collapse's start left a one-member run's ETA growing
// with the time elapsed).
TEST(Progress, ACollapseCountsByItsStepsAgainstAFreeFall) {
  const auto scan = scan_of(R"(
[scan]
protocol = "C"
seeds = 1
[system]
width = 40.0
height = 60.0
bond_number = 1000.0
time_step = 0.0028
[observables]
lower_half_from = 4.0
)");
  const auto members = members_of(scan);
  std::vector<Progress> seen;
  RunHooks hooks;
  hooks.progress = [&](const Progress& p) { seen.push_back(p); };
  const auto results = run_members(scan, members, hooks);
  ASSERT_EQ(results.size(), 1u);
  const double expected = collapse_steps(members[0].params);
  EXPECT_NEAR(expected, std::sqrt(4.0 * 60.0 / 3.0) / 0.0028, 1e-9);
  EXPECT_GT(static_cast<double>(results[0].steps), 0.5 * expected);
  EXPECT_LT(static_cast<double>(results[0].steps), 2.0 * expected);
  int rises = 0, collapsing = 0;
  double fastest = 0.0, last_speed = -1.0;
  // The averaged speed (rest.average_span, 5 sqrt(R/g): n steps a span) is there from the end of
  // the second span on.
  const long n = std::lround(std::ceil(scan.rest.average_span / 0.0028));
  for (std::size_t k = 1; k < seen.size(); ++k) {
    if (seen[k].collapsing == 0) continue;
    if (seen[k].collapse_steps < 2 * n) {
      EXPECT_LT(seen[k].collapse_mean_speed, 0.0);
    } else if (seen[k].collapse_steps > 2 * n) {
      EXPECT_GE(seen[k].collapse_mean_speed, 0.0);
    }
    ++collapsing;
    rises += seen[k].fraction > seen[k - 1].fraction ? 1 : 0;
    fastest = std::max(fastest, seen[k].collapse_speed);
    last_speed = seen[k].collapse_speed;
  }
  // The fraction rises with the steps until the collapse reaches nine tenths of its expected
  // steps (then it holds); a share fixed at the collapse's start never rises.
  EXPECT_GT(collapsing, 100);
  EXPECT_GT(rises, collapsing / 3);
  // The progress line's speed of the collapse, over the rest speed (1e-3 sqrt(gR)): the column's
  // top falls freely at first (sqrt(2 g d) passes 100 rest speeds after d = 0.005 R), and the
  // last reports come from the steps of the rest window, below the rest speed.
  EXPECT_GT(fastest, 100.0);
  EXPECT_GE(last_speed, 0.0);
  EXPECT_LT(last_speed, 1.0);
}

// With the paper's stop rule the box is full when its lowest column is, so a member's share done
// follows the mean of its columns' tops, not its highest disk: the valleys of the rough top still
// take many disks after the first column reaches H. The share is (height / H)^q with q = 3 at
// Bo = 1e2 (expected_cost). When the member has placed 90 % of its disks its mean height is at
// most 0.9 of the final one (the deposit is looser higher up), which is below H: a share of at
// most 0.9^3 = 0.73, and at least (2/3)^3 = 0.30 while its mean height is two thirds of H or more.
// By then its highest disk stands at about 0.93 H, which gave 0.82.
TEST(Progress, ThePapersStopRuleCountsTheColumnsNotTheHighestDisk) {
  const auto scan = papers_rule_scan();
  std::vector<Progress> seen;
  RunHooks hooks;
  hooks.progress = [&](const Progress& p) { seen.push_back(p); };
  const auto results = run_members(scan, members_of(scan), hooks);
  ASSERT_EQ(results.size(), 1u);
  const auto disks = static_cast<long>(results[0].y_e.size());
  double at_nine_tenths = -1.0;
  for (const auto& p : seen)
    if (p.disks_deposited * 10 >= disks * 9) {
      at_nine_tenths = p.fraction;
      break;
    }
  std::printf("%ld disks; share done at 90 %% of them: %.3f\n", disks, at_nine_tenths);
  EXPECT_GT(at_nine_tenths, 0.3);
  EXPECT_LT(at_nine_tenths, 0.75);
}

// A member of the paper's rule that goes on from its snapshot keeps its columns' tops (they are in
// the snapshot): at every disk count its share done is the uninterrupted run's.
TEST(Progress, ThePapersStopRuleKeepsItsEstimateOverAResume) {
  const auto scan = papers_rule_scan();
  const auto members = members_of(scan);
  std::map<long, double> straight;  // disks deposited -> share done
  RunHooks whole;
  whole.progress = [&](const Progress& p) {
    if (p.members_done == 0) straight[p.disks_deposited] = p.fraction;
  };
  run_members(scan, members, whole);
  const std::vector<MemberSnapshot> snaps = stopped_after(scan, 300).snaps;
  ASSERT_EQ(snaps.size(), 1u);
  ASSERT_GT(snaps[0].stage.column_top.size(), 0u);
  int compared = 0;
  RunHooks second;
  second.progress = [&](const Progress& p) {
    if (p.members_done > 0) return;
    ++compared;
    EXPECT_EQ(p.fraction, straight.at(p.disks_deposited)) << p.disks_deposited << " disks";
  };
  run_members(scan, members, second, snaps);
  EXPECT_GT(compared, 10);
}

// A relaxation of kLongRelaxation steps or more is reported while it runs (a tall cohesive
// deposit's avalanche deposits nothing for hours at the paper's size, so the line would look
// stalled), with its steps so far. Frictionless disks slide over the pile for a thousand steps and
// more before they rest: every report of such a relaxation names at most as many steps as the
// longest event the members record, and none is reported at the end.
TEST(Progress, LongRelaxationsAreReportedWhileTheyRun) {
  const auto scan = scan_of(R"(
[scan]
protocol = "A"
seeds = 2
[system]
width = 10.0
height = 8.0
bond_number = 0.0
friction = 0.0
rolling_friction = 0.0
[observables]
lower_half_from = 0.0
)");
  std::vector<Progress> seen;
  RunHooks hooks;
  hooks.progress = [&](const Progress& p) { seen.push_back(p); };
  const auto results = run_members(scan, members_of(scan), hooks);
  ASSERT_EQ(results.size(), 2u);
  long longest_event = 0;
  for (const auto& r : results)
    for (const auto& e : r.events) longest_event = std::max(longest_event, e.steps);
  ASSERT_GE(longest_event, kLongRelaxation);  // the scene has such relaxations
  int reports = 0;
  long longest = 0;
  double fastest = 0.0;
  for (const auto& p : seen) {
    EXPECT_LE(p.relaxing_long, 2);
    if (p.relaxing_long == 0) {
      EXPECT_EQ(p.relax_steps, 0);
      continue;
    }
    ++reports;
    EXPECT_GE(p.relax_steps, kLongRelaxation);
    longest = std::max(longest, p.relax_steps);
    fastest = std::max(fastest, p.relax_speed);
  }
  EXPECT_GT(reports, 10);
  // A relaxation goes on while a disk moves faster than the rest speed: the progress line's
  // speed of the longest (over the rest speed) passes 1.
  EXPECT_GT(fastest, 1.0);
  // An event lasts to its last step not at rest and the rest window: the relaxation's steps.
  EXPECT_LE(longest, longest_event);
  EXPECT_GE(longest, kLongRelaxation);
  EXPECT_EQ(seen.back().relaxing_long, 0);
}

// A solver held to one sweep per step never reaches the tolerance in a collapsing deposit: the
// member fails as unconverged once the cap has been hit on every step for longer than
// protocol.max_unconverged_time (0.505 / h = 0.01: on step 51), keeps its state for the
// diagnostic snapshot, and its point counts it as failed and aggregates nothing from it.
TEST(Failure, UnconvergedForTooLongFailsTheMember) {
  const Scan scan = scan_of(R"(
[scan]
protocol = "C"
[system]
width = 12.0
height = 12.0
bond_number = 30
time_step = 0.01
[solver]
max_sweeps = 1
[protocol]
max_unconverged_time = 0.505
[observables]
lower_half_from = 2.0
)");
  const auto results = run_all(scan);
  ASSERT_EQ(results.size(), 1u);
  const auto& r = results[0];
  EXPECT_EQ(r.failure, Failure::Unconverged);
  EXPECT_EQ(r.steps, 51);
  EXPECT_EQ(r.vx.size(), r.x.size());
  EXPECT_FALSE(r.x.empty());
  const auto points = aggregate(scan, results);
  EXPECT_EQ(points.at(0).members, 1);
  EXPECT_EQ(points.at(0).failed, 1);
  EXPECT_EQ(points.at(0).nu_lower_half.n, 0);
}

// What a scan leaves to the backend is filled in by the backend: on a host backend (the build
// the suite runs on) one thread per system, and 4 or 64 systems per batch; a file's own choices
// stay. (On a device the defaults are the team solver, 4 096 and 8 sweeps a launch where the
// batch holds more than one system, and the staged step: docs/PERFORMANCE.md.)
TEST(Backend, DefaultsFillOnlyWhatTheScanLeavesOpen) {
  Scan open = scan_of("[scan]\nname = \"open\"\n");
  resolve_backend_defaults(open, 100);
  EXPECT_EQ(open.solver.kind, default_solver_kind());
  EXPECT_EQ(open.batch_size, default_batch_size());
  // docs/PERFORMANCE.md's defaults: a device (memory the host cannot read) gets the team solver,
  // batches of 4 096 and its solve split into launches of 8 sweeps; host threads batches of 64,
  // one thread 4, and whole solves.
  const bool device =
      !Kokkos::SpaceAccessibility<Kokkos::HostSpace,
                                  Kokkos::DefaultExecutionSpace::memory_space>::accessible;
  EXPECT_EQ(default_solver_kind(), device ? SolverKind::ColouredAcceleratedGaussSeidel
                                          : SolverKind::AcceleratedGaussSeidel);
  const int threads_batch = Kokkos::DefaultExecutionSpace().concurrency() > 1 ? 64 : 4;
  EXPECT_EQ(default_batch_size(), device ? 4096 : threads_batch);
  EXPECT_EQ(default_sweeps_per_launch(2), device ? 8 : 0);
  EXPECT_EQ(open.solver.sweeps_per_launch, device ? 8 : 0);
  // A batch of one system has no other system to step while its solve goes on: whole solves,
  // for a run of one member or a batch of one slot.
  EXPECT_EQ(default_sweeps_per_launch(1), 0);
  Scan one = scan_of("[scan]\nname = \"one\"\n");
  resolve_backend_defaults(one, 1);
  EXPECT_EQ(one.solver.sweeps_per_launch, 0);
  Scan one_slot = scan_of("[scan]\nbatch_size = 1\n");
  resolve_backend_defaults(one_slot, 100);
  EXPECT_EQ(one_slot.solver.sweeps_per_launch, 0);
  Scan set = scan_of("[scan]\nbatch_size = 3\n[solver]\nkind = \"gauss_seidel\"\n");
  resolve_backend_defaults(set, 100);
  EXPECT_EQ(set.solver.kind, SolverKind::GaussSeidel);
  EXPECT_EQ(set.batch_size, 3);
  EXPECT_EQ(set.solver.sweeps_per_launch, 0);  // only the team solver splits its solve
  // The team solver chosen without a split takes the backend's; a file's own split stays.
  Scan team = scan_of("[solver]\nkind = \"coloured_accelerated_gauss_seidel\"\n");
  resolve_backend_defaults(team, 100);
  EXPECT_EQ(team.solver.sweeps_per_launch, default_sweeps_per_launch(100));
  Scan whole =
      scan_of("[solver]\nkind = \"coloured_accelerated_gauss_seidel\"\nsweeps_per_launch = 0\n");
  resolve_backend_defaults(whole, 100);
  EXPECT_EQ(whole.solver.sweeps_per_launch, 0);
  Scan split =
      scan_of("[solver]\nkind = \"coloured_accelerated_gauss_seidel\"\nsweeps_per_launch = 3\n");
  resolve_backend_defaults(split, 1);
  EXPECT_EQ(split.solver.sweeps_per_launch, 3);
  // The fused step: the host's with every solver that allows it, a device's not yet (not
  // measured there); a file's own choice stays.
  EXPECT_EQ(open.solver.fused_step, !device);
  EXPECT_EQ(team.solver.fused_step, !device);
  EXPECT_FALSE(set.solver.fused_step);  // gauss_seidel colours the whole batch
  for (SolverKind kind : {SolverKind::AcceleratedGaussSeidel, SolverKind::SequentialGaussSeidel,
                          SolverKind::ColouredAcceleratedGaussSeidel})
    EXPECT_EQ(default_fused_step(kind), !device) << solver_kind_name(kind);
  EXPECT_FALSE(default_fused_step(SolverKind::Jacobi));
  Scan staged = scan_of("[solver]\nfused_step = false\n");
  resolve_backend_defaults(staged, 100);
  EXPECT_FALSE(staged.solver.fused_step);
  Scan fused = scan_of("[solver]\nfused_step = true\n");
  resolve_backend_defaults(fused, 100);
  EXPECT_TRUE(fused.solver.fused_step);
}

// In a relaxation region the progress line names the speed of the region's last step; a region
// cut again around the moving disks has taken none yet, and its speed is not known: reported as
// -1 (not as the 0 of a system at rest), and the line then names no speed. Frictionless disks in
// regions of radius 5 slide on for more than kLongRelaxation steps, their regions cut again as
// they move.
TEST(Progress, ARegionCutAgainNamesNoSpeedBeforeItSteps) {
  const auto scan = scan_of(R"(
[scan]
protocol = "A"
seeds = 2
[system]
width = 16.0
height = 12.0
bond_number = 0.0
friction = 0.0
rolling_friction = 0.0
[protocol]
region_radius = 5.0
region_check_every = 1
[observables]
lower_half_from = 0.0
)");
  int reports = 0, unknown = 0;
  RunHooks hooks;
  hooks.progress = [&](const Progress& p) {
    if (p.relaxing_long == 0) return;
    ++reports;
    if (p.relax_speed == -1.0)
      ++unknown;
    else
      EXPECT_GE(p.relax_speed, 0.0);
  };
  run_members(scan, members_of(scan), hooks);
  EXPECT_GT(reports, 1000);
  EXPECT_GT(unknown, 0);  // the scene reports between a cut and its region's first step
}
