// The time step's ends (its start: the margin and tolerance; its end: the status report) and
// the whole step of one system in one team (SystemStep, solver.fused_step): every stage of
// StepStage over the system's own disks, with a team barrier between stages, in one launch
// for the whole batch. The stages are the functors the staged step launches one by one over
// the batch, so a system's step is the same bit for bit either way.
#pragma once
#include "kernels/contacts.hpp"
#include "kernels/grid.hpp"
#include "kernels/integrate.hpp"
#include "kernels/solver.hpp"

namespace loosepack {

// The detection margin and the solver tolerance from the last step's speeds (or those of the
// disks Batch::set_disks wrote since); the step's counters reset. A system inside a step
// (sys.mid_step) keeps its step's.
// Reads: sys.{mid_step, active, time_step, gravity_x, gravity_y, radius, tolerance, max_margin,
// max_speed, max_centre_speed}. Writes: sys.{step_tolerance, margin, unconverged,
// sweep_change, max_speed, max_centre_speed}; sweeps.
struct StepStart {
  SystemViews sys;
  DView<int> sweeps;  // [S] sweeps of this step
  double kappa;       // SolverSettings::relative_tolerance
  double kappa_step;  // kRelativeToleranceStep [sqrt(R/g)] (loosepack/params.hpp)

  KOKKOS_INLINE_FUNCTION void operator()(int s) const {
    if (sys.mid_step(s)) return;
    sweeps(s) = 0;
    const double h = sys.time_step(s);
    const double g =
        kmath::sqrt(sys.gravity_x(s) * sys.gravity_x(s) + sys.gravity_y(s) * sys.gravity_y(s));
    const double r = sys.radius(s);
    double tolerance = sys.tolerance(s);
    if (g > 0.0) {
      const double relative_step = kmath::max(h, kappa_step * kmath::sqrt(r / g));
      tolerance = kmath::max(tolerance, kappa * sys.max_speed(s) / (g * relative_step));
    }
    sys.step_tolerance(s) = tolerance;
    sys.margin(s) =
        kmath::clamp(2.0 * h * (sys.max_speed(s) + h * g), kMinMarginFactor * r, sys.max_margin(s));
    sys.unconverged(s) = sys.active(s) ? kIterating : 0;
    sys.sweep_change(s) = 0.0;
    sys.max_speed(s) = sys.active(s) ? 0.0 : sys.max_speed(s);
    sys.max_centre_speed(s) = sys.active(s) ? 0.0 : sys.max_centre_speed(s);
  }
};

// The per-system status the host reads after every step, packed as [S x kStatusFields] so that
// it comes back in one copy (one wait for the device per step).
enum StatusField : int {
  kFailure,
  kMaxSpeed,
  kMaxCentreSpeed,
  kStepTolerance,
  kUnconverged,
  kSweeps,
  kCount,
  kMidStep,
  kMeanSpeed,
  kStatusFields
};

// The averaged rest test (add_to_span, kernels/integrate.hpp) after a finished step of system s:
// on a span's last step, the largest change of a disk's mean position over the span's time
// becomes the system's mean speed (from the second span on), and the next span begins.
// Reads: sys.{active, mid_step, failure, time_step}. Writes: sys.{span_step, spans, span_change,
// mean_speed}.
KOKKOS_INLINE_FUNCTION void end_span(const SystemViews& sys, int s) {
  const int n = sys.span_steps(s);
  if (n <= 0 || !sys.active(s) || sys.mid_step(s) || sys.failure(s) != kOk) return;
  if (++sys.span_step(s) < n) return;
  if (sys.spans(s) > 0) sys.mean_speed(s) = sys.span_change(s) / (n * sys.time_step(s));
  sys.spans(s) += 1;
  sys.span_step(s) = 0;
  sys.span_change(s) = 0.0;
}

// Ends the step's span (end_span), then packs the report.
// Reads: sys.{failure, max_speed, max_centre_speed, step_tolerance, unconverged, count,
// mid_step, mean_speed}; sweeps. Writes: report (system s's fields); what end_span writes.
struct StatusReport {
  SystemViews sys;
  DView<int> sweeps;
  DView<double> report;

  KOKKOS_INLINE_FUNCTION void operator()(int s) const {
    end_span(sys, s);
    double* r = &report(s * kStatusFields);
    r[kFailure] = sys.failure(s);
    r[kMaxSpeed] = sys.max_speed(s);
    r[kMaxCentreSpeed] = sys.max_centre_speed(s);
    r[kStepTolerance] = sys.step_tolerance(s);
    r[kUnconverged] = sys.unconverged(s);
    r[kSweeps] = sweeps(s);
    r[kCount] = sys.count(s);
    r[kMidStep] = sys.mid_step(s);
    r[kMeanSpeed] = sys.mean_speed(s);
  }
};

using TeamMember = Kokkos::TeamPolicy<ExecSpace>::member_type;

// A solver that sweeps a system with one thread (AcceleratedGaussSeidel without Newton steps,
// SequentialGaussSeidel) as a team's solve: one thread of the team runs it.
template <class PerSystem>
struct OneThreadSolve {
  PerSystem solver;
  KOKKOS_INLINE_FUNCTION void operator()(const TeamMember& team, int s) const {
    Kokkos::single(Kokkos::PerTeam(team), [&]() { solver(s); });
  }
};

// The team solver as a team's solve.
template <class Fx>
struct TeamSolve {
  ColouredAcceleratedGaussSeidel<Fx> solver;
  KOKKOS_INLINE_FUNCTION void operator()(const TeamMember& team, int s) const {
    solver.solve(team, s);
  }
};

// One time step of system s in its team: the stages of the staged step (src/batch.cpp,
// Batch::Impl::step) in their order, each over the system's own disks and cells, a team barrier
// between two. Reads and writes what those stages do, and the status report.
template <class Solve>
struct SystemStep {
  SystemViews sys;
  ParticleViews part;
  ContactViews con;
  GridViews grid;
  StepStart start;
  Solve solve;
  StatusReport status;
  double overlap_correction;  // SolverSettings::overlap_correction

  KOKKOS_INLINE_FUNCTION void operator()(const TeamMember& team) const {
    const int s = team.league_rank();
    Kokkos::single(Kokkos::PerTeam(team), [&]() { start(s); });
    team.team_barrier();
    if (sys.active(s)) {  // (an inactive system's cells are read by no stage of a fused step)
      build_system_grid(team, sys, part, grid, s);  // ends with a barrier
      const int first = sys.offset(s), end = first + sys.count(s);
      over_disks(team, first, end, FreeVelocity{sys, part});
      over_disks(team, first, end, ContactBuild{sys, part, con, grid});
      over_disks(team, first, end, IncidentScatter{sys, part, con});
      over_disks(team, first, end, IncidentSort{part});
      // (mass splitting is Jacobi's, which has no fused step)
      over_disks(team, first, end, ContactMobilityBuild{part, con, false});
      over_disks(team, first, end, BodyVelocity{sys, part, con, false});
      solve(team, s);
      team.team_barrier();
      over_disks(team, first, end, Integrate{sys, part});
      if (overlap_correction > 0.0) {
        Kokkos::single(Kokkos::PerTeam(team), [&]() {
          OverlapCorrection{sys, part, con, overlap_correction}(s);
        });
        team.team_barrier();
      }
    }
    Kokkos::single(Kokkos::PerTeam(team), [&]() { status(s); });
  }

  // A stage's functor over disks [first, end) by the team's threads, then a barrier.
  template <class Stage>
  KOKKOS_INLINE_FUNCTION void over_disks(const TeamMember& team, int first, int end,
                                         const Stage& stage) const {
    Kokkos::parallel_for(Kokkos::TeamThreadRange(team, first, end), [&](int p) { stage(p); });
    team.team_barrier();
  }
};

}  // namespace loosepack
