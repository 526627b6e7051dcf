// Hard cases (docs/VALIDATION.md): extreme Bond numbers, a tall exact column and its toppling,
// degenerate geometry, extreme parameters. Every test states the quantity it checks and where its
// bound comes from (statics, the contact law of MODEL.md, or the solver's tolerance); none is a
// number copied from a previous run.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>

#include "loosepack/batch.hpp"
#include "loosepack/geometry.hpp"
#include "loosepack/scan.hpp"
#include "loosepack/scenes.hpp"
#include "tests/scan_errors.hpp"

using namespace loosepack;
using namespace loosepack::scenes;

namespace {

double mass_of(const Disk& d, const SystemParams& p) {
  return p.disk_density * M_PI * d.radius * d.radius;
}

// Every disk finite and inside the domain: 0 <= x < L_x (periodic), y >= r - overlap_bound.
void expect_in_domain(const std::vector<Disk>& disks, const SystemParams& p, double overlap_bound,
                      const std::string& what) {
  for (std::size_t k = 0; k < disks.size(); ++k) {
    const auto& d = disks[k];
    ASSERT_TRUE(std::isfinite(d.x) && std::isfinite(d.y) && std::isfinite(d.vx) &&
                std::isfinite(d.vy) && std::isfinite(d.w))
        << what << ": disk " << k;
    EXPECT_GE(d.x, 0.0) << what << ": disk " << k;
    EXPECT_LT(d.x, p.width) << what << ": disk " << k;
    EXPECT_GE(d.y, d.radius - overlap_bound) << what << ": disk " << k;
  }
}

// The contact law's bounds on every contact force (MODEL.md, contact law 2-4): tension at most
// F_c (only for a cohesive contact: gap < d_c), |F_t| <= mu (F_n + F_c), |M| <= mu_r R_c
// (F_n + F_c). The solver projects onto exactly these bounds, so they hold to rounding
// (relative 1e-12 of the largest term).
void expect_within_contact_law(const std::vector<ContactForce>& contacts,
                               const std::vector<Disk>& disks, const SystemParams& p,
                               const std::string& what) {
  const double fc = p.cohesive_force();
  for (const auto& c : contacts) {
    const bool cohesive = fc > 0.0 && c.gap < p.cohesion_range && (c.j >= 0 || p.floor_cohesion);
    const double lower = cohesive ? -fc : 0.0;
    const double slack = 1e-12 * (std::fabs(c.normal) + fc + 1.0);
    EXPECT_GE(c.normal, lower - slack) << what << ": contact " << c.i << "-" << c.j;
    const double shifted = c.normal - lower;
    EXPECT_LE(std::fabs(c.tangential), p.friction * shifted + slack)
        << what << ": contact " << c.i << "-" << c.j;
    const double rc = c.j < 0 ? disks[static_cast<std::size_t>(c.i)].radius
                              : std::min(disks[static_cast<std::size_t>(c.i)].radius,
                                         disks[static_cast<std::size_t>(c.j)].radius);
    EXPECT_LE(std::fabs(c.moment), p.rolling_friction * rc * shifted + slack * rc)
        << what << ": contact " << c.i << "-" << c.j;
  }
}

// Vertical force of the floor on the disks: the floor normal is (0, -1) from disk to floor, so
// the normal force on the disk points up; tangential floor forces are horizontal.
double floor_reaction(const std::vector<ContactForce>& contacts) {
  double f = 0.0;
  for (const auto& c : contacts)
    if (c.j < 0) f += c.normal;
  return f;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// 1. Bo = 1e6: loose ballistic deposits (protocol B: DropRule::Capture with gravity off) hold
// under gravity (then switched on, as in protocol C) for 5000 steps.
// Statics: the longest cantilever a cohesive contact can carry is j^2 <= mu_r Bo (j <= 316
// disks) and j <= mu Bo; the box is 24 R wide, so every branch of the deposit holds and nothing
// may move once the contacts have taken the load.
// Checked, after 100 steps of settling (the contacts taking the weight):
//  - no failure, no NaN, count preserved, every disk in the domain;
//  - max displacement of any disk over the next 5000 steps < d_c / 10: a contact that breaks
//    opens beyond d_c and its disk falls freely (metres, not d_c); the solver's residual
//    (tolerance tau = 1e-8 per contact per sweep, in h m g) moves a disk by at most about
//    n_contacts tau h g per step, h n_contacts tau h g K = n_contacts x 5e-9 R over K = 5000
//    steps (h = 0.01; at most 4e-8 R for the 8 contact slots of a disk), far below it;
//  - the floor's total vertical reaction equals the total weight sum(m g), within the solver
//    tolerance: n_contacts tau m g (each contact's impulse is converged to tau h m g, and the
//    sum is exact at rest by the momentum balance of the whole system);
//  - no contact force outside the cohesion law (tension <= F_c, Coulomb and rolling bounds).
TEST(HardCase, BallisticDepositsHoldAtBo1e6) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<SystemSetup> setups;
  for (double r_capt : {1.0, 3.0}) {  // plain ballistic deposition, and long horizontal chains
    SystemParams p = bare_params(24.0, 24.0);
    p.bond_number = 1e6;
    p.friction = 0.3;
    p.rolling_friction = 0.1;
    p.capture_radius = r_capt;
    p.gravity_on = false;
    SystemSetup s = setup(p, {}, 400);
    s.seed = 3;
    s.member = static_cast<std::uint64_t>(r_capt);
    setups.push_back(s);
  }
  SolverSettings solver;
  solver.tolerance = 1e-8;
  solver.max_sweeps = 100000;
  Batch batch(setups, solver);
  const int S = batch.size();
  // Deposit until full (protocol B).
  std::vector<char> mask(static_cast<std::size_t>(S), 1);
  for (int k = 0; k < 1000; ++k) {
    const auto dep = batch.deposit(mask, DropRule::Capture);
    bool any = false;
    for (int s = 0; s < S; ++s) {
      if (!dep[static_cast<std::size_t>(s)].placed) mask[static_cast<std::size_t>(s)] = 0;
      any = any || mask[static_cast<std::size_t>(s)];
    }
    if (!any) break;
  }
  std::vector<int> counts;
  for (int s = 0; s < S; ++s) {
    const auto& p = batch.params(s);
    const auto d = batch.disks(s);
    counts.push_back(static_cast<int>(d.size()));
    double area = 0.0;
    for (const auto& a : d) area += M_PI * a.radius * a.radius;
    const double nu = area / (p.width * p.height);
    std::printf("r_capt = %g: %zu disks, volume fraction %.3f\n", p.capture_radius, d.size(), nu);
    // A loose structure of chains and arches, not a pile: a dense disk packing has nu > 0.8.
    EXPECT_LT(nu, 0.5);
    ASSERT_GT(d.size(), 20u);
    batch.set_gravity(s, true);
  }
  for (int k = 0; k < 100; ++k) batch.step();
  std::vector<std::vector<Disk>> settled;
  for (int s = 0; s < S; ++s) settled.push_back(batch.disks(s));
  const int hold = 5000;
  double max_speed = 0.0;
  long sweeps0 = batch.status(0).sweeps + batch.status(1).sweeps;
  for (int k = 0; k < hold; ++k) {
    batch.step();
    for (int s = 0; s < S; ++s) max_speed = std::max(max_speed, batch.status(s).max_speed);
  }
  const long sweeps = batch.status(0).sweeps + batch.status(1).sweeps - sweeps0;
  for (int s = 0; s < S; ++s) {
    const auto& p = batch.params(s);
    const auto& st = batch.status(s);
    ASSERT_EQ(st.failure, Failure::None);
    EXPECT_TRUE(st.converged);
    const auto d = batch.disks(s);
    ASSERT_EQ(static_cast<int>(d.size()), counts[static_cast<std::size_t>(s)]);
    expect_in_domain(d, p, p.cohesion_range, "Bo 1e6");
    double drift = 0.0, weight = 0.0;
    for (std::size_t k = 0; k < d.size(); ++k) {
      double dx = d[k].x - settled[static_cast<std::size_t>(s)][k].x;
      dx -= p.width * std::round(dx / p.width);
      drift = std::max(drift, std::hypot(dx, d[k].y - settled[static_cast<std::size_t>(s)][k].y));
      weight += mass_of(d[k], p) * p.gravity;
    }
    const auto contacts = batch.contacts(s);
    const double reaction = floor_reaction(contacts);
    const double force_tol = static_cast<double>(contacts.size()) * solver.tolerance * 1.0;
    std::printf(
        "r_capt = %g: drift over %d steps %.3g R (bound %.3g), floor reaction %.9g, weight "
        "%.9g (bound %.3g), max overlap %.3g R\n",
        p.capture_radius, hold, drift, 0.1 * p.cohesion_range, reaction, weight, force_tol,
        batch.max_overlap(s));
    EXPECT_LT(drift, 0.1 * p.cohesion_range);
    EXPECT_NEAR(reaction, weight, force_tol);
    expect_within_contact_law(contacts, d, p, "Bo 1e6");
    EXPECT_LT(batch.max_overlap(s), 0.1 * p.cohesion_range);
  }
  std::printf("max speed while holding %.3g sqrt(gR); %.1f sweeps per step; %.2f s\n", max_speed,
              static_cast<double>(sweeps) / (S * hold), seconds_since(t0));
}

// A step whose solve reaches its sweep cap ends within the contact law too: every impulse is
// that of an exact local solve, projected onto its bounds, where the accelerated solvers' last
// move could be an extrapolation (NNCG's step) that nothing projects. A cohesive hexagonal
// packing 10 disks wide and 6 rows high, its disks thrown in random directions at up to 2
// sqrt(gR), stepped 40 times with a cap of 6 sweeps and a tolerance of 1e-14 (at least half of
// the steps capped), with both accelerated solvers.
TEST(HardCase, CappedStepsStayWithinTheContactLaw) {
  SystemParams p = bare_params(20.0, 30.0);
  p.friction = 0.3;
  p.rolling_friction = 0.1;
  p.bond_number = 10.0;
  p.time_step = 0.005;
  std::vector<Disk> disks = hexagonal(10, 6);
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> uniform(-2.0, 2.0);
  for (auto& d : disks) {
    d.vx = uniform(rng);
    d.vy = uniform(rng);
    d.w = uniform(rng);
  }
  for (SolverKind kind :
       {SolverKind::AcceleratedGaussSeidel, SolverKind::ColouredAcceleratedGaussSeidel}) {
    SolverSettings solver;
    solver.kind = kind;
    solver.tolerance = 1e-14;
    solver.max_sweeps = 6;
    Batch batch({setup(p, disks)}, solver);
    int capped = 0;
    for (int k = 0; k < 40; ++k) {
      batch.step();
      ASSERT_EQ(batch.status(0).failure, Failure::None);
      capped += batch.status(0).converged ? 0 : 1;
      expect_within_contact_law(
          batch.contacts(0), batch.disks(0), p,
          std::string(solver_kind_name(kind)) + ", step " + std::to_string(k));
    }
    EXPECT_GE(capped, 20) << solver_kind_name(kind) << ": too few capped steps to tell";
  }
}

// ---------------------------------------------------------------------------------------------
// 2. Bo = 0: a column of 200 disks in exact alignment (the existing column tests stop at 50 and
// 80 disks and check the floor only), loaded from zero impulses in one step by the default
// accelerated solver.
// Statics: the contact below the k-th disk from the top carries k m g; tangential forces and
// moments zero. Bound: the solver stops when no impulse changes by more than tau h m g in a
// sweep (tau = 1e-10). For an iteration contracting by rho per sweep the remaining error is at
// most change rho / (1 - rho); on a chain of n contacts the slowest mode of Gauss-Seidel has
// 1 - rho ~ pi^2 / n^2 (force diffusing along the column), so the error is below
// n^2 tau m g = 4e-6 m g (the acceleration only makes it smaller).
TEST(HardCase, ColumnOf200CarriesWeights) {
  const auto t0 = std::chrono::steady_clock::now();
  const int n = 200;
  SystemParams p = column_params(n);
  SolverSettings solver;
  solver.tolerance = 1e-10;
  solver.max_sweeps = 1000000;
  Batch batch({setup(p, column(n, 10.0))}, solver);
  batch.step();
  const auto& st = batch.status(0);
  ASSERT_EQ(st.failure, Failure::None);
  EXPECT_TRUE(st.converged);
  const double mg = p.reference_mass() * p.gravity;
  const double bound = static_cast<double>(n) * n * solver.tolerance * mg;
  double worst = 0.0;
  int checked = 0;
  for (const auto& c : batch.contacts(0)) {
    if (c.j >= 0 && c.j != c.i + 1) {
      EXPECT_NEAR(c.normal, 0.0, bound);
      continue;
    }
    const int upper = c.j < 0 ? c.i : c.j;
    const double expected = (n - upper) * mg;
    worst = std::max(worst, std::fabs(c.normal - expected));
    EXPECT_NEAR(c.normal, expected, bound) << "contact below disk " << upper;
    EXPECT_NEAR(c.tangential, 0.0, bound);
    EXPECT_NEAR(c.moment, 0.0, bound);
    ++checked;
  }
  EXPECT_EQ(checked, n);
  std::printf(
      "column of %d, %s: converged in %d sweeps (one step from zero impulses), worst "
      "force error %.3g m g (bound %.3g); %.2f s\n",
      n, solver_kind_name(solver.kind), st.last_sweeps, worst, bound, seconds_since(t0));
}

// The same column, one disk (the 100th) shifted by 1e-6 R sideways, without rolling friction:
// a disk on a disk is an inverted pendulum and the column topples (with rolling friction
// mu_r = 0.1 it would hold: the offset tilts the contacts by 5e-7 rad << mu_r). Checked:
//  - it topples: the top ends below half the column's height;
//  - the pile comes to rest (MODEL.md's rest criterion) within a cap of 40 000 steps;
//  - no failure or NaN, count preserved, 0 <= x < L_x, y >= r - bound;
//  - max overlap below d_c = 0.01 R: overlaps are never pushed apart, so what the solver
//    leaves (tolerance 1e-3 h m g per sweep, about tau h^2 g per step) and what a step's motion
//    beyond the detection margin creates accumulates; d_c is the model's contact resolution
//    (it decides which contacts are cohesive), so a larger overlap would change the physics.
TEST(HardCase, PerturbedColumnOf200TopplesAndSettles) {
  const auto t0 = std::chrono::steady_clock::now();
  const int n = 200;
  SystemParams p = bare_params(40.0, 2.0 * n + 10.0);  // the pile is about 10 layers deep
  p.friction = 0.3;
  p.rolling_friction = 0.0;
  auto disks = column(n, 10.0);
  disks[100].x += 1e-6;
  // Default (accelerated) solver with tolerance 1e-2 h m g: near rest a pile of 200 needs
  // hundreds of sweeps per step (README, "Speed"); 1e-2 keeps this test at seconds, and the
  // overlap bound below checks what the looser solve costs.
  SolverSettings solver;
  solver.tolerance = 1e-2;
  Batch batch({setup(p, disks)}, solver);
  // The column stands (at rest) until the instability has grown from 1e-6 R: step until the
  // top has fallen below half the height, then to rest. Caps: 40 000 steps for each.
  const long cap = 40000;
  long toppled_after = -1;
  for (long k = 0; k < cap && toppled_after < 0; ++k) {
    batch.step();
    if (k % 100 != 99) continue;
    double top = 0.0;
    for (const auto& a : batch.disks(0)) top = std::max(top, a.y + a.radius);
    if (top < n) toppled_after = k + 1;
  }
  ASSERT_GT(toppled_after, 0) << "the column did not topple in " << cap << " steps";
  const long steps = batch.run_to_rest(cap);
  const auto& st = batch.status(0);
  ASSERT_EQ(st.failure, Failure::None);
  const auto d = batch.disks(0);
  ASSERT_EQ(static_cast<int>(d.size()), n);
  double top = 0.0;
  for (const auto& a : d) top = std::max(top, a.y + a.radius);
  const double overlap = batch.max_overlap(0);
  std::printf(
      "perturbed column of %d: toppled after %ld steps, top %.2f R after %ld more "
      "(at rest: %d), %ld sweeps (%.1f per step), max overlap %.3g R; %.2f s\n",
      n, toppled_after, top, steps, st.at_rest ? 1 : 0, st.sweeps,
      static_cast<double>(st.sweeps) / std::max(1L, st.steps), overlap, seconds_since(t0));
  EXPECT_LT(top, static_cast<double>(n));  // toppled: below half of 2 n R
  EXPECT_TRUE(st.at_rest) << "not at rest after " << steps << " steps";
  EXPECT_LT(overlap, p.cohesion_range);
  expect_in_domain(d, p, p.cohesion_range, "toppled column");
  // The control: with rolling friction mu_r = 0.1 the same perturbed column stands as long as
  // the bare one took to topple (the offset tilts its contacts by 5e-7 rad << mu_r), so the
  // toppling is the pendulum's and not the solver's.
  p.rolling_friction = 0.1;
  Batch standing({setup(p, disks)}, solver);
  for (long k = 0; k < toppled_after; ++k) standing.step();
  double standing_top = 0.0, drift = 0.0;
  for (const auto& a : standing.disks(0)) {
    standing_top = std::max(standing_top, a.y + a.radius);
    drift = std::max(drift, std::fabs(a.x - 10.0));
  }
  EXPECT_GT(standing_top, 2.0 * n - 1e-2) << "the column with rolling friction fell";
  EXPECT_LT(drift, 1e-3) << "the column with rolling friction leans";
}

// ---------------------------------------------------------------------------------------------
// 3. Degenerate geometry. Checked in every scene: no failure, no NaN, the disk count preserved
// (what was placed is still there), every disk in the domain (0 <= x < L_x, y >= r - d_c).

// deposit_at exactly at x = 0 and x = L_x (the same abscissa in a periodic box), both drop
// rules: the second disk lands exactly on top of the first (Touch: at y = 3 R; Capture with
// r_capt = 1: the same) and both are stored inside [0, L_x). Then gravity, 500 steps: the
// exact two-disk column stands (statics: contacts carry 2 m g and m g).
TEST(HardCase, DepositAtBothEndsOfThePeriodicBox) {
  for (DropRule rule : {DropRule::Touch, DropRule::Capture}) {
    SystemParams p = bare_params(20.0, 20.0);
    p.friction = 0.3;
    p.rolling_friction = 0.1;
    p.bond_number = 10.0;
    Batch batch({setup(p, {}, 8)});
    const auto a = batch.deposit_at({1}, {p.width}, rule);  // on the bare floor
    const auto b = batch.deposit_at({1}, {0.0}, rule);
    ASSERT_TRUE(a[0].placed && b[0].placed);
    const auto d = batch.disks(0);
    ASSERT_EQ(d.size(), 2u);
    expect_in_domain(d, p, 0.0, "deposit at 0 and L_x");
    EXPECT_EQ(d[0].x, 0.0);
    EXPECT_EQ(d[1].x, 0.0);  // L_x is x = 0
    EXPECT_EQ(d[0].y, 1.0);
    EXPECT_NEAR(d[1].y, 3.0, 1e-12);
    for (int k = 0; k < 500; ++k) batch.step();
    ASSERT_EQ(batch.status(0).failure, Failure::None);
    const auto e = batch.disks(0);
    ASSERT_EQ(e.size(), 2u);
    expect_in_domain(e, p, p.cohesion_range, "two-disk column at x = 0");
    int seen = 0;  // the floor's contact and the pair's
    for (const auto& c : batch.contacts(0)) {
      if (c.j < 0) {
        ++seen;
        EXPECT_NEAR(c.normal, 2.0, 1e-6);
      } else if (c.j == 1) {
        ++seen;
        EXPECT_NEAR(c.normal, 1.0, 1e-6);
      }
    }
    EXPECT_EQ(seen, 2);
  }
}

// A crowded disk: a large disk (R = 2) on the floor with ten small ones (R = 0.5) around it,
// without gravity or friction, while a far disk moving at 20 R/sqrt(R/g) widens every pair's
// detection margin to 2 h v = 0.4 R. The large disk owns the floor and all ten pairs (lower
// index), more than its kSlots = 8 contact slots. Pairs beyond the reach of a system at rest
// (d_c + 0.05 R: kernels/contacts.hpp) are only there for the margin, so the eight nearest
// candidates keep the slots and the system goes on: its slots hold the floor, the touching
// ring and the nearest far pair. Nine candidates within that reach are more than the slots
// can hold: the system fails with ContactOverflow.
TEST(HardCase, ACrowdedDiskKeepsItsNearestCandidates) {
  auto crowd = [](const std::vector<double>& gaps) {
    std::vector<Disk> d(1);
    d[0].radius = 2.0;
    d[0].x = 10.0;
    d[0].y = 2.0;  // touching the floor
    for (std::size_t k = 0; k < gaps.size(); ++k) {
      const double angle = (-30.0 + 26.0 * static_cast<double>(k)) * M_PI / 180.0;
      Disk a;
      a.radius = 0.5;
      a.x = 10.0 + (2.5 + gaps[k]) * std::cos(angle);
      a.y = 2.0 + (2.5 + gaps[k]) * std::sin(angle);
      d.push_back(a);
    }
    Disk fast;  // far from the crowd, and the fastest disk of the system
    fast.x = 2.0;
    fast.y = 15.0;
    fast.vx = 20.0;
    d.push_back(fast);
    return d;
  };
  SystemParams p = bare_params(20.0, 20.0);
  p.gravity_on = false;
  const double touch = 1e-3;  // within d_c + 0.05 R = 0.06 R of a system at rest
  const std::vector<double> spread = {0.35, touch, 0.2,   touch, touch,
                                      0.1,  touch, touch, touch, 0.3};
  const std::vector<double> packed = {touch, touch, 0.2,   touch, touch,
                                      touch, touch, touch, touch, 0.3};
  Batch batch({setup(p, crowd(spread)), setup(p, crowd(packed))});
  for (int k = 0; k < 3; ++k) batch.step();  // the margin follows the last step's speeds
  ASSERT_EQ(batch.status(0).failure, Failure::None);
  ASSERT_GT(2.0 * p.time_step * batch.status(0).max_speed, 0.35 + p.cohesion_range);
  std::vector<double> kept;
  for (const auto& c : batch.contacts(0))
    if (c.i == 0) kept.push_back(c.j < 0 ? -1.0 : spread[static_cast<std::size_t>(c.j - 1)]);
  std::sort(kept.begin(), kept.end());
  // The floor (-1), the six touching disks and the nearest far one (0.1 R); 0.2-0.35 R dropped.
  const std::vector<double> expected = {-1.0, touch, touch, touch, touch, touch, touch, 0.1};
  EXPECT_EQ(kept, expected);
  EXPECT_EQ(batch.status(1).failure, Failure::ContactOverflow);
}

// A disk named by more contacts than its kIncident = 14 entries of incident slots hold: a large
// disk (R = 4, the highest index, so that every pair with it is its small neighbour's) floating
// without gravity, ringed by small disks (R = 0.5) each 1e-3 R from it, every pair within reach.
// With 14 around it the system goes on; with 15 it fails with ContactOverflow (its solver would
// not see the 15th contact).
TEST(HardCase, ADiskInMoreContactsThanItsIncidentSlotsFails) {
  auto ring = [](int n) {
    std::vector<Disk> d;
    for (int k = 0; k < n; ++k) {
      const double angle = 2.0 * M_PI * k / n;
      Disk a;
      a.radius = 0.5;
      a.x = 15.0 + (4.5 + 1e-3) * std::cos(angle);
      a.y = 10.0 + (4.5 + 1e-3) * std::sin(angle);
      d.push_back(a);
    }
    Disk large;
    large.radius = 4.0;
    large.x = 15.0;
    large.y = 10.0;
    d.push_back(large);
    return d;
  };
  SystemParams p = bare_params(30.0, 20.0);
  p.gravity_on = false;
  Batch batch({setup(p, ring(14)), setup(p, ring(15))});
  batch.step();
  EXPECT_EQ(batch.status(0).failure, Failure::None);
  int named = 0;
  for (const auto& c : batch.contacts(0)) named += c.j == 14;
  EXPECT_EQ(named, 14);
  EXPECT_EQ(batch.status(1).failure, Failure::ContactOverflow);
}

// Exactly touching (gap 0), exactly above each other, and at the cohesion range's edge, without
// gravity (so only the contact law acts). Contact law 2 (MODEL.md): cohesion acts while the gap
// is below d_c. With d_c = 2^-7 R and centres at dyadic positions every gap is exact in double
// precision. A pair at gap exactly d_c feels nothing and stays;
// a pair at gap d_c (1 - 1e-9) is pulled together (the pull h F_c = 0.1 per step against the
// impulse m_n gap / h = 0.39 that would close it in one: it closes over a few steps) and ends
// touching (|gap| < 1e-9 R); a touching pair stays
// touching; coincident-free vertical pairs keep their x exactly.
TEST(HardCase, TouchingStackedAndAtTheCohesionEdge) {
  SystemParams p = bare_params(20.0, 20.0);
  p.gravity_on = false;
  p.bond_number = 10.0;
  p.friction = 0.3;
  p.rolling_friction = 0.1;
  p.cohesion_range = 0.0078125;  // 2^-7: exact in binary
  const double dc = p.cohesion_range;
  auto pair = [](double x, double y, double gap, bool vertical) {
    std::vector<Disk> d(2);
    d[0].x = x;
    d[0].y = y;
    d[1].x = vertical ? x : x + 2.0 + gap;
    d[1].y = vertical ? y + 2.0 + gap : y;
    return d;
  };
  struct Scene {
    const char* name;
    std::vector<Disk> disks;
    double final_gap;  // expected
  };
  const Scene scenes[] = {
      {"touching", pair(5.0, 5.0, 0.0, false), 0.0},
      {"stacked", pair(5.0, 5.0, 0.0, true), 0.0},
      {"stacked across x = 0", pair(0.0, 5.0, 0.0, true), 0.0},
      {"touching across x = L_x", pair(19.0, 5.0, 0.0, false), 0.0},
      {"at d_c", pair(5.0, 5.0, dc, false), dc},
      {"inside d_c", pair(5.0, 5.0, dc * (1.0 - 1e-9), false), 0.0},
      {"on the floor at d_c", {Disk{5.0, 1.0 + dc}}, dc},
      {"on the floor inside d_c", {Disk{5.0, 1.0 + dc * (1.0 - 1e-9)}}, 0.0},
  };
  for (const auto& sc : scenes) {
    Batch batch({setup(p, sc.disks)});
    for (int k = 0; k < 200; ++k) batch.step();
    ASSERT_EQ(batch.status(0).failure, Failure::None) << sc.name;
    const auto d = batch.disks(0);
    ASSERT_EQ(d.size(), sc.disks.size()) << sc.name;
    expect_in_domain(d, p, 1e-9, sc.name);
    double gap;
    if (d.size() == 1) {
      gap = d[0].y - d[0].radius;
    } else {
      double dx = d[1].x - d[0].x;
      dx -= p.width * std::round(dx / p.width);
      gap = std::hypot(dx, d[1].y - d[0].y) - 2.0;
    }
    EXPECT_NEAR(gap, sc.final_gap, 1e-9) << sc.name;
    expect_within_contact_law(batch.contacts(0), d, p, sc.name);
    if (d.size() == 2 && sc.disks[1].x == sc.disks[0].x) {  // a vertical pair: no force across
      for (std::size_t k = 0; k < 2; ++k) EXPECT_EQ(d[k].x, sc.disks[k].x) << sc.name;
    }
  }
}

// One disk in a system: deposited (on the floor at y = R), it stays at rest on the floor under
// gravity (y = R to 1e-12, speed 0), and a single disk dropped from 3 R lands on the floor.
// A system with no disk at all steps without failure. A system whose H is below one diameter
// (no disk fits below H) refuses every deposit and stays empty; a box 4 R high and as narrow as the
// scan allows (smallest_width: 4 R + 2 d_c) fills until the next disk would stand above H, each placed disk counted,
// no more disk area than the box's, then relaxes under gravity with the count preserved.
TEST(HardCase, OneDiskEmptyAndFullSystems) {
  SystemParams p = bare_params(20.0, 20.0);
  p.friction = 0.3;
  p.rolling_friction = 0.1;
  p.bond_number = 100.0;
  SystemParams tiny = p;
  tiny.height = 1.5;  // no disk fits: y + r = 2 R > H
  SystemParams box = p;
  box.width = smallest_width(box);
  box.height = 4.0;
  std::vector<Disk> high(1);
  high[0].x = 7.0;
  high[0].y = 3.0;
  Batch batch({setup(p, {}, 4), setup(p, high, 4), setup(p, {}, 4), setup(tiny, {}, 4),
               setup(box, {}, 16)});
  const auto first = batch.deposit_at({1, 0, 0, 1, 0}, {3.0, 0.0, 0.0, 3.0, 0.0}, DropRule::Touch);
  EXPECT_TRUE(first[0].placed);
  EXPECT_FALSE(first[3].placed);
  int in_box = 0;
  for (int k = 0; k < 20; ++k) in_box += batch.deposit({0, 0, 0, 0, 1}, DropRule::Touch)[4].placed;
  const int box_count = batch.status(4).count;
  EXPECT_EQ(in_box, box_count);
  EXPECT_GT(box_count, 0);
  // Area bound: the disks placed fit in the box, pi R^2 each within L_x H; and each stands
  // below H (a deposit that would stand above it is refused).
  EXPECT_LE(box_count * M_PI, box.width * box.height);
  for (const Disk& d : batch.disks(4)) EXPECT_LE(d.y + d.radius, box.height);
  for (int k = 0; k < 1000; ++k) batch.step();
  for (int s = 0; s < batch.size(); ++s) {
    ASSERT_EQ(batch.status(s).failure, Failure::None) << "system " << s;
    expect_in_domain(batch.disks(s), batch.params(s), p.cohesion_range,
                     "system " + std::to_string(s));
  }
  EXPECT_EQ(batch.disks(0).size(), 1u);
  // Resting on the floor: with relaxation omega < 1 one contact is solved to the tolerance, not
  // exactly; an impulse error below tol h m g per step moves the disk by at most tol h^2 g per
  // step, and the floor contact's gap closing pulls it back, so the position error stays below
  // that (1e-7 at tol 1e-3, h = 0.01).
  const double h = batch.params(0).time_step;
  EXPECT_NEAR(batch.disks(0)[0].y, 1.0, SolverSettings{}.tolerance * h * h * p.gravity);
  EXPECT_EQ(batch.disks(0)[0].vx, 0.0);
  // Fell 2 R and rests on the floor. Its impact step (speed v = sqrt(2 g 2 R)) is solved to the
  // relative tolerance kappa m v: the last relaxed sweep (omega) changed the impulse by at most
  // that, which leaves (1 - omega) / omega of it, so the disk sinks into the floor by at most
  // h (1 - omega) / omega kappa v in that step, and the overlap is held, not pushed apart.
  const SolverSettings solver;
  const double v_impact = std::sqrt(2.0 * p.gravity * 2.0);
  const double sink =
      h * (1.0 - solver.relaxation) / solver.relaxation * solver.relative_tolerance * v_impact;
  EXPECT_LE(batch.disks(1)[0].y, 1.0 + 1e-9);
  EXPECT_GE(batch.disks(1)[0].y, 1.0 - sink);
  EXPECT_LT(batch.status(1).max_speed, 1e-9);
  EXPECT_EQ(batch.disks(2).size(), 0u);
  EXPECT_EQ(batch.disks(3).size(), 0u);
  EXPECT_EQ(static_cast<int>(batch.disks(4).size()), box_count);
  EXPECT_LT(batch.max_overlap(4), p.cohesion_range);
}

// ---------------------------------------------------------------------------------------------
// 4. Extreme parameters: a correct result, or a refusal by the scan validator before running.

namespace {
// A random drop of n disks in a 24 R box, run to rest (MODEL.md's criterion) within `cap`
// steps. Checked: at rest, no failure or NaN, count preserved, every disk in the domain,
// max overlap below d_c (the model's contact resolution, see the toppling column), contact
// forces within the contact law.
void expect_pile_at_rest(const SystemParams& p, const SolverSettings& solver, int n, long cap,
                         const std::string& what) {
  const auto t0 = std::chrono::steady_clock::now();
  Batch batch({setup(p, random_drop(n, p.width, 5))}, solver);
  const long steps = batch.run_to_rest(cap);
  const auto& st = batch.status(0);
  ASSERT_EQ(st.failure, Failure::None) << what;
  const auto d = batch.disks(0);
  ASSERT_EQ(static_cast<int>(d.size()), n) << what;
  const double overlap = batch.max_overlap(0);
  std::printf("%-28s at rest %d after %6ld steps, %7.1f sweeps/step, overlap %.2g R, %.2f s\n",
              what.c_str(), st.at_rest ? 1 : 0, steps,
              static_cast<double>(st.sweeps) / std::max(1L, st.steps), overlap, seconds_since(t0));
  EXPECT_TRUE(st.at_rest) << what << ": not at rest after " << steps << " steps";
  EXPECT_LT(overlap, p.cohesion_range) << what;
  expect_in_domain(d, p, p.cohesion_range, what);
  expect_within_contact_law(batch.contacts(0), d, p, what);
}

SystemParams pile_params() {
  SystemParams p = bare_params(24.0, 40.0);
  p.friction = 0.3;
  p.rolling_friction = 0.1;
  return p;
}
}  // namespace

TEST(HardCase, ExtremeFrictionAndBondNumbers) {
  const SolverSettings solver;
  {
    auto p = pile_params();
    p.friction = 0.0;
    expect_pile_at_rest(p, solver, 60, 20000, "mu = 0");
  }
  {
    auto p = pile_params();
    p.rolling_friction = 0.0;
    expect_pile_at_rest(p, solver, 60, 20000, "mu_r = 0");
  }
  {
    auto p = pile_params();
    p.friction = 1e6;
    expect_pile_at_rest(p, solver, 60, 20000, "mu = 1e6");
  }
  for (double bo : {1e-3, 1.0, 1e3, 1e6, 1e8}) {
    auto p = pile_params();
    p.bond_number = bo;
    char name[64];
    std::snprintf(name, sizeof name, "Bo = %g", bo);
    expect_pile_at_rest(p, solver, 60, 20000, name);
  }
}

// Time steps: the largest the scan allows (h = 0.1) on a pile, and a small one (1e-4) on a disk
// falling 0.01 R onto the floor (1.4e3 steps) and a 5-disk column: statics (forces k m g within
// 1e-6, impulses are in units of h m g so the tolerance scales with h), the disk at rest on the
// floor (y = R to 1e-9, the tolerance-limited overlap tau h^2 g per step).
TEST(HardCase, ExtremeTimeSteps) {
  {
    auto p = pile_params();
    p.time_step = 0.1;
    expect_pile_at_rest(p, SolverSettings{}, 60, 20000, "h = 0.1");
  }
  auto p = pile_params();
  p.time_step = 1e-4;
  std::vector<Disk> falling(1);
  falling[0].x = 3.0;
  falling[0].y = 1.01;
  auto col = column(5, 12.0);
  SolverSettings s;
  s.tolerance = 1e-10;
  s.max_sweeps = 100000;
  Batch batch({setup(p, falling), setup(p, col)}, s);
  for (int k = 0; k < 6000; ++k) batch.step();
  for (int sys = 0; sys < 2; ++sys) {
    ASSERT_EQ(batch.status(sys).failure, Failure::None);
    expect_in_domain(batch.disks(sys), p, 1e-9, "h = 1e-4");
  }
  EXPECT_NEAR(batch.disks(0)[0].y, 1.0, 1e-9);
  EXPECT_LT(batch.status(0).max_speed, 1e-9);
  int seen = 0;  // the floor's contact and the 4 between neighbours
  for (const auto& c : batch.contacts(1)) {
    if (c.j >= 0 && c.j != c.i + 1) continue;
    ++seen;
    const int upper = c.j < 0 ? c.i : c.j;
    EXPECT_NEAR(c.normal, 5 - upper, 1e-6);
  }
  EXPECT_EQ(seen, 5);
}

// Beyond the supported ranges the scan validator refuses before anything runs, naming
// file:line:column, the key, and why (docs/MODEL.md, "Supported ranges").
TEST(HardCase, ValidatorRefusesUnsupportedParameters) {
  const std::vector<scan_errors::Case> cases = {
      {"[system]\nbond_number = 1e9\n", "bad.toml:2:15: key 'system.bond_number': Bo must be"},
      {"[system]\ntime_step = 0.2\n", "bad.toml:2:13: key 'system.time_step': h must be"},
      {"[system]\ntime_step = 0\n", "bad.toml:2:13: key 'system.time_step': h must be"},
      // H = 150: a fall through the box reaches v = sqrt(2 g 152) = 17.4, 2 h v = 1.75 R.
      {"[system]\ntime_step = 0.05\n",
       "bad.toml:2:13: key 'system.time_step': h = 0.05 is too large for H = 150"},
      {"[system]\nfriction = \"inf\"\n", "bad.toml:2:12: key 'system.friction': mu must be"},
      {"[system]\nrolling_friction = -0.1\n",
       "bad.toml:2:20: key 'system.rolling_friction': mu_r must be"},
  };
  scan_errors::expect_refused(cases);
  // The edges of the ranges are accepted.
  // (h = 0.1 with H = 20: 2 h (sqrt(2 g 22) + h g) = 1.35 R, within the 1.4 R of detection.)
  EXPECT_NO_THROW(
      parse_scan("[system]\nbond_number = [0, 1e-3, 1e8, \"inf\"]\ntime_step = 0.1\n"
                 "height = 20\nfriction = [0, 1e6]\nrolling_friction = 0\n"
                 "[observables]\nlower_half_from = 2\n",
                 "ok.toml"));
}

// A disk falling through a tall box lands without a missed impact: at h = 0.045 a fall of 98 R
// ends at v = sqrt(2 g 98) = 14 sqrt(gR), so a disk moves h v = 0.63 R in one step, more than
// the old fixed detection margin of R/2 (it then overlapped by up to that); the margin now grows
// to cover a fall through the whole box (src/batch.cpp, grid_shape; 2 h (v + h g) = 1.29 R, in
// the supported range). Checked: the falling disk comes to rest on the one below it with an
// overlap below d_c (the solver never pushes an overlap apart), and on the floor beside it.
TEST(HardCase, FallThroughATallBoxIsCaught) {
  auto p = scenes::bare_params(20.0, 100.0);
  p.time_step = 0.045;
  p.friction = 0.5;  // a stack of two frictionless disks topples at the slightest residual
  p.rolling_friction = 0.1;
  // Disk 0 rests on the floor, disk 1 falls onto it; disks 2-9 fall onto the floor from
  // heights spread over one step's travel, so that some reach the contact between two checks.
  std::vector<Disk> d(10);
  d[0].x = 1.0;
  d[0].y = 1.0;
  d[1].x = 1.0;
  d[1].y = 99.0;
  for (int k = 2; k < 10; ++k) {
    d[static_cast<std::size_t>(k)].x = 2.0 * k + 0.5;
    d[static_cast<std::size_t>(k)].y = 99.0 - 0.08 * k;
  }
  SolverSettings s;
  s.tolerance = 1e-8;
  Batch batch({setup(p, d)}, s);
  for (int k = 0; k < 1500; ++k) batch.step();
  ASSERT_EQ(batch.status(0).failure, Failure::None);
  const auto out = batch.disks(0);
  EXPECT_LT(batch.max_overlap(0), p.cohesion_range);
  EXPECT_NEAR(out[1].y, 3.0, p.cohesion_range);
  for (int k = 2; k < 10; ++k)
    EXPECT_NEAR(out[static_cast<std::size_t>(k)].y, 1.0, p.cohesion_range);
  expect_in_domain(out, p, p.cohesion_range, "fall through a tall box");
}
