// Free velocities, the implicit position update, the non-finite guard and the speeds that feed
// rest detection.
#pragma once
#include "kernels/state.hpp"

namespace loosepack {

// Reads: sys.{time_step, gravity_x, gravity_y}; part.{cell, system, inv_mass, vx, vy, w}.
// Writes: part.{vfx, vfy, wf}.
struct FreeVelocity {
  SystemViews sys;
  ParticleViews part;
  KOKKOS_INLINE_FUNCTION void operator()(int p) const {
    if (part.cell(p) < 0) return;
    const int s = part.system(p);
    const double h = sys.time_step(s);
    const bool mobile = part.inv_mass(p) > 0.0;
    part.vfx(p) = part.vx(p) + (mobile ? h * sys.gravity_x(s) : 0.0);
    part.vfy(p) = part.vy(p) + (mobile ? h * sys.gravity_y(s) : 0.0);
    part.wf(p) = part.w(p);
  }
};

// A disk's centre speed |v|, and its speed max(|v|, R |w|): what the rest test, the detection
// margin and the relative tolerance read (sys.max_speed).
KOKKOS_INLINE_FUNCTION double centre_speed(const ParticleViews& part, int p) {
  return kmath::sqrt(part.vx(p) * part.vx(p) + part.vy(p) * part.vy(p));
}
KOKKOS_INLINE_FUNCTION double disk_speed(const ParticleViews& part, int p) {
  return kmath::max(centre_speed(part, p), kmath::fabs(part.radius(p) * part.w(p)));
}

// The averaged rest test (RestSettings::average_span) at the end of a step of system s, for disk
// p, which moved by dx across and now stands at y: the span's sums grow; on the span's last step
// its mean position replaces the previous span's, and how far it moved from there feeds the
// system's largest change (span_change, from the second span on). Positions only: a disk turning
// in place changes no observable. End of the span: end_span (kernels/step.hpp).
// Reads: sys.{span_steps, span_step, spans}. Writes: part.span of p; sys.span_change.
KOKKOS_INLINE_FUNCTION void add_to_span(const SystemViews& sys, const ParticleViews& part, int s,
                                        int p, double dx, double y) {
  const int n = sys.span_steps(s);
  if (n <= 0) return;
  double* a = &part.span(p * kSpanFields);
  a[kSpanShiftX] += dx;
  a[kSpanSumX] += a[kSpanShiftX];
  a[kSpanSumY] += y;
  if (sys.span_step(s) + 1 < n) return;
  const double mean_x = a[kSpanSumX] / n, mean_y = a[kSpanSumY] / n;
  if (sys.spans(s) > 0) {
    const double ex = mean_x - a[kSpanMeanX], ey = mean_y - a[kSpanMeanY];
    Kokkos::atomic_fetch_max(&sys.span_change(s), kmath::sqrt(ex * ex + ey * ey));
  }
  a[kSpanMeanX] = mean_x;
  a[kSpanMeanY] = mean_y;
  a[kSpanSumX] = 0.0;
  a[kSpanSumY] = 0.0;
}

// Over i in [0, capacity): the averaged rest test of system s starts afresh with spans of
// `steps` steps (0: off), from the disks' positions now (Batch::set_average_span).
// Writes: part.span of the slot; sys.{span_steps, span_step, spans, span_change, mean_speed}.
struct StartSpan {
  SystemViews sys;
  ParticleViews part;
  int s, first, steps;
  KOKKOS_INLINE_FUNCTION void operator()(int i) const {
    for (int field = 0; field < kSpanFields; ++field)
      part.span((first + i) * kSpanFields + field) = 0.0;
    if (i != 0) return;
    sys.span_steps(s) = steps;
    sys.span_step(s) = 0;
    sys.spans(s) = 0;
    sys.span_change(s) = 0.0;
    sys.mean_speed(s) = -1.0;
  }
};

// x += h v (wrapped into [0, L_x)), theta += h w; flags non-finite state; records max speed and
// the averaged rest test's sums (add_to_span).
// Reads: sys.{active, mid_step, offset, count, failure, time_step, width, span_*}; part.{system,
// vx, vy, w, radius}.
// Writes: part.{x, y, theta, span}; sys.{failure (kNonFinite), max_speed, max_centre_speed,
// span_change}.
struct Integrate {
  SystemViews sys;
  ParticleViews part;
  KOKKOS_INLINE_FUNCTION void operator()(int p) const {
    // The disks of the systems whose step ends now: not of one whose solve goes on, and also of
    // one whose step began in an earlier launch (the grid gave it no cells then).
    const int s = part.system(p);
    if (!sys.active(s) || sys.mid_step(s) || p >= sys.offset(s) + sys.count(s)) return;
    if (sys.failure(s) == kContactOverflow || sys.failure(s) == kParticleOverflow) return;
    const double h = sys.time_step(s);
    const double x = wrap_into_box(part.x(p) + h * part.vx(p), sys.width(s));
    const double y = part.y(p) + h * part.vy(p);
    part.x(p) = x;
    part.y(p) = y;
    part.theta(p) += h * part.w(p);
    const double v = centre_speed(part, p);
    const double rw = part.radius(p) * part.w(p);
    if (!kmath::isfinite(x) || !kmath::isfinite(y) || !kmath::isfinite(v) || !kmath::isfinite(rw)) {
      Kokkos::atomic_exchange(&sys.failure(s), int(kNonFinite));
      return;
    }
    Kokkos::atomic_fetch_max(&sys.max_speed(s), disk_speed(part, p));
    Kokkos::atomic_fetch_max(&sys.max_centre_speed(s), v);
    add_to_span(sys, part, s, p, h * part.vx(p), y);
  }
};

// Overlap correction (SolverSettings::overlap_correction, beta > 0): after the positions, each
// contact of a system whose disks now overlap by delta is pushed apart along the line of centres
// by beta delta (at most 0.2 R), split by the inverse masses, in one Gauss-Seidel pass over the
// system's contacts. Positions only: velocities are left as they are, so no kinetic energy is
// injected (docs/MODEL.md, "Contact law": overlaps resolved without adding kinetic energy), and an
// overlap that a capped solve leaves decays by (1 - beta) per step instead of being held.
// Reads: sys.{active, mid_step, failure, width, offset, count}; con.partner; part.{inv_mass,
// radius}.
// Reads and writes: part.{x, y}.
struct OverlapCorrection {
  SystemViews sys;
  ParticleViews part;
  ContactViews con;
  double beta;
  KOKKOS_INLINE_FUNCTION void operator()(int s) const {
    if (!sys.active(s) || sys.mid_step(s) || sys.failure(s) != kOk) return;
    const double width = sys.width(s);
    const SlotRange range = system_slots(sys, s);
    for (int c = range.first; c < range.end; ++c) {
      const int q = con.partner(c);
      if (q == kNoContact) continue;
      const int p = c / kSlots;
      const double wp = part.inv_mass(p);
      if (q == kFloor) {
        const double delta = part.radius(p) - part.y(p);
        if (delta > 0.0 && wp > 0.0) part.y(p) += push(delta, part.radius(p));
        continue;
      }
      const double wq = part.inv_mass(q);
      if (!(wp + wq > 0.0)) continue;
      const double dx = periodic_delta(part.x(q) - part.x(p), width);
      const double dy = part.y(q) - part.y(p);
      const double d = kmath::sqrt(dx * dx + dy * dy);
      const double delta = part.radius(p) + part.radius(q) - d;
      if (!(delta > 0.0) || !(d > 0.0)) continue;
      const double move = push(delta, kmath::min(part.radius(p), part.radius(q))) / (d * (wp + wq));
      part.x(p) = wrap_into_box(part.x(p) - wp * move * dx, width);
      part.y(p) -= wp * move * dy;
      part.x(q) = wrap_into_box(part.x(q) + wq * move * dx, width);
      part.y(q) += wq * move * dy;
    }
  }
  KOKKOS_INLINE_FUNCTION double push(double delta, double r) const {
    return kmath::min(beta * delta, 0.2 * r);
  }
};

}  // namespace loosepack
