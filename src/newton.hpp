// Nonsmooth Newton steps for the contact problem of one system (host code, Eigen): what lets
// the accelerated Gauss-Seidel solver (kernels/solver.hpp) converge where its sweeps crawl.
//
// The solution of a step's contact problem is the fixed point P = L(P) of the exact local solves
// (local_impulse) taken all at once. Near it, each component of L is either inside its bounds,
// where the fixed point says the contact's relative velocity meets its target (u_n = -gap/h for
// a closed contact, u_t = 0 sticking, Omega = 0 not rolling), or on a bound, where the impulse
// is that bound (P_n = -h F_c for an open contact, P_t = +-mu (P_n + h F_c) sliding, M = +-mu_r
// R_c (P_n + h F_c) rolling). Which is which is read off the local solves at the current
// impulses; with that choice fixed the conditions are linear in P, and one sparse solve gives
// the impulses that meet them all: the semismooth Newton step of Silcowitz, Niebe & Erleben
// ("A nonsmooth Newton method with applications to computer animation", 2009). Velocity rows
// couple contacts through the Delassus matrix W = H M^-1 H^T, so force crosses a whole deposit in
// one step where sweeps move it one contact per sweep (a column of n disks: ~n NNCG sweeps).
//
// Safeguards: W is singular for the closed loops of a cohesive deposit (stuck contacts in a loop
// carry any self-stress), so its diagonal is raised by the relative kRegularisation for the
// factorisation (and the solve refined against the exact matrix); the step is projected onto
// the bounds and accepted only if it lowers the merit (the sum of squares of the changes a
// Jacobi pass of local solves would make, in the units of the solver tolerance), with step
// halving; a step that lowers nothing is undone. The sweeps stay the judge of convergence.
// When to take a step is the batch's business (Batch::Impl::solve_with_newton, src/batch.cpp).
//
// Loops that cannot close: when a loop of stuck contacts is asked for velocities no rigid motion
// gives (a small gap to close across it), the linear system is inconsistent along the loop's
// self-stresses, and its solution is a huge self-stress (the inconsistency over the
// regularisation) that breaks every bound. That self-stress is where the sweeps creep, a little
// per sweep, for thousands of sweeps, until one contact of the loop reaches its friction or
// rolling bound and the loop opens. Newton steps go there at once: when no step lowers the
// merit, the first component inside its bounds that the refined step would drive onto one (the
// blocking constraint of an active-set method) is held on that bound in the system's later steps
// (`pinned`). A loop of stuck contacts (three self-stresses) opens in up to three such steps, and
// the next one solves the rest exactly (docs/PERFORMANCE.md, "Loops that cannot close").
#pragma once
#include <klu.h>

#include <Eigen/Sparse>
#include <algorithm>
#include <limits>
#include <vector>

#include "kernels/solver.hpp"

namespace loosepack {

// Relative increase of the velocity rows' diagonal (see above). Measured (docs/PERFORMANCE.md,
// "Newton steps"): 1e-5 leaves errors in the near-null modes that the sweeps cannot see (a
// column of 200 stuck disks: its bottom force off by 7e-3; a Bo = 1e6 deposit's floor reaction
// off by 3x the tolerance's bound) and is 1.2-1.4x slower on protocols A and C than 1e-8; with
// the damped step as the fallback, 1e-8 costs no robustness.
constexpr double kRegularisation = 1e-8;
// Refinements of the regularised solve (each a back substitution and a product with W).
constexpr int kRefinements = 3;
// Step lengths tried: 1, 1/2, ..., 1/32.
constexpr int kLineSearchSteps = 6;

// A sparse LU factorisation by KLU (SuiteSparse; Davis & Palamadai Natarajan, "Algorithm 907:
// KLU", 2010: made for very sparse unsymmetric systems such as these tree-like contact
// networks), called directly for the size of its factors (the measure of a Newton step's work)
// and to keep its symbolic analysis (BTF and AMD ordering: as costly as the factorisation
// itself) for the next matrix with the same pattern.
class KluFactor {
 public:
  KluFactor() { klu_defaults(&common_); }
  ~KluFactor() {
    if (numeric_ != nullptr) klu_free_numeric(&numeric_, &common_);
    if (symbolic_ != nullptr) klu_free_symbolic(&symbolic_, &common_);
  }
  KluFactor(const KluFactor&) = delete;
  KluFactor& operator=(const KluFactor&) = delete;

  // Factorises A (compressed columns), analysing its pattern unless it is the last one's;
  // false where KLU fails (a singular matrix).
  bool factorise(const Eigen::SparseMatrix<double>& A) {
    if (numeric_ != nullptr) klu_free_numeric(&numeric_, &common_);
    const int n = static_cast<int>(A.rows());
    const int *p = A.outerIndexPtr(), *i = A.innerIndexPtr();
    const bool same = symbolic_ != nullptr && n == n_ &&
                      std::equal(p, p + n + 1, column_start_.begin(), column_start_.end()) &&
                      std::equal(i, i + p[n], row_.begin(), row_.end());
    if (!same) {
      if (symbolic_ != nullptr) klu_free_symbolic(&symbolic_, &common_);
      n_ = n;
      column_start_.assign(p, p + n + 1);
      row_.assign(i, i + p[n]);
      symbolic_ = klu_analyze(n_, column_start_.data(), row_.data(), &common_);
      if (symbolic_ == nullptr) return false;
      ++analyses_;
    }
    numeric_ = klu_factor(column_start_.data(), row_.data(), const_cast<double*>(A.valuePtr()),
                          symbolic_, &common_);
    return numeric_ != nullptr;
  }
  // A^-1 b, after a successful factorise.
  Eigen::VectorXd solve(const Eigen::VectorXd& b) {
    Eigen::VectorXd x = b;
    klu_solve(symbolic_, numeric_, n_, 1, x.data(), &common_);
    return x;
  }
  // Entries of L and U, diagonals included.
  long entries() const { return numeric_ != nullptr ? long{numeric_->lnz} + numeric_->unz : 0; }
  // Symbolic analyses done so far.
  long analyses() const { return analyses_; }

 private:
  klu_common common_{};
  klu_symbolic* symbolic_ = nullptr;
  klu_numeric* numeric_ = nullptr;
  int n_ = 0;
  std::vector<int> column_start_, row_;  // the analysed pattern
  long analyses_ = 0;
};

// One system's contact problem on the host, in local indices: what a Newton step reads and
// writes. Bodies [n]: inverse mass and inertia, radius, free and current velocities; their
// incident contacts as a compressed list. Contacts [m]: bodies i < j (j = kFloor: the floor),
// geometry, local problem and impulses.
struct NewtonSystem {
  double impulse_unit = 1.0;  // h m g: the unit of the solver tolerance
  std::vector<double> inv_mass, inv_inertia, radius, vfx, vfy, wf, vx, vy, w;
  std::vector<int> incident_start, incident;
  std::vector<int> i, j;
  std::vector<double> nx, ny, rc;
  std::vector<LocalProblem> problem;
  std::vector<ContactImpulse> impulse;
  // Per row (3 per contact: n, t, Omega): 0, or the side (+-1; -1 for a normal row: open) of the
  // bound a blocked step held it on, for the steps after it. Sized by the first step.
  std::vector<signed char> pinned;
  // Entries of the LU factors of every step so far (the steps' work; src/batch.cpp).
  long factor_entries = 0;
  // Where the steps factorise: the system's own, kept from round to round (its analysis is
  // reused while the pattern stays), or, if null, a new one per step.
  KluFactor* factor = nullptr;

  int bodies() const { return static_cast<int>(inv_mass.size()); }
  int contacts() const { return static_cast<int>(i.size()); }

  RelativeVelocity relative_velocity(int c) const {
    const auto k = static_cast<std::size_t>(c);
    const int a = i[k], b = j[k] >= 0 ? j[k] : a;
    return contact_relative_velocity(nx[k], ny[k], vx[a], vy[a], w[a], radius[a], j[k] < 0, vx[b],
                                     vy[b], w[b], radius[b]);
  }

  // v = v_free + M^-1 H^T P (as BodyVelocity).
  void update_velocities() {
    for (int p = 0; p < bodies(); ++p) {
      double ux = vfx[p], uy = vfy[p], uw = wf[p];
      for (int a = incident_start[p]; a < incident_start[p + 1]; ++a) {
        const auto c = static_cast<std::size_t>(incident[a]);
        add_contact_impulse(i[c] == p, impulse[c].pn, impulse[c].pt, impulse[c].pm, nx[c], ny[c],
                            inv_mass[p], inv_inertia[p], radius[p], ux, uy, uw);
      }
      vx[p] = ux;
      vy[p] = uy;
      w[p] = uw;
    }
  }

  // Calls f with the change [h m g] that each contact's exact local solve would make from the
  // current impulses (the quotient the sweeps' convergence test compares: above_tolerance).
  template <class Fx, class F>
  void for_each_local_change(F f) const {
    for (int c = 0; c < contacts(); ++c) {
      const auto k = static_cast<std::size_t>(c);
      if (problem[k].wn <= 0.0) continue;
      const ContactImpulse& P = impulse[k];
      const ContactImpulse L = local_impulse<Fx>(P, relative_velocity(c), problem[k], 1.0);
      f(impulse_change<Fx>(L.pn - P.pn, L.pt - P.pt, L.pm - P.pm, rc[k]) / impulse_unit);
    }
  }
  // The natural residual: the largest of those changes.
  template <class Fx>
  double residual() const {
    double worst = 0.0;
    for_each_local_change<Fx>([&](double d) { worst = std::max(worst, d); });
    return worst;
  }
  // The merit of the Newton step's line search: the sum of their squares (a step that lowers it
  // moves the impulses towards the fixed point as a whole; the largest change alone would
  // refuse a step that settles all contacts but one).
  template <class Fx>
  double merit() const {
    double sum = 0.0;
    for_each_local_change<Fx>([&](double d) { sum += d * d; });
    return sum;
  }

  // The bounds of contact c's impulses: P_n >= lower, and |P_t|, |M| <= coef[0], coef[1] times
  // (P_n - lower) (a coefficient is 0 where its effect is off, or a body cannot roll).
  struct Bounds {
    double lower, coef[2];
  };
  template <class Fx>
  Bounds bounds(int c) const {
    const LocalProblem& q = problem[static_cast<std::size_t>(c)];
    return {Fx::Cohesion ? q.lower : 0.0,
            {Fx::Friction ? q.friction : 0.0, (Fx::Rolling && q.wb > 0.0) ? q.rolling_lever : 0.0}};
  }

  // The rows of H for contact c on body p (rows n, t, Omega; columns vx, vy, w).
  void jacobian_rows(int c, int p, double H[3][3]) const {
    const auto k = static_cast<std::size_t>(c);
    const double sg = i[k] == p ? -1.0 : 1.0;
    H[0][0] = sg * nx[k];
    H[0][1] = sg * ny[k];
    H[0][2] = 0.0;
    H[1][0] = -sg * ny[k];
    H[1][1] = sg * nx[k];
    H[1][2] = -radius[p];
    H[2][0] = 0.0;
    H[2][1] = 0.0;
    H[2][2] = sg;
  }

  // One Newton step from the current impulses (velocities consistent with them): Full (the
  // refined step, or a damped one, lowered the merit), Blocked (none did, and the first row the
  // refined step drives onto a bound is pinned there for the next steps), or Failed (none did
  // and none can be pinned). Unless Full, the impulses and velocities are left as they were.
  enum class Step { Full, Blocked, Failed };
  template <class Fx>
  Step newton_step();

 private:
  // The linearised problem of one Newton step, row by row (classify_rows).
  struct NewtonRows {
    enum Kind : char { Velocity, Impulse };
    std::vector<char> kind;
    std::vector<double> rhs, follow;
    std::vector<int> unknown;  // a velocity row's index among the unknowns; -1 for the others
    int n_unknowns = 0;
    Eigen::VectorXd expand(const Eigen::VectorXd& x) const;
  };
  template <class Fx>
  NewtonRows classify_rows() const;
  bool solve_rows(const NewtonRows& rows, Eigen::VectorXd& damped_x, Eigen::VectorXd& refined_x);
  template <class Fx>
  double take(const std::vector<ContactImpulse>& start, const Eigen::VectorXd& step, double length);
  template <class Fx>
  Step block(const NewtonRows& rows, const std::vector<ContactImpulse>& start,
             const Eigen::VectorXd& refined);
};

template <class Fx>
NewtonSystem::Step NewtonSystem::newton_step() {
  const int m = contacts();
  if (m == 0) return Step::Failed;
  const double r0 = merit<Fx>();
  if (pinned.size() != static_cast<std::size_t>(3 * m))
    pinned.assign(static_cast<std::size_t>(3 * m), 0);
  const NewtonRows rows = classify_rows<Fx>();
  Eigen::VectorXd damped_x = Eigen::VectorXd::Zero(rows.n_unknowns), refined_x = damped_x;
  if (rows.n_unknowns > 0 && !solve_rows(rows, damped_x, refined_x)) return Step::Failed;
  const Eigen::VectorXd damped = rows.expand(damped_x), refined = rows.expand(refined_x);
  // The refined step if it lowers the merit (the merit hardly sees the near-null modes, which
  // only the refined step gets right), else the damped one (on the near-null modes of a loop
  // whose active set is not yet right the refined step can leave the bounds far behind),
  // halved while the merit does not fall; projected onto the bounds.
  const std::vector<ContactImpulse> start = impulse;
  if (take<Fx>(start, refined, 1.0) < r0) return Step::Full;
  double r1 = take<Fx>(start, damped, 1.0);
  double length = 1.0;
  for (int attempt = 1; attempt < kLineSearchSteps && !(r1 < r0); ++attempt) {
    length *= 0.5;
    r1 = take<Fx>(start, damped, length);
  }
  if (r1 < r0) return Step::Full;
  impulse = start;
  update_velocities();
  return block<Fx>(rows, start, refined);
}

// The rows of a Newton step (three per contact: n, t, Omega). A velocity row: the contact's
// relative velocity meets its target; an impulse row, whose change is fixed: dP_r = rhs_r +
// follow_r dP_n, where follow_r = +-coef makes a component on its bound follow the contact's
// normal impulse (when that has a velocity row). The velocity rows' changes are the unknowns of
// the sparse solve; the impulse rows are eliminated into it.
template <class Fx>
NewtonSystem::NewtonRows NewtonSystem::classify_rows() const {
  const int m = contacts();
  const auto n_rows = static_cast<std::size_t>(3 * m);
  NewtonRows rows;
  rows.kind.assign(n_rows, NewtonRows::Velocity);
  rows.rhs.assign(n_rows, 0.0);
  rows.follow.assign(n_rows, 0.0);
  auto& kind = rows.kind;
  auto& rhs = rows.rhs;
  auto& follow = rows.follow;
  for (int c = 0; c < m; ++c) {
    const auto k = static_cast<std::size_t>(c);
    const auto r = static_cast<std::size_t>(3 * c);
    const LocalProblem& q = problem[k];
    const ContactImpulse& P = impulse[k];
    const Bounds B = bounds<Fx>(c);
    const double lower = B.lower;
    if (q.wn <= 0.0) {  // two immobile bodies: nothing to solve
      for (std::size_t a = 0; a < 3; ++a) kind[r + a] = NewtonRows::Impulse;
      continue;
    }
    const RelativeVelocity u = relative_velocity(c);
    const ContactImpulse L = local_impulse<Fx>(P, u, q, 1.0);
    // Closed: the local solve leaves the normal impulse above its bound, or the contact touches
    // and does not separate (at zero impulse and zero relative velocity, as in a resting column
    // cold started, the local solve cannot tell; the Newton step can).
    const bool closed = pinned[r] == 0 && (L.pn > lower || (q.gap <= 0.0 && u.un <= 0.0));
    if (closed) {
      rhs[r] = -(q.gap > 0.0 ? q.gap / q.h : 0.0) - u.un;
    } else {
      kind[r] = NewtonRows::Impulse;
      rhs[r] = lower - P.pn;
    }
    // Tangential and rolling rows: inside the bounds a velocity row, on a bound an impulse row
    // that follows the normal impulse (through the bound), open contacts carry nothing.
    const double shifted = L.pn - lower;
    const double value[2] = {L.pt, L.pm}, now[2] = {P.pt, P.pm};
    const double* coef = B.coef;
    const double velocity[2] = {u.ut, u.om};
    for (std::size_t a = 0; a < 2; ++a) {
      const std::size_t row = r + 1 + a;
      const double bound = coef[a] * shifted;
      // (A contact closed by touching, with no normal impulse yet, sticks.)
      const bool inside = closed && pinned[row] == 0 &&
                          (std::abs(value[a]) < bound || (bound <= 0.0 && coef[a] > 0.0));
      if (inside) {
        rhs[row] = -velocity[a];
        continue;
      }
      kind[row] = NewtonRows::Impulse;
      const double sign = !closed || bound <= 0.0 ? 0.0
                          : pinned[row] != 0      ? pinned[row]
                                                  : (value[a] > 0.0 ? 1.0 : -1.0);
      // P + dP = sign coef (P_n + dP_n - lower)
      rhs[row] = sign * coef[a] * (P.pn - lower) - now[a];
      if (kind[r] == NewtonRows::Velocity) follow[row] = sign * coef[a];
    }
  }
  rows.unknown.assign(n_rows, -1);
  for (std::size_t r = 0; r < n_rows; ++r)
    if (kind[r] == NewtonRows::Velocity) rows.unknown[r] = rows.n_unknowns++;
  return rows;
}

// The whole step from the unknowns' changes x.
inline Eigen::VectorXd NewtonSystem::NewtonRows::expand(const Eigen::VectorXd& x) const {
  const auto n_rows = static_cast<int>(kind.size());
  Eigen::VectorXd step(n_rows);
  for (int r = 0; r < n_rows; ++r) {
    const auto k = static_cast<std::size_t>(r);
    step(r) = unknown[k] >= 0
                  ? x(unknown[k])
                  : rhs[k] + (follow[k] != 0.0 ? follow[k] * x(unknown[k - k % 3]) : 0.0);
  }
  return step;
}

// The unknowns' changes of the velocity rows: W = H M^-1 H^T over the bodies the contacts
// share, with the impulse rows' fixed changes moved to the right-hand side and their following
// into the normal's column. Factorises the regularised matrix (damped: the near-null modes
// damped), then refines against the exact one (refined). False when that fails.
inline bool NewtonSystem::solve_rows(const NewtonRows& rows, Eigen::VectorXd& damped_x,
                                     Eigen::VectorXd& refined_x) {
  const int n_unknowns = rows.n_unknowns;
  const auto& unknown = rows.unknown;
  Eigen::VectorXd b(n_unknowns);
  for (std::size_t r = 0; r < unknown.size(); ++r)
    if (unknown[r] >= 0) b(unknown[r]) = rows.rhs[r];
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(static_cast<std::size_t>(n_unknowns) * 8);
  for (int p = 0; p < bodies(); ++p) {
    const double mobility[3] = {inv_mass[p], inv_mass[p], inv_inertia[p]};
    for (int a = incident_start[p]; a < incident_start[p + 1]; ++a) {
      const int ca = incident[a];
      double Ha[3][3];
      jacobian_rows(ca, p, Ha);
      for (int e = incident_start[p]; e < incident_start[p + 1]; ++e) {
        const int cb = incident[e];
        double Hb[3][3];
        jacobian_rows(cb, p, Hb);
        for (int x = 0; x < 3; ++x) {
          const int ra = unknown[static_cast<std::size_t>(3 * ca + x)];
          if (ra < 0) continue;
          for (int y = 0; y < 3; ++y) {
            double v = 0.0;
            for (int d = 0; d < 3; ++d) v += Ha[x][d] * mobility[d] * Hb[y][d];
            if (v == 0.0) continue;
            const auto rb = static_cast<std::size_t>(3 * cb + y);
            if (unknown[rb] >= 0) {
              entries.emplace_back(ra, unknown[rb], v);
              continue;
            }
            b(ra) -= v * rows.rhs[rb];
            if (rows.follow[rb] != 0.0)
              entries.emplace_back(ra, unknown[3 * cb], v * rows.follow[rb]);
          }
        }
      }
    }
  }
  Eigen::SparseMatrix<double> A(n_unknowns, n_unknowns);
  A.setFromTriplets(entries.begin(), entries.end());
  A.makeCompressed();
  // Iterative refinement against the exact matrix removes the regularisation's error where W is
  // well conditioned (a tall column needs it: its smallest eigenvalue is ~1/n^2 of the
  // diagonal) and leaves the near-null modes damped.
  Eigen::SparseMatrix<double> regularised = A;
  for (int r = 0; r < n_unknowns; ++r) regularised.coeffRef(r, r) *= 1.0 + kRegularisation;
  regularised.makeCompressed();  // (KLU reads compressed columns)
  KluFactor own;
  KluFactor& lu = factor != nullptr ? *factor : own;
  const bool factorised = lu.factorise(regularised);
  factor_entries += lu.entries();
  if (!factorised) return false;
  damped_x = lu.solve(b);
  refined_x = damped_x;
  for (int k = 0; k < kRefinements; ++k) refined_x += lu.solve(b - A * refined_x);
  return damped_x.allFinite() && refined_x.allFinite();
}

// The impulses start + length step, projected onto the bounds, with their velocities; returns
// the merit there.
template <class Fx>
double NewtonSystem::take(const std::vector<ContactImpulse>& start, const Eigen::VectorXd& step,
                          double length) {
  for (int c = 0; c < contacts(); ++c) {
    const auto k = static_cast<std::size_t>(c);
    const Bounds B = bounds<Fx>(c);
    const double pn = std::max(B.lower, start[k].pn + length * step(3 * c));
    const double bound_t = B.coef[0] * (pn - B.lower), bound_r = B.coef[1] * (pn - B.lower);
    impulse[k] = {pn, std::clamp(start[k].pt + length * step(3 * c + 1), -bound_t, bound_t),
                  std::clamp(start[k].pm + length * step(3 * c + 2), -bound_r, bound_r)};
  }
  update_velocities();
  return merit<Fx>();
}

// Nothing lowered the merit. Along the refined step, which component that is inside its bounds
// (a velocity row) reaches one first, and on which side: hold it there from the next step on (a
// loop that cannot close opens there; the impulses are not moved now).
template <class Fx>
NewtonSystem::Step NewtonSystem::block(const NewtonRows& rows,
                                       const std::vector<ContactImpulse>& start,
                                       const Eigen::VectorXd& refined) {
  double blocking = std::numeric_limits<double>::infinity();
  int block_row = -1;
  signed char block_side = 0;
  const auto limit = [&](double rate, double slack, int row, signed char side) {
    if (rate > 0.0 && std::max(0.0, slack) < blocking * rate) {
      blocking = std::max(0.0, slack) / rate;
      block_row = row;
      block_side = side;
    }
  };
  for (int c = 0; c < contacts(); ++c) {
    const auto k = static_cast<std::size_t>(c);
    const Bounds B = bounds<Fx>(c);
    const ContactImpulse& P = start[k];
    const double dn = refined(3 * c), shifted = P.pn - B.lower;
    if (rows.kind[3 * k] == NewtonRows::Velocity) limit(-dn, shifted, 3 * c, -1);
    const double now[2] = {P.pt, P.pm};
    for (int a = 0; a < 2; ++a) {  // |P + L dP| <= coef (P_n + L dP_n - lower), both sides
      const int row = 3 * c + 1 + a;
      const double d = refined(row), coef = B.coef[a];
      if (rows.kind[static_cast<std::size_t>(row)] != NewtonRows::Velocity || !(coef > 0.0))
        continue;
      limit(d - coef * dn, coef * shifted - now[a], row, 1);
      limit(-d - coef * dn, coef * shifted + now[a], row, -1);
    }
  }
  if (block_row < 0) return Step::Failed;
  pinned[static_cast<std::size_t>(block_row)] = block_side;
  return Step::Blocked;
}

// When one system's Newton rounds come (Batch::Impl::solve_with_newton, src/batch.cpp). A
// step's sweeps run for `wait` sweeps before its first round and between rounds; a round that
// pays (cuts the residual tenfold, or below the tolerance) halves the wait, down to `shortest`;
// one that does not doubles it, up to `longest` (one wait short of the sweep cap, so that a step
// about to be capped still gets a round, and a round that pays there brings the waits down).
// Rounds at the longest wait spend at most kCapShare of the sweeps of the capped steps: each
// capped step earns that share of its sweeps as credit (up to one step's share), each round at
// the longest wait costs what it cost (in sweeps of its system: NewtonPace::round_cost) unless
// it ended its step (the step converged instead of being capped: the round did what it came
// for), and a step starts without a round while the credit is negative. Where such rounds are
// cheap against a capped step or end it often (a loose cohesive deposit: tree-like contact
// networks, small factors, a quarter of them end their step) every capped step keeps its
// round; where the capped steps are a nonsmooth switch that no Newton step settles (frictional
// packings without cohesion: 1 % end their step) and a round factorises a dense packing (a
// round of eight steps there can cost more than the capped step's sweeps), they thin out.
struct NewtonPace {
  static constexpr double kCapShare = 0.0625;
  int wait = 0;          // sweeps before a step's first round, and between rounds
  double credit = 0.0;   // [sweeps] for rounds at the longest wait
  double charged = 0.0;  // [sweeps] the cost of this step's round at the longest wait, if any

  // A round's cost in sweeps of its system: its steps (their classification, assembly, line
  // searches and residuals) and their factorisations, from timings of rounds against sweeps on
  // protocol A at Bo = 0 and 1e3 (docs/PERFORMANCE.md, "The pace of the rounds"): about 25
  // sweeps a step, one per entry of the LU factors per contact, and 4 for gathering the system
  // (fitted before each system kept its KLU analysis: since then a little high, which makes
  // the budget below a little stricter).
  static double round_cost(int steps, long factor_entries, int contacts) {
    return 4.0 + 25.0 * steps + static_cast<double>(factor_entries) / std::max(contacts, 1);
  }
  // Whether this step runs to the sweep cap without a round.
  bool skips_step(int longest) const { return wait >= longest && credit < 0.0; }
  void after_round(bool paid, double cost, int shortest, int longest) {
    if (wait >= longest) {
      credit -= cost;
      charged += cost;
    }
    if (paid)
      wait = std::max(shortest, wait / 2);
    else
      wait = std::min(longest, 2 * wait);
  }
  // At the end of every step.
  void step_done(bool capped, int max_sweeps) {
    const double most = kCapShare * max_sweeps;
    credit = std::min(credit + (capped ? most : charged), most);
    charged = 0.0;
  }
};

}  // namespace loosepack
