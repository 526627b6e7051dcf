// The stepper of a batch: the stages of a time step (StepStage), the solvers' host loops and
// Newton rounds, per-system status and rest detection; deposition and avalanche events. The
// batch's device state (allocation, loading a system, reading and restoring it) is in
// src/batch_state.cpp. All device work is in kernels/.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <utility>

#include "batch_impl.hpp"
#include "kernels/colouring.hpp"
#include "kernels/contacts.hpp"
#include "kernels/deposit.hpp"
#include "kernels/events.hpp"
#include "kernels/integrate.hpp"
#include "kernels/solver.hpp"
#include "loosepack/geometry.hpp"
#include "src/newton.hpp"

namespace loosepack {

std::string failure_message(Failure f) {
  switch (f) {
    case Failure::None:
      return "none";
    case Failure::NonFinite:
      return "non-finite position or velocity (NaN or Inf)";
    case Failure::ContactOverflow:
      return "a disk had more contacts than the fixed capacity (overlapping disks?)";
    case Failure::ParticleOverflow:
      return "more disks than the system's capacity";
    case Failure::Unconverged:
      return "the solver hit its sweep cap on every step for protocol.max_unconverged_time";
    case Failure::Escaped:
      return "a disk ended outside the box (above H + 4 R_max or below the floor): the solution "
             "blew up (a solver setting that does not converge, e.g. Jacobi without mass "
             "splitting)";
    case Failure::Runaway:
      return "a disk moved faster than a fall through the box and cohesion can make it: the "
             "solution blew up";
    case Failure::Overlap:
      return "two disks, or a disk and the floor, ended overlapping by more than 0.25 R: the "
             "solution blew up";
  }
  return "unknown";
}

template <class F>
void Batch::Impl::with_effects(F&& f) const {
  const EffectFlags e = needed_effects();
  if (e.rolling) {
    f(Effects<true, true, true>{});
  } else if (e.friction) {
    if (e.cohesion)
      f(Effects<true, true, false>{});
    else
      f(Effects<false, true, false>{});
  } else {
    if (e.cohesion)
      f(Effects<true, false, false>{});
    else
      f(Effects<false, false, false>{});
  }
}

template <class Fx>
ColouredAcceleratedGaussSeidel<Fx> Batch::Impl::team_solver() {
  return {sys,
          part,
          con,
          sweeps_this_step,
          colour_list,
          system_colour_start,
          solver.relaxation,
          solver.sweeps_per_launch,
          packed,
          packed_owner};
}

template <class Fx>
void Batch::Impl::solve() {
  const SystemViews sys_ = sys;
  const auto sweeps = sweeps_this_step;
  const double omega = solver.relaxation;
  const bool jacobi = solver.kind == SolverKind::Jacobi;
  const int n_contacts = n_particles * kSlots;
  // The per-system solvers iterate each system to convergence in one launch.
  if (solver.kind == SolverKind::AcceleratedGaussSeidel) {
    const AcceleratedGaussSeidel<Fx> sweeper{sys, part, con, sweeps, omega, DView<int>()};
    if (newton_rounds()) {
      solve_with_newton(sweeper);
      return;
    }
    Kokkos::parallel_for("accelerated_gauss_seidel",
                         PerSystemPolicy(0, n_systems, Kokkos::ChunkSize(1)), sweeper);
    return;
  }
  if (solver.kind == SolverKind::SequentialGaussSeidel) {
    Kokkos::parallel_for("sequential_gauss_seidel",
                         PerSystemPolicy(0, n_systems, Kokkos::ChunkSize(1)),
                         SequentialGaussSeidel<Fx>{sys, part, con, sweeps, omega});
    return;
  }
  if (solver.kind == SolverKind::ColouredAcceleratedGaussSeidel) {  // one team per system
    const auto solver_ = team_solver<Fx>();
    Kokkos::parallel_for("coloured_accelerated_gauss_seidel", team_policy(solver_), solver_);
    return;
  }
  int n_colours = 0;
  std::vector<int> colour_begin;
  if (!jacobi) {
    n_colours = colour();
    auto hs = Kokkos::create_mirror_view(colour_start);
    Kokkos::deep_copy(hs, colour_start);
    colour_begin.assign(hs.data(), hs.data() + n_colours + 1);
  }
  // Each system stops at its own cap (kStoppedAtCap: not converged).
  const int largest_cap = *std::max_element(sweep_cap.begin(), sweep_cap.end());
  for (int sweep = 0; sweep < largest_cap; ++sweep) {
    if (jacobi) {
      Kokkos::parallel_for("jacobi_contacts", Kokkos::RangePolicy<ExecSpace>(0, n_contacts),
                           JacobiContacts<Fx>{sys, part, con, omega});
      Kokkos::parallel_for("jacobi_bodies", Kokkos::RangePolicy<ExecSpace>(0, n_particles),
                           BodyVelocity{sys, part, con, true});
    } else {
      for (int k = 0; k < n_colours; ++k) {
        const int n = colour_begin[k + 1] - colour_begin[k];
        if (n == 0) continue;
        Kokkos::parallel_for(
            "gauss_seidel_colour", Kokkos::RangePolicy<ExecSpace>(0, n),
            GaussSeidelContacts<Fx>{sys, part, con, colour_list, colour_begin[k], omega});
      }
    }
    int still = 0;
    Kokkos::parallel_reduce(
        "convergence", Kokkos::RangePolicy<ExecSpace>(0, n_systems),
        KOKKOS_LAMBDA(int s, int& n) {
          if (!sys_.active(s) || sys_.unconverged(s) != kIterating) return;
          sweeps(s) += 1;
          if (!above_tolerance(sys_, s, sys_.sweep_change(s))) {
            sys_.unconverged(s) = 0;
          } else if (sweeps(s) >= sys_.max_sweeps(s)) {
            sys_.unconverged(s) = kStoppedAtCap;
          } else {
            ++n;
          }
          sys_.sweep_change(s) = 0.0;
        },
        still);
    if (still == 0) break;
  }
}

// The accelerated solver with Newton steps: each system iterates until it converges or has
// done its wait; the host then takes Newton steps for the systems still iterating, and the sweeps
// go on from the new impulses for another wait. The wait adapts per system from round to round
// and carries over to the next step (NewtonPace, src/newton.hpp): where Newton steps pay (a tall
// cohesive deposit, whose sweeps crawl) they come early; where the sweeps' trouble is a nonsmooth
// switch that a Newton step does not settle either, they fade out and cost little.
template <class Fx>
void Batch::Impl::solve_with_newton(const AcceleratedGaussSeidel<Fx>& plain) {
  AcceleratedGaussSeidel<Fx> sweeper = plain;  // the same sweeps, stopping at sweep_limit
  sweeper.sweep_limit = sweep_limit;
  auto& limit = sweep_limit_host;
  for (int s = 0; s < n_systems; ++s) limit(s) = first_newton_limit(s);
  auto& unconverged = newton_host.unconverged;
  auto& done = newton_host.sweeps;
  for (;;) {
    Kokkos::deep_copy(sweep_limit, limit);
    Kokkos::parallel_for("accelerated_gauss_seidel",
                         PerSystemPolicy(0, n_systems, Kokkos::ChunkSize(1)), sweeper);
    Kokkos::deep_copy(unconverged, sys.unconverged);
    Kokkos::deep_copy(done, sweeps_this_step);
    std::vector<int> due;
    for (int s = 0; s < n_systems; ++s)
      if (status[static_cast<std::size_t>(s)].active && unconverged(s) &&
          done(s) < sweep_cap[static_cast<std::size_t>(s)])
        due.push_back(s);
    if (due.empty()) {  // every system converged or was capped
      for (int s = 0; s < n_systems; ++s)
        if (status[static_cast<std::size_t>(s)].active)
          newton_pace[static_cast<std::size_t>(s)].step_done(
              unconverged(s) != 0, sweep_cap[static_cast<std::size_t>(s)]);
      return;
    }
    lap(timer(StepStage::Solve));
    newton_round<Fx>(due);
    lap(newton_cost);
    for (int s : due) limit(s) = next_newton_limit(s, done(s));
  }
}

namespace {
template <class T>
using HostCopy =
    decltype(Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), std::declval<KView<T>>()));
template <class T>
HostCopy<T> host_copy(const KView<T>& v) {
  return Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), v);
}

// Host copies of the batch state a Newton round reads (the same memory on a host backend): each
// system's bodies and contacts gathered into a NewtonSystem, and its impulses and velocities
// scattered back after the round.
struct NewtonHostState {
  HostCopy<double> vx, vy, w, vfx, vfy, wf, inv_mass, inv_inertia, radius;
  HostCopy<int> n_incident, incident, partner;
  HostCopy<double> nx, ny, gap, rc, wn, wa, wb, wc, lower, pn, pt, pm, weight, tolerance;
  HostCopy<int> counts;

  NewtonHostState(const ParticleViews& part, const ContactViews& con, const SystemViews& sys)
      : vx(host_copy(part.vx)),
        vy(host_copy(part.vy)),
        w(host_copy(part.w)),
        vfx(host_copy(part.vfx)),
        vfy(host_copy(part.vfy)),
        wf(host_copy(part.wf)),
        inv_mass(host_copy(part.inv_mass)),
        inv_inertia(host_copy(part.inv_inertia)),
        radius(host_copy(part.radius)),
        n_incident(host_copy(part.n_incident)),
        incident(host_copy(part.incident)),
        partner(host_copy(con.partner)),
        nx(host_copy(con.nx)),
        ny(host_copy(con.ny)),
        gap(host_copy(con.gap)),
        rc(host_copy(con.rc)),
        wn(host_copy(con.wn)),
        wa(host_copy(con.wa)),
        wb(host_copy(con.wb)),
        wc(host_copy(con.wc)),
        lower(host_copy(con.lower)),
        pn(host_copy(con.pn)),
        pt(host_copy(con.pt)),
        pm(host_copy(con.pm)),
        weight(host_copy(sys.weight)),
        tolerance(host_copy(sys.step_tolerance)),
        counts(host_copy(sys.count)) {}

  // System s's bodies first..first+count and their contacts in slot order; `local` maps the
  // system's contact slots to the NewtonSystem's contacts (-1: no contact).
  NewtonSystem gather(int s, const SystemParams& pr, int first, std::vector<int>& local) const {
    const int count = counts(s);
    NewtonSystem ns;
    ns.impulse_unit = pr.time_step * weight(s);
    local.assign(static_cast<std::size_t>(count) * kSlots, -1);
    for (int p = first; p < first + count; ++p)
      for (int a = 0; a < kSlots; ++a) {
        const int c = p * kSlots + a;
        const int j = partner(c);
        if (j == kNoContact) break;
        local[static_cast<std::size_t>(c - first * kSlots)] = ns.contacts();
        ns.i.push_back(p - first);
        ns.j.push_back(j >= 0 ? j - first : kFloor);
        ns.nx.push_back(nx(c));
        ns.ny.push_back(ny(c));
        ns.rc.push_back(rc(c));
        ns.problem.push_back({gap(c), pr.time_step, wn(c), wa(c), wb(c), wc(c), lower(c),
                              pr.friction, pr.rolling_friction * rc(c)});
        ns.impulse.push_back({pn(c), pt(c), pm(c)});
      }
    ns.incident_start.push_back(0);
    for (int p = first; p < first + count; ++p) {
      ns.inv_mass.push_back(inv_mass(p));
      ns.inv_inertia.push_back(inv_inertia(p));
      ns.radius.push_back(radius(p));
      ns.vfx.push_back(vfx(p));
      ns.vfy.push_back(vfy(p));
      ns.wf.push_back(wf(p));
      ns.vx.push_back(vx(p));
      ns.vy.push_back(vy(p));
      ns.w.push_back(w(p));
      for (int a = 0; a < n_incident(p); ++a)
        ns.incident.push_back(
            local[static_cast<std::size_t>(incident(p * kIncident + a) - first * kSlots)]);
      ns.incident_start.push_back(static_cast<int>(ns.incident.size()));
    }
    return ns;
  }

  // The round's impulses and velocities back into the copies of system s.
  void scatter(const NewtonSystem& ns, int s, int first, const std::vector<int>& local) const {
    for (int p = first; p < first + counts(s); ++p) {
      const auto b = static_cast<std::size_t>(p - first);
      vx(p) = ns.vx[b];
      vy(p) = ns.vy[b];
      w(p) = ns.w[b];
      for (int a = 0; a < kSlots; ++a) {
        const int c = p * kSlots + a;
        const int l = local[static_cast<std::size_t>(c - first * kSlots)];
        if (l < 0) break;
        const ContactImpulse& P = ns.impulse[static_cast<std::size_t>(l)];
        pn(c) = P.pn;
        pt(c) = P.pt;
        pm(c) = P.pm;
      }
    }
  }

  // The copies' velocities and impulses back into the batch.
  void write_back(const ParticleViews& part, const ContactViews& con) const {
    Kokkos::deep_copy(part.vx, vx);
    Kokkos::deep_copy(part.vy, vy);
    Kokkos::deep_copy(part.w, w);
    Kokkos::deep_copy(con.pn, pn);
    Kokkos::deep_copy(con.pt, pt);
    Kokkos::deep_copy(con.pm, pm);
  }
};
}  // namespace

// Newton steps (src/newton.hpp) for the systems `due`, on host copies of their state, one
// system per host thread; per round at most kNewtonSteps steps that are not blocked, and
// kMaxSteps in all (a blocked step opens one self-stress of a loop that cannot close:
// src/newton.hpp).
template <class Fx>
void Batch::Impl::newton_round(const std::vector<int>& due) {
  constexpr int kNewtonSteps = 3, kMaxSteps = 8;
  const NewtonHostState host(part, con, sys);
  Kokkos::parallel_for(
      "newton",
      Kokkos::RangePolicy<Kokkos::DefaultHostExecutionSpace, Kokkos::Schedule<Kokkos::Dynamic>>(
          0, static_cast<int>(due.size())),
      [&](int k) {
        const int s = due[static_cast<std::size_t>(k)];
        const auto su = static_cast<std::size_t>(s);
        std::vector<int> local;
        NewtonSystem ns = host.gather(s, params[su], offsets[su], local);
        ns.factor = newton_factor[su].get();
        const double tolerance = host.tolerance(s), before = ns.residual<Fx>();
        double residual = before;
        int steps = 0;  // taken (a failed one ends the round)
        for (int full = 0; full < kNewtonSteps && steps < kMaxSteps && residual > tolerance;
             ++steps) {
          const auto step = ns.newton_step<Fx>();
          if (step == NewtonSystem::Step::Failed) break;
          if (step == NewtonSystem::Step::Full) ++full;
          residual = ns.residual<Fx>();
        }
        newton_steps[su] += steps;
        newton_pace[su].after_round(residual < 0.1 * before || !(residual > tolerance),
                                    NewtonPace::round_cost(steps, ns.factor_entries, ns.contacts()),
                                    shortest_newton_wait(s), longest_newton_wait(s));
        host.scatter(ns, s, offsets[su], local);
      });
  host.write_back(part, con);
}

// Colours the contacts of every system (ColourRound) and lists the batch's contact slots by
// colour in colour_list, delimited by colour_start. Returns the colour count.
int Batch::Impl::colour() {
  const int n_contacts = n_particles * kSlots;
  Kokkos::parallel_for("colour_reset", Kokkos::RangePolicy<ExecSpace>(0, n_contacts),
                       ColourReset{con});
  int rounds = 0;
  for (;; ++rounds) {
    int uncoloured = 0;
    Kokkos::parallel_reduce("colour_round", Kokkos::RangePolicy<ExecSpace>(0, n_contacts),
                            ColourRound{sys, part, con, rounds}, uncoloured);
    if (uncoloured == 0) break;
  }
  const int n_colours = rounds + 1;
  if (static_cast<int>(colour_fill.extent(0)) < n_colours) {
    colour_fill = alloc<int>("colour_fill", static_cast<std::size_t>(n_colours));
    colour_start = alloc<int>("colour_start", static_cast<std::size_t>(n_colours) + 1);
  }
  auto fill = colour_fill;
  auto start = colour_start;
  auto list = colour_list;
  auto col = con.colour;
  Kokkos::deep_copy(ExecSpace(), fill, 0);
  Kokkos::parallel_for(
      "colour_count", Kokkos::RangePolicy<ExecSpace>(0, n_contacts), KOKKOS_LAMBDA(int c) {
        if (col(c) >= 0) Kokkos::atomic_increment(&fill(col(c)));
      });
  Kokkos::parallel_scan(
      "colour_scan", Kokkos::RangePolicy<ExecSpace>(0, n_colours + 1),
      KOKKOS_LAMBDA(int k, int& partial, bool final) {
        const int n = k < n_colours ? fill(k) : 0;
        if (final) start(k) = partial;
        partial += n;
      });
  Kokkos::deep_copy(ExecSpace(), fill, 0);
  Kokkos::parallel_for(
      "colour_fill", Kokkos::RangePolicy<ExecSpace>(0, n_contacts), KOKKOS_LAMBDA(int c) {
        const int k = col(c);
        if (k >= 0) list(start(k) + Kokkos::atomic_fetch_add(&fill(k), 1)) = c;
      });
  return n_colours;
}

// The particle ranges of the contact stage: on the host, runs of active systems of about
// kChunkSlots particle slots each, so that inactive systems (at rest, or finished while the rest
// of the batch runs) cost nothing and one chunk's contact arrays stay in cache from one kernel
// to the next; on a device, which hides latency by width, the whole batch in one launch.
void Batch::Impl::chunk_active() {
  chunks.clear();
  constexpr bool host_memory = Kokkos::SpaceAccessibility<Kokkos::HostSpace, MemSpace>::accessible;
  if (!host_memory) {
    chunks.emplace_back(0, n_particles);
    return;
  }
  // A system's disks, not its slot's capacity: a deposit and a relaxation region fill a slot
  // sized for the whole box only as the deposit grows. A run of active systems next to each
  // other shares a chunk (its span includes the empty tails, whose particles have no cell).
  std::size_t last = status.size();  // the last active system
  for (std::size_t s = 0; s < status.size(); ++s) {
    if (!status[s].active) continue;
    const int begin = offsets[s], end = begin + status[s].count;
    if (!chunks.empty() && last + 1 == s &&
        chunks.back().second - chunks.back().first < kChunkSlots)
      chunks.back().second = end;
    else
      chunks.emplace_back(begin, end);
    last = s;
  }
}

const char* stage_name(StepStage stage) {
  switch (stage) {
    case StepStage::Margin:
      return "margin";
    case StepStage::Grid:
      return "grid";
    case StepStage::FreeVelocity:
      return "free_velocity";
    case StepStage::Contacts:
      return "contacts";
    case StepStage::Solve:
      return "solve";
    case StepStage::Integrate:
      return "integrate";
    case StepStage::Status:
      return "status";
  }
  return "?";
}

// One time step of the active systems: the stages of StepStage in their order (a system inside
// a step whose solve goes on takes part in the solve alone), each launched over the batch, or
// with solver.fused_step all but the status's host side in one launch.
void Batch::Impl::step() {
  if (std::none_of(status.begin(), status.end(), [](const SystemStatus& st) { return st.active; }))
    return;
  upload_changed_active();
  if (timing) {
    ExecSpace().fence();
    stage_timer.reset();
    lap_counts = launch_counts();
    ++timed_steps;
  }
  if (solver.fused_step) {
    with_effects([this](auto fx) { fused_step<decltype(fx)>(); });
    return;
  }
  for (int k = 0; k < kStepStages; ++k) {
    const auto stage = static_cast<StepStage>(k);
    run_stage(stage);
    lap(timer(stage));
  }
}

void Batch::Impl::run_stage(StepStage stage) {
  switch (stage) {
    case StepStage::Margin:
      return margin_stage();
    // Inactive systems get no cells: all later kernels skip them.
    case StepStage::Grid:
      return build_grid(sys, part, grid, n_particles, n_cells);
    case StepStage::FreeVelocity:
      Kokkos::parallel_for("free_velocity", Kokkos::RangePolicy<ExecSpace>(0, n_particles),
                           FreeVelocity{sys, part});
      return;
    case StepStage::Contacts:
      return contact_stage();
    case StepStage::Solve:
      return solve_stage();
    case StepStage::Integrate:
      return integrate_stage();
    case StepStage::Status:
      return status_stage();
  }
}

// The detection margin and the solver tolerance from the last step's speeds (StepStart).
void Batch::Impl::margin_stage() {
  Kokkos::parallel_for(
      "margin", Kokkos::RangePolicy<ExecSpace>(0, n_systems),
      StepStart{sys, sweeps_this_step, solver.relative_tolerance, kRelativeToleranceStep});
}

// Contacts, warm-started from the previous step's impulses, then the velocities those impulses
// give. Systems not stepped now, and systems inside a step, keep theirs untouched (ContactBuild).
void Batch::Impl::contact_stage() {
  // Chunk by chunk of active systems (they share nothing; see chunk_active).
  chunk_active();
  const bool split_mass = solver.kind == SolverKind::Jacobi && solver.mass_splitting;
  for (const auto& [p0, p1] : chunks) {
    Kokkos::parallel_for("contacts", Kokkos::RangePolicy<ExecSpace>(p0, p1),
                         ContactBuild{sys, part, con, grid});
    Kokkos::parallel_for("incident", Kokkos::RangePolicy<ExecSpace>(p0, p1),
                         IncidentScatter{sys, part, con});
    Kokkos::parallel_for("incident_sort", Kokkos::RangePolicy<ExecSpace>(p0, p1),
                         IncidentSort{part});
    Kokkos::parallel_for("mobility", Kokkos::RangePolicy<ExecSpace>(p0, p1),
                         ContactMobilityBuild{part, con, split_mass});
    Kokkos::parallel_for("warm_start", Kokkos::RangePolicy<ExecSpace>(p0, p1),
                         BodyVelocity{sys, part, con, false});
  }
}

// The effects of the systems active now (not of every system the batch ever held): the
// specialised kernels skip only terms that are exactly zero for the others, so a system's
// results do not depend on which kernel its batch runs, and a batch runs the cheapest one its
// current members allow.
Batch::KernelEffects Batch::Impl::needed_effects() const {
  EffectFlags e;
  for (int s = 0; s < n_systems; ++s) {
    if (!status[static_cast<std::size_t>(s)].active) continue;
    const SystemParams& pr = params[static_cast<std::size_t>(s)];
    e.cohesion = e.cohesion || pr.cohesive_force() > 0.0;
    e.friction = e.friction || pr.friction > 0.0;
    // The rolling bound mu_r R_c P_n holds without sliding friction too; the rolling kernel is
    // the one with every effect, whose sliding bound is then zero.
    e.rolling = e.rolling || pr.rolling_friction > 0.0;
  }
  return e;
}

void Batch::Impl::solve_stage() {
  with_effects([this](auto fx) { solve<decltype(fx)>(); });
}

// The fused step: one launch (system_step), the status read back, and with Newton steps the
// rounds of the systems that stopped at their wait inside the step, which go on in the next
// launch while the others take their next steps.
template <class Fx>
void Batch::Impl::fused_step() {
  const bool newton = newton_rounds();
  if (newton) upload_newton_limits();
  for (int s = 0; s < n_systems; ++s)
    launched[static_cast<std::size_t>(s)] = status[static_cast<std::size_t>(s)].active ? 1 : 0;
  system_step<Fx>();
  lap(fused_cost);
  read_status();
  lap(timer(StepStage::Status));
  if (newton) newton_between_launches<Fx>();
}

// Each sweep limit of the fused step's next launch: a system that starts a step sweeps until
// its first Newton round is due (or to the cap where its pace skips the rounds this step); one
// inside its step keeps the limit its last round set.
void Batch::Impl::upload_newton_limits() {
  for (int s = 0; s < n_systems; ++s) {
    const auto su = static_cast<std::size_t>(s);
    if (status[su].mid_step) continue;
    sweep_limit_host(s) = first_newton_limit(s);
  }
  Kokkos::deep_copy(sweep_limit, sweep_limit_host);
}

// After a fused step's launch: the Newton rounds of the systems inside their step, each with
// its next limit; the pace of those whose step ended (solve_with_newton's, system by system).
template <class Fx>
void Batch::Impl::newton_between_launches() {
  std::vector<int> due;
  for (int s = 0; s < n_systems; ++s) {
    const auto su = static_cast<std::size_t>(s);
    const SystemStatus& st = status[su];
    if (!launched[su]) continue;
    if (st.mid_step)
      due.push_back(s);
    else
      newton_pace[su].step_done(!st.converged, sweep_cap[su]);
  }
  if (due.empty()) return;
  newton_round<Fx>(due);
  lap(newton_cost);
  for (int s : due)
    sweep_limit_host(s) =
        next_newton_limit(s, static_cast<int>(host_report(s * kStatusFields + kSweeps)));
}

// One team per system takes it through every stage (SystemStep, kernels/step.hpp) with the
// solver's sweeps of one system: the team solver's, or one thread's (the accelerated solver's
// stopping at the Newton rounds' limits, where it takes them).
template <class Fx>
void Batch::Impl::system_step() {
  const auto launch = [&](const auto& solve) {
    using Solve = std::decay_t<decltype(solve)>;
    const SystemStep<Solve> step{
        sys,
        part,
        con,
        grid,
        StepStart{sys, sweeps_this_step, solver.relative_tolerance, kRelativeToleranceStep},
        solve,
        StatusReport{sys, sweeps_this_step, report},
        solver.overlap_correction};
    Kokkos::parallel_for("system_step", team_policy(step), step);
  };
  const auto& sweeps = sweeps_this_step;
  const double omega = solver.relaxation;
  switch (solver.kind) {
    case SolverKind::ColouredAcceleratedGaussSeidel:
      return launch(TeamSolve<Fx>{team_solver<Fx>()});
    case SolverKind::AcceleratedGaussSeidel: {
      const bool newton = newton_rounds();
      return launch(OneThreadSolve<AcceleratedGaussSeidel<Fx>>{
          {sys, part, con, sweeps, omega, newton ? sweep_limit : DView<int>(), newton}});
    }
    case SolverKind::SequentialGaussSeidel:
      return launch(OneThreadSolve<SequentialGaussSeidel<Fx>>{{sys, part, con, sweeps, omega}});
    default:  // refused when the batch was made
      throw std::logic_error("Batch: a fused step with a solver that sweeps the whole batch");
  }
}

// x += h v (wrapped into [0, L_x)), theta += h w; then the overlap correction where it is on.
void Batch::Impl::integrate_stage() {
  Kokkos::parallel_for("integrate", Kokkos::RangePolicy<ExecSpace>(0, n_particles),
                       Integrate{sys, part});
  if (solver.overlap_correction > 0.0)
    Kokkos::parallel_for("overlap_correction", PerSystemPolicy(0, n_systems, Kokkos::ChunkSize(1)),
                         OverlapCorrection{sys, part, con, solver.overlap_correction});
}

// Per-system status on the host: the non-finite and overflow guards stop a system; rest
// detection. The device packs it (StatusReport), the host reads it in one copy (read_status).
void Batch::Impl::status_stage() {
  Kokkos::parallel_for("status_report", Kokkos::RangePolicy<ExecSpace>(0, n_systems),
                       StatusReport{sys, sweeps_this_step, report});
  read_status();
}

// The status report read back and acted on. A system whose solve goes on (sys.mid_step) has
// finished no step yet: only the solve's balance counts it.
void Batch::Impl::read_status() {
  Kokkos::deep_copy(host_report, report);
  const auto field = [&](int s, StatusField f) { return host_report(s * kStatusFields + f); };
  const auto whole = [&](int s, StatusField f) { return static_cast<int>(field(s, f)); };
  Balance balance;
  for (int s = 0; s < n_systems; ++s) {
    auto& st = status[static_cast<std::size_t>(s)];
    if (!st.active) continue;
    // This launch's sweeps: the step's so far, less those of earlier launches.
    int& earlier = sweeps_before[static_cast<std::size_t>(s)];
    const int step_sweeps = whole(s, kSweeps);
    balance.add(whole(s, kCount), step_sweeps - (st.mid_step ? earlier : 0));
    st.mid_step = whole(s, kMidStep) != 0;
    if (st.mid_step) {  // nothing else of the step is done yet
      earlier = step_sweeps;
      continue;
    }
    ++balance.finished;
    st.steps += 1;
    st.last_sweeps = step_sweeps;
    st.newton_steps = newton_steps[static_cast<std::size_t>(s)];
    st.sweeps += step_sweeps;
    st.converged = whole(s, kUnconverged) == 0;
    st.tolerance = field(s, kStepTolerance);
    st.max_speed = field(s, kMaxSpeed);
    st.max_centre_speed = field(s, kMaxCentreSpeed);
    st.count = whole(s, kCount);
    st.failure = static_cast<Failure>(whole(s, kFailure));
    if (st.failure != Failure::None) {
      st.active = false;
      continue;
    }
    const bool quiet = (st.converged || !rest.converged) && st.rest_speed(rest.spin) < rest.speed;
    st.rest_steps = quiet ? st.rest_steps + 1 : 0;
    st.mean_speed = field(s, kMeanSpeed);
    const bool still_on_average = st.mean_speed >= 0.0 && st.mean_speed < rest.speed;
    st.at_rest = st.rest_steps >= rest.steps || still_on_average;
  }
  if (timing) {
    auto& cost = solver.fused_step ? fused_cost : timer(StepStage::Solve);
    cost.system_steps += balance.systems;
    cost.disk_steps += balance.disks;
    cost.finished_steps += balance.finished;
    cost.sweeps += balance.sweeps;
    cost.slowest_sweeps += balance.systems * balance.slowest;
    cost.launch_sweeps += balance.slowest;
  }
}

Batch::Batch(const std::vector<SystemSetup>& systems, const SolverSettings& solver,
             const RestSettings& rest)
    : impl_(std::make_unique<Impl>()) {
  if (solver.fused_step && !fused_step_solver(solver.kind))
    throw std::invalid_argument(
        "Batch: solver.fused_step needs a solver that sweeps each system in its own team: "
        "accelerated_gauss_seidel, coloured_accelerated_gauss_seidel or sequential_gauss_seidel");
  impl_->solver = solver;
  impl_->rest = rest;
  impl_->allocate(systems);
}

Batch::~Batch() = default;

int Batch::size() const { return impl_->n_systems; }
const SystemParams& Batch::params(int s) const {
  return impl_->params.at(static_cast<std::size_t>(s));
}
int Batch::max_sweeps(int s) const { return impl_->sweep_cap.at(static_cast<std::size_t>(s)); }
int Batch::newton_every(int s) const { return impl_->newton_every.at(static_cast<std::size_t>(s)); }
const SolverSettings& Batch::solver() const { return impl_->solver; }

void Batch::step() { impl_->step(); }

void Batch::set_timing(bool on) {
  if (on) count_launches();
  impl_->timing = on;
}
Batch::KernelEffects Batch::kernel_effects() const { return impl_->needed_effects(); }
const std::vector<StageCost>& Batch::stage_costs() const {
  auto& I = *impl_;
  I.stage_costs.clear();
  const auto named = [&](const char* name, StageCost cost) {
    cost.name = name;
    cost.steps = I.timed_steps;
    I.stage_costs.push_back(std::move(cost));
  };
  if (I.solver.fused_step) {  // one launch, and the status read on the host
    named("system_step", I.fused_cost);
    I.stage_costs.back().team_size = I.team_threads;
    named(stage_name(StepStage::Status), I.timer(StepStage::Status));
    if (I.newton_cost.seconds > 0.0) named("newton", I.newton_cost);  // between the launches
    return I.stage_costs;
  }
  for (int k = 0; k < kStepStages; ++k) {
    const auto stage = static_cast<StepStage>(k);
    named(stage_name(stage), I.timer(stage));
    if (stage == StepStage::Solve) {
      I.stage_costs.back().team_size = I.team_threads;
      if (I.newton_cost.seconds > 0.0) named("newton", I.newton_cost);
    }
  }
  return I.stage_costs;
}

long Batch::run_to_rest(long max_steps) {
  long n = 0;
  for (; n < max_steps; ++n) {
    bool any = false;
    for (int s = 0; s < size(); ++s) {
      const auto& st = impl_->status[static_cast<std::size_t>(s)];
      if (st.active && st.at_rest && !st.mid_step) set_active(s, false);
      any = any || impl_->status[static_cast<std::size_t>(s)].active;
    }
    if (!any) break;
    step();
  }
  return n;
}

void Batch::set_active(int s, bool active) {
  auto& st = impl_->status.at(static_cast<std::size_t>(s));
  if (active && st.failure != Failure::None) return;
  if (st.active == active) return;
  if (st.mid_step)
    throw std::logic_error("Batch::set_active: system " + std::to_string(s) +
                           " is inside a step (its solve goes on); step until it ends");
  st.active = active;  // the device learns it before the next step
}

void Batch::set_gravity(int s, bool on) {
  auto& pr = impl_->params.at(static_cast<std::size_t>(s));
  pr.gravity_on = on;
  Kokkos::deep_copy(Kokkos::subview(impl_->sys.gravity_x, s), pr.gravity_x());
  Kokkos::deep_copy(Kokkos::subview(impl_->sys.gravity_y, s), pr.gravity_y());
  reset_rest(s);
}

Batch::SolverPace Batch::solver_pace(int s) const {
  const NewtonPace& p = impl_->newton_pace.at(static_cast<std::size_t>(s));
  return {p.wait, p.credit};
}

void Batch::set_solver_pace(int s, const SolverPace& pace) {
  NewtonPace& p = impl_->newton_pace.at(static_cast<std::size_t>(s));
  p.wait = std::clamp(pace.wait, impl_->shortest_newton_wait(s), impl_->longest_newton_wait(s));
  p.credit = pace.credit;
  p.charged = 0.0;
}

const SystemStatus& Batch::status(int s) const {
  return impl_->status.at(static_cast<std::size_t>(s));
}

void Batch::reset_rest(int s) {
  auto& st = impl_->status.at(static_cast<std::size_t>(s));
  st.rest_steps = 0;
  st.at_rest = false;
}

void Batch::set_average_span(int s, int steps) {
  auto& I = *impl_;
  const auto k = static_cast<std::size_t>(s);
  if (steps < 0) throw std::invalid_argument("Batch::set_average_span: negative span");
  if (I.status.at(k).mid_step)
    throw std::logic_error("Batch::set_average_span: system " + std::to_string(s) +
                           " is inside a step");
  Kokkos::parallel_for("start_span", Kokkos::RangePolicy<ExecSpace>(0, I.slot_capacity[k]),
                       StartSpan{I.sys, I.part, s, I.offsets[k], steps});
  I.status[k].mean_speed = -1.0;
  reset_rest(s);
}

std::vector<Deposit> Batch::deposit(const std::vector<char>& mask, DropRule rule) {
  return deposit_at(mask, {}, rule);
}

std::vector<Deposit> Batch::deposit_at(const std::vector<char>& mask, const std::vector<double>& x,
                                       DropRule rule) {
  auto& I = *impl_;
  const auto S = static_cast<std::size_t>(I.n_systems);
  if (mask.size() != S) throw std::invalid_argument("Batch::deposit: mask size");
  if (!x.empty() && x.size() != S) throw std::invalid_argument("Batch::deposit_at: x size");
  // Persistent buffers: no allocation per deposition.
  auto& host = I.scheduler_host;
  const DView<double> given = x.empty() ? DView<double>() : I.request_x;
  if (!x.empty()) fill_from(given, host.request_x, S, [&](std::size_t s) { return x[s]; });
  fill_from(I.request, host.request, S, [&](std::size_t s) {
    return (mask[s] && I.status[s].failure == Failure::None) ? 1 : 0;
  });
  Kokkos::parallel_for(
      "deposit", Kokkos::TeamPolicy<ExecSpace>(I.n_systems, Kokkos::AUTO),
      DepositKernel{I.sys, I.part, I.request, I.reply, given, rule == DropRule::Capture});
  const auto hr = host.reply;
  Kokkos::deep_copy(hr, I.reply);  // the only failure a deposit sets comes in the reply
  std::vector<Deposit> out(S);
  for (std::size_t s = 0; s < S; ++s) {
    auto& st = I.status[s];
    if (!mask[s] || st.failure != Failure::None) continue;  // (not deposited)
    if (hr(4 * s) < -0.5) {
      st.failure = static_cast<Failure>(kParticleOverflow);
      st.active = false;
      continue;
    }
    out[s].placed = hr(4 * s) > 0.5;
    out[s].x = hr(4 * s + 1);
    out[s].y = hr(4 * s + 2);
    out[s].radius = hr(4 * s + 3);
    if (out[s].placed) {
      st.count += 1;
      st.rest_steps = 0;
      st.at_rest = false;
    }
  }
  return out;
}

std::vector<Batch::Avalanche> Batch::close_events(const std::vector<char>& mask, double threshold) {
  auto& I = *impl_;
  const auto S = static_cast<std::size_t>(I.n_systems);
  if (mask.size() != S) throw std::invalid_argument("Batch::close_events: mask size");
  fill_from(I.request, I.scheduler_host.request, S, [&](std::size_t s) { return mask[s] ? 1 : 0; });
  Kokkos::parallel_for("event_measure", Kokkos::TeamPolicy<ExecSpace>(I.n_systems, Kokkos::AUTO),
                       EventMeasure{I.sys, I.part, I.request, I.reply, threshold});
  const auto hr = I.scheduler_host.reply;
  Kokkos::deep_copy(hr, I.reply);
  std::vector<Avalanche> out(S);
  for (std::size_t s = 0; s < S; ++s) {
    out[s].moved = static_cast<int>(hr(2 * s));
    out[s].downward = hr(2 * s + 1);
  }
  return out;
}

}  // namespace loosepack
