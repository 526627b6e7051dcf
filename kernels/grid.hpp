// Neighbour grid: one uniform cell grid per system, periodic in x, bounded in y (disks above
// the top row or below the floor are binned into the nearest row, which keeps the search exact).
// Cells hold their particles in increasing index order, so every later loop is deterministic.
#pragma once
#include "kernels/state.hpp"

namespace loosepack {

KOKKOS_INLINE_FUNCTION int grid_column(double x, double width, int nx) {
  int cx = static_cast<int>(kmath::floor(x / width * nx));
  return cx < 0 ? 0 : (cx >= nx ? nx - 1 : cx);
}

KOKKOS_INLINE_FUNCTION int grid_row(double y, double cell, int ny) {
  int cy = static_cast<int>(kmath::floor(y / cell));
  return cy < 0 ? 0 : (cy >= ny ? ny - 1 : cy);
}

// Columns to visit around column cx: all of them when nx < 3 (so none is visited twice). The
// k-th wraps around the periodic x by a compare, not a division: first + k lies in [-1, nx].
struct ColumnRange {
  int first, n, nx;
  KOKKOS_INLINE_FUNCTION int operator[](int k) const {
    const int c = first + k;
    return c < 0 ? c + nx : (c >= nx ? c - nx : c);
  }
};
KOKKOS_INLINE_FUNCTION ColumnRange grid_columns(int cx, int nx) {
  return nx < 3 ? ColumnRange{0, nx, nx} : ColumnRange{cx - 1, 3, nx};
}

// The cell of disk p (of system s) for this step, or -1: a system not stepped, one inside a
// step's solve (sys.mid_step) and the empty tail of a slot get no cells.
KOKKOS_INLINE_FUNCTION int step_cell(const SystemViews& sys, const ParticleViews& part, int s,
                                     int p) {
  if (!sys.active(s) || sys.mid_step(s) || p >= sys.offset(s) + sys.count(s)) return -1;
  const int nx = sys.grid_nx(s);
  const int cx = grid_column(part.x(p), sys.width(s), nx);
  const int cy = grid_row(part.y(p), sys.cell_size(s), sys.grid_ny(s));
  return sys.cell_offset(s) + cy * nx + cx;
}

// Reads: sys.{active, mid_step, offset, count, width, cell_size, grid_nx, grid_ny,
// cell_offset}; part.{system, x, y}. Writes: part.cell; grid.{cell_start, cell_fill,
// cell_particles}.
inline void build_grid(const SystemViews& sys, const ParticleViews& part, const GridViews& grid,
                       int n_particles, int n_cells) {
  auto cell = part.cell;
  auto psys = part.system;
  auto start = grid.cell_start, fill = grid.cell_fill, plist = grid.cell_particles;

  // Fills on the execution space run in order with the kernels: the host does not wait for the
  // device (Kokkos 3.4's deep_copy without one fences).
  Kokkos::deep_copy(ExecSpace(), fill, 0);
  Kokkos::parallel_for(
      "grid_bin", Kokkos::RangePolicy<ExecSpace>(0, n_particles), KOKKOS_LAMBDA(int p) {
        const int c = step_cell(sys, part, psys(p), p);
        cell(p) = c;
        if (c >= 0) Kokkos::atomic_increment(&fill(c));
      });
  Kokkos::parallel_scan(
      "grid_scan", Kokkos::RangePolicy<ExecSpace>(0, n_cells + 1),
      KOKKOS_LAMBDA(int c, int& partial, bool final) {
        const int n = c < n_cells ? fill(c) : 0;
        if (final) start(c) = partial;
        partial += n;
      });
  Kokkos::deep_copy(ExecSpace(), fill, 0);
  Kokkos::parallel_for(
      "grid_fill", Kokkos::RangePolicy<ExecSpace>(0, n_particles), KOKKOS_LAMBDA(int p) {
        const int c = cell(p);
        if (c < 0) return;
        plist(start(c) + Kokkos::atomic_fetch_add(&fill(c), 1)) = p;
      });
  Kokkos::parallel_for(
      "grid_sort_cells", Kokkos::RangePolicy<ExecSpace>(0, n_cells),
      KOKKOS_LAMBDA(int c) { sort_range(plist, start(c), start(c + 1)); });
}

// The grid of system s alone, by one team (the fused step, kernels/step.hpp): the same cells,
// each holding the same disks in the same order, as build_grid's. The system's cells list its
// disks from its first disk slot on, and the cell past its last (each system has one to spare,
// Batch::Impl::lay_out) marks where they end. Reads and writes what build_grid does, of system
// s's disks: not the cells of its slot's empty tail, which no stage of a fused step reads (they
// run over the system's disks; a loaded slot's cells start at -1). Ends with a team barrier.
template <class Member>
KOKKOS_INLINE_FUNCTION void build_system_grid(const Member& team, const SystemViews& sys,
                                              const ParticleViews& part, const GridViews& grid,
                                              int s) {
  const int first = sys.offset(s);
  const int c0 = sys.cell_offset(s), c1 = c0 + sys.grid_nx(s) * sys.grid_ny(s);
  auto start = grid.cell_start, fill = grid.cell_fill, plist = grid.cell_particles;
  const auto zero_fill = [&]() {
    Kokkos::parallel_for(Kokkos::TeamThreadRange(team, c0, c1), [&](int c) { fill(c) = 0; });
    team.team_barrier();
  };
  zero_fill();
  Kokkos::parallel_for(Kokkos::TeamThreadRange(team, first, first + sys.count(s)), [&](int p) {
    const int c = step_cell(sys, part, s, p);
    part.cell(p) = c;
    if (c >= 0) Kokkos::atomic_increment(&fill(c));
  });
  team.team_barrier();
  if (!sys.active(s) || sys.mid_step(s)) return;  // no cells
  Kokkos::parallel_scan(Kokkos::TeamThreadRange(team, c0, c1 + 1),
                        [&](int c, int& partial, bool final) {
                          const int n = c < c1 ? fill(c) : 0;
                          if (final) start(c) = first + partial;
                          partial += n;
                        });
  team.team_barrier();
  zero_fill();
  Kokkos::parallel_for(Kokkos::TeamThreadRange(team, first, first + sys.count(s)), [&](int p) {
    const int c = part.cell(p);
    plist(start(c) + Kokkos::atomic_fetch_add(&fill(c), 1)) = p;
  });
  team.team_barrier();
  Kokkos::parallel_for(Kokkos::TeamThreadRange(team, c0, c1),
                       [&](int c) { sort_range(plist, start(c), start(c + 1)); });
  team.team_barrier();
}

}  // namespace loosepack
