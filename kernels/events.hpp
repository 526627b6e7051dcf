// Avalanche events of protocol A: what one deposited disk set in motion, measured against the
// heights marked when the disk was placed.
#pragma once
#include "kernels/state.hpp"

namespace loosepack {

// Reads: request; sys.{offset, count}; part.{y, y_mark}. Writes: result; part.y_mark.
struct EventMeasure {
  using team_member = Kokkos::TeamPolicy<ExecSpace>::member_type;
  SystemViews sys;
  ParticleViews part;
  DView<int> request;    // [S]
  DView<double> result;  // [S*2]: disks moved beyond the threshold, and their summed downward
                         // displacement
  double threshold;

  KOKKOS_INLINE_FUNCTION void operator()(const team_member& team) const {
    const int s = team.league_rank();
    if (!request(s)) return;
    const int first = sys.offset(s), n = sys.count(s);
    double moved = 0.0, down = 0.0;
    Kokkos::parallel_reduce(
        Kokkos::TeamThreadRange(team, n),
        [&](int a, double& m) {
          const double d = part.y(first + a) - part.y_mark(first + a);
          if (kmath::fabs(d) > threshold) m += 1.0;
        },
        moved);
    Kokkos::parallel_reduce(
        Kokkos::TeamThreadRange(team, n),
        [&](int a, double& acc) {
          const double d = part.y(first + a) - part.y_mark(first + a);
          if (d < -threshold) acc -= d;  // a disk that moved beyond the threshold, downwards
        },
        down);
    team.team_barrier();
    Kokkos::parallel_for(Kokkos::TeamThreadRange(team, n),
                         [&](int a) { part.y_mark(first + a) = part.y(first + a); });
    Kokkos::single(Kokkos::PerTeam(team), [&]() {
      result(2 * s) = moved;
      result(2 * s + 1) = down;
    });
  }
};

}  // namespace loosepack
