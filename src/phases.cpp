// The protocol phases of run_members (src/member_run.hpp; docs/MODEL.md, "Protocols"): one
// advance function per phase, each one round of every slot in that phase, and the transitions
// between phases.
//
//   Ballistic --(box full, C)--> Collapse --(rest or cap)--> finished
//   Ballistic --(box full, B or A at Bo = inf)--> finished
//   Deposit --(disk placed)--> Region, or Relax where no region fits
//   Region --(rest, no check due)--> Deposit (the event stays open until the next disk)
//   Region --(rest, check due / overflow)--> Relax (the whole system)
//   Relax --(check finds motion)--> Region (twice the radius of the last)
//   Relax or Region --(rest or cap)--> the event closes --> Deposit, or finished after the
//   final check (box full)
#include <algorithm>
#include <cmath>
#include <limits>

#include "kernels/random.hpp"
#include "loosepack/geometry.hpp"
#include "member_run.hpp"
#include "room_below.hpp"

namespace loosepack {

// --- The phases ---------------------------------------------------------------------------

// Ballistic deposition: one disk per slot and round.
void MemberRun::advance_ballistic() {
  bool any = false;
  const Mask ballistic = mask_of(Phase::Ballistic, &any);
  if (!any) return;
  auto placed = batch_->deposit(ballistic, DropRule::Capture);
  redraw_where_room(ballistic, DropRule::Capture, placed);
  for (std::size_t k = 0; k < n_slots_; ++k) {
    if (!ballistic[k]) continue;
    const int s = static_cast<int>(k);
    if (placed[k].placed)
      count_disk(k, placed[k]);
    else if (batch_->status(s).failure == Failure::None &&
             members_[slots_[k].member].protocol == Protocol::C)
      start_collapse(k);
    else
      finish(k);
  }
}

// Slow deposition: the next disk for every slot whose last one came to rest.
void MemberRun::advance_deposit() {
  bool any = false;
  const Mask depositing = mask_of(Phase::Deposit, &any);
  if (!any) return;
  auto placed = batch_->deposit(depositing, DropRule::Touch);
  redraw_where_room(depositing, DropRule::Touch, placed);
  // The open events close now: the new disk has not moved, the others have not since. When the
  // box is full the whole system is checked first, and that check belongs to the event.
  Mask open(n_slots_, 0);
  for (std::size_t k = 0; k < n_slots_; ++k) {
    if (!depositing[k] || !slots_[k].event_open) continue;
    if (placed[k].placed || batch_->status(static_cast<int>(k)).failure != Failure::None)
      open[k] = 1;
    else
      start_final_check(k);
  }
  if (std::find(open.begin(), open.end(), 1) != open.end()) close_events(open);
  for (std::size_t k = 0; k < n_slots_; ++k) {
    if (!depositing[k] || slots_[k].final_check) continue;
    if (placed[k].placed && batch_->status(static_cast<int>(k)).failure == Failure::None)
      start_relaxation(k, placed[k]);
    else
      finish(k);
  }
}

// The paper's stop rule for protocol A (StopRule::NoRoom; A at Bo = inf deposits ballistically
// with r_capt = 1, the same drop): each drop that would pass H is drawn again, once, uniformly
// among the abscissae where a disk of the mean radius lands below H (so the accepted drops are
// uniform over them, as if drawn again until one fits). The draw is keyed by the member and its
// disk count, so a resumed member draws the same. Where there is no such abscissa, the drop
// stays unplaced and the box is full.
void MemberRun::redraw_where_room(const Mask& depositing, DropRule rule,
                                  std::vector<Deposit>& placed) {
  if (scan_.protocol.stop_rule != StopRule::NoRoom) return;
  constexpr std::uint64_t kRoomDraws = std::uint64_t{1} << 62;  // apart from the drops' draws
  Mask again(n_slots_, 0);
  std::vector<double> x(n_slots_, 0.0);
  for (std::size_t k = 0; k < n_slots_; ++k) {
    const int s = static_cast<int>(k);
    if (!depositing[k] || placed[k].placed || batch_->status(s).failure != Failure::None ||
        members_[slots_[k].member].protocol != Protocol::A)
      continue;
    const SystemParams& p = batch_->params(s);
    const auto disks = batch_->disks(s);
    const double u =
        uniform01(scan_.seed, members_[slots_[k].member].id, kRoomDraws + disks.size());
    const auto at = free_abscissa(room_below(disks, p.width, p.height, p.radius), u);
    if (!at) continue;
    again[k] = 1;
    x[k] = *at;
  }
  if (std::find(again.begin(), again.end(), 1) == again.end()) return;
  const auto redrawn = batch_->deposit_at(again, x, rule);
  for (std::size_t k = 0; k < n_slots_; ++k)
    if (again[k]) placed[k] = redrawn[k];
}

// One step of every system in a dynamic phase (the batch's and the regions'), then what each
// slot's step means for its phase; a step whose solve goes on (mid_step) means nothing yet.
void MemberRun::advance_dynamics() {
  batch_->step();
  if (regions_) regions_->step();
  Mask closing(n_slots_, 0);
  for (std::size_t k = 0; k < n_slots_; ++k) {
    if (mid_step(k)) continue;  // its step goes on
    switch (slots_[k].phase) {
      case Phase::Region:
        advance_region(k, closing);
        break;
      case Phase::Relax:
        advance_relax(k, closing);
        break;
      case Phase::Collapse:
        advance_collapse(k);
        break;
      default:
        break;
    }
  }
  if (std::find(closing.begin(), closing.end(), 1) != closing.end()) close_events(closing);
}

// A step of slot k's relaxation region.
void MemberRun::advance_region(std::size_t k, Mask& closing) {
  Slot& sl = slots_[k];
  const int s = static_cast<int>(k);
  count_step(sl, regions_->status(s), batch_->params(s));
  if (sl.gave_up || sl.runaway) {
    regions_->stop(*batch_, s);
    finish(k);
    return;
  }
  // A region the check started (not the disk's first) is part of the check and ends as it
  // does: rest.steps steps without a disk above the wake speed, converged or not.
  auto state = regions_->poll(*batch_, s);
  if (state == Regions::State::Running && sl.rounds > 1 && sl.below_wake >= scan_.rest.steps) {
    regions_->stop(*batch_, s);
    state = Regions::State::Rested;
  }
  const bool check_due = sl.final_check || sl.deposited % scan_.protocol.region_check_every == 0;
  if (state == Regions::State::Running) {
    if (sl.steps < sl.cap) return;
    regions_->stop(*batch_, s);
    sl.event_capped = true;
    // The cap ends the disk's relaxation, its check too where one is due. The event stays open,
    // as after a region that rested (the next disk closes it as it is): the box full, the whole
    // system's final check belongs to it. A region of the final check itself ends it.
    if (sl.final_check) {
      closing[k] = 1;
    } else {
      sl.event_open = true;
      await_disk(k);
    }
  } else if (state == Regions::State::Rested && !check_due) {
    sl.event_open = true;
    await_disk(k);
  } else {  // rested, and the whole system's rest is checked; or the region overflowed
    relax_whole(k, state == Regions::State::Rested);
  }
}

// A step of slot k's whole system relaxing after a disk (or checking after a region).
void MemberRun::advance_relax(std::size_t k, Mask& closing) {
  if (!whole_step_counted(k)) return;
  Slot& sl = slots_[k];
  const int s = static_cast<int>(k);
  const auto& st = batch_->status(s);
  // The check after a region: rest.steps steps without motion suffice, converged or not (a
  // tall deposit's solve misses the tolerance on some steps; docs/MODEL.md).
  const bool still = sl.checking && sl.below_wake >= scan_.rest.steps;
  const bool done = st.at_rest || still || sl.steps >= sl.cap;
  if (!done && sl.checking && st.max_speed > wake_ && sl.rounds < kMaxRegionRounds) {
    // The whole system moves after the region came to rest: relax around what moves.
    std::vector<Regions::Point> seeds;
    for (const auto& d : batch_->disks(s))
      if (speed(d) > wake_) seeds.push_back({d.x, d.y});
    if (start_region(k, seeds)) return;
    sl.rounds = kMaxRegionRounds;  // it does not fit: the check goes on in the whole system
  }
  if (!done) return;
  sl.event_capped = sl.event_capped || (!st.at_rest && !still);
  closing[k] = 1;
}

// A step of slot k's collapse (C), sampled every observables.trajectory_interval steps.
void MemberRun::advance_collapse(std::size_t k) {
  if (!whole_step_counted(k)) return;
  Slot& sl = slots_[k];
  const auto& st = batch_->status(static_cast<int>(k));
  const bool done = st.at_rest || sl.steps >= sl.cap;
  if (done || sl.steps % scan_.observables.trajectory_interval == 0)
    sample(k, static_cast<double>(sl.steps));
  if (!done) return;
  sl.result.capped = st.at_rest ? 0 : 1;
  finish(k);
}

// Closes the avalanche events of the slots in `closing` (A): what moved since the disk was
// placed, a trajectory sample of the disks deposited so far; then the next disk, or, after the
// final check, the member's end.
void MemberRun::close_events(const Mask& closing) {
  const auto moved = batch_->close_events(closing, scan_.observables.event_threshold);
  for (std::size_t k = 0; k < n_slots_; ++k) {
    if (!closing[k]) continue;
    Slot& sl = slots_[k];
    AvalancheEvent ev;
    ev.moved = moved[k].moved;
    ev.downward = moved[k].downward;
    // A region's event ends as the whole system's does: rest.steps after its last step not at
    // rest (a check that finds nothing adds no steps). A capped event was not at rest on one of
    // its last rest.steps steps, so it keeps all its steps.
    ev.steps = std::min(sl.steps, sl.moved_until + scan_.rest.steps);
    ev.capped = sl.event_capped;
    sl.result.capped += ev.capped ? 1 : 0;
    sl.result.events.push_back(ev);
    sample(k, static_cast<double>(sl.deposited), static_cast<std::size_t>(sl.deposited));
    sl.event_open = false;
    if (sl.final_check)
      finish(k);
    else
      await_disk(k);
  }
}

// --- Phase transitions ---------------------------------------------------------------------

// The one place a slot's phase is set (but for a member going on from its snapshot, whose
// restored system is already as its phase needs): the batch steps the slot's system exactly
// in the phases Relax and Collapse.
void MemberRun::set_phase(std::size_t k, Phase to) {
  slots_[k].phase = to;
  batch_->set_active(static_cast<int>(k), to == Phase::Relax || to == Phase::Collapse);
}

// C: the box is full; gravity on, dynamics until rest.
void MemberRun::start_collapse(std::size_t k) {
  Slot& sl = slots_[k];
  sl.steps = 0;
  sample(k, 0.0);
  sl.cap = steps_for(k, scan_.protocol.max_collapse_time);
  batch_->set_gravity(static_cast<int>(k), true);
  const long span = steps_for(k, scan_.rest.average_span);  // (a tiny h could overflow an int)
  batch_->set_average_span(static_cast<int>(k),
                           static_cast<int>(std::min<long>(span, std::numeric_limits<int>::max())));
  set_phase(k, Phase::Collapse);
}

// A: a disk was placed; its relaxation starts in a region around it, or in the whole system.
void MemberRun::start_relaxation(std::size_t k, const Deposit& placed) {
  Slot& sl = slots_[k];
  count_disk(k, placed);
  sl.steps = 0;
  sl.moved_until = 0;
  sl.cap = steps_for(k, scan_.protocol.max_relax_time);
  sl.checking = false;
  sl.rounds = 0;
  sl.event_capped = false;
  if (!start_region(k, {{placed.x, placed.y}})) set_phase(k, Phase::Relax);
}

// A: the box is full after a disk whose region was not checked: the whole system's check, which
// belongs to that disk's event.
void MemberRun::start_final_check(std::size_t k) {
  Slot& sl = slots_[k];
  sl.final_check = true;
  sl.checking = true;
  sl.below_wake = 0;
  sl.cap = sl.steps + steps_for(k, scan_.protocol.max_relax_time);
  set_phase(k, Phase::Relax);
}

// A: after a region the whole system steps: its rest check where the region rested
// (`checking`), its relaxation where the region overflowed.
void MemberRun::relax_whole(std::size_t k, bool checking) {
  Slot& sl = slots_[k];
  sl.checking = checking;
  sl.below_wake = 0;
  // A check shares its disk's cap, but always has the rest.steps steps that find a quiet
  // deposit quiet (a region that rested just before the cap left it fewer: capped at once).
  if (checking) sl.cap = std::max(sl.cap, sl.steps + scan_.rest.steps);
  set_phase(k, Phase::Relax);
}

// A: a relaxation region around the seeds. Every region after the first of a disk (the check
// found motion where the last one rested) has twice the radius of the one before: what the
// region held fixed (the rest of a cohesive arm tipping about a pivot further away, the load of
// the column above) may be what moves. False where regions are off or the region does not fit.
bool MemberRun::start_region(std::size_t k, const std::vector<Regions::Point>& seeds) {
  Slot& sl = slots_[k];
  const int s = static_cast<int>(k);
  const double radius = region_round_radius(scan_.protocol.region_radius, sl.rounds);
  if (!regions_ || !regions_->begin(*batch_, s, seeds, scan_.tolerance(Protocol::A), radius))
    return false;
  sl.below_wake = 0;
  ++sl.rounds;
  set_phase(k, Phase::Region);
  return true;
}

// A: the next disk goes in at the next round.
void MemberRun::await_disk(std::size_t k) { set_phase(k, Phase::Deposit); }

// --- Bookkeeping -----------------------------------------------------------------------------

// Whether slot k's system (its region's in a region) is inside a step whose solve goes on in
// the next launch (SolverSettings::sweeps_per_launch, or a fused step's Newton round): nothing of
// it is to be read or changed.
bool MemberRun::mid_step(std::size_t k) const {
  const int s = static_cast<int>(k);
  return slots_[k].phase == Phase::Region ? regions_->status(s).mid_step
                                          : batch_->status(s).mid_step;
}

// Counts a step of slot k's whole system; where the step failed the member (a guard, or a solve
// capped for too long), finishes it and returns false.
bool MemberRun::whole_step_counted(std::size_t k) {
  Slot& sl = slots_[k];
  const int s = static_cast<int>(k);
  const auto& st = batch_->status(s);
  count_step(sl, st, batch_->params(s));
  if (st.failure == Failure::None && !sl.gave_up && !sl.runaway) return true;
  finish(k);
  return false;
}

// A slot's counters after one step of its system (whole or region): steps, the last step not
// at rest, consecutive unconverged steps (with rest.converged false a capped solve blocks
// nothing, so it is not a failure either) and consecutive steps with no disk above the wake
// speed.
void MemberRun::count_step(Slot& sl, const SystemStatus& st, const SystemParams& p) {
  ++sl.steps;
  if (st.rest_steps == 0) sl.moved_until = sl.steps;
  sl.unconverged = st.converged || !scan_.rest.converged ? 0 : sl.unconverged + 1;
  sl.gave_up =
      static_cast<double>(sl.unconverged) * p.time_step > scan_.protocol.max_unconverged_time;
  sl.below_wake = st.max_speed < wake_ ? sl.below_wake + 1 : 0;
  sl.runaway = st.max_speed > runaway_speed(p);
}

namespace {

// Raises the top of the column 2 R wide that holds x to `top` if that is higher, and returns the
// mean of the columns' tops (columns no disk has reached count as 0).
double mean_column_top(std::vector<double>& column_top, double x, double top,
                       const SystemParams& p) {
  const int n = std::max(1, static_cast<int>(p.width / (2.0 * p.radius)));
  column_top.resize(static_cast<std::size_t>(n), 0.0);
  const int c = std::clamp(static_cast<int>(std::floor(x / p.width * n)), 0, n - 1);
  auto& column = column_top[static_cast<std::size_t>(c)];
  column = std::max(column, top);
  double sum = 0.0;
  for (double t : column_top) sum += t;
  return sum / n;
}

}  // namespace

void MemberRun::count_disk(std::size_t k, const Deposit& d) {
  Slot& sl = slots_[k];
  ++sl.deposited;
  ++progress_.disks_deposited;
  // The highest so far, not the last: a disk landing in a valley of the rough surface would
  // otherwise move the progress estimate backwards. The paper's rule fills the valleys up to H
  // before the box is full: there the mean of the columns' tops.
  const SystemParams& p = batch_->params(static_cast<int>(k));
  const bool by_columns =
      scan_.protocol.stop_rule == StopRule::NoRoom && members_[sl.member].protocol == Protocol::A;
  const double top = by_columns ? mean_column_top(sl.column_top, d.x, d.y + d.radius, p) : d.y;
  sl.filled = std::max(sl.filled, std::min(1.0, top / p.height));
}

// Trajectory samples (observables.trajectory_every = every > 0) of the slot's first `count`
// disks (all by default).
void MemberRun::sample(std::size_t k, double when, std::size_t count) {
  const int every = scan_.observables.trajectory_every;
  if (every <= 0) return;
  MemberResult& r = slots_[k].result;
  const auto disks = batch_->disks(static_cast<int>(k));
  for (std::size_t d = 0; d < std::min(count, disks.size()); d += static_cast<std::size_t>(every)) {
    r.trajectory_time.push_back(when);
    r.trajectory_disk.push_back(static_cast<double>(d));
    r.trajectory_x.push_back(disks[d].x);
    r.trajectory_y.push_back(disks[d].y);
  }
}

// Steps of slot k's system in `time` (a cap).
long MemberRun::steps_for(std::size_t k, double time) const {
  return steps_in(time, batch_->params(static_cast<int>(k)).time_step);
}

}  // namespace loosepack
