// A batch of independent 2D systems of disks advanced together by one set of Kokkos kernels.
// The host API uses plain structs; the device state stays behind the pointer to implementation.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "loosepack/params.hpp"

namespace loosepack {

struct Disk {
  double x = 0.0, y = 0.0, theta = 0.0;
  double vx = 0.0, vy = 0.0, w = 0.0;
  double radius = 1.0;
  bool fixed = false;          // infinite mass and inertia (a support, not part of the deposit)
  bool lock_rotation = false;  // infinite inertia only
  double y_deposit = 0.0;      // y_i: height at which the disk was deposited
};

// The speed the rest criterion compares with rest.speed: max(|v|, R |w|), or |v| alone without
// spin (RestSettings::spin).
inline double speed(const Disk& d, bool spin = true) {
  const double v = std::hypot(d.vx, d.vy);
  return spin ? std::max(v, std::abs(d.radius * d.w)) : v;
}

struct SystemSetup {
  SystemParams params;
  std::vector<Disk> disks;
  int capacity = 0;    // particle slots; at least disks.size()
  int grid_cells = 0;  // grid cells to reserve (at least what these parameters need)
  // Key of the counter-based random stream of this system: (scan seed, member id).
  std::uint64_t seed = 0;
  std::uint64_t member = 0;
  // Solver tolerance of this system [h m g]; 0: the batch's SolverSettings::tolerance.
  double tolerance = 0.0;
  // Solver sweep cap per step of this system; 0: the batch's SolverSettings::max_sweeps.
  int max_sweeps = 0;
  // Newton rounds of this system (SolverSettings::newton_every, 0: none); -1: the batch's.
  int newton_every = -1;
};

// Contact force of one contact, in force units (impulse / h).
struct ContactForce {
  int i = 0, j = 0;  // local disk indices; j = -1: the floor
  double nx = 0.0, ny = 0.0, gap = 0.0;
  double normal = 0.0, tangential = 0.0, moment = 0.0;
};

enum class Failure {
  None = 0,
  NonFinite = 1,
  ContactOverflow = 2,
  ParticleOverflow = 3,
  Unconverged = 4,  // set by the protocols: protocol.max_unconverged_time exceeded
  Escaped = 5,      // set by the protocols: a disk ended outside the box (the solution blew up)
  Overlap = 6,      // set by the protocols: two disks (or a disk and the floor) ended
                    // overlapping by more than kMaxFinalOverlap (the solution blew up)
  Runaway = 7,      // set by the protocols: a disk moved faster than runaway_speed
};
// The largest overlap a finished member may hold [R]: converged solves leave ~1e-4 R, moving
// steps under the relative tolerance up to ~3e-3 R (docs/PERFORMANCE.md), this 80 times that.
constexpr double kMaxFinalOverlap = 0.25;
std::string failure_message(Failure f);

// Host copy of the per-system status after a step.
struct SystemStatus {
  bool active = false;
  Failure failure = Failure::None;
  int count = 0;
  long steps = 0;         // steps taken
  long sweeps = 0;        // solver sweeps, all steps
  int last_sweeps = 0;    // sweeps of the last step
  long newton_steps = 0;  // Newton steps of the accelerated solver (src/newton.hpp), all steps
  bool converged = true;  // the last step's solve reached the tolerance
  // The tolerance the last step's solve ran to [h m g]: max(tolerance, kappa v_max / (g max(h,
  // h_kappa))), v_max the max_speed before it (SolverSettings::relative_tolerance).
  double tolerance = 0.0;
  double max_speed = 0.0;         // max(|v|, R|w|) after the last step
  double max_centre_speed = 0.0;  // max |v|
  // The largest speed the rest criterion compares with rest.speed (RestSettings::spin).
  double rest_speed(bool spin) const { return spin ? max_speed : max_centre_speed; }
  int rest_steps = 0;  // consecutive steps below the rest speed (the solver converged, where
                       // RestSettings::converged asks it)
  // The averaged rest test (Batch::set_average_span): the largest distance a disk's position
  // averaged over a span moved from the span before, over the span's time [sqrt(g R)];
  // negative until two spans have ended. Below rest.speed the system is at rest too.
  double mean_speed = -1.0;
  bool at_rest = false;
  // The system is inside a step: its solve goes on in the next step() (the team solver's
  // SolverSettings::sweeps_per_launch, or a fused step's Newton round between the launches of
  // accelerated_gauss_seidel), and the rest of this status is still the last finished
  // step's. Nothing is to change the system (deactivate, deposit, read back) until it ends.
  bool mid_step = false;
};

// Where the next disk goes on a vertical drop line.
enum class DropRule {
  Touch,    // highest height at which it touches a disk or the floor (protocol A)
  Capture,  // Meakin's ballistic deposition with capture radius r_capt (protocol B)
};

// Result of one deposition attempt in one system.
struct Deposit {
  bool placed = false;  // false: the disk would stand above H; the system is full
  double x = 0.0, y = 0.0, radius = 0.0;
};

// Grid cells a system with these parameters needs (to size batch slots for reuse).
int grid_cells_needed(const SystemSetup& setup);

// The stages of a time step, in the order they run (docs/MODEL.md, "Time step", lists them by
// these names, and a test holds the list to this enum). Batch::step runs them in this order.
enum class StepStage {
  Margin,        // detection margin and the step's solver tolerance from the last speeds
  Grid,          // neighbour grid
  FreeVelocity,  // v + h g
  Contacts,      // contact build, warm-started from the previous step's impulses
  Solve,         // the iterative solve (and its Newton rounds)
  Integrate,     // positions, then the overlap correction where it is on
  Status,        // per-system status on the host: guards, rest detection
};
constexpr int kStepStages = 7;
// The stage's name in docs/MODEL.md and in Batch::stage_costs.
const char* stage_name(StepStage stage);

// What one stage of the step cost while timing was on (Batch::stage_costs): wall seconds
// (fenced), kernel launches and deep copies (src/launch_count.hpp), over `steps` steps.
struct StageCost {
  std::string name;
  double seconds = 0.0;
  long launches = 0, copies = 0;
  long steps = 0;
  // The solve stage's balance: the systems in each launch summed over the launches, their
  // solver sweeps, and the sweeps they would have made had each swept as long as its launch's
  // slowest system. A device's solve launch lasts as long as its slowest system
  // (docs/PERFORMANCE.md, "Building for more cores or a GPU"). One launch is one step, except
  // with SolverSettings::sweeps_per_launch, where the steps that ended are finished_steps.
  // launch_sweeps: the slowest system's sweeps summed over the launches, which a device's solve
  // time follows. disk_steps: the disks of the systems in each launch, summed over the launches
  // (a stage's seconds over them: its cost per disk of a step).
  long system_steps = 0, finished_steps = 0, sweeps = 0, slowest_sweeps = 0, launch_sweeps = 0;
  long disk_steps = 0;
  int team_size = 0;  // the team solver's solve stage: threads per system's team
};

// Largest interpenetration (disk-disk 2R - d or disk-floor R - y) of these disks in a box
// periodic over `width`.
double max_overlap(const std::vector<Disk>& disks, double width);

class Batch {
 public:
  Batch(const std::vector<SystemSetup>& systems, const SolverSettings& solver = {},
        const RestSettings& rest = {});
  ~Batch();
  Batch(const Batch&) = delete;
  Batch& operator=(const Batch&) = delete;

  int size() const;
  const SystemParams& params(int s) const;
  // The solver's sweep cap per step of system s (SystemSetup::max_sweeps, else the batch's).
  int max_sweeps(int s) const;
  // The Newton rounds of system s (SystemSetup::newton_every, else the batch's; 0: none).
  int newton_every(int s) const;
  const SolverSettings& solver() const;

  // One time step of every active system. With SolverSettings::sweeps_per_launch a system whose
  // solve needs more sweeps is left inside its step (SystemStatus::mid_step), which goes on in
  // the next call while the others take their next steps; so is a system due for a Newton round
  // in a fused step (SolverSettings::fused_step).
  void step();
  // Wall time, launches and copies per stage of the step (StepStage, by stage_name, in order;
  // "newton": the Newton rounds inside the solve, apart from its sweeps), summed over all steps
  // since timing was switched on. Timing fences after every stage. With
  // SolverSettings::fused_step two rows: "system_step" (the one launch, with the solve's balance)
  // and "status".
  void set_timing(bool on);
  const std::vector<StageCost>& stage_costs() const;
  // The effects the next step's solve is specialised on: those of the systems active now.
  struct KernelEffects {
    bool cohesion = false, friction = false, rolling = false;
  };
  KernelEffects kernel_effects() const;
  // Put a new system into slot s (a finished member frees its slot for the next one). The
  // setup must fit the slot: capacity and grid cells no larger than the slot's.
  void reset(int s, const SystemSetup& setup);
  // What the solver has learned about system s's steps: when its Newton rounds come
  // (SolverSettings::newton_every; src/newton.hpp, NewtonPace). reset() starts it afresh; a
  // system that goes on with other disks hands it on (the relaxation regions of one deposit
  // take it from the whole system and give it back: src/region.cpp).
  struct SolverPace {
    int wait = 0;         // sweeps before a step's first round
    double credit = 0.0;  // [sweeps] for rounds at the longest wait
  };
  SolverPace solver_pace(int s) const;
  void set_solver_pace(int s, const SolverPace& pace);
  // Step until every active system is at rest or failed, or max_steps. Returns steps taken.
  long run_to_rest(long max_steps);

  void set_active(int s, bool active);
  // Switch gravity on or off in one system (protocol C), keeping the state.
  void set_gravity(int s, bool on);
  const SystemStatus& status(int s) const;
  void reset_rest(int s);
  // The averaged rest test of system s (RestSettings::average_span): from now on its disks'
  // positions are averaged over spans of `steps` steps (0: off), and the system is at rest also
  // when none moved by more than rest.speed times a span's time from one span's mean position to
  // the next (SystemStatus::mean_speed), converged or not. It covers the disks the system has
  // now: no deposit after it (protocol C: the collapse).
  void set_average_span(int s, int steps);

  // Drop one disk into each system s with mask[s] at a random x from its stream.
  std::vector<Deposit> deposit(const std::vector<char>& mask, DropRule rule);
  // The same at given abscissae x[s] (standard scenes with their own random sequence); the
  // disk has the system's mean radius and no random draw is consumed.
  std::vector<Deposit> deposit_at(const std::vector<char>& mask, const std::vector<double>& x,
                                  DropRule rule);

  // Avalanche of the last event in each system s with mask[s]: disks that moved more than
  // `threshold` in y since the event began, and their summed downward displacement; then a new
  // event begins (heights marked again). Deposited disks are marked where they were placed.
  struct Avalanche {
    int moved = 0;
    double downward = 0.0;
  };
  std::vector<Avalanche> close_events(const std::vector<char>& mask, double threshold);

  std::vector<Disk> disks(int s) const;
  // Overwrite position, angle and velocities of the disks index[k] (local indices) of system s
  // with disks[k] (radius, mass and y_i stay). The next step's contacts are warm-started from
  // the impulses their pairs carried before; its detection margin and relative tolerance follow
  // the fastest of the system's disks as written.
  void set_disks(int s, const std::vector<int>& index, const std::vector<Disk>& disks);
  std::vector<ContactForce> contacts(int s) const;
  // Replace the impulses system s's next step is warm-started from with these contacts' forces
  // (i < j, or j = -1 for the floor; geometry fields are ignored). For an inactive system.
  void set_contacts(int s, const std::vector<ContactForce>& contacts);
  // Largest interpenetration (disk-disk 2R - d or disk-floor R - y) in system s (the free
  // max_overlap of its disks).
  double max_overlap(int s) const;

  // Everything system s carries from one step to the next, bit for bit: disks, the heights its
  // current avalanche event began at, the impulses its next step is warm-started from, its
  // random stream, gravity, status and solver pace. What a checkpoint of a running member keeps.
  struct SystemState {
    std::vector<Disk> disks;
    // Per disk: the height its current avalanche event began at, its inverse mass and inertia.
    std::vector<double> y_mark, inv_mass, inv_inertia;
    // Contact slots in use: slot (disk * slots per disk + k), partner (local disk; -1: the
    // floor), the impulses normal, tangential and rolling, and the geometry of the last step
    // (normal and gap: what contacts() reports before the next step).
    std::vector<int> slot, partner;
    std::vector<double> pn, pt, pm, nx, ny, gap;
    std::uint64_t draws = 0;                 // random draws taken
    double speed = 0.0, centre_speed = 0.0;  // the speeds the next step's margin comes from
    bool gravity_on = true;
    // The averaged rest test (set_average_span): steps per span (0: off), steps into the span,
    // spans ended, the span's largest change so far [R], and per disk its sums and means
    // (kernels/state.hpp, SpanField, disk after disk).
    int span_steps = 0, span_step = 0, spans = 0;
    double span_change = 0.0;
    std::vector<double> span;
    SystemStatus status;
    SolverPace pace;
  };
  SystemState state(int s) const;
  // Continues system s from `state`, taken from a system of the same setup: reset(s, setup)
  // with setup.disks = state.disks first, then restore(s, state) puts back what reset derives
  // (positions bit for bit, marks, impulses, stream, counters). The system's steps from here
  // are those the system of the state would have taken.
  void restore(int s, const SystemState& state);

  // Public only because CUDA's extended lambdas (in the kernels of batch.cpp) may not be defined
  // inside a class of private access; nothing outside batch.cpp can use it.
  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace loosepack
