// Formulas of the disks' sizes and of contact detection that the scan's validation
// (src/scan.cpp), the batch's grid (src/batch_state.cpp), the relaxation regions (src/region.cpp)
// and the slots' capacity (src/protocols.cpp) share (docs/MODEL.md, "Time step" and "Supported
// ranges").
#pragma once
#include <algorithm>
#include <cmath>

#include "loosepack/params.hpp"

namespace loosepack {

// Radii are uniform on R (1 +- sqrt(3) sigma) (kernels/deposit.hpp).
inline double largest_radius(const SystemParams& p) {
  return p.radius * (1.0 + std::sqrt(3.0) * p.polydispersity);
}
// How far apart two disks of radius at most rmax can stand and still touch or pull within
// `margin` of motion: their radii, the cohesive range and the margin.
inline double contact_reach(const SystemParams& p, double rmax, double margin = 0.0) {
  return 2.0 * rmax + p.cohesion_range + margin;
}
// The narrowest periodic box: two disks within the cohesive range of each other one way round
// are beyond it the other way.
inline double smallest_width(const SystemParams& p) {
  return 2.0 * contact_reach(p, largest_radius(p));
}
// The top of a box of disks of radius at most rmax: no centre is placed above H, so no disk
// reaches above H + 2 rmax, and none falls further (the grid's height and margin, and the time
// step's bound, are taken from it).
inline double box_top(const SystemParams& p, double rmax) { return p.height + 2.0 * rmax; }
// The smallest, bounded below at 0.2 R for the capacity of a slot.
inline double smallest_radius(const SystemParams& p) {
  return p.radius * std::max(0.2, 1.0 - std::sqrt(3.0) * p.polydispersity);
}

// Contacts are detected up to 2 h (v + h g) ahead: how far a disk at speed v under gravity g
// goes in two steps. The margin stage (src/batch.cpp) computes the same on the device from each
// system's last largest speed, clamped to [kMinMarginFactor R, the grid's margin].
inline double detection_margin(double h, double v, double g) { return 2.0 * h * (v + h * g); }

// The speed of a disk that has fallen `height` under gravity g.
inline double fall_speed(double g, double height) { return std::sqrt(2.0 * g * height); }

// The margin a grid leaves for a system whose disks fall at most `height`: no disk moves faster
// than such a fall (contacts dissipate), and at least kMaxMarginFactor R.
constexpr double kMaxMarginFactor = 0.5;
inline double grid_margin(const SystemParams& p, double height) {
  const double g = std::abs(p.gravity);
  return std::max(kMaxMarginFactor * p.radius,
                  detection_margin(p.time_step, fall_speed(g, height), g));
}

// Above it no disk of a sound solution lies: no disk is placed above H, and none rises under
// gravity and inelastic contacts (a member with a disk beyond fails, Failure::Escaped).
inline double escape_height(const SystemParams& p) { return p.height + 4.0 * largest_radius(p); }

// Faster than any disk of the box can move: twice the speed of a fall from H + 4 R_max plus
// what the cohesive pull-in of six contacts can add, m v^2 / 2 = 6 F_c d_c. A disk beyond it has
// taken energy from no source in the model: the solution blew up (Failure::Runaway). Infinite
// where nothing bounds it (Bo = inf has no gravity and no dynamics).
inline double runaway_speed(const SystemParams& p) {
  const double g = std::abs(p.gravity);
  const double fall = fall_speed(g, escape_height(p));
  const double pull = std::sqrt(2.0 * 6.0 * p.cohesive_force() * p.cohesion_range /
                                p.reference_mass());
  const double v = 2.0 * (fall + pull);
  return std::isfinite(v) && v > 0.0 ? v : INFINITY;
}

// The largest detection margin the contact capacity allows: with 2 R + d_c + margin below the
// second neighbour shell of a hexagonal packing (2 sqrt(3) R), kSlots contact slots per disk
// suffice.
constexpr double kMaxDetectionMargin = 1.4;

}  // namespace loosepack
