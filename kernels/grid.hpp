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

// Reads: sys.{active, solving, offset, count, width, cell_size, grid_nx, grid_ny,
// cell_offset}; part.{system, x, y}. A system inside a step's solve (sys.solving) gets no cells,
// as an inactive one. Writes: part.cell; grid.{cell_start, cell_fill, cell_particles}.
inline void build_grid(const SystemViews& sys, const ParticleViews& part, const GridViews& grid,
                       int n_particles, int n_cells) {
  auto cell = part.cell;
  auto psys = part.system;
  auto x = part.x, y = part.y;
  auto offset = sys.offset, count = sys.count, active = sys.active, solving = sys.solving;
  auto width = sys.width, cell_size = sys.cell_size;
  auto nxv = sys.grid_nx, nyv = sys.grid_ny, cell_offset = sys.cell_offset;
  auto start = grid.cell_start, fill = grid.cell_fill, plist = grid.cell_particles;

  // Fills on the execution space run in order with the kernels: the host does not wait for the
  // device (Kokkos 3.4's deep_copy without one fences).
  Kokkos::deep_copy(ExecSpace(), fill, 0);
  Kokkos::parallel_for(
      "grid_bin", Kokkos::RangePolicy<ExecSpace>(0, n_particles), KOKKOS_LAMBDA(int p) {
        const int s = psys(p);
        if (!active(s) || solving(s) || p >= offset(s) + count(s)) {
          cell(p) = -1;
          return;
        }
        const int cx = grid_column(x(p), width(s), nxv(s));
        const int cy = grid_row(y(p), cell_size(s), nyv(s));
        const int c = cell_offset(s) + cy * nxv(s) + cx;
        cell(p) = c;
        Kokkos::atomic_increment(&fill(c));
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

}  // namespace loosepack
