// The contact law's local solves against their defining conditions.
#include <gtest/gtest.h>

#include <cmath>
#include <utility>

#include "kernels/contact_law.hpp"

using namespace loosepack;

TEST(ContactLaw, EffectiveMassesOfEqualDisksAndWall) {
  // Solid disks m = 1, R = 1, I = 1/2: normal m/2, tangential m/6, rolling m R^2/4;
  // against the wall m, m/3, m R^2/2 (MODEL.md).
  const auto dd = contact_mobility(1.0, 2.0, 1.0, 1.0, 2.0, 1.0);
  EXPECT_DOUBLE_EQ(1.0 / dd.wn, 0.5);
  EXPECT_DOUBLE_EQ(1.0 / dd.a, 1.0 / 6.0);
  EXPECT_DOUBLE_EQ(1.0 / dd.b, 0.25);
  EXPECT_DOUBLE_EQ(dd.c, 0.0);
  const auto dw = contact_mobility(1.0, 2.0, 1.0, 0.0, 0.0, 0.0);
  EXPECT_DOUBLE_EQ(1.0 / dw.wn, 1.0);
  EXPECT_DOUBLE_EQ(1.0 / dw.a, 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(1.0 / dw.b, 0.5);
  EXPECT_DOUBLE_EQ(dw.c, 2.0);
}

TEST(ContactLaw, NormalClosesGapExactlyAndNeverPushesOverlapApart) {
  const double h = 0.01, wn = 2.0;
  // Approaching at -1 with gap 0.004: end-of-step velocity must be -gap/h = -0.4.
  double p = solve_normal(0.0, -1.0, 0.004, h, wn, 0.0);
  EXPECT_NEAR(-1.0 + wn * p, -0.4, 1e-14);
  // Far open contact moving apart: no impulse.
  EXPECT_EQ(solve_normal(0.0, 0.5, 0.1, h, wn, 0.0), 0.0);
  // Overlap of 0.01 at rest: target 0, not +overlap/h.
  p = solve_normal(0.0, 0.0, -0.01, h, wn, 0.0);
  EXPECT_EQ(p, 0.0);
  // Cohesive open contact separating slowly: pulled with exactly -h F_c.
  const double lower = -h * 5.0;
  EXPECT_DOUBLE_EQ(solve_normal(0.0, 0.1, 0.001, h, wn, lower), lower);
}

TEST(ContactLaw, FrictionSticksBelowBoundAndSlidesAtIt) {
  const double a = 6.0;
  EXPECT_NEAR(solve_friction(0.0, 0.3, a, 1.0), -0.05, 1e-15);  // stick: u_t + a P_t = 0
  EXPECT_DOUBLE_EQ(solve_friction(0.0, 30.0, a, 1.0), -1.0);    // slide: at the bound
  EXPECT_DOUBLE_EQ(solve_friction(0.0, -30.0, a, 1.0), 1.0);
}

// KKT conditions of the coupled friction/rolling box problem.
static void check_kkt(double ut, double om, double a, double b, double c, double bt, double br) {
  double pt = 0.0, m = 0.0;
  solve_friction_rolling(0.0, 0.0, ut, om, a, b, c, bt, br, pt, m);
  const double ut_new = ut + a * pt + c * m;
  const double om_new = om + c * pt + b * m;
  const double eps = 1e-12;
  ASSERT_LE(std::fabs(pt), bt + eps);
  ASSERT_LE(std::fabs(m), br + eps);
  if (std::fabs(pt) < bt - eps) {
    EXPECT_NEAR(ut_new, 0.0, 1e-10);
  }  // sticks
  if (bt > eps && pt >= bt - eps) {
    EXPECT_LE(ut_new, 1e-10);
  }  // slides against the impulse
  if (bt > eps && pt <= -bt + eps) {
    EXPECT_GE(ut_new, -1e-10);
  }
  if (std::fabs(m) < br - eps) {
    EXPECT_NEAR(om_new, 0.0, 1e-10);
  }
  if (br > eps && m >= br - eps) {
    EXPECT_LE(om_new, 1e-10);
  }
  if (br > eps && m <= -br + eps) {
    EXPECT_GE(om_new, -1e-10);
  }
}

TEST(ContactLaw, CoupledFrictionRollingSatisfiesStickSlipLaws) {
  // Disk on the wall: a = 3, b = 2, c = 2 (m = R = 1).
  const double a = 3.0, b = 2.0, c = 2.0;
  for (double ut : {-5.0, -0.3, 0.0, 0.2, 4.0})
    for (double om : {-3.0, -0.1, 0.0, 0.5, 6.0})
      for (double bt : {0.0, 0.05, 1.0})
        for (double br : {0.0, 0.01, 0.5}) check_kkt(ut, om, a, b, c, bt, br);
}

// Unequal disks (R_i = 1, R_j = 2.5, masses r^2 and 3 r^2, I = m r^2 / 2): the Delassus block
// against the rigid-body response it stands for. An impulse P_t on j (and -P_t on i) at the
// contact point, with the torques -R_i P_t on i and -R_j P_t on j, and a moment M on j (-M on i)
// change the velocities by P/m and torque/I; by the definitions of u_t and Omega (top of
// kernels/contact_law.hpp) that is du_t = a P_t + c M and dOmega = c P_t + b M. The coupling c =
// R_i/I_i - R_j/I_j vanishes for equal disks, so only this case can tell it from 0 or from the
// sum (each fails here). Then the coupled solve on this block: the KKT conditions hold.
TEST(ContactLaw, CouplingOfUnequalDisksIsTheRigidBodyResponse) {
  const double ri = 1.0, rj = 2.5, mi = ri * ri, mj = 3.0 * rj * rj;
  const double Ii = 0.5 * mi * ri * ri, Ij = 0.5 * mj * rj * rj;
  const auto w = contact_mobility(1.0 / mi, 1.0 / Ii, ri, 1.0 / mj, 1.0 / Ij, rj);
  for (const auto& [pt, m] : {std::pair{0.7, 0.0}, std::pair{0.0, 0.4}, std::pair{-0.3, 1.1}}) {
    const double dvi = -pt / mi, dvj = pt / mj;  // along t
    const double dwi = (-ri * pt - m) / Ii, dwj = (-rj * pt + m) / Ij;
    const double dut = (dvj - dvi) - (ri * dwi + rj * dwj);
    const double dom = dwj - dwi;
    EXPECT_NEAR(dut, w.a * pt + w.c * m, 1e-14);
    EXPECT_NEAR(dom, w.c * pt + w.b * m, 1e-14);
  }
  EXPECT_NEAR(w.c, 1.0 / Ii * ri - rj / Ij, 1e-15);
  EXPECT_GT(std::fabs(w.c), 0.1);
  for (double ut : {-2.0, 0.1, 3.0})
    for (double om : {-1.0, 0.0, 0.7})
      for (double bt : {0.0, 0.05, 1.0})
        for (double br : {0.0, 0.02, 0.5}) check_kkt(ut, om, w.a, w.b, w.c, bt, br);
}

TEST(ContactLaw, DiskStripAreaIsExact) {
  const double r = 1.3;
  EXPECT_NEAR(disk_strip_area(5.0, r, 0.0, 10.0), M_PI * r * r, 1e-12);        // whole disk
  EXPECT_NEAR(disk_strip_area(5.0, r, 5.0, 10.0), 0.5 * M_PI * r * r, 1e-12);  // upper half
  EXPECT_EQ(disk_strip_area(5.0, r, 7.0, 10.0), 0.0);  // strip misses the disk
  // Segment of height r/2: r^2 acos(1/2) - (r/2) sqrt(r^2 - r^2/4)
  const double seg = r * r * std::acos(0.5) - 0.5 * r * std::sqrt(0.75) * r;
  EXPECT_NEAR(disk_strip_area(5.0, r, 5.0 + 0.5 * r, 10.0), seg, 1e-12);
}
