// Convergence of the contact solvers on tall structures (docs/PERFORMANCE.md, "Convergence on tall
// structures"): sweeps to a fixed tolerance against the height n of a loaded column, for each
// solver, cold started (first step, all impulses zero) and warm started (one disk added on top of
// a column at rest). Also the error of the bottom contact force against n m g, so a solver that
// stops early cannot look fast. The accelerated solver runs with and without Newton steps.
// Prints one JSON record per solver, n and start.
//
//   bench_convergence [--n 25,50,100,200] [--tolerance 1e-4] [--max-sweeps 400000]
#include <Kokkos_Core.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "bench/options.hpp"
#include "bench/record.hpp"
#include "loosepack/batch.hpp"
#include "loosepack/scenes.hpp"

using namespace loosepack;

namespace {

// The solvers, and for the accelerated one with and without Newton steps (newton_every).
struct Variant {
  SolverKind kind;
  int newton_every;
};
const Variant kSolvers[] = {{SolverKind::Jacobi, 0},
                            {SolverKind::GaussSeidel, 0},
                            {SolverKind::SequentialGaussSeidel, 0},
                            {SolverKind::AcceleratedGaussSeidel, 0},
                            {SolverKind::AcceleratedGaussSeidel, SolverSettings{}.newton_every}};

// Force on the floor contact over the weight of the column above it, minus one.
double bottom_error(const Batch& batch, int n_total) {
  for (const auto& c : batch.contacts(0))
    if (c.j < 0) return c.normal / n_total - 1.0;
  return NAN;
}

struct Record {
  long sweeps, newton_steps;
  double error, seconds;
};

Record run(Variant variant, int n, bool warm, double tolerance, int max_sweeps) {
  SolverSettings solver;
  solver.kind = variant.kind;
  solver.newton_every = variant.newton_every;
  solver.tolerance = tolerance;
  solver.max_sweeps = max_sweeps;
  SystemSetup su;
  su.params = scenes::column_params(n);
  su.disks = scenes::column(n, 10.0);
  su.capacity = n + 1;
  Batch batch({su}, solver);
  if (warm) {
    // Converge the column, then put one disk on top: the step after it is the warm solve.
    for (int k = 0; k < 3; ++k) batch.step();
    batch.deposit_at({1}, {10.0}, DropRule::Touch);
  }
  const long before = batch.status(0).sweeps, newton_before = batch.status(0).newton_steps;
  const auto t0 = std::chrono::steady_clock::now();
  batch.step();
  const double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return {batch.status(0).sweeps - before, batch.status(0).newton_steps - newton_before,
          bottom_error(batch, warm ? n + 1 : n), sec};
}

}  // namespace

int main(int argc, char** argv) {
  Kokkos::ScopeGuard kokkos(argc, argv);
  std::vector<int> sizes = {25, 50, 100, 200};
  double tolerance = 1e-4;
  int max_sweeps = 400000;
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--n") && a + 1 < argc) {
      sizes = bench::parse_list(argv[++a]);
    } else if (!std::strcmp(argv[a], "--tolerance") && a + 1 < argc) {
      tolerance = std::atof(argv[++a]);
    } else if (!std::strcmp(argv[a], "--max-sweeps") && a + 1 < argc) {
      max_sweeps = std::atoi(argv[++a]);
    } else {
      std::fprintf(stderr,
                   "usage: bench_convergence [--n 25,50,100,200] [--tolerance 1e-4] "
                   "[--max-sweeps 400000]\n");
      return 2;
    }
  }
  // A solve that reached its cap, or whose floor does not carry the column's weight, fails the
  // run (exit 1) after its record. The bound: a sweep that changes no impulse by more than tol h
  // m g can still leave an error of the change over (1 - rho), rho the iteration's contraction,
  // 1 - O(1/n^2) on a column of n: an absolute error O(n^2 tol) in the floor's impulse of n m g,
  // so a relative one O(n tol) (measured: at most 2 n tol over every solver and start,
  // bench/results/convergence-2026-11-23.jsonl).
  int bad = 0;
  for (const Variant& variant : kSolvers)
    for (bool warm : {false, true})
      for (int n : sizes) {
        const Record r = run(variant, n, warm, tolerance, max_sweeps);
        const bool capped = r.sweeps >= max_sweeps;
        const double bound = 4.0 * (warm ? n + 1 : n) * tolerance;
        if (capped || !(std::fabs(r.error) <= bound)) {
          std::fprintf(stderr,
                       "bench_convergence: %s (newton_every %d), %s start, n = %d: %s, floor "
                       "force error %.3e (bound 4 n tol = %.3e)\n",
                       solver_kind_name(variant.kind), variant.newton_every, warm ? "warm" : "cold",
                       n, capped ? "capped" : "not capped", r.error, bound);
          ++bad;
        }
        std::printf(
            "{\"study\": \"column_convergence\", \"solver\": \"%s\", \"newton_every\": %d, "
            "\"start\": \"%s\", \"n\": %d, \"tolerance\": %g, \"sweeps\": %ld, "
            "\"newton_steps\": %ld, \"capped\": %s, \"bottom_force_rel_error\": %.3e, "
            "\"wall_s\": %.4f, %s}\n",
            solver_kind_name(variant.kind), variant.newton_every, warm ? "warm" : "cold", n,
            tolerance, r.sweeps, r.newton_steps, capped ? "true" : "false", r.error, r.seconds,
            bench::Environment().json().c_str());
        std::fflush(stdout);
      }
  return bad > 0 ? 1 : 0;
}
