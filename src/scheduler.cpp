// The slot scheduler of run_members (src/member_run.hpp): members take batch slots in order, a
// finished member's slot takes the next member at once, and around the protocol phases'
// rounds the scheduler reports progress, hands over snapshots of running members and stops.
#include <Kokkos_Core.hpp>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "fault_injection.hpp"
#include "loosepack/geometry.hpp"
#include "member_run.hpp"
#include "src/launch_count.hpp"

namespace loosepack {

namespace {
// Whether the default execution space runs on a device whose memory the host cannot read.
constexpr bool kOnDevice =
    !Kokkos::SpaceAccessibility<Kokkos::HostSpace,
                                Kokkos::DefaultExecutionSpace::memory_space>::accessible;
// With timing: adds its scope's wall time (fenced), launches and copies to a StageCost.
class CostLap {
 public:
  explicit CostLap(StageCost* cost) : cost_(cost) {
    if (!cost_) return;
    Kokkos::fence();
    timer_.reset();
    at_ = launch_counts();
  }
  CostLap(const CostLap&) = delete;
  CostLap& operator=(const CostLap&) = delete;
  ~CostLap() {
    if (!cost_) return;
    Kokkos::fence();
    const LaunchCounts now = launch_counts();
    cost_->seconds += timer_.seconds();
    cost_->launches += now.launches - at_.launches;
    cost_->copies += now.copies - at_.copies;
  }

 private:
  StageCost* cost_;
  Kokkos::Timer timer_;
  LaunchCounts at_;
};
}  // namespace

double progress_eta(const Progress& p, double elapsed) {
  const double since = p.fraction - p.start_fraction;
  if (since < 0.01 || p.fraction >= 1.0) return -1.0;
  return elapsed * (1.0 - p.fraction) / since;
}

double run_eta(const std::vector<Progress>& ranks, const std::vector<char>& finished,
               const Progress& all, double elapsed) {
  double eta = -1.0;
  for (std::size_t r = 0; r < ranks.size(); ++r) {
    const double f = ranks[r].fraction;
    if (finished[r] || std::isnan(f)) continue;  // done, or a rank with no share (0 of 0)
    if (f >= 1.0) return -1.0;  // its last member past the model's cost: no estimate
    const double left = progress_eta(ranks[r], elapsed);
    if (left < 0.0) return progress_eta(all, elapsed);  // not yet 1 % on: the whole run's
    eta = std::max(eta, left);
  }
  return eta;
}

int default_batch_size() {
  if (kOnDevice) return 4096;
  return Kokkos::DefaultExecutionSpace().concurrency() > 1 ? 64 : 4;
}

SolverKind default_solver_kind() {
  return kOnDevice ? SolverKind::ColouredAcceleratedGaussSeidel
                   : SolverKind::AcceleratedGaussSeidel;
}

int default_sweeps_per_launch(std::size_t systems) { return kOnDevice && systems > 1 ? 8 : 0; }

bool default_fused_step(SolverKind kind) { return !kOnDevice && fused_step_solver(kind); }

void resolve_backend_defaults(Scan& scan, std::size_t members) {
  if (scan.batch_size == 0) scan.batch_size = default_batch_size();
  if (!scan.solver_kind_given) scan.solver.kind = default_solver_kind();
  if (!scan.sweeps_per_launch_given && scan.solver.sweeps_per_launch == 0 &&
      scan.solver.kind == SolverKind::ColouredAcceleratedGaussSeidel)
    scan.solver.sweeps_per_launch =
        default_sweeps_per_launch(std::min(members, static_cast<std::size_t>(scan.batch_size)));
  if (!scan.fused_step_given) scan.solver.fused_step = default_fused_step(scan.solver.kind);
}

std::vector<MemberResult> run_members(const Scan& scan, const std::vector<Member>& members,
                                      const RunHooks& hooks,
                                      const std::vector<MemberSnapshot>& resume) {
  if (members.empty()) return {};
  return MemberRun(scan, members, hooks, resume).run();
}

MemberRun::MemberRun(const Scan& scan, const std::vector<Member>& members, const RunHooks& hooks,
                     const std::vector<MemberSnapshot>& resume)
    : scan_(scan), members_(members), hooks_(hooks) {
  resolve_backend_defaults(scan_, members.size());
  results_.resize(members.size());
  done_.assign(members.size(), 0);
  size_slots();
  n_slots_ = std::min(members.size(), static_cast<std::size_t>(scan_.batch_size));
  std::vector<SystemSetup> setups;
  for (std::size_t k = 0; k < n_slots_; ++k) setups.push_back(setup_of(members[k]));
  batch_ = std::make_unique<Batch>(setups, scan_.solver, scan_.rest);
  batch_->set_timing(hooks.stage_costs != nullptr);
  make_regions();
  slots_.resize(n_slots_);
  for (const auto& snap : resume) snapshot_of_[snap.result.member.id] = &snap;
  for (const auto& m : members) total_cost_ += expected_cost(m);
  wake_ = kWakeFactor * scan_.rest.speed;
}

SystemSetup MemberRun::setup_of(const Member& m) const {
  SystemSetup su;
  su.params = m.params;
  su.params.gravity_on = !deposits_ballistically(m);              // B and C deposit without gravity
  if (m.protocol == Protocol::A) su.params.capture_radius = 1.0;  // A drops by touch: none
  su.capacity = capacity_;
  su.grid_cells = cells_;
  su.seed = scan_.seed;
  su.member = m.id;
  su.tolerance = scan_.tolerance(m.protocol);
  su.max_sweeps = scan_.max_sweeps(m.protocol, m.params);
  su.newton_every = scan_.newton_every(m.params);
  inject_faults(m, su);
  return su;
}

// Slots and regions are sized for every member of the scan, not only those of this run: a
// region's reach depends on the tallest (src/region.cpp), and a member's result must not depend
// on which members share its run (MPI shards, resumed runs). The run's own members count too:
// run_members may be given members that the scan's points do not list.
std::vector<Member> MemberRun::members_sized_for() const {
  std::vector<Member> sized = members_of(scan_);
  sized.insert(sized.end(), members_.begin(), members_.end());
  return sized;
}

void MemberRun::size_slots() {
  for (const auto& m : members_sized_for()) {
    capacity_ = std::max(capacity_, member_capacity(m.params));
    cells_ = std::max(cells_, grid_cells_needed(setup_of(m)));
  }
}

// Relaxation regions for the slow depositions, when the scan asks for them; sized, like the
// slots, for every member of the scan.
void MemberRun::make_regions() {
  if (scan_.protocol.region_radius <= 0.0) return;
  std::vector<SystemParams> slow;
  double tallest = 0.0;
  for (const auto& m : members_sized_for())
    if (!deposits_ballistically(m)) {
      slow.push_back(m.params);
      tallest = std::max(tallest, m.params.height);
    }
  if (slow.empty()) return;
  RegionSettings rs;
  rs.radius = scan_.protocol.region_radius;
  rs.max_disks = scan_.protocol.region_max_disks;
  // For the largest region: the last round's radius (start_region).
  rs.max_height = region_slot_height(region_round_radius(rs.radius, kMaxRegionRounds - 1), tallest);
  regions_ =
      std::make_unique<Regions>(static_cast<int>(n_slots_), slow, rs, scan_.solver, scan_.rest);
  regions_->set_timing(hooks_.stage_costs != nullptr);
}

std::vector<MemberResult> MemberRun::run() {
  for (std::size_t k = 0; k < n_slots_; ++k) begin(k);
  Kokkos::Timer loop_timer;  // with timing: the scheduler's share of the loop (collect_stage_costs)
  const LaunchCounts at_start = launch_counts();
  for (;;) {
    // Every member goes on from here after a snapshot: one inside a step (its solve going on
    // over launches) gives its snapshot once the step ends.
    if (stopped()) break;
    advance_ballistic();
    advance_deposit();
    report();
    if (!any_busy()) break;
    if (any_dynamic()) advance_dynamics();
  }
  if (hooks_.stage_costs) {
    Kokkos::fence();
    const LaunchCounts now = launch_counts();
    collect_stage_costs(loop_timer.seconds(), now.launches - at_start.launches,
                        now.copies - at_start.copies);
  }
  std::vector<MemberResult> finished;
  for (std::size_t k = 0; k < results_.size(); ++k)
    if (done_[k]) finished.push_back(std::move(results_[k]));
  return finished;
}

// With timing: the stages of the batch's steps, the regions' ("region ..."), then "scheduler",
// what the loop did between the steps (deposits, events, phase changes, progress): the loop's
// seconds, launches and copies less the stages' and the snapshots', over the batch's steps; then
// "snapshots", the running members' snapshots taken and handed over (the checkpoints written).
void MemberRun::collect_stage_costs(double loop_seconds, long launches, long copies) const {
  auto& costs = *hooks_.stage_costs;
  costs = batch_->stage_costs();
  if (regions_)
    for (StageCost cost : regions_->stage_costs()) {
      cost.name = "region " + cost.name;
      costs.push_back(std::move(cost));
    }
  StageCost between;
  between.name = "scheduler";
  between.steps = costs.empty() ? 0 : costs.front().steps;
  between.seconds = loop_seconds;
  between.launches = launches;
  between.copies = copies;
  StageCost snapshots = snapshot_cost_;  // all zero where none are taken
  snapshots.name = "snapshots";
  snapshots.steps = between.steps;
  const auto less = [&](const StageCost& cost) {
    between.seconds -= cost.seconds;
    between.launches -= cost.launches;
    between.copies -= cost.copies;
  };
  for (const auto& cost : costs) less(cost);
  less(snapshots);
  costs.push_back(std::move(between));
  if (hooks_.snapshots) costs.push_back(std::move(snapshots));
}

// Puts the next member into slot k (from its snapshot where it has one), or empties the slot.
void MemberRun::begin(std::size_t k) {
  Slot& sl = slots_[k];
  const int s = static_cast<int>(k);
  if (next_ >= members_.size()) {
    set_phase(k, Phase::Empty);
    return;
  }
  sl = Slot{};
  sl.member = next_++;
  const Member& m = members_[sl.member];
  inject_error(m);
  sl.start = Clock::now();
  if (regions_) {
    sl.region_steps = regions_->steps(s);
    sl.region_sweeps = regions_->sweeps(s);
  }
  const auto from = snapshot_of_.find(m.id);
  if (from != snapshot_of_.end()) return go_on_from(k, *from->second);
  if (sl.member >= n_slots_) batch_->reset(s, setup_of(m));  // the first ones are loaded
  sl.result.member = m;
  set_phase(k, deposits_ballistically(m) ? Phase::Ballistic : Phase::Deposit);
}

// The member of slot k goes on from its snapshot, taken at the top of run()'s loop.
void MemberRun::go_on_from(std::size_t k, const MemberSnapshot& snap) {
  Slot& sl = slots_[k];
  const int s = static_cast<int>(k);
  const Member& m = members_[sl.member];
  if (!goes_on_from(snap.phase))
    throw std::invalid_argument("the snapshot of member " + std::to_string(m.id) +
                                " has no phase a member goes on from");
  if (snap.region && !regions_)
    throw std::invalid_argument("the snapshot of member " + std::to_string(m.id) +
                                " is inside a relaxation region, and this run has none");
  SystemSetup su = setup_of(m);
  su.disks = snap.system.disks;
  batch_->reset(s, su);
  batch_->restore(s, snap.system);  // active as the snapshot's phase needs
  if (snap.region) regions_->resume(*batch_, s, *snap.region);
  static_cast<MemberStage&>(sl) = snap.stage;
  sl.phase = snap.phase;
  sl.result = snap.result;
  sl.result.member = m;
  sl.start -= std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(snap.result.wall_time));
  if (regions_) {  // the region steps before the snapshot are the member's, not this run's
    sl.region_steps = regions_->steps(s) - snap.result.steps;
    sl.region_sweeps = regions_->sweeps(s) - snap.result.sweeps;
  }
  progress_.disks_deposited += sl.deposited;
  progress_.disks_before += sl.deposited;
}

// Whether a disk of a finished member lies outside its box: above escape_height or with its
// centre below the floor. Only a solution that blew up gets there; its member fails
// (Failure::Escaped) instead of passing its displacements of hundreds of R into the aggregates.
static bool escaped(const std::vector<Disk>& disks, const SystemParams& p) {
  const double top = escape_height(p);
  return std::any_of(disks.begin(), disks.end(),
                     [&](const Disk& d) { return !(d.y <= top) || d.y < 0.0; });
}

// The member of slot k has finished (or failed): its result is collected and handed to the
// hooks, and the slot takes the next member.
void MemberRun::finish(std::size_t k) {
  Slot& sl = slots_[k];
  const int s = static_cast<int>(k);
  MemberResult& r = sl.result;
  const auto& st = batch_->status(s);
  r.failure = sl.gave_up ? Failure::Unconverged : sl.runaway ? Failure::Runaway : st.failure;
  r.steps = st.steps;
  r.sweeps = st.sweeps;
  if (regions_) {
    r.steps += regions_->steps(s) - sl.region_steps;
    r.sweeps += regions_->sweeps(s) - sl.region_sweeps;
  }
  r.wall_time = std::chrono::duration<double>(Clock::now() - sl.start).count();
  const std::vector<Disk> disks = batch_->disks(s);
  r.contacts = batch_->contacts(s);
  if (r.failure == Failure::None && escaped(disks, batch_->params(s))) r.failure = Failure::Escaped;
  // An overlap beyond kMaxFinalOverlap R is a failure too. It is measured on the disks as they
  // ended, not on the contacts' gaps, which are those the last step started from.
  if (r.failure == Failure::None &&
      max_overlap(disks, batch_->params(s).width) > kMaxFinalOverlap * batch_->params(s).radius)
    r.failure = Failure::Overlap;
  for (const auto& d : disks) {
    r.x.push_back(d.x);
    r.y_i.push_back(d.y_deposit);
    r.y_e.push_back(d.y);
    r.radius.push_back(d.radius);
    if (r.failure == Failure::None) continue;
    r.vx.push_back(d.vx);
    r.vy.push_back(d.vy);
    r.w.push_back(d.w);
  }
  taken_.erase(
      std::remove_if(taken_.begin(), taken_.end(),
                     [&](const MemberSnapshot& t) { return t.result.member.id == r.member.id; }),
      taken_.end());
  done_cost_ += expected_cost(members_[sl.member]);
  if (hooks_.finished) hooks_.finished(r);
  results_[sl.member] = std::move(r);
  done_[sl.member] = 1;
  ++progress_.members_done;
  begin(k);
}

// True when the run is to return now: after a stop, once every running member has handed over
// a snapshot (or RunHooks::stop_grace has passed). Otherwise takes the snapshots a checkpoint asks
// for.
bool MemberRun::stopped() {
  if (!hooks_.stop || !*hooks_.stop) {
    take_snapshots(false, false);
    return false;
  }
  if (stopped_at_ == Clock::time_point{}) stopped_at_ = Clock::now();
  const bool last_chance =
      std::chrono::duration<double>(Clock::now() - stopped_at_).count() >= hooks_.stop_grace;
  return take_snapshots(true, last_chance);
}

// Snapshots of running members for checkpoints (RunHooks::snapshots): those asked for, taken
// slot by slot when each can be, and handed over when every running member has one. At a stop,
// every member's as it was then, and the run goes on (for at most stop_grace) until the members
// inside a step have ended it; those still inside one then go to RunHooks::missed_at_stop. True
// when handed over.
bool MemberRun::take_snapshots(bool stopping, bool last_chance) {
  if (!hooks_.snapshots) return true;
  // A stop starts a round of its own (a checkpoint's round under way included), so that every
  // snapshot handed over is of the stop; each member's is taken once, as soon as it can give one.
  const bool round_starts =
      stopping ? !stop_round_
               : !snapshots_wanted_ && hooks_.snapshot_wanted && hooks_.snapshot_wanted();
  if (round_starts) {
    snapshots_wanted_ = true;
    stop_round_ = stopping;
    taken_.clear();
  }
  if (!snapshots_wanted_) return false;
  CostLap lap(hooks_.stage_costs ? &snapshot_cost_ : nullptr);
  std::vector<std::uint64_t> inside_a_step;  // running members without a snapshot of this round
  for (std::size_t k = 0; k < n_slots_; ++k) {
    const Slot& sl = slots_[k];
    if (sl.phase == Phase::Empty) continue;
    const std::uint64_t id = members_[sl.member].id;
    const auto have = std::find_if(taken_.begin(), taken_.end(), [&](const MemberSnapshot& t) {
      return t.result.member.id == id;
    });
    if (!goes_on_from(sl.phase) || mid_step(k)) {
      if (have == taken_.end()) inside_a_step.push_back(id);
      continue;
    }
    if (have == taken_.end()) taken_.push_back(snapshot(k));
  }
  if (!inside_a_step.empty() && !last_chance) return false;
  if (stopping && !inside_a_step.empty() && hooks_.missed_at_stop)
    hooks_.missed_at_stop(inside_a_step);
  hooks_.snapshots(std::move(taken_));
  taken_.clear();
  snapshots_wanted_ = false;
  return true;
}

MemberSnapshot MemberRun::snapshot(std::size_t k) const {
  const Slot& sl = slots_[k];
  const int s = static_cast<int>(k);
  MemberSnapshot snap;
  snap.result = sl.result;
  snap.result.steps = regions_ ? regions_->steps(s) - sl.region_steps : 0;
  snap.result.sweeps = regions_ ? regions_->sweeps(s) - sl.region_sweeps : 0;
  snap.result.wall_time = std::chrono::duration<double>(Clock::now() - sl.start).count();
  snap.phase = sl.phase;
  snap.stage = sl;
  snap.system = batch_->state(s);
  if (sl.phase == Phase::Region) snap.region = regions_->state(s);
  return snap;
}

void MemberRun::report() {
  if (!hooks_.progress) return;
  double running = 0.0;
  progress_.collapsing = progress_.relaxing_long = 0;
  std::size_t collapse = slots_.size(), relax = slots_.size();  // the longest of each
  const auto longer = [&](std::size_t k, std::size_t than) {
    return than == slots_.size() || slots_[k].steps > slots_[than].steps;
  };
  for (std::size_t k = 0; k < slots_.size(); ++k) {
    Slot& sl = slots_[k];
    running += running_share(sl);
    if (sl.phase == Phase::Collapse) {
      ++progress_.collapsing;
      if (longer(k, collapse)) collapse = k;
    } else if ((sl.phase == Phase::Relax || sl.phase == Phase::Region) &&
               sl.steps >= kLongRelaxation) {
      ++progress_.relaxing_long;
      if (longer(k, relax)) relax = k;
    }
  }
  const bool collapsing = collapse < slots_.size(), relaxing = relax < slots_.size();
  progress_.collapse_steps = collapsing ? slots_[collapse].steps : 0;
  progress_.collapse_speed = collapsing ? speed_over_rest(collapse) : 0.0;
  const double mean_speed =
      collapsing ? batch_->status(static_cast<int>(collapse)).mean_speed : -1.0;
  progress_.collapse_mean_speed = mean_speed >= 0.0 ? mean_speed / scan_.rest.speed : -1.0;
  progress_.relax_steps = relaxing ? slots_[relax].steps : 0;
  progress_.relax_speed = relaxing ? speed_over_rest(relax) : 0.0;
  progress_.fraction = (done_cost_ + running) / total_cost_;
  if (!reported_) progress_.start_fraction = progress_.fraction;
  reported_ = true;
  hooks_.progress(progress_);
}

// The largest speed of slot k's system after its last step (its region's, in a region), over
// rest.speed: what the rest test compares; -1 where the system has not stepped since it was
// loaded (a region cut again around the moving disks), whose speed is not known yet.
double MemberRun::speed_over_rest(std::size_t k) const {
  const int s = static_cast<int>(k);
  const SystemStatus& st =
      slots_[k].phase == Phase::Region ? regions_->status(s) : batch_->status(s);
  return st.steps > 0 ? st.rest_speed(scan_.rest.spin) / scan_.rest.speed : -1.0;
}

// Slot sl's running_cost, computed again only where its phase or its progress changed: report()
// runs between every two steps over every slot (on a device, thousands), most of them unchanged.
double MemberRun::running_share(Slot& sl) const {
  if (sl.phase == Phase::Empty) return 0.0;
  const Member& m = members_[sl.member];
  const double got = member_progress(m, sl.phase, sl);
  if (sl.phase != sl.share_phase || got != sl.share_got) {
    sl.share = running_cost(m, sl.phase, got);
    sl.share_phase = sl.phase;
    sl.share_got = got;
  }
  return sl.share;
}

MemberRun::Mask MemberRun::mask_of(Phase phase, bool* any) const {
  Mask m(n_slots_, 0);
  *any = false;
  for (std::size_t k = 0; k < n_slots_; ++k)
    if (slots_[k].phase == phase) m[k] = 1, *any = true;
  return m;
}

bool MemberRun::any_dynamic() const {
  return std::any_of(slots_.begin(), slots_.end(), [](const Slot& sl) {
    return sl.phase == Phase::Relax || sl.phase == Phase::Collapse || sl.phase == Phase::Region;
  });
}

bool MemberRun::any_busy() const {
  return std::any_of(slots_.begin(), slots_.end(),
                     [](const Slot& sl) { return sl.phase != Phase::Empty; });
}

}  // namespace loosepack
