// Loading one system into its batch slot: what the host gathered (its parameters and disks)
// reaches the device in two copies, and one kernel puts it in place, so that refilling a slot
// on a device costs two copies and a launch instead of one copy per value. Reading one back
// (Batch::disks, contacts, state) is the reverse: one kernel gathers it, and it reaches the host
// in one copy.
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

// The particle view that holds disk field `field` (SlotDiskField): the one mapping of the fields
// to the views, for LoadSlot and ReadSlot.
KOKKOS_INLINE_FUNCTION const KView<double>& disk_field(const ParticleViews& part, int field) {
  switch (field) {
    case kLoadY: return part.y;
    case kLoadTheta: return part.theta;
    case kLoadVx: return part.vx;
    case kLoadVy: return part.vy;
    case kLoadW: return part.w;
    case kLoadRadius: return part.radius;
    case kLoadInvMass: return part.inv_mass;
    case kLoadInvInertia: return part.inv_inertia;
    case kLoadYDeposit: return part.y_deposit;
    case kLoadYMark: return part.y_mark;
    default: return part.x;  // kLoadX
  }
}

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
      for (int field = 0; field < kSlotDiskFields; ++field)
        disk_field(part, field)(p) = disks(field * capacity + i);
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

// What a read of one system gathers (Batch::disks, contacts, state).
enum class SlotRead { Disks, Contacts, State };

// The per-contact-slot values of a slot read back, field after field, after its disks'.
enum SlotContactField {
  kReadPartner,  // kNoContact, kFloor, or the partner's particle index (exact in a double)
  kReadNx,
  kReadNy,
  kReadGap,
  kReadPn,
  kReadPt,
  kReadPm,
  kSlotContactFields
};

// What a read of the whole state gathers after the contact slots: the speeds the next step's
// margin comes from and the random draws taken, as two 32-bit halves (each exact in a double).
enum SlotReadValue {
  kReadMaxSpeed,
  kReadCentreSpeed,
  kReadDrawsHigh,
  kReadDrawsLow,
  kSlotReadValues
};

// Where ReadSlot puts field `field` of contact slot c of a system of `count` disks, and value
// `value` (SlotReadValue): its disks come first (field * count + a for a disk a), then its
// contact slots, then the values. A read fills, and copies, only its own part of that layout.
KOKKOS_INLINE_FUNCTION int read_contact_at(int count, int field, int c) {
  return kSlotDiskFields * count + field * count * kSlots + c;
}
KOKKOS_INLINE_FUNCTION int read_value_at(int count, int value) {
  return (kSlotDiskFields + kSlotContactFields * kSlots) * count + value;
}

// Over i in [0, count) for the disks, [0, count * kSlots) for the contacts, [0, max(1, count *
// kSlots)) for the state: gathers system s's disks (SlotDiskField, kLoadYMark included), its
// contact slots (SlotContactField) or both with the values (SlotReadValue) into out, where
// read_contact_at and read_value_at say.
// Reads: what it gathers of part.*, con.{partner, nx, ny, gap, pn, pt, pm} of the slot and
// sys.{max_speed, max_centre_speed, draws} of s. Writes: out.
struct ReadSlot {
  SystemViews sys;
  ParticleViews part;
  ContactViews con;
  DView<double> out;
  int s, first, count;
  SlotRead what;

  KOKKOS_INLINE_FUNCTION void operator()(int i) const {
    if (what != SlotRead::Contacts && i < count)
      for (int field = 0; field < kSlotDiskFields; ++field)
        out(field * count + i) = disk_field(part, field)(first + i);
    if (what == SlotRead::Disks) return;
    if (what == SlotRead::State && i == 0) {
      const std::uint64_t draws = sys.draws(s);
      out(read_value_at(count, kReadMaxSpeed)) = sys.max_speed(s);
      out(read_value_at(count, kReadCentreSpeed)) = sys.max_centre_speed(s);
      out(read_value_at(count, kReadDrawsHigh)) = static_cast<double>(draws >> 32);
      out(read_value_at(count, kReadDrawsLow)) = static_cast<double>(draws & 0xffffffffu);
    }
    if (i >= count * kSlots) return;
    const int c = first * kSlots + i;
    auto put = [&](int field, double v) { out(read_contact_at(count, field, i)) = v; };
    put(kReadPartner, con.partner(c));
    put(kReadNx, con.nx(c));
    put(kReadNy, con.ny(c));
    put(kReadGap, con.gap(c));
    put(kReadPn, con.pn(c));
    put(kReadPt, con.pt(c));
    put(kReadPm, con.pm(c));
  }
};

}  // namespace loosepack
