// Free velocities, the implicit position update, the non-finite guard and the speeds that feed
// rest detection.
#pragma once
#include "kernels/state.hpp"

namespace loosepack {

struct FreeVelocity {
  SystemViews sys;
  ParticleViews part;
  KOKKOS_INLINE_FUNCTION void operator()(int p) const {
    if (part.cell(p) < 0) return;
    const int s = part.system(p);
    const double h = sys.time_step(s);
    const bool mobile = part.inv_mass(p) > 0.0;
    part.vfx(p) = part.vx(p) + (mobile ? h * sys.gravity_x(s) : 0.0);
    part.vfy(p) = part.vy(p) + (mobile ? h * sys.gravity_y(s) : 0.0);
    part.wf(p) = part.w(p);
  }
};

// x += h v (wrapped into [0, L_x)), theta += h w; flags non-finite state; records max speed.
struct Integrate {
  SystemViews sys;
  ParticleViews part;
  KOKKOS_INLINE_FUNCTION void operator()(int p) const {
    if (part.cell(p) < 0) return;
    const int s = part.system(p);
    if (sys.failure(s) == kContactOverflow || sys.failure(s) == kParticleOverflow) return;
    const double h = sys.time_step(s);
    const double width = sys.width(s);
    double x = part.x(p) + h * part.vx(p);
    if (x >= width) x -= width;
    if (x < 0.0) x += width;
    if (x >= width) x = 0.0;  // -tiny + width rounds to width
    const double y = part.y(p) + h * part.vy(p);
    part.x(p) = x;
    part.y(p) = y;
    part.theta(p) += h * part.w(p);
    const double v2 = part.vx(p) * part.vx(p) + part.vy(p) * part.vy(p);
    const double rw = part.radius(p) * part.w(p);
    if (!kmath::isfinite(x) || !kmath::isfinite(y) || !kmath::isfinite(v2) ||
        !kmath::isfinite(rw)) {
      Kokkos::atomic_exchange(&sys.failure(s), int(kNonFinite));
      return;
    }
    const double v = kmath::sqrt(v2);
    Kokkos::atomic_fetch_max(&sys.max_speed(s), kmath::max(v, kmath::fabs(rw)));
    Kokkos::atomic_fetch_max(&sys.max_centre_speed(s), v);
  }
};

}  // namespace loosepack
