// A binary collision, the simplest dynamics with an exact answer (docs/VALIDATION.md): two
// disks of any radii and masses touching with an approaching normal velocity u_n, no gravity.
// Contact dynamics is perfectly inelastic, so one step later:
// - the normal relative velocity is zero;
// - momentum is conserved, and angular momentum about any point (the impulses act at the
//   contact point, equal and opposite);
// - without friction the tangential relative velocity is unchanged and the kinetic energy lost
//   is m_n u_n^2 / 2, m_n = m_i m_j / (m_i + m_j) the reduced mass;
// - with friction mu and a tangential relative velocity large enough to slide, the tangential
//   impulse is mu times the normal one.
// Across the periodic seam as well as inside the box.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "loosepack/batch.hpp"
#include "loosepack/scenes.hpp"

using namespace loosepack;
using namespace loosepack::scenes;

namespace {

struct Pair {
  double ri, rj;  // radii
  bool seam;      // the contact lies across x = 0 = L_x
};

std::string name(const Pair& p) {
  return "radii " + std::to_string(p.ri) + ", " + std::to_string(p.rj) +
         (p.seam ? " across the seam" : "");
}

struct Collision {
  SystemParams params;
  Disk a, b;
  double nx = 0, ny = 0;  // unit normal from a to b (unwrapped)
  double bx_unwrapped = 0;
};

// Disks a and b touching along the normal at angle `angle` from x; a moves with (vx, vy), b at
// rest. With `seam`, a sits just left of x = L_x and b beyond it, wrapped to small x.
Collision touching(const Pair& p, double angle, double vx, double vy) {
  Collision c;
  c.params = bare_params(40.0, 40.0);
  c.params.gravity_on = false;
  c.nx = std::cos(angle);
  c.ny = std::sin(angle);
  const double d = p.ri + p.rj;
  c.a.radius = p.ri;
  c.b.radius = p.rj;
  c.a.x = p.seam ? c.params.width - 0.5 * d * c.nx : 20.0;
  c.a.y = 20.0;
  c.bx_unwrapped = c.a.x + d * c.nx;
  c.b.x = std::fmod(c.bx_unwrapped, c.params.width);
  c.b.y = c.a.y + d * c.ny;
  c.a.vx = vx;
  c.a.vy = vy;
  return c;
}

double mass(const SystemParams& p, const Disk& d) {
  return p.disk_density * M_PI * d.radius * d.radius;
}
double inertia(const SystemParams& p, const Disk& d) {
  return 0.5 * mass(p, d) * d.radius * d.radius;
}

// One step of the pair, tightly solved; returns the disks after it (a, b).
std::pair<Disk, Disk> step_once(const Collision& c, double friction) {
  SystemParams p = c.params;
  p.friction = friction;
  SolverSettings tight;
  tight.kind = SolverKind::GaussSeidel;
  tight.tolerance = 1e-13;
  tight.max_sweeps = 100000;
  Batch batch({setup(p, {c.a, c.b})}, tight);
  batch.step();
  const auto d = batch.disks(0);
  return {d[0], d[1]};
}

// Relative velocity of b against a at the contact point, split into normal and tangential.
std::pair<double, double> relative(const Collision& c, const Disk& a, const Disk& b) {
  const double tx = -c.ny, ty = c.nx;
  const double ux = b.vx - a.vx, uy = b.vy - a.vy;
  // Contact point velocities: v + w x r, r = +R_a n for a, -R_b n for b.
  const double wa_t = a.w * a.radius, wb_t = b.w * b.radius;
  return {ux * c.nx + uy * c.ny, ux * tx + uy * ty - wa_t - wb_t};
}

const Pair kPairs[] = {
    {1.0, 1.0, false}, {1.0, 2.5, false}, {2.5, 1.0, false}, {1.0, 2.5, true}, {2.5, 1.0, true}};

}  // namespace

TEST(Collision, FrictionlessImpactIsPerfectlyInelasticAndConservesMomentum) {
  for (const Pair& pair : kPairs) {
    SCOPED_TRACE(name(pair));
    // Oblique: the normal 30 degrees off the motion.
    const Collision c = touching(pair, 0.5235987755982988, 1.0, 0.0);
    const auto [a, b] = step_once(c, 0.0);
    const double ma = mass(c.params, c.a), mb = mass(c.params, c.b);
    const auto [un0, ut0] = relative(c, c.a, c.b);
    const auto [un, ut] = relative(c, a, b);
    ASSERT_LT(un0, -0.5);  // approaching
    EXPECT_NEAR(un, 0.0, 1e-10);
    EXPECT_NEAR(ut, ut0, 1e-12);
    EXPECT_NEAR(ma * a.vx + mb * b.vx, ma * c.a.vx, 1e-12);
    EXPECT_NEAR(ma * a.vy + mb * b.vy, ma * c.a.vy, 1e-12);
    EXPECT_EQ(a.w, 0.0);
    EXPECT_EQ(b.w, 0.0);
    const double e0 = 0.5 * ma * (c.a.vx * c.a.vx + c.a.vy * c.a.vy);
    const double e1 =
        0.5 * ma * (a.vx * a.vx + a.vy * a.vy) + 0.5 * mb * (b.vx * b.vx + b.vy * b.vy);
    const double reduced = ma * mb / (ma + mb);
    EXPECT_NEAR(e0 - e1, 0.5 * reduced * un0 * un0, 1e-10 * e0);
  }
}

TEST(Collision, SlidingImpactConservesMomentumAndAngularMomentum) {
  for (const Pair& pair : kPairs) {
    SCOPED_TRACE(name(pair));
    // A glancing impact: the normal 60 degrees off the motion, so the tangential relative
    // velocity (sin 60) exceeds what friction 0.1 can stop (it takes mu (1 + ...) cos 60).
    const double mu = 0.1;
    const Collision c = touching(pair, 1.0471975511965976, 1.0, 0.0);
    const auto [a, b] = step_once(c, mu);
    const double ma = mass(c.params, c.a), mb = mass(c.params, c.b);
    const auto [un, ut] = relative(c, a, b);
    const double ut0 = relative(c, c.a, c.b).second;
    EXPECT_NEAR(un, 0.0, 1e-10);
    EXPECT_GT(std::abs(ut), 1e-3) << "still sliding";
    EXPECT_NEAR(ma * a.vx + mb * b.vx, ma * c.a.vx, 1e-12);
    EXPECT_NEAR(ma * a.vy + mb * b.vy, ma * c.a.vy, 1e-12);
    // Impulses on b: normal P_n = m_b (v_b . n), tangential P_t = m_b (v_b . t); sliding: the
    // tangential one is mu times the normal one, against the slip.
    const double pn = mb * (b.vx * c.nx + b.vy * c.ny);
    const double pt = mb * (-b.vx * c.ny + b.vy * c.nx);
    EXPECT_GT(pn, 0.0);
    EXPECT_NEAR(std::abs(pt), mu * pn, 1e-10);
    EXPECT_LT(pt * ut0, 0.0) << "friction on b opposes b's slip relative to a";
    // Angular momentum about the start of the step's centre of a: orbital (positions at the
    // start of the step, where the impulses act) plus spin.
    const double bx = c.bx_unwrapped - c.a.x, by = c.b.y - c.a.y;
    const double l0 = 0.0;  // a at the origin, b at rest
    const double l1 =
        mb * (bx * b.vy - by * b.vx) + inertia(c.params, c.a) * a.w + inertia(c.params, c.b) * b.w;
    EXPECT_NEAR(l1, l0, 1e-10);
  }
}
