// The protocols of MODEL.md run on batches of ensemble members.
#pragma once
#include <csignal>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "loosepack/batch.hpp"
#include "loosepack/region.hpp"
#include "loosepack/scan.hpp"

namespace loosepack {

// One ensemble member: a scan point and a seed.
struct Member {
  int point = 0;
  int seed_index = 0;
  std::uint64_t id = 0;  // point * seeds + seed_index: keys the random stream
  Protocol protocol = Protocol::A;
  SystemParams params;
  // A: relaxed in relaxation regions (protocol.region_radius > 0), which the cost model prices.
  bool in_regions = false;
};

std::vector<Member> members_of(const Scan& scan);

// One deposition event of protocol A.
struct AvalancheEvent {
  int moved = 0;          // disks that moved more than the threshold in y
  double downward = 0.0;  // their summed downward displacement [R]
  long steps = 0;         // steps to rest: to the last step not at rest, and rest.steps more
  bool capped = false;    // hit max_relax_time before rest
};

struct MemberResult {
  Member member;
  Failure failure = Failure::None;
  std::vector<double> x, y_i, y_e, radius;  // per disk, in deposition order
  std::vector<AvalancheEvent> events;       // protocol A
  std::vector<ContactForce> contacts;       // final contact forces (force chains, paper fig. 1)
  // A failed member only: velocities at the failure, for its diagnostic snapshot (the contacts
  // above are then those of the failing step).
  std::vector<double> vx, vy, w;
  // Trajectories of every k-th disk (observables.trajectory_every = k > 0), one row per sample:
  // when (A: disks deposited so far; C: collapse step), which disk, where.
  std::vector<double> trajectory_time, trajectory_disk, trajectory_x, trajectory_y;
  long steps = 0, sweeps = 0;
  int capped = 0;          // A: events that hit the cap; C: 1 if the collapse hit its cap
  double wall_time = 0.0;  // seconds the member held its batch slot (shared with the others)
  bool ok() const { return failure == Failure::None; }
};

// What a batch slot is doing.
enum class MemberPhase {
  Empty,      // no member left for it
  Ballistic,  // B and C (and A at Bo = inf): one disk per round, no dynamics
  Collapse,   // C after its deposit: gravity on, dynamics until rest
  Deposit,    // A: the next disk goes in this round
  Relax,      // A: dynamics of the whole system until rest after the last disk
  Region,     // A: dynamics of a relaxation region around the last disk until rest
};
// The phases a member can be snapshotted in, and go on from: all but Empty (and no value
// outside the enumeration: a checkpoint's phase is read as a number).
inline bool goes_on_from(MemberPhase p) {
  return p == MemberPhase::Ballistic || p == MemberPhase::Collapse || p == MemberPhase::Deposit ||
         p == MemberPhase::Relax || p == MemberPhase::Region;
}

// Where a running member stands in its protocol, apart from its system: the counters of its
// batch slot (src/member_run.hpp, src/phases.cpp).
struct MemberStage {
  long steps = 0;        // steps of the current relaxation or collapse
  long cap = 0;          // their cap
  // A: the steps of the current relaxation up to its last step that was not at rest by the rest
  // criterion (a disk above rest.speed, or an unconverged solve); its event lasts these and the
  // rest window, in a relaxation region as in the whole system.
  long moved_until = 0;
  long unconverged = 0;  // consecutive steps whose solve hit the sweep cap
  bool gave_up = false;  // unconverged for protocol.max_unconverged_time: Failure::Unconverged
  long deposited = 0;
  // The progress estimate: the highest deposited disk's centre over H, or for A with the paper's
  // stop rule the mean of column_top over H (src/phases.cpp, count_disk).
  double filled = 0.0;
  // A with the paper's stop rule: the highest top of a disk placed in each column 2 R wide
  // (the box is full when its lowest column is, not its highest).
  std::vector<double> column_top;
  bool checking = false;      // A: a whole system's relaxation after a region is its rest check
  int below_wake = 0;         // steps in a row with no disk above the wake speed (check)
  int rounds = 0;             // relaxation regions started for the current disk
  bool event_capped = false;  // the current disk's relaxation hit max_relax_time
  // A: the disk's region came to rest where the whole system is not checked; its event closes
  // with the next disk (nothing moves in between), or after the final check when the box is full.
  bool event_open = false;
  bool final_check = false;  // the whole system's check after an unchecked last disk
};

// A running member where it can stop and go on bit for bit: a checkpoint of a member that has
// not finished. Taken between steps (of its relaxation region's system, inside a region).
struct MemberSnapshot {
  // What it has recorded so far; steps and sweeps: those of its relaxation regions so far;
  // wall_time: its time so far.
  MemberResult result;
  MemberPhase phase = MemberPhase::Deposit;
  MemberStage stage;
  Batch::SystemState system;
  std::optional<RegionState> region;  // the phase Region's running region; else none
};

// A relaxation this long [steps] is reported while it runs (Progress::relaxing_long): most of a
// deposit's relaxations take 10 to 100 steps, its avalanches thousands (docs/PERFORMANCE.md,
// "Where a tall cohesive deposit's steps go").
constexpr long kLongRelaxation = 1000;

// Reported periodically during a run (and after the last member) for progress messages.
struct Progress {
  int members_done = 0;
  // Disks deposited by this run's members, those deposited before a resume included.
  long disks_deposited = 0;
  // Of those, the disks the members that went on from their snapshots had deposited before this
  // run started (the progress line's rate leaves them out).
  long disks_before = 0;
  // Protocol C: members collapsing now, and the steps of the longest such collapse so far (a
  // collapse deposits nothing, so without them a long one would look stalled).
  int collapsing = 0;
  long collapse_steps = 0;
  // That collapse's largest speed over rest.speed (the rest test's); -1 before its first step.
  double collapse_speed = 0.0;
  // ... and its mean speed over rest.speed (the averaged rest test's, rest.average_span;
  // SystemStatus::mean_speed): negative until its second span has ended.
  double collapse_mean_speed = -1.0;
  // Protocol A: members whose relaxation after their last disk has taken kLongRelaxation steps
  // or more so far, and the steps of the longest (an avalanche of a tall cohesive deposit runs
  // for thousands of steps, at the paper's size for hours, depositing nothing meanwhile).
  int relaxing_long = 0;
  long relax_steps = 0;
  // That relaxation's largest speed over rest.speed; -1 where its system has not stepped yet
  // (a relaxation region cut again around the moving disks, between the cut and its step).
  double relax_speed = 0.0;
  // Fraction of the run's expected cost (expected_cost) done, counting running members by how
  // far they got: for the ETA only.
  double fraction = 0.0;
  // The fraction of the run's first report: members that went on from snapshots had done it
  // before this run started. The ETA counts the rate since (progress_eta).
  double start_fraction = 0.0;
};

// Seconds left at the rate since the start: elapsed (1 - fraction) / (fraction - start_fraction);
// negative (no estimate) until the run has done 1 % of its cost.
double progress_eta(const Progress& p, double elapsed);
// A run under mpirun ends with its slowest rank: the largest of the running ranks' ETAs (each
// rank's Progress over its own share, `finished` those done; a rank with no members, whose
// fraction is 0 of 0, left out), each at its own rate; the whole run's (`all`) while a running
// rank has not done 1 % since its start (or not reported yet); none (negative) while a running
// rank's fraction has reached 1 (its last member costing more than the model said) or no rank
// is running.
double run_eta(const std::vector<Progress>& ranks, const std::vector<char>& finished,
               const Progress& all, double elapsed);
using ProgressFn = std::function<void(const Progress&)>;

// What a caller may attach to a run.
struct RunHooks {
  ProgressFn progress;
  // Called with each member as it finishes (in finishing order), e.g. to checkpoint it.
  std::function<void(const MemberResult&)> finished;
  // When this becomes nonzero (a signal handler sets it), the run returns at the end of the
  // current step with the members finished so far (with `snapshots`, once it has handed over
  // those of the running members: below); the others are dropped.
  const volatile std::sig_atomic_t* stop = nullptr;
  // Receives what each named stage of the batch step cost (Batch::stage_costs); those of the
  // relaxation regions' batch follow, their names prefixed with "region ".
  std::vector<StageCost>* stage_costs = nullptr;
  // Checkpoints of running members. When `snapshot_wanted` returns true the run takes a
  // snapshot of every running member at its next point where it can (between two steps: not
  // while a step's solve goes on over launches, solver.sweeps_per_launch or the host's Newton
  // rounds in a fused step) and hands them to
  // `snapshots` together. At a stop it takes the latest it can
  // and goes on, for at most `stop_grace` seconds, until every running member has one.
  std::function<bool()> snapshot_wanted;
  std::function<void(std::vector<MemberSnapshot>)> snapshots;
  // 10 s: a batch system's grace period after SIGTERM is usually 30 s or more.
  double stop_grace = 10.0;
  // At a stop whose grace ran out: the ids of the running members still inside a step, which
  // the stop's `snapshots` lack (called just before it).
  std::function<void(const std::vector<std::uint64_t>&)> missed_at_stop;
};

// Systems per batch where the scan sets none: 4 on a backend that runs one thread (Kokkos
// Serial: a batch there runs nothing side by side and costs cache locality, so batches of small
// systems cost more per member: docs/PERFORMANCE.md, "Batch scaling"), 64 on host threads
// (OpenMP shares the systems of a batch out, so a batch needs at least as many as a machine's
// threads; on two threads batches from 4 to 256 cost within about a tenth of each other a member,
// 64 the least), 4 096 on a
// device (a GPU's time per member still falls from 1 024 to 4 096 members: docs/PERFORMANCE.md,
// "Building for more cores or a GPU").
int default_batch_size();
// The solver where the scan sets none: accelerated_gauss_seidel (one thread per system) on the
// host, coloured_accelerated_gauss_seidel (a team of threads per system) on a device, where it
// is 2.3-2.7x faster (docs/PERFORMANCE.md, "Building for more cores or a GPU").
SolverKind default_solver_kind();
// The team solver's sweeps per launch where the scan sets none, for a batch of `systems`: 0 (each
// step's whole solve in one launch) on the host, where a core gains nothing from the balance and
// each launch runs the other stages again, and for a batch of one system, which has no other
// system to step while its solve goes on; 8 on a device, where a launch would otherwise last as
// long as the batch's slowest solve: a member costs 4.7x (protocol C) and 2.4x (A) less on an
// H200 at 4 096 members, and 16 is no better (docs/PERFORMANCE.md, "Building for more cores or a
// GPU").
int default_sweeps_per_launch(std::size_t systems);
// Whether the step is fused (SolverSettings::fused_step) where the scan does not say: on a host
// backend with a solver that allows it, where the fused step gives the same results for less
// time (0.47-0.78x on two OpenMP threads, whose staged step forks and joins them for every
// stage; 0.83-0.99x on one core); not on a device, where it is not measured yet
// (docs/PERFORMANCE.md, "Building for more cores or a GPU").
bool default_fused_step(SolverKind kind);
// Fills in what the scan leaves to the backend: the batch size, the solver kind, for the team
// solver its sweeps per launch, and the fused step, for a run of `members` members (its batch
// holds min(members, batch size) systems).
void resolve_backend_defaults(Scan& scan, std::size_t members);

// Run the members on one batch of scan.batch_size slots (default_batch_size() if 0): members of any
// protocol advance together, and a finished member's slot takes the next member. Returns the
// finished members in the order given (all of them unless stopped). A member with a snapshot in
// `resume` goes on from it.
std::vector<MemberResult> run_members(const Scan& scan, const std::vector<Member>& members,
                                      const RunHooks& hooks = {},
                                      const std::vector<MemberSnapshot>& resume = {});

// Rough cost of a member in arbitrary units, for progress estimates and for sharding members
// over MPI ranks: a protocol-A member costs ~ width * height^q / time step, times the time a
// deposit takes to come to rest, which falls with the Bond number like (1 + Bo/4)^-0.7 (1 at
// Bo = 0, 0.02 at Bo = 1e3); up to 60 R q grows with the Bond number, from 2.5 without cohesion
// to 4 at Bo = 1e3 (avalanches grow with the height above them), at most 3 for a member relaxed
// in relaxation regions (Member::in_regions); above 60 R it is the tall boxes' measured exponent
// (3.7 for the whole system, 2.9 to 3.6 by the Bond number in regions); a running member's share
// done is the cost of a member as tall as its deposit so far; a collapse ~ width * height^2 / time
// step; ballistic deposition ~ width * height (negligible beside either); lengths in disk radii,
// the time step in sqrt(R/g) (a system of radius 2 costs what the same system of radius 1 does).
// Calibrated on members of this machine, and right within a factor of a few only:
// docs/PERFORMANCE.md, "What a member costs".
double expected_cost(const Member& m);
// expected_cost's unit in seconds: about 0.039 microseconds of one core of the AMD EPYC VM it was
// calibrated on (the geometric mean over the recorded protocol-A scenes); `--dry-run` prints the
// cost in seconds by it.
constexpr double kSecondsPerCostUnit = 3.9e-8;

// The steps of time step `time_step` in `time` [sqrt(R/g)], rounded up: how a member's caps
// (protocol.max_relax_time, max_collapse_time) and rest.average_span count in steps.
long steps_in(double time, double time_step);

// The steps a collapse (protocol C) is expected to take, for the progress line's ETA: the top of
// the column falling freely through two thirds of its height, sqrt(4 H / (3 g)), over the time
// step (docs/PERFORMANCE.md, "What a member costs").
double collapse_steps(const SystemParams& p);

// How far a running member got, as running_cost counts it: the deposit's height over H while it
// deposits (stage.filled), the steps over collapse_steps while it collapses.
double member_progress(const Member& m, MemberPhase phase, const MemberStage& stage);

// The cost model's share of a running member (expected_cost, counting how far it got): `got` is
// member_progress.
double running_cost(const Member& m, MemberPhase phase, double got);

// What is left of the expected cost of a member that goes on from its snapshot (`--resume`,
// `--dry-run`): expected_cost less the share its snapshot had done.
double cost_left(const MemberSnapshot& snap);

// Splits work items of the given costs over `ranks` so that the costs balance (largest first,
// each to the least loaded rank; ties to the lower index and rank). Deterministic: every rank
// computes the same. Returns, per rank, indices into `costs` in increasing order.
std::vector<std::vector<std::size_t>> balance_costs(const std::vector<double>& costs, int ranks);

// balance_costs of the members' expected costs: the split of a scan into shards (`run --shard
// K/N`), fixed by the scan alone. An MPI run balances what is left of each member instead
// (share_over_ranks), so that a resumed run's ranks end together.
std::vector<std::vector<std::size_t>> shard_members(const std::vector<Member>& members, int ranks);

// What the cost model leaves of each member to compute: cost_left of its snapshot where it goes
// on from one of `started`, else its whole expected_cost.
std::vector<double> costs_left(const std::vector<Member>& todo,
                               const std::vector<MemberSnapshot>& started);

// The members to compute shared over an MPI run's ranks: balance_costs of their costs_left.
struct RankShares {
  std::vector<std::vector<std::size_t>> members;  // per rank: indices into todo, increasing
  std::vector<double> expected;                   // per rank: its members' whole expected_cost
  std::vector<double> left;                       // per rank: their costs_left
};
RankShares share_over_ranks(const std::vector<Member>& todo,
                            const std::vector<MemberSnapshot>& started, int ranks);

// Grid capacity for one member: enough slots for the densest packing below H.
int member_capacity(const SystemParams& p);

}  // namespace loosepack
