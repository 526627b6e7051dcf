// How run_members runs members on one batch (include/loosepack/protocols.hpp), in two layers:
// - the slot scheduler (src/scheduler.cpp): which member holds which batch slot, refilling a
//   slot when its member finishes, progress, snapshots for checkpoints, and the stop;
// - the protocol phases (src/phases.cpp): one advance function per phase of docs/MODEL.md's
//   protocols, and the transitions between phases, all in one section there.
// A slot's system is stepped by the batch exactly while its phase is Relax or Collapse
// (set_phase); while it is Region, the member's relaxation region is stepped instead.
#pragma once
#include <chrono>
#include <cmath>
#include <cstddef>
#include <map>
#include <memory>
#include <vector>

#include "loosepack/protocols.hpp"
#include "loosepack/region.hpp"

namespace loosepack {

// Relaxation regions per deposited disk, the first included: a region that ends at rest and
// then finds motion in the whole system starts a new one around it until there have been this
// many; then the whole system relaxes.
constexpr int kMaxRegionRounds = 4;
// The radius of a disk's region in round `round` (0 first): each round after the first has twice
// the radius of the one before (MemberRun::start_region).
inline double region_round_radius(double first_radius, int round) {
  return first_radius * std::ldexp(1.0, round);
}
// The check of the whole system after a region finds motion where a disk is faster than this
// many rest speeds (slower disks creeping near the rest speed are not a failure of the deposit).
constexpr double kWakeFactor = 3.0;

// Whether a member deposits ballistically (B, C, and A at Bo = inf): no dynamics while it fills.
bool deposits_ballistically(const Member& m);

class MemberRun {
 public:
  MemberRun(const Scan& scan, const std::vector<Member>& members, const RunHooks& hooks,
            const std::vector<MemberSnapshot>& resume);
  std::vector<MemberResult> run();

 private:
  using Clock = std::chrono::steady_clock;
  using Phase = MemberPhase;
  using Mask = std::vector<char>;
  struct Slot : MemberStage {
    Phase phase = Phase::Empty;
    std::size_t member = 0;
    long region_steps = 0, region_sweeps = 0;  // the slot's region counters when it began
    // A disk moved faster than anything in the box can make it (count_step): Failure::Runaway.
    // Never set in a snapshot: the member finishes at once.
    bool runaway = false;
    Clock::time_point start;
    MemberResult result;
    // running_cost at the phase and progress it was last computed for (running_share).
    double share = 0.0;
    Phase share_phase = Phase::Empty;
    double share_got = -1.0;
  };

  // Construction (src/scheduler.cpp).
  SystemSetup setup_of(const Member& m) const;
  std::vector<Member> members_sized_for() const;
  void size_slots();
  void make_regions();

  // The slot scheduler (src/scheduler.cpp).
  void begin(std::size_t k);
  void go_on_from(std::size_t k, const MemberSnapshot& snap);
  void finish(std::size_t k);
  bool stopped();
  bool take_snapshots(bool stopping, bool last_chance);
  MemberSnapshot snapshot(std::size_t k) const;
  void report();
  double running_share(Slot& sl) const;
  double speed_over_rest(std::size_t k) const;
  void collect_stage_costs(double loop_seconds, long launches, long copies) const;
  Mask mask_of(Phase phase, bool* any) const;
  bool any_dynamic() const;
  bool any_busy() const;

  // The protocol phases (src/phases.cpp): one round of each.
  void advance_ballistic();
  void advance_deposit();
  void redraw_where_room(const Mask& depositing, DropRule rule, std::vector<Deposit>& placed);
  void advance_dynamics();
  void advance_region(std::size_t k, Mask& closing);
  void advance_relax(std::size_t k, Mask& closing);
  void advance_collapse(std::size_t k);
  void close_events(const Mask& closing);
  // Phase transitions (src/phases.cpp).
  void set_phase(std::size_t k, Phase to);
  void start_collapse(std::size_t k);
  void start_relaxation(std::size_t k, const Deposit& placed);
  void start_final_check(std::size_t k);
  void relax_whole(std::size_t k, bool checking);
  bool start_region(std::size_t k, const std::vector<Regions::Point>& seeds);
  void await_disk(std::size_t k);
  // Bookkeeping shared by the phases.
  bool mid_step(std::size_t k) const;
  bool whole_step_counted(std::size_t k);
  void count_step(Slot& sl, const SystemStatus& st, const SystemParams& p);
  void count_disk(std::size_t k, const Deposit& d);
  void sample(std::size_t k, double when, std::size_t count = static_cast<std::size_t>(-1));
  long steps_for(std::size_t k, double time) const;

  Scan scan_;  // the run's, with the backend's defaults filled in (resolve_backend_defaults)
  const std::vector<Member>& members_;
  const RunHooks& hooks_;
  std::map<std::uint64_t, const MemberSnapshot*> snapshot_of_;
  int capacity_ = 0, cells_ = 0;  // every slot holds the largest member of the scan
  std::size_t n_slots_ = 0;
  std::unique_ptr<Batch> batch_;
  std::unique_ptr<Regions> regions_;  // null: relaxation regions off, or no slow deposition
  std::vector<Slot> slots_;
  std::vector<MemberResult> results_;
  std::vector<char> done_;
  std::size_t next_ = 0;  // the next member to begin
  Progress progress_;
  bool reported_ = false;  // progress_.start_fraction is set
  double total_cost_ = 0.0, done_cost_ = 0.0;
  bool snapshots_wanted_ = false;
  bool stop_round_ = false;  // the round of snapshots under way is the stop's
  StageCost snapshot_cost_;  // with timing: what the snapshots cost (collect_stage_costs)
  std::vector<MemberSnapshot> taken_;
  Clock::time_point stopped_at_{};
  double wake_ = 0.0;  // kWakeFactor rest speeds
};

}  // namespace loosepack
