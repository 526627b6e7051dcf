// The standard scenes S1 (sequential deposition, no cohesion) and S2 (collapse of a ballistic
// deposit) of docs/SCENES.md, run through loosepack's engine with periodic x;
// prints one JSON record per scene and N, to set beside other engines' records.
//
//   bench_scenes [--scene S1|S2|both] [--n N1,N2,...] [--dt H] [--solver KIND]
//                [--tolerance T] [--max-sweeps N] [--newton K] [--overlap-correction B]
//                [--rest converged|speed] [--regions R [--region-check K]]
// The defaults are the program's (scan defaults, our stricter rest test); --rest speed is the
// scene's own rest test (disk centre speeds only), which a solve capped by --max-sweeps needs to
// end at all. --newton K: solver.newton_every (0: NNCG alone, docs/MODEL.md, "Solvers").
// --overlap-correction B: solver.overlap_correction (a fraction B of each overlap removed per
// step by moving positions, velocities untouched; docs/MODEL.md).
#include "loosepack/scenes.hpp"

#include <Kokkos_Core.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "bench/options.hpp"
#include "bench/record.hpp"
#include "loosepack/batch.hpp"
#include "loosepack/observables.hpp"
#include "loosepack/region.hpp"
#include "loosepack/scan.hpp"

using namespace loosepack;

namespace {

struct Measure {
  double h_top = 0, h_mean = 0, phi_final = NAN, phi_aux = NAN, max_overlap = 0;
};

Measure measure(const Batch& batch) {
  const auto d = batch.disks(0);
  Measure m;
  // Upper envelope at 1000 evenly spaced x.
  double sum = 0;
  for (int k = 0; k < 1000; ++k) {
    const double x = (k + 0.5) * scenes::kSceneWidth / 1000.0;
    double top = 0;
    for (const auto& a : d) {
      double dx = std::fabs(a.x - x);
      dx = std::min(dx, scenes::kSceneWidth - dx);
      if (dx < 1.0) top = std::max(top, a.y + std::sqrt(1.0 - dx * dx));
    }
    sum += top;
  }
  m.h_mean = sum / 1000.0;
  std::vector<double> y, r;
  for (const auto& q : d) {
    y.push_back(q.y);
    r.push_back(q.radius);
  }
  m.h_top = deposit_top(y, r);
  m.phi_final =
      band_volume_fraction(y, r, scenes::kSceneWidth, 10.0, m.h_mean - 10.0);  // NaN: no band
  m.phi_aux = band_volume_fraction(y, r, scenes::kSceneWidth, 2.0, m.h_mean - 5.0);
  m.max_overlap = batch.max_overlap(0);
  return m;
}

std::string num(double v) {
  if (std::isnan(v)) return "null";
  std::ostringstream o;
  o.precision(10);
  o << v;
  return o.str();
}

RestSettings g_rest;  // --rest; the program's rest test (speeds and a converged solve) otherwise

RestSettings scene_rest(double dt) { return scenes::scene_rest(g_rest, dt); }

SolverSettings g_solver;  // --solver, --tolerance, --max-sweeps; the scan defaults otherwise

double g_region_radius = 0.0;  // --regions R: S1 relaxes each new disk in a region (below)
int g_region_check = 0;        // --region-check K: the whole system after every K-th disk

bool default_settings() {
  const SolverSettings s;
  return g_solver.kind == s.kind && g_solver.tolerance == s.tolerance &&
         g_solver.max_sweeps == s.max_sweeps && g_solver.newton_every == s.newton_every &&
         g_solver.overlap_correction == s.overlap_correction && g_rest.converged &&
         g_region_radius == 0.0;
}

void record(const char* scene, int n, double wall, long steps, const Measure& m, double phi_i,
            double sim_time, int capped, double vmax, double dt) {
  std::printf(
      "{\"engine\": \"loosepack\", \"scene\": \"%s\", \"bc\": \"periodic\", \"N\": %d, "
      "\"wall_s\": %s, \"steps\": %ld, \"per_particle_ms\": %s, \"phi_final\": %s, "
      "\"phi_initial\": %s, \"phi_aux\": %s, \"h_top\": %s, \"h_mean\": %s, \"sim_time\": %s, "
      "\"max_overlap\": %s, \"n_capped\": %d, \"vmax_peak\": %s, \"setting\": \"%s\", "
      "\"params\": {\"dt\": %s, \"solver\": \"%s\", \"tolerance\": %g, \"max_sweeps\": %d, "
      "\"newton_every\": %d, \"overlap_correction\": %s, "
      "\"rest\": \"%s\", \"region_radius\": %s, \"region_check_every\": %d}, "
      "\"notes\": \"contact dynamics, Kokkos %s; %s%s\", %s}\n",
      scene, n, num(wall).c_str(), steps, num(1000.0 * wall / n).c_str(), num(m.phi_final).c_str(),
      num(phi_i).c_str(), num(m.phi_aux).c_str(), num(m.h_top).c_str(), num(m.h_mean).c_str(),
      num(sim_time).c_str(), num(m.max_overlap).c_str(), capped, num(vmax).c_str(),
      default_settings() && dt == 0.01 ? "default" : "custom", num(dt).c_str(),
      solver_kind_name(g_solver.kind), g_solver.tolerance, g_solver.max_sweeps,
      g_solver.newton_every, num(g_solver.overlap_correction).c_str(),
      g_rest.converged ? "converged" : "speed", num(g_region_radius).c_str(), g_region_check,
      Kokkos::DefaultExecutionSpace::name(),
      g_rest.converged ? "rest also needs R|w| < 1e-3 and a converged solve"
                       : "the scene's rest test (centre speeds)",
      g_region_radius > 0.0 && !std::strcmp(scene, "S1")
          ? "; each disk relaxes in a region around it, the rest of the deposit held fixed "
            "(and the whole system relaxes after every region_check_every-th disk)"
          : "",
      bench::Environment().json().c_str());
  std::fflush(stdout);
}

// How the relaxation after one deposit ended.
struct Relaxation {
  long steps = 0;
  bool rested = false;  // by the rest criterion (else cut at the cap)
  bool failed = false;  // the system failed (its status says why)
};

// Relaxes the whole system after a deposit until rest or the cap.
Relaxation relax_whole(Batch& batch, long cap, double& vmax) {
  batch.set_active(0, true);
  Relaxation r;
  for (; r.steps < cap && !batch.status(0).at_rest; ++r.steps) {
    batch.step();
    vmax = std::max(vmax, batch.status(0).max_centre_speed);
    r.failed = batch.status(0).failure != Failure::None;
    if (r.failed) return r;
  }
  r.rested = batch.status(0).at_rest;
  return r;
}

// With --regions R the new disk relaxes in a relaxation region of radius R (docs/MODEL.md,
// "Relaxation regions"); after every --region-check K-th disk (never by default) the whole
// system then relaxes to rest by the ordinary criterion, else the disks outside the region stay
// where they are. A region that outgrows its slot relaxes in the whole system instead.
Relaxation relax_region(Batch& batch, Regions& regions, const Deposit& d, bool check, long cap,
                        double& vmax) {
  if (!regions.begin(batch, 0, {{d.x, d.y}}, g_solver.tolerance))
    return relax_whole(batch, cap, vmax);
  batch.set_active(0, false);
  for (long n = 0; n < cap; ++n) {
    regions.step();
    vmax = std::max(vmax, regions.status(0).max_centre_speed);
    const Regions::State state = regions.poll(batch, 0);
    if (state == Regions::State::Rested && !check) return {n + 1, true, false};
    if (state != Regions::State::Running) {
      Relaxation r = relax_whole(batch, cap - n - 1, vmax);
      r.steps += n + 1;
      return r;
    }
  }
  regions.stop(batch, 0);
  return {cap, false, false};
}

// Each scene returns false (after a message on stderr) when a disk could not be placed or the
// system failed.
bool scene_s1(const std::vector<int>& ns, double dt) {
  const int n_max = *std::max_element(ns.begin(), ns.end());
  SystemSetup su;
  su.params = scenes::s1_params(n_max, dt);
  su.capacity = n_max;
  Batch batch({su}, g_solver, scene_rest(dt));
  std::unique_ptr<Regions> regions;
  if (g_region_radius > 0.0) {
    RegionSettings rs;
    rs.radius = g_region_radius;
    rs.max_disks = ProtocolSettings{}.region_max_disks;
    rs.max_height = region_slot_height(rs.radius, su.params.height);
    regions = std::make_unique<Regions>(1, std::vector<SystemParams>{su.params}, rs, g_solver,
                                        scene_rest(dt));
  }
  scenes::SplitMix64 rng{scenes::kS1Seed};
  const long cap = static_cast<long>(std::ceil(20.0 / dt));
  long steps = 0;
  int capped = 0;
  double vmax = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 1; k <= n_max; ++k) {
    const double x = scenes::kSceneWidth * rng.next();
    const Deposit d = batch.deposit_at({1}, {x}, DropRule::Touch)[0];
    if (!d.placed) {
      std::fprintf(stderr, "S1: disk %d could not be placed below the box height\n", k);
      return false;
    }
    const bool check = g_region_check > 0 && k % g_region_check == 0;
    const Relaxation r = regions ? relax_region(batch, *regions, d, check, cap, vmax)
                                 : relax_whole(batch, cap, vmax);
    if (r.failed) {
      std::fprintf(stderr, "S1: %s\n", failure_message(batch.status(0).failure).c_str());
      return false;
    }
    steps += r.steps;
    capped += r.rested ? 0 : 1;
    if (std::find(ns.begin(), ns.end(), k) != ns.end()) {
      const double wall =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      record("S1", k, wall, steps, measure(batch), NAN, steps * dt, capped, vmax, dt);
    }
  }
  return true;
}

bool scene_s2(int n, double dt) {
  SystemSetup su;
  su.params = scenes::s2_params(n, dt);
  su.capacity = n;
  Batch batch({su}, g_solver, scene_rest(dt));
  scenes::SplitMix64 rng{scenes::kS2Seed};
  for (int k = 0; k < n; ++k)
    if (!batch.deposit_at({1}, {scenes::kSceneWidth * rng.next()}, DropRule::Touch)[0].placed) {
      std::fprintf(stderr, "S2: disk %d could not be placed\n", k + 1);
      return false;
    }
  const Measure before = measure(batch);
  batch.set_gravity(0, true);
  batch.set_active(0, true);
  const long cap = static_cast<long>(std::ceil(3000.0 / dt));
  double vmax = 0;
  long steps = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (; steps < cap && !batch.status(0).at_rest; ++steps) {
    batch.step();
    vmax = std::max(vmax, batch.status(0).max_centre_speed);
    if (batch.status(0).failure != Failure::None) {
      std::fprintf(stderr, "S2, N = %d: %s\n", n, failure_message(batch.status(0).failure).c_str());
      return false;
    }
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  record("S2", n, wall, steps, measure(batch), before.phi_final, steps * dt,
         batch.status(0).at_rest ? 0 : 1, vmax, dt);
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  Kokkos::ScopeGuard kokkos(argc, argv);
  std::string scene = "both";
  std::vector<int> ns = {250, 500, 1000, 2000};
  double dt = 0.01;
  auto usage = [] {
    std::fprintf(stderr,
                 "usage: bench_scenes [--scene S1|S2|both] [--n N1,N2,...] [--dt H] "
                 "[--solver jacobi|gauss_seidel|sequential_gauss_seidel|"
                 "accelerated_gauss_seidel|coloured_accelerated_gauss_seidel] [--tolerance T] "
                 "[--max-sweeps N] [--newton K] [--overlap-correction B] "
                 "[--rest converged|speed] "
                 "[--regions R [--region-check K]]\n");
    return 2;
  };
  for (int k = 1; k < argc; k += 2) {
    if (k + 1 >= argc)  // every option takes a value
      return usage();
    if (!std::strcmp(argv[k], "--scene"))
      scene = argv[k + 1];
    else if (!std::strcmp(argv[k], "--n"))
      ns = bench::parse_list(argv[k + 1]);
    else if (!std::strcmp(argv[k], "--dt"))
      dt = std::atof(argv[k + 1]);
    else if (!std::strcmp(argv[k], "--solver") && solver_kind_from_name(argv[k + 1], g_solver.kind))
      continue;
    else if (!std::strcmp(argv[k], "--tolerance") && std::atof(argv[k + 1]) > 0.0)
      g_solver.tolerance = std::atof(argv[k + 1]);
    else if (!std::strcmp(argv[k], "--max-sweeps") && std::atoi(argv[k + 1]) > 0)
      g_solver.max_sweeps = std::atoi(argv[k + 1]);
    else if (!std::strcmp(argv[k], "--newton") && std::atoi(argv[k + 1]) >= 0)
      g_solver.newton_every = std::atoi(argv[k + 1]);
    else if (!std::strcmp(argv[k], "--overlap-correction") && std::atof(argv[k + 1]) >= 0.0 &&
             std::atof(argv[k + 1]) <= 1.0)
      g_solver.overlap_correction = std::atof(argv[k + 1]);
    else if (!std::strcmp(argv[k], "--regions") && std::atof(argv[k + 1]) > 0.0)
      g_region_radius = std::atof(argv[k + 1]);
    else if (!std::strcmp(argv[k], "--region-check") && std::atoi(argv[k + 1]) > 0)
      g_region_check = std::atoi(argv[k + 1]);
    else if (!std::strcmp(argv[k], "--rest") &&
             (!std::strcmp(argv[k + 1], "speed") || !std::strcmp(argv[k + 1], "converged")))
      g_rest.converged = g_rest.spin = !std::strcmp(argv[k + 1], "converged");
    else
      return usage();
  }
  scenes::SplitMix64 check{scenes::kS1Seed};
  const double x1 = scenes::kSceneWidth * check.next(), x2 = scenes::kSceneWidth * check.next(),
               x3 = scenes::kSceneWidth * check.next();
  if (std::fabs(x1 - 32.516485265275463) > 1e-12 || std::fabs(x2 - 22.957386292461301) > 1e-12 ||
      std::fabs(x3 - 22.83426811397883) > 1e-12) {
    std::fprintf(stderr, "bench_scenes: SplitMix64 check values differ from the scene's\n");
    return 1;
  }
  if (scene != "S1" && scene != "S2" && scene != "both") return usage();
  bool ok = true;
  if (scene == "S1" || scene == "both") ok = scene_s1(ns, dt) && ok;
  if (scene == "S2" || scene == "both")
    for (int n : ns) ok = scene_s2(n, dt) && ok;
  return ok ? 0 : 1;
}
