// Loading one system into its batch slot: what the host gathered (its parameters and disks)
// reaches the device in two copies, and one kernel puts it in place, so that refilling a slot
// on a device costs two copies and a launch instead of one copy per value.
#pragma once
#include <cstdint>

#include "kernels/state.hpp"

namespace loosepack {

// The per-system values of one slot (SystemViews), as Batch::reset sets them.
struct SlotLoad {
  int count, max_sweeps, floor_cohesion, grid_nx, grid_ny;
  double width, height, radius, polydispersity, disk_density, capture_radius, gravity_x, gravity_y,
      cohesive_force, cohesion_range, friction, rolling_friction, time_step, weight, tolerance,
      cell_size, max_margin, max_speed;
  std::uint64_t seed, member;
};

// The per-disk values of a slot, field after field: disks(field * capacity + a) for a disk a.
enum SlotDiskField {
  kLoadX,
  kLoadY,
  kLoadTheta,
  kLoadVx,
  kLoadVy,
  kLoadW,
  kLoadRadius,
  kLoadInvMass,
  kLoadInvInertia,
  kLoadYDeposit,
  kLoadYMark,
  kSlotDiskFields
};

// Over i in [0, capacity * kSlots): slot s takes `load` and its disks (the slot's `capacity`
// disk slots, zeros past the system's disks), no cell and no contact; its random stream starts
// at draw 0 and it is not inside a step.
// Reads: load, disks. Writes: sys.* of s but offset, capacity, cell_offset and active;
// part.{x, y, theta, vx, vy, w, radius, inv_mass, inv_inertia, y_deposit, y_mark, cell} and
// con.partner of the slot.
struct LoadSlot {
  SystemViews sys;
  ParticleViews part;
  ContactViews con;
  DView<SlotLoad> load;  // [1]
  DView<double> disks;   // [kSlotDiskFields * capacity]
  int s, first, capacity;

  KOKKOS_INLINE_FUNCTION void operator()(int i) const {
    if (i == 0) put_system();
    if (i < capacity) {
      const int p = first + i;
      auto d = [&](int field) { return disks(field * capacity + i); };
      part.x(p) = d(kLoadX);
      part.y(p) = d(kLoadY);
      part.theta(p) = d(kLoadTheta);
      part.vx(p) = d(kLoadVx);
      part.vy(p) = d(kLoadVy);
      part.w(p) = d(kLoadW);
      part.radius(p) = d(kLoadRadius);
      part.inv_mass(p) = d(kLoadInvMass);
      part.inv_inertia(p) = d(kLoadInvInertia);
      part.y_deposit(p) = d(kLoadYDeposit);
      part.y_mark(p) = d(kLoadYMark);
      part.cell(p) = -1;
    }
    con.partner(first * kSlots + i) = kNoContact;
  }

  KOKKOS_INLINE_FUNCTION void put_system() const {
    const SlotLoad& v = load(0);
    sys.count(s) = v.count;
    sys.width(s) = v.width;
    sys.height(s) = v.height;
    sys.radius(s) = v.radius;
    sys.polydispersity(s) = v.polydispersity;
    sys.disk_density(s) = v.disk_density;
    sys.capture_radius(s) = v.capture_radius;
    sys.gravity_x(s) = v.gravity_x;
    sys.gravity_y(s) = v.gravity_y;
    sys.cohesive_force(s) = v.cohesive_force;
    sys.cohesion_range(s) = v.cohesion_range;
    sys.friction(s) = v.friction;
    sys.rolling_friction(s) = v.rolling_friction;
    sys.time_step(s) = v.time_step;
    sys.weight(s) = v.weight;
    sys.tolerance(s) = v.tolerance;
    sys.max_sweeps(s) = v.max_sweeps;
    sys.floor_cohesion(s) = v.floor_cohesion;
    sys.seed(s) = v.seed;
    sys.member(s) = v.member;
    sys.draws(s) = 0;
    sys.cell_size(s) = v.cell_size;
    sys.max_margin(s) = v.max_margin;
    sys.grid_nx(s) = v.grid_nx;
    sys.grid_ny(s) = v.grid_ny;
    sys.unconverged(s) = 0;
    sys.solving(s) = 0;
    sys.failure(s) = kOk;
    sys.max_speed(s) = v.max_speed;
  }
};

}  // namespace loosepack
