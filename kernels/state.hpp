// Device state of a batch of independent systems, structure of arrays.
// Shapes are written beside each field: [S] per system, [P] per particle slot (all systems
// concatenated, system s owns [offset(s), offset(s) + capacity(s))), [P*kSlots] per contact slot
// (particle p owns slots p*kSlots ... p*kSlots + kSlots - 1), [C] per grid cell of all systems.
// The kernels take these bundles whole; each says above it which fields it reads and writes.
// Their views are KViews (kernels/compat.hpp): the Batch that allocates them owns their memory.
#pragma once
#include <cstdint>

#include "kernels/compat.hpp"

namespace loosepack {

// Contacts owned by one particle: its neighbours of higher index and the floor. Six disks at
// most touch an equal disk in 2D; slack for polydispersity and the detection margin.
constexpr int kSlots = 8;
// Contacts incident to one particle (owned and as partner).
constexpr int kIncident = 14;
constexpr int kNoContact = -2;
// The contact detection margin of a system at rest, times its mean radius: the least reach
// beyond the cohesion range at which pairs become contacts (src/batch.cpp, stage 1).
constexpr double kMinMarginFactor = 0.05;
// SystemViews::unconverged while a step's solve runs: 0 once converged (or for a system not
// stepped), kIterating while it iterates, kStoppedAtCap when a host-loop solver (Jacobi,
// coloured Gauss-Seidel) stopped it at its sweep cap without converging.
constexpr int kIterating = 1;
constexpr int kStoppedAtCap = 2;
constexpr int kFloor = -1;

// Why a system stopped being stepped.
enum SystemFailure : int {
  kOk = 0,
  kNonFinite = 1,         // NaN or Inf in positions or velocities
  kContactOverflow = 2,   // a particle had more contacts than the fixed capacity
  kParticleOverflow = 3,  // more disks than the system's capacity
};

// Sorts v[first, end) in increasing order (insertion sort: the ranges are a grid cell's
// particles or a disk's incident contacts, a handful each). After the atomic fills of a
// parallel backend this makes every list, and every loop over it, the same on every backend.
KOKKOS_INLINE_FUNCTION void sort_range(const KView<int>& v, int first, int end) {
  for (int a = first + 1; a < end; ++a) {
    const int x = v(a);
    int b = a - 1;
    while (b >= first && v(b) > x) {
      v(b + 1) = v(b);
      --b;
    }
    v(b + 1) = x;
  }
}

// x wrapped into the periodic box [0, L_x): as it is, to the bit, where it lies within (a wrap by
// fmod(fmod(x, L) + L, L) would round it), else shifted by whole periods.
KOKKOS_INLINE_FUNCTION double wrap_into_box(double x, double width) {
  if (x >= 0.0 && x < width) return x;
  x -= width * kmath::floor(x / width);
  if (x < 0.0) x += width;      // x / width rounded up to the next integer
  return x >= width ? 0.0 : x;  // -tiny + width rounds to width
}

// Minimum-image difference a - b in a periodic interval of length width.
KOKKOS_INLINE_FUNCTION double periodic_delta(double d, double width) {
  if (d > 0.5 * width) return d - width;
  if (d < -0.5 * width) return d + width;
  return d;
}

// What the averaged rest test keeps of a disk (ParticleViews::span, p * kSpanFields + field): x
// moved since the test began (unwrapped), the sums of that x and of y over the current span's
// steps, and the previous span's means.
enum SpanField : int { kSpanShiftX, kSpanSumX, kSpanSumY, kSpanMeanX, kSpanMeanY, kSpanFields };

struct SystemViews {
  // [S] layout
  KView<int> offset, capacity, count;
  // [S] parameters (see SystemParams)
  KView<double> width, height, radius, polydispersity, disk_density, capture_radius, gravity_x,
      gravity_y, cohesive_force, cohesion_range, friction, rolling_friction, time_step,
      weight,     // weight: m g of a mean disk, the force unit of tolerances
      tolerance,  // solver tolerance [h m g]: a sweep whose largest impulse change is below it ends
      step_tolerance;     // this step's: max(tolerance, kappa v_max / (g max(h, h_kappa)))
  KView<int> max_sweeps;  // solver sweep cap per step
  KView<int> floor_cohesion;
  // [S] counter-based random stream: key (seed, member) and the next draw index
  KView<std::uint64_t> seed, member, draws;
  // [S] grid: cell edge, cells in x and y, first cell index
  KView<double> cell_size;
  KView<int> grid_nx, grid_ny, cell_offset;
  // [S] status
  KView<int> active;               // 1: stepped by step()
  KView<int> unconverged;          // kIterating, kStoppedAtCap, or 0: converged (or not stepped)
  KView<int> failure;              // SystemFailure
  KView<double> sweep_change;      // max impulse change of the last sweep (impulse units)
  KView<double> max_speed;         // max(|v|, R|w|) after the last step (or Batch::set_disks)
  KView<double> max_centre_speed;  // max |v| after the last step (RestSettings::spin false)
  KView<double> margin;            // contact detection margin of the current step
  KView<double> max_margin;        // its bound, which the grid cell leaves room for
  KView<double> gradient2;  // accelerated Gauss-Seidel: squared norm of the last iteration's change
  // 1 while the system is inside a step whose solve goes on in the next launch (the team
  // solver's SolverSettings::sweeps_per_launch): every stage but the solve leaves it alone.
  KView<int> mid_step;
  KView<int> colours;  // the team solver: the colour count of the system's current step
  // The team solver: the disk count when the system's colouring was made, plus one (0: none).
  KView<int> coloured_count;
  // The averaged rest test (RestSettings::average_span; add_to_span in kernels/integrate.hpp,
  // end_span in kernels/step.hpp): steps per span (0: off), steps into the current span, spans
  // completed, the largest change of a disk's mean position in the span ending now, and the last
  // completed comparison's mean speed (negative before two spans).
  KView<int> span_steps, span_step, spans;
  KView<double> span_change, mean_speed;
};

// The contact slots of system s: [first, end).
struct SlotRange {
  int first, end;
};
KOKKOS_INLINE_FUNCTION SlotRange system_slots(const SystemViews& sys, int s) {
  return {sys.offset(s) * kSlots, (sys.offset(s) + sys.count(s)) * kSlots};
}

struct ParticleViews {
  // [P]
  KView<int> system;  // owning system
  KView<double> x, y, theta, vx, vy, w;
  KView<double> vfx, vfy, wf;  // free velocities of the current step
  KView<double> radius, inv_mass, inv_inertia;
  KView<double> y_deposit;  // y_i, the height at which the disk was deposited
  KView<double> y_mark;     // height at the start of the current avalanche event
  KView<double> span;       // [P*kSpanFields] the averaged rest test's sums (SpanField)
  KView<int> cell;          // grid cell (global index)
  KView<int> n_incident;    // [P] number of incident contacts
  KView<int> incident;      // [P*kIncident] contact slot ids
};

struct ContactViews {
  // [P*kSlots]
  KView<int> partner;  // kNoContact, kFloor, or the partner's particle index
  KView<double> nx, ny, gap, rc;
  KView<double> wn, wa, wb, wc;  // local Delassus entries (with mass splitting for Jacobi)
  KView<double> lower;           // -h F_c for a cohesive contact, else 0
  KView<double> pn, pt, pm;      // impulses: normal, tangential, rolling moment
  KView<int> colour;             // Gauss-Seidel colour, -1 when uncoloured
  KView<int> coloured_partner;   // the team solver: the partner when the system was coloured
  // [P*kSlots] accelerated Gauss-Seidel (NNCG): the impulses at the start of the iteration and
  // the conjugate direction
  KView<double> start_pn, start_pt, start_pm;
  KView<double> dir_pn, dir_pt, dir_pm;
};

struct GridViews {
  KView<int> cell_start;      // [C+1]
  KView<int> cell_fill;       // [C]
  KView<int> cell_particles;  // [P]
};

}  // namespace loosepack
