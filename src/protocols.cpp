// The members of a scan, what each is expected to cost (progress estimates, MPI sharding) and
// their slots' capacity. How they run: src/member_run.hpp (the slot scheduler in
// src/scheduler.cpp, the protocols' phases in src/phases.cpp).
#include "loosepack/protocols.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "loosepack/geometry.hpp"
#include "member_run.hpp"

namespace loosepack {

std::vector<Member> members_of(const Scan& scan) {
  std::vector<Member> out;
  for (const auto& pt : scan.points)
    for (int k = 0; k < scan.seeds; ++k) {
      Member m;
      m.point = pt.index;
      m.seed_index = k;
      m.id = static_cast<std::uint64_t>(pt.index) * static_cast<std::uint64_t>(scan.seeds) +
             static_cast<std::uint64_t>(k);
      m.protocol = pt.protocol;
      m.params = pt.params;
      m.in_regions = pt.protocol == Protocol::A && scan.protocol.region_radius > 0.0;
      out.push_back(m);
    }
  return out;
}

int member_capacity(const SystemParams& p) {
  // Hexagonal packing (0.9069) of the smallest radius, plus a row.
  const double rmin = smallest_radius(p);
  const double area = p.width * (p.height + 2.0 * rmin);
  return static_cast<int>(std::ceil(0.9069 * area / (M_PI * rmin * rmin))) + 8;
}

namespace {

// The parts of expected_cost, in units of kSecondsPerCostUnit (docs/PERFORMANCE.md, "What a
// member costs").
// Ballistic deposition: each disk looks for its landing place among all the disks of its system
// (kernels/deposit.hpp), so a box of W H costs ~ (W H)^2 beyond a cost per disk. 1 000 R^2: one
// core's CPU per member of protocol B at r_capt = 1, 0.5 ms at 48 R x 48 R and 1.07 s at 200 R x
// 800 R (bench/results/cost-relative-2026-12-03.jsonl). `filled`: the share of H deposited.
double ballistic_cost(const SystemParams& p, double filled = 1.0) {
  const double area = p.width * p.height * filled;
  return area * (1.0 + area / 1000.0);
}
// Cohesion shortens the relaxation after each deposit, and with it a member's CPU time at the same
// box and time step: (1 + Bo/4)^-0.7 is the exponent that makes the CPU seconds per unit of the
// recorded protocol-A scenes most alike (spread 3.1 against 7.1 with the -0.55 of the simulated
// time per disk alone; bench/results/cost-relative-2026-11-25.jsonl, docs/PERFORMANCE.md "What a
// member costs").
double relaxation_time(const SystemParams& p) { return std::pow(1.0 + p.bond_number / 4.0, -0.7); }
// Above Bo = 1e3 a deposit too low to avalanche relaxes faster than tau says: a landed disk sticks
// where it lands, and nearly nothing moves once the cohesion is three times Bo = 1e3's; what is
// left are the steps that find each disk at rest, 0.16 of tau's cost in the whole system (each
// step covers the deposit) and 0.03 in regions (each covers a region), reached as (Bo/1e3)^-2 and
// (Bo/1e3)^-3. A taller deposit avalanches again, from a height that grows with the cohesion: the
// factor returns to 1, geometrically in the height, between 120 R and 400 R at Bo = 1e4, heights
// that scale like (Bo/1e4)^0.5 (66 R and 219 R at Bo = 3e3). Set from members of the present
// program 40 R wide, 60 R to 180 R tall, at Bo = 3e3 to 1e5
// (bench/results/cost-bond-held-2026-12-07.jsonl, and relative-tolerance-step-2026-12-07.jsonl's
// held line for the whole system) and 400 R tall at Bo = 1e4 (claims-bo1e4-2026-12-07.jsonl, second
// line): docs/PERFORMANCE.md, "What a member costs".
double fewer_avalanches(const SystemParams& p, bool in_regions, double height) {
  if (p.bond_number <= 1e3) return 1.0;
  const double fewer = in_regions ? std::max(std::pow(p.bond_number / 1e3, -3.0), 0.03)
                                  : std::max(std::pow(p.bond_number / 1e3, -2.0), 0.16);
  const double scale = std::sqrt(p.bond_number / 1e4);
  const double low = 120.0 * scale, high = 400.0 * scale;
  if (height >= high) return 1.0;
  if (height <= low) return fewer;
  return std::pow(fewer, std::log(high / height) / std::log(high / low));
}
// The value at p's Bond number of a table over log10(Bo): linear between its points, the end
// values beyond them (Bo = 0 takes the first).
template <int n>
double interpolated_in_log_bond(const SystemParams& p, const double (&log_bond)[n],
                                const double (&value)[n]) {
  const double x = p.bond_number > 0.0 ? std::log10(p.bond_number) : log_bond[0];
  if (x <= log_bond[0]) return value[0];
  for (int k = 1; k < n; ++k)
    if (x <= log_bond[k])
      return value[k - 1] +
             (value[k] - value[k - 1]) * (x - log_bond[k - 1]) / (log_bond[k] - log_bond[k - 1]);
  return value[n - 1];
}
// How the cost grows with the height, below and above the reference height of 60 R (the boxes
// tau was fitted on were 60 R tall or less, so the cost is W^2/30 H^3 tau / h at 60 R). Up to
// 60 R a deposit H tall costs ~ H^q: a disk rolls over a surface that grows with the deposit, and
// the avalanches of a cohesive deposit grow with the height above them, so q grows with the Bond
// number: from members' progress over time, 2.2-2.6 at Bo <= 10, 2.8-3.2 at Bo = 1e2 and 3.6-5.4
// at Bo = 1e3 (docs/PERFORMANCE.md, "What a member costs"). Relaxation regions keep most
// relaxations local: there members grow like H^3 at most (q(1e2)).
double height_exponent(const SystemParams& p, bool in_regions) {
  const double q = 2.5 + 2.0 * p.bond_number / (p.bond_number + 300.0);
  return in_regions ? std::min(q, 3.0) : q;
}
// Above 60 R, measured on members 40 R wide from 60 R to 180-800 R tall (docs/PERFORMANCE.md,
// "What a member costs", gives the points; tests/python/test_cost_model.py checks them within a
// factor of 2): the whole system grows like H^3.7 at every Bond number from 0 to 1e3 (3.4 to 3.8
// each), faster than the smaller boxes did below Bo = 1e3; in regions like H^2.3 at Bo <= 1
// (H^2.2 at Bo = 0, H^2.5 at 1: a landed disk rolls into place and its region holds all that
// moves), H^2.9 at 10, H^3.5 at 1e2, H^3.6 at 3e2 and H^3.0 at 1e3 (at Bo = 1e2 and 3e2 a landed
// disk rolls further and its regions grow larger; at 1e3 it sticks where it lands), linear in
// log10(Bo) between those and constant beyond them.
double tall_height_exponent(const SystemParams& p, bool in_regions) {
  if (!in_regions) return 3.7;
  const double log_bond[] = {0.0, 1.0, 2.0, std::log10(300.0), 3.0};
  constexpr double q[] = {2.3, 2.9, 3.5, 3.6, 3.0};
  return interpolated_in_log_bond(p, log_bond, q);
}
// Below Bo = 1e2 regions cost less than the whole system already at 60 R, where a member's cost
// is the whole system's (tau was fitted on whole-system scenes): 0.41 of it at Bo = 0 and 1, 0.62
// at 10 (each member's relaxation stays in its region, where a step of the whole system covers
// the deposit). The level: 0.4 at Bo <= 1, 1 from Bo = 1e2 on, linear in log10(Bo) between
// (bench/results/cost-regions-low-bond-2026-12-07.jsonl and cost-heights-2026-12-07.jsonl).
double region_level(const SystemParams& p, bool in_regions) {
  if (!in_regions) return 1.0;
  const double log_bond[] = {0.0, 2.0};
  constexpr double level[] = {0.4, 1.0};
  return interpolated_in_log_bond(p, log_bond, level);
}
// The cost of a deposit `height` tall relative to one of 60 R: (height / 60)^q below, and the
// tall exponent above.
constexpr double kReferenceHeight = 60.0;
double height_cost(const SystemParams& p, bool in_regions, double height) {
  const double x = height / kReferenceHeight;
  return std::pow(x,
                  x <= 1.0 ? height_exponent(p, in_regions) : tall_height_exponent(p, in_regions));
}
// How the cost grows with the width: W^2. A box twice as wide holds twice the disks, and each of
// its steps costs twice as much, since a step builds the grid and contacts of the whole deposit:
// twice as wide cost 3.0x at Bo = 0 (24 R -> 48 R), five times as wide 34x at Bo = 1e3 (40 R ->
// 200 R, 120 R tall), where W alone says 2x and 5x. 30 R: the middle of the widths tau was
// fitted on (24 R to 48 R).
double width_cost(const SystemParams& p) {
  const double reference_width = 30.0;
  return p.width * p.width / reference_width;
}
// `filled`: the share of H deposited.
double slow_cost(const SystemParams& p, bool in_regions, double filled = 1.0) {
  const double height = filled * p.height;
  return width_cost(p) * std::pow(kReferenceHeight, 3.0) * height_cost(p, in_regions, height) *
         region_level(p, in_regions) * relaxation_time(p) *
         fewer_avalanches(p, in_regions, height) / p.time_step;
}
// A collapse: its steps grow like sqrt(H) / h (the column's fall), each steps the W H deposit,
// and a taller column takes more sweeps a step: W H^2 / h. 0.25 (the collapse scenes' seconds per
// unit were a fourth of the protocol-A scenes', bench/results/cost-relative-2026-11-25.jsonl)
// prices the 200 R x 200 R collapses of r_capt = 2 within 6 %. Taller columns cost more than
// H^2, (H / 200)^0.4, and a denser deposit (a smaller capture radius) holds more disks and
// contacts and takes more sweeps, (2 / r_capt)^1.3: the least-squares fit (in log) to the
// recorded collapses from 40 R x 60 R to 200 R x 800 R and r_capt = 1 to 3, each point's
// members' CPU within 0.81-1.64 of it, and within 0.65-3.1 of H^2 (2 / r_capt) alone
// (docs/PERFORMANCE.md, "What a member costs"; tests/python/test_cost_model.py checks the 200 R
// wide points).
double collapse_cost(const SystemParams& p) {
  return 0.25 * p.width * p.height * p.height / p.time_step * std::pow(p.height / 200.0, 0.4) *
         std::pow(2.0 / p.capture_radius, 1.3);
}

// The cost model was fitted on disks of radius 1: a system of radius r is that system scaled,
// its box W/r x H/r radii and its time step h / sqrt(r) (units of sqrt(R/g)).
SystemParams in_radii(const SystemParams& p) {
  SystemParams q = p;
  q.width = p.width / p.radius;
  q.height = p.height / p.radius;
  q.time_step = p.time_step / std::sqrt(p.radius);
  return q;
}

}  // namespace

bool deposits_ballistically(const Member& m) {
  return m.protocol != Protocol::A || std::isinf(m.params.bond_number);
}

double expected_cost(const Member& m) {
  const SystemParams p = in_radii(m.params);
  if (deposits_ballistically(m))
    return ballistic_cost(p) + (m.protocol == Protocol::C ? collapse_cost(p) : 0.0);
  return slow_cost(p, m.in_regions);
}

long steps_in(double time, double time_step) {
  return static_cast<long>(std::ceil(time / time_step));
}

double collapse_steps(const SystemParams& p) {
  return std::sqrt(4.0 * p.height / (3.0 * std::abs(p.gravity))) / p.time_step;
}

double member_progress(const Member& m, MemberPhase phase, const MemberStage& stage) {
  return phase == MemberPhase::Collapse
             ? static_cast<double>(stage.steps) / collapse_steps(m.params)
             : stage.filled;
}

double running_cost(const Member& m, MemberPhase phase, double got) {
  // A collapse that runs past its expected steps counts as at most this share done.
  constexpr double kMostOfACollapse = 0.9;
  const SystemParams p = in_radii(m.params);
  switch (phase) {
    case MemberPhase::Empty:
      return 0.0;
    case MemberPhase::Collapse:
      return ballistic_cost(p) + std::min(got, kMostOfACollapse) * collapse_cost(p);
    case MemberPhase::Ballistic:
      return ballistic_cost(p, got);
    default:
      return slow_cost(p, m.in_regions, got);
  }
}

double cost_left(const MemberSnapshot& snap) {
  const Member& m = snap.result.member;
  const double got = member_progress(m, snap.phase, snap.stage);
  return std::max(0.0, expected_cost(m) - running_cost(m, snap.phase, got));
}

std::vector<std::vector<std::size_t>> balance_costs(const std::vector<double>& costs, int ranks) {
  std::vector<std::vector<std::size_t>> out(static_cast<std::size_t>(std::max(1, ranks)));
  std::vector<std::size_t> order(costs.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return costs[a] > costs[b]; });
  std::vector<double> load(out.size(), 0.0);
  for (std::size_t k : order) {
    const auto r =
        static_cast<std::size_t>(std::min_element(load.begin(), load.end()) - load.begin());
    load[r] += costs[k];
    out[r].push_back(k);
  }
  for (auto& v : out) std::sort(v.begin(), v.end());
  return out;
}

std::vector<std::vector<std::size_t>> shard_members(const std::vector<Member>& members, int ranks) {
  std::vector<double> costs;
  for (const auto& m : members) costs.push_back(expected_cost(m));
  return balance_costs(costs, ranks);
}

std::vector<double> costs_left(const std::vector<Member>& todo,
                               const std::vector<MemberSnapshot>& started) {
  std::map<std::uint64_t, const MemberSnapshot*> snapshot_of;
  for (const auto& snap : started) snapshot_of[snap.result.member.id] = &snap;
  std::vector<double> left;
  for (const auto& m : todo) {
    const auto snap = snapshot_of.find(m.id);
    left.push_back(snap == snapshot_of.end() ? expected_cost(m) : cost_left(*snap->second));
  }
  return left;
}

RankShares share_over_ranks(const std::vector<Member>& todo,
                            const std::vector<MemberSnapshot>& started, int ranks) {
  const std::vector<double> left_of = costs_left(todo, started);
  RankShares shares;
  shares.members = balance_costs(left_of, ranks);
  for (const auto& mine : shares.members) {
    shares.expected.push_back(0.0);
    shares.left.push_back(0.0);
    for (std::size_t k : mine) {
      shares.expected.back() += expected_cost(todo[k]);
      shares.left.back() += left_of[k];
    }
  }
  return shares;
}

}  // namespace loosepack
