// Small scene builders shared by the physics tests.
#pragma once
#include <cmath>
#include <vector>

#include "loosepack/batch.hpp"

namespace loosepack::scenes {

// Frictionless, cohesionless defaults with gravity; each test turns on what it checks.
inline SystemParams bare_params(double width = 20.0, double height = 40.0) {
  SystemParams p;
  p.width = width;
  p.height = height;
  p.bond_number = 0.0;
  p.friction = 0.0;
  p.rolling_friction = 0.0;
  p.time_step = 0.01;
  return p;
}

// A vertical column of n touching disks standing on the floor at x.
inline std::vector<Disk> column(int n, double x, double radius = 1.0) {
  std::vector<Disk> d(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    d[static_cast<std::size_t>(k)].x = x;
    d[static_cast<std::size_t>(k)].y = radius * (1.0 + 2.0 * k);
    d[static_cast<std::size_t>(k)].radius = radius;
  }
  return d;
}

inline SystemSetup setup(const SystemParams& p, std::vector<Disk> disks, int capacity = 0) {
  SystemSetup s;
  s.params = p;
  s.disks = std::move(disks);
  s.capacity = capacity;
  return s;
}

// Kinetic plus gravitational energy of a system.
inline double mechanical_energy(const std::vector<Disk>& disks, const SystemParams& p) {
  double e = 0.0;
  const double g = p.gravity_on ? p.gravity : 0.0;
  for (const auto& d : disks) {
    const double m = p.disk_density * M_PI * d.radius * d.radius;
    const double I = 0.5 * m * d.radius * d.radius;
    e += 0.5 * m * (d.vx * d.vx + d.vy * d.vy) + 0.5 * I * d.w * d.w;
    e -= m * g * (p.gravity_dir_x * d.x + p.gravity_dir_y * d.y);
  }
  return e;
}

}  // namespace loosepack::scenes
