// The iterative contact solve of one time step: warm start, Jacobi or graph-coloured
// Gauss-Seidel sweeps, per-system convergence and masking.
// Kernels are specialised at compile time on the effects the batch needs (Effects below), so a
// batch without friction or rolling resistance compiles those parts out.
#pragma once
#include "kernels/colouring.hpp"
#include "kernels/contact_law.hpp"
#include "kernels/state.hpp"

namespace loosepack {

template <bool Cohesion_, bool Friction_, bool Rolling_>
struct Effects {
  static constexpr bool Cohesion = Cohesion_;
  static constexpr bool Friction = Friction_;
  static constexpr bool Rolling = Rolling_;
};

// Relative velocities of a contact: normal, tangential, rolling (Omega = w_j - w_i).
struct RelativeVelocity {
  double un, ut, om;
};

// Relative velocities at a contact with normal (nx, ny) between body i and body j (velocities
// v, spin w, radius r), or the floor (floor: j's terms absent, at rest).
KOKKOS_INLINE_FUNCTION RelativeVelocity contact_relative_velocity(double nx, double ny, double vxi,
                                                                  double vyi, double wi, double ri,
                                                                  bool floor, double vxj,
                                                                  double vyj, double wj,
                                                                  double rj) {
  double dvx = -vxi, dvy = -vyi;
  double spin = ri * wi;
  double om = -wi;
  if (!floor) {
    dvx += vxj;
    dvy += vyj;
    spin += rj * wj;
    om += wj;
  }
  RelativeVelocity u;
  u.un = dvx * nx + dvy * ny;
  u.ut = -dvx * ny + dvy * nx - spin;
  u.om = om;
  return u;
}

// Relative velocities of contact c between i and j (j < 0: the floor, at rest).
KOKKOS_INLINE_FUNCTION RelativeVelocity relative_velocity(const ParticleViews& part,
                                                          const ContactViews& con, int c, int i,
                                                          int j) {
  const bool floor = j < 0;
  const int b = floor ? i : j;
  return contact_relative_velocity(con.nx(c), con.ny(c), part.vx(i), part.vy(i), part.w(i),
                                   part.radius(i), floor, part.vx(b), part.vy(b), part.w(b),
                                   part.radius(b));
}

// Impulses of one contact: normal, tangential, rolling moment.
struct ContactImpulse {
  double pn, pt, pm;
};

// What the local solve of one contact reads besides its impulses and relative velocity.
struct LocalProblem {
  double gap, h;          // gap at the start of the step, time step
  double wn, wa, wb, wc;  // local Delassus entries (ContactMobility)
  double lower;           // -h F_c for a cohesive contact, else 0
  double friction;        // mu
  double rolling_lever;   // mu_r R_c
};

// The exact local solve of one contact with everything else fixed: normal first, then the
// friction/rolling box that depends on it, relaxed by omega and projected back onto the bounds.
// p0 are the current impulses and u the relative velocities they give. The one definition of
// the local step, used by every sweep and by the Newton step (src/newton.hpp).
template <class Fx>
KOKKOS_INLINE_FUNCTION ContactImpulse local_impulse(const ContactImpulse& p0,
                                                    const RelativeVelocity& u,
                                                    const LocalProblem& q, double omega) {
  const double lower = Fx::Cohesion ? q.lower : 0.0;
  double pn = solve_normal(p0.pn, u.un, q.gap, q.h, q.wn, lower);
  // Relaxation (omega < 1 under-, omega > 1 over-relaxation), projected back onto the bounds.
  pn = kmath::max(lower, p0.pn + omega * (pn - p0.pn));
  ContactImpulse p{pn, p0.pt, p0.pm};
  if (Fx::Friction) {
    const double shifted = pn - lower;  // P_n + h F_c >= 0
    // The tangential velocity after this contact's normal change is unchanged (t is orthogonal
    // to n and a normal impulse exerts no torque on a disk).
    const double bound_t = q.friction * shifted;
    double pt = p0.pt, pm = p0.pm;
    const double bound_r = Fx::Rolling ? q.rolling_lever * shifted : 0.0;
    if (Fx::Rolling && bound_r > 0.0 && q.wb > 0.0) {
      solve_friction_rolling(p0.pt, p0.pm, u.ut, u.om, q.wa, q.wb, q.wc, bound_t, bound_r, pt, pm);
    } else {
      // No rolling resistance here: the moment goes to zero, which shifts u_t by -c pm0.
      pt = solve_friction(p0.pt, u.ut - q.wc * p0.pm, q.wa, bound_t);
      pm = 0.0;
    }
    p.pt = kmath::clamp(p0.pt + omega * (pt - p0.pt), -bound_t, bound_t);
    p.pm = kmath::clamp(p0.pm + omega * (pm - p0.pm), -bound_r, bound_r);
  }
  return p;
}

// Size of an impulse change in impulse units (moments by the rolling radius r_c): what the
// convergence test compares with the tolerance (after division by h m g).
template <class Fx>
KOKKOS_INLINE_FUNCTION double impulse_change(double dn, double dt, double dm, double rc) {
  double change = kmath::fabs(dn);
  if (Fx::Friction) change += kmath::fabs(dt) + kmath::fabs(dm) / rc;
  return change;
}

// The local problem of contact slot c of system s.
KOKKOS_INLINE_FUNCTION LocalProblem local_problem(const SystemViews& sys, const ContactViews& con,
                                                  int s, int c) {
  return {con.gap(c),   sys.time_step(s), con.wn(c),
          con.wa(c),    con.wb(c),        con.wc(c),
          con.lower(c), sys.friction(s),  sys.rolling_friction(s) * con.rc(c)};
}

// One exact local solve of contact c with everything else fixed; returns the impulse change
// (dn, dt, dm) and the size of the change in impulse units (impulse_change), which
// above_tolerance compares with the step's tolerance.
// Reads: con.{partner, gap, nx, ny, rc, wn, wa, wb, wc, lower, pn, pt, pm}; part.{system, vx, vy,
// w, radius}; sys.{time_step, weight, friction, rolling_friction}.
template <class Fx>
KOKKOS_INLINE_FUNCTION double local_solve(const SystemViews& sys, const ParticleViews& part,
                                          const ContactViews& con, int c, int i, int j,
                                          double omega, double& dn, double& dt, double& dm) {
  dn = dt = dm = 0.0;
  if (con.wn(c) <= 0.0) return 0.0;  // two immobile bodies
  const int s = part.system(i);
  const ContactImpulse p0{con.pn(c), con.pt(c), con.pm(c)};
  const ContactImpulse p = local_impulse<Fx>(p0, relative_velocity(part, con, c, i, j),
                                             local_problem(sys, con, s, c), omega);
  dn = p.pn - p0.pn;
  dt = p.pt - p0.pt;
  dm = p.pm - p0.pm;
  return impulse_change<Fx>(dn, dt, dm, con.rc(c));
}

// Whether the largest change `worst` of a sweep of system s (in impulse units, as local_solve
// gives each) is above the step's tolerance [h m g]. Divided by h m g once per test instead of
// once per contact: division by one positive number keeps the order of numbers, so the quotient
// of the largest change is the largest quotient, bit for bit. A NaN is not above: such a system
// stops iterating, and the integrate guard fails it.
KOKKOS_INLINE_FUNCTION bool above_tolerance(const SystemViews& sys, int s, double worst) {
  return worst / (sys.time_step(s) * sys.weight(s)) > sys.step_tolerance(s);
}

// Applies an impulse change (dn, dt, dm) of contact c to the velocities of its bodies i and j.
KOKKOS_INLINE_FUNCTION void apply_impulse_change(const ParticleViews& part, const ContactViews& con,
                                                 int c, int i, int j, double dn, double dt,
                                                 double dm) {
  const double nx = con.nx(c), ny = con.ny(c);
  const double fx = dn * nx - dt * ny, fy = dn * ny + dt * nx;
  part.vx(i) -= part.inv_mass(i) * fx;
  part.vy(i) -= part.inv_mass(i) * fy;
  part.w(i) += part.inv_inertia(i) * (-part.radius(i) * dt - dm);
  if (j >= 0) {
    part.vx(j) += part.inv_mass(j) * fx;
    part.vy(j) += part.inv_mass(j) * fy;
    part.w(j) += part.inv_inertia(j) * (-part.radius(j) * dt + dm);
  }
}

// Adds to a body's velocity (vx, vy, w) what the impulses (pn, pt, pm) of one of its contacts
// with normal (nx, ny) give it: the partner j receives pn n + pt t (t = (-ny, nx)) and the
// moment pm, the owner i the opposite; both the torque -r pt. The one statement of H^T P, for
// BodyVelocity and the Newton step's host copy (src/newton.hpp).
KOKKOS_INLINE_FUNCTION void add_contact_impulse(bool owner, double pn, double pt, double pm,
                                                double nx, double ny, double im, double iI,
                                                double r, double& vx, double& vy, double& w) {
  const double fx = pn * nx - pt * ny, fy = pn * ny + pt * nx;
  if (owner) {
    vx -= im * fx;
    vy -= im * fy;
    w += iI * (-r * pt - pm);
  } else {
    vx += im * fx;
    vy += im * fy;
    w += iI * (-r * pt + pm);
  }
}

// v = v_free + M^-1 sum H^T P over the contacts incident to each particle.
// Reads: sys.unconverged; part.{system, cell, vfx, vfy, wf, inv_mass, inv_inertia, radius,
// n_incident, incident}; con.{pn, pt, pm, nx, ny}. Writes: part.{vx, vy, w}.
struct BodyVelocity {
  SystemViews sys;
  ParticleViews part;
  ContactViews con;
  bool only_unconverged;

  KOKKOS_INLINE_FUNCTION void operator()(int p) const {
    const int s = part.system(p);
    if (part.cell(p) < 0) return;
    if (only_unconverged && sys.unconverged(s) != kIterating) return;
    double vx = part.vfx(p), vy = part.vfy(p), w = part.wf(p);
    const double im = part.inv_mass(p), iI = part.inv_inertia(p), r = part.radius(p);
    const int n = part.n_incident(p);
    for (int a = 0; a < n; ++a) {
      const int c = part.incident(p * kIncident + a);
      add_contact_impulse(c / kSlots == p, con.pn(c), con.pt(c), con.pm(c), con.nx(c), con.ny(c),
                          im, iI, r, vx, vy, w);
    }
    part.vx(p) = vx;
    part.vy(p) = vy;
    part.w(p) = w;
  }
};

// One Gauss-Seidel update of contact c (owned by disk i) in place: the exact local solve, then
// its impulse change applied to the two bodies at once; `worst` keeps the largest change (impulse
// units).
template <class Fx>
KOKKOS_INLINE_FUNCTION void gauss_seidel_update(const SystemViews& sys, const ParticleViews& part,
                                                const ContactViews& con, int c, int i, double omega,
                                                double& worst) {
  const int j = con.partner(c);
  if (j == kNoContact) return;
  double dn, dt, dm;
  const double change = local_solve<Fx>(sys, part, con, c, i, j, omega, dn, dt, dm);
  if (dn == 0.0 && dt == 0.0 && dm == 0.0) return;
  worst = kmath::max(worst, change);
  con.pn(c) += dn;
  con.pt(c) += dt;
  con.pm(c) += dm;
  apply_impulse_change(part, con, c, i, j, dn, dt, dm);
}

// Jacobi: every contact reads the velocities of the previous iterate. Writing the impulses in
// place is safe: a contact's update reads only its own impulses and the (unchanged) velocities.
// Reads: sys.unconverged and what the local solve reads (local_solve). Writes: con.{pn, pt,
// pm}; sys.sweep_change.
template <class Fx>
struct JacobiContacts {
  SystemViews sys;
  ParticleViews part;
  ContactViews con;
  double omega;

  KOKKOS_INLINE_FUNCTION void operator()(int c) const {
    const int j = con.partner(c);
    if (j == kNoContact) return;
    const int i = c / kSlots;
    const int s = part.system(i);
    if (sys.unconverged(s) != kIterating) return;
    double dn, dt, dm;
    const double change = local_solve<Fx>(sys, part, con, c, i, j, omega, dn, dt, dm);
    con.pn(c) += dn;
    con.pt(c) += dt;
    con.pm(c) += dm;
    Kokkos::atomic_fetch_max(&sys.sweep_change(s), change);
  }
};

// Gauss-Seidel on one colour: contacts of one colour share no body, so each applies its
// impulse change to its two bodies at once without races.
// Reads: list; sys.unconverged; part.{inv_mass, inv_inertia} and what the local solve reads
// (local_solve). Writes: con.{pn, pt, pm}; part.{vx, vy, w}; sys.sweep_change.
template <class Fx>
struct GaussSeidelContacts {
  SystemViews sys;
  ParticleViews part;
  ContactViews con;
  DView<int> list;  // contact slots of this colour
  int first;
  double omega;

  KOKKOS_INLINE_FUNCTION void operator()(int a) const {
    const int c = list(first + a);
    const int j = con.partner(c);
    const int i = c / kSlots;
    const int s = part.system(i);
    if (sys.unconverged(s) != kIterating) return;
    double dn, dt, dm;
    const double change = local_solve<Fx>(sys, part, con, c, i, j, omega, dn, dt, dm);
    if (dn == 0.0 && dt == 0.0 && dm == 0.0) return;
    con.pn(c) += dn;
    con.pt(c) += dt;
    con.pm(c) += dm;
    apply_impulse_change(part, con, c, i, j, dn, dt, dm);
    Kokkos::atomic_fetch_max(&sys.sweep_change(s), change);
  }
};

// The number of contact slots disk p owns that hold a contact. ContactBuild fills a disk's
// slots from its first and marks the rest empty, so a loop over a system's contacts can stop
// at each disk's first empty slot instead of testing all kSlots.
KOKKOS_INLINE_FUNCTION int owned_contacts(const ContactViews& con, int p) {
  int k = 0;
  while (k < kSlots && con.partner(p * kSlots + k) != kNoContact) ++k;
  return k;
}

// f(c) for every contact slot of disks [first, end) that holds a contact, in slot order
// (for_contacts) or in the reverse order (for_contacts_reverse).
template <class F>
KOKKOS_INLINE_FUNCTION void for_contacts(const ContactViews& con, int first, int end, F&& f) {
  for (int p = first; p < end; ++p)
    for (int c = p * kSlots, e = c + owned_contacts(con, p); c < e; ++c) f(c);
}
template <class F>
KOKKOS_INLINE_FUNCTION void for_contacts_reverse(const ContactViews& con, int first, int end,
                                                 F&& f) {
  for (int p = end - 1; p >= first; --p)
    for (int c = p * kSlots + owned_contacts(con, p) - 1; c >= p * kSlots; --c) f(c);
}

// Gauss-Seidel in contact order within each system, one thread per system, alternating the
// direction every sweep (symmetric Gauss-Seidel). Systems share nothing, so this is parallel
// across the batch; within a system it needs no colouring. Each thread iterates its system to
// convergence (or its sweep cap) in one launch: the system's contacts stay in cache, and nothing
// is read back to the host between sweeps.
// Reads: sys.{active, unconverged, offset, count, max_sweeps, step_tolerance}; part.{inv_mass,
// inv_inertia} and what the local solve reads (local_solve). Writes: con.{pn, pt, pm};
// part.{vx, vy, w}; sys.unconverged; sweeps.
template <class Fx>
struct SequentialGaussSeidel {
  SystemViews sys;
  ParticleViews part;
  ContactViews con;
  DView<int> sweeps;  // [S] sweeps of this step
  double omega;

  KOKKOS_INLINE_FUNCTION void apply(int c, double& worst) const {
    gauss_seidel_update<Fx>(sys, part, con, c, c / kSlots, omega, worst);
  }

  KOKKOS_INLINE_FUNCTION void operator()(int s) const {
    if (!sys.active(s) || !sys.unconverged(s)) return;
    const int first = sys.offset(s), end = sys.offset(s) + sys.count(s);  // its disks
    const int cap = sys.max_sweeps(s);
    for (int sweep = 0; sweep < cap; ++sweep) {
      double worst = 0.0;
      auto update = [&](int c) { apply(c, worst); };
      if (sweep % 2 == 1)
        for_contacts_reverse(con, first, end, update);
      else
        for_contacts(con, first, end, update);
      sweeps(s) += 1;
      if (!above_tolerance(sys, s, worst)) {
        sys.unconverged(s) = 0;
        return;
      }
    }
  }
};

// The NNCG pieces shared by AcceleratedGaussSeidel and ColouredAcceleratedGaussSeidel.
// Squared norm of contact c's change over the last iteration (moments scaled by 1/r_c).
KOKKOS_INLINE_FUNCTION double nncg_change2(const ContactViews& con, int c) {
  if (con.partner(c) == kNoContact) return 0.0;
  const double dn = con.pn(c) - con.start_pn(c), dt = con.pt(c) - con.start_pt(c);
  const double dm = (con.pm(c) - con.start_pm(c)) / con.rc(c);
  return dn * dn + dt * dt + dm * dm;
}
// beta = |d_k|^2 / |d_{k-1}|^2; 2 (a restart) on the first iteration of a step.
KOKKOS_INLINE_FUNCTION double nncg_beta(double previous, double g2) {
  return previous > 0.0 ? g2 / previous : 2.0;
}
KOKKOS_INLINE_FUNCTION void nncg_keep_start(const ContactViews& con, int c) {
  if (con.partner(c) == kNoContact) return;
  con.start_pn(c) = con.pn(c);
  con.start_pt(c) = con.pt(c);
  con.start_pm(c) = con.pm(c);
}
// The NNCG step of contact c: beta > 1 restarts (the direction becomes the change d), else the
// impulses move by beta p and p becomes beta p + d. Writes the impulse step (sn, st, sm) and
// returns true when there is one for the bodies; the iterate is then the next start.
KOKKOS_INLINE_FUNCTION bool nncg_step(const ContactViews& con, int c, double beta, double& sn,
                                      double& st, double& sm) {
  sn = st = sm = 0.0;
  if (con.partner(c) == kNoContact) return false;
  const double dn = con.pn(c) - con.start_pn(c), dt = con.pt(c) - con.start_pt(c),
               dm = con.pm(c) - con.start_pm(c);
  const bool step = !(beta > 1.0);
  if (step) {
    sn = beta * con.dir_pn(c);
    st = beta * con.dir_pt(c);
    sm = beta * con.dir_pm(c);
    con.pn(c) += sn;
    con.pt(c) += st;
    con.pm(c) += sm;
  }
  con.dir_pn(c) = sn + dn;
  con.dir_pt(c) = st + dt;
  con.dir_pm(c) = sm + dm;
  nncg_keep_start(con, c);
  return step;
}

// Gauss-Seidel accelerated by the nonsmooth nonlinear conjugate gradient method (NNCG; Silcowitz,
// Niebe & Erleben, "A nonsmooth nonlinear conjugate gradient method for interactive contact
// force problems", 2010). One iteration is a symmetric pair of exact Gauss-Seidel sweeps (the
// projected map x -> GS(x)); its change d = GS(x) - x plays the role of the negative gradient.
// With beta = |d_k|^2 / |d_{k-1}|^2 the iterate takes the step x += beta p and the direction
// becomes p = beta p + d; beta > 1 restarts (no step; the direction becomes d), and so does
// the first iteration of a step. Force propagates through a chain of n grains in about n
// iterations instead of n^2. One thread per system iterating to convergence in one launch,
// like SequentialGaussSeidel; the convergence test is the same (largest local change of a
// sweep).
//
// With Newton steps (SolverSettings::newton_every), a launch iterates each system only up to its
// `sweep_limit` (sweeps of this step, [S]); the host then takes a Newton step (src/newton.hpp)
// and launches again, which restarts the iteration from the new impulses. In a fused step
// (pause_at_limit) a system stopped at its limit below the cap stays inside its step
// (sys.mid_step) for the host's round, and goes on in the next launch.
// Reads: sweep_limit; sys.{active, unconverged, offset, count, max_sweeps, step_tolerance};
// part.{inv_mass, inv_inertia} and what the local solve reads (local_solve). Writes: con.{pn,
// pt, pm, start_pn, start_pt, start_pm, dir_pn, dir_pt, dir_pm}; part.{vx, vy, w};
// sys.{unconverged, gradient2, mid_step (pause_at_limit)}; sweeps.
template <class Fx>
struct AcceleratedGaussSeidel {
  SystemViews sys;
  ParticleViews part;
  ContactViews con;
  DView<int> sweeps;  // [S] sweeps of this step
  double omega;
  DView<int> sweep_limit;  // [S] this launch's limit, below the system's cap; empty: the cap
  bool pause_at_limit = false;

  KOKKOS_INLINE_FUNCTION void apply(int c, double& worst) const {
    gauss_seidel_update<Fx>(sys, part, con, c, c / kSlots, omega, worst);
  }

  KOKKOS_INLINE_FUNCTION void operator()(int s) const {
    if (!sys.active(s) || !sys.unconverged(s)) return;
    const int first = sys.offset(s), end = sys.offset(s) + sys.count(s);  // its disks
    // The first iteration of a launch restarts, so no direction is read.
    sys.gradient2(s) = 0.0;
    for_contacts(con, first, end, [&](int c) { keep_start(c); });
    const int cap = sys.max_sweeps(s);
    const int limit = sweep_limit.extent(0) > 0 ? kmath::imin(sweep_limit(s), cap) : cap;
    bool converged = false;
    while (!converged && sweeps(s) < limit) converged = iterate(s, first, end);
    if (pause_at_limit) sys.mid_step(s) = !converged && sweeps(s) < cap ? 1 : 0;
  }

  // One iteration (a symmetric pair of sweeps and the NNCG step) over the contacts of disks
  // [first, end); true once converged.
  KOKKOS_INLINE_FUNCTION bool iterate(int s, int first, int end) const {
    double worst = 0.0;
    auto update = [&](int c) { apply(c, worst); };
    for_contacts(con, first, end, update);
    for_contacts_reverse(con, first, end, update);
    sweeps(s) += 2;
    if (!above_tolerance(sys, s, worst)) {
      sys.unconverged(s) = 0;
      return true;
    }
    // At the cap the step ends on the sweeps' impulses, each an exact local solve within its
    // bounds: NNCG's step is an extrapolation that nothing projects after it.
    if (sweeps(s) >= sys.max_sweeps(s)) return false;
    double g2 = 0.0;
    for_contacts(con, first, end, [&](int c) { g2 += nncg_change2(con, c); });
    const double previous = sys.gradient2(s);
    sys.gradient2(s) = g2;
    const double beta = nncg_beta(previous, g2);
    for_contacts(con, first, end, [&](int c) {
      double sn, st, sm;
      if (nncg_step(con, c, beta, sn, st, sm))
        apply_impulse_change(part, con, c, c / kSlots, con.partner(c), sn, st, sm);
    });
    return false;
  }

  KOKKOS_INLINE_FUNCTION void keep_start(int c) const { nncg_keep_start(con, c); }
};

// NNCG over graph-coloured symmetric Gauss-Seidel with one team per system, for wide devices
// (a GPU): the team's threads share the contacts of one colour (which share no body), sweep the
// colours forward then backward, and reduce the convergence test and |d|^2 among themselves;
// the NNCG step then moves the impulses colour by colour, each contact's step applied to its two
// bodies at once, which needs no atomics. Each team iterates its system to convergence in one
// launch, as AcceleratedGaussSeidel does with one thread. The sweeps read a packed copy of the
// system's contacts in colour order (`packed`, copied from the slots as a step's solve starts,
// the impulses back at each launch's end), so a colour's contacts lie side by side in memory and
// no empty slot is visited. The team
// first colours its own system (the Jones-Plassmann rounds of kernels/colouring.hpp, so each
// contact gets the colour a batch-wide colouring gives it), which needs no launch or host
// round trip per round, and sweeps only its own colours. A system whose contact pairs are those
// of its last colouring keeps that colouring (same_contacts).
// `list` holds each system's contact slots grouped by colour within the system's own slot
// range; `starts` [P * kSlots + S] the colour boundaries, system s's from offset(s) kSlots + s
// (a system has at most one colour per contact, and at least one).
// On a host backend (team size 1) it is the same method with the contacts in colour order.
// With sweeps_per_launch, a launch lasts at most that many sweeps of any system instead of its
// slowest system's whole solve: a system that has not converged keeps its colours, its sweeps
// and NNCG's last |d|^2 (sys.{colours, gradient2}) and goes on in the next launch, while the
// others take their next steps (Batch::step). The iterates are the same as in one launch.
// Reads: sys.{active, unconverged, mid_step, offset, count, max_sweeps, step_tolerance}; what
// the colouring reads (ColourRound) and what the local solve reads (local_solve), of the slots.
// Writes: con.{colour, coloured_partner, pn, pt, pm}; list, starts; packed, owner; part.{vx, vy,
// w}; sys.{unconverged, mid_step, colours, coloured_count, gradient2}; sweeps.
template <class Fx>
struct ColouredAcceleratedGaussSeidel {
  using Member = Kokkos::TeamPolicy<ExecSpace>::member_type;
  SystemViews sys;
  ParticleViews part;
  ContactViews con;
  DView<int> sweeps;  // [S] sweeps of this step
  DView<int> list, starts;
  double omega;
  // At most this many sweeps a launch (rounded up to whole iterations of two); a system still
  // iterating then goes on from where it stopped in the next launch (sys.mid_step). 0: to
  // convergence or the cap in one launch.
  int sweeps_per_launch = 0;

  // [P * kSlots] system s's contacts in colour order (list's), from offset(s) kSlots on, and
  // their owners; the NNCG start and direction live only here.
  ContactViews packed;
  DView<int> owner;

  KOKKOS_INLINE_FUNCTION void operator()(const Member& team) const {
    solve(team, team.league_rank());
  }

  // System s's solve (or its next launch's share) by this team.
  KOKKOS_INLINE_FUNCTION void solve(const Member& team, int s) const {
    if (!sys.active(s) || !sys.unconverged(s)) return;
    const SlotRange range = system_slots(sys, s);
    const int base = range.first + s;
    const int done = sweeps(s);  // > 0 where the step's solve goes on from the last launch
    const bool goes_on = sys.mid_step(s);
    const int n_colours = goes_on ? sys.colours(s) : start_step(team, s, range, base);
    const int first = range.first, end = starts(base + n_colours);  // the packed contacts
    if (!goes_on) pack(team, first, end);  // a solve that goes on has its copy
    // NNCG's last |d|^2; a step's first iteration restarts.
    double previous = goes_on ? sys.gradient2(s) : 0.0;
    team.team_barrier();  // the contacts are packed, and every thread has read the system's state
    const int cap = sys.max_sweeps(s);
    const int stop = sweeps_per_launch > 0 ? kmath::imin(cap, done + sweeps_per_launch) : cap;
    int sweep = done;
    for (; sweep < stop; sweep += 2) {
      // Each thread keeps the largest change of its own updates over both sweeps; one team
      // reduction per iteration then gives the system's (a maximum, so the same whatever the
      // order), where a reduction per colour cost a colour two team synchronisations.
      double worst = 0.0;
      for (int k = 0; k < n_colours; ++k) colour_sweep(team, base, k, worst);
      for (int k = n_colours - 1; k >= 0; --k) colour_sweep(team, base, k, worst);
      team.team_reduce(Kokkos::Max<double>(worst));
      Kokkos::single(Kokkos::PerTeam(team), [&]() { sweeps(s) += 2; });
      if (!above_tolerance(sys, s, worst)) {
        unpack(team, first, end);
        Kokkos::single(Kokkos::PerTeam(team), [&]() {
          sys.unconverged(s) = 0;
          sys.mid_step(s) = 0;
        });
        return;
      }
      double g2 = 0.0;
      Kokkos::parallel_reduce(
          Kokkos::TeamThreadRange(team, first, end),
          [&](int a, double& sum) { sum += nncg_change2(packed, a); }, g2);
      const double beta = nncg_beta(previous, g2);
      previous = g2;
      // At the cap the step ends on the sweeps' impulses, within their bounds
      // (AcceleratedGaussSeidel::iterate).
      if (sweep + 2 < cap) nncg_steps(team, base, n_colours, first, end, beta);
    }
    // Capped (the step ends unconverged), or paused until the next launch.
    unpack(team, first, end);
    Kokkos::single(Kokkos::PerTeam(team), [&]() {
      sys.mid_step(s) = sweep < cap ? 1 : 0;
      sys.gradient2(s) = previous;
    });
  }

  // The start of a step's solve: the system's contacts coloured and listed by colour. Returns
  // the colour count.
  KOKKOS_INLINE_FUNCTION int start_step(const Member& team, int s, SlotRange range,
                                        int base) const {
    const int n_colours =
        same_contacts(team, s, range) ? sys.colours(s) : colour(team, s, range, base);
    Kokkos::single(Kokkos::PerTeam(team), [&]() { sys.colours(s) = n_colours; });
    team.team_barrier();  // starts and list are the step's before they are read
    return n_colours;
  }

  // At the start of a step's solve, the contacts [first, end) of list copied from their slots
  // into `packed`, and the impulses the iteration starts from kept (nncg_keep_start). The copy
  // serves the step's every launch: between them no other stage touches a system inside its
  // solve (sys.mid_step), and each launch writes the impulses back to the slots as it ends.
  KOKKOS_INLINE_FUNCTION void pack(const Member& team, int first, int end) const {
    Kokkos::parallel_for(Kokkos::TeamThreadRange(team, first, end), [&](int a) {
      const int c = list(a);
      owner(a) = c / kSlots;
      packed.partner(a) = con.partner(c);
      packed.gap(a) = con.gap(c);
      packed.nx(a) = con.nx(c);
      packed.ny(a) = con.ny(c);
      packed.rc(a) = con.rc(c);
      packed.wn(a) = con.wn(c);
      packed.wa(a) = con.wa(c);
      packed.wb(a) = con.wb(c);
      packed.wc(a) = con.wc(c);
      packed.lower(a) = con.lower(c);
      packed.pn(a) = con.pn(c);
      packed.pt(a) = con.pt(c);
      packed.pm(a) = con.pm(c);
      nncg_keep_start(packed, a);
    });
  }
  // The impulses of the packed contacts [first, end) back into their slots.
  KOKKOS_INLINE_FUNCTION void unpack(const Member& team, int first, int end) const {
    Kokkos::parallel_for(Kokkos::TeamThreadRange(team, first, end), [&](int a) {
      const int c = list(a);
      con.pn(c) = packed.pn(a);
      con.pt(c) = packed.pt(a);
      con.pm(c) = packed.pm(a);
    });
  }

  // NNCG's step over the packed contacts [first, end). A step (beta <= 1) moves them colour by
  // colour, each contact's impulse step applied to its two bodies at once (a colour's contacts
  // share no body); a restart moves no impulse and only sets the direction and the start, all
  // contacts at once.
  KOKKOS_INLINE_FUNCTION void nncg_steps(const Member& team, int base, int n_colours, int first,
                                         int end, double beta) const {
    if (beta > 1.0) {
      Kokkos::parallel_for(Kokkos::TeamThreadRange(team, first, end), [&](int a) {
        double sn, st, sm;
        nncg_step(packed, a, beta, sn, st, sm);
      });
      team.team_barrier();
      return;
    }
    for (int k = 0; k < n_colours; ++k) {
      Kokkos::parallel_for(
          Kokkos::TeamThreadRange(team, starts(base + k), starts(base + k + 1)), [&](int a) {
            double sn, st, sm;
            if (nncg_step(packed, a, beta, sn, st, sm))
              apply_impulse_change(part, packed, a, owner(a), packed.partner(a), sn, st, sm);
          });
      team.team_barrier();
    }
  }

  // Whether every contact slot of the system holds the partner it held when the system was last
  // coloured (with the same disk count). A colouring is a function of the partners alone (the
  // incidence lists are built from them, the priorities from the slots' places in the system),
  // so such a system keeps its colours, list and colour starts, which nothing else writes. Most
  // steps change no contact pair (docs/PERFORMANCE.md, "Building for more cores or a GPU").
  KOKKOS_INLINE_FUNCTION bool same_contacts(const Member& team, int s, SlotRange range) const {
    if (sys.coloured_count(s) != sys.count(s) + 1) return false;
    int changed = 0;
    Kokkos::parallel_reduce(
        Kokkos::TeamThreadRange(team, range.first, range.end),
        [&](int c, int& n) { n += con.partner(c) != con.coloured_partner(c) ? 1 : 0; }, changed);
    return changed == 0;
  }

  // Colours the system's contacts and lists them by colour; keeps the partners it coloured.
  // Returns the colour count.
  KOKKOS_INLINE_FUNCTION int colour(const Member& team, int s, SlotRange range, int base) const {
    const int n_colours = colour_system(team, range);
    group_by_colour(team, range, base, n_colours);
    Kokkos::parallel_for(Kokkos::TeamThreadRange(team, range.first, range.end),
                         [&](int c) { con.coloured_partner(c) = con.partner(c); });
    Kokkos::single(Kokkos::PerTeam(team), [&]() { sys.coloured_count(s) = sys.count(s) + 1; });
    return n_colours;
  }

  // One colour's contacts updated in parallel; `worst` keeps this thread's largest change. The
  // barrier lets the next colour read the velocities this one wrote.
  KOKKOS_INLINE_FUNCTION void colour_sweep(const Member& team, int base, int k,
                                           double& worst) const {
    Kokkos::parallel_for(
        Kokkos::TeamThreadRange(team, starts(base + k), starts(base + k + 1)),
        [&](int a) { gauss_seidel_update<Fx>(sys, part, packed, a, owner(a), omega, worst); });
    team.team_barrier();
  }

  // Colours the system's contacts in Jones-Plassmann rounds until none is left; returns the
  // colour count.
  KOKKOS_INLINE_FUNCTION int colour_system(const Member& team, SlotRange range) const {
    const ColourReset reset{con};
    Kokkos::parallel_for(Kokkos::TeamThreadRange(team, range.first, range.end),
                         [&](int c) { reset(c); });
    team.team_barrier();
    for (int round = 0;; ++round) {
      const ColourRound colour_round{sys, part, con, round};
      int uncoloured = 0;
      Kokkos::parallel_reduce(
          Kokkos::TeamThreadRange(team, range.first, range.end),
          [&](int c, int& n) { colour_round(c, n); }, uncoloured);
      team.team_barrier();
      if (uncoloured == 0) return round + 1;
    }
  }

  // Writes the system's contact slots into list[range], grouped by colour (in slot order within
  // a colour), and the colour boundaries into starts[base ...]: one team scan per colour, whose
  // extra last element writes where the next colour begins.
  KOKKOS_INLINE_FUNCTION void group_by_colour(const Member& team, SlotRange range, int base,
                                              int n_colours) const {
    Kokkos::single(Kokkos::PerTeam(team), [&]() { starts(base) = range.first; });
    team.team_barrier();
    for (int k = 0; k < n_colours; ++k) {
      const int next = starts(base + k);
      Kokkos::parallel_scan(Kokkos::TeamThreadRange(team, range.first, range.end + 1),
                            [&](int c, int& partial, bool final) {
                              if (c == range.end) {
                                if (final) starts(base + k + 1) = next + partial;
                              } else if (con.colour(c) == k) {
                                if (final) list(next + partial) = c;
                                ++partial;
                              }
                            });
      team.team_barrier();
    }
  }
};

}  // namespace loosepack
