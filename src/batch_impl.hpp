// The inside of a Batch (include/loosepack/batch.hpp), shared by its stepper (src/batch.cpp)
// and its device state (src/batch_state.cpp).
#pragma once
#include <algorithm>
#include <any>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "kernels/colouring.hpp"
#include "kernels/contacts.hpp"
#include "kernels/deposit.hpp"
#include "kernels/events.hpp"
#include "kernels/integrate.hpp"
#include "kernels/load.hpp"
#include "kernels/solver.hpp"
#include "kernels/step.hpp"
#include "loosepack/batch.hpp"
#include "loosepack/geometry.hpp"
#include "src/launch_count.hpp"
#include "src/newton.hpp"

namespace loosepack {

namespace batch_detail {
// Particle slots per chunk of the contact stage on the host: ~1.3 kB of contact and particle
// state each, so a chunk is ~1 MB, half this machine's L2 (docs/PERFORMANCE.md, batch scaling).
constexpr int kChunkSlots = 768;

template <class T>
DView<T> alloc(const char* name, std::size_t n) {
  return DView<T>(Kokkos::view_alloc(std::string(name)), n);
}

// v(k) = f(k) for k < n, filled through the host mirror h (v itself on a host backend).
template <class V, class H, class F>
void fill_from(const V& v, const H& h, std::size_t n, F f) {
  for (std::size_t k = 0; k < n; ++k) h(k) = f(k);
  Kokkos::deep_copy(v, h);
}
template <class V, class F>
void fill_from(const V& v, std::size_t n, F f) {
  fill_from(v, Kokkos::create_mirror_view(v), n, f);
}
}  // namespace batch_detail
using batch_detail::alloc;
using batch_detail::fill_from;
using batch_detail::kChunkSlots;

struct Batch::Impl {
  std::vector<SystemParams> params;
  SolverSettings solver;
  RestSettings rest;
  int n_systems = 0, n_particles = 0, n_cells = 0;
  // The kernels' bundles of views (kernels/state.hpp), whose views count no references: their
  // memory is in `bundle_memory`, allocated by own().
  SystemViews sys;
  ParticleViews part;
  ContactViews con;
  GridViews grid;
  std::vector<std::any> bundle_memory;  // each field's allocation, made once with the batch
  template <class T>
  void own(KView<T>& field, const char* name, std::size_t n) {
    DView<T> memory = alloc<T>(name, n);
    field = memory;
    bundle_memory.emplace_back(std::move(memory));
  }
  DView<int> colour_list, colour_start, colour_fill;
  // ColouredAcceleratedGaussSeidel's packed copy of each system's contacts and their owners.
  ContactViews packed;
  DView<int> packed_owner;
  DView<int> system_colour_start;  // [P * kSlots + S] ColouredAcceleratedGaussSeidel's
  DView<int> sweeps_this_step;     // [S]
  DView<int> sweep_limit;          // [S] accelerated solver with Newton steps: this launch's limit
  DView<int>::HostMirror sweep_limit_host;  // [S] its host mirror: the limits set between launches
  std::vector<long> newton_steps;  // [S] Newton steps taken (host counters)
  std::vector<NewtonPace> newton_pace;  // [S] when Newton rounds come (src/newton.hpp)
  std::vector<int> sweep_cap;           // [S] host copy of sys.max_sweeps
  std::vector<int> newton_every;        // [S] SystemSetup::newton_every, else the solver's
  std::vector<std::unique_ptr<KluFactor>> newton_factor;  // [S] kept for its analysis
  // The per-system status read after every step: packed on the device into `report` [S x
  // StatusField] (StatusReport, kernels/step.hpp) and read back in one copy.
  DView<double> report;
  DView<double>::HostMirror host_report;
  // Host mirrors of what the host reads between the accelerated solver's launches when it takes
  // Newton steps (solve_with_newton).
  struct NewtonMirrors {
    DView<int>::HostMirror unconverged, sweeps;
  } newton_host;
  DView<int> request;       // [S] per-system requests of deposit and close_events
  DView<double> request_x;  // [S] given abscissae of deposit_at
  DView<double> reply;      // [4 S] their results
  // Host mirrors of what the scheduler sends and reads between most steps (the requests, their
  // replies, the active flags), made once rather than at each call.
  struct SchedulerMirrors {
    DView<int>::HostMirror request, active;
    DView<double>::HostMirror request_x, reply;
  } scheduler_host;
  // load()'s staging: one system's values and disks, gathered on the host (load_host) and
  // copied in two pieces; sized for the largest slot.
  DView<SlotLoad> load_system;  // [1]
  DView<double> load_disks;     // [kSlotDiskFields * largest slot capacity]
  struct LoadMirrors {
    DView<SlotLoad>::HostMirror system;
    DView<double>::HostMirror disks;
  } load_host;
  // Reads and writes of one system (Batch::disks, contacts, state; set_disks, set_contacts,
  // restore) pass through slot_staging and slot_host in one copy: ReadSlot gathers into the
  // one, WriteSlot puts from it; sized for the largest slot (slot_value_at).
  DView<double> slot_staging;
  DView<double>::HostMirror slot_host;
  // What `what` reads of system s on the host, laid out as ReadSlot writes it; valid until the
  // next read or write.
  DView<double>::HostMirror read_slot(int s, SlotPart what);
  // Puts what the host staged in slot_host (n disks by index for SlotPart::Disks) into system s
  // (WriteSlot).
  void write_slot(int s, SlotPart what, int n = 0);
  std::vector<SystemStatus> status;
  std::vector<int> offsets, slot_capacity, slot_cells;
  std::vector<std::pair<int, int>> chunks;  // particle ranges of the contact stage's chunks
  void chunk_active();
  // The team solver with sweeps_per_launch: the sweeps so far of each system whose step goes on
  // in the next launch (SystemStatus::mid_step).
  std::vector<int> sweeps_before;
  // One launch of the solve: the systems in it, their disks, their sweeps in it and the most
  // any made; the steps that ended in it.
  struct Balance {
    long systems = 0, disks = 0, sweeps = 0, slowest = 0, finished = 0;
    void add(int count, int launch_sweeps) {
      ++systems;
      disks += count;
      sweeps += launch_sweeps;
      slowest = std::max<long>(slowest, launch_sweeps);
    }
  };
  // What each stage of the step (StepStage) and the Newton rounds inside the solve cost, summed
  // while timing is on (fenced); Batch::stage_costs lists them by name.
  bool timing = false;
  long timed_steps = 0;
  std::array<StageCost, kStepStages> stage_cost{};
  StageCost newton_cost;
  std::vector<StageCost> stage_costs;
  Kokkos::Timer stage_timer;
  LaunchCounts lap_counts;
  void lap(StageCost& into) {
    if (!timing) return;
    ExecSpace().fence();
    into.seconds += stage_timer.seconds();
    const LaunchCounts now = launch_counts();
    into.launches += now.launches - lap_counts.launches;
    into.copies += now.copies - lap_counts.copies;
    lap_counts = now;
    stage_timer.reset();
  }
  StageCost& timer(StepStage stage) { return stage_cost[static_cast<std::size_t>(stage)]; }
  // The fused step's one launch (solver.fused_step): every stage but the status's host side.
  StageCost fused_cost;
  // The effects the active systems call for: the solve runs the kernel specialised on them.
  using EffectFlags = Batch::KernelEffects;
  EffectFlags needed_effects() const;

  void allocate(const std::vector<SystemSetup>& setups);
  std::vector<int> lay_out(const std::vector<SystemSetup>& setups);
  void allocate_systems(const std::vector<int>& cell_offset);
  void allocate_particles();
  void allocate_contacts();
  void load(int s, const SystemSetup& setup);
  // The host's status[s].active, copied to sys.active at the start of the next step, whose
  // kernels are the only ones that read it: a scheduler that moves many systems in or out
  // between two steps copies once.
  void upload_changed_active();
  // f(Fx{}) with the Effects the systems active now call for: the kernels specialised on them.
  template <class F>
  void with_effects(F&& f) const;
  template <class Fx>
  ColouredAcceleratedGaussSeidel<Fx> team_solver();
  template <class Fx>
  void solve();
  // The whole step of every system in one launch (solver.fused_step), and with the accelerated
  // solver's Newton steps the rounds between launches.
  template <class Fx>
  void fused_step();
  template <class Fx>
  void system_step();
  // Whether any system takes Newton rounds (only the accelerated solver takes them).
  bool newton_rounds() const {
    return solver.kind == SolverKind::AcceleratedGaussSeidel &&
           std::any_of(newton_every.begin(), newton_every.end(), [](int n) { return n > 0; });
  }
  void upload_newton_limits();
  template <class Fx>
  void newton_between_launches();
  // [S] which systems took part in the fused step's last launch.
  std::vector<char> launched;
  template <class Fx>
  void solve_with_newton(const AcceleratedGaussSeidel<Fx>& plain);
  template <class Fx>
  void newton_round(const std::vector<int>& due);
  // The bounds of a system's wait for its next Newton round (NewtonPace), in sweeps:
  // newton_every iterations (two sweeps each), and one wait short of the sweep cap, so that a
  // step about to be capped still gets a round.
  int shortest_newton_wait(int s) const { return 2 * newton_every[static_cast<std::size_t>(s)]; }
  int longest_newton_wait(int s) const {
    return std::max(shortest_newton_wait(s),
                    sweep_cap[static_cast<std::size_t>(s)] - shortest_newton_wait(s));
  }
  // The threads per team of a launch of f: solver.team_size lowered to the backend's largest
  // team for f, or where the scan sets none (0) the backend's recommended size for f, rounded
  // down to a power of two (a team scan on CUDA needs one). A GPU's limits differ from kernel to
  // kernel (registers): found once for each kernel type. team_threads keeps the last launch's
  // size for --timing.
  template <class Functor>
  int team_size_of(const Functor& f) {
    static const std::pair<int, int> largest_and_recommended = [&] {
      const Kokkos::TeamPolicy<ExecSpace> policy(1, 1);
      return std::make_pair(policy.team_size_max(f, Kokkos::ParallelForTag()),
                            policy.team_size_recommended(f, Kokkos::ParallelForTag()));
    }();
    const auto [largest, recommended] = largest_and_recommended;
    const int size = solver.team_size > 0 ? std::min(solver.team_size, largest) : recommended;
    int power = 1;
    while (2 * power <= size) power *= 2;
    team_threads = power;
    return power;
  }
  int team_threads = 0;
  // A step's sweep limit before its first Newton round (the cap for a system without rounds or
  // where the pace skips them this step), and after a round at `done` sweeps.
  int first_newton_limit(int s) const {
    const auto su = static_cast<std::size_t>(s);
    return newton_every[su] == 0 || newton_pace[su].skips_step(longest_newton_wait(s))
               ? sweep_cap[su]
               : newton_pace[su].wait;
  }
  int next_newton_limit(int s, int done) const {
    return done + newton_pace[static_cast<std::size_t>(s)].wait;
  }
  // One team per system, of team_size_of(f) threads. The systems are handed out dynamically: on
  // host threads a thread that is done takes the next system, so that a system whose solve takes
  // long holds back no share of the batch fixed in advance (0.82-0.91 of the static split's time
  // on two OpenMP threads, the same results: docs/PERFORMANCE.md, "Batch scaling"); a device
  // schedules its teams itself.
  using SystemPolicy = Kokkos::TeamPolicy<ExecSpace, Kokkos::Schedule<Kokkos::Dynamic>>;
  template <class Functor>
  SystemPolicy team_policy(const Functor& f) {
    return SystemPolicy(n_systems, team_size_of(f));
  }
  int colour();
  void step();
  void run_stage(StepStage stage);
  void margin_stage();
  void contact_stage();
  void solve_stage();
  void integrate_stage();
  void status_stage();
  void read_status();
};

// The cells and margins of one system's neighbour grid.
struct GridShape {
  double cell;
  double max_margin;
  int nx, ny;
};
GridShape grid_shape(const SystemSetup& su);

}  // namespace loosepack
