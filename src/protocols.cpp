// Protocols A (slow deposition under gravity), B (ballistic deposition with capture radius)
// and C (B, then collapse under gravity), each advancing a whole batch of members together.
#include "loosepack/protocols.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

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

// Deposit until every system is full, without dynamics (protocol B, and A at Bo = inf).
void deposit_ballistic(Batch& batch, DropRule rule, std::vector<long>& deposited,
                       const std::function<void()>& tick) {
  const int S = batch.size();
  std::vector<char> open(static_cast<std::size_t>(S), 1);
  for (bool any = true; any;) {
    const auto placed = batch.deposit(open, rule);
    any = false;
    for (int s = 0; s < S; ++s) {
      auto& o = open[static_cast<std::size_t>(s)];
      if (!o) continue;
      if (!placed[static_cast<std::size_t>(s)].placed || batch.status(s).failure != Failure::None) {
        o = 0;
        continue;
      }
      ++deposited[static_cast<std::size_t>(s)];
      any = true;
    }
    tick();
  }
}

void run_slow_deposition(Batch& batch, const Scan& scan, std::vector<MemberResult>& res,
                         std::vector<long>& deposited, const std::function<void()>& tick) {
  const int S = batch.size();
  std::vector<char> want(static_cast<std::size_t>(S), 1), running(static_cast<std::size_t>(S), 0);
  std::vector<long> relax_steps(static_cast<std::size_t>(S), 0);
  std::vector<long> cap(static_cast<std::size_t>(S));
  for (int s = 0; s < S; ++s)
    cap[static_cast<std::size_t>(s)] = static_cast<long>(
        std::ceil(scan.protocol.max_relax_time / batch.params(s).time_step));
  const double threshold = scan.observables.event_threshold;
  for (;;) {
    // Deposit one disk into every system that is ready for it.
    bool any_want = false;
    for (char w : want) any_want = any_want || w;
    if (any_want) {
      const auto placed = batch.deposit(want, DropRule::Touch);
      for (int s = 0; s < S; ++s) {
        const auto k = static_cast<std::size_t>(s);
        if (!want[k]) continue;
        want[k] = 0;
        if (placed[k].placed && batch.status(s).failure == Failure::None) {
          running[k] = 1;
          relax_steps[k] = 0;
          ++deposited[k];
          batch.set_active(s, true);
        } else {
          running[k] = 0;
          batch.set_active(s, false);
        }
      }
      tick();
    }
    bool any_running = false;
    for (char r : running) any_running = any_running || r;
    if (!any_running) break;
    batch.step();
    std::vector<char> finished(static_cast<std::size_t>(S), 0);
    bool any_finished = false;
    for (int s = 0; s < S; ++s) {
      const auto k = static_cast<std::size_t>(s);
      if (!running[k]) continue;
      const auto& st = batch.status(s);
      if (st.failure != Failure::None) {
        running[k] = 0;
        continue;
      }
      ++relax_steps[k];
      if (st.at_rest || relax_steps[k] >= cap[k]) {
        finished[k] = 1;
        any_finished = true;
      }
    }
    if (!any_finished) continue;
    const auto aval = batch.close_events(finished, threshold);
    for (int s = 0; s < S; ++s) {
      const auto k = static_cast<std::size_t>(s);
      if (!finished[k]) continue;
      AvalancheEvent ev;
      ev.moved = aval[k].moved;
      ev.downward = aval[k].downward;
      ev.steps = relax_steps[k];
      ev.capped = !batch.status(s).at_rest;
      res[k].capped += ev.capped ? 1 : 0;
      res[k].events.push_back(ev);
      running[k] = 0;
      want[k] = 1;
      batch.set_active(s, false);
    }
  }
}

// Protocol C after its ballistic deposit: gravity on, dynamics until rest or the cap.
void run_collapse(Batch& batch, const Scan& scan, const std::vector<Member>& group,
                  std::vector<MemberResult>& res) {
  long cap = 0;
  for (int s = 0; s < batch.size(); ++s) {
    const bool collapse = group[static_cast<std::size_t>(s)].protocol == Protocol::C;
    batch.set_active(s, collapse);
    if (!collapse) continue;
    batch.set_gravity(s, true);
    cap = std::max(cap, static_cast<long>(std::ceil(scan.protocol.max_collapse_time /
                                                    batch.params(s).time_step)));
  }
  batch.run_to_rest(cap);
  for (int s = 0; s < batch.size(); ++s) {
    const auto& st = batch.status(s);
    if (group[static_cast<std::size_t>(s)].protocol == Protocol::C && !st.at_rest &&
        st.failure == Failure::None)
      res[static_cast<std::size_t>(s)].capped = 1;
  }
}

}  // namespace

std::vector<MemberResult> run_members(const Scan& scan, const std::vector<Member>& members,
                                      const ProgressFn& progress) {
  std::vector<MemberResult> results(members.size());
  Progress prog;
  prog.members_total = static_cast<int>(members.size());
  // Batches hold members of one kind (dynamic deposition, or ballistic), in member order.
  std::vector<std::vector<std::size_t>> batches;
  for (int kind = 0; kind < 2; ++kind) {
    std::vector<std::size_t> cur;
    for (std::size_t k = 0; k < members.size(); ++k) {
      if (static_cast<int>(ballistic(members[k])) != kind) continue;
      cur.push_back(k);
      if (static_cast<int>(cur.size()) == scan.batch_size) {
        batches.push_back(cur);
        cur.clear();
      }
    }
    if (!cur.empty()) batches.push_back(cur);
  }
  long deposited_before = 0;
  for (const auto& idx : batches) {
    const auto t0 = Clock::now();
    std::vector<SystemSetup> setups;
    std::vector<Member> group;
    for (std::size_t k : idx) {
      const Member& m = members[k];
      SystemSetup su;
      su.params = m.params;
      su.params.gravity_on = !ballistic(m);  // B and C deposit without gravity
      if (m.protocol == Protocol::A) su.params.capture_radius = 1.0;  // Bo = inf: plain BD
      su.capacity = member_capacity(m.params);
      su.seed = scan.seed;
      su.member = m.id;
      setups.push_back(su);
      group.push_back(m);
    }
    Batch batch(setups, scan.solver, scan.rest);
    std::vector<MemberResult> res(idx.size());
    std::vector<long> deposited(idx.size(), 0);
    auto tick = [&]() {
      if (!progress) return;
      long sum = deposited_before;
      for (long d : deposited) sum += d;
      prog.disks_deposited = sum;
      progress(prog);
    };
    if (ballistic(group.front())) {
      // Protocol A at Bo = inf is plain ballistic deposition: capture radius 1.
      deposit_ballistic(batch, DropRule::Capture, deposited, tick);
      run_collapse(batch, scan, group, res);
    } else {
      run_slow_deposition(batch, scan, res, deposited, tick);
    }
    const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
    long batch_disks = 0;
    for (long d : deposited) batch_disks += d;
    for (std::size_t k = 0; k < idx.size(); ++k) {
      const int s = static_cast<int>(k);
      auto& r = res[k];
      r.member = group[k];
      r.failure = batch.status(s).failure;
      r.steps = batch.status(s).steps;
      r.sweeps = batch.status(s).sweeps;
      // Wall time of the batch shared out by deposited disks.
      r.wall_time = batch_disks > 0 ? wall * static_cast<double>(deposited[k]) / batch_disks
                                    : wall / static_cast<double>(idx.size());
      for (const auto& d : batch.disks(s)) {
        r.x.push_back(d.x);
        r.y_i.push_back(d.y_deposit);
        r.y_e.push_back(d.y);
        r.radius.push_back(d.radius);
      }
      results[idx[k]] = std::move(r);
      ++prog.members_done;
    }
    deposited_before += batch_disks;
    tick();
  }
  return results;
}

}  // namespace loosepack
