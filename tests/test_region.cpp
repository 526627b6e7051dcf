// Relaxation regions (protocol A): which disks a region holds, the round trip of state and
// impulses between a region and the whole system, and a column whose new top disk is relaxed
// in a region and then by the whole system, with the exact weights of MODEL.md case 1.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <utility>
#include <vector>

#include "loosepack/region.hpp"
#include "loosepack/scenes.hpp"
#include "tests/run_helpers.hpp"

using namespace loosepack;
using namespace loosepack::scenes;

namespace {

SolverSettings accurate() {
  SolverSettings s;
  s.tolerance = 1e-8;
  s.max_sweeps = 200000;
  return s;
}

// The selection rule by brute force: a disk moves iff its distance to the nearest seed
// (minimum image in x) is at most the radius and it is not fixed, is held iff that distance is
// at most radius + reach otherwise, and is left out beyond. Returns {moving, held} indices.
std::pair<std::vector<int>, std::vector<int>> selection_by_every_seed(
    const std::vector<Disk>& disks, const std::vector<Regions::Point>& seeds, double width,
    double radius, double reach) {
  std::vector<int> moving, held;
  for (int k = 0; k < static_cast<int>(disks.size()); ++k) {
    double d = 1e300;
    for (const auto& p : seeds) {
      const double dx = std::fmod(disks[k].x - p.x + 1.5 * width, width) - 0.5 * width;
      d = std::min(d, std::hypot(dx, disks[k].y - p.y));
    }
    if (d <= radius && !disks[k].fixed)
      moving.push_back(k);
    else if (d <= radius + reach)
      held.push_back(k);
  }
  return {moving, held};
}

// A selection split into its {moving, held} disk indices.
std::pair<std::vector<int>, std::vector<int>> split(const RegionSelection& sel) {
  std::vector<int> moving, held;
  for (std::size_t k = 0; k < sel.index.size(); ++k)
    (sel.moving[k] ? moving : held).push_back(sel.index[k]);
  return {moving, held};
}

}  // namespace

// A disk moves iff it lies within the radius of a seed (minimum image in x), is held fixed iff
// it lies beyond the radius but within radius + reach, and is left out otherwise.
TEST(Region, SelectsByDistanceToTheNearestSeed) {
  const double width = 40.0, radius = 6.0, reach = 2.5;
  std::vector<Disk> disks;
  for (int k = 0; k < 40; ++k) {
    Disk d;
    d.x = std::fmod(1.0 + 1.0 * k, width);  // along y = 5, crossing x = 0
    d.y = 5.0;
    disks.push_back(d);
  }
  disks[3].fixed = true;  // a support: never moves
  const std::vector<Regions::Point> seeds = {{2.0, 5.0}, {2.0, 12.0}};
  const RegionSelection sel = select_region(disks, seeds, width, radius, reach);
  const auto [moving, fixed] = split(sel);
  const auto [expect_moving, expect_fixed] =
      selection_by_every_seed(disks, seeds, width, radius, reach);
  EXPECT_EQ(moving, expect_moving);
  EXPECT_EQ(fixed, expect_fixed);
  EXPECT_EQ(fixed, std::vector<int>({3, 8, 9, 33, 34}));  // x = 4 (fixed), 9, 10, 34, 35
  EXPECT_TRUE(std::is_sorted(sel.index.begin(), sel.index.end()));
  // Disks across the periodic boundary (x near 40) are within the radius of x = 2.
  EXPECT_NE(std::find(moving.begin(), moving.end(), 38), moving.end());  // x = 39
}

// The same rule with many seeds scattered over several cells of the seed grid, against the
// distance to every seed: the search that stops at the first seed near enough must not change
// which disks move or are held.
TEST(Region, SelectionMatchesEverySeedsDistance) {
  const double width = 40.0, height = 60.0, radius = 6.0, reach = 2.5;
  std::uint64_t state = 12345;
  auto uniform = [&state]() {  // a fixed LCG: the scene is the same on every platform
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(state >> 11) / 9007199254740992.0;
  };
  std::vector<Disk> disks(400);
  for (auto& d : disks) {
    d.x = width * uniform();
    d.y = height * uniform();
    d.fixed = uniform() < 0.1;
  }
  std::vector<Regions::Point> seeds(30);
  for (auto& p : seeds) p = {width * uniform(), height * uniform()};
  const RegionSelection sel = select_region(disks, seeds, width, radius, reach);
  const auto [moving, fixed] = split(sel);
  const auto [expect_moving, expect_fixed] =
      selection_by_every_seed(disks, seeds, width, radius, reach);
  EXPECT_EQ(moving, expect_moving);
  EXPECT_EQ(fixed, expect_fixed);
  EXPECT_GT(moving.size(), 50u);  // the scene exercises all three outcomes
  EXPECT_GT(fixed.size(), 20u);
  EXPECT_LT(sel.index.size(), disks.size());
}

// An event's size counts the disks that moved beyond the threshold in y since it began, and their
// downward displacement only: creep below the threshold (here 0.005 R) adds to neither.
TEST(Region, AnEventCountsOnlyTheDisksThatMovedBeyondTheThreshold) {
  Batch batch({setup(bare_params(), column(4, 10.0))}, accurate());
  batch.close_events({1}, 0.01);  // an event begins from the heights now
  auto d = batch.disks(0);
  const std::vector<double> dy = {-0.5, -0.005, 0.3, -0.02};
  for (std::size_t k = 0; k < dy.size(); ++k) d[k].y += dy[k];
  batch.set_disks(0, {0, 1, 2, 3}, d);
  const auto ev = batch.close_events({1}, 0.01);
  ASSERT_EQ(ev.size(), 1u);
  EXPECT_EQ(ev[0].moved, 3);
  EXPECT_NEAR(ev[0].downward, 0.52, 1e-12);
}

// set_disks and set_contacts write what disks() and contacts() read back.
TEST(Region, BatchStateRoundTrip) {
  auto p = bare_params();
  p.friction = 0.3;
  Batch batch({setup(p, column(4, 10.0))}, accurate());
  for (int k = 0; k < 3; ++k) batch.step();
  auto d = batch.disks(0);
  d[2].x = 11.5;
  d[2].vy = -0.25;
  d[2].w = 0.5;
  batch.set_disks(0, {2}, {d[2]});
  const auto back = batch.disks(0);
  EXPECT_EQ(back[2].x, 11.5);
  EXPECT_EQ(back[2].vy, -0.25);
  EXPECT_EQ(back[2].w, 0.5);
  EXPECT_EQ(back[1].y, d[1].y);
  std::vector<ContactForce> forces = {{0, -1, 0, -1, 0, 7.0, 0.5, 0.0}, {1, 2, 0, 1, 0, 3.0, 0, 0}};
  batch.set_contacts(0, forces);
  const auto c = batch.contacts(0);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c[0].j, -1);
  EXPECT_DOUBLE_EQ(c[0].normal, 7.0);
  EXPECT_DOUBLE_EQ(c[0].tangential, 0.5);
  EXPECT_EQ(c[1].i, 1);
  EXPECT_EQ(c[1].j, 2);
  EXPECT_DOUBLE_EQ(c[1].normal, 3.0);
  EXPECT_THROW(batch.set_contacts(0, {{2, 1, 0, 1, 0, 1.0, 0, 0}}), std::out_of_range);
}

// The disks as written (a region's avalanche handed to the whole system, or a region's disks
// come to rest) set the next step's relative tolerance, kappa v_max / (g h), as they set its
// detection margin (the margin stage), not the speeds of the step before: a fast disk written
// into a column at rest loosens it, and the disks written at rest after a fast step tighten it
// back to the absolute tolerance.
TEST(Region, DisksWrittenSetTheNextStepsTolerance) {
  const auto p = bare_params();
  Batch batch({setup(p, column(4, 10.0))}, accurate());
  for (int k = 0; k < 3; ++k) batch.step();
  auto d = batch.disks(0);
  const double fast = 2.0;
  d[3].vx = fast;
  batch.set_disks(0, {3}, {d[3]});
  batch.step();
  const double loosened = batch.solver().relative_tolerance * fast / (p.gravity * p.time_step);
  ASSERT_GT(loosened, accurate().tolerance);
  EXPECT_DOUBLE_EQ(batch.status(0).tolerance, loosened);
  ASSERT_GT(batch.status(0).max_speed, 0.1);  // the step moved the disk
  d = batch.disks(0);
  for (auto& disk : d) disk.vx = disk.vy = disk.w = 0.0;
  batch.set_disks(0, {0, 1, 2, 3}, d);
  batch.step();
  EXPECT_EQ(batch.status(0).tolerance, accurate().tolerance);
}

namespace {

// A column of n disks at rest gets a disk on top (MODEL.md case 1: the contact below the k-th
// disk from the top carries k m g). Relaxed in a region around the new disk, the top `moving`
// disks move and carry 1 ... moving m g below them; the disks below are held and keep their old
// loads (one m g short) and their positions exactly. The whole system then carries the new
// disk's weight to the floor: k m g everywhere. `radius` is the region's (0: the settings' 5).
void column_top_relaxes_in_its_region(double radius, int moving) {
  const int n = 20;
  auto p = bare_params(20.0, 60.0);
  p.friction = 0.3;
  p.rolling_friction = 0.1;
  RestSettings rest;
  Batch batch({setup(p, column(n, 10.0), 64)}, accurate(), rest);
  batch.run_to_rest(2000);
  ASSERT_TRUE(batch.status(0).at_rest);
  const auto before = batch.disks(0);
  const auto placed = batch.deposit_at({1}, {10.0}, DropRule::Touch);
  ASSERT_TRUE(placed[0].placed);
  EXPECT_NEAR(placed[0].y, 1.0 + 2.0 * n, 1e-6);

  RegionSettings rs;
  rs.radius = 5.0;
  rs.max_disks = 64;
  rs.max_height = 60.0;
  Regions regions(1, {p}, rs, accurate(), rest);
  ASSERT_TRUE(regions.begin(batch, 0, {{placed[0].x, placed[0].y}}, 1e-8, radius));
  Regions::State state = Regions::State::Running;
  for (int k = 0; k < 2000 && state == Regions::State::Running; ++k) {
    regions.step();
    state = regions.poll(batch, 0);
  }
  ASSERT_EQ(state, Regions::State::Rested);
  const double mg = p.reference_mass() * p.gravity;
  const int top = n;  // index of the new disk
  auto load_below = [&](const std::vector<ContactForce>& contacts, int upper) {
    for (const auto& c : contacts)
      if ((upper == 0 && c.i == 0 && c.j < 0) || (c.j == upper && c.i == upper - 1))
        return c.normal;
    return -1.0;
  };
  const auto after_region = batch.contacts(0);
  // Each contact's force within the step's tolerance at rest (here kappa 1e-3 times the rest
  // speed 1e-3 over h = 0.01: 1e-4 m g).
  const SolverSettings solver = accurate();
  const double step_tolerance = run_helpers::step_tolerance_at_rest(
                                    solver.tolerance, solver.relative_tolerance, rest.speed, p) *
                                mg;
  for (int k = 1; k <= moving; ++k)  // moving disks: the new load
    EXPECT_NEAR(load_below(after_region, top + 1 - k), k * mg, step_tolerance) << "k = " << k;
  for (int k = moving + 1; k <= n + 1; ++k)  // held disks: the load before the new disk
    EXPECT_NEAR(load_below(after_region, top + 1 - k), (k - 1) * mg, step_tolerance) << "k = " << k;
  const auto held = batch.disks(0);
  for (int k = 0; k + moving < n; ++k) EXPECT_EQ(held[k].y, before[k].y) << "disk " << k;

  batch.set_active(0, true);
  batch.reset_rest(0);
  batch.run_to_rest(2000);
  ASSERT_TRUE(batch.status(0).at_rest);
  const auto whole = batch.contacts(0);
  for (int k = 1; k <= n + 1; ++k)  // the k contacts down to this one each within the tolerance
    EXPECT_NEAR(load_below(whole, top + 1 - k), k * mg, k * step_tolerance) << "k = " << k;
}

}  // namespace

// Radius 5 around the new disk (centres 2 R apart): it and the two below move.
TEST(Region, ColumnTopRelaxesInItsRegionThenTheWholeCarriesTheWeight) {
  column_top_relaxes_in_its_region(0.0, 3);
}

// A radius given to begin() replaces the settings' (the larger regions the protocol starts
// where the check finds motion): radius 9 moves the new disk and the four below it.
TEST(Region, AGivenRadiusReplacesTheSettingsRadius) { column_top_relaxes_in_its_region(9.0, 5); }

// A region needs a disk to move: without a seed (a check whose fastest disk is at the wake speed
// to rounding) none starts, and the whole system goes on; a seed on a disk starts one.
TEST(Region, NoSeedStartsNoRegion) {
  const auto p = bare_params(20.0, 60.0);
  Batch batch({setup(p, column(5, 10.0), 64)}, accurate());
  RegionSettings rs;
  rs.radius = 5.0;
  rs.max_disks = 64;
  rs.max_height = 60.0;
  Regions regions(1, {p}, rs, accurate(), RestSettings{});
  EXPECT_FALSE(regions.begin(batch, 0, {}, accurate().tolerance));
  const auto bottom = batch.disks(0).front();
  EXPECT_TRUE(regions.begin(batch, 0, {{bottom.x, bottom.y}}, accurate().tolerance));
}

namespace {
// The whole system's disks that move in a region.
std::vector<int> moving_of(const RegionCut& cut) {
  std::vector<int> moving;
  for (std::size_t k = 0; k < cut.index.size(); ++k)
    if (cut.moving[k]) moving.push_back(cut.index[k]);
  return moving;
}
}  // namespace

// A region grows where motion reaches its edge (docs/MODEL.md, "Relaxation regions"): a row of
// disks 2.5 R apart on the floor, without gravity, a region of radius 5.5 R seeded on the first;
// the third, 5 R from the seed (beyond 0.6 of the radius), moves at 0.5 sqrt(gR): after the first
// step the region is made again around it (its seed there) and holds the disks near it. In a slot
// of 5 disks, which the first region fits and the grown one does not, the region hands the
// system back (RelaxWhole) with its disks written back.
TEST(Region, MotionNearTheEdgeGrowsTheRegionOrHandsItBack) {
  auto p = bare_params(40.0, 10.0);
  p.gravity_on = false;
  std::vector<Disk> row(10);
  for (std::size_t k = 0; k < row.size(); ++k) {
    row[k].x = 2.0 + 2.5 * static_cast<double>(k);
    row[k].y = 1.0;
  }
  row[2].vx = 0.5;
  for (const int slot : {64, 5}) {
    SCOPED_TRACE("slot of " + std::to_string(slot) + " disks");
    Batch batch({setup(p, row, 64)}, accurate());
    RegionSettings rs;
    rs.radius = 5.5;
    rs.max_disks = slot;
    rs.max_height = 10.0;
    Regions regions(1, {p}, rs, accurate(), RestSettings{});
    ASSERT_TRUE(regions.begin(batch, 0, {{2.0, 1.0}}, accurate().tolerance));
    ASSERT_EQ(regions.state(0).cut.seeds.size(), 1u);
    EXPECT_EQ(moving_of(regions.state(0).cut), (std::vector<int>{0, 1, 2}));  // within 5.5 R of 2
    regions.step();
    const Regions::State state = regions.poll(batch, 0);
    if (slot == 5) {
      EXPECT_EQ(state, Regions::State::RelaxWhole);
      EXPECT_GT(batch.disks(0)[2].x, row[2].x);  // its step written back
      continue;
    }
    ASSERT_EQ(state, Regions::State::Running);
    const RegionCut cut = regions.state(0).cut;
    const bool seeded_there = std::any_of(cut.seeds.begin(), cut.seeds.end(), [&](const auto& q) {
      return std::fabs(q.x - row[2].x) < 0.1 && std::fabs(q.y - 1.0) < 1e-9;
    });
    EXPECT_TRUE(seeded_there);
    EXPECT_EQ(moving_of(cut), (std::vector<int>{0, 1, 2, 3, 4}));  // within 5.5 R of x = 7
  }
}

// The pace of the Newton rounds (Batch::SolverPace) belongs to the deposit, not to one region:
// a region starts from the whole system's pace and hands its own back, and only reset() starts
// afresh. A column's new top disk relaxed in a region, with a sweep cap of 40 that some steps
// reach (rest by speeds alone): with a fresh pace the region's steps take Newton rounds; with a
// pace that has given up on them (the longest wait and a credit of -1e9) they take none, and
// the whole system gets back that pace with the credit its capped steps earned (each capped
// step adds a share of its sweeps: NewtonPace::step_done), so above -1e9.
TEST(Region, TheNewtonPaceIsTheDepositsAndGoesBackToTheWholeSystem) {
  const int n = 20;
  auto p = bare_params(20.0, 60.0);
  p.friction = 0.3;
  p.rolling_friction = 0.1;
  SolverSettings solver;  // accelerated Gauss-Seidel with Newton rounds
  solver.tolerance = 1e-10;
  solver.max_sweeps = 40;
  RestSettings rest;
  rest.converged = false;
  const int shortest = 2 * solver.newton_every, longest = solver.max_sweeps - shortest;
  RegionSettings rs;
  rs.radius = 9.0;
  rs.max_disks = 64;
  rs.max_height = 60.0;
  struct Outcome {
    long newton = 0;
    int capped = 0;
    Batch::SolverPace after;
  };
  auto relax_top = [&](const Batch::SolverPace* pace) {
    Batch batch({setup(p, column(n, 10.0), 64)}, solver, rest);
    EXPECT_EQ(batch.solver_pace(0).wait, shortest);
    EXPECT_EQ(batch.solver_pace(0).credit, 0.0);
    batch.run_to_rest(20000);
    EXPECT_TRUE(batch.status(0).at_rest);
    if (pace) batch.set_solver_pace(0, *pace);
    const auto placed = batch.deposit_at({1}, {10.0}, DropRule::Touch);
    Regions regions(1, {p}, rs, solver, rest);
    EXPECT_TRUE(regions.begin(batch, 0, {{placed[0].x, placed[0].y}}, solver.tolerance));
    Regions::State state = Regions::State::Running;
    Outcome out;
    for (int k = 0; k < 20000 && state == Regions::State::Running; ++k) {
      regions.step();
      out.newton = regions.status(0).newton_steps;
      out.capped += regions.status(0).converged ? 0 : 1;
      state = regions.poll(batch, 0);
    }
    EXPECT_EQ(state, Regions::State::Rested);
    out.after = batch.solver_pace(0);
    batch.reset(0, setup(p, column(n, 10.0), 64));  // a new system: afresh
    EXPECT_EQ(batch.solver_pace(0).wait, shortest);
    EXPECT_EQ(batch.solver_pace(0).credit, 0.0);
    return out;
  };
  EXPECT_GT(relax_top(nullptr).newton, 0) << "the scene takes no rounds: it shows nothing";
  const Batch::SolverPace given_up{1000000, -1e9};  // the wait is clamped to the longest
  const Outcome o = relax_top(&given_up);
  EXPECT_EQ(o.newton, 0);
  ASSERT_GT(o.capped, 0) << "no capped step: the hand-back shows nothing";
  EXPECT_EQ(o.after.wait, longest);
  EXPECT_GT(o.after.credit, -1e9);
  EXPECT_LT(o.after.credit, 0.0);
}
