// The validation cases of docs/VALIDATION.md with their exact answers.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "loosepack/batch.hpp"
#include "loosepack/scenes.hpp"
#include "tests/run_helpers.hpp"

using namespace loosepack;
using namespace loosepack::scenes;

namespace {
SolverSettings tight(SolverKind kind = SolverKind::GaussSeidel) {
  SolverSettings s;
  s.kind = kind;
  s.tolerance = 1e-10;
  s.max_sweeps = 200000;
  return s;
}
}  // namespace

// 1. Column of N disks: the contact below the k-th disk from the top carries k m g.
TEST(Validation, ColumnCarriesWeights) {
  const int n = 50;
  auto p = bare_params(20.0, 110.0);
  p.friction = 0.3;
  p.rolling_friction = 0.1;
  Batch batch({setup(p, column(n, 10.0))}, tight());
  for (int k = 0; k < 20; ++k) batch.step();
  ASSERT_EQ(batch.status(0).failure, Failure::None);
  EXPECT_TRUE(batch.status(0).converged);
  const double mg = p.reference_mass() * p.gravity;
  int checked = 0;
  for (const auto& c : batch.contacts(0)) {
    const int upper = c.j < 0 ? c.i : c.j;  // the upper disk of the pair
    if (c.j >= 0 && c.j != c.i + 1) {
      EXPECT_NEAR(c.normal, 0.0, 1e-9);  // no other contacts should carry force
      continue;
    }
    const int from_top = n - upper;  // disks at and above `upper`
    EXPECT_NEAR(c.normal, from_top * mg, 1e-6 * from_top * mg) << "contact below disk " << upper;
    EXPECT_NEAR(c.tangential, 0.0, 1e-9);
    ++checked;
  }
  EXPECT_EQ(checked, n);
  const auto d = batch.disks(0);
  for (int k = 0; k < n; ++k) {
    EXPECT_NEAR(d[k].x, 10.0, 1e-9);
    EXPECT_NEAR(d[k].y, 1.0 + 2.0 * k, 1e-6);
  }
  std::printf("column of %d: %ld sweeps over 20 steps\n", n, batch.status(0).sweeps);
}

// The same with disks of any radius: a column of radii alternating 1 and 2.5 R (masses
// rho pi r^2, 1 and 6.25 m) carries under each disk the weight of those above it, m_k = rho pi
// r_k^2 each, and the disks stack at y_k = y_(k-1) + r_(k-1) + r_k. Checked against the wrong
// law: every disk given the reference mass (rho pi R^2) fails it.
TEST(Validation, ColumnOfUnequalDisksCarriesTheirR2Weights) {
  const int n = 20;
  auto p = bare_params(20.0, 120.0);
  p.friction = 0.3;
  p.rolling_friction = 0.1;
  std::vector<Disk> disks(static_cast<std::size_t>(n));
  double y = 0.0;
  for (int k = 0; k < n; ++k) {
    Disk& d = disks[static_cast<std::size_t>(k)];
    d.radius = k % 2 == 0 ? 1.0 : 2.5;
    y += (k == 0 ? 0.0 : disks[static_cast<std::size_t>(k - 1)].radius) + d.radius;
    d.x = 10.0;
    d.y = y;
  }
  Batch batch({setup(p, disks)}, tight());
  for (int k = 0; k < 20; ++k) batch.step();
  ASSERT_EQ(batch.status(0).failure, Failure::None);
  auto weight = [&](int from) {  // of disks from..n-1
    double w = 0.0;
    for (int k = from; k < n; ++k) {
      const double r = disks[static_cast<std::size_t>(k)].radius;
      w += p.disk_density * M_PI * r * r * p.gravity;
    }
    return w;
  };
  int checked = 0;
  for (const auto& c : batch.contacts(0)) {
    if (c.j >= 0 && c.j != c.i + 1) continue;
    const int upper = c.j < 0 ? c.i : c.j;
    EXPECT_NEAR(c.normal, weight(upper), 1e-6 * weight(upper)) << "contact below disk " << upper;
    ++checked;
  }
  EXPECT_EQ(checked, n);
  const auto d = batch.disks(0);
  for (int k = 0; k < n; ++k)
    EXPECT_NEAR(d[static_cast<std::size_t>(k)].y, disks[static_cast<std::size_t>(k)].y, 1e-6);
}

// The column converges with Jacobi too (mass splitting), to the same forces.
TEST(Validation, ColumnJacobiMatchesWeights) {
  const int n = 20;
  auto p = bare_params(20.0, 50.0);
  p.friction = 0.3;
  Batch batch({setup(p, column(n, 10.0))}, tight(SolverKind::Jacobi));
  for (int k = 0; k < 10; ++k) batch.step();
  ASSERT_TRUE(batch.status(0).converged);
  const double mg = p.reference_mass() * p.gravity;
  int seen = 0;  // the floor's contact and the n - 1 between neighbours
  for (const auto& c : batch.contacts(0)) {
    if (c.j >= 0 && c.j != c.i + 1) continue;
    ++seen;
    const int upper = c.j < 0 ? c.i : c.j;
    EXPECT_NEAR(c.normal, (n - upper) * mg, 1e-6 * (n - upper) * mg);
  }
  EXPECT_EQ(seen, n);
  std::printf("column of %d, Jacobi: %ld sweeps over 10 steps\n", n, batch.status(0).sweeps);
}

// 2. Three-disk pyramid without rolling friction.
TEST(Validation, PyramidForcesAndStability) {
  const double threshold = 2.0 - std::sqrt(3.0);  // 0.2679
  // Within 0.5 % of the threshold on both sides, and far. Checked against the wrong law: a
  // friction bound 1 % low (0.99 mu in kernels/solver.hpp) fails at 1.005 of the threshold.
  for (double mu : {0.3, 1.005 * threshold, 0.995 * threshold, 0.25}) {
    auto p = bare_params();
    p.friction = mu;
    Batch batch({setup(p, pyramid())}, tight());
    for (int k = 0; k < 1000; ++k) batch.step();  // 10 time units
    const auto d = batch.disks(0);
    const double drop = pyramid()[2].y - d[2].y;
    if (mu >= threshold) {
      EXPECT_LT(drop, 1e-6) << "mu = " << mu;
      int upper = 0;
      for (const auto& c : batch.contacts(0)) {
        if (c.j != 2) continue;
        EXPECT_NEAR(c.normal, 0.5, 1e-6);
        EXPECT_NEAR(std::fabs(c.tangential), threshold / 2.0, 1e-6);
        ++upper;
      }
      EXPECT_EQ(upper, 2);
    } else {
      EXPECT_GT(drop, 0.1) << "mu = " << mu << " should collapse";
    }
  }
}

// 3. Disk on an incline: the floor with gravity tilted by theta.
namespace {
SystemParams incline(double theta, double mu, double mu_r) {
  auto p = bare_params(1000.0, 10.0);
  p.friction = mu;
  p.rolling_friction = mu_r;
  p.gravity_dir_x = std::sin(theta);
  p.gravity_dir_y = -std::cos(theta);
  return p;
}
std::vector<Disk> one_disk(bool lock_rotation = false, double radius = 1.0) {
  std::vector<Disk> d(1);
  d[0].x = 100.0;
  d[0].y = radius;
  d[0].radius = radius;
  d[0].lock_rotation = lock_rotation;
  return d;
}
// Distance the disk travels down the slope in time t (with floor cohesion Bo: the disk stuck to
// the incline by F_c = Bo m g).
double slide(double theta, double mu, double mu_r, bool lock, double t, double* speed = nullptr,
             double bo = 0.0, double radius = 1.0, double* spin = nullptr) {
  SystemParams p = incline(theta, mu, mu_r);
  p.bond_number = bo;
  p.floor_cohesion = bo > 0.0;
  p.radius = radius;
  Batch batch({setup(p, one_disk(lock, radius))}, tight());
  const int steps = static_cast<int>(std::lround(t / 0.01));
  for (int k = 0; k < steps; ++k) batch.step();
  const auto d = batch.disks(0);
  if (speed) *speed = d[0].vx;
  if (spin) *spin = d[0].w;
  EXPECT_NEAR(d[0].y, radius, 1e-9);  // stays on the incline
  return d[0].x - 100.0;
}
}  // namespace

// Static iff tan theta <= mu, to 1e-6 of the threshold on both sides, and beyond it slides with
// a = g (sin theta - mu cos theta) however small.
TEST(Validation, InclineRotationLockedStaticIffTanBelowMu) {
  const double mu = 0.3;
  for (double f : {1e-6, 0.02}) {
    EXPECT_LT(std::fabs(slide(std::atan((1.0 - f) * mu), mu, 0.0, true, 2.0)), 1e-12) << f;
    const double theta = std::atan((1.0 + f) * mu);
    double v = 0.0;
    slide(theta, mu, 0.0, true, 2.0, &v);
    const double a = std::sin(theta) - mu * std::cos(theta);  // g = 1
    EXPECT_NEAR(v, a * 2.0, 1e-3 * a * 2.0) << f;
  }
}

// The cohesive shift of the Coulomb bound, |P_t| <= mu (P_n + h F_c), binding: a disk stuck to
// the incline by floor cohesion F_c = Bo m g (rotation locked) holds iff
// sin theta <= mu (cos theta + Bo), and beyond slides with a = g (sin theta - mu (cos theta + Bo)).
// Checked against the wrong law: with the bound unshifted (mu P_n in kernels/solver.hpp) both
// assertions fail (the disk slides from tan theta = mu, 35 degrees below this threshold).
TEST(Validation, CohesiveInclineStaticIffSinBelowMuTimesCosPlusBo) {
  const double mu = 0.3, bo = 2.0;
  const double theta_c = std::atan(mu) + std::asin(mu * bo / std::sqrt(1.0 + mu * mu));
  EXPECT_LT(std::fabs(slide(0.995 * theta_c, mu, 0.0, true, 2.0, nullptr, bo)), 1e-9);
  const double theta = 1.005 * theta_c;
  double v = 0.0;
  slide(theta, mu, 0.0, true, 2.0, &v, bo);
  const double a = std::sin(theta) - mu * (std::cos(theta) + bo);  // g = 1
  ASSERT_GT(a, 0.0);
  EXPECT_NEAR(v, a * 2.0, 1e-3 * a * 2.0);
}

// Detachment under combined tension and shear: the same disk stuck under a ceiling (the floor,
// gravity pulling it away at theta from the normal), rotation locked. The contact carries the
// tension m g cos theta (held while cos theta <= Bo) and the shear m g sin theta, bounded by
// mu (P_n + F_c) with P_n = -m g cos theta in tension: static iff sin theta <= mu (Bo - cos theta),
// theta_c = asin(mu Bo / sqrt(1 + mu^2)) - atan(mu), else it slides along the ceiling, still
// attached, with a = g (sin theta - mu (Bo - cos theta)). Bo = 2, mu = 0.3: theta_c = 18.4 deg;
// a bound written with + cos theta (compression's sign) would hold it to 51.8 deg and fails.
TEST(Validation, CohesiveCeilingSlidesIffSinAboveMuTimesBoMinusCos) {
  const double mu = 0.3, bo = 2.0, t = 2.0;
  const double theta_c = std::asin(mu * bo / std::sqrt(1.0 + mu * mu)) - std::atan(mu);
  const auto hang = [&](double theta, double* speed) {
    SystemParams p = incline(theta, mu, 0.0);
    p.gravity_dir_y = std::cos(theta);  // away from the floor
    p.bond_number = bo;
    Batch batch({setup(p, one_disk(true))}, tight());
    for (int k = 0; k < static_cast<int>(std::lround(t / 0.01)); ++k) batch.step();
    const auto d = batch.disks(0);
    *speed = d[0].vx;
    EXPECT_NEAR(d[0].y, 1.0, 1e-9) << "theta " << theta << ": it came off the ceiling";
    return d[0].x - 100.0;
  };
  double v = 0.0;
  EXPECT_LT(std::fabs(hang(0.995 * theta_c, &v)), 1e-9);
  const double theta = 1.005 * theta_c;
  hang(theta, &v);
  const double a = std::sin(theta) - mu * (bo - std::cos(theta));  // g = 1
  ASSERT_GT(a, 0.0);
  EXPECT_NEAR(v, a * t, 1e-3 * a * t);
}

// A disk free to roll on an incline (mu = 0.3) is held by the rolling bound iff tan theta <= mu_r.
// Beyond the threshold it rolls against the rolling moment mu_r R N: m a = m g sin theta - F,
// (m R^2 / 2) a / R = F R - mu_r R m g cos theta, so a = (2/3) g (sin theta - mu_r cos theta);
// in n steps of h the discrete motion covers a h^2 n (n + 1) / 2 (2.67e-3 R here).
TEST(Validation, InclineRollingFrictionStaticIffTanBelowMuR) {
  const double mu = 0.3, mu_r = 0.1;  // threshold atan(0.1) = 5.71 degrees
  // At R = 1 and 2.5: the lever mu_r R_c makes the threshold and the acceleration independent
  // of R (a lever mu_r, without R_c, fails at R = 2.5: it rolls at 0.98 of the threshold).
  for (double radius : {1.0, 2.5}) {
    EXPECT_LT(std::fabs(slide(std::atan(0.98 * mu_r), mu, mu_r, false, 2.0, nullptr, 0.0, radius)),
              1e-9)
        << "R = " << radius;
    const double theta = std::atan(1.02 * mu_r), t = 2.0, h = 0.01;
    const double a = 2.0 / 3.0 * (std::sin(theta) - mu_r * std::cos(theta));
    const double n = std::round(t / h);
    double v = 0.0;
    const double x = slide(theta, mu, mu_r, false, t, &v, 0.0, radius);
    EXPECT_NEAR(x, a * h * h * n * (n + 1) / 2.0, 1e-3 * x) << "R = " << radius;
    EXPECT_NEAR(v, a * n * h, 1e-3 * v) << "R = " << radius;
  }
}

// With mu < mu_r the rolling moment holds the rotation that sliding friction drives (mu N R <
// mu_r N R): static iff tan theta <= mu, beyond it the disk slides without turning, with
// a = g (sin theta - mu cos theta) as if its rotation were locked (the coupled friction and
// rolling solve, kernels/contact_law.hpp).
TEST(Validation, InclineWithMuBelowMuRSlidesWithoutTurning) {
  const double mu = 0.1, mu_r = 0.3;
  EXPECT_LT(std::fabs(slide(std::atan(0.98 * mu), mu, mu_r, false, 2.0)), 1e-9);
  const double theta = std::atan(1.02 * mu);
  double v = 0.0, w = 1.0;
  slide(theta, mu, mu_r, false, 2.0, &v, 0.0, 1.0, &w);
  const double a = std::sin(theta) - mu * std::cos(theta);
  EXPECT_NEAR(v, a * 2.0, 1e-3 * a * 2.0);
  // Unturned: rolling would turn it at v / R (here 0.04 / tau after 2 tau).
  EXPECT_LT(std::fabs(w), 1e-6 * v);
}

TEST(Validation, InclineRollsWithTwoThirdsGSinTheta) {
  const double mu = 0.3;
  for (double theta : {0.2, std::atan(2.9 * mu)}) {  // below the 3 mu rolling limit
    double v = 0.0;
    const double t = 2.0;
    slide(theta, mu, 0.0, false, t, &v);
    const double expected = 2.0 / 3.0 * std::sin(theta) * t;
    EXPECT_NEAR(v, expected, 1e-3 * expected) << "theta = " << theta;
  }
  // Beyond tan(theta) = 3 mu it slides from the start, friction at its bound: a = g (sin theta -
  // mu cos theta), 1.045 times the rolling 2/3 g sin theta here.
  const double theta = std::atan(3.3 * mu), t = 2.0;
  double v = 0.0;
  slide(theta, mu, 0.0, false, t, &v);
  const double sliding = (std::sin(theta) - mu * std::cos(theta)) * t;
  EXPECT_NEAR(v, sliding, 1e-3 * sliding);
}

// Free fall is Moreau-Jean's discrete motion exactly (v_n = v_0 - n g h, y_n = y_(n-1) + h v_n):
// y_n = y_0 + n h v_0 - g h^2 n (n + 1) / 2, to rounding, whatever h; the continuous parabola
// differs from it by g h t / 2 (first order in h).
TEST(Validation, FreeFallIsTheDiscreteMotionExactly) {
  for (double h : {0.01, 0.0028, 1e-3}) {
    auto p = bare_params(20.0, 200.0);
    p.time_step = h;
    std::vector<Disk> d(1);
    d[0].x = 10.0;
    d[0].y = 150.0;
    d[0].vy = 0.5;
    Batch batch({setup(p, d)}, tight());
    const int n = static_cast<int>(std::lround(2.0 / h));
    for (int k = 0; k < n; ++k) batch.step();
    const auto e = batch.disks(0);
    const double expected = 150.0 + n * h * 0.5 - h * h * n * (n + 1) / 2.0;  // g = 1
    EXPECT_NEAR(e[0].y, expected, 1e-9) << "h = " << h;
    EXPECT_NEAR(e[0].vy, 0.5 - n * h, 1e-12) << "h = " << h;
  }
}

// 4. Disk launched sliding on the floor.
namespace {
// A disk at x = 100 launched at v0 along the floor, friction mu, no spin, solved tightly while
// it moves too (no relative tolerance).
Batch sliding_disk(double mu, double v0, double h) {
  auto p = bare_params(1000.0, 10.0);
  p.friction = mu;
  p.time_step = h;
  auto d = one_disk();
  d[0].vx = v0;
  SolverSettings solver = tight();
  solver.relative_tolerance = 0.0;
  return Batch({setup(p, d)}, solver);
}
}  // namespace

TEST(Validation, SlidingDiskStartsRollingAtTwoThirdsV0) {
  const double mu = 0.3, v0 = 2.0, h = 1e-3;
  Batch batch = sliding_disk(mu, v0, h);
  const double t_slide = v0 / (3.0 * mu);
  const double x_slide = 5.0 * v0 * v0 / (18.0 * mu);
  const double t_end = 2.0 * t_slide;
  // While it slides, friction mu m g decelerates it and spins it up: v = v0 - mu g t,
  // R w = -2 mu g t (the torque mu m g R on the inertia m R^2 / 2), to the solver's tolerance.
  const int half = static_cast<int>(std::lround(0.5 * t_slide / h));
  for (int k = 0; k < half; ++k) batch.step();
  const auto m = batch.disks(0);
  EXPECT_NEAR(m[0].vx, v0 - mu * half * h, 1e-6);
  EXPECT_NEAR(m[0].w * m[0].radius, -2.0 * mu * half * h, 1e-6);
  const int steps = static_cast<int>(std::lround(t_end / h));
  for (int k = half; k < steps; ++k) batch.step();
  const auto e = batch.disks(0);
  // The slip ends within a step of t_slide: speed and distance within mu g h of the continuous
  // answer (2e-4 of them here).
  EXPECT_NEAR(e[0].vx, 2.0 * v0 / 3.0, 1e-3 * 2.0 * v0 / 3.0);
  EXPECT_NEAR(e[0].w * e[0].radius, -e[0].vx, 1e-9);  // rolling: no slip
  const double x_expected = x_slide + 2.0 * v0 / 3.0 * (t_end - t_slide);
  EXPECT_NEAR(e[0].x - 100.0, x_expected, 1e-3 * x_expected);
}

// 5. Cohesive chain hanging from a ceiling (the floor, with gravity reversed), and without the
// floor's cohesion.
TEST(Validation, HangingChainHoldsIffNAtMostBo) {
  const double bo = 5.0;
  for (int n : {5, 6}) {
    auto p = bare_params(20.0, 30.0);
    p.bond_number = bo;
    p.friction = 0.3;
    p.rolling_friction = 0.1;
    p.gravity_dir_y = 1.0;  // away from the floor, which is the ceiling
    Batch batch({setup(p, column(n, 10.0))}, tight());
    for (int k = 0; k < 200; ++k) batch.step();
    const auto d = batch.disks(0);
    const double gap = d[0].y - d[0].radius;
    if (n <= bo) {
      EXPECT_LT(gap, 1e-9) << n << " disks should hang";
    } else {
      EXPECT_GT(gap, 10.0 * p.cohesion_range) << n << " disks should fall";
    }
  }
  // system.floor_cohesion = false: the ceiling does not attract, so even a chain of n <= Bo
  // falls off it, whole (in free fall its disks press on nothing, so their cohesion holds them).
  auto p = bare_params(20.0, 30.0);
  p.bond_number = bo;
  p.friction = 0.3;
  p.rolling_friction = 0.1;
  p.gravity_dir_y = 1.0;
  p.floor_cohesion = false;
  Batch batch({setup(p, column(3, 10.0))}, tight());
  for (int k = 0; k < 200; ++k) batch.step();
  const auto d = batch.disks(0);
  EXPECT_GT(d[0].y - d[0].radius, 10.0 * p.cohesion_range) << "the chain should fall";
  for (int a = 1; a < 3; ++a)
    EXPECT_LT(d[a].y - d[a - 1].y - d[a].radius - d[a - 1].radius, p.cohesion_range)
        << "the chain should stay whole";
}

// 6. Pull-off barrier: escape iff v > sqrt(2 F_c d_c / m_n), approached as h shrinks.
namespace {
// Disk 1 (radius r1, mass r1^2 m) leaves disk 0 (R, m) at speed v: whether it gets away.
bool escapes(double v, double h, double bo, double dc, double r1 = 1.0) {
  auto p = bare_params(40.0, 10.0);
  p.gravity_on = false;
  p.bond_number = bo;
  p.cohesion_range = dc;
  p.time_step = h;
  std::vector<Disk> d(2);
  d[0].x = 10.0;
  d[0].y = 5.0;
  d[1].x = 11.0 + r1;
  d[1].y = 5.0;
  d[1].radius = r1;
  d[1].vx = v;
  Batch batch({setup(p, d)}, tight());
  // Long enough to cross the range at a tenth of the threshold speed several times over.
  const int steps = static_cast<int>(std::ceil(20.0 * dc / (0.1 * v) / h)) + 10;
  for (int k = 0; k < steps; ++k) batch.step();
  const auto e = batch.disks(0);
  return e[1].x - e[0].x - 1.0 - r1 > dc;
}

double escape_threshold(double h, double bo, double dc, double v_lo, double v_hi) {
  for (int it = 0; it < 24; ++it) {
    const double mid = 0.5 * (v_lo + v_hi);
    (escapes(mid, h, bo, dc) ? v_hi : v_lo) = mid;
  }
  return 0.5 * (v_lo + v_hi);
}
}  // namespace

TEST(Validation, PullOffBarrier) {
  const double bo = 10.0, dc = 0.01, m_n = 0.5;
  const double v_star = std::sqrt(2.0 * bo * dc / m_n);   // F_c = Bo m g with m = g = 1
  const double h_scale = std::sqrt(2.0 * m_n * dc / bo);  // sqrt(2 m_n d_c / F_c) = 0.032
  const double h1 = h_scale / 10.0, h2 = h_scale / 100.0;
  EXPECT_FALSE(escapes(0.95 * v_star, h2, bo, dc));
  EXPECT_TRUE(escapes(1.05 * v_star, h2, bo, dc));
  const double t1 = escape_threshold(h1, bo, dc, 0.5 * v_star, 2.0 * v_star);
  const double t2 = escape_threshold(h2, bo, dc, 0.5 * v_star, 2.0 * v_star);
  std::printf("pull-off threshold / v*: h = %.2g: %.4f, h = %.2g: %.4f\n", h1, t1 / v_star, h2,
              t2 / v_star);
  EXPECT_LT(std::fabs(t2 - v_star), std::fabs(t1 - v_star));  // converges as h shrinks
  EXPECT_NEAR(t2, v_star, 0.02 * v_star);
}

// Unequal disks: the barrier F_c d_c is the same (F_c = Bo m g from the reference disk's mass,
// whatever the pair), the kinetic energy of the relative motion m_n v^2 / 2 with the reduced
// mass m_n = m_0 m_1 / (m_0 + m_1) = 0.8 m for radii R and 2 R (masses m and 4 m). Checked
// against the wrong law: F_c from the larger disk's mass (4 Bo m g) fails the escape at 1.05 v*.
TEST(Validation, PullOffBarrierOfUnequalDisks) {
  const double bo = 10.0, dc = 0.01, m_n = 1.0 * 4.0 / (1.0 + 4.0);
  const double v_star = std::sqrt(2.0 * bo * dc / m_n);
  const double h = std::sqrt(2.0 * m_n * dc / bo) / 100.0;
  EXPECT_FALSE(escapes(0.95 * v_star, h, bo, dc, 2.0));
  EXPECT_TRUE(escapes(1.05 * v_star, h, bo, dc, 2.0));
}

// 11. A disk between two fixed disks, each within the cohesive range but not touching it (gap g0
// < d_c): both pull with F_c (the gap closes at neither, the pulls cancel along their line), and
// at the full pull the Coulomb bound mu (P_n + h F_c) is zero, so the disk moves across that line
// without friction. Displaced by s, it feels -2 F_c s / sqrt(D^2 + s^2) (D = 2 R + g0, the
// distance from its centre to each of theirs): a harmonic oscillation with omega^2 = 2 F_c / (m D)
// for s << D, kept by nothing from going on for ever (the gaps grow by s^2 / (2 D) only, and stay
// open). Touching its neighbours (g0 = 0) the same disk stops within a step: closed, its contacts
// hold friction. Such disks keep a dense cohesive packing from coming to rest (docs/PERFORMANCE.md,
// "What keeps a dense collapse moving").
namespace {
struct Rattle {
  std::vector<double> s;  // the disk's displacement across the line, after each step
  double max_gap = 0.0, min_gap = 1e9;
};
// The disk (index 1) between its two fixed neighbours, at gaps g0, set moving across their line
// at v0.
Batch rattling(double g0, double v0, double h) {
  auto p = bare_params(40.0, 20.0);
  p.gravity_on = false;
  p.bond_number = 1000.0;
  p.friction = 0.3;
  p.rolling_friction = 0.1;
  p.time_step = h;
  const double D = 2.0 + g0;
  std::vector<Disk> d(3);
  for (int k = 0; k < 3; ++k) {
    d[static_cast<std::size_t>(k)].x = 20.0 + (k - 1) * D;
    d[static_cast<std::size_t>(k)].y = 10.0;
    d[static_cast<std::size_t>(k)].fixed = k != 1;
  }
  d[1].vy = v0;
  return Batch({setup(p, d)}, tight());
}

Rattle rattle(double g0, double v0, double h, int steps) {
  Batch batch = rattling(g0, v0, h);
  Rattle r;
  for (int k = 0; k < steps; ++k) {
    batch.step();
    const auto e = batch.disks(0);
    r.s.push_back(e[1].y - 10.0);
    for (int side : {0, 2}) {
      const auto& n = e[static_cast<std::size_t>(side)];
      const double gap = std::hypot(e[1].x - n.x, e[1].y - n.y) - 2.0;
      r.max_gap = std::max(r.max_gap, gap);
      r.min_gap = std::min(r.min_gap, gap);
    }
  }
  return r;
}
}  // namespace

TEST(Validation, DiskPulledFromBothSidesOscillatesWithoutLoss) {
  const double g0 = 0.004, v0 = 1.0, h = 0.0028, f_c = 1000.0, D = 2.0 + g0;
  const double omega = std::sqrt(2.0 * f_c / D), period = 2.0 * M_PI / omega;
  const int steps = static_cast<int>(10.0 * period / h);
  const Rattle r = rattle(g0, v0, h, steps);
  // Upward zero crossings of s: whole periods.
  std::vector<double> up;
  for (std::size_t k = 1; k < r.s.size(); ++k)
    if (r.s[k - 1] < 0.0 && r.s[k] >= 0.0)
      up.push_back(h * (k - r.s[k] / (r.s[k] - r.s[k - 1])));  // interpolated, in time
  ASSERT_GE(up.size(), 9u);
  const double measured = (up.back() - up.front()) / static_cast<double>(up.size() - 1);
  std::printf("rattle: period %.5f against 2 pi / omega = %.5f\n", measured, period);
  EXPECT_NEAR(measured, period, 5e-3 * period);
  // No loss: the last period's largest displacement is the first's, v0 / omega.
  const auto last = r.s.end() - static_cast<long>(period / h);
  const double first_amp =
      *std::max_element(r.s.begin(), r.s.begin() + static_cast<long>(period / h));
  const double last_amp = *std::max_element(last, r.s.end());
  EXPECT_NEAR(first_amp, v0 / omega, 5e-3 * v0 / omega);
  EXPECT_NEAR(last_amp, first_amp, 5e-3 * first_amp);
  // Both contacts stay open and inside the range throughout.
  EXPECT_GT(r.min_gap, 0.0);
  EXPECT_LT(r.max_gap, bare_params().cohesion_range);
  // Touching its neighbours, the disk stops at once: it moves in no step, the first included.
  const Rattle touching = rattle(0.0, v0, h, 5);
  for (std::size_t k = 0; k < touching.s.size(); ++k)
    EXPECT_LT(std::fabs(touching.s[k] - (k > 0 ? touching.s[k - 1] : 0.0)), 1e-9) << "step " << k;
}

// The averaged rest test (Batch::set_average_span, RestSettings::average_span) ends what the speed
// test cannot: the disk of case 11 oscillating without loss at amplitude A = v0 / omega. Averaged
// over a span of time W its position lies within 2 A / (omega W) of the centre, so two spans'
// means differ by at most 4 A / (omega W) and the mean speed is at most 4 A / (omega W^2): 1.6e-4
// sqrt(gR) for W = 5, under the rest speed 1e-3, and the system is at rest when the second span
// ends, not a step before. A disk drifting at a constant v (across the periodic edge) moves its
// mean by v W from span to span: its mean speed is v, and at 2e-3 it is not at rest.
TEST(Validation, AveragedRestEndsAnOscillationButNotADrift) {
  const double g0 = 0.004, v0 = 1.0, h = 0.0028, D = 2.0 + g0;
  const double omega = std::sqrt(2.0 * 1000.0 / D), amplitude = v0 / omega;
  const int n = static_cast<int>(std::lround(5.0 / h));
  const double span = n * h;
  Batch batch = rattling(g0, v0, h);
  batch.set_average_span(0, n);
  // Taken up from its state half-way through the second span, the test goes on bit for bit.
  Batch again = rattling(g0, v0, h);
  for (int k = 0; k < 2 * n - 1; ++k) {
    batch.step();
    ASSERT_FALSE(batch.status(0).at_rest) << "step " << k + 1;
    ASSERT_LT(batch.status(0).mean_speed, 0.0) << "step " << k + 1;
    if (k + 1 != 3 * n / 2) continue;
    const Batch::SystemState state = batch.state(0);
    EXPECT_EQ(state.spans, 1);
    SystemSetup su = setup(batch.params(0), state.disks);
    again.reset(0, su);
    again.restore(0, state);
  }
  batch.step();
  for (int k = 3 * n / 2; k < 2 * n; ++k) again.step();
  EXPECT_TRUE(again.status(0).at_rest);
  EXPECT_EQ(again.status(0).mean_speed, batch.status(0).mean_speed);
  const SystemStatus& st = batch.status(0);
  std::printf("averaged rest: mean speed %.3e after two spans, bound %.3e, speed %.3f\n",
              st.mean_speed, 4.0 * amplitude / (omega * span * span), st.max_speed);
  EXPECT_TRUE(st.at_rest);
  EXPECT_GE(st.mean_speed, 0.0);
  EXPECT_LT(st.mean_speed, 4.0 * amplitude / (omega * span * span));
  EXPECT_GT(st.max_speed, 100.0 * RestSettings{}.speed);  // the speed test alone: not at rest
  EXPECT_EQ(st.rest_steps, 0);

  const double v = 2e-3;
  auto p = bare_params(40.0, 20.0);
  p.gravity_on = false;
  auto d = one_disk();
  d[0].x = 39.99;
  d[0].y = 10.0;
  d[0].vx = v;
  Batch drift({setup(p, d)}, tight());
  drift.set_average_span(0, n);
  for (int k = 0; k < 3 * n; ++k) {
    drift.step();
    ASSERT_FALSE(drift.status(0).at_rest) << "step " << k + 1;
  }
  EXPECT_LT(drift.disks(0)[0].x, 1.0);  // it crossed the edge
  EXPECT_NEAR(drift.status(0).mean_speed, v, 1e-9 * v);
}

// Order in h of Moreau-Jean (first order), from the discrete motion worked out in closed form.
// Pull-off: a disk leaving at u under the constant pull a = F_c / m_n has u_k = u - k h a and
// gap_k = h (u_1 + ... + u_k), largest at K = floor(u / (h a)) = u / (h a) - f:
// gap_K = u^2 / (2 a) - h u / 2 + h^2 a f (1 - f) / 2. It escapes when that passes d_c, so the
// threshold is v_t = v* + a h / 2 + O(h^2) (v* = sqrt(2 a d_c)): first order, with that slope.
// Sliding: the slip speed falls by 3 mu g h per step until the step that sticks, which ends at
// exactly 2 v0 / 3 (the friction impulse is the same on v and R w); with x advanced by h v_k,
// x(T) = x_continuous - h v0 / 6 + mu g h^2 f (1 - f) / 2, f the fraction of a step at which
// the continuous slip ends. Each error is checked against its first-order term to within the
// bound of its h^2 term, and the order fitted over h spanning a factor of 8 is 1 +- 0.05. A
// scheme of second order (or a first-order term with another slope) fails both (checked once:
// x advanced by h (v_old + v_new) / 2 leaves the slip error at 1e-6 and fails).
namespace {
double fitted_order(const std::vector<double>& h, const std::vector<double>& err) {
  std::vector<double> log_h, log_err;
  for (std::size_t k = 0; k < h.size(); ++k) {
    log_h.push_back(std::log(h[k]));
    log_err.push_back(std::log(std::fabs(err[k])));
  }
  return run_helpers::slope(log_h, log_err).first;
}
}  // namespace

TEST(Validation, PullOffThresholdIsFirstOrderInH) {
  const double bo = 10.0, dc = 0.01, m_n = 0.5, a = bo / m_n;
  const double v_star = std::sqrt(2.0 * a * dc);
  const double h_scale = std::sqrt(2.0 * m_n * dc / bo);
  std::vector<double> hs, errs;
  for (double div : {4.0, 8.0, 16.0, 32.0}) {
    const double h = h_scale / div;
    const double err = escape_threshold(h, bo, dc, 0.5 * v_star, 2.0 * v_star) - v_star;
    std::printf("h = %.3g: v_t - v* = %.5f, a h / 2 = %.5f\n", h, err, 0.5 * a * h);
    EXPECT_NEAR(err, 0.5 * a * h, a * a * h * h / v_star) << "h = " << h;
    hs.push_back(h);
    errs.push_back(err);
  }
  EXPECT_NEAR(fitted_order(hs, errs), 1.0, 0.05);
}

TEST(Validation, SlipDistanceIsFirstOrderInH) {
  const double mu = 0.3, v0 = 2.0, g = 1.0;
  const double t_slide = v0 / (3.0 * mu * g), t_end = 2.0 * t_slide;
  const double x_continuous =
      v0 * t_slide - 0.5 * mu * g * t_slide * t_slide + 2.0 * v0 / 3.0 * (t_end - t_slide);
  std::vector<double> hs, errs;
  for (double h : {8e-3, 4e-3, 2e-3, 1e-3}) {
    Batch batch = sliding_disk(mu, v0, h);
    const int steps = static_cast<int>(std::lround(t_end / h));
    for (int k = 0; k < steps; ++k) batch.step();
    const double err =
        batch.disks(0)[0].x - 100.0 - (x_continuous + (steps * h - t_end) * 2.0 * v0 / 3.0);
    std::printf("h = %.3g: x - x_continuous = %.3e, -h v0 / 6 = %.3e\n", h, err, -h * v0 / 6.0);
    EXPECT_NEAR(err, -h * v0 / 6.0, mu * g * h * h / 8.0 + 1e-7) << "h = " << h;
    hs.push_back(h);
    errs.push_back(err);
  }
  EXPECT_NEAR(fitted_order(hs, errs), 1.0, 0.05);
}

// Invariance: a small scene in motion (a disk dropped off-centre onto a two-disk base, the base
// pushed apart, and a larger disk sliding and spinning towards them, with cohesion, friction and
// rolling friction), run as it is, shifted by 10.3 R so that it straddles the periodic seam, and
// mirrored about x = 10 (x -> 20 - x, v_x -> -v_x, w -> -w). The grid orders the contacts
// differently in each, so the solves agree to their tolerance, not bit for bit: after 400 steps
// every disk's position and velocity agree to 1e-6. A law with a handedness or an image chosen
// wrongly across the seam fails it (checked once: a friction bound of 0.5 mu on one side of the
// tangent fails the mirror).
TEST(Validation, MotionIsInvariantUnderShiftAndMirror) {
  auto p = bare_params(20.0, 20.0);
  p.friction = 0.3;
  p.rolling_friction = 0.1;
  p.bond_number = 5.0;
  p.time_step = 0.005;
  auto base = pyramid();
  base[2].x += 0.4;
  base[2].y = 3.9;  // 0.96 R above the right base disk
  Disk slider;
  slider.radius = 1.5;
  slider.x = 5.0;
  slider.y = 1.5;
  slider.vx = 1.0;
  slider.w = 0.7;
  base.push_back(slider);
  SolverSettings solver = tight();
  solver.relative_tolerance = 0.0;
  const auto run = [&](std::vector<Disk> d) {
    Batch batch({setup(p, std::move(d))}, solver);
    for (int k = 0; k < 400; ++k) batch.step();
    EXPECT_EQ(batch.status(0).failure, Failure::None);
    return batch.disks(0);
  };
  const auto wrap = [&](double x) { return x - p.width * std::floor(x / p.width); };
  const auto seam = [&](double dx) { return dx - p.width * std::round(dx / p.width); };
  const auto plain = run(base);
  auto shifted_in = base, mirrored_in = base;
  for (Disk& d : shifted_in) d.x = wrap(d.x + 10.3);
  for (Disk& d : mirrored_in) {
    d.x = 20.0 - d.x;
    d.vx = -d.vx;
    d.w = -d.w;
  }
  const auto shifted = run(shifted_in);
  const auto mirrored = run(mirrored_in);
  ASSERT_EQ(plain.size(), base.size());
  EXPECT_GT(std::hypot(plain[2].x - base[2].x, plain[2].y - base[2].y), 0.5);  // it moved
  for (std::size_t k = 0; k < plain.size(); ++k) {
    SCOPED_TRACE("disk " + std::to_string(k));
    EXPECT_NEAR(seam(shifted[k].x - 10.3 - plain[k].x), 0.0, 1e-6);
    EXPECT_NEAR(shifted[k].y, plain[k].y, 1e-6);
    EXPECT_NEAR(shifted[k].vx, plain[k].vx, 1e-6);
    EXPECT_NEAR(shifted[k].vy, plain[k].vy, 1e-6);
    EXPECT_NEAR(shifted[k].w, plain[k].w, 1e-6);
    EXPECT_NEAR(seam(20.0 - mirrored[k].x - plain[k].x), 0.0, 1e-6);
    EXPECT_NEAR(mirrored[k].y, plain[k].y, 1e-6);
    EXPECT_NEAR(-mirrored[k].vx, plain[k].vx, 1e-6);
    EXPECT_NEAR(mirrored[k].vy, plain[k].vy, 1e-6);
    EXPECT_NEAR(-mirrored[k].w, plain[k].w, 1e-6);
  }
}

// 7. Cohesive cantilever: a chain of j disks standing on the wall (the floor) with gravity
// sideways, stepped 300 times: how far its tip moved, and its root contact's moment and shear in
// units of m g R and m g.
struct Cantilever {
  double tip = 0.0, moment = 0.0, shear = 0.0;
  int roots = 0;  // contacts with the wall
};
Cantilever stand_cantilever(int j, double bo, double mu, double mu_r, double radius,
                            const SolverSettings& solver) {
  auto p = bare_params(60.0 * radius, 30.0 * radius);
  p.radius = radius;
  p.bond_number = bo;
  p.friction = mu;
  p.rolling_friction = mu_r;
  p.gravity_dir_x = 1.0;
  p.gravity_dir_y = 0.0;
  const double x0 = 10.0 * radius;
  Batch batch({setup(p, column(j, x0, radius))}, solver);
  for (int k = 0; k < 300; ++k) batch.step();
  const double mg = p.reference_mass() * p.gravity;
  Cantilever c;
  c.tip = batch.disks(0)[static_cast<std::size_t>(j - 1)].x - x0;
  for (const auto& f : batch.contacts(0)) {
    if (f.j != -1) continue;
    ++c.roots;
    c.moment = std::fabs(f.moment) / (mg * radius);
    c.shear = std::fabs(f.tangential) / mg;
  }
  return c;
}

// At R = 1 and 2.5: the root moment j^2 m g R and the bound mu_r R (F_c + N) scale alike, so the
// threshold is the same (a rolling lever mu_r without R_c fails it at R = 2.5).
TEST(Validation, CantileverHoldsIffJSquaredAtMostMuRBo) {
  const double bo = 260.0, mu_r = 0.1;  // mu_r Bo = 26: j = 5 holds, j = 6 falls
  for (double radius : {1.0, 2.5})
    for (int j : {5, 6}) {
      const Cantilever c = stand_cantilever(j, bo, 0.3, mu_r, radius, tight());  // j <= mu Bo
      if (j * j <= mu_r * bo) {
        EXPECT_LT(std::fabs(c.tip), 1e-6 * radius) << j << " disks of R = " << radius;
        EXPECT_EQ(c.roots, 1) << j << " disks";
        EXPECT_NEAR(c.moment, j * j, 1e-6 * j * j);  // the root's moment j^2 m g R
        EXPECT_NEAR(c.shear, j, 1e-6 * j);           // and its shear j m g
      } else {
        EXPECT_GT(c.tip, 0.1 * radius) << j << " disks of R = " << radius << " should fall";
      }
    }
}

// The same cantilever where shear decides: the root carries the shear j m g with no normal load,
// so the cohesive shift alone bounds it, j <= mu Bo (6.3 here: j = 6 holds, 7 slides off the
// wall), while the moment j^2 m g R stays far inside mu_r Bo = 105. Checked against the wrong
// law: with the Coulomb bound unshifted (mu P_n in kernels/solver.hpp) j = 6 falls too.
TEST(Validation, CantileverHoldsIffJAtMostMuBoWhereShearDecides) {
  const double bo = 21.0, mu = 0.3, mu_r = 5.0;
  for (int j : {6, 7}) {
    const Cantilever c = stand_cantilever(j, bo, mu, mu_r, 1.0, tight());
    if (j <= mu * bo) {
      EXPECT_LT(std::fabs(c.tip), 1e-6) << j << " disks should hold";
      EXPECT_EQ(c.roots, 1) << j << " disks";
      EXPECT_NEAR(c.shear, j, 1e-6 * j);
    } else {
      EXPECT_GT(c.tip, 0.1) << j << " disks should slide off";
    }
  }
}

// Both cantilevers' thresholds with every solver, staged and fused where it allows (the cases
// above use the graph-coloured Gauss-Seidel): the program's default (accelerated, with Newton
// rounds), the team solver, the sequential one and Jacobi each hold j = 5 (rolling) and j = 6
// (shear) with the root's exact moment and shear, and let j = 6 and 7 go.
class CantileverSolvers : public ::testing::TestWithParam<std::tuple<SolverKind, bool>> {};

TEST_P(CantileverSolvers, ThresholdsHold) {
  SolverSettings solver = tight(std::get<0>(GetParam()));
  solver.fused_step = std::get<1>(GetParam());
  const Cantilever rolls = stand_cantilever(5, 260.0, 0.3, 0.1, 1.0, solver);
  EXPECT_LT(std::fabs(rolls.tip), 1e-6);
  EXPECT_NEAR(rolls.moment, 25.0, 25e-6);
  EXPECT_NEAR(rolls.shear, 5.0, 5e-6);
  EXPECT_GT(stand_cantilever(6, 260.0, 0.3, 0.1, 1.0, solver).tip, 0.1);
  const Cantilever slides = stand_cantilever(6, 21.0, 0.3, 5.0, 1.0, solver);
  EXPECT_LT(std::fabs(slides.tip), 1e-6);
  EXPECT_NEAR(slides.shear, 6.0, 6e-6);
  EXPECT_GT(stand_cantilever(7, 21.0, 0.3, 5.0, 1.0, solver).tip, 0.1);
}

INSTANTIATE_TEST_SUITE_P(
    Validation, CantileverSolvers,
    ::testing::Values(std::tuple(SolverKind::AcceleratedGaussSeidel, false),
                      std::tuple(SolverKind::AcceleratedGaussSeidel, true),
                      std::tuple(SolverKind::ColouredAcceleratedGaussSeidel, false),
                      std::tuple(SolverKind::ColouredAcceleratedGaussSeidel, true),
                      std::tuple(SolverKind::SequentialGaussSeidel, true),
                      std::tuple(SolverKind::Jacobi, false)));

// A system that goes non-finite stops with its reason; the others in the batch go on unchanged.
TEST(Guard, NonFiniteStopsOnlyItsSystem) {
  auto p = bare_params();
  p.friction = 0.3;
  auto bad = column(3, 10.0);
  bad[2].vy = std::nan("");
  const auto good = column(4, 5.0);
  Batch both({setup(p, bad), setup(p, good)}, tight());
  Batch alone({setup(p, good)}, tight());
  for (int k = 0; k < 20; ++k) {
    both.step();
    alone.step();
  }
  EXPECT_EQ(both.status(0).failure, Failure::NonFinite);
  EXPECT_FALSE(both.status(0).active);
  EXPECT_EQ(both.status(0).steps, 1);
  EXPECT_NE(failure_message(Failure::NonFinite).find("NaN"), std::string::npos);
  EXPECT_EQ(both.status(1).failure, Failure::None);
  EXPECT_EQ(both.status(1).steps, 20);
  const auto a = both.disks(1), b = alone.disks(0);
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].y, b[k].y);
    EXPECT_EQ(a[k].x, b[k].x);
  }
}

// Too many disks for the capacity stops the system with its reason.
TEST(Guard, CapacityOverflowIsReported) {
  auto p = bare_params(8.0, 40.0);
  SystemSetup s = setup(p, {}, 3);
  Batch batch({s});
  int placed = 0;
  for (int k = 0; k < 5; ++k) placed += batch.deposit({1}, DropRule::Touch)[0].placed ? 1 : 0;
  EXPECT_EQ(placed, 3);
  EXPECT_EQ(batch.status(0).failure, Failure::ParticleOverflow);
}

// A system that sits out steps keeps its contact forces readable and resumes deterministically.
TEST(Guard, PausedSystemKeepsItsContactsAndResumesLikeAlone) {
  auto p = bare_params();
  p.friction = 0.3;
  const auto col = column(5, 10.0);
  Batch both({setup(p, col), setup(p, column(3, 4.0))}, tight());
  Batch alone({setup(p, col)}, tight());
  for (int k = 0; k < 5; ++k) {
    both.step();
    alone.step();
  }
  both.set_active(0, false);
  for (int k = 0; k < 3; ++k) both.step();  // an odd number of steps without system 0
  const auto a = both.contacts(0), b = alone.contacts(0);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) EXPECT_EQ(a[k].normal, b[k].normal);
  // Resuming continues from its own last impulses, untouched while it sat out: exactly the
  // steps the system alone takes, as a paused system does not move.
  both.set_active(0, true);
  for (int k = 0; k < 4; ++k) {
    both.step();
    alone.step();
  }
  const auto c = both.disks(0), d = alone.disks(0);
  for (std::size_t k = 0; k < c.size(); ++k) EXPECT_EQ(c[k].y, d[k].y);
  const auto e = both.contacts(0), f = alone.contacts(0);
  ASSERT_EQ(e.size(), f.size());
  for (std::size_t k = 0; k < e.size(); ++k) EXPECT_EQ(e[k].normal, f[k].normal);
}

// The periodic boundary is invisible: a pyramid straddling x = 0 carries the same forces.
TEST(Validation, PyramidAcrossThePeriodicBoundary) {
  auto p = bare_params(20.0, 40.0);
  p.friction = 0.3;
  auto d = pyramid();
  for (auto& a : d) a.x -= 10.0;  // top disk exactly at x = 0, base disks at x < 0 and x > 0
  Batch batch({setup(p, d)}, tight());
  for (int k = 0; k < 100; ++k) batch.step();
  int upper = 0;
  for (const auto& c : batch.contacts(0)) {
    if (c.j != 2) continue;
    EXPECT_NEAR(c.normal, 0.5, 1e-6);
    EXPECT_NEAR(std::fabs(c.tangential), (2.0 - std::sqrt(3.0)) / 2.0, 1e-6);
    ++upper;
  }
  EXPECT_EQ(upper, 2);
  for (const auto& a : batch.disks(0)) {
    EXPECT_GE(a.x, 0.0);
    EXPECT_LT(a.x, p.width);
  }
}

// solver.overlap_correction = beta: after each step's positions, an overlap delta is reduced by
// beta delta (at most 0.2 R) by moving positions alone. A disk pressed into the floor by gravity
// stays at rest (the solve cancels gravity exactly: target u_n = 0 for an overlap), so its overlap
// is delta0 (1 - beta)^n after n steps, and no speed appears: no kinetic energy is injected, as
// a target u_n = -gap/h would (a speed delta0/h = 2). Without the correction the overlap is held.
TEST(OverlapCorrection, FloorOverlapDecaysWithoutMotion) {
  auto p = bare_params(20.0, 10.0);
  Disk d;
  d.x = 10.0;
  const double delta0 = 0.02;
  d.y = 1.0 - delta0;
  for (const double beta : {0.0, 0.5}) {
    SCOPED_TRACE(beta);
    auto s = tight();
    s.overlap_correction = beta;
    Batch b({setup(p, {d})}, s);
    b.set_active(0, true);
    for (int n = 1; n <= 6; ++n) {
      b.step();
      const Disk e = b.disks(0)[0];
      EXPECT_NEAR(1.0 - e.y, delta0 * std::pow(1.0 - beta, n), 1e-9) << "step " << n;
      EXPECT_LT(speed(e), 1e-9) << "step " << n;
      EXPECT_NEAR(e.x, d.x, 1e-12);
    }
  }
}

// Two disks overlapping by delta across the periodic boundary, no gravity, no velocities (a zero
// solve): the correction moves them apart along the line of centres by beta delta in all, split
// by the inverse masses (a fixed disk does not move), and wraps x into [0, L_x). A large overlap
// is corrected by at most 0.2 R per step.
TEST(OverlapCorrection, PairMovesApartByInverseMassAcrossThePeriodicBoundary) {
  auto p = bare_params(20.0, 10.0);
  p.gravity_on = false;
  Disk a, b;
  a.x = 0.5;
  b.x = 18.8;  // minimum image at -1.2, left of a: centres 1.7 apart, overlap 0.3
  a.y = b.y = 5.0;
  struct Case {
    bool a_fixed;
    double beta, move_a, move_b;  // signed moves in x (a to the right, b to the left)
  };
  for (const Case& c :
       {Case{false, 0.4, 0.06, -0.06}, Case{true, 0.4, 0.0, -0.12}, Case{false, 1.0, 0.1, -0.1}}) {
    SCOPED_TRACE(c.beta);
    a.fixed = c.a_fixed;
    auto s = tight();
    s.overlap_correction = c.beta;
    Batch batch({setup(p, {a, b})}, s);
    batch.set_active(0, true);
    batch.step();
    const auto d = batch.disks(0);
    EXPECT_NEAR(d[0].x, a.x + c.move_a, 1e-12);
    EXPECT_NEAR(d[1].x, b.x + c.move_b, 1e-12);
    EXPECT_NEAR(d[0].y, 5.0, 1e-12);
    EXPECT_NEAR(d[1].y, 5.0, 1e-12);
    EXPECT_LT(speed(d[0]) + speed(d[1]), 1e-12);
  }
  // A mobile disk pushed across x = 0 by a fixed one: b at 0.3 (1.8 from a at 2.1, overlap 0.2)
  // moves by 0.2 to x = 0.1; b at 0.1 (1.8 from a at 1.9) moves to -0.1, wrapped to L_x - 0.1.
  a.fixed = true;
  a.x = 2.1;
  b.x = 0.3;
  auto s = tight();
  s.overlap_correction = 1.0;
  Batch wrap({setup(p, {a, b})}, s);
  wrap.set_active(0, true);
  wrap.step();
  EXPECT_NEAR(wrap.disks(0)[1].x, 0.1, 1e-12);
  a.x = 1.9;
  b.x = 0.1;
  Batch across({setup(p, {a, b})}, s);
  across.set_active(0, true);
  across.step();
  EXPECT_NEAR(across.disks(0)[1].x, 19.9, 1e-12);
}
