// Protocols A (slow deposition under gravity), B (ballistic deposition with capture radius)
// and C (B, then collapse under gravity), each advancing a whole batch of members together.
#include "loosepack/protocols.hpp"

#include <Kokkos_Core.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>

#include "loosepack/region.hpp"

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
      out.push_back(m);
    }
  return out;
}

int member_capacity(const SystemParams& p) {
  // Hexagonal packing (0.9069) of the smallest radius, plus a row.
  const double rmin = p.radius * std::max(0.2, 1.0 - std::sqrt(3.0) * p.polydispersity);
  const double area = p.width * (p.height + 2.0 * rmin);
  return static_cast<int>(std::ceil(0.9069 * area / (M_PI * rmin * rmin))) + 8;
}

namespace {

using Clock = std::chrono::steady_clock;

bool ballistic(const Member& m) {
  return m.protocol != Protocol::A || std::isinf(m.params.bond_number);
}

// The parts of expected_cost, in units of about 0.1 microseconds of one core of the AMD EPYC
// VM the project is developed on (docs/PERFORMANCE.md, "What a member costs").
double ballistic_cost(const SystemParams& p) { return p.width * p.height; }
// Cohesion shortens the relaxation after each deposit: the simulated time a disk takes to come
// to rest falls from ~5 sqrt(R/g) at Bo = 0 to ~0.25 at Bo = 1e3 once avalanches set in (steps
// x h per disk at 40 R x 60 R; docs/PERFORMANCE.md, "What a member costs").
double relaxation_time(const SystemParams& p) { return std::pow(1.0 + p.bond_number / 4.0, -0.55); }
// How the cost grows with the height: a deposit H tall costs ~ H^q. A disk rolls over a surface
// that grows with the deposit, and the avalanches of a cohesive deposit grow with the height
// above them, so q grows with the Bond number: from members' progress over time, 2.2-2.6 at
// Bo <= 10, 2.8-3.2 at Bo = 1e2 and 3.6-5.4 at Bo = 1e3 (docs/PERFORMANCE.md, "What a member
// costs"). The boxes tau was fitted on were 60 R tall, so the cost is W H^3 tau / h there.
double height_exponent(const SystemParams& p) {
  return 2.5 + 2.0 * p.bond_number / (p.bond_number + 300.0);
}
double slow_cost(const SystemParams& p) {
  const double reference_height = 60.0;
  return p.width * std::pow(reference_height, 3.0) *
         std::pow(p.height / reference_height, height_exponent(p)) * relaxation_time(p) /
         p.time_step;
}
double collapse_cost(const SystemParams& p) { return p.width * p.height * p.height / p.time_step; }

}  // namespace

double expected_cost(const Member& m) {
  if (ballistic(m))
    return ballistic_cost(m.params) + (m.protocol == Protocol::C ? collapse_cost(m.params) : 0.0);
  return slow_cost(m.params);
}

std::vector<std::vector<std::size_t>> shard_members(const std::vector<Member>& members, int ranks) {
  std::vector<std::vector<std::size_t>> out(static_cast<std::size_t>(std::max(1, ranks)));
  std::vector<std::size_t> order(members.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return expected_cost(members[a]) > expected_cost(members[b]);
  });
  std::vector<double> load(out.size(), 0.0);
  for (std::size_t k : order) {
    const auto r =
        static_cast<std::size_t>(std::min_element(load.begin(), load.end()) - load.begin());
    load[r] += expected_cost(members[k]);
    out[r].push_back(k);
  }
  for (auto& v : out) std::sort(v.begin(), v.end());
  return out;
}

namespace {

using Phase = MemberPhase;

// Relaxation regions that end at rest and then find motion in the whole system start a new
// region around it at most this many times per disk; then the whole system relaxes.
constexpr int kMaxRegionRounds = 4;
// The check of the whole system after a region finds motion where a disk is faster than this
// many rest speeds (slower disks creeping near the rest speed are not a failure of the deposit).
constexpr double kWakeFactor = 3.0;
// After a stop, the run goes on at most this long [s] for snapshots of the members inside
// relaxation regions (a batch system's grace period after SIGTERM is usually 30 s or more).
constexpr double kStopGrace = 10.0;

struct Slot : MemberStage {
  Phase phase = Phase::Empty;
  std::size_t member = 0;
  long region_steps = 0, region_sweeps = 0;  // the slot's region counters when the member began
  Clock::time_point start;
  MemberResult result;
};

}  // namespace

int default_batch_size() { return Kokkos::DefaultExecutionSpace().concurrency() > 1 ? 64 : 4; }

std::vector<MemberResult> run_members(const Scan& scan, const std::vector<Member>& members,
                                      const RunHooks& hooks,
                                      const std::vector<MemberSnapshot>& resume) {
  std::vector<MemberResult> results(members.size());
  std::vector<char> done(members.size(), 0);
  if (members.empty()) return results;
  // Every slot can hold every member: capacity and grid of the largest.
  int capacity = 0, cells = 0;
  // Fault injection for the failure-handling tests: LOOSEPACK_INJECT_NAN=<member id> starts
  // that member with one disk of NaN velocity, which fails it at its first dynamic step.
  const char* inject = std::getenv("LOOSEPACK_INJECT_NAN");
  auto setup_of = [&](const Member& m) {
    SystemSetup su;
    if (inject && std::to_string(m.id) == inject) {
      Disk d;
      d.x = 0.5 * m.params.width;
      d.y = m.params.radius;
      d.radius = m.params.radius;
      d.vy = std::nan("");
      su.disks.push_back(d);
    }
    su.params = m.params;
    su.params.gravity_on = !ballistic(m);  // B and C deposit without gravity
    if (m.protocol == Protocol::A) su.params.capture_radius = 1.0;  // Bo = inf: plain BD
    su.capacity = capacity;
    su.grid_cells = cells;
    su.seed = scan.seed;
    su.member = m.id;
    su.tolerance = scan.tolerance(m.protocol);
    su.max_sweeps = scan.max_sweeps(m.protocol, m.params);
    return su;
  };
  // Slots and regions are sized for every member of the scan, not only those of this run: a
  // region's reach depends on the tallest (src/region.cpp), and a member's result must not
  // depend on which members share its run (MPI shards, resumed runs).
  std::vector<Member> sized = members_of(scan);
  sized.insert(sized.end(), members.begin(), members.end());
  for (const auto& m : sized) {
    capacity = std::max(capacity, member_capacity(m.params));
    cells = std::max(cells, grid_cells_needed(setup_of(m)));
  }
  const int batch_size = scan.batch_size > 0 ? scan.batch_size : default_batch_size();
  const std::size_t n_slots = std::min(members.size(), static_cast<std::size_t>(batch_size));
  std::vector<SystemSetup> setups;
  for (std::size_t k = 0; k < n_slots; ++k) setups.push_back(setup_of(members[k]));
  Batch batch(setups, scan.solver, scan.rest);
  batch.set_timing(hooks.stage_seconds != nullptr);
  // Relaxation regions for the slow depositions, when the scan asks for them.
  std::unique_ptr<Regions> regions;
  if (scan.protocol.region_radius > 0.0) {
    std::vector<SystemParams> slow;
    double tallest = 0.0;
    for (const auto& m : sized)
      if (!ballistic(m)) {
        slow.push_back(m.params);
        tallest = std::max(tallest, m.params.height);
      }
    if (!slow.empty()) {
      RegionSettings rs;
      rs.radius = scan.protocol.region_radius;
      rs.max_disks = scan.protocol.region_max_disks;
      // For the largest region: the last round's radius (see start_region).
      rs.max_height =
          region_slot_height(rs.radius * std::ldexp(1.0, kMaxRegionRounds - 1), tallest);
      regions =
          std::make_unique<Regions>(static_cast<int>(n_slots), slow, rs, scan.solver, scan.rest);
      regions->set_timing(hooks.stage_seconds != nullptr);
    }
  }
  std::vector<Slot> slots(n_slots);
  // Every region after the first of a disk (the check found motion where the last one rested)
  // has twice the radius of the one before: what the region held fixed (the rest of a cohesive
  // arm tipping about a pivot further away, the load of the column above) may be what moves.
  auto start_region = [&](std::size_t k, const std::vector<Regions::Point>& seeds) {
    const int s = static_cast<int>(k);
    const double radius = scan.protocol.region_radius * std::ldexp(1.0, slots[k].rounds);
    if (!regions || !regions->begin(batch, s, seeds, scan.tolerance(Protocol::A), radius))
      return false;
    slots[k].phase = Phase::Region;
    slots[k].quiet = 0;
    ++slots[k].rounds;
    batch.set_active(s, false);
    return true;
  };
  std::map<std::uint64_t, const MemberSnapshot*> snapshot_of;
  for (const auto& snap : resume) snapshot_of[snap.result.member.id] = &snap;
  std::size_t next = 0;
  Progress prog;
  prog.members_total = static_cast<int>(members.size());
  double total_weight = 0.0, done_weight = 0.0;
  for (const auto& m : members) total_weight += expected_cost(m);

  auto begin = [&](std::size_t k) {
    Slot& sl = slots[k];
    const int s = static_cast<int>(k);
    if (next >= members.size()) {
      sl.phase = Phase::Empty;
      batch.set_active(s, false);
      return;
    }
    sl = Slot{};
    sl.member = next++;
    const Member& m = members[sl.member];
    sl.start = Clock::now();
    if (regions) {
      sl.region_steps = regions->steps(s);
      sl.region_sweeps = regions->sweeps(s);
    }
    const auto from = snapshot_of.find(m.id);
    if (from == snapshot_of.end()) {
      if (sl.member >= n_slots) batch.reset(s, setup_of(m));
      sl.phase = ballistic(m) ? Phase::Ballistic : Phase::Deposit;
      sl.result.member = m;
      batch.set_active(s, false);
      return;
    }
    // Go on from the snapshot: taken at the top of the loop below, where this member goes on.
    const MemberSnapshot& snap = *from->second;
    if (!goes_on_from(snap.phase))
      throw std::invalid_argument("the snapshot of member " + std::to_string(m.id) +
                                  " has no phase a member goes on from");
    SystemSetup su = setup_of(m);
    su.disks = snap.system.disks;
    batch.reset(s, su);
    batch.restore(s, snap.system);
    static_cast<MemberStage&>(sl) = snap.stage;
    sl.phase = snap.phase;
    sl.result = snap.result;
    sl.result.member = m;
    sl.start -= std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(snap.result.wall_time));
    sl.region_steps -= snap.result.steps;
    sl.region_sweeps -= snap.result.sweeps;
  };
  // Snapshots of running members for checkpoints (RunHooks::snapshots): those asked for, taken
  // slot by slot when each can be, and handed over when every running member has one. At a
  // stop, the latest of every member that can give one, and the run goes on (for at most
  // kStopGrace) until the members inside relaxation regions have left them. True when handed
  // over.
  bool snapshots_wanted = false;
  std::vector<MemberSnapshot> taken;
  auto take_snapshots = [&](bool stopping, bool last_chance) {
    if (!hooks.snapshots) return true;
    if (!snapshots_wanted && (stopping || (hooks.snapshot_wanted && hooks.snapshot_wanted()))) {
      snapshots_wanted = true;
      taken.clear();
    }
    if (!snapshots_wanted) return false;
    bool all = true;
    for (std::size_t k = 0; k < n_slots; ++k) {
      const Slot& sl = slots[k];
      if (sl.phase == Phase::Empty) continue;
      const std::uint64_t id = members[sl.member].id;
      const auto have = std::find_if(taken.begin(), taken.end(), [&](const MemberSnapshot& t) {
        return t.result.member.id == id;
      });
      if (!goes_on_from(sl.phase)) {
        all = all && have != taken.end();
        continue;
      }
      if (have != taken.end()) {
        if (!stopping) continue;
        taken.erase(have);
      }
      const int s = static_cast<int>(k);
      MemberSnapshot snap;
      snap.result = sl.result;
      snap.result.steps = regions ? regions->steps(s) - sl.region_steps : 0;
      snap.result.sweeps = regions ? regions->sweeps(s) - sl.region_sweeps : 0;
      snap.result.wall_time = std::chrono::duration<double>(Clock::now() - sl.start).count();
      snap.phase = sl.phase;
      snap.stage = sl;
      snap.system = batch.state(s);
      taken.push_back(std::move(snap));
    }
    if (!all && !last_chance) return false;
    hooks.snapshots(std::move(taken));
    taken.clear();
    snapshots_wanted = false;
    return true;
  };
  auto finish = [&](std::size_t k) {
    Slot& sl = slots[k];
    const int s = static_cast<int>(k);
    MemberResult& r = sl.result;
    const auto& st = batch.status(s);
    r.failure = sl.gave_up ? Failure::Unconverged : st.failure;
    r.steps = st.steps;
    r.sweeps = st.sweeps;
    if (regions) {
      r.steps += regions->steps(s) - sl.region_steps;
      r.sweeps += regions->sweeps(s) - sl.region_sweeps;
    }
    r.wall_time = std::chrono::duration<double>(Clock::now() - sl.start).count();
    for (const auto& d : batch.disks(s)) {
      r.x.push_back(d.x);
      r.y_i.push_back(d.y_deposit);
      r.y_e.push_back(d.y);
      r.radius.push_back(d.radius);
      if (r.failure == Failure::None) continue;
      r.vx.push_back(d.vx);
      r.vy.push_back(d.vy);
      r.w.push_back(d.w);
    }
    r.contacts = batch.contacts(s);
    taken.erase(
        std::remove_if(taken.begin(), taken.end(),
                       [&](const MemberSnapshot& t) { return t.result.member.id == r.member.id; }),
        taken.end());
    done_weight += expected_cost(members[sl.member]);
    if (hooks.finished) hooks.finished(r);
    results[sl.member] = std::move(r);
    done[sl.member] = 1;
    ++prog.members_done;
    begin(k);
  };
  auto mask_of = [&](Phase ph) {
    std::vector<char> m(n_slots, 0);
    bool any = false;
    for (std::size_t k = 0; k < n_slots; ++k)
      if (slots[k].phase == ph) m[k] = 1, any = true;
    return std::make_pair(m, any);
  };
  auto report = [&]() {
    if (!hooks.progress) return;
    double running = 0.0;
    for (const auto& sl : slots) {
      if (sl.phase == Phase::Empty) continue;
      const SystemParams& p = members[sl.member].params;
      if (sl.phase == Phase::Collapse)
        running += ballistic_cost(p) + 0.5 * collapse_cost(p);
      else if (sl.phase == Phase::Ballistic)
        running += ballistic_cost(p) * sl.filled;
      else
        running += std::pow(sl.filled, height_exponent(p)) * slow_cost(p);
    }
    prog.fraction = (done_weight + running) / total_weight;
    hooks.progress(prog);
  };
  for (std::size_t k = 0; k < n_slots; ++k) begin(k);

  const double threshold = scan.observables.event_threshold;
  const double wake = kWakeFactor * scan.rest.speed;
  // A slot's counters after one step of its system (whole or region): steps, consecutive
  // unconverged steps (with rest.converged false a capped solve blocks nothing, so it is not a
  // failure either) and consecutive steps with no disk above the wake speed.
  auto count_step = [&](Slot& sl, const SystemStatus& st, double time_step) {
    ++sl.steps;
    sl.unconverged = st.converged || !scan.rest.converged ? 0 : sl.unconverged + 1;
    sl.gave_up =
        static_cast<double>(sl.unconverged) * time_step > scan.protocol.max_unconverged_time;
    sl.quiet = st.max_speed < wake ? sl.quiet + 1 : 0;
  };
  const int every = scan.observables.trajectory_every;
  // Trajectory samples of the slot's first `count` disks (all by default).
  auto sample = [&](std::size_t k, double when, std::size_t count = static_cast<std::size_t>(-1)) {
    if (every <= 0) return;
    MemberResult& r = slots[k].result;
    const auto disks = batch.disks(static_cast<int>(k));
    for (std::size_t d = 0; d < std::min(count, disks.size());
         d += static_cast<std::size_t>(every)) {
      r.trajectory_time.push_back(when);
      r.trajectory_disk.push_back(static_cast<double>(d));
      r.trajectory_x.push_back(disks[d].x);
      r.trajectory_y.push_back(disks[d].y);
    }
  };
  auto count_disk = [&](std::size_t k, const Deposit& d) {
    ++slots[k].deposited;
    ++prog.disks_deposited;
    // The highest so far, not the last: a disk landing in a valley of the rough surface would
    // otherwise move the progress estimate backwards.
    slots[k].filled =
        std::max(slots[k].filled, std::min(1.0, d.y / batch.params(static_cast<int>(k)).height));
  };
  // Closes the avalanche events of the slots in `closing` (A): what moved since the disk was
  // placed, a trajectory sample of the disks deposited so far; then the next disk, or, after the
  // final check, the member's end.
  auto close = [&](const std::vector<char>& closing) {
    const auto aval = batch.close_events(closing, threshold);
    for (std::size_t k = 0; k < n_slots; ++k) {
      if (!closing[k]) continue;
      Slot& sl = slots[k];
      AvalancheEvent ev;
      ev.moved = aval[k].moved;
      ev.downward = aval[k].downward;
      ev.steps = sl.steps;
      ev.capped = sl.event_capped;
      sl.result.capped += ev.capped ? 1 : 0;
      sl.result.events.push_back(ev);
      sample(k, static_cast<double>(sl.deposited), static_cast<std::size_t>(sl.deposited));
      sl.event_open = false;
      if (sl.final_check) {
        finish(k);
        continue;
      }
      sl.phase = Phase::Deposit;
      batch.set_active(static_cast<int>(k), false);
    }
  };
  Clock::time_point stopped{};
  for (;;) {
    // Every member goes on from here after a snapshot: none is inside a step.
    if (hooks.stop && *hooks.stop) {
      if (stopped == Clock::time_point{}) stopped = Clock::now();
      const bool last_chance =
          std::chrono::duration<double>(Clock::now() - stopped).count() >= kStopGrace;
      if (take_snapshots(true, last_chance)) break;
    } else {
      take_snapshots(false, false);
    }
    // Ballistic deposition: one disk per slot and round.
    auto [mb, any_b] = mask_of(Phase::Ballistic);
    if (any_b) {
      const auto placed = batch.deposit(mb, DropRule::Capture);
      for (std::size_t k = 0; k < n_slots; ++k) {
        if (!mb[k]) continue;
        const int s = static_cast<int>(k);
        if (placed[k].placed) {
          count_disk(k, placed[k]);
        } else if (batch.status(s).failure == Failure::None &&
                   members[slots[k].member].protocol == Protocol::C) {
          slots[k].phase = Phase::Collapse;  // full: switch gravity on
          slots[k].steps = 0;
          sample(k, 0.0);
          slots[k].cap = static_cast<long>(
              std::ceil(scan.protocol.max_collapse_time / batch.params(s).time_step));
          batch.set_gravity(s, true);
          batch.set_active(s, true);
        } else {
          finish(k);
        }
      }
    }
    // Slow deposition: the next disk for every slot whose last one came to rest.
    auto [ma, any_a] = mask_of(Phase::Deposit);
    if (any_a) {
      const auto placed = batch.deposit(ma, DropRule::Touch);
      // The open events close now: the new disk has not moved, the others have not since. When
      // the box is full the whole system is checked first, and that check belongs to the event.
      std::vector<char> open(n_slots, 0);
      bool any_open = false;
      for (std::size_t k = 0; k < n_slots; ++k) {
        Slot& sl = slots[k];
        if (!ma[k] || !sl.event_open) continue;
        const int s = static_cast<int>(k);
        if (placed[k].placed || batch.status(s).failure != Failure::None) {
          open[k] = 1;
          any_open = true;
        } else {
          sl.final_check = true;
          sl.phase = Phase::Relax;
          sl.checking = true;
          sl.quiet = 0;
          sl.cap = sl.steps + static_cast<long>(std::ceil(scan.protocol.max_relax_time /
                                                          batch.params(s).time_step));
          batch.set_active(s, true);
        }
      }
      if (any_open) close(open);
      for (std::size_t k = 0; k < n_slots; ++k) {
        if (!ma[k] || slots[k].final_check) continue;
        const int s = static_cast<int>(k);
        if (placed[k].placed && batch.status(s).failure == Failure::None) {
          count_disk(k, placed[k]);
          slots[k].phase = Phase::Relax;
          slots[k].steps = 0;
          slots[k].cap = static_cast<long>(
              std::ceil(scan.protocol.max_relax_time / batch.params(s).time_step));
          slots[k].checking = false;
          slots[k].rounds = 0;
          if (!start_region(k, {{placed[k].x, placed[k].y}})) batch.set_active(s, true);
        } else {
          finish(k);
        }
      }
    }
    bool dynamic = false, busy = false;
    for (const auto& sl : slots) {
      dynamic = dynamic || sl.phase == Phase::Relax || sl.phase == Phase::Collapse ||
                sl.phase == Phase::Region;
      busy = busy || sl.phase != Phase::Empty;
    }
    report();
    if (!busy) break;
    if (!dynamic) continue;
    batch.step();
    if (regions) regions->step();
    std::vector<char> closing(n_slots, 0);
    bool any_closing = false;
    for (std::size_t k = 0; k < n_slots; ++k) {
      Slot& sl = slots[k];
      if (sl.phase == Phase::Region) {
        const int s = static_cast<int>(k);
        count_step(sl, regions->status(s), batch.params(s).time_step);
        if (sl.gave_up) {
          regions->stop(batch, s);
          finish(k);
          continue;
        }
        // A region the check started (not the disk's first) is part of the check and ends as
        // it does: rest.steps steps without a disk above the wake speed, converged or not.
        auto state = regions->poll(batch, s);
        if (state == Regions::State::Running && sl.rounds > 1 && sl.quiet >= scan.rest.steps) {
          regions->stop(batch, s);
          state = Regions::State::Rested;
        }
        if (state == Regions::State::Running) {
          if (sl.steps < sl.cap) continue;
          regions->stop(batch, s);
          sl.event_capped = true;
          closing[k] = 1;
          any_closing = true;
        } else if (state == Regions::State::Rested && !sl.final_check &&
                   sl.deposited % scan.protocol.region_check_every != 0) {
          sl.event_capped = false;
          sl.event_open = true;
          sl.phase = Phase::Deposit;
          batch.set_active(s, false);
        } else {  // rested, and the whole system's rest is checked; or the region overflowed
          sl.phase = Phase::Relax;
          sl.checking = state == Regions::State::Rested;
          sl.quiet = 0;
          batch.set_active(s, true);
        }
        continue;
      }
      if (sl.phase != Phase::Relax && sl.phase != Phase::Collapse) continue;
      const auto& st = batch.status(static_cast<int>(k));
      count_step(sl, st, batch.params(static_cast<int>(k)).time_step);
      if (st.failure != Failure::None || sl.gave_up) {
        finish(k);
        continue;
      }
      // The check after a region: rest.steps steps without motion suffice, converged or not
      // (a tall deposit's solve misses the tolerance on some steps; docs/MODEL.md).
      const bool quiet = sl.checking && sl.quiet >= scan.rest.steps;
      const bool done = st.at_rest || quiet || sl.steps >= sl.cap;
      if (!done && sl.checking && st.max_speed > wake && sl.rounds < kMaxRegionRounds) {
        // The whole system moves after the region came to rest: relax around what moves.
        std::vector<Regions::Point> seeds;
        for (const auto& d : batch.disks(static_cast<int>(k)))
          if (speed(d) > wake) seeds.push_back({d.x, d.y});
        if (start_region(k, seeds)) continue;
      }
      if (sl.phase == Phase::Collapse &&
          (done || sl.steps % scan.observables.trajectory_interval == 0))
        sample(k, static_cast<double>(sl.steps));
      if (!done) continue;
      if (sl.phase == Phase::Collapse) {
        sl.result.capped = st.at_rest ? 0 : 1;
        finish(k);
      } else {
        sl.event_capped = !st.at_rest && !quiet;
        closing[k] = 1;
        any_closing = true;
      }
    }
    if (any_closing) close(closing);
  }
  if (hooks.stage_seconds) {
    *hooks.stage_seconds = batch.stage_seconds();
    if (regions)
      for (const auto& [name, sec] : regions->stage_seconds())
        hooks.stage_seconds->emplace_back("region " + name, sec);
  }
  std::vector<MemberResult> finished;
  for (std::size_t k = 0; k < results.size(); ++k)
    if (done[k]) finished.push_back(std::move(results[k]));
  return finished;
}

}  // namespace loosepack
