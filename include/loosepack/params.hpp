// Plain parameter structs: the one home of every model parameter and its default.
// Units: disk radius R = 1, disk mass m = 1 (at R = 1), gravity g = 1, time sqrt(R/g).
#pragma once
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <tuple>

namespace loosepack {

// The physical parameters of one system (one ensemble member).
struct SystemParams {
  double width = 200.0;              // L_x, periodic width [R]
  double height = 150.0;             // H, target height: no disk is placed with its top above H [R]
  double radius = 1.0;               // mean disk radius R
  double polydispersity = 0.0;       // sigma_R / R; radii uniform with this relative std. deviation
  double disk_density = 1.0 / M_PI;  // areal density: m = density * pi r^2 (m = 1 at r = 1)
  double gravity = 1.0;              // g, sets the weight m g and the cohesive force Bo m g
  double gravity_dir_x = 0.0;        // unit vector of gravity
  double gravity_dir_y = -1.0;
  bool gravity_on = true;    // false: no gravitational acceleration (Bo = inf, or before collapse)
  double bond_number = 1e3;  // Bo = F_c / (m g), m the mass of a disk of the mean radius
  double cohesion_range = 0.01;   // d_c [R]: cohesion acts while the gap is below d_c
  bool floor_cohesion = true;     // the floor attracts disks like a disk does
  double friction = 0.3;          // mu (disk-disk and disk-floor)
  double rolling_friction = 0.1;  // mu_r: rolling lever arm mu_r * R_c
  // h [sqrt(R/g)]: the rule a scan applies at each point (default_time_step below), here at the
  // defaults above (0.00285 at Bo = 1e3). Fields set after construction leave it as it is: a
  // system built with another Bo or d_c sets time_step = default_time_step() again.
  double time_step = default_time_step();
  double capture_radius = 1.0;  // r_capt >= 1 (protocol B)

  double reference_mass() const { return disk_density * M_PI * radius * radius; }
  // The gravitational acceleration the disks feel (x, y): zero while gravity is off.
  double gravity_x() const { return gravity_on ? gravity * gravity_dir_x : 0.0; }
  double gravity_y() const { return gravity_on ? gravity * gravity_dir_y : 0.0; }
  // Every field, in order (a new field belongs here: the size check below fails without it).
  auto fields() const {
    return std::tie(width, height, radius, polydispersity, disk_density, gravity, gravity_dir_x,
                    gravity_dir_y, gravity_on, bond_number, cohesion_range, floor_cohesion,
                    friction, rolling_friction, time_step, capture_radius);
  }
  // Every field equal (two scan points of the same system).
  bool operator==(const SystemParams& o) const { return fields() == o.fields(); }
  // F_c; zero for Bo = 0; infinite Bond numbers never reach the dynamics (protocol B path).
  double cohesive_force() const {
    return std::isfinite(bond_number) ? bond_number * reference_mass() * gravity : 0.0;
  }
  // The time over which the pull-off barrier F_c d_c is crossed: the discrete barrier matches
  // F_c d_c only for h well below sqrt(2 m_n d_c / F_c), m_n = m/2 of two reference disks
  // (docs/MODEL.md, the parameter table); infinite without cohesion.
  double cohesive_barrier_time() const {
    const double fc = cohesive_force();
    if (!(fc > 0.0)) return INFINITY;
    return std::sqrt(2.0 * 0.5 * reference_mass() * cohesion_range / fc);
  }
  // The default time step: 0.9 of the barrier time where cohesion needs it, at most 0.01 (the
  // paper files' choice at every Bond number: 0.01 up to Bo = 10, 0.009 at 1e2, 0.0028 at 1e3,
  // 0.0009 at 1e4).
  static constexpr double kDefaultTimeStep = 0.01;
  static constexpr double kBarrierTimeFraction = 0.9;
  double default_time_step() const {
    return std::min(kDefaultTimeStep, kBarrierTimeFraction * cohesive_barrier_time());
  }
};
static_assert(sizeof(SystemParams) == 14 * sizeof(double) + 2 * alignof(double),
              "a field added to SystemParams belongs in SystemParams::fields()");

enum class SolverKind {
  Jacobi,                 // all contacts at once from the previous iterate (parallel over contacts)
  GaussSeidel,            // graph-coloured Gauss-Seidel (parallel over the contacts of one colour)
  SequentialGaussSeidel,  // symmetric Gauss-Seidel in contact order, one thread per system
  // SequentialGaussSeidel accelerated by the nonsmooth nonlinear conjugate gradient step (NNCG,
  // Silcowitz, Niebe & Erleben 2010): force crosses n layers in about n sweeps, not n^2.
  AcceleratedGaussSeidel,
  // NNCG over graph-coloured Gauss-Seidel, one team of threads per system: the solver for wide
  // devices (a GPU), where one thread per system leaves the device idle.
  ColouredAcceleratedGaussSeidel,
};

// The scan-file spelling of a solver kind.
inline const char* solver_kind_name(SolverKind k) {
  switch (k) {
    case SolverKind::Jacobi:
      return "jacobi";
    case SolverKind::GaussSeidel:
      return "gauss_seidel";
    case SolverKind::SequentialGaussSeidel:
      return "sequential_gauss_seidel";
    case SolverKind::AcceleratedGaussSeidel:
      return "accelerated_gauss_seidel";
    case SolverKind::ColouredAcceleratedGaussSeidel:
      return "coloured_accelerated_gauss_seidel";
  }
  return "unknown";
}

// Every solver kind, in the order the scan file's error message lists them.
constexpr SolverKind kSolverKinds[] = {
    SolverKind::Jacobi, SolverKind::GaussSeidel, SolverKind::SequentialGaussSeidel,
    SolverKind::AcceleratedGaussSeidel, SolverKind::ColouredAcceleratedGaussSeidel};

// The solver kind of a scan-file spelling; false if there is none.
inline bool solver_kind_from_name(const std::string& name, SolverKind& kind) {
  for (SolverKind k : kSolverKinds)
    if (name == solver_kind_name(k)) {
      kind = k;
      return true;
    }
  return false;
}

// h_kappa [sqrt(R/g)] of SolverSettings::relative_tolerance: below this step the relative term
// stops growing like 1/h. The term lets a step's impulses err by kappa m v_max, an error per unit
// of time of kappa m v_max / h; held at its value at 0.0028, the step of Bo = 1e3 where kappa was
// measured against the tight solve (docs/PERFORMANCE.md, "The tolerance follows the motion"),
// for the smaller steps of Bo > 1e3. With 1/h's growth, at h = 2.8e-4 (Bo = 1e5) the solve's
// error kept half of a deposit swinging at 0.75 sqrt(gR) without loss, where nothing can move.
constexpr double kRelativeToleranceStep = 0.0028;

// How the contact problem is solved; shared by all systems of a batch except the tolerance,
// which a system's SystemSetup may set.
struct SolverSettings {
  SolverKind kind = SolverKind::AcceleratedGaussSeidel;
  // Max impulse change per sweep [h m g], per system: this is the batch's value for systems
  // whose SystemSetup sets none; a scan gives each member its protocol's default_tolerance
  // (scan.hpp) unless the file sets [solver] tolerance.
  double tolerance = 1e-3;
  int max_sweeps = 2000;  // iteration cap per step
  // kappa: while a system moves, a step's solve ends once no impulse changes in a sweep by more
  // than kappa times the momentum of its fastest disk (m v_max, v_max the largest |v| or R|w|
  // after the last step), or by the tolerance above if that is larger: the step's tolerance is
  // max(tolerance, kappa v_max / (g max(h, h_kappa))) [h m g] (h_kappa: kRelativeToleranceStep
  // above). Near rest the absolute tolerance decides, so rest detection and the forces of a
  // structure at rest are as before; during an avalanche the impulses converge relative to the
  // motion. 0: the absolute tolerance alone.
  double relative_tolerance = 1e-3;
  // omega: P <- P + omega (P_local - P). 0.8 since the accuracy/time study (docs/PERFORMANCE.md):
  // fewer sweeps than 1.0 at the same accuracy for protocols A and C.
  double relaxation = 0.8;
  bool mass_splitting = true;  // Jacobi: each body's mass divided by its contact count
  // accelerated_gauss_seidel: a nonsmooth Newton step (src/newton.hpp) after every this many
  // unconverged iterations (pairs of sweeps) of a step, on the host; 0: none.
  int newton_every = 5;
  // Fraction beta of an overlap removed per step by moving positions apart, velocities untouched
  // (kernels/integrate.hpp, OverlapCorrection); 0: none, an overlap is held as it is.
  double overlap_correction = 0.0;
  // coloured_accelerated_gauss_seidel and fused_step: threads in each system's team, at most the
  // backend's largest team (1 on Serial, the threads on OpenMP); 0: the backend's recommended size
  // (Kokkos::AUTO).
  int team_size = 0;
  // coloured_accelerated_gauss_seidel: at most this many sweeps of a system per launch of the
  // solve; a system still iterating goes on in the next launch while the others take their next
  // steps, so a launch does not last as long as the batch's slowest solve (docs/PERFORMANCE.md,
  // "Building for more cores or a GPU"). The results are the same. 0: every system's whole solve
  // in one launch.
  int sweeps_per_launch = 0;
  // Every stage of a system's step in one team, the whole batch's step in one launch
  // (kernels/step.hpp), where the staged step launches each stage over the batch (16 launches).
  // The results are the same bit for bit. For the solvers that sweep a system in one team or
  // thread (fused_step_solver): the team solver, accelerated_gauss_seidel (a system due for a
  // Newton round stays inside its step for it, and goes on in the next launch),
  // sequential_gauss_seidel. A Batch steps staged unless told; a scan that does not say takes
  // the backend's default (default_fused_step: fused on a host backend, staged on a device).
  bool fused_step = false;
};

// Whether a solver sweeps each system within the system's own team, so that the step can run
// in one launch (SolverSettings::fused_step): not Jacobi or the batch-wide colouring.
inline bool fused_step_solver(SolverKind kind) {
  return kind == SolverKind::ColouredAcceleratedGaussSeidel ||
         kind == SolverKind::SequentialGaussSeidel || kind == SolverKind::AcceleratedGaussSeidel;
}

// When a system counts as at rest.
struct RestSettings {
  double speed = 1e-3;  // all |v| and R|w| below this [sqrt(g R)] ...
  int steps = 10;       // ... on this many consecutive steps, with the solver converged
  // false: speeds alone decide, as other engines' rest tests do (bench_scenes --rest speed); a
  // solve stopped by a sweep cap then still lets a system come to rest.
  bool converged = true;
  // false: the centre speeds |v| alone, not R|w| (the standard scenes' rest criterion,
  // docs/SCENES.md; bench_scenes --rest speed).
  bool spin = true;
  // Protocol C's collapse is at rest also when every disk's position averaged over a span of
  // this length moved by less than speed x span from the span before [sqrt(R/g)]; 0: off
  // (Batch::set_average_span; docs/MODEL.md, "Rest").
  double average_span = 5.0;
};

}  // namespace loosepack
