// The contact law of loosepack, as small stateless functions shared by kernels and tests.
//
// Conventions (docs/MODEL.md):
//  - A contact joins body i (the owner, lower index) and body j (higher index, or the floor).
//  - n is the unit vector from the centre of i to the centre of j (for the floor: (0,-1)),
//    t = n rotated by +90 degrees = (-n_y, n_x).
//  - Relative velocities of j with respect to i at the contact point:
//      u_n   = (v_j - v_i).n
//      u_t   = (v_j - v_i).t - (R_i w_i + R_j w_j)
//      Omega = w_j - w_i          (rolling; the rolling velocity is u_r = R_c * Omega)
//  - Impulses over a step (P = h F) act on j: P_n n + P_t t and a moment M; on i the opposite
//    force and -M. A tangential impulse P_t also gives the torques -R_i P_t on i and -R_j P_t on j.
//  - Cohesion shifts the Signorini conditions: P_n >= -h F_c while the gap is below d_c.
//  - Coulomb: |P_t| <= mu (P_n + h F_c); rolling: |M| <= mu_r R_c (P_n + h F_c), where
//    R_c = min(R_i, R_j) is the contact's rolling radius (R for equal disks and for the floor).
#pragma once
#include "kernels/compat.hpp"

namespace loosepack {

// Inverse effective "masses" of one contact: the Delassus block of the contact with itself.
struct ContactMobility {
  double wn;  // normal: 1/m_i + 1/m_j
  double a;   // tangential: 1/m_i + 1/m_j + R_i^2/I_i + R_j^2/I_j
  double b;   // rolling: 1/I_i + 1/I_j
  double c;   // tangential-rolling coupling: R_i/I_i - R_j/I_j (zero for equal disks)
};

KOKKOS_INLINE_FUNCTION ContactMobility contact_mobility(double inv_mi, double inv_Ii, double Ri,
                                                        double inv_mj, double inv_Ij, double Rj) {
  ContactMobility w;
  w.wn = inv_mi + inv_mj;
  w.a = inv_mi + inv_mj + Ri * Ri * inv_Ii + Rj * Rj * inv_Ij;
  w.b = inv_Ii + inv_Ij;
  w.c = Ri * inv_Ii - Rj * inv_Ij;
  return w;
}

// Normal impulse of one contact with all others held fixed.
//  pn_old: the contact's current impulse; un: current normal relative velocity (including pn_old);
//  gap: gap at the start of the step; lower: -h F_c for a cohesive contact (gap < d_c), else 0.
// The target end-of-step normal velocity is -max(gap,0)/h: a closing contact closes exactly and
// an overlap is never pushed apart (no kinetic energy is injected).
KOKKOS_INLINE_FUNCTION double solve_normal(double pn_old, double un, double gap, double h,
                                           double wn, double lower) {
  const double target = un + (gap > 0.0 ? gap / h : 0.0);
  const double p = pn_old - target / wn;
  return p < lower ? lower : p;
}

// Objective of the local tangential/rolling problem for the impulse change (dt, dm).
KOKKOS_INLINE_FUNCTION double local_energy(double dt, double dm, double ut, double om, double a,
                                           double b, double c) {
  return 0.5 * (a * dt * dt + 2.0 * c * dt * dm + b * dm * dm) + ut * dt + om * dm;
}

// Coulomb friction alone (no rolling resistance): stick if |P_t| stays within the bound, else
// slide with P_t at the bound opposing the slip.
KOKKOS_INLINE_FUNCTION double solve_friction(double pt_old, double ut, double a, double bound_t) {
  return kmath::clamp(pt_old - ut / a, -bound_t, bound_t);
}

// Coulomb friction and rolling friction together: the exact minimiser of the local quadratic
// (the Delassus 2x2 block [a c; c b]) over the box |P_t| <= bound_t, |M| <= bound_r. Its KKT
// conditions are exactly the two stick/slip laws; the coupling c (a disk on the floor, unequal
// disks) is kept. Candidates: the unconstrained point, then the minimiser on each edge.
KOKKOS_INLINE_FUNCTION void solve_friction_rolling(double pt_old, double m_old, double ut,
                                                   double om, double a, double b, double c,
                                                   double bound_t, double bound_r, double& pt,
                                                   double& m) {
  const double det = a * b - c * c;
  double dt = -(b * ut - c * om) / det;
  double dm = -(a * om - c * ut) / det;
  if (kmath::fabs(pt_old + dt) <= bound_t && kmath::fabs(m_old + dm) <= bound_r) {
    pt = pt_old + dt;
    m = m_old + dm;
    return;
  }
  double best = 0.0;
  bool have = false;
  for (int e = 0; e < 4; ++e) {
    double ct, cm;
    if (e < 2) {  // P_t on a bound, M free within its box
      ct = e == 0 ? bound_t : -bound_t;
      const double d_t = ct - pt_old;
      cm = kmath::clamp(m_old - (om + c * d_t) / b, -bound_r, bound_r);
    } else {  // M on a bound, P_t free within its box
      cm = e == 2 ? bound_r : -bound_r;
      const double d_m = cm - m_old;
      ct = kmath::clamp(pt_old - (ut + c * d_m) / a, -bound_t, bound_t);
    }
    const double f = local_energy(ct - pt_old, cm - m_old, ut, om, a, b, c);
    if (!have || f < best) {
      best = f;
      pt = ct;
      m = cm;
      have = true;
    }
  }
}

// Area of a disk of radius r below the line at height r*t above its centre, minus half the disk
// (pi r^2 / 2): F(t) = r^2 (t sqrt(1-t^2) + asin t), t clamped to [-1, 1].
KOKKOS_INLINE_FUNCTION double disk_segment_primitive(double t, double r) {
  t = kmath::clamp(t, -1.0, 1.0);
  return r * r * (t * kmath::sqrt(1.0 - t * t) + kmath::asin(t));
}

// Area of a disk of radius r (centre height yc) inside the strip [a, b): exact, not centre
// counting.
KOKKOS_INLINE_FUNCTION double disk_strip_area(double yc, double r, double a, double b) {
  return disk_segment_primitive((b - yc) / r, r) - disk_segment_primitive((a - yc) / r, r);
}

}  // namespace loosepack
