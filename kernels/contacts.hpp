// Contact detection: every pair (and disk-floor pair) whose gap is below the cohesion range
// plus a motion margin becomes a contact slot of its lower-index particle, warm-started with
// the impulses the same pair carried in the previous step; a disk with more candidates than
// its kSlots keeps the nearest (ContactBuild::add).
#pragma once
#include "kernels/contact_law.hpp"
#include "kernels/grid.hpp"

namespace loosepack {

// The contacts a disk owned in the last step and their impulses: the warm start of its new ones.
struct LastContacts {
  int n = 0;
  int partner[kSlots];
  double pn[kSlots], pt[kSlots], pm[kSlots];
};

// A particle of a system stepped now (one with a cell) reads its last contacts and impulses,
// then builds its new ones in their place; every other particle's contacts stay where they are:
// a system that sits out steps keeps its warm start, and a system inside a step (no cells;
// sys.mid_step) keeps the contacts and impulses its solve goes on with.
// Reads: sys.{time_step, cohesion_range, margin, radius, cohesive_force, floor_cohesion,
// grid_nx, grid_ny, cell_offset, width}; part.{cell, system, x, y, radius}; grid;
// con.{partner, pn, pt, pm} (its own slots).
// Writes: con.{partner, nx, ny, gap, rc, lower, pn, pt, pm}; part.{incident, n_incident} (its
// own slots); sys.failure (kContactOverflow).
struct ContactBuild {
  SystemViews sys;
  ParticleViews part;
  ContactViews con;
  GridViews grid;

  // Slot k of particle p becomes the pair (p, partner), warm-started with the impulses the same
  // pair carried in the previous step.
  KOKKOS_INLINE_FUNCTION void write(const LastContacts& last, int p, int k, int partner, double nx,
                                    double ny, double gap, double rc, double lower) const {
    const int c = p * kSlots + k;
    con.partner(c) = partner;
    con.nx(c) = nx;
    con.ny(c) = ny;
    con.gap(c) = gap;
    con.rc(c) = rc;
    con.lower(c) = lower;
    double pn = 0.0, pt = 0.0, pm = 0.0;
    for (int q = 0; q < last.n; ++q) {
      if (last.partner[q] == partner) {
        pn = last.pn[q];
        pt = last.pt[q];
        pm = last.pm[q];
        break;
      }
    }
    con.pn(c) = pn;
    con.pt(c) = pt;
    con.pm(c) = pm;
  }

  // A candidate pair of p, k slots filled so far. When they are all taken, the kSlots nearest
  // candidates keep them: a candidate beyond the reach of a system at rest (`keep`: the
  // cohesion range plus the least margin) is only there for the motion margin, which assumes
  // the largest speed in the system, so the furthest is dropped. The system fails only when a
  // pair within `keep` (touching, held by cohesion, or about to be) would be dropped.
  KOKKOS_INLINE_FUNCTION void add(const LastContacts& last, int p, int& k, int partner, double nx,
                                  double ny, double gap, double rc, double lower,
                                  double keep) const {
    if (k < kSlots) {
      write(last, p, k, partner, nx, ny, gap, rc, lower);
      ++k;
      return;
    }
    int far = 0;
    for (int q = 1; q < kSlots; ++q)
      if (con.gap(p * kSlots + q) > con.gap(p * kSlots + far)) far = q;
    const double far_gap = con.gap(p * kSlots + far);
    if (kmath::max(gap, far_gap) < keep) {
      Kokkos::atomic_exchange(&sys.failure(part.system(p)), int(kContactOverflow));
      return;
    }
    if (gap < far_gap) write(last, p, far, partner, nx, ny, gap, rc, lower);
  }

  // The last step's contacts of p, up to its first empty slot.
  KOKKOS_INLINE_FUNCTION LastContacts last_contacts(int p) const {
    LastContacts last;
    for (; last.n < kSlots; ++last.n) {
      const int c = p * kSlots + last.n;
      if (con.partner(c) == kNoContact) break;
      last.partner[last.n] = con.partner(c);
      last.pn[last.n] = con.pn(c);
      last.pt[last.n] = con.pt(c);
      last.pm[last.n] = con.pm(c);
    }
    return last;
  }

  KOKKOS_INLINE_FUNCTION void operator()(int p) const {
    if (part.cell(p) < 0) return;  // not stepped now, or an empty slot: keep what it had
    const LastContacts last = last_contacts(p);
    const int s = part.system(p);
    int k = 0;
    {
      const double h = sys.time_step(s);
      const double dc = sys.cohesion_range(s);
      const double reach = dc + sys.margin(s);
      const double keep = dc + kMinMarginFactor * sys.radius(s);
      const double fc_impulse = h * sys.cohesive_force(s);
      const double rp = part.radius(p);
      const double xp = part.x(p), yp = part.y(p);
      const double floor_gap = yp - rp;
      if (floor_gap < reach) {
        const double lower =
            (sys.floor_cohesion(s) && floor_gap < dc && fc_impulse > 0.0) ? -fc_impulse : 0.0;
        add(last, p, k, kFloor, 0.0, -1.0, floor_gap, rp, lower, keep);
      }
      const int nx = sys.grid_nx(s), ny = sys.grid_ny(s);
      const int c0 = part.cell(p) - sys.cell_offset(s);
      const int cx = c0 % nx, cy = c0 / nx;
      const ColumnRange cols = grid_columns(cx, nx);
      const double width = sys.width(s);
      for (int ry = kmath::imax(cy - 1, 0); ry <= kmath::imin(cy + 1, ny - 1); ++ry) {
        for (int kc = 0; kc < cols.n; ++kc) {
          const int c = sys.cell_offset(s) + ry * nx + cols[kc];
          for (int a = grid.cell_start(c); a < grid.cell_start(c + 1); ++a) {
            const int q = grid.cell_particles(a);
            if (q <= p) continue;
            const double dx = periodic_delta(part.x(q) - xp, width);
            const double dy = part.y(q) - yp;
            const double rq = part.radius(q);
            const double reach_pq = rp + rq + reach;
            const double d2 = dx * dx + dy * dy;
            if (d2 >= reach_pq * reach_pq) continue;
            const double d = kmath::sqrt(d2);
            const double gap = d - rp - rq;
            const double lower = (gap < dc && fc_impulse > 0.0) ? -fc_impulse : 0.0;
            const double inv_d = d > 0.0 ? 1.0 / d : 0.0;
            // Exactly coincident centres have no line of centres: push along +y by convention.
            const double nxv = d > 0.0 ? dx * inv_d : 0.0;
            const double nyv = d > 0.0 ? dy * inv_d : 1.0;
            add(last, p, k, q, nxv, nyv, gap, kmath::min(rp, rq), lower, keep);
          }
        }
      }
    }
    for (int q = k; q < kSlots; ++q) con.partner(p * kSlots + q) = kNoContact;
    // The particle's own slots open its incidence list (IncidentScatter adds the others).
    for (int q = 0; q < k; ++q) part.incident(p * kIncident + q) = p * kSlots + q;
    part.n_incident(p) = k;  // k <= kSlots < kIncident (add keeps the nearest kSlots)
  }
};

// Contact slot ids incident to each particle: ContactBuild writes its own slots; this adds each
// contact slot to the list of its partner (a disk of higher index, in the same system), and
// IncidentSort then puts every list in increasing slot order, so that the sums over it are
// the same on every backend whatever order the atomics took.
// Reads: part.{cell, system}; con.partner. Writes: part.{n_incident, incident} (of partners);
// sys.failure (kContactOverflow).
struct IncidentScatter {
  SystemViews sys;
  ParticleViews part;
  ContactViews con;

  KOKKOS_INLINE_FUNCTION void operator()(int p) const {
    if (part.cell(p) < 0) return;
    for (int k = 0; k < kSlots; ++k) {
      const int c = p * kSlots + k;
      const int j = con.partner(c);
      if (j == kNoContact) break;
      if (j < 0) continue;  // the floor
      const int a = Kokkos::atomic_fetch_add(&part.n_incident(j), 1);
      if (a < kIncident)
        part.incident(j * kIncident + a) = c;
      else
        Kokkos::atomic_exchange(&sys.failure(part.system(p)), int(kContactOverflow));
    }
  }
};

// Reads and writes: part.{n_incident, incident}; reads part.cell.
struct IncidentSort {
  ParticleViews part;

  KOKKOS_INLINE_FUNCTION void operator()(int p) const {
    if (part.cell(p) < 0) return;
    const int n = kmath::imin(part.n_incident(p), kIncident);  // more: the system has failed
    part.n_incident(p) = n;
    sort_range(part.incident, p * kIncident, p * kIncident + n);
  }
};

// Local Delassus entries of every contact, particle by particle over its own slots (filled from
// the first: ContactBuild). With mass splitting (Jacobi) each body's inverse mass and inertia are
// multiplied by its number of contacts, which makes Jacobi convergent.
// Reads: con.partner; part.{cell, n_incident, inv_mass, inv_inertia, radius}.
// Writes: con.{wn, wa, wb, wc}.
struct ContactMobilityBuild {
  ParticleViews part;
  ContactViews con;
  bool mass_splitting;

  KOKKOS_INLINE_FUNCTION void operator()(int i) const {
    if (part.cell(i) < 0) return;  // not stepped now: its contacts are as they were
    const double si = mass_splitting ? double(kmath::imax(part.n_incident(i), 1)) : 1.0;
    for (int k = 0; k < kSlots; ++k) {
      const int c = i * kSlots + k;
      const int j = con.partner(c);
      if (j == kNoContact) break;
      double inv_mj = 0.0, inv_Ij = 0.0, Rj = 0.0;
      if (j >= 0) {
        const double sj = mass_splitting ? double(kmath::imax(part.n_incident(j), 1)) : 1.0;
        inv_mj = sj * part.inv_mass(j);
        inv_Ij = sj * part.inv_inertia(j);
        Rj = part.radius(j);
      }
      const ContactMobility w = contact_mobility(si * part.inv_mass(i), si * part.inv_inertia(i),
                                                 part.radius(i), inv_mj, inv_Ij, Rj);
      con.wn(c) = w.wn;
      con.wa(c) = w.a;
      con.wb(c) = w.b;
      con.wc(c) = w.c;
    }
  }
};

}  // namespace loosepack
