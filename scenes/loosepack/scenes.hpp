// The scenes the tests and the benches share (the loosepack_scenes library): small scene
// builders (a column, a pyramid, a hexagonal packing, a random drop) and the standard scenes S1
// and S2 (docs/SCENES.md).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
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

// The box of a column of n disks (20 R wide, room above it), with friction and rolling
// friction (mu = 0.3, mu_r = 0.1), no cohesion.
inline SystemParams column_params(int n) {
  SystemParams p = bare_params(20.0, 2.0 * n + 10.0);
  p.friction = 0.3;
  p.rolling_friction = 0.1;
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

// Three-disk pyramid on the floor around x = 10: two base disks, one on top. The base disks
// stand a hair apart: touching, their contact could take any compression the friction leaves
// free (a statically indeterminate family); apart, the forces are unique.
inline std::vector<Disk> pyramid() {
  constexpr double kBaseGap = 1e-9;
  std::vector<Disk> d(3);
  const double half = 1.0 + 0.5 * kBaseGap;
  d[0].x = 10.0 - half;
  d[0].y = 1.0;
  d[1].x = 10.0 + half;
  d[1].y = 1.0;
  d[2].x = 10.0;
  d[2].y = 1.0 + std::sqrt(4.0 - half * half);
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

namespace loosepack::scenes {

// n disks on a jittered square lattice (spacing 2.4 R) above the floor, at rest: a random drop.
inline std::vector<Disk> random_drop(int n, double width, unsigned seed, double radius = 1.0) {
  std::vector<Disk> d(static_cast<std::size_t>(n));
  const int per_row = static_cast<int>(width / (2.4 * radius));
  std::uint64_t state = seed;
  auto uniform = [&state]() {  // SplitMix64, enough for a test scene
    state += 0x9E3779B97F4A7C15ULL;
    std::uint64_t z = state;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return static_cast<double>((z ^ (z >> 31)) >> 11) * 0x1.0p-53;
  };
  for (int k = 0; k < n; ++k) {
    auto& a = d[static_cast<std::size_t>(k)];
    a.radius = radius;
    a.x = (k % per_row + 0.5) * 2.4 * radius + 0.15 * radius * (2.0 * uniform() - 1.0);
    a.y = (k / per_row) * 2.4 * radius + 2.0 * radius + 0.15 * radius * (2.0 * uniform() - 1.0);
  }
  return d;
}

// Rows of touching disks in a hexagonal packing on the floor, n_rows x per_row, periodic width.
inline std::vector<Disk> hexagonal(int per_row, int n_rows, double radius = 1.0) {
  std::vector<Disk> d;
  for (int r = 0; r < n_rows; ++r)
    for (int k = 0; k < per_row; ++k) {
      Disk a;
      a.radius = radius;
      a.x = radius * (1.0 + 2.0 * k + (r % 2));
      a.y = radius * (1.0 + std::sqrt(3.0) * r);
      d.push_back(a);
    }
  return d;
}

// Gaps of all disk pairs and disk-floor pairs below `range` (host, O(N^2): small scenes only).
template <class F>
void for_each_close_pair(const std::vector<Disk>& d, double width, double range, F f) {
  for (std::size_t i = 0; i < d.size(); ++i) {
    const double gf = d[i].y - d[i].radius;
    if (gf < range) f(gf, true);
    for (std::size_t j = i + 1; j < d.size(); ++j) {
      double dx = d[j].x - d[i].x;
      dx -= width * std::round(dx / width);
      const double dy = d[j].y - d[i].y;
      const double gap = std::sqrt(dx * dx + dy * dy) - d[i].radius - d[j].radius;
      if (gap < range) f(gap, false);
    }
  }
}

}  // namespace loosepack::scenes

namespace loosepack::scenes {

// The standard scenes S1 (slow deposition, relaxed to rest after every disk) and S2
// (ballistic deposit, then collapse under gravity): docs/SCENES.md.
constexpr double kSceneWidth = 100.0;
constexpr std::uint64_t kS1Seed = 1001, kS2Seed = 2002;

// SplitMix64 exactly as the scenes define it: the drop abscissae are width x next().
struct SplitMix64 {
  std::uint64_t s;
  double next() {
    s += 0x9E3779B97F4A7C15ULL;
    std::uint64_t z = s;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    z ^= z >> 31;
    return static_cast<double>(z >> 11) * 0x1.0p-53;
  }
};

// The box of a scene of at most n_max disks: room for the deposit above the floor, S1's dense
// pile (phi ~ 0.9, ~0.035 R per disk on this width: height_per_disk 0.04) or S2's ballistic
// one (phi ~ 0.26, ~0.12 R per disk, whose top varies more: 0.2). Frictional (mu = 0.3), no
// cohesion, no rolling friction.
inline SystemParams scene_params(int n_max, double dt, double height_per_disk) {
  SystemParams p;
  p.width = kSceneWidth;
  p.height = height_per_disk * n_max + 20.0;
  p.bond_number = 0.0;
  p.friction = 0.3;
  p.rolling_friction = 0.0;
  p.time_step = dt;
  return p;
}
inline SystemParams s1_params(int n_max, double dt) { return scene_params(n_max, dt, 0.04); }
inline SystemParams s2_params(int n, double dt) {
  SystemParams p = scene_params(n, dt, 0.2);
  p.gravity_on = false;  // deposited ballistically, then collapsing
  return p;
}

// The scenes' rest test: speeds below 1e-3 for 1/6 of a time unit (at least 10 steps), on top
// of `base` (the program's test with a converged solve, or speeds alone).
inline RestSettings scene_rest(RestSettings base, double dt) {
  base.speed = 1e-3;
  base.steps = std::max(10, static_cast<int>(std::ceil((1.0 / 6.0) / dt)));
  return base;
}

}  // namespace loosepack::scenes
