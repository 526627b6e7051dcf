// Whole-run studies (docs/PERFORMANCE.md), one JSON record per ensemble run on stdout:
//
//   --study effects   the default scene (protocol A, 24 R x 24 R, Bo = 1e2, mu_r = 0.1) and the
//                     collapse scene (protocol C, Bo = 1e3) with and without cohesion (Bo = 0),
//                     rolling friction (mu_r = 0) and gravity (protocol B: ballistic deposition,
//                     no dynamics): the time each effect costs.
//   --study size      time to build one system against its disk count N, four sizes over a
//                     factor of ~8 in N: protocol A in square boxes, protocol C in boxes 48 R tall
//                     of growing width; the fitted exponent of t ~ N^p (least squares on ln t
//                     against ln N).
//   --study accuracy  a reference ensemble (protocol A at Bo = 1e2, protocol C at Bo = 1e3) run
//                     tightly converged, then once per setting of the solver tolerance, sweep
//                     cap, time step, relaxation factor and solver kind: wall time and the error
//                     against the reference in nu_lower_half, in the nu(y) profile (rms), in the
//                     avalanche profile Delta y(y_e) (rms) and the largest overlap of the final
//                     packings. tools/pareto.py draws the Pareto plot from these records.
//   --study cost      the time per member of protocols A (Bond numbers 0 to 1e3, two sizes), C
//                     and B against expected_cost, the a-priori cost that the progress ETA and
//                     the sharding over MPI ranks use: seconds per unit of each, and the spread
//                     of that ratio over the scenes (how far off the model is).
//
// Every member of an ensemble is keyed by (scan seed, member id), so all settings deposit the
// same sequence of drop abscissae; the deposits still differ once the dynamics differ (the
// packing is chaotic), so an error is only resolved where it exceeds the statistical noise
// that each record states (`*_noise`: the standard errors of both ensembles combined).
//
//   bench_study --study effects|size|accuracy|cost [--tiny] [--seeds N] [--budget S]
//               [--protocol A|C] [--match TEXT] [--sides S1,S2,...]
//               [--regions R [--region-check K]] [--newton K] [--overlap-correction B]
// --newton: solver.newton_every of every ensemble (0: NNCG alone; docs/MODEL.md, "Solvers");
// unset, each ensemble's default at its Bond number, as the program's. --overlap-correction:
// solver.overlap_correction of every ensemble (default 0: overlaps held as they are).
// --sides: the box sides (A) or widths (C) of the size study; --regions: every ensemble's
// protocol-A members relax in relaxation regions of radius R, the whole system checked after
// every K-th disk (protocol.region_radius, region_check_every; docs/MODEL.md).
// --match: the accuracy study runs only the settings whose label contains TEXT (after the
// reference and the default, which every run has). With --tiny (the CI runs) a failed member
// makes the program exit 1.
#include <Kokkos_Core.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "bench/options.hpp"
#include "bench/record.hpp"
#include "loosepack/analysis.hpp"
#include "loosepack/observables.hpp"
#include "loosepack/protocols.hpp"

using namespace loosepack;

namespace {

// The time step a scan gives a point of Bond number bo (SystemParams::default_time_step).
double step_at(double bo) {
  SystemParams p;
  p.bond_number = bo;
  return p.default_time_step();
}

// One ensemble: protocol, geometry, physics and solver.
struct Setup {
  std::string label = "default";
  std::string protocol = "A";
  double width = 24.0, height = 24.0, bond_number = 1e2, capture_radius = 1.0;
  // The program's defaults (params.hpp); the time step is a scan's at this Bond number (0.009).
  double rolling_friction = SystemParams{}.rolling_friction, time_step = step_at(bond_number);
  double tolerance = default_tolerance(Protocol::A), relaxation = SolverSettings{}.relaxation;
  double relative_tolerance = SolverSettings{}.relative_tolerance;
  double overlap_correction = SolverSettings{}.overlap_correction;
  int max_sweeps = 0;  // 0: the protocol's default for the box (default_max_sweeps)
  int newton_every = -1;  // -1: the program's default at this Bond number (default_newton_every)
  bool rest_converged = RestSettings{}.converged;
  double region_radius = 0.0;  // protocol.region_radius; 0: the whole system relaxes
  int region_check_every = ProtocolSettings{}.region_check_every;
  std::string solver = solver_kind_name(SolverSettings{}.kind);
  int seeds = 16;

  // Protocol C at Bo = 1e3 with the time step of the documented rule h = 0.9 sqrt(2 m_n d_c /
  // F_c) (docs/MODEL.md; the examples' 0.0028). A deposit this small collapses visibly only
  // when loose: capture radius 2 (dnu/nu_i ~ 0.17; at r_capt = 1 and H = 24 nothing moves).
  static Setup collapse() {
    Setup s;
    s.protocol = "C";
    s.height = 40.0;
    s.bond_number = 1e3;
    s.capture_radius = 2.0;
    s.time_step = 0.0028;
    s.tolerance = default_tolerance(Protocol::C);
    s.seeds = 8;
    return s;
  }
  // A copy with another label and one change.
  template <class Change>
  Setup variant(const std::string& new_label, Change change) const {
    Setup s = *this;
    s.label = new_label;
    change(s);
    return s;
  }
  // The sweep cap the ensemble runs with.
  int cap() const {
    return max_sweeps > 0 ? max_sweeps : bench::default_cap(protocol, width, height);
  }
  int rounds() const {
    SystemParams p;
    p.bond_number = bond_number;
    return newton_every >= 0 ? newton_every : default_newton_every(p);
  }

  std::string toml() const {
    std::ostringstream o;
    o.precision(17);
    o << "[scan]\nname = \"bench_study\"\nseed = 2026\nseeds = " << seeds << "\nprotocol = \""
      << protocol << "\"\nbatch_size = " << seeds << "\n[system]\nwidth = " << width
      << "\nheight = " << height << "\nbond_number = " << bond_number
      << "\ncapture_radius = " << capture_radius
      << "\nfriction = 0.3\nrolling_friction = " << rolling_friction
      << "\ncohesion_range = 0.01\ntime_step = " << time_step << "\n[solver]\nkind = \"" << solver
      << "\"\ntolerance = " << tolerance << "\nrelative_tolerance = " << relative_tolerance
      << "\noverlap_correction = " << overlap_correction << "\nmax_sweeps = " << cap()
      << "\nrelaxation = " << relaxation << "\nnewton_every = " << rounds()
      << "\n[rest]\nconverged = " << (rest_converged ? "true" : "false")
      << "\n[protocol]\nregion_radius = " << region_radius
      << "\nregion_check_every = " << region_check_every
      << "\n[observables]\nlower_half_from = " << std::min(4.0, height / 4.0)
      << "\nstrip_width = 3.97\nbin_width = 4.0\n";
    return o.str();
  }
  std::string json() const {
    std::ostringstream o;
    o << "\"setup\": {\"label\": " << bench::json_string(label)
      << ", \"protocol\": " << bench::json_string(protocol)
      << ", \"width\": " << bench::json_number(width)
      << ", \"height\": " << bench::json_number(height)
      << ", \"bond_number\": " << bench::json_number(bond_number)
      << ", \"capture_radius\": " << bench::json_number(capture_radius)
      << ", \"friction\": 0.3, \"rolling_friction\": " << bench::json_number(rolling_friction)
      << ", \"time_step\": " << bench::json_number(time_step)
      << ", \"solver\": " << bench::json_string(solver)
      << ", \"tolerance\": " << bench::json_number(tolerance)
      << ", \"relative_tolerance\": " << bench::json_number(relative_tolerance)
      << ", \"overlap_correction\": " << bench::json_number(overlap_correction)
      << ", \"max_sweeps\": " << cap() << ", \"relaxation\": " << bench::json_number(relaxation)
      << ", \"newton_every\": " << rounds()
      << ", \"rest_converged\": " << (rest_converged ? "true" : "false")
      << ", \"region_radius\": " << bench::json_number(region_radius)
      << ", \"region_check_every\": " << region_check_every << ", \"seeds\": " << seeds << "}";
    return o.str();
  }
};

// What one ensemble run gave.
struct Outcome {
  double wall = 0.0, core_share = 0.0, max_overlap = 0.0;
  long disks = 0, steps = 0, sweeps = 0;
  int members = 0, failed = 0, capped = 0;
  bool over_budget = false;  // stopped at the time budget: the figures are incomplete
  PointResult point;
};

volatile std::sig_atomic_t stop_flag = 0;

// Largest overlap of a final packing [R]: disk pairs (periodic in x) and the floor.
double max_overlap(const MemberResult& m, double width) {
  double worst = 0.0;
  const std::size_t n = m.x.size();
  for (std::size_t i = 0; i < n; ++i) {
    worst = std::max(worst, m.radius[i] - m.y_e[i]);
    for (std::size_t j = i + 1; j < n; ++j) {
      double dx = m.x[j] - m.x[i];
      dx -= width * std::round(dx / width);
      const double dy = m.y_e[j] - m.y_e[i];
      const double reach = m.radius[i] + m.radius[j];
      if (std::abs(dy) >= reach || std::abs(dx) >= reach) continue;
      worst = std::max(worst, reach - std::sqrt(dx * dx + dy * dy));
    }
  }
  return worst;
}

int failed_members = 0;  // over every run; a --tiny run exits 1 when one failed (a CI check)

Outcome run(const Setup& s, double budget_s) {
  const Scan scan = parse_scan(s.toml(), "bench_study.toml");
  const std::vector<Member> members = members_of(scan);
  stop_flag = 0;
  RunHooks hooks;
  const auto t0 = std::chrono::steady_clock::now();
  hooks.progress = [&](const Progress&) {
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > budget_s)
      stop_flag = 1;
  };
  hooks.stop = &stop_flag;
  const double cpu0 = bench::process_cpu_seconds();
  const std::vector<MemberResult> results = run_members(scan, members, hooks);
  Outcome o;
  o.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  o.core_share = (bench::process_cpu_seconds() - cpu0) / o.wall;
  o.over_budget = results.size() < members.size();
  for (const auto& m : results) {
    ++o.members;
    o.disks += static_cast<long>(m.x.size());
    o.steps += m.steps;
    o.sweeps += m.sweeps;
    o.failed += m.ok() ? 0 : 1;
    o.capped += m.capped;
    if (m.ok()) o.max_overlap = std::max(o.max_overlap, max_overlap(m, m.member.params.width));
  }
  if (!results.empty()) o.point = aggregate(scan, results).front();
  failed_members += o.failed;
  return o;
}

std::string outcome_json(const Outcome& o) {
  std::ostringstream f;
  f << "\"wall_s\": " << bench::json_number(o.wall)
    << ", \"core_share\": " << bench::json_number(o.core_share)
    << ", \"over_budget\": " << (o.over_budget ? "true" : "false") << ", \"members\": " << o.members
    << ", \"failed\": " << o.failed << ", \"capped\": " << o.capped << ", \"disks\": " << o.disks
    << ", \"steps\": " << o.steps << ", \"sweeps\": " << o.sweeps
    << ", \"wall_per_member_s\": " << bench::json_number(o.wall / std::max(1, o.members))
    << ", \"disks_per_member\": "
    << bench::json_number(static_cast<double>(o.disks) / std::max(1, o.members))
    << ", \"disks_per_s\": " << bench::json_number(static_cast<double>(o.disks) / o.wall)
    << ", \"nu_lower_half\": " << bench::json_number(o.point.nu_lower_half.mean)
    << ", \"nu_lower_half_sem\": " << bench::json_number(o.point.nu_lower_half.sem)
    << ", \"max_overlap\": " << bench::json_number(o.max_overlap);
  if (o.point.point.protocol == Protocol::C)
    f << ", \"relative_increase\": " << bench::json_number(o.point.relative_increase.mean)
      << ", \"relative_increase_sem\": " << bench::json_number(o.point.relative_increase.sem);
  return f.str();
}

void print(const std::string& study, const Setup& s, const std::string& fields) {
  std::printf("{\"study\": \"%s\", %s, %s, %s}\n", study.c_str(),
              bench::Environment().json().c_str(), s.json().c_str(), fields.c_str());
  std::fflush(stdout);
}

// Root mean square of a - b over the entries where both are finite and keep(k) holds, and of
// the combined standard errors there (the noise level of that difference).
template <class Keep>
std::pair<double, double> rms_difference(const std::vector<double>& a,
                                         const std::vector<double>& a_sem,
                                         const std::vector<double>& b,
                                         const std::vector<double>& b_sem, Keep keep) {
  double s = 0.0, noise = 0.0;
  int n = 0;
  for (std::size_t k = 0; k < a.size() && k < b.size(); ++k) {
    if (!keep(k) || !std::isfinite(a[k]) || !std::isfinite(b[k])) continue;
    s += (a[k] - b[k]) * (a[k] - b[k]);
    const double ea = k < a_sem.size() && std::isfinite(a_sem[k]) ? a_sem[k] : 0.0;
    const double eb = k < b_sem.size() && std::isfinite(b_sem[k]) ? b_sem[k] : 0.0;
    noise += ea * ea + eb * eb;
    ++n;
  }
  if (n == 0) return {NAN, NAN};
  return {std::sqrt(s / n), std::sqrt(noise / n)};
}

// The errors of a run against the reference (see the header).
std::string error_json(const Setup& s, const Outcome& o, const Outcome& ref) {
  const PointResult &p = o.point, &r = ref.point;
  const double lower = std::min(4.0, s.height / 4.0);
  // nu(y): strips between lower_half_from and 4 R below H (the rough top excluded).
  auto in_bulk = [&](std::size_t k) {
    return k < r.nu.centre.size() && r.nu.centre[k] > lower && r.nu.centre[k] < s.height - 4.0;
  };
  const auto nu = rms_difference(p.nu.mean, p.nu.sem, r.nu.mean, r.nu.sem, in_bulk);
  // Delta y(y_e): every bin holding samples in both runs.
  auto has_samples = [&](std::size_t k) {
    return k < p.dy_by_ye.count.size() && k < r.dy_by_ye.count.size() && p.dy_by_ye.count[k] > 0 &&
           r.dy_by_ye.count[k] > 0;
  };
  const auto dy =
      rms_difference(p.dy_by_ye.mean, p.dy_by_ye.sem, r.dy_by_ye.mean, r.dy_by_ye.sem, has_samples);
  std::ostringstream f;
  f << "\"reference_wall_s\": " << bench::json_number(ref.wall) << ", \"error_nu_lower_half\": "
    << bench::json_number(std::abs(p.nu_lower_half.mean - r.nu_lower_half.mean))
    << ", \"error_nu_lower_half_noise\": "
    << bench::json_number(std::hypot(p.nu_lower_half.sem, r.nu_lower_half.sem))
    << ", \"error_nu_profile_rms\": " << bench::json_number(nu.first)
    << ", \"error_nu_profile_noise\": " << bench::json_number(nu.second)
    << ", \"error_avalanche_rms\": " << bench::json_number(dy.first)
    << ", \"error_avalanche_noise\": " << bench::json_number(dy.second);
  return f.str();
}

// The settings of the accuracy study around a protocol's defaults.
std::vector<Setup> accuracy_settings(const Setup& base) {
  std::vector<Setup> v;
  auto add = [&](const std::string& label, auto change) {
    v.push_back(base.variant(label, change));
  };
  add("default", [](Setup&) {});
  // Two half-decade steps either side of the protocol's default tolerance.
  const std::vector<double> grid = {3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5};
  std::size_t at = 0;
  for (std::size_t k = 1; k < grid.size(); ++k)
    if (std::abs(std::log(grid[k] / base.tolerance)) <
        std::abs(std::log(grid[at] / base.tolerance)))
      at = k;
  for (std::size_t k = at >= 2 ? at - 2 : 0; k <= std::min(at + 2, grid.size() - 1); ++k) {
    const double t = grid[k];
    if (k != at) add("tolerance=" + bench::json_number(t), [t](Setup& s) { s.tolerance = t; });
  }
  for (double k : {0.0, 1e-4, 3e-4, 1e-3, 3e-3})
    if (k != base.relative_tolerance)
      add("relative_tolerance=" + bench::json_number(k),
          [k](Setup& s) { s.relative_tolerance = k; });
  for (int c : {100, 300, 1000, 2000, 5000})
    if (c != base.cap())
      add("max_sweeps=" + std::to_string(c), [c](Setup& s) { s.max_sweeps = c; });
  for (double f : {2.0, 0.5})
    add("time_step=" + bench::json_number(base.time_step * f), [f](Setup& s) { s.time_step *= f; });
  for (double w : {0.6, 0.8, 1.0, 1.2, 1.5})
    if (w != base.relaxation)
      add("relaxation=" + bench::json_number(w), [w](Setup& s) { s.relaxation = w; });
  for (const char* k : {"sequential_gauss_seidel", "gauss_seidel", "jacobi"})
    add(std::string("solver=") + k, [k](Setup& s) { s.solver = k; });
  // The Newton rounds the other way than the default at this Bond number.
  const int other_rounds = base.rounds() > 0 ? 0 : SolverSettings{}.newton_every;
  add("newton_every=" + std::to_string(other_rounds),
      [other_rounds](Setup& s) { s.newton_every = other_rounds; });
  // Rest by speeds alone, the solve capped as a fixed-iteration engine caps it.
  for (int c : {16, 64, 2000})
    add("rest=speed max_sweeps=" + std::to_string(c), [c](Setup& s) {
      s.rest_converged = false;
      s.max_sweeps = c;
    });
  // The default again, last: its two wall times give the run-to-run timing noise.
  add("default (repeat)", [](Setup&) {});
  return v;
}

void accuracy(const Setup& base, double budget_s, const std::string& match) {
  Setup ref = base;
  ref.label = "reference";
  ref.tolerance = 1e-5;
  ref.relative_tolerance = 0.0;
  ref.max_sweeps = 20000;
  ref.time_step = base.time_step / 2.0;
  const Outcome r = run(ref, 1e30);
  print("accuracy_reference", ref, outcome_json(r));
  for (const Setup& s : accuracy_settings(base)) {
    // The default and its repeat (the timing noise) run whatever --match selects.
    if (!match.empty() && s.label.rfind("default", 0) != 0 &&
        s.label.find(match) == std::string::npos)
      continue;
    const Outcome o = run(s, budget_s);
    print("accuracy", s, outcome_json(o) + ", " + error_json(s, o, r));
  }
}

void effects(const Setup& base, double budget_s) {
  const std::vector<Setup> v = {
      base.variant("all effects", [](Setup&) {}),
      base.variant("no cohesion", [](Setup& s) { s.bond_number = 0.0; }),
      base.variant("no rolling friction", [](Setup& s) { s.rolling_friction = 0.0; }),
      base.variant("no gravity (ballistic deposition)", [](Setup& s) { s.protocol = "B"; })};
  double t_all = NAN;
  for (const Setup& s : v) {
    const Outcome o = run(s, budget_s);
    if (s.label == "all effects") t_all = o.wall;
    print(
        "effects", s,
        outcome_json(o) + ", \"time_saved_fraction\": " + bench::json_number(1.0 - o.wall / t_all));
  }
}

// Protocol A: square systems of side L. Protocol C: widths L at the base height, because a
// small deposit does not collapse at all (below H ~ 40 R nothing moves: the cost would jump
// from nothing to a collapse rather than scale).
void size(Setup base, const std::vector<double>& sides, double budget_s) {
  std::vector<double> n, t;
  for (double side : sides) {
    const bool square = base.protocol == "A";
    const Setup s =
        base.variant((square ? "side=" : "width=") + bench::json_number(side), [&](Setup& v) {
          v.width = side;
          if (square) v.height = side;
        });
    const Outcome o = run(s, budget_s);
    const double disks = static_cast<double>(o.disks) / std::max(1, o.members);
    const double per = o.wall / std::max(1, o.members);
    print("size", s, outcome_json(o) + ", \"time_per_system_s\": " + bench::json_number(per));
    if (!o.over_budget && o.members > 0) {
      n.push_back(disks);
      t.push_back(per);
    }
  }
  const Fit f = power_law_fit(n, t, {});
  std::ostringstream o;
  o << "\"points\": " << n.size()
    << ", \"exponent\": " << bench::json_number(f.valid() ? f.coef[1] : NAN)
    << ", \"exponent_error\": " << bench::json_number(f.valid() ? f.error[1] : NAN)
    << ", \"prefactor_s\": " << bench::json_number(f.valid() ? std::exp(f.coef[0]) : NAN)
    << ", \"n_min\": " << bench::json_number(n.empty() ? NAN : n.front())
    << ", \"n_max\": " << bench::json_number(n.empty() ? NAN : n.back());
  base.label = "fit";
  print("size_fit", base, o.str());
}

// expected_cost against the measured time per member over scenes that span what a scan may hold:
// protocol A from cohesionless to Bo = 1e3 (each with the examples' time step), A's box made
// wider and taller, C's collapse at r_capt = 1 and 2, ballistic deposition in a small box and at
// the paper's size. Times are CPU seconds of this process (wall x core share), so a run beside
// other work measures the same.
void cost(double budget_s, bool tiny, int seeds) {
  const Setup a = Setup().variant("", [&](Setup& s) { s.seeds = seeds > 0 ? seeds : 2; });
  std::vector<Setup> v;
  for (double bo : {0.0, 1.0, 10.0, 100.0, 1000.0})
    v.push_back(a.variant("A Bo=" + bench::json_number(bo), [&](Setup& s) {
      s.bond_number = bo;
      s.time_step = bo < 50.0 ? 0.01 : (bo < 500.0 ? 0.009 : 0.0028);
    }));
  if (!tiny) {
    v.push_back(v[0].variant("A Bo=0 twice as wide", [](Setup& s) { s.width *= 2.0; }));
    v.push_back(v[0].variant("A Bo=0 twice as tall", [](Setup& s) { s.height *= 2.0; }));
    v.push_back(
        v[4].variant("A Bo=1000 taller, wider", [](Setup& s) { s.width = 40.0, s.height = 60.0; }));
  }
  Setup c = Setup::collapse();
  c.seeds = a.seeds;
  v.push_back(c.variant("C r_capt=2", [](Setup& s) { s.width = s.height = 48.0; }));
  if (!tiny)
    v.push_back(c.variant(
        "C r_capt=1", [](Setup& s) { s.width = 40.0, s.height = 60.0, s.capture_radius = 1.0; }));
  v.push_back(a.variant("B", [](Setup& s) { s.protocol = "B", s.width = s.height = 48.0; }));
  if (!tiny)
    v.push_back(
        v.back().variant("B paper size", [](Setup& s) { s.width = 200.0, s.height = 800.0; }));
  std::vector<double> ratios;
  for (Setup s : v) {
    if (tiny) s.width = s.height = 8.0;
    const Outcome o = run(s, budget_s);
    const Scan scan = parse_scan(s.toml(), "bench_study.toml");
    const double expected = expected_cost(members_of(scan).front());
    const double per = o.wall * o.core_share / std::max(1, o.members);
    const double ratio = per / expected;
    if (!o.over_budget && o.members > 0 && ratio > 0.0) ratios.push_back(ratio);
    print("cost", s,
          outcome_json(o) + ", \"cpu_per_member_s\": " + bench::json_number(per) +
              ", \"expected_cost\": " + bench::json_number(expected) +
              ", \"seconds_per_unit\": " + bench::json_number(ratio));
  }
  // The spread as a factor: largest over smallest seconds per unit, and the geometric mean.
  double log_sum = 0.0;
  for (double r : ratios) log_sum += std::log(r);
  const auto mm = std::minmax_element(ratios.begin(), ratios.end());
  std::ostringstream o;
  o << "\"scenes\": " << ratios.size() << ", \"seconds_per_unit_geometric_mean\": "
    << bench::json_number(ratios.empty() ? NAN : std::exp(log_sum / ratios.size()))
    << ", \"spread_factor\": " << bench::json_number(ratios.empty() ? NAN : *mm.second / *mm.first);
  print("cost_summary", a.variant("summary", [](Setup&) {}), o.str());
}

int usage() {
  std::fprintf(stderr,
               "usage: bench_study --study effects|size|accuracy|cost [--tiny] [--seeds N] "
               "[--budget S] [--protocol A|C] [--match TEXT] [--sides S1,S2,...] "
               "[--regions R [--region-check K]] [--newton K] [--overlap-correction B]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  Kokkos::ScopeGuard kokkos(argc, argv);
  std::string study, protocol, match;
  std::vector<int> sides_given;
  double region_radius = 0.0;
  int newton_every = -1;  // --newton; -1: by Bond number, as the program
  double overlap_correction = SolverSettings{}.overlap_correction;
  int region_check = ProtocolSettings{}.region_check_every;
  bool tiny = false;
  int seeds = 0;
  double budget_s = 600.0;  // per ensemble run of a setting
  for (int a = 1; a < argc; ++a) {
    const std::string f = argv[a];
    const bool has_value = a + 1 < argc;
    if (f == "--study" && has_value) {
      study = argv[++a];
    } else if (f == "--tiny") {
      tiny = true;
    } else if (f == "--seeds" && has_value) {
      seeds = std::atoi(argv[++a]);
    } else if (f == "--budget" && has_value) {
      budget_s = std::atof(argv[++a]);
    } else if (f == "--sides" && has_value) {
      sides_given = bench::parse_list(argv[++a]);
    } else if (f == "--regions" && has_value) {
      region_radius = std::atof(argv[++a]);
    } else if (f == "--region-check" && has_value) {
      region_check = std::atoi(argv[++a]);
    } else if (f == "--newton" && has_value) {
      newton_every = std::atoi(argv[++a]);
    } else if (f == "--overlap-correction" && has_value) {
      overlap_correction = std::atof(argv[++a]);
    } else if (f == "--match" && has_value) {
      match = argv[++a];
    } else if (f == "--protocol" && has_value) {
      protocol = argv[++a];
    } else {
      return usage();
    }
  }
  if (study != "effects" && study != "size" && study != "accuracy" && study != "cost")
    return usage();
  if (!protocol.empty() && protocol != "A" && protocol != "C") return usage();
  auto bases = [&]() {
    std::vector<Setup> b;
    if (protocol != "C") b.push_back(Setup());
    if (protocol != "A") b.push_back(Setup::collapse());
    for (Setup& s : b) {
      if (tiny) s.width = s.height = 8.0;
      s.seeds = seeds > 0 ? seeds : (tiny ? 2 : s.seeds);
      s.region_radius = region_radius;
      s.region_check_every = region_check;
      s.newton_every = newton_every;
      s.overlap_correction = overlap_correction;
    }
    return b;
  };
  try {
    if (study == "cost") {
      cost(budget_s, tiny, seeds);
      return 0;
    }
    for (Setup base : bases()) {
      if (study == "effects") {
        effects(base, budget_s);
      } else if (study == "accuracy") {
        accuracy(base, budget_s, match);
      } else {
        if (seeds <= 0) base.seeds = base.protocol == "A" ? 2 : 4;
        if (base.protocol == "C" && !tiny) base.height = 48.0;
        std::vector<double> sides =
            tiny ? std::vector<double>{6.0, 8.0}
                 : (base.protocol == "A" ? std::vector<double>{16.0, 23.0, 32.0, 46.0}
                                         : std::vector<double>{12.0, 24.0, 48.0, 144.0});
        if (!sides_given.empty()) sides.assign(sides_given.begin(), sides_given.end());
        size(base, sides, budget_s);
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_study: %s\n", e.what());
    return 1;
  }
  if (tiny && failed_members > 0) {
    std::fprintf(stderr, "bench_study: %d member(s) failed (their records say which)\n",
                 failed_members);
    return 1;
  }
  return 0;
}
