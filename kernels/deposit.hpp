// Deposition of one disk per requesting system on a vertical drop line at a random x:
// DropRule::Touch puts it at the highest height where it touches a disk or the floor
// (protocol A); DropRule::Capture is Meakin's ballistic deposition with capture radius
// (protocol B): the disk falls until its centre comes within r_capt (r + r_j) of a deposited
// disk's centre (or it touches the floor), then moves along the line of centres to touch it.
#pragma once
#include "kernels/contacts.hpp"
#include "kernels/random.hpp"

namespace loosepack {

// The largest value and, among equal largest values, the lowest index: Kokkos::MaxLoc's join
// keeps whichever of two equal values it meets first, which on a GPU's strided threads need not
// be the lowest index (a drop exactly between two equal disks would be captured by either).
// Written as Kokkos 3.4's MaxLoc is, with that join.
struct MaxLowestLoc {
  using reducer = MaxLowestLoc;
  using value_type = Kokkos::ValLocScalar<double, int>;
  using result_view_type = Kokkos::View<value_type, Kokkos::HostSpace>;

  KOKKOS_INLINE_FUNCTION explicit MaxLowestLoc(value_type& v) : value(&v) {}
  KOKKOS_INLINE_FUNCTION void join(value_type& dest, const value_type& src) const {
    if (src.val > dest.val || (src.val == dest.val && src.loc < dest.loc)) dest = src;
  }
  KOKKOS_INLINE_FUNCTION void join(volatile value_type& dest,
                                   const volatile value_type& src) const {
    if (src.val > dest.val || (src.val == dest.val && src.loc < dest.loc)) {
      dest.val = src.val;
      dest.loc = src.loc;
    }
  }
  KOKKOS_INLINE_FUNCTION void init(value_type& v) const {
    v.val = Kokkos::reduction_identity<double>::max();
    v.loc = -1;  // no disk
  }
  KOKKOS_INLINE_FUNCTION value_type& reference() const { return *value.data(); }
  KOKKOS_INLINE_FUNCTION result_view_type view() const { return value; }
  KOKKOS_INLINE_FUNCTION bool references_scalar() const { return true; }

 private:
  result_view_type value;
};

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
    x = wrap_into_box(x, width);
    double r = sys.radius(s);
    const double sigma = sys.polydispersity(s);
    if (sigma > 0.0 && !given) {
      const double u = uniform01(sys.seed(s), sys.member(s), d0 + 1);
      r *= 1.0 + kmath::sqrt(3.0) * sigma * (2.0 * u - 1.0);
    }
    const double rc = capture ? sys.capture_radius(s) : 1.0;
    const int first = sys.offset(s), n = sys.count(s);
    MaxLowestLoc::value_type best;
    Kokkos::parallel_reduce(
        Kokkos::TeamThreadRange(team, n),
        [&](int a, MaxLowestLoc::value_type& acc) {
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
        MaxLowestLoc(best));
    const int q = best.loc;
    const bool captured = q >= 0 && best.val > r;
    // The capture point less q's centre, and the share of it that leaves the disk touching q.
    const double dx = captured ? periodic_delta(x - part.x(q), width) : 0.0;
    const double dy = captured ? best.val - part.y(q) : 0.0;
    const double pull = captured ? (r + part.radius(q)) / (rc * (r + part.radius(q))) : 1.0;
    // Equal radii meet nothing on the way (first_touch_on_pull): no second pass over the disks.
    const double travel =
        captured && sigma > 0.0
            ? first_touch_on_pull(team, s, q, x, best.val, r, (pull - 1.0) * dx, (pull - 1.0) * dy)
            : 1.0;
    Kokkos::single(Kokkos::PerTeam(team), [&]() {
      double px = x, py = r;  // the floor
      if (captured) {
        if (travel < 1.0) {  // stopped on the way by another disk or the floor
          px = x + travel * (pull - 1.0) * dx;
          py = best.val + travel * (pull - 1.0) * dy;
        } else {
          px = part.x(q) + pull * dx;
          py = part.y(q) + pull * dy;
        }
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

  // The pull (ux, uy) of a disk of radius r captured at (x, y) by disk q, along the line of
  // centres to touch q: the fraction of it travelled before the disk first touches another disk
  // or the floor (1 when nothing is in the way). With equal radii nothing ever is: every disk p is
  // at least r_capt (r + r_p) from the capture point (else the drop line would have met p's capture
  // circle higher), and on the pull |c - p|^2 >= lambda^2 |u|^2 + (1 - lambda) |v|^2 > (2 R)^2 for
  // the point c = q + lambda u (u the capture point less q, v = p - q, lambda >= 1/r_capt). With
  // unequal radii a large disk pulled onto a small one can meet a neighbour or the floor first.
  KOKKOS_INLINE_FUNCTION double first_touch_on_pull(const team_member& team, int s, int q, double x,
                                                    double y, double r, double ux,
                                                    double uy) const {
    const double width = sys.width(s);
    const double uu = ux * ux + uy * uy;
    if (!(uu > 0.0)) return 1.0;
    const int first = sys.offset(s), n = sys.count(s);
    double travel = 1.0;
    Kokkos::parallel_reduce(
        Kokkos::TeamThreadRange(team, n),
        [&](int a, double& t) {
          const int p = first + a;
          if (p == q) return;
          const double touch = r + part.radius(p);
          const double ey = y - part.y(p);
          // Every periodic image of p within reach of the pull's path.
          const double ex0 = periodic_delta(x - part.x(p), width);
          const int images = static_cast<int>(kmath::fabs(ux) / width) + 1;
          for (int k = -images; k <= images; ++k) {
            const double ex = ex0 + k * width;
            const double eu = ex * ux + ey * uy;  // |e + t u|^2 = touch^2 for t in [0, 1)
            if (eu >= 0.0) continue;              // the pull goes away from this image
            const double disc = eu * eu - uu * (ex * ex + ey * ey - touch * touch);
            if (disc <= 0.0) continue;
            const double enter = (-eu - kmath::sqrt(disc)) / uu;
            if (enter < t) t = kmath::max(enter, 0.0);
          }
        },
        Kokkos::Min<double>(travel));
    travel = kmath::min(travel, 1.0);
    if (y + uy < r) travel = kmath::min(travel, (r - y) / uy);  // y > r: the floor on the way
    return travel;
  }
};

}  // namespace loosepack
