// Deposition of one disk per requesting system on a vertical drop line at a random x:
// DropRule::Touch puts it at the highest height where it touches a disk or the floor
// (protocol A); DropRule::Capture is Meakin's ballistic deposition with capture radius
// (protocol B): the disk falls until its centre comes within r_capt (r + r_j) of a deposited
// disk's centre (or it touches the floor), then moves along the line of centres to touch it.
#pragma once
#include "kernels/contacts.hpp"
#include "kernels/random.hpp"

namespace loosepack {

// Reads: request, given_x; sys.{failure, draws, seed, member, width, radius, polydispersity,
// capture_radius, offset, count, height, capacity, disk_density}; part.{x, y, radius}.
// Writes: result; sys.{draws, count, failure (kParticleOverflow)}; the new disk's
// part.{x, y, theta, vx, vy, w, radius, inv_mass, inv_inertia, y_deposit, y_mark}.
struct DepositKernel {
  using team_member = Kokkos::TeamPolicy<ExecSpace>::member_type;
  SystemViews sys;
  ParticleViews part;
  DView<int> request;     // [S] 1: deposit one disk
  DView<double> result;   // [S*4] placed (1; 0: full; -1: kParticleOverflow), x, y, radius
  DView<double> given_x;  // [S] abscissae to use instead of random draws (empty: draw)
  bool capture;           // DropRule::Capture

  KOKKOS_INLINE_FUNCTION void operator()(const team_member& team) const {
    const int s = team.league_rank();
    if (!request(s) || sys.failure(s) != kOk) return;
    const bool given = given_x.extent(0) > 0;
    const std::uint64_t d0 = sys.draws(s);
    const double width = sys.width(s);
    double x = given ? given_x(s) : width * uniform01(sys.seed(s), sys.member(s), d0);
    // A given abscissa may lie anywhere (x = L_x is x = 0): wrap it into [0, L_x), or a disk
    // dropped onto the bare floor keeps it (and the minimum image below needs |dx| < 1.5 L_x).
    x -= width * kmath::floor(x / width);
    if (x >= width) x = 0.0;  // -tiny + width rounds to width
    double r = sys.radius(s);
    const double sigma = sys.polydispersity(s);
    if (sigma > 0.0 && !given) {
      const double u = uniform01(sys.seed(s), sys.member(s), d0 + 1);
      r *= 1.0 + kmath::sqrt(3.0) * sigma * (2.0 * u - 1.0);
    }
    const double rc = capture ? sys.capture_radius(s) : 1.0;
    const int first = sys.offset(s), n = sys.count(s);
    using Reducer = Kokkos::MaxLoc<double, int>;
    typename Reducer::value_type best;
    Kokkos::parallel_reduce(
        Kokkos::TeamThreadRange(team, n),
        [&](int a, typename Reducer::value_type& acc) {
          const int q = first + a;
          const double dx = periodic_delta(part.x(q) - x, width);
          const double reach = rc * (r + part.radius(q));
          if (kmath::fabs(dx) >= reach) return;
          const double cand = part.y(q) + kmath::sqrt(reach * reach - dx * dx);
          if (cand > acc.val || (cand == acc.val && q < acc.loc)) {
            acc.val = cand;
            acc.loc = q;
          }
        },
        Reducer(best));
    Kokkos::single(Kokkos::PerTeam(team), [&]() {
      double px = x, py = r;  // the floor
      if (best.loc >= 0 && best.val > r) {
        const int q = best.loc;
        const double reach = rc * (r + part.radius(q));
        const double dx = periodic_delta(x - part.x(q), width);
        const double dy = best.val - part.y(q);
        const double pull = (r + part.radius(q)) / reach;
        px = part.x(q) + pull * dx;
        py = part.y(q) + pull * dy;
        if (px < 0.0) px += width;
        if (px >= width) px -= width;
        if (px >= width) px = 0.0;
      }
      if (!given) sys.draws(s) = d0 + 2;
      result(4 * s + 0) = 0.0;
      result(4 * s + 1) = px;
      result(4 * s + 2) = py;
      result(4 * s + 3) = r;
      if (py + r > sys.height(s)) return;  // the system is full
      if (n >= sys.capacity(s)) {
        sys.failure(s) = kParticleOverflow;
        result(4 * s + 0) = -1.0;
        return;
      }
      const int p = first + n;
      const double m = sys.disk_density(s) * M_PI * r * r;
      part.x(p) = px;
      part.y(p) = py;
      part.theta(p) = 0.0;
      part.vx(p) = part.vy(p) = part.w(p) = 0.0;
      part.radius(p) = r;
      part.inv_mass(p) = 1.0 / m;
      part.inv_inertia(p) = 2.0 / (m * r * r);
      part.y_deposit(p) = py;
      part.y_mark(p) = py;
      sys.count(s) = n + 1;
      result(4 * s + 0) = 1.0;
    });
  }
};

}  // namespace loosepack
