// Checkpoint encoding and sharding: bit-exact round trips, damage always detected, balance.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>

#include "kernels/state.hpp"
#include "loosepack/checkpoint.hpp"

using namespace loosepack;

namespace {

// A fresh directory under the system's temporary one, removed with everything in it when the
// test ends, passed or failed.
struct ScratchDir {
  explicit ScratchDir(const std::string& name)
      : path(std::filesystem::temp_directory_path() / (name + "-" + std::to_string(::getpid()))) {
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  std::string string() const { return path.string(); }
  std::filesystem::path path;
};

// Protocol C, 2 seeds at two Bond numbers, with the [system] lines `system`.
Scan small_scan(const std::string& system = "width = 12\nheight = 12\nbond_number = [10, 100]\n") {
  return parse_scan("[scan]\nprotocol = \"C\"\nseeds = 2\n[system]\n" + system +
                        "[observables]\nlower_half_from = 2\n",
                    "test.toml");
}

// A member result with every field set, including a NaN with a payload and signed zeros. Its
// collapse was stopped at the scan's cap, as a checkpoint of this scan may hold it (a resume
// keeps only the members its protocol.max_collapse_time ends the same: read_checkpoint).
MemberResult filled(const Scan& scan, std::size_t id) {
  MemberResult r;
  r.member = members_of(scan).at(id);
  r.failure = Failure::NonFinite;
  r.steps = steps_in(scan.protocol.max_collapse_time, r.member.params.time_step);
  r.sweeps = 123456789012;
  r.capped = 1;
  r.wall_time = 0.125;
  r.x = {1.0, -0.0, std::numeric_limits<double>::denorm_min()};
  r.y_i = {2.0, 3.0, 4.0};
  r.y_e = {1.5, std::nan("0x7ff"), 3.5};
  r.radius = {1.0, 0.9, 1.1};
  r.vx = {0.1, 0.2, std::numeric_limits<double>::infinity()};
  r.vy = {0.0, 0.0, 0.0};
  r.w = {1e-300, 0.0, -1e300};
  r.trajectory_time = {0.0, 20.0};
  r.trajectory_disk = {0.0, 0.0};
  r.trajectory_x = {1.0, 1.1};
  r.trajectory_y = {2.0, 1.9};
  r.events = {{3, 0.75, 1000, true}, {0, 0.0, 5, false}};
  ContactForce c;
  c.i = 2;
  c.j = -1;
  c.nx = 0.0;
  c.ny = 1.0;
  c.gap = -1e-5;
  c.normal = 3.25;
  c.tangential = -0.5;
  c.moment = 0.01;
  r.contacts = {c};
  return r;
}

// Bitwise equality of two vectors of doubles (NaN payloads included).
bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

// Everything a finished member records but its wall time, bit for bit.
void expect_same_member(const MemberResult& a, const MemberResult& b) {
  SCOPED_TRACE("member " + std::to_string(a.member.id));
  EXPECT_EQ(a.member.id, b.member.id);
  EXPECT_EQ(a.failure, b.failure);
  EXPECT_EQ(a.steps, b.steps);
  EXPECT_EQ(a.sweeps, b.sweeps);
  EXPECT_EQ(a.capped, b.capped);
  for (auto f :
       {&MemberResult::x, &MemberResult::y_i, &MemberResult::y_e, &MemberResult::radius,
        &MemberResult::vx, &MemberResult::vy, &MemberResult::w, &MemberResult::trajectory_time,
        &MemberResult::trajectory_disk, &MemberResult::trajectory_x, &MemberResult::trajectory_y})
    EXPECT_TRUE(same_bits(a.*f, b.*f));
  ASSERT_EQ(a.events.size(), b.events.size());
  for (std::size_t k = 0; k < a.events.size(); ++k) {
    EXPECT_EQ(a.events[k].moved, b.events[k].moved) << "event " << k;
    EXPECT_TRUE(same_bits({a.events[k].downward}, {b.events[k].downward})) << "event " << k;
    EXPECT_EQ(a.events[k].steps, b.events[k].steps) << "event " << k;
    EXPECT_EQ(a.events[k].capped, b.events[k].capped) << "event " << k;
  }
  ASSERT_EQ(a.contacts.size(), b.contacts.size());
  for (std::size_t k = 0; k < a.contacts.size(); ++k) {
    const auto &p = a.contacts[k], &q = b.contacts[k];
    EXPECT_EQ(p.i, q.i);
    EXPECT_EQ(p.j, q.j);
    EXPECT_TRUE(same_bits({p.nx, p.ny, p.gap, p.normal, p.tangential, p.moment},
                          {q.nx, q.ny, q.gap, q.normal, q.tangential, q.moment}))
        << "contact " << k;
  }
}

// The scan of expect_running_members_go_on: cohesive deposits relaxed in regions with a
// whole-system check every third disk (A), slow deposits without cohesion (A) and collapses (C),
// with trajectories, on batches of 2. `solver` is the scan file's [solver] section, `more`
// sections after it.
Scan interrupted_scan(const std::string& solver, const std::string& more) {
  return parse_scan(
      "[scan]\nseeds = 2\nbatch_size = 2\n"
      "[[point]]\nprotocol = \"A\"\nwidth = 16\nheight = 20\nbond_number = 1000\n"
      "time_step = 0.0028\n"
      "[[point]]\nprotocol = \"A\"\nwidth = 8\nheight = 8\nbond_number = 0\n"
      "[[point]]\nprotocol = \"C\"\nwidth = 12\nheight = 16\nbond_number = 30\n"
      "[protocol]\nregion_radius = 5\nregion_check_every = 3\n"
      "[observables]\nlower_half_from = 2\ntrajectory_every = 3\n"
      "[solver]\n" +
          solver + more,
      "test.toml");
}

// A member stopped while it runs goes on from its snapshot as if it had never stopped. On the
// interrupted_scan: a snapshot of every running member is asked for every 16 rounds; the run is
// stopped after every sixteenth of the rounds the whole run takes (or, every other time,
// crashes), each time saved to a checkpoint part and read back, and resumed on batches of 3.
// Every member's result equals the uninterrupted run's bit for bit; some went on from inside a
// relaxation region. `straight_out` gets the uninterrupted run's results.
void expect_running_members_go_on(const std::string& solver, const std::string& more = "",
                                  std::vector<MemberResult>* straight_out = nullptr) {
  const Scan scan = interrupted_scan(solver, more);
  const auto members = members_of(scan);
  long rounds = 0;  // of the run's loop: one progress report each
  RunHooks counting;
  counting.progress = [&](const Progress&) { ++rounds; };
  const auto straight = run_members(scan, members, counting);
  if (straight_out) *straight_out = straight;
  ASSERT_EQ(straight.size(), members.size());
  ASSERT_GT(rounds, 100);

  const ScratchDir dir("loosepack-running");
  const std::string part = checkpoint_part(dir.string(), 1, 0);
  Scan resumed_scan = scan;
  resumed_scan.batch_size = 3;
  std::vector<MemberResult> done;
  std::vector<MemberSnapshot> started;
  int stops = 0;
  bool went_on_moving = false, went_on_resting = false, went_on_in_region = false;
  while (done.size() < members.size()) {
    ASSERT_LT(stops, 16);
    std::vector<Member> todo;
    for (const auto& m : members)
      if (std::none_of(done.begin(), done.end(),
                       [&](const MemberResult& r) { return r.member.id == m.id; }))
        todo.push_back(m);
    // As `loosepack run` keeps them: the latest snapshot of each member still running.
    std::map<std::uint64_t, MemberSnapshot> latest;
    for (const auto& s : started) latest[s.result.member.id] = s;
    volatile std::sig_atomic_t stop = 0;
    long n = 0;
    RunHooks hooks;
    hooks.stop = &stop;
    hooks.progress = [&](const Progress&) { ++n; };
    hooks.snapshot_wanted = [&] { return n % 16 == 0; };
    // Stopped after the first set of snapshots past a sixteenth of the rounds; the stop then
    // takes fresh snapshots (waiting for members inside a split step to end it), which most
    // often find the members of A inside a relaxation region. Every other stop goes on from the
    // last set before it instead, as after a crash, and comes where that set holds a member
    // between two disks.
    const bool crash = stops % 2 == 1;
    hooks.snapshots = [&](std::vector<MemberSnapshot> snaps) {
      if (stop && crash) return;  // lost in the crash
      const bool between = std::any_of(snaps.begin(), snaps.end(), [](const MemberSnapshot& s) {
        return s.phase == MemberPhase::Deposit || s.phase == MemberPhase::Ballistic;
      });
      for (auto& s : snaps) latest[s.result.member.id] = std::move(s);
      if (n >= rounds / 16 && (!crash || between)) stop = 1;
    };
    hooks.finished = [&](const MemberResult& r) { latest.erase(r.member.id); };
    for (auto& r : run_members(stops == 0 ? scan : resumed_scan, todo, hooks, started))
      done.push_back(std::move(r));
    std::vector<MemberSnapshot> snaps;
    for (auto& [id, s] : latest) snaps.push_back(std::move(s));
    write_checkpoint_part(part, scan_fingerprint(scan), done, snaps);
    const auto ck = read_checkpoint(dir.string(), scan);
    ASSERT_EQ(ck.members.size(), done.size());
    started = ck.running;
    for (const auto& s : started) {
      (s.system.status.active || s.region ? went_on_moving : went_on_resting) = true;
      went_on_in_region = went_on_in_region || s.region.has_value();
    }
    if (done.size() < members.size()) ++stops;
  }
  EXPECT_GE(stops, 4);
  // Some members went on inside a relaxation or collapse, some between two disks, some inside a
  // relaxation region.
  EXPECT_TRUE(went_on_moving);
  EXPECT_TRUE(went_on_resting);
  EXPECT_TRUE(went_on_in_region);
  std::sort(done.begin(), done.end(),
            [](const MemberResult& a, const MemberResult& b) { return a.member.id < b.member.id; });
  for (std::size_t k = 0; k < members.size(); ++k) expect_same_member(straight[k], done[k]);
}

// A running member's snapshot with every field set (its system is not a real one).
MemberSnapshot snapshot(const Scan& scan, std::size_t id) {
  MemberSnapshot snap;
  snap.result = filled(scan, id);
  snap.phase = MemberPhase::Deposit;
  snap.stage.steps = 17;
  snap.stage.moved_until = 6;
  snap.stage.deposited = 2;
  snap.stage.filled = 0.25;
  snap.stage.event_open = true;
  Batch::SystemState& sys = snap.system;
  sys.disks.resize(2);
  sys.disks[1].x = -0.0;
  sys.disks[1].fixed = true;
  sys.y_mark = {1.0, 3.0};
  sys.inv_mass = {1.0, 0.0};
  sys.inv_inertia = {2.0, 0.0};
  sys.slot = {8};
  sys.partner = {0};
  sys.pn = {0.5};
  sys.pt = {-0.25};
  sys.pm = {1e-9};
  sys.nx = {0.0};
  sys.ny = {-1.0};
  sys.gap = {2e-3};
  sys.draws = 4;
  sys.status.count = 2;
  sys.status.steps = 40;
  sys.pace.wait = 12;
  sys.pace.credit = -3.5;
  sys.span_steps = 7;
  sys.span_step = 3;
  sys.spans = 2;
  sys.span_change = 0.125;
  sys.status.mean_speed = 4e-4;
  for (int k = 0; k < 2 * kSpanFields; ++k) sys.span.push_back(0.5 * k);
  return snap;
}

// The same member inside a relaxation region of its two disks: the first moves, the second is
// held; the region's small system is the whole one's, shifted down by y0.
MemberSnapshot in_region(const Scan& scan, std::size_t id) {
  MemberSnapshot snap = snapshot(scan, id);
  snap.phase = MemberPhase::Region;
  RegionState rg;
  rg.cut = {{0, 1}, {1, 0}, {{0.5, 2.0}, {1.5, -0.0}}, 8.0, 0.75, 9.0, 3e-3};
  rg.system = snap.system;
  rg.system.status.steps = 5;
  rg.system.pace.wait = 24;
  snap.region = rg;
  return snap;
}

}  // namespace

TEST(Checkpoint, MembersRoundTripBitForBit) {
  const Scan scan = small_scan();
  const std::vector<MemberResult> in = {filled(scan, 3), filled(scan, 0)};
  const auto out = decode_members(encode_members(in), scan, "test bytes");
  ASSERT_EQ(out.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    const auto &a = in[k], &b = out[k];
    expect_same_member(a, b);
    EXPECT_EQ(a.member.point, b.member.point);
    EXPECT_EQ(a.member.params.bond_number, b.member.params.bond_number);
    EXPECT_EQ(a.wall_time, b.wall_time);
  }
}

// A part with a finished member and two running ones (one inside a relaxation region) reads
// back; every truncation and every single flipped byte of it is refused with a CheckpointError
// naming the file: never a crash, never silently used.
TEST(Checkpoint, EveryTruncationAndFlippedByteIsRefused) {
  const Scan scan = small_scan();
  const ScratchDir dir("loosepack-ckpt");
  const std::string part = checkpoint_part(dir.string(), 1, 0);
  write_checkpoint_part(part, scan_fingerprint(scan), {filled(scan, 1)},
                        {snapshot(scan, 2), in_region(scan, 3)});
  const auto ck = read_checkpoint(dir.string(), scan);
  ASSERT_EQ(ck.members.size(), 1u);
  ASSERT_EQ(ck.running.size(), 2u);
  const MemberSnapshot& back = ck.running[0];
  EXPECT_FALSE(back.region.has_value());
  const MemberSnapshot& inside = ck.running[1];
  EXPECT_EQ(inside.phase, MemberPhase::Region);
  ASSERT_TRUE(inside.region.has_value());
  const RegionState& rg = *inside.region;
  const RegionCut& cut = rg.cut;
  EXPECT_EQ(cut.index, std::vector<int>({0, 1}));
  EXPECT_EQ(cut.moving, std::vector<char>({1, 0}));
  ASSERT_EQ(cut.seeds.size(), 2u);
  EXPECT_EQ(cut.seeds[0].x, 0.5);
  EXPECT_TRUE(std::signbit(cut.seeds[1].y));
  EXPECT_EQ(cut.radius, 8.0);
  EXPECT_EQ(cut.y0, 0.75);
  EXPECT_EQ(cut.height, 9.0);
  EXPECT_EQ(cut.tolerance, 3e-3);
  EXPECT_EQ(rg.system.status.steps, 5);
  EXPECT_EQ(rg.system.pace.wait, 24);
  EXPECT_TRUE(rg.system.disks[1].fixed);
  EXPECT_EQ(back.result.member.id, 2u);
  EXPECT_EQ(back.phase, MemberPhase::Deposit);
  EXPECT_EQ(back.stage.steps, 17);
  EXPECT_EQ(back.stage.moved_until, 6);
  EXPECT_TRUE(back.stage.event_open);
  ASSERT_EQ(back.system.disks.size(), 2u);
  EXPECT_TRUE(std::signbit(back.system.disks[1].x));
  EXPECT_TRUE(back.system.disks[1].fixed);
  EXPECT_EQ(back.system.slot, std::vector<int>({8}));
  EXPECT_EQ(back.system.pm, std::vector<double>({1e-9}));
  EXPECT_EQ(back.system.gap, std::vector<double>({2e-3}));
  EXPECT_EQ(back.system.draws, 4u);
  EXPECT_EQ(back.system.status.steps, 40);
  EXPECT_EQ(back.system.pace.credit, -3.5);
  EXPECT_EQ(back.system.span_steps, 7);
  EXPECT_EQ(back.system.span_step, 3);
  EXPECT_EQ(back.system.spans, 2);
  EXPECT_EQ(back.system.span_change, 0.125);
  EXPECT_EQ(back.system.status.mean_speed, 4e-4);
  ASSERT_EQ(back.system.span.size(), std::size_t{2 * kSpanFields});
  EXPECT_EQ(back.system.span.back(), 0.5 * (2 * kSpanFields - 1));
  std::ifstream f(part, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  auto refused = [&](const std::string& damaged) {
    std::ofstream(part, std::ios::binary | std::ios::trunc) << damaged;
    try {
      read_checkpoint(dir.string(), scan);
    } catch (const CheckpointError& e) {
      return std::string(e.what()).find(part) != std::string::npos;
    }
    return false;
  };
  for (std::size_t n = 0; n < bytes.size(); ++n)
    ASSERT_TRUE(refused(bytes.substr(0, n))) << "truncated to " << n << " bytes";
  for (std::size_t k = 0; k < bytes.size(); ++k) {
    std::string d = bytes;
    d[k] = static_cast<char>(d[k] ^ 0x10);
    ASSERT_TRUE(refused(d)) << "byte " << k << " flipped";
  }
  // A part of the format before snapshots inside regions is refused with its format named.
  {
    std::string older = bytes;
    older[7] = '1';
    std::ofstream(part, std::ios::binary | std::ios::trunc) << older;
    try {
      read_checkpoint(dir.string(), scan);
      ADD_FAILURE() << "a part of format LPCKPT01 was read";
    } catch (const CheckpointError& e) {
      EXPECT_NE(std::string(e.what()).find("another checkpoint format (LPCKPT01"),
                std::string::npos)
          << e.what();
    }
  }
  // Parts with a valid checksum whose region does not hold together are refused too: a seed
  // not in the box, a region's disk outside the whole system, a member in a region without it.
  const auto refused_part = [&](const MemberSnapshot& snap) {
    write_checkpoint_part(part, scan_fingerprint(scan), {}, {snap});
    EXPECT_THROW(read_checkpoint(dir.string(), scan), CheckpointError);
  };
  MemberSnapshot bad = in_region(scan, 3);
  bad.region->cut.seeds[0].x = std::nan("");
  refused_part(bad);
  bad = in_region(scan, 3);
  bad.region->cut.index[1] = 2;  // the whole system has two disks
  refused_part(bad);
  bad = in_region(scan, 3);
  bad.region.reset();
  refused_part(bad);
  // Another scan (one setting edited) is refused too; the same settings with comments, blank
  // lines, other spacing and keys in another order are the same scan.
  write_checkpoint_part(part, scan_fingerprint(scan), {filled(scan, 1)});
  std::string text = scan.text;
  text.replace(text.find("height = 12"), 11, "height = 13");
  EXPECT_THROW(read_checkpoint(dir.string(), parse_scan(text, "test.toml")), CheckpointError);
  const Scan commented = parse_scan(
      "# the same scan\n[system]\nheight = 12\nbond_number = [10, 100]\nwidth=12  # R\n\n"
      "[scan]\nseeds = 2\nprotocol = \"C\"\n[observables]\nlower_half_from = 2\n",
      "test.toml");
  EXPECT_EQ(read_checkpoint(dir.string(), commented).members.size(), 1u);
}

// A run's finished members go to parts written once, its running members' snapshots to one part
// rewritten each time: a member found finished in any part is not taken from a stale snapshot.
TEST(Checkpoint, FinishedPartsWinOverSnapshots) {
  const Scan scan = small_scan();
  const ScratchDir dir("loosepack-parts");
  const std::string running = checkpoint_part(dir.string(), 2, 1);
  const std::string first = checkpoint_part(dir.string(), 2, 1, 1);
  EXPECT_EQ(std::filesystem::path(running).filename(), "part-2-1.bin");
  EXPECT_EQ(std::filesystem::path(first).filename(), "part-2-1-1.bin");
  const auto fp = scan_fingerprint(scan);
  write_checkpoint_part(first, fp, {filled(scan, 1)});
  write_checkpoint_part(checkpoint_part(dir.string(), 2, 1, 2), fp, {filled(scan, 3)});
  // Written before member 1 finished, as a run killed between the two writes leaves it.
  write_checkpoint_part(running, fp, {}, {snapshot(scan, 1), snapshot(scan, 2)});
  const auto ck = read_checkpoint(dir.string(), scan);
  ASSERT_EQ(ck.members.size(), 2u);
  EXPECT_EQ(ck.members[0].member.id, 1u);
  EXPECT_EQ(ck.members[1].member.id, 3u);
  ASSERT_EQ(ck.running.size(), 1u);
  EXPECT_EQ(ck.running[0].result.member.id, 2u);
  EXPECT_EQ(ck.generation, 2);
}

// A resume may change protocol.max_collapse_time: a member of the checkpoint is kept where the
// new cap gives it the same result, and runs again where not. Steps are those of the collapse,
// the cap's ceil(T / h) (h = 0.01 at Bo = 10 and 20: T = 10 is 1 000 steps).
TEST(Checkpoint, AChangedCollapseCapKeepsTheMembersItWouldEndTheSame) {
  const std::string system = "width = 12\nheight = 12\nbond_number = [10, 20]\n";
  const Scan wrote = small_scan(system);  // the default cap, 3 000: 300 000 steps
  const auto collapse = [&](const std::string& cap) {
    return small_scan(system + "[protocol]\nmax_collapse_time = " + cap + "\n");
  };
  for (const auto& m : members_of(wrote)) ASSERT_EQ(m.params.time_step, 0.01);
  ASSERT_EQ(scan_fingerprint(collapse("10")), scan_fingerprint(wrote));
  ASSERT_NE(collapse("10").content, wrote.content);  // a merge still tells them apart
  const ScratchDir dir("loosepack-collapse-cap");
  write_checkpoint_selection(dir.string(), "", false, wrote);
  const auto ended = [&](std::size_t id, long steps, int capped) {
    MemberResult r = filled(wrote, id);
    r.failure = Failure::None;
    r.steps = steps;
    r.capped = capped;
    return r;
  };
  // Members 0 and 1 came to rest after 1 000 and 1 001 steps, member 2 was stopped at the cap.
  write_checkpoint_part(checkpoint_part(dir.string(), 1, 0, 1), scan_fingerprint(wrote),
                        {ended(0, 1000, 0), ended(1, 1001, 0), ended(2, 300000, 1)});
  // Member 3 collapses, 999 steps in; member 1's snapshot 500 steps in is still there (a run
  // killed between its two writes leaves it).
  const auto collapsing = [&](std::size_t id, long steps) {
    MemberSnapshot snap = snapshot(wrote, id);
    snap.phase = MemberPhase::Collapse;
    snap.stage.steps = steps;
    snap.stage.cap = 300000;
    return snap;
  };
  write_checkpoint_part(checkpoint_part(dir.string(), 1, 0), scan_fingerprint(wrote), {},
                        {collapsing(1, 500), collapsing(3, 999)});
  const auto running_ids = [](const CheckpointContents& ck) {
    std::vector<std::uint64_t> out;
    for (const auto& s : ck.running) out.push_back(s.result.member.id);
    return out;
  };
  const auto ids = [](const CheckpointContents& ck) {
    std::vector<std::uint64_t> out;
    for (const auto& r : ck.members) out.push_back(r.member.id);
    return out;
  };
  const auto same = read_checkpoint(dir.string(), wrote);  // the finished member 1 wins
  EXPECT_EQ(ids(same), (std::vector<std::uint64_t>{0, 1, 2}));
  EXPECT_EQ(running_ids(same), (std::vector<std::uint64_t>{3}));
  EXPECT_EQ(same.run_again, 0);
  // A cap of 1 000 steps: member 0 ends as before; 1 would have stopped at the cap, so it goes on
  // from its snapshot, as 3 does, under the new cap; 2 runs again.
  const auto lower = read_checkpoint(dir.string(), collapse("10"));
  EXPECT_EQ(ids(lower), (std::vector<std::uint64_t>{0}));
  ASSERT_EQ(running_ids(lower), (std::vector<std::uint64_t>{1, 3}));
  for (const auto& snap : lower.running) EXPECT_EQ(snap.stage.cap, 1000);
  EXPECT_EQ(lower.running[1].stage.steps, 999);
  EXPECT_EQ(lower.run_again, 1);
  // A cap of 999 steps (9.985 / 0.01, rounded up): member 3 is there already, and 0 went past it.
  const auto at_the_snapshot = read_checkpoint(dir.string(), collapse("9.985"));
  EXPECT_TRUE(ids(at_the_snapshot).empty());
  EXPECT_EQ(running_ids(at_the_snapshot), (std::vector<std::uint64_t>{1}));
  EXPECT_EQ(at_the_snapshot.run_again, 3);
  // A longer cap: member 2, stopped at the old one, would have gone on.
  const auto longer = read_checkpoint(dir.string(), collapse("4000"));
  EXPECT_EQ(ids(longer), (std::vector<std::uint64_t>{0, 1}));
  ASSERT_EQ(running_ids(longer), (std::vector<std::uint64_t>{3}));
  EXPECT_EQ(longer.running[0].stage.cap, 400000);
  EXPECT_EQ(longer.run_again, 1);
  // Member 2 run again under that cap came to rest after 350 000 steps (a second generation's
  // part, read after the first's): under it each member is kept, and nothing runs again; under
  // the first cap its first record is kept.
  write_checkpoint_part(checkpoint_part(dir.string(), 2, 0, 1), scan_fingerprint(wrote),
                        {ended(2, 350000, 0)});
  const auto again = read_checkpoint(dir.string(), collapse("4000"));
  EXPECT_EQ(ids(again), (std::vector<std::uint64_t>{0, 1, 2}));
  ASSERT_EQ(again.members.size(), 3u);
  EXPECT_EQ(again.members[2].steps, 350000);
  EXPECT_EQ(again.run_again, 0);
  const auto first = read_checkpoint(dir.string(), wrote);
  ASSERT_EQ(ids(first), (std::vector<std::uint64_t>{0, 1, 2}));
  EXPECT_EQ(first.members[2].steps, 300000);
  EXPECT_EQ(first.run_again, 0);
}

// A resume finds the running parts of earlier generations whose every snapshot a later record
// replaces (superseded: the run removes them). Generation 1 held members 0 and 1 running on
// rank 0 and member 2 on rank 1; generation 2 finished member 0 and took member 1 further, so
// rank 0's first part is superseded; rank 1's is not (member 2 goes on from it), nor is the
// latest generation's part, and both snapshots are still read.
TEST(Checkpoint, RunningPartsThatLaterRecordsReplaceAreSuperseded) {
  const Scan scan = small_scan();
  const ScratchDir dir("loosepack-superseded");
  const std::string d = dir.string();
  const auto fingerprint = scan_fingerprint(scan);
  write_checkpoint_selection(d, "", false, scan);
  write_checkpoint_part(checkpoint_part(d, 1, 0), fingerprint, {},
                        {snapshot(scan, 0), snapshot(scan, 1)});
  write_checkpoint_part(checkpoint_part(d, 1, 1), fingerprint, {}, {snapshot(scan, 2)});
  write_checkpoint_part(checkpoint_part(d, 2, 0, 1), fingerprint, {filled(scan, 0)});
  MemberSnapshot further = snapshot(scan, 1);
  further.stage.steps = 40;
  write_checkpoint_part(checkpoint_part(d, 2, 0), fingerprint, {}, {further});
  const auto ck = read_checkpoint(d, scan);
  EXPECT_EQ(ck.superseded, std::vector<std::string>{checkpoint_part(d, 1, 0)});
  ASSERT_EQ(ck.running.size(), 2u);
  EXPECT_EQ(ck.running[0].result.member.id, 1u);
  EXPECT_EQ(ck.running[0].stage.steps, 40);
  EXPECT_EQ(ck.running[1].result.member.id, 2u);
  ASSERT_EQ(ck.members.size(), 1u);
  // Without the superseded part the checkpoint reads the same.
  std::filesystem::remove(ck.superseded[0]);
  const auto without = read_checkpoint(d, scan);
  EXPECT_TRUE(without.superseded.empty());
  ASSERT_EQ(without.running.size(), 2u);
  EXPECT_EQ(without.running[0].stage.steps, 40);
  EXPECT_EQ(without.members.size(), 1u);
}

// A checkpoint of another scan or program is refused with what differs: the first setting, with
// its value there and here, or the program that wrote it (the `scan` file beside the parts).
TEST(Checkpoint, ARefusedCheckpointSaysWhatDiffers) {
  const Scan scan = small_scan();
  const ScratchDir dir("loosepack-differs");
  write_checkpoint_selection(dir.string(), "", false, scan);
  write_checkpoint_part(checkpoint_part(dir.string(), 1, 0, 1), scan_fingerprint(scan),
                        {filled(scan, 1)});
  const auto refusal = [&](const Scan& other) {
    try {
      read_checkpoint(dir.string(), other);
    } catch (const CheckpointError& e) {
      return std::string(e.what());
    }
    return std::string("(used)");
  };
  // The same settings written otherwise (integers as reals) are the same scan.
  EXPECT_EQ(refusal(small_scan("width = 12.0\nheight = 1.2e1\nbond_number = [1e1, 100]\n")),
            "(used)");
  const Scan wider = small_scan("width = 14\nheight = 12\nbond_number = [10, 100]\n");
  EXPECT_NE(refusal(wider).find("key 'system.width' is `12.0` in the checkpoint's scan and `14.0` "
                                "in this one"),
            std::string::npos)
      << refusal(wider);
  // A key set on one side only is named with `(none)` on the other.
  const std::string rough =
      refusal(small_scan("width = 12\nheight = 12\nbond_number = [10, 100]\nfriction = 0.5\n"));
  EXPECT_NE(rough.find("key 'system.friction' is `(none)` in the checkpoint's scan and `0.5` in "
                       "this one"),
            std::string::npos)
      << rough;
  // Another build: its program line (and so its fingerprint) differs.
  std::string text;
  {
    std::ifstream in(dir.string() + "/scan");
    text.assign(std::istreambuf_iterator<char>(in), {});
  }
  std::ofstream(dir.string() + "/scan")
      << "loosepack 0.0.1 (commit 0000000, Serial)" << text.substr(text.find('\n'));
  EXPECT_NE(refusal(wider).find("it was written by loosepack 0.0.1 (commit 0000000, Serial), "
                                "this is loosepack "),
            std::string::npos)
      << refusal(wider);
}

// Largest expected cost first, each to the least loaded rank: one protocol-A member as costly
// as all the others together gets a rank of its own; the shards are disjoint and complete.
TEST(Checkpoint, ShardsBalanceExpectedCost) {
  Scan scan = parse_scan(
      "[scan]\nseeds = 1\n[[point]]\nprotocol = \"A\"\nwidth = 40\nheight = 40\n"
      "bond_number = 0\n"
      "[[point]]\nprotocol = \"C\"\nwidth = 20\nheight = 20\n[[point]]\nprotocol = \"C\"\n"
      "width = 20\nheight = 20\n[[point]]\nprotocol = \"B\"\nwidth = 20\nheight = 20\n"
      "[observables]\nlower_half_from = 2\n",
      "test.toml");
  const auto members = members_of(scan);
  const auto shards = shard_members(members, 2);
  ASSERT_EQ(shards.size(), 2u);
  // A at Bo = 0: ~ 40 * 40^2.5 / h against C: 20 * 20^2 / h each: A alone outweighs the rest.
  EXPECT_GT(expected_cost(members[0]),
            expected_cost(members[1]) + expected_cost(members[2]) + expected_cost(members[3]));
  EXPECT_EQ(shards[0], std::vector<std::size_t>({0}));
  EXPECT_EQ(shards[1], std::vector<std::size_t>({1, 2, 3}));
  const auto three = shard_members(members, 3);
  std::vector<int> seen(members.size(), 0);
  for (const auto& s : three)
    for (auto k : s) ++seen[k];
  EXPECT_EQ(seen, std::vector<int>(members.size(), 1));
  EXPECT_EQ(shard_members({}, 4).size(), 4u);
}

// balance_costs puts the largest cost first, each on the least loaded rank (ties to the lower
// rank): four equal costs alternate over two ranks, two small ones go with one large one each,
// and no rank (0) means one.
TEST(Checkpoint, BalanceCostsLargestFirstOnTheLeastLoadedRank) {
  EXPECT_EQ(balance_costs({1.0, 1.0, 1.0, 1.0}, 2),
            (std::vector<std::vector<std::size_t>>{{0, 2}, {1, 3}}));
  const auto left = balance_costs({0.1, 1.0, 0.1, 1.0}, 2);
  ASSERT_EQ(left.size(), 2u);
  EXPECT_EQ(left[0], std::vector<std::size_t>({0, 1}));
  EXPECT_EQ(left[1], std::vector<std::size_t>({2, 3}));
  EXPECT_EQ(balance_costs({}, 3), std::vector<std::vector<std::size_t>>(3));
  EXPECT_EQ(balance_costs({2.0, 1.0}, 0), (std::vector<std::vector<std::size_t>>{{0, 1}}));
}

namespace {
// A protocol-A member of the given Bond number and box, at the time step of Bo = 1e3.
Member deposit_member(double bo, double width, double height) {
  Member m;
  m.protocol = Protocol::A;
  m.params.bond_number = bo;
  m.params.width = width;
  m.params.height = height;
  m.params.time_step = 0.0028;
  return m;
}
}  // namespace

// The cost model's shape: at the same box and time step a protocol-A member expects less the
// larger the Bond number (cohesion shortens each relaxation), and more in a taller or wider
// box, growing with the height up to 60 R faster at Bo = 1e3 than at Bo = 0 (avalanches grow
// with the height above them) and with the width faster than the number of disks; a member
// part of the way up has behind it the cost of a member as tall as its deposit, below 60 R and
// above (where the height exponent changes). Its numbers are checked against the recorded
// measurements it was fitted on, not here: tests/python/test_cost_model.py.
TEST(Checkpoint, ExpectedCostFallsWithTheBondNumberAndGrowsWithTheBox) {
  double before = std::numeric_limits<double>::infinity();
  for (double bo : {0.0, 1.0, 10.0, 100.0, 1000.0}) {
    const double c = expected_cost(deposit_member(bo, 40.0, 60.0));
    EXPECT_LT(c, before) << "Bo = " << bo;
    before = c;
  }
  EXPECT_GT(expected_cost(deposit_member(1e3, 40.0, 120.0)),
            expected_cost(deposit_member(1e3, 40.0, 60.0)));
  // Twice as wide: twice the disks, each step over twice the deposit.
  EXPECT_GT(expected_cost(deposit_member(1e3, 80.0, 60.0)),
            2.0 * expected_cost(deposit_member(1e3, 40.0, 60.0)));
  const auto taller = [](double bo) {
    return expected_cost(deposit_member(bo, 40.0, 60.0)) /
           expected_cost(deposit_member(bo, 40.0, 30.0));
  };
  EXPECT_GT(taller(1e3), taller(0.0));
  for (double height : {30.0, 60.0, 120.0, 400.0}) {
    const Member tall = deposit_member(1e3, 40.0, 400.0);
    const Member part = deposit_member(1e3, 40.0, height);
    EXPECT_NEAR(running_cost(tall, MemberPhase::Deposit, height / 400.0), expected_cost(part),
                1e-12 * expected_cost(part))
        << "H = " << height;
  }
  // Disks of radius 2 in a box and with a time step scaled to them are the same system (lengths
  // in R, times in sqrt(R/g)), and cost the same.
  Member doubled = deposit_member(1e3, 80.0, 120.0);
  doubled.params.radius = 2.0;
  doubled.params.time_step = 0.0028 * std::sqrt(2.0);
  EXPECT_DOUBLE_EQ(expected_cost(doubled), expected_cost(deposit_member(1e3, 40.0, 60.0)));
}

// A member going on from its snapshot is expected to cost what is left of it: a deposit half as
// tall as its box has (1/2)^q of a protocol-A member's cost behind it (q the height exponent, so
// less than half), a collapse half through its expected steps the ballistic deposit and half the
// collapse; one that has not begun, all of it.
TEST(Checkpoint, AMemberFromItsSnapshotIsExpectedToCostWhatIsLeft) {
  MemberSnapshot snap;
  snap.result.member = deposit_member(1e3, 40.0, 60.0);
  const double whole = expected_cost(snap.result.member);
  EXPECT_DOUBLE_EQ(cost_left(snap), whole);
  snap.stage.filled = 0.5;
  const double left = cost_left(snap);
  EXPECT_LT(left, whole);
  EXPECT_GT(left, 0.5 * whole);  // the upper half of a deposit is its costlier half
  EXPECT_NEAR(left, whole - running_cost(snap.result.member, MemberPhase::Deposit, 0.5),
              1e-12 * whole);
  MemberSnapshot collapse;
  collapse.result.member = snap.result.member;
  collapse.result.member.protocol = Protocol::C;
  collapse.phase = MemberPhase::Collapse;
  const Member& c = collapse.result.member;
  collapse.stage.steps = static_cast<long>(0.5 * collapse_steps(c.params));
  const double ballistic = running_cost(c, MemberPhase::Collapse, 0.0);
  // The steps are half the expected ones, rounded down: that share of the collapse is left.
  const double share_left =
      1.0 - static_cast<double>(collapse.stage.steps) / collapse_steps(c.params);
  ASSERT_NEAR(share_left, 0.5, 1.0 / collapse_steps(c.params));
  EXPECT_NEAR(cost_left(collapse), share_left * (expected_cost(c) - ballistic),
              1e-12 * expected_cost(c));
}

// A resumed MPI run shares out what the cost model leaves of each member: of four equal members,
// 0 and 2 nearly done (their snapshots 95 % filled), each rank gets one of them and one fresh
// member ({0, 1} and {2, 3}), and the ranks' costs left are equal; the whole costs would pair
// the nearly done ones on one rank ({0, 2} and {1, 3}, the shards' split).
TEST(Checkpoint, RanksShareWhatIsLeftOfEachMember) {
  std::vector<Member> todo;
  for (std::uint64_t id = 0; id < 4; ++id) {
    todo.push_back(deposit_member(1e3, 40.0, 60.0));
    todo.back().id = id;
  }
  std::vector<MemberSnapshot> started(2);
  for (std::size_t k = 0; k < 2; ++k) {
    started[k].result.member = todo[2 * k];
    started[k].stage.filled = 0.95;
  }
  const double whole = expected_cost(todo[0]);
  const double nearly_done = cost_left(started[0]);
  ASSERT_LT(nearly_done, 0.5 * whole);
  EXPECT_EQ(costs_left(todo, started),
            (std::vector<double>{nearly_done, whole, nearly_done, whole}));
  const RankShares shares = share_over_ranks(todo, started, 2);
  EXPECT_EQ(shares.members, (std::vector<std::vector<std::size_t>>{{0, 1}, {2, 3}}));
  EXPECT_EQ(shares.left, (std::vector<double>{whole + nearly_done, whole + nearly_done}));
  EXPECT_EQ(shares.expected, (std::vector<double>{2.0 * whole, 2.0 * whole}));
  EXPECT_EQ(shard_members(todo, 2), (std::vector<std::vector<std::size_t>>{{0, 2}, {1, 3}}));
  // A fresh run (nothing started) shares the whole costs, as the shards do.
  EXPECT_EQ(share_over_ranks(todo, {}, 2).members, shard_members(todo, 2));
}

// A ballistic deposit looks for each disk's landing place among all the disks before it
// (kernels/deposit.hpp): a box of W H costs ~ (W H)^2 where it is large, so four times the area
// costs nearly sixteen times as much, and a deposit half done has less than half behind it.
TEST(Checkpoint, ABallisticDepositCostsTheSquareOfItsArea) {
  Member m;
  m.protocol = Protocol::B;
  m.params.width = 100.0;
  m.params.height = 400.0;
  const double small = expected_cost(m);
  m.params.width = 200.0;
  m.params.height = 800.0;
  const double paper = expected_cost(m);
  EXPECT_GT(paper, 15.0 * small);
  EXPECT_LT(paper, 16.0 * small);
  EXPECT_LT(running_cost(m, MemberPhase::Ballistic, 0.5), 0.3 * paper);
  EXPECT_DOUBLE_EQ(running_cost(m, MemberPhase::Ballistic, 1.0), paper);
}

TEST(Checkpoint, RunningMembersGoOnBitForBit) { expect_running_members_go_on(""); }

// The same with the collapse's averaged rest test (rest.average_span), whose spans a snapshot
// takes with it: spans of 5 steps, short enough to end a collapse before the speed test alone
// does. The test adds a way to be at rest and changes nothing before it, so no collapse ends
// later than with the speed test alone.
TEST(Checkpoint, RunningMembersOfAveragedRestGoOnBitForBit) {
  std::vector<MemberResult> averaged;
  expect_running_members_go_on("", "[rest]\naverage_span = 0.05\n", &averaged);
  const Scan off = interrupted_scan("", "[rest]\naverage_span = 0\n");
  const auto speed_only = run_members(off, members_of(off), RunHooks{});
  ASSERT_EQ(averaged.size(), speed_only.size());
  int earlier = 0;
  for (std::size_t k = 0; k < averaged.size(); ++k) {
    if (averaged[k].member.protocol != Protocol::C) continue;
    EXPECT_LE(averaged[k].steps, speed_only[k].steps) << "member " << k;
    earlier += averaged[k].steps < speed_only[k].steps ? 1 : 0;
  }
  EXPECT_GE(earlier, 1);
}

// The same where a step's solve goes on over launches (solver.sweeps_per_launch): a member
// inside a step gives its snapshot once the step has ended.
TEST(Checkpoint, RunningMembersOfSplitSolvesGoOnBitForBit) {
  expect_running_members_go_on(
      "kind = \"coloured_accelerated_gauss_seidel\"\nsweeps_per_launch = 4\n");
}

// A stop hands over the running members as they were when it came: each member's snapshot is
// taken once, at the stop's first pass of the loop, or, for a member inside a step whose solve
// goes on over launches, once that step has ended; the members stepped in between are not
// snapshotted again. So a stop gives the snapshots a checkpoint's round started at the same
// pass gives, among them some taken after the round's first pass.
TEST(Checkpoint, AStopTakesEachRunningMembersSnapshotOnce) {
  const Scan scan = parse_scan(
      "[scan]\nseeds = 4\nbatch_size = 4\nprotocol = \"A\"\n"
      "[system]\nwidth = 16\nheight = 16\nbond_number = 1000\ntime_step = 0.0028\n"
      "[solver]\nkind = \"coloured_accelerated_gauss_seidel\"\nsweeps_per_launch = 2\n",
      "test.toml");
  const auto members = members_of(scan);
  // The snapshots of a round started at the top of pass `at + 1` of the run's loop (`at`
  // progress reports before it), by a stop or by a checkpoint; `later`: handed over at a later
  // pass (a member was inside a step when the round started).
  const auto round_at = [&](long at, bool by_stop, bool* later) {
    volatile std::sig_atomic_t stop = 0;
    long n = 0;
    std::vector<MemberSnapshot> got;
    RunHooks hooks;
    hooks.stop = &stop;
    hooks.progress = [&](const Progress&) {
      if (++n == at && by_stop) stop = 1;
    };
    hooks.snapshot_wanted = [&] { return !by_stop && n == at; };
    hooks.snapshots = [&](std::vector<MemberSnapshot> snaps) {
      if (!got.empty()) return;
      *later = n > at;
      got = std::move(snaps);
      stop = 1;  // the checkpoint's run ends here too
    };
    run_members(scan, members, hooks);
    std::sort(got.begin(), got.end(), [](const MemberSnapshot& a, const MemberSnapshot& b) {
      return a.result.member.id < b.result.member.id;
    });
    return got;
  };
  long at = 40;
  bool later = false;
  std::vector<MemberSnapshot> checkpoint;
  for (; at < 400 && !later; ++at) checkpoint = round_at(at, false, &later);
  ASSERT_TRUE(later) << "no round found a member inside a step";
  bool stop_later = false;
  const auto stopped = round_at(at - 1, true, &stop_later);
  EXPECT_TRUE(stop_later);
  ASSERT_EQ(stopped.size(), checkpoint.size());
  bool moving = false;
  for (std::size_t k = 0; k < stopped.size(); ++k) {
    const auto &a = stopped[k].system, &b = checkpoint[k].system;
    EXPECT_EQ(stopped[k].result.member.id, checkpoint[k].result.member.id);
    EXPECT_EQ(a.status.steps, b.status.steps) << "member " << k;
    ASSERT_EQ(a.disks.size(), b.disks.size());
    for (std::size_t d = 0; d < a.disks.size(); ++d) {
      EXPECT_EQ(a.disks[d].x, b.disks[d].x);
      EXPECT_EQ(a.disks[d].y, b.disks[d].y);
    }
    moving = moving || a.status.active;
  }
  EXPECT_TRUE(moving);  // some were stepped while the others ended their steps
}

// A stop whose grace (RunHooks::stop_grace) runs out while members are inside a step hands over
// the others' snapshots and names those (missed_at_stop): none of the running members is left
// out silently. With no grace, a stop that comes while a member's solve goes on over launches
// hands over at once.
TEST(Checkpoint, AStopPastItsGraceNamesTheMembersInsideAStep) {
  const Scan scan = parse_scan(
      "[scan]\nseeds = 4\nbatch_size = 4\nprotocol = \"A\"\n"
      "[system]\nwidth = 16\nheight = 16\nbond_number = 1000\ntime_step = 0.0028\n"
      "[solver]\nkind = \"coloured_accelerated_gauss_seidel\"\nsweeps_per_launch = 1\n",
      "test.toml");
  const auto members = members_of(scan);
  bool found = false;
  for (long at = 40; at < 400 && !found; ++at) {
    volatile std::sig_atomic_t stop = 0;
    long n = 0, handed_at = -1;
    std::vector<std::uint64_t> snapped, missed;
    RunHooks hooks;
    hooks.stop = &stop;
    hooks.stop_grace = 0.0;
    hooks.progress = [&](const Progress&) {
      if (++n == at) stop = 1;
    };
    hooks.snapshots = [&](std::vector<MemberSnapshot> snaps) {
      handed_at = n;
      for (const auto& snap : snaps) snapped.push_back(snap.result.member.id);
    };
    hooks.missed_at_stop = [&](const std::vector<std::uint64_t>& ids) {
      EXPECT_TRUE(snapped.empty()) << "named after the hand-over";
      missed = ids;
    };
    const auto finished = run_members(scan, members, hooks);
    ASSERT_EQ(handed_at, at) << "the stop waited past its grace of 0 s";
    if (missed.empty()) continue;  // every member was between two steps
    found = true;
    // Every member is either finished, handed over or named, exactly once.
    std::vector<std::uint64_t> all = snapped;
    all.insert(all.end(), missed.begin(), missed.end());
    for (const auto& r : finished) all.push_back(r.member.id);
    std::sort(all.begin(), all.end());
    std::vector<std::uint64_t> expected;
    for (const auto& m : members) expected.push_back(m.id);
    EXPECT_EQ(all, expected);
  }
  EXPECT_TRUE(found) << "no stop found a member inside a step";
}
