// Loading one system into its batch slot: what the host gathered (its parameters and disks)
// reaches the device in two copies, and one kernel puts it in place, so that refilling a slot
// on a device costs two copies and a launch instead of one copy per value. Reading one back
// (Batch::disks, contacts, state) is the reverse: one kernel gathers it, and it reaches the host
// in one copy. Writing part of one back (Batch::set_disks, set_contacts, restore) is one copy
// and one kernel too, in the layout of a read.
#pragma once
#include <cstdint>

#include "kernels/integrate.hpp"
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
    sys.mid_step(s) = 0;
    sys.failure(s) = kOk;
    sys.max_speed(s) = v.max_speed;
    sys.span_steps(s) = 0;  // the averaged rest test off (Batch::set_average_span)
    sys.mean_speed(s) = -1.0;
  }
};

// The part of one system a read (Batch::disks, contacts, state) gathers or a write
// (Batch::set_disks, set_contacts, restore) puts in place: its disks, its contact slots, or its
// whole state.
enum class SlotPart { Disks, Contacts, State };

// The per-contact-slot values of a slot read back, field after field, after its disks'.
enum SlotContactField {
  kSlotPartner,  // kNoContact, kFloor, or the partner's particle index (exact in a double)
  kSlotNx,
  kSlotNy,
  kSlotGap,
  kSlotPn,
  kSlotPt,
  kSlotPm,
  kSlotContactFields
};

// What a read or write of the whole state holds after the contact slots: the speeds the next
// step's margin comes from, the random draws taken, as two 32-bit halves (each exact in a
// double), the gravity the system feels, and the averaged rest test's counters (each exact in a
// double); then each disk's SpanField values.
enum SlotValue {
  kSlotMaxSpeed,
  kSlotCentreSpeed,
  kSlotDrawsHigh,
  kSlotDrawsLow,
  kSlotGravityX,
  kSlotGravityY,
  kSlotSpanSteps,
  kSlotSpanStep,
  kSlotSpans,
  kSlotSpanChange,
  kSlotMeanSpeed,
  kSlotValues
};

// Where ReadSlot puts, and WriteSlot finds, field `field` of disk a and of contact slot c of a
// system of `count` disks, value `value` (SlotValue) and a disk's SpanField: its disks come
// first, then its contact slots, then the values, then the span fields. A read or write fills,
// and copies, only its own part of that layout (a write of disks by index lays out its n disks
// as slot_disk_at(n, field, k)).
KOKKOS_INLINE_FUNCTION int slot_disk_at(int count, int field, int a) { return field * count + a; }
KOKKOS_INLINE_FUNCTION int slot_contact_at(int count, int field, int c) {
  return kSlotDiskFields * count + field * count * kSlots + c;
}
KOKKOS_INLINE_FUNCTION int slot_value_at(int count, int value) {
  return (kSlotDiskFields + kSlotContactFields * kSlots) * count + value;
}
KOKKOS_INLINE_FUNCTION int slot_span_at(int count, int field, int a) {
  return slot_value_at(count, kSlotValues) + field * count + a;
}

// Over i in [0, count) for the disks, [0, count * kSlots) for the contacts, [0, max(1, count *
// kSlots)) for the state: gathers system s's disks (SlotDiskField, kLoadYMark included), its
// contact slots (SlotContactField) or both with the values (SlotValue) and the span fields into
// out, where slot_contact_at, slot_value_at and slot_span_at say.
// Reads: what it gathers of part.*, con.{partner, nx, ny, gap, pn, pt, pm} of the slot and
// sys.{max_speed, max_centre_speed, draws, gravity_x, gravity_y, span_*, mean_speed} of s.
// Writes: out.
struct ReadSlot {
  SystemViews sys;
  ParticleViews part;
  ContactViews con;
  DView<double> out;
  int s, first, count;
  SlotPart what;

  KOKKOS_INLINE_FUNCTION void operator()(int i) const {
    if (what != SlotPart::Contacts && i < count)
      for (int field = 0; field < kSlotDiskFields; ++field)
        out(slot_disk_at(count, field, i)) = disk_field(part, field)(first + i);
    if (what == SlotPart::Disks) return;
    if (what == SlotPart::State && i < count)
      for (int field = 0; field < kSpanFields; ++field)
        out(slot_span_at(count, field, i)) = part.span((first + i) * kSpanFields + field);
    if (what == SlotPart::State && i == 0) {
      const std::uint64_t draws = sys.draws(s);
      out(slot_value_at(count, kSlotMaxSpeed)) = sys.max_speed(s);
      out(slot_value_at(count, kSlotCentreSpeed)) = sys.max_centre_speed(s);
      out(slot_value_at(count, kSlotDrawsHigh)) = static_cast<double>(draws >> 32);
      out(slot_value_at(count, kSlotDrawsLow)) = static_cast<double>(draws & 0xffffffffu);
      out(slot_value_at(count, kSlotGravityX)) = sys.gravity_x(s);
      out(slot_value_at(count, kSlotGravityY)) = sys.gravity_y(s);
      out(slot_value_at(count, kSlotSpanSteps)) = sys.span_steps(s);
      out(slot_value_at(count, kSlotSpanStep)) = sys.span_step(s);
      out(slot_value_at(count, kSlotSpans)) = sys.spans(s);
      out(slot_value_at(count, kSlotSpanChange)) = sys.span_change(s);
      out(slot_value_at(count, kSlotMeanSpeed)) = sys.mean_speed(s);
    }
    if (i >= count * kSlots) return;
    const int c = first * kSlots + i;
    auto put = [&](int field, double v) { out(slot_contact_at(count, field, i)) = v; };
    put(kSlotPartner, con.partner(c));
    put(kSlotNx, con.nx(c));
    put(kSlotNy, con.ny(c));
    put(kSlotGap, con.gap(c));
    put(kSlotPn, con.pn(c));
    put(kSlotPt, con.pt(c));
    put(kSlotPm, con.pm(c));
  }
};

// A write of n disks by index (SlotPart::Disks) holds the k-th disk's x, y, theta, vx, vy and w
// (SlotDiskField) at slot_disk_at(n, field, k) and its index in the row after them.
constexpr int kWrittenIndex = kLoadW + 1;

// One team (a league of one) puts what the host staged in `in` into system s:
// - Disks: n disks by index, then sys.max_speed(s) from the system's disks as written (the next
//   step's margin and relative tolerance follow the fastest disk, as after an integration);
// - Contacts: every contact slot of the system as ReadSlot lays them out (slot_contact_at): its
//   partner, and where it has one, its impulses; the slots from count * kSlots on, up to the
//   slot's capacity, have none;
// - State: the contacts with their normals and gaps too, the disks' x, y_mark, inv_mass,
//   inv_inertia and span fields, and the values (SlotValue).
// A slot without a partner keeps what it held, as the step's contact build expects.
// Reads: in. Writes: what it puts of part.*, con.* of the slot and sys.* of s.
struct WriteSlot {
  using Member = Kokkos::TeamPolicy<ExecSpace>::member_type;
  SystemViews sys;
  ParticleViews part;
  ContactViews con;
  DView<double> in;
  int s, first, count, capacity, n;
  SlotPart what;

  KOKKOS_INLINE_FUNCTION void operator()(const Member& team) const {
    if (what == SlotPart::Disks) return put_disks(team);
    put_contacts(team);
    if (what == SlotPart::Contacts) return;
    Kokkos::parallel_for(Kokkos::TeamThreadRange(team, count), [&](int a) {
      const auto put = [&](int field) {
        disk_field(part, field)(first + a) = in(slot_disk_at(count, field, a));
      };
      put(kLoadX);
      put(kLoadYMark);
      put(kLoadInvMass);
      put(kLoadInvInertia);
      for (int field = 0; field < kSpanFields; ++field)
        part.span((first + a) * kSpanFields + field) = in(slot_span_at(count, field, a));
    });
    Kokkos::single(Kokkos::PerTeam(team), [&]() { put_values(); });
  }

  KOKKOS_INLINE_FUNCTION void put_disks(const Member& team) const {
    Kokkos::parallel_for(Kokkos::TeamThreadRange(team, n), [&](int k) {
      const int p = first + static_cast<int>(in(slot_disk_at(n, kWrittenIndex, k)));
      for (int field = kLoadX; field <= kLoadW; ++field)
        disk_field(part, field)(p) = in(slot_disk_at(n, field, k));
    });
    team.team_barrier();
    double fastest = 0.0;
    Kokkos::parallel_reduce(
        Kokkos::TeamThreadRange(team, count),
        [&](int a, double& m) { m = kmath::max(m, disk_speed(part, first + a)); },
        Kokkos::Max<double>(fastest));
    // (A reduction over no disk gives the lowest double.)
    Kokkos::single(Kokkos::PerTeam(team), [&]() { sys.max_speed(s) = kmath::max(0.0, fastest); });
  }

  KOKKOS_INLINE_FUNCTION void put_contacts(const Member& team) const {
    Kokkos::parallel_for(Kokkos::TeamThreadRange(team, capacity * kSlots), [&](int i) {
      const int c = first * kSlots + i;
      if (i >= count * kSlots) {
        con.partner(c) = kNoContact;
        return;
      }
      const auto v = [&](int field) { return in(slot_contact_at(count, field, i)); };
      con.partner(c) = static_cast<int>(v(kSlotPartner));
      if (con.partner(c) == kNoContact) return;
      con.pn(c) = v(kSlotPn);
      con.pt(c) = v(kSlotPt);
      con.pm(c) = v(kSlotPm);
      if (what != SlotPart::State) return;
      con.nx(c) = v(kSlotNx);
      con.ny(c) = v(kSlotNy);
      con.gap(c) = v(kSlotGap);
    });
  }

  KOKKOS_INLINE_FUNCTION void put_values() const {
    const auto value = [&](int v) { return in(slot_value_at(count, v)); };
    sys.draws(s) = (static_cast<std::uint64_t>(value(kSlotDrawsHigh)) << 32) |
                   static_cast<std::uint64_t>(value(kSlotDrawsLow));
    sys.max_speed(s) = value(kSlotMaxSpeed);
    sys.max_centre_speed(s) = value(kSlotCentreSpeed);
    sys.gravity_x(s) = value(kSlotGravityX);
    sys.gravity_y(s) = value(kSlotGravityY);
    sys.span_steps(s) = static_cast<int>(value(kSlotSpanSteps));
    sys.span_step(s) = static_cast<int>(value(kSlotSpanStep));
    sys.spans(s) = static_cast<int>(value(kSlotSpans));
    sys.span_change(s) = value(kSlotSpanChange);
    sys.mean_speed(s) = value(kSlotMeanSpeed);
  }
};

}  // namespace loosepack
