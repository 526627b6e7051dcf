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
    // One thread, in index order: the downward sum is the same on every backend and team size
    // (a team reduction's order follows them), and it runs once an event, not once a step.
    Kokkos::single(Kokkos::PerTeam(team), [&]() {
      double moved = 0.0, down = 0.0;
      for (int q = first; q < first + n; ++q) {
        const double d = part.y(q) - part.y_mark(q);
        if (kmath::fabs(d) > threshold) moved += 1.0;
        if (d < -threshold) down -= d;  // a disk that moved beyond the threshold, downwards
        part.y_mark(q) = part.y(q);
      }
      result(2 * s) = moved;
      result(2 * s + 1) = down;
    });
  }
};

}  // namespace loosepack
