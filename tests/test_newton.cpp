// The Newton step of the contact solve (src/newton.hpp) on hand-built problems: exact loads from
// statics, and the safeguards (the residual never rises, impulses stay within their bounds).
#include <gtest/gtest.h>

#include <cmath>

#include "src/newton.hpp"

using namespace loosepack;

namespace {

using Full = Effects<false, true, true>;  // friction and rolling friction, no cohesion
using Cohesive = Effects<true, true, true>;

struct Body {
  double x, y;
};

// The contact problem of disks of radius 1 and mass 1 at rest under gravity g = 1 (free
// velocities -h g), with the contacts (i, j) given (j = kFloor: the floor), all impulses zero.
NewtonSystem rest_problem(const std::vector<Body>& bodies,
                          const std::vector<std::pair<int, int>>& pairs, double h, double mu,
                          double mu_r) {
  NewtonSystem ns;
  ns.impulse_unit = h;  // h m g
  const int n = static_cast<int>(bodies.size());
  for (int p = 0; p < n; ++p) {
    ns.inv_mass.push_back(1.0);
    ns.inv_inertia.push_back(2.0);  // I = m R^2 / 2
    ns.radius.push_back(1.0);
    ns.vfx.push_back(0.0);
    ns.vfy.push_back(-h);
    ns.wf.push_back(0.0);
  }
  ns.vx = ns.vfx;
  ns.vy = ns.vfy;
  ns.w = ns.wf;
  for (const auto& [i, j] : pairs) {
    double nx = 0.0, ny = -1.0, gap = bodies[i].y - 1.0;
    ContactMobility mob = contact_mobility(1.0, 2.0, 1.0, 0.0, 0.0, 0.0);
    if (j >= 0) {
      const double dx = bodies[j].x - bodies[i].x, dy = bodies[j].y - bodies[i].y;
      const double d = std::hypot(dx, dy);
      nx = dx / d;
      ny = dy / d;
      gap = d - 2.0;
      mob = contact_mobility(1.0, 2.0, 1.0, 1.0, 2.0, 1.0);
    }
    ns.i.push_back(i);
    ns.j.push_back(j);
    ns.nx.push_back(nx);
    ns.ny.push_back(ny);
    ns.rc.push_back(1.0);
    ns.problem.push_back({gap, h, mob.wn, mob.a, mob.b, mob.c, 0.0, mu, mu_r});
    ns.impulse.push_back({0.0, 0.0, 0.0});
  }
  ns.incident_start.push_back(0);
  for (int p = 0; p < n; ++p) {
    for (int c = 0; c < ns.contacts(); ++c)
      if (ns.i[static_cast<std::size_t>(c)] == p || ns.j[static_cast<std::size_t>(c)] == p)
        ns.incident.push_back(c);
    ns.incident_start.push_back(static_cast<int>(ns.incident.size()));
  }
  return ns;
}

}  // namespace

// A column of n disks on the floor from zero impulses: the contacts are all closed and stuck, the
// conditions linear, and one Newton step gives the statics: the contact below the k-th disk from
// the top carries k m g (impulse k h m g), no tangential force, no moment, all at rest. (The
// regularisation, 1e-5 of the diagonal, refined three times, leaves a relative error ~1e-9.)
TEST(Newton, OneStepCarriesAColumnsWeight) {
  const int n = 30;
  const double h = 0.01;
  std::vector<Body> bodies;
  std::vector<std::pair<int, int>> pairs{{0, kFloor}};
  for (int k = 0; k < n; ++k) bodies.push_back({5.0, 1.0 + 2.0 * k});
  for (int k = 0; k + 1 < n; ++k) pairs.emplace_back(k, k + 1);
  NewtonSystem ns = rest_problem(bodies, pairs, h, 0.3, 0.1);
  const double r0 = ns.residual<Full>();
  EXPECT_NEAR(r0, 1.0, 1e-12);  // the floor contact alone would take h m g
  EXPECT_EQ(ns.newton_step<Full>(), NewtonSystem::Step::Full);
  EXPECT_LT(ns.residual<Full>(), 1e-6);
  for (int c = 0; c < ns.contacts(); ++c) {
    const int below = c == 0 ? n : n - c;  // disks above contact c
    const ContactImpulse& P = ns.impulse[static_cast<std::size_t>(c)];
    EXPECT_NEAR(P.pn, below * h, 1e-6 * below * h) << "contact " << c;
    EXPECT_NEAR(P.pt, 0.0, 1e-12);
    EXPECT_NEAR(P.pm, 0.0, 1e-12);
  }
  for (int p = 0; p < n; ++p) EXPECT_NEAR(ns.vy[static_cast<std::size_t>(p)], 0.0, 1e-6 * h);
}

// The three-disk pyramid with mu = 0.25, below its stability threshold 2 - sqrt 3 = 0.268: no
// impulses hold it, the upper contacts slide. Whatever the steps do, each leaves a merit no
// larger than the one it started from, leaves every impulse within its bounds and the
// velocities those of the impulses.
TEST(Newton, StepsNeverRaiseTheMeritNorLeaveTheBounds) {
  const double half = 1.0 + 0.5e-9, h = 0.01, mu = 0.25;
  const std::vector<Body> bodies{
      {10.0 - half, 1.0}, {10.0 + half, 1.0}, {10.0, 1.0 + std::sqrt(4.0 - half * half)}};
  NewtonSystem ns = rest_problem(bodies, {{0, kFloor}, {1, kFloor}, {0, 2}, {1, 2}}, h, mu, 0.0);
  for (int step = 0; step < 10; ++step) {
    const double before = ns.merit<Full>();
    ns.newton_step<Full>();
    EXPECT_LE(ns.merit<Full>(), before) << "step " << step;
    for (const auto& P : ns.impulse) {
      EXPECT_GE(P.pn, 0.0);
      EXPECT_LE(std::abs(P.pt), mu * P.pn * (1.0 + 1e-12));
      EXPECT_EQ(P.pm, 0.0);  // no rolling resistance
    }
    NewtonSystem again = ns;
    again.update_velocities();
    for (int p = 0; p < ns.bodies(); ++p) {
      const auto k = static_cast<std::size_t>(p);
      EXPECT_NEAR(again.vx[k], ns.vx[k], 1e-14);
      EXPECT_NEAR(again.vy[k], ns.vy[k], 1e-14);
      EXPECT_NEAR(again.w[k], ns.w[k], 1e-14);
    }
  }
  // The top disk cannot stay: it moves down (the base disks slide apart).
  EXPECT_LT(ns.vy[2], -1e-3 * h);
}

// A loop that cannot close: two cohesive disks on the floor, 2 delta apart, their contact within
// the cohesion range and pulled shut in one step (u_n = -gap/h), both stuck to the floor and not
// rolling. No rigid motion closes the gap, so the linear system of "everything stuck" is
// inconsistent along the loop's three self-stresses, and its solution a huge self-stress that
// breaks every bound: a full Newton step cannot lower the merit. Blocked steps go along it
// until contacts reach their bounds (the loop opens; Gauss-Seidel creeps there a little per
// sweep), and the steps end at the fixed point of the local solves: the gap closes within the
// step, the bodies approach each other by exactly 2 delta, every impulse within its bounds.
TEST(Newton, BlockedStepsOpenALoopThatCannotClose) {
  const double delta = 1e-5, h = 0.01, mu = 0.3, mu_r = 0.1, cohesion = 10.0 * h;  // h F_c
  NewtonSystem ns = rest_problem({{5.0 - 1.0 - delta, 1.0}, {5.0 + 1.0 + delta, 1.0}},
                                 {{0, kFloor}, {1, kFloor}, {0, 1}}, h, mu, mu_r);
  for (auto& q : ns.problem) q.lower = -cohesion;
  int blocked = 0, steps = 0;
  for (; steps < 12 && ns.residual<Cohesive>() > 1e-9; ++steps) {
    const auto step = ns.newton_step<Cohesive>();
    ASSERT_NE(step, NewtonSystem::Step::Failed) << "step " << steps;
    blocked += step == NewtonSystem::Step::Blocked;
  }
  EXPECT_LE(ns.residual<Cohesive>(), 1e-9);  // within the 12 steps the loop allows
  EXPECT_GE(blocked, 1);
  // The gap closes: the relative normal velocity of the pair is -2 delta / h.
  EXPECT_NEAR(ns.relative_velocity(2).un, -2.0 * delta / h, 1e-9 * delta / h);
  for (int c = 0; c < ns.contacts(); ++c) {
    const ContactImpulse& P = ns.impulse[static_cast<std::size_t>(c)];
    const double shifted = P.pn + cohesion;
    EXPECT_GE(shifted, -1e-15) << "contact " << c;
    EXPECT_LE(std::abs(P.pt), mu * shifted * (1.0 + 1e-12)) << "contact " << c;
    EXPECT_LE(std::abs(P.pm), mu_r * shifted * (1.0 + 1e-12)) << "contact " << c;
  }
}

// The pace of a system's Newton rounds: failed rounds double the wait up to the longest; there,
// rounds spend at most NewtonPace::kCapShare of the capped steps' sweeps (a cheap round comes
// with every capped step, a dear one with some) unless they end their step; a round that pays
// halves the wait.
TEST(Newton, PaceSpendsAShareOfTheCappedStepsOnRounds) {
  const int shortest = 10, max_sweeps = 1000, longest = max_sweeps - shortest;
  NewtonPace pace{shortest};
  for (int expected : {20, 40, 80, 160, 320, 640, 990}) {
    EXPECT_FALSE(pace.skips_step(longest));
    pace.after_round(false, 1.0, shortest, longest);
    EXPECT_EQ(pace.wait, expected);
  }
  EXPECT_EQ(pace.credit, 0.0);  // rounds below the longest wait are not counted
  const double share = NewtonPace::kCapShare * max_sweeps;
  const int capped_steps = 2000;
  for (double cost : {0.5 * share, share, 3.0 * share, 7.5 * share}) {
    NewtonPace p{longest};
    int rounds = 0;
    for (int step = 0; step < capped_steps; ++step) {
      if (!p.skips_step(longest)) {
        ++rounds;
        p.after_round(false, cost, shortest, longest);
      }
      p.step_done(true, max_sweeps);
    }
    if (cost <= share) {
      EXPECT_EQ(rounds, capped_steps) << "cost " << cost;
      continue;
    }
    // Spent rounds * cost; earned a share per capped step, spent ahead by at most one round,
    // and at most one share left unspent.
    EXPECT_LE(rounds * cost, capped_steps * share + cost) << "cost " << cost;
    EXPECT_GE(rounds * cost, (capped_steps - 1) * share) << "cost " << cost;
  }
  // Rounds that end their step (it converges instead of being capped) cost nothing, however
  // dear: every step keeps its round.
  {
    NewtonPace p{longest};
    for (int step = 0; step < 100; ++step) {
      ASSERT_FALSE(p.skips_step(longest)) << "step " << step;
      p.after_round(false, 7.5 * share, shortest, longest);
      p.step_done(false, max_sweeps);
    }
  }
  // A round that pays at the longest wait brings the wait and the rounds back.
  NewtonPace p{longest};
  p.after_round(false, 10.0 * share, shortest, longest);
  EXPECT_TRUE(p.skips_step(longest));
  p.after_round(true, 1.0, shortest, longest);
  EXPECT_EQ(p.wait, longest / 2);
  EXPECT_FALSE(p.skips_step(longest));
  for (int i = 0; i < 10; ++i) p.after_round(true, 1.0, shortest, longest);
  EXPECT_EQ(p.wait, shortest);
}

// A round's cost in sweeps grows with its steps and with the size of its factors per contact.
TEST(Newton, RoundCostCountsStepsAndFactors) {
  EXPECT_LT(NewtonPace::round_cost(1, 3000, 100), NewtonPace::round_cost(2, 3000, 100));
  EXPECT_LT(NewtonPace::round_cost(1, 3000, 100), NewtonPace::round_cost(1, 30000, 100));
  // The same factors per contact cost the same sweeps in a larger system.
  EXPECT_DOUBLE_EQ(NewtonPace::round_cost(3, 3000, 100), NewtonPace::round_cost(3, 30000, 1000));
}

// The factorisation keeps its analysis for the next matrix with the same pattern (and solves
// it exactly as a fresh one would), and analyses a new pattern afresh.
TEST(Newton, FactorReusesItsAnalysisWhileThePatternStays) {
  const auto tridiagonal = [](int n, double diagonal, bool corner) {
    std::vector<Eigen::Triplet<double>> t;
    for (int r = 0; r < n; ++r) {
      t.emplace_back(r, r, diagonal + r);
      if (r > 0) t.emplace_back(r, r - 1, -1.0);
      if (r + 1 < n) t.emplace_back(r, r + 1, -0.5);
    }
    if (corner) t.emplace_back(0, n - 1, 0.25);
    Eigen::SparseMatrix<double> A(n, n);
    A.setFromTriplets(t.begin(), t.end());
    A.makeCompressed();
    return A;
  };
  const int n = 40;
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(n, -1.0, 2.0);
  KluFactor kept;
  ASSERT_TRUE(kept.factorise(tridiagonal(n, 4.0, false)));
  for (double diagonal : {3.0, 5.0, 9.0}) {
    const Eigen::SparseMatrix<double> A = tridiagonal(n, diagonal, false);
    ASSERT_TRUE(kept.factorise(A));
    KluFactor fresh;
    ASSERT_TRUE(fresh.factorise(A));
    const Eigen::VectorXd x = kept.solve(b), y = fresh.solve(b);
    for (int r = 0; r < n; ++r) EXPECT_EQ(x(r), y(r)) << "row " << r;  // bit for bit
    EXPECT_LT((A * x - b).norm(), 1e-12 * b.norm());
  }
  EXPECT_EQ(kept.analyses(), 1);
  const Eigen::SparseMatrix<double> other = tridiagonal(n, 4.0, true);
  ASSERT_TRUE(kept.factorise(other));
  EXPECT_EQ(kept.analyses(), 2);
  EXPECT_LT((other * kept.solve(b) - b).norm(), 1e-12 * b.norm());
}
