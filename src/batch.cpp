// Host orchestration of a batch: allocation, the named stages of a time step, per-system
// status and rest detection. All device work is in kernels/.
#include "loosepack/batch.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <utility>

#include "kernels/colouring.hpp"
#include "kernels/contacts.hpp"
#include "kernels/deposit.hpp"
#include "kernels/events.hpp"
#include "kernels/integrate.hpp"
#include "kernels/solver.hpp"
#include "loosepack/geometry.hpp"
#include "src/newton.hpp"

namespace loosepack {

std::string failure_message(Failure f) {
  switch (f) {
    case Failure::None:
      return "none";
    case Failure::NonFinite:
      return "non-finite position or velocity (NaN or Inf)";
    case Failure::ContactOverflow:
      return "a disk had more contacts than the fixed capacity (overlapping disks?)";
    case Failure::ParticleOverflow:
      return "more disks than the system's capacity";
    case Failure::Unconverged:
      return "the solver hit its sweep cap on every step for protocol.max_unconverged_time";
  }
  return "unknown";
}

namespace {
// Particle slots per chunk of the contact stage on the host: ~1.3 kB of contact and particle
// state each, so a chunk is ~1 MB, half this machine's L2 (docs/PERFORMANCE.md, batch scaling).
constexpr int kChunkSlots = 768;

template <class T>
DView<T> alloc(const char* name, std::size_t n) {
  return DView<T>(Kokkos::view_alloc(std::string(name)), n);
}

template <class T, class F>
void fill_from(const DView<T>& v, std::size_t n, F f) {
  auto h = Kokkos::create_mirror_view(v);
  for (std::size_t k = 0; k < n; ++k) h(k) = f(k);
  Kokkos::deep_copy(v, h);
}
}  // namespace

struct Batch::Impl {
  std::vector<SystemParams> params;
  SolverSettings solver;
  RestSettings rest;
  int n_systems = 0, n_particles = 0, n_cells = 0;
  SystemViews sys;
  ParticleViews part;
  ContactViews con;
  GridViews grid;
  DView<int> colour_list, colour_start, colour_fill;
  DView<int> system_colour_start;  // [S * (colours + 1)] ColouredAcceleratedGaussSeidel's
  DView<int> sweeps_this_step;     // [S]
  DView<int> sweep_limit;          // [S] accelerated solver with Newton steps: this launch's limit
  std::vector<long> newton_steps;  // [S] Newton steps taken (host counters)
  std::vector<NewtonPace> newton_pace;  // [S] when Newton rounds come (src/newton.hpp)
  std::vector<int> sweep_cap;           // [S] host copy of sys.max_sweeps
  std::vector<std::unique_ptr<KluFactor>> newton_factor;  // [S] kept for its analysis
  // Host mirrors of the per-system status read after every step (allocated once).
  struct HostStatus {
    DView<int>::HostMirror failure, unconverged, sweeps, count;
    DView<double>::HostMirror max_speed, max_centre_speed, step_tolerance;
  } host;
  DView<int> request;       // [S] per-system requests of deposit and close_events
  DView<double> request_x;  // [S] given abscissae of deposit_at
  DView<double> reply;      // [4 S] their results
  std::vector<SystemStatus> status;
  std::vector<int> offsets, slot_capacity, slot_cells;
  std::vector<std::pair<int, int>> chunks;  // particle ranges of the contact stage's chunks
  void chunk_active();
  // Batch steps taken, and the last one each system took part in. The contact arrays are
  // swapped every step; a system that sat out an odd number of steps has its own last contacts
  // in the other buffer, and resumes from them (restore_warm_start), so a system keeps its
  // warm start while it waits and its results never depend on what the rest of the batch did.
  long batch_steps = 0;
  std::vector<long> last_stepped;
  // Wall time of each stage of the step (StepStage) and of the Newton rounds inside the solve,
  // summed while timing is on (fenced); Batch::stage_seconds lists them by name.
  bool timing = false;
  std::array<double, kStepStages> stage_time{};
  double newton_time = 0.0;
  std::vector<std::pair<std::string, double>> stage_seconds;
  Kokkos::Timer stage_timer;
  void lap(double& into) {
    if (!timing) return;
    ExecSpace().fence();
    into += stage_timer.seconds();
    stage_timer.reset();
  }
  double& timer(StepStage stage) { return stage_time[static_cast<std::size_t>(stage)]; }
  void restore_warm_start(int s);
  // The effects the active systems call for: the solve runs the kernel specialised on them.
  using EffectFlags = Batch::KernelEffects;
  EffectFlags needed_effects() const;

  void allocate(const std::vector<SystemSetup>& setups);
  void load(int s, const SystemSetup& setup);
  void upload_status_active();
  template <class Fx>
  void solve();
  template <class Fx>
  void solve_with_newton(const AcceleratedGaussSeidel<Fx>& plain);
  template <class Fx>
  void newton_round(const std::vector<int>& due);
  // The bounds of a system's wait for its next Newton round (NewtonPace), in sweeps:
  // newton_every iterations (two sweeps each), and one wait short of the sweep cap, so that a
  // step about to be capped still gets a round.
  int shortest_newton_wait() const { return 2 * solver.newton_every; }
  int longest_newton_wait(int s) const {
    return std::max(shortest_newton_wait(),
                    sweep_cap[static_cast<std::size_t>(s)] - shortest_newton_wait());
  }
  int colour(bool batch_list);
  void step();
  void run_stage(StepStage stage);
  void margin_stage();
  void contact_stage();
  void solve_stage();
  void integrate_stage();
  void status_stage();
};

namespace {
struct GridShape {
  double cell;
  double max_margin;
  int nx, ny;
};
GridShape grid_shape(const SystemSetup& su) {
  const auto& pr = su.params;
  double rmax = largest_radius(pr);
  for (const auto& d : su.disks) rmax = std::max(rmax, d.radius);
  GridShape g;
  // No disk moves faster than a fall through the whole box.
  g.max_margin = grid_margin(pr, pr.height + 2.0 * rmax);
  g.cell = 2.0 * rmax + pr.cohesion_range + g.max_margin;
  g.nx = std::max(1, static_cast<int>(std::floor(pr.width / g.cell)));
  g.ny = std::max(1, static_cast<int>(std::ceil((pr.height + 2.0 * rmax) / g.cell)));
  return g;
}
}  // namespace

int grid_cells_needed(const SystemSetup& setup) {
  const GridShape g = grid_shape(setup);
  return g.nx * g.ny;
}

void Batch::Impl::allocate(const std::vector<SystemSetup>& setups) {
  n_systems = static_cast<int>(setups.size());
  if (n_systems == 0) throw std::invalid_argument("Batch: no systems");
  const auto S = static_cast<std::size_t>(n_systems);
  offsets.resize(S);
  slot_capacity.resize(S);
  slot_cells.resize(S);
  std::vector<int> cell_offset(S);
  // Disk, contact and cell indices of the whole batch are ints: refuse a batch beyond them.
  const long long kMaxIndex = std::numeric_limits<int>::max() / kIncident;
  long long particles = 0, cells = 0;
  for (const auto& su : setups) {
    particles += std::max<long long>({su.capacity, static_cast<long long>(su.disks.size()), 1});
    cells += std::max(su.grid_cells, grid_cells_needed(su));
  }
  if (particles > kMaxIndex || cells > kMaxIndex)
    throw std::invalid_argument(
        "Batch: " + std::to_string(S) + " systems need " + std::to_string(particles) +
        " disk slots and " + std::to_string(cells) + " grid cells, more than one batch " +
        "indexes (" + std::to_string(kMaxIndex) + "): use a smaller batch size");
  for (std::size_t s = 0; s < S; ++s) {
    const auto& su = setups[s];
    slot_capacity[s] = std::max({su.capacity, static_cast<int>(su.disks.size()), 1});
    slot_cells[s] = std::max(su.grid_cells, grid_cells_needed(su));
    offsets[s] = n_particles;
    n_particles += slot_capacity[s];
    cell_offset[s] = n_cells;
    n_cells += slot_cells[s];
  }
  const auto P = static_cast<std::size_t>(n_particles);
  const auto NC = P * kSlots;

  sys.offset = alloc<int>("offset", S);
  sys.capacity = alloc<int>("capacity", S);
  sys.count = alloc<int>("count", S);
  sys.width = alloc<double>("width", S);
  sys.height = alloc<double>("height", S);
  sys.radius = alloc<double>("radius", S);
  sys.polydispersity = alloc<double>("polydispersity", S);
  sys.disk_density = alloc<double>("disk_density", S);
  sys.capture_radius = alloc<double>("capture_radius", S);
  sys.gravity_x = alloc<double>("gravity_x", S);
  sys.gravity_y = alloc<double>("gravity_y", S);
  sys.cohesive_force = alloc<double>("cohesive_force", S);
  sys.cohesion_range = alloc<double>("cohesion_range", S);
  sys.friction = alloc<double>("friction", S);
  sys.rolling_friction = alloc<double>("rolling_friction", S);
  sys.time_step = alloc<double>("time_step", S);
  sys.weight = alloc<double>("weight", S);
  sys.tolerance = alloc<double>("tolerance", S);
  sys.step_tolerance = alloc<double>("step_tolerance", S);
  sys.max_sweeps = alloc<int>("max_sweeps", S);
  sys.floor_cohesion = alloc<int>("floor_cohesion", S);
  sys.seed = alloc<std::uint64_t>("seed", S);
  sys.member = alloc<std::uint64_t>("member", S);
  sys.draws = alloc<std::uint64_t>("draws", S);
  sys.cell_size = alloc<double>("cell_size", S);
  sys.grid_nx = alloc<int>("grid_nx", S);
  sys.grid_ny = alloc<int>("grid_ny", S);
  sys.cell_offset = alloc<int>("cell_offset", S);
  sys.active = alloc<int>("active", S);
  sys.unconverged = alloc<int>("unconverged", S);
  sys.failure = alloc<int>("failure", S);
  sys.sweep_change = alloc<double>("sweep_change", S);
  sys.max_speed = alloc<double>("max_speed", S);
  sys.max_centre_speed = alloc<double>("max_centre_speed", S);
  sys.margin = alloc<double>("margin", S);
  sys.max_margin = alloc<double>("max_margin", S);
  sys.gradient2 = alloc<double>("gradient2", S);
  sweeps_this_step = alloc<int>("sweeps_this_step", S);
  sweep_limit = alloc<int>("sweep_limit", S);
  newton_steps.assign(static_cast<std::size_t>(S), 0);
  newton_pace.assign(static_cast<std::size_t>(S), NewtonPace{shortest_newton_wait()});
  sweep_cap.assign(static_cast<std::size_t>(S), solver.max_sweeps);
  newton_factor.resize(static_cast<std::size_t>(S));
  for (auto& f : newton_factor) f = std::make_unique<KluFactor>();
  host.failure = Kokkos::create_mirror_view(sys.failure);
  host.unconverged = Kokkos::create_mirror_view(sys.unconverged);
  host.sweeps = Kokkos::create_mirror_view(sweeps_this_step);
  host.count = Kokkos::create_mirror_view(sys.count);
  host.max_speed = Kokkos::create_mirror_view(sys.max_speed);
  host.max_centre_speed = Kokkos::create_mirror_view(sys.max_centre_speed);
  host.step_tolerance = Kokkos::create_mirror_view(sys.step_tolerance);
  request = alloc<int>("request", S);
  request_x = alloc<double>("request_x", S);
  reply = alloc<double>("reply", 4 * S);
  fill_from(sys.offset, S, [&](std::size_t s) { return offsets[s]; });
  fill_from(sys.capacity, S, [&](std::size_t s) { return slot_capacity[s]; });
  fill_from(sys.cell_offset, S, [&](std::size_t s) { return cell_offset[s]; });

  part.system = alloc<int>("system", P);
  part.x = alloc<double>("x", P);
  part.y = alloc<double>("y", P);
  part.theta = alloc<double>("theta", P);
  part.vx = alloc<double>("vx", P);
  part.vy = alloc<double>("vy", P);
  part.w = alloc<double>("w", P);
  part.vfx = alloc<double>("vfx", P);
  part.vfy = alloc<double>("vfy", P);
  part.wf = alloc<double>("wf", P);
  part.radius = alloc<double>("radius", P);
  part.inv_mass = alloc<double>("inv_mass", P);
  part.inv_inertia = alloc<double>("inv_inertia", P);
  part.y_deposit = alloc<double>("y_deposit", P);
  part.y_mark = alloc<double>("y_mark", P);
  part.cell = alloc<int>("cell", P);
  part.n_incident = alloc<int>("n_incident", P);
  part.incident = alloc<int>("incident", P * kIncident);
  {
    auto h = Kokkos::create_mirror_view(part.system);
    for (std::size_t s = 0; s < S; ++s)
      for (int k = 0; k < slot_capacity[s]; ++k) h(offsets[s] + k) = static_cast<int>(s);
    Kokkos::deep_copy(part.system, h);
  }
  // No slot belongs to a cell until the first grid build.
  Kokkos::deep_copy(part.cell, -1);

  con.partner = alloc<int>("partner", NC);
  con.prev_partner = alloc<int>("prev_partner", NC);
  Kokkos::deep_copy(con.partner, kNoContact);
  Kokkos::deep_copy(con.prev_partner, kNoContact);
  con.nx = alloc<double>("cnx", NC);
  con.ny = alloc<double>("cny", NC);
  con.gap = alloc<double>("gap", NC);
  con.rc = alloc<double>("rc", NC);
  con.wn = alloc<double>("wn", NC);
  con.wa = alloc<double>("wa", NC);
  con.wb = alloc<double>("wb", NC);
  con.wc = alloc<double>("wc", NC);
  con.lower = alloc<double>("lower", NC);
  con.pn = alloc<double>("pn", NC);
  con.pt = alloc<double>("pt", NC);
  con.pm = alloc<double>("pm", NC);
  con.prev_pn = alloc<double>("prev_pn", NC);
  con.prev_pt = alloc<double>("prev_pt", NC);
  con.prev_pm = alloc<double>("prev_pm", NC);
  con.colour = alloc<int>("colour", NC);
  if (solver.kind == SolverKind::AcceleratedGaussSeidel ||
      solver.kind == SolverKind::ColouredAcceleratedGaussSeidel) {
    con.start_pn = alloc<double>("start_pn", NC);
    con.start_pt = alloc<double>("start_pt", NC);
    con.start_pm = alloc<double>("start_pm", NC);
    con.dir_pn = alloc<double>("dir_pn", NC);
    con.dir_pt = alloc<double>("dir_pt", NC);
    con.dir_pm = alloc<double>("dir_pm", NC);
  }
  colour_list = alloc<int>("colour_list", NC);
  colour_start = alloc<int>("colour_start", 2);
  colour_fill = alloc<int>("colour_fill", 1);

  grid.cell_start = alloc<int>("cell_start", static_cast<std::size_t>(n_cells) + 1);
  grid.cell_fill = alloc<int>("cell_fill", static_cast<std::size_t>(n_cells));
  grid.cell_particles = alloc<int>("cell_particles", P);

  params.resize(S);
  status.assign(S, SystemStatus{});
  last_stepped.assign(S, 0);
  for (std::size_t s = 0; s < S; ++s) load(static_cast<int>(s), setups[s]);
}

// Puts one system into slot s: parameters, grid shape, disks; contacts and status cleared.
void Batch::Impl::load(int s, const SystemSetup& su) {
  const auto k = static_cast<std::size_t>(s);
  const SystemParams& pr = su.params;
  const int count = static_cast<int>(su.disks.size());
  if (std::max(su.capacity, count) > slot_capacity[k])
    throw std::invalid_argument(
        "Batch: system needs " + std::to_string(std::max(su.capacity, count)) +
        " disk slots, the batch slot has " + std::to_string(slot_capacity[k]));
  const GridShape g = grid_shape(su);
  if (g.nx * g.ny > slot_cells[k])
    throw std::invalid_argument("Batch: system needs " + std::to_string(g.nx * g.ny) +
                                " grid cells, the batch slot has " + std::to_string(slot_cells[k]));
  params[k] = pr;
  auto set = [s](const auto& view, auto value) {
    Kokkos::deep_copy(Kokkos::subview(view, s), value);
  };
  set(sys.count, count);
  set(sys.width, pr.width);
  set(sys.height, pr.height);
  set(sys.radius, pr.radius);
  set(sys.polydispersity, pr.polydispersity);
  set(sys.disk_density, pr.disk_density);
  set(sys.capture_radius, pr.capture_radius);
  set(sys.gravity_x, pr.gravity_on ? pr.gravity * pr.gravity_dir_x : 0.0);
  set(sys.gravity_y, pr.gravity_on ? pr.gravity * pr.gravity_dir_y : 0.0);
  set(sys.cohesive_force, pr.cohesive_force());
  set(sys.cohesion_range, pr.cohesion_range);
  set(sys.friction, pr.friction);
  set(sys.rolling_friction, pr.rolling_friction);
  set(sys.time_step, pr.time_step);
  const double weight = pr.reference_mass() * pr.gravity;
  set(sys.weight, weight > 0.0 ? weight : 1.0);
  set(sys.tolerance, su.tolerance > 0.0 ? su.tolerance : solver.tolerance);
  sweep_cap[k] = su.max_sweeps > 0 ? su.max_sweeps : solver.max_sweeps;
  set(sys.max_sweeps, sweep_cap[k]);
  set(sys.floor_cohesion, pr.floor_cohesion ? 1 : 0);
  set(sys.seed, su.seed);
  set(sys.member, su.member);
  set(sys.draws, std::uint64_t(0));
  set(sys.cell_size, g.cell);
  set(sys.max_margin, g.max_margin);
  set(sys.grid_nx, g.nx);
  set(sys.grid_ny, g.ny);
  set(sys.active, 1);
  set(sys.unconverged, 0);
  set(sys.failure, int(kOk));

  const int first = offsets[k], cap = slot_capacity[k];
  const auto range = std::make_pair(first, first + cap);
  auto upload = [&](const DView<double>& v, auto f) {
    auto sub = Kokkos::subview(v, range);
    auto h = Kokkos::create_mirror_view(sub);
    for (int a = 0; a < cap; ++a) h(a) = a < count ? f(su.disks[static_cast<std::size_t>(a)]) : 0.0;
    Kokkos::deep_copy(sub, h);
  };
  const double width = pr.width;
  auto mass = [&](const Disk& d) { return pr.disk_density * M_PI * d.radius * d.radius; };
  double speed = 0.0;
  for (const auto& d : su.disks) {
    if (!(d.radius > 0.0)) throw std::invalid_argument("Batch: disk radius must be positive");
    speed = std::max(speed, loosepack::speed(d));
  }
  upload(part.x, [&](const Disk& d) { return std::fmod(std::fmod(d.x, width) + width, width); });
  upload(part.y, [](const Disk& d) { return d.y; });
  upload(part.theta, [](const Disk& d) { return d.theta; });
  upload(part.vx, [](const Disk& d) { return d.vx; });
  upload(part.vy, [](const Disk& d) { return d.vy; });
  upload(part.w, [](const Disk& d) { return d.w; });
  upload(part.radius, [](const Disk& d) { return d.radius; });
  upload(part.inv_mass, [&](const Disk& d) { return d.fixed ? 0.0 : 1.0 / mass(d); });
  upload(part.inv_inertia, [&](const Disk& d) {
    return (d.fixed || d.lock_rotation) ? 0.0 : 2.0 / (mass(d) * d.radius * d.radius);
  });
  upload(part.y_deposit, [](const Disk& d) { return d.y_deposit; });
  upload(part.y_mark, [](const Disk& d) { return d.y; });
  set(sys.max_speed, speed);
  const auto slots = std::make_pair(first * kSlots, (first + cap) * kSlots);
  Kokkos::deep_copy(Kokkos::subview(con.partner, slots), kNoContact);
  Kokkos::deep_copy(Kokkos::subview(con.prev_partner, slots), kNoContact);
  Kokkos::deep_copy(Kokkos::subview(part.cell, range), -1);

  status[k] = SystemStatus{};
  status[k].active = true;
  status[k].count = count;
  newton_steps[k] = 0;
  newton_pace[k] = NewtonPace{shortest_newton_wait()};
  newton_factor[k] = std::make_unique<KluFactor>();
  last_stepped[k] = batch_steps;
}

void Batch::Impl::restore_warm_start(int s) {
  const auto k = static_cast<std::size_t>(s);
  if ((batch_steps - last_stepped[k]) % 2 == 0) return;
  const int first = offsets[k];
  const auto slots = std::make_pair(first * kSlots, (first + slot_capacity[k]) * kSlots);
  auto copy = [&](const auto& to, const auto& from) {
    Kokkos::deep_copy(Kokkos::subview(to, slots), Kokkos::subview(from, slots));
  };
  copy(con.partner, con.prev_partner);
  copy(con.pn, con.prev_pn);
  copy(con.pt, con.prev_pt);
  copy(con.pm, con.prev_pm);
}

template <class Fx>
void Batch::Impl::solve() {
  const SystemViews sys_ = sys;
  const auto sweeps = sweeps_this_step;
  const double omega = solver.relaxation;
  const bool jacobi = solver.kind == SolverKind::Jacobi;
  const int n_contacts = n_particles * kSlots;
  Kokkos::deep_copy(sweeps, 0);
  // The per-system solvers iterate each system to convergence in one launch.
  if (solver.kind == SolverKind::AcceleratedGaussSeidel) {
    const AcceleratedGaussSeidel<Fx> sweeper{sys, part, con, sweeps, omega, DView<int>()};
    if (solver.newton_every > 0) {
      solve_with_newton(sweeper);
      return;
    }
    Kokkos::parallel_for("accelerated_gauss_seidel",
                         PerSystemPolicy(0, n_systems, Kokkos::ChunkSize(1)), sweeper);
    return;
  }
  if (solver.kind == SolverKind::SequentialGaussSeidel) {
    Kokkos::parallel_for("sequential_gauss_seidel",
                         PerSystemPolicy(0, n_systems, Kokkos::ChunkSize(1)),
                         SequentialGaussSeidel<Fx>{sys, part, con, sweeps, omega});
    return;
  }
  if (solver.kind == SolverKind::ColouredAcceleratedGaussSeidel) {  // one team per system
    const int n_colours = colour(false);
    const auto need = static_cast<std::size_t>(n_systems) * (n_colours + 1);
    if (system_colour_start.extent(0) < need)
      system_colour_start = alloc<int>("system_colour_start", need);
    Kokkos::parallel_for("coloured_accelerated_gauss_seidel",
                         Kokkos::TeamPolicy<ExecSpace>(n_systems, Kokkos::AUTO),
                         ColouredAcceleratedGaussSeidel<Fx>{sys, part, con, sweeps, colour_list,
                                                            system_colour_start, n_colours, omega});
    return;
  }
  int n_colours = 0;
  std::vector<int> colour_begin;
  if (!jacobi) {
    n_colours = colour(true);
    auto hs = Kokkos::create_mirror_view(colour_start);
    Kokkos::deep_copy(hs, colour_start);
    colour_begin.assign(hs.data(), hs.data() + n_colours + 1);
  }
  // Each system stops at its own cap (kStoppedAtCap: not converged).
  const int largest_cap = *std::max_element(sweep_cap.begin(), sweep_cap.end());
  for (int sweep = 0; sweep < largest_cap; ++sweep) {
    if (jacobi) {
      Kokkos::parallel_for("jacobi_contacts", Kokkos::RangePolicy<ExecSpace>(0, n_contacts),
                           JacobiContacts<Fx>{sys, part, con, omega});
      Kokkos::parallel_for("jacobi_bodies", Kokkos::RangePolicy<ExecSpace>(0, n_particles),
                           BodyVelocity{sys, part, con, true});
    } else {
      for (int k = 0; k < n_colours; ++k) {
        const int n = colour_begin[k + 1] - colour_begin[k];
        if (n == 0) continue;
        Kokkos::parallel_for(
            "gauss_seidel_colour", Kokkos::RangePolicy<ExecSpace>(0, n),
            GaussSeidelContacts<Fx>{sys, part, con, colour_list, colour_begin[k], omega});
      }
    }
    int still = 0;
    Kokkos::parallel_reduce(
        "convergence", Kokkos::RangePolicy<ExecSpace>(0, n_systems),
        KOKKOS_LAMBDA(int s, int& n) {
          if (!sys_.active(s) || sys_.unconverged(s) != kIterating) return;
          sweeps(s) += 1;
          if (!(sys_.sweep_change(s) > sys_.step_tolerance(s))) {
            sys_.unconverged(s) = 0;
          } else if (sweeps(s) >= sys_.max_sweeps(s)) {
            sys_.unconverged(s) = kStoppedAtCap;
          } else {
            ++n;
          }
          sys_.sweep_change(s) = 0.0;
        },
        still);
    if (still == 0) break;
  }
}

// The accelerated solver with Newton steps: each system iterates until it converges or has
// done its wait; the host then takes Newton steps for the systems still iterating, and the sweeps
// go on from the new impulses for another wait. The wait adapts per system from round to round
// and carries over to the next step (NewtonPace, src/newton.hpp): where Newton steps pay (a tall
// cohesive deposit, whose sweeps crawl) they come early; where the sweeps' trouble is a nonsmooth
// switch that a Newton step does not settle either, they fade out and cost little.
template <class Fx>
void Batch::Impl::solve_with_newton(const AcceleratedGaussSeidel<Fx>& plain) {
  AcceleratedGaussSeidel<Fx> sweeper = plain;  // the same sweeps, stopping at sweep_limit
  sweeper.sweep_limit = sweep_limit;
  auto limit = Kokkos::create_mirror_view(sweep_limit);
  for (int s = 0; s < n_systems; ++s) {
    const NewtonPace& pace = newton_pace[static_cast<std::size_t>(s)];
    limit(s) = pace.skips_step(longest_newton_wait(s)) ? sweep_cap[static_cast<std::size_t>(s)]
                                                       : pace.wait;
  }
  auto& unconverged = host.unconverged;
  auto& done = host.sweeps;
  for (;;) {
    Kokkos::deep_copy(sweep_limit, limit);
    Kokkos::parallel_for("accelerated_gauss_seidel",
                         PerSystemPolicy(0, n_systems, Kokkos::ChunkSize(1)), sweeper);
    Kokkos::deep_copy(unconverged, sys.unconverged);
    Kokkos::deep_copy(done, sweeps_this_step);
    std::vector<int> due;
    for (int s = 0; s < n_systems; ++s)
      if (status[static_cast<std::size_t>(s)].active && unconverged(s) &&
          done(s) < sweep_cap[static_cast<std::size_t>(s)])
        due.push_back(s);
    if (due.empty()) {  // every system converged or was capped
      for (int s = 0; s < n_systems; ++s)
        if (status[static_cast<std::size_t>(s)].active)
          newton_pace[static_cast<std::size_t>(s)].step_done(
              unconverged(s) != 0, sweep_cap[static_cast<std::size_t>(s)]);
      return;
    }
    lap(timer(StepStage::Solve));
    newton_round<Fx>(due);
    lap(newton_time);
    for (int s : due) limit(s) = done(s) + newton_pace[static_cast<std::size_t>(s)].wait;
  }
}

// Newton steps (src/newton.hpp) for the systems `due`, on host copies of their state (the same
// memory on a host backend), one system per host thread; per round at most kNewtonSteps steps
// that are not blocked, and kMaxSteps in all (a blocked step opens one self-stress of a loop
// that cannot close: src/newton.hpp).
template <class Fx>
void Batch::Impl::newton_round(const std::vector<int>& due) {
  constexpr int kNewtonSteps = 3, kMaxSteps = 8;
  const auto mirror = [](const auto& v) {
    return Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), v);
  };
  const auto vx = mirror(part.vx), vy = mirror(part.vy), w = mirror(part.w);
  const auto vfx = mirror(part.vfx), vfy = mirror(part.vfy), wf = mirror(part.wf);
  const auto inv_mass = mirror(part.inv_mass), inv_inertia = mirror(part.inv_inertia);
  const auto radius = mirror(part.radius);
  const auto n_incident = mirror(part.n_incident), incident = mirror(part.incident);
  const auto partner = mirror(con.partner);
  const auto nx = mirror(con.nx), ny = mirror(con.ny), gap_ = mirror(con.gap), rc = mirror(con.rc);
  const auto wn = mirror(con.wn), wa = mirror(con.wa), wb = mirror(con.wb), wc = mirror(con.wc);
  const auto lower = mirror(con.lower);
  const auto pn = mirror(con.pn), pt = mirror(con.pt), pm = mirror(con.pm);
  const auto weight = mirror(sys.weight), tolerance = mirror(sys.step_tolerance);
  const auto counts = mirror(sys.count);
  Kokkos::parallel_for(
      "newton",
      Kokkos::RangePolicy<Kokkos::DefaultHostExecutionSpace, Kokkos::Schedule<Kokkos::Dynamic>>(
          0, static_cast<int>(due.size())),
      [&](int k) {
        const int s = due[static_cast<std::size_t>(k)];
        const auto su = static_cast<std::size_t>(s);
        const SystemParams& pr = params[su];
        const int first = offsets[su], count = counts(s);
        // Gather: bodies first..first+count, their contacts in slot order.
        NewtonSystem ns;
        ns.impulse_unit = pr.time_step * weight(s);
        ns.factor = newton_factor[su].get();
        std::vector<int> local(static_cast<std::size_t>(count) * kSlots, -1);
        for (int p = first; p < first + count; ++p)
          for (int a = 0; a < kSlots; ++a) {
            const int c = p * kSlots + a;
            const int j = partner(c);
            if (j == kNoContact) break;
            local[static_cast<std::size_t>(c - first * kSlots)] = ns.contacts();
            ns.i.push_back(p - first);
            ns.j.push_back(j >= 0 ? j - first : kFloor);
            ns.nx.push_back(nx(c));
            ns.ny.push_back(ny(c));
            ns.rc.push_back(rc(c));
            ns.problem.push_back({gap_(c), pr.time_step, wn(c), wa(c), wb(c), wc(c), lower(c),
                                  pr.friction, pr.rolling_friction * rc(c)});
            ns.impulse.push_back({pn(c), pt(c), pm(c)});
          }
        ns.incident_start.push_back(0);
        for (int p = first; p < first + count; ++p) {
          ns.inv_mass.push_back(inv_mass(p));
          ns.inv_inertia.push_back(inv_inertia(p));
          ns.radius.push_back(radius(p));
          ns.vfx.push_back(vfx(p));
          ns.vfy.push_back(vfy(p));
          ns.wf.push_back(wf(p));
          ns.vx.push_back(vx(p));
          ns.vy.push_back(vy(p));
          ns.w.push_back(w(p));
          for (int a = 0; a < n_incident(p); ++a)
            ns.incident.push_back(
                local[static_cast<std::size_t>(incident(p * kIncident + a) - first * kSlots)]);
          ns.incident_start.push_back(static_cast<int>(ns.incident.size()));
        }
        const double before = ns.residual<Fx>();
        double residual = before;
        int steps = 0;  // taken (a failed one ends the round)
        for (int full = 0; full < kNewtonSteps && steps < kMaxSteps && residual > tolerance(s);
             ++steps) {
          const auto step = ns.newton_step<Fx>();
          if (step == NewtonSystem::Step::Failed) break;
          if (step == NewtonSystem::Step::Full) ++full;
          residual = ns.residual<Fx>();
        }
        newton_steps[su] += steps;
        newton_pace[su].after_round(residual < 0.1 * before || !(residual > tolerance(s)),
                                    NewtonPace::round_cost(steps, ns.factor_entries, ns.contacts()),
                                    shortest_newton_wait(), longest_newton_wait(s));

        // Scatter the impulses and velocities back.
        for (int p = first; p < first + count; ++p) {
          const auto b = static_cast<std::size_t>(p - first);
          vx(p) = ns.vx[b];
          vy(p) = ns.vy[b];
          w(p) = ns.w[b];
          for (int a = 0; a < kSlots; ++a) {
            const int c = p * kSlots + a;
            const int l = local[static_cast<std::size_t>(c - first * kSlots)];
            if (l < 0) break;
            const ContactImpulse& P = ns.impulse[static_cast<std::size_t>(l)];
            pn(c) = P.pn;
            pt(c) = P.pt;
            pm(c) = P.pm;
          }
        }
      });
  Kokkos::deep_copy(part.vx, vx);
  Kokkos::deep_copy(part.vy, vy);
  Kokkos::deep_copy(part.w, w);
  Kokkos::deep_copy(con.pn, pn);
  Kokkos::deep_copy(con.pt, pt);
  Kokkos::deep_copy(con.pm, pm);
}

// Colours the contacts of every system (ColourRound); with batch_list, also lists the batch's
// contact slots by colour in colour_list, delimited by colour_start. Returns the colour count.
int Batch::Impl::colour(bool batch_list) {
  const int n_contacts = n_particles * kSlots;
  Kokkos::parallel_for("colour_reset", Kokkos::RangePolicy<ExecSpace>(0, n_contacts),
                       ColourReset{con});
  int rounds = 0;
  for (;; ++rounds) {
    int uncoloured = 0;
    Kokkos::parallel_reduce("colour_round", Kokkos::RangePolicy<ExecSpace>(0, n_contacts),
                            ColourRound{sys, part, con, rounds}, uncoloured);
    if (uncoloured == 0) break;
  }
  const int n_colours = rounds + 1;
  if (!batch_list) return n_colours;
  if (static_cast<int>(colour_fill.extent(0)) < n_colours) {
    colour_fill = alloc<int>("colour_fill", static_cast<std::size_t>(n_colours));
    colour_start = alloc<int>("colour_start", static_cast<std::size_t>(n_colours) + 1);
  }
  auto fill = colour_fill;
  auto start = colour_start;
  auto list = colour_list;
  auto col = con.colour;
  Kokkos::deep_copy(fill, 0);
  Kokkos::parallel_for(
      "colour_count", Kokkos::RangePolicy<ExecSpace>(0, n_contacts), KOKKOS_LAMBDA(int c) {
        if (col(c) >= 0) Kokkos::atomic_increment(&fill(col(c)));
      });
  Kokkos::parallel_scan(
      "colour_scan", Kokkos::RangePolicy<ExecSpace>(0, n_colours + 1),
      KOKKOS_LAMBDA(int k, int& partial, bool final) {
        const int n = k < n_colours ? fill(k) : 0;
        if (final) start(k) = partial;
        partial += n;
      });
  Kokkos::deep_copy(fill, 0);
  Kokkos::parallel_for(
      "colour_fill", Kokkos::RangePolicy<ExecSpace>(0, n_contacts), KOKKOS_LAMBDA(int c) {
        const int k = col(c);
        if (k >= 0) list(start(k) + Kokkos::atomic_fetch_add(&fill(k), 1)) = c;
      });
  return n_colours;
}

// The particle ranges of the contact stage: on the host, runs of active systems of about
// kChunkSlots particle slots each, so that inactive systems (at rest, or finished while the rest
// of the batch runs) cost nothing and one chunk's contact arrays stay in cache from one kernel
// to the next; on a device, which hides latency by width, the whole batch in one launch.
void Batch::Impl::chunk_active() {
  chunks.clear();
  constexpr bool host_memory = Kokkos::SpaceAccessibility<Kokkos::HostSpace, MemSpace>::accessible;
  if (!host_memory) {
    chunks.emplace_back(0, n_particles);
    return;
  }
  for (std::size_t s = 0; s < status.size(); ++s) {
    if (!status[s].active) continue;
    const int begin = offsets[s], end = begin + slot_capacity[s];
    if (!chunks.empty() && chunks.back().second == begin &&
        chunks.back().second - chunks.back().first < kChunkSlots)
      chunks.back().second = end;
    else
      chunks.emplace_back(begin, end);
  }
}

const char* stage_name(StepStage stage) {
  switch (stage) {
    case StepStage::Margin:
      return "margin";
    case StepStage::Grid:
      return "grid";
    case StepStage::FreeVelocity:
      return "free_velocity";
    case StepStage::Contacts:
      return "contacts";
    case StepStage::Solve:
      return "solve";
    case StepStage::Integrate:
      return "integrate";
    case StepStage::Status:
      return "status";
  }
  return "?";
}

// One time step of the active systems: the stages of StepStage in their order.
void Batch::Impl::step() {
  if (std::none_of(status.begin(), status.end(), [](const SystemStatus& st) { return st.active; }))
    return;
  if (timing) {
    ExecSpace().fence();
    stage_timer.reset();
  }
  for (int k = 0; k < kStepStages; ++k) {
    const auto stage = static_cast<StepStage>(k);
    run_stage(stage);
    lap(timer(stage));
  }
}

void Batch::Impl::run_stage(StepStage stage) {
  switch (stage) {
    case StepStage::Margin:
      return margin_stage();
    // Inactive systems get no cells: all later kernels skip them.
    case StepStage::Grid:
      return build_grid(sys, part, grid, n_particles, n_cells);
    case StepStage::FreeVelocity:
      Kokkos::parallel_for("free_velocity", Kokkos::RangePolicy<ExecSpace>(0, n_particles),
                           FreeVelocity{sys, part});
      return;
    case StepStage::Contacts:
      return contact_stage();
    case StepStage::Solve:
      return solve_stage();
    case StepStage::Integrate:
      return integrate_stage();
    case StepStage::Status:
      return status_stage();
  }
}

// The detection margin and the solver tolerance from the last step's speeds; the step's
// counters reset.
void Batch::Impl::margin_stage() {
  const SystemViews sys_ = sys;
  const double kappa = solver.relative_tolerance;
  Kokkos::parallel_for(
      "margin", Kokkos::RangePolicy<ExecSpace>(0, n_systems), KOKKOS_LAMBDA(int s) {
        const double h = sys_.time_step(s);
        const double g = kmath::sqrt(sys_.gravity_x(s) * sys_.gravity_x(s) +
                                     sys_.gravity_y(s) * sys_.gravity_y(s));
        const double r = sys_.radius(s);
        sys_.step_tolerance(s) =
            g > 0.0 ? kmath::max(sys_.tolerance(s), kappa * sys_.max_speed(s) / (g * h))
                    : sys_.tolerance(s);
        sys_.margin(s) = kmath::clamp(2.0 * h * (sys_.max_speed(s) + h * g), kMinMarginFactor * r,
                                      sys_.max_margin(s));
        sys_.unconverged(s) = sys_.active(s) ? kIterating : 0;
        sys_.sweep_change(s) = 0.0;
        sys_.max_speed(s) = sys_.active(s) ? 0.0 : sys_.max_speed(s);
        sys_.max_centre_speed(s) = sys_.active(s) ? 0.0 : sys_.max_centre_speed(s);
      });
}

// Contacts, warm-started from the previous step's impulses, then the velocities those impulses
// give. Systems not stepped now keep theirs untouched in one of the two buffers (see
// restore_warm_start).
void Batch::Impl::contact_stage() {
  std::swap(con.partner, con.prev_partner);
  std::swap(con.pn, con.prev_pn);
  std::swap(con.pt, con.prev_pt);
  std::swap(con.pm, con.prev_pm);
  // Chunk by chunk of active systems (they share nothing; see chunk_active).
  chunk_active();
  const bool split_mass = solver.kind == SolverKind::Jacobi && solver.mass_splitting;
  for (const auto& [p0, p1] : chunks) {
    Kokkos::parallel_for("contacts", Kokkos::RangePolicy<ExecSpace>(p0, p1),
                         ContactBuild{sys, part, con, grid});
    Kokkos::parallel_for("incident", Kokkos::RangePolicy<ExecSpace>(p0, p1),
                         IncidentScatter{sys, part, con});
    Kokkos::parallel_for("incident_sort", Kokkos::RangePolicy<ExecSpace>(p0, p1),
                         IncidentSort{part});
    Kokkos::parallel_for("mobility", Kokkos::RangePolicy<ExecSpace>(p0 * kSlots, p1 * kSlots),
                         ContactMobilityBuild{part, con, split_mass});
    Kokkos::parallel_for("warm_start", Kokkos::RangePolicy<ExecSpace>(p0, p1),
                         BodyVelocity{sys, part, con, false});
  }
}

// The effects of the systems active now (not of every system the batch ever held): the
// specialised kernels skip only terms that are exactly zero for the others, so a system's
// results do not depend on which kernel its batch runs, and a batch runs the cheapest one its
// current members allow.
Batch::KernelEffects Batch::Impl::needed_effects() const {
  EffectFlags e;
  for (int s = 0; s < n_systems; ++s) {
    if (!status[static_cast<std::size_t>(s)].active) continue;
    const SystemParams& pr = params[static_cast<std::size_t>(s)];
    e.cohesion = e.cohesion || pr.cohesive_force() > 0.0;
    e.friction = e.friction || pr.friction > 0.0;
    e.rolling = e.rolling || (pr.friction > 0.0 && pr.rolling_friction > 0.0);
  }
  return e;
}

void Batch::Impl::solve_stage() {
  const EffectFlags e = needed_effects();
  if (e.rolling) {
    solve<Effects<true, true, true>>();
  } else if (e.friction) {
    if (e.cohesion)
      solve<Effects<true, true, false>>();
    else
      solve<Effects<false, true, false>>();
  } else {
    if (e.cohesion)
      solve<Effects<true, false, false>>();
    else
      solve<Effects<false, false, false>>();
  }
}

// x += h v (wrapped into [0, L_x)), theta += h w; then the overlap correction where it is on.
void Batch::Impl::integrate_stage() {
  Kokkos::parallel_for("integrate", Kokkos::RangePolicy<ExecSpace>(0, n_particles),
                       Integrate{sys, part});
  if (solver.overlap_correction > 0.0)
    Kokkos::parallel_for("overlap_correction", PerSystemPolicy(0, n_systems, Kokkos::ChunkSize(1)),
                         OverlapCorrection{sys, part, con, solver.overlap_correction});
}

// Per-system status on the host: the non-finite and overflow guards stop a system; rest
// detection.
void Batch::Impl::status_stage() {
  auto& h_fail = host.failure;
  auto& h_speed = host.max_speed;
  auto& h_unconv = host.unconverged;
  auto& h_sweeps = host.sweeps;
  auto& h_count = host.count;
  Kokkos::deep_copy(h_fail, sys.failure);
  Kokkos::deep_copy(h_speed, sys.max_speed);
  Kokkos::deep_copy(host.max_centre_speed, sys.max_centre_speed);
  Kokkos::deep_copy(host.step_tolerance, sys.step_tolerance);
  Kokkos::deep_copy(h_unconv, sys.unconverged);
  Kokkos::deep_copy(h_sweeps, sweeps_this_step);
  Kokkos::deep_copy(h_count, sys.count);
  bool deactivate = false;
  ++batch_steps;
  for (int s = 0; s < n_systems; ++s) {
    auto& st = status[static_cast<std::size_t>(s)];
    if (!st.active) continue;
    last_stepped[static_cast<std::size_t>(s)] = batch_steps;
    st.steps += 1;
    st.last_sweeps = h_sweeps(s);
    st.newton_steps = newton_steps[static_cast<std::size_t>(s)];
    st.sweeps += h_sweeps(s);
    st.converged = h_unconv(s) == 0;
    st.tolerance = host.step_tolerance(s);
    st.max_speed = h_speed(s);
    st.max_centre_speed = host.max_centre_speed(s);
    st.count = h_count(s);
    st.failure = static_cast<Failure>(h_fail(s));
    if (st.failure != Failure::None) {
      st.active = false;
      deactivate = true;
      continue;
    }
    const bool quiet = (st.converged || !rest.converged) && st.rest_speed(rest.spin) < rest.speed;
    st.rest_steps = quiet ? st.rest_steps + 1 : 0;
    st.at_rest = st.rest_steps >= rest.steps;
  }
  if (deactivate) upload_status_active();
}

void Batch::Impl::upload_status_active() {
  fill_from(sys.active, static_cast<std::size_t>(n_systems),
            [&](std::size_t s) { return status[s].active ? 1 : 0; });
}

Batch::Batch(const std::vector<SystemSetup>& systems, const SolverSettings& solver,
             const RestSettings& rest)
    : impl_(std::make_unique<Impl>()) {
  impl_->solver = solver;
  impl_->rest = rest;
  impl_->allocate(systems);
}

Batch::~Batch() = default;

int Batch::size() const { return impl_->n_systems; }
const SystemParams& Batch::params(int s) const {
  return impl_->params.at(static_cast<std::size_t>(s));
}
int Batch::max_sweeps(int s) const { return impl_->sweep_cap.at(static_cast<std::size_t>(s)); }
const SolverSettings& Batch::solver() const { return impl_->solver; }

void Batch::step() { impl_->step(); }

void Batch::set_timing(bool on) { impl_->timing = on; }
Batch::KernelEffects Batch::kernel_effects() const { return impl_->needed_effects(); }
const std::vector<std::pair<std::string, double>>& Batch::stage_seconds() const {
  auto& I = *impl_;
  I.stage_seconds.clear();
  for (int k = 0; k < kStepStages; ++k) {
    const auto stage = static_cast<StepStage>(k);
    I.stage_seconds.emplace_back(stage_name(stage), I.timer(stage));
    if (stage == StepStage::Solve && I.newton_time > 0.0)
      I.stage_seconds.emplace_back("newton", I.newton_time);
  }
  return I.stage_seconds;
}

void Batch::reset(int s, const SystemSetup& setup) {
  if (s < 0 || s >= size()) throw std::out_of_range("Batch::reset: no system " + std::to_string(s));
  impl_->load(s, setup);
}

long Batch::run_to_rest(long max_steps) {
  long n = 0;
  for (; n < max_steps; ++n) {
    bool any = false;
    for (int s = 0; s < size(); ++s) {
      const auto& st = impl_->status[static_cast<std::size_t>(s)];
      if (st.active && st.at_rest) set_active(s, false);
      any = any || impl_->status[static_cast<std::size_t>(s)].active;
    }
    if (!any) break;
    step();
  }
  return n;
}

void Batch::set_active(int s, bool active) {
  auto& st = impl_->status.at(static_cast<std::size_t>(s));
  if (active && st.failure != Failure::None) return;
  if (st.active == active) return;
  st.active = active;
  if (active) {
    impl_->restore_warm_start(s);
    impl_->last_stepped[static_cast<std::size_t>(s)] = impl_->batch_steps;
  }
  impl_->upload_status_active();
}

void Batch::set_gravity(int s, bool on) {
  auto& pr = impl_->params.at(static_cast<std::size_t>(s));
  pr.gravity_on = on;
  const double gx = on ? pr.gravity * pr.gravity_dir_x : 0.0;
  const double gy = on ? pr.gravity * pr.gravity_dir_y : 0.0;
  Kokkos::deep_copy(Kokkos::subview(impl_->sys.gravity_x, s), gx);
  Kokkos::deep_copy(Kokkos::subview(impl_->sys.gravity_y, s), gy);
  reset_rest(s);
}

Batch::SolverPace Batch::solver_pace(int s) const {
  const NewtonPace& p = impl_->newton_pace.at(static_cast<std::size_t>(s));
  return {p.wait, p.credit};
}

void Batch::set_solver_pace(int s, const SolverPace& pace) {
  NewtonPace& p = impl_->newton_pace.at(static_cast<std::size_t>(s));
  p.wait = std::clamp(pace.wait, impl_->shortest_newton_wait(), impl_->longest_newton_wait(s));
  p.credit = pace.credit;
  p.charged = 0.0;
}

const SystemStatus& Batch::status(int s) const {
  return impl_->status.at(static_cast<std::size_t>(s));
}

void Batch::reset_rest(int s) {
  auto& st = impl_->status.at(static_cast<std::size_t>(s));
  st.rest_steps = 0;
  st.at_rest = false;
}

std::vector<Deposit> Batch::deposit(const std::vector<char>& mask, DropRule rule) {
  return deposit_at(mask, {}, rule);
}

std::vector<Deposit> Batch::deposit_at(const std::vector<char>& mask, const std::vector<double>& x,
                                       DropRule rule) {
  auto& I = *impl_;
  const auto S = static_cast<std::size_t>(I.n_systems);
  if (mask.size() != S) throw std::invalid_argument("Batch::deposit: mask size");
  if (!x.empty() && x.size() != S) throw std::invalid_argument("Batch::deposit_at: x size");
  // Persistent buffers: no allocation per deposition.
  const DView<double> given = x.empty() ? DView<double>() : I.request_x;
  if (!x.empty()) fill_from(given, S, [&](std::size_t s) { return x[s]; });
  fill_from(I.request, S, [&](std::size_t s) {
    return (mask[s] && I.status[s].failure == Failure::None) ? 1 : 0;
  });
  Kokkos::parallel_for(
      "deposit", Kokkos::TeamPolicy<ExecSpace>(I.n_systems, Kokkos::AUTO),
      DepositKernel{I.sys, I.part, I.request, I.reply, given, rule == DropRule::Capture});
  auto hr = Kokkos::create_mirror_view(I.reply);
  Kokkos::deep_copy(hr, I.reply);
  auto h_fail = Kokkos::create_mirror_view(I.sys.failure);
  Kokkos::deep_copy(h_fail, I.sys.failure);
  std::vector<Deposit> out(S);
  bool deactivate = false;
  for (std::size_t s = 0; s < S; ++s) {
    if (!mask[s]) continue;
    auto& st = I.status[s];
    st.failure = static_cast<Failure>(h_fail(static_cast<int>(s)));
    if (st.failure != Failure::None) {
      deactivate = deactivate || st.active;
      st.active = false;
      continue;
    }
    out[s].placed = hr(4 * s) > 0.5;
    out[s].x = hr(4 * s + 1);
    out[s].y = hr(4 * s + 2);
    out[s].radius = hr(4 * s + 3);
    if (out[s].placed) {
      st.count += 1;
      st.rest_steps = 0;
      st.at_rest = false;
    }
  }
  if (deactivate) I.upload_status_active();
  return out;
}

std::vector<Batch::Avalanche> Batch::close_events(const std::vector<char>& mask, double threshold) {
  auto& I = *impl_;
  const auto S = static_cast<std::size_t>(I.n_systems);
  if (mask.size() != S) throw std::invalid_argument("Batch::close_events: mask size");
  fill_from(I.request, S, [&](std::size_t s) { return mask[s] ? 1 : 0; });
  Kokkos::parallel_for("event_measure", Kokkos::TeamPolicy<ExecSpace>(I.n_systems, Kokkos::AUTO),
                       EventMeasure{I.sys, I.part, I.request, I.reply, threshold});
  auto hr = Kokkos::create_mirror_view(I.reply);
  Kokkos::deep_copy(hr, I.reply);
  std::vector<Avalanche> out(S);
  for (std::size_t s = 0; s < S; ++s) {
    out[s].moved = static_cast<int>(hr(2 * s));
    out[s].downward = hr(2 * s + 1);
  }
  return out;
}

void Batch::set_disks(int s, const std::vector<int>& index, const std::vector<Disk>& disks) {
  auto& I = *impl_;
  const auto& st = I.status.at(static_cast<std::size_t>(s));
  if (index.size() != disks.size()) throw std::invalid_argument("Batch::set_disks: sizes differ");
  const int first = I.offsets[static_cast<std::size_t>(s)];
  const auto range = std::make_pair(first, first + st.count);
  const double width = I.params[static_cast<std::size_t>(s)].width;
  auto put = [&](const DView<double>& v, auto f) {
    auto sub = Kokkos::subview(v, range);
    auto h = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), sub);
    for (std::size_t k = 0; k < index.size(); ++k) {
      if (index[k] < 0 || index[k] >= st.count)
        throw std::out_of_range("Batch::set_disks: no disk " + std::to_string(index[k]));
      h(index[k]) = f(disks[k]);
    }
    Kokkos::deep_copy(sub, h);
  };
  put(I.part.x, [&](const Disk& d) { return std::fmod(std::fmod(d.x, width) + width, width); });
  put(I.part.y, [](const Disk& d) { return d.y; });
  put(I.part.theta, [](const Disk& d) { return d.theta; });
  put(I.part.vx, [](const Disk& d) { return d.vx; });
  put(I.part.vy, [](const Disk& d) { return d.vy; });
  put(I.part.w, [](const Disk& d) { return d.w; });
}

void Batch::set_contacts(int s, const std::vector<ContactForce>& contacts) {
  auto& I = *impl_;
  const auto k = static_cast<std::size_t>(s);
  const auto& st = I.status.at(k);
  const int first = I.offsets[k];
  const auto range = std::make_pair(first * kSlots, (first + I.slot_capacity[k]) * kSlots);
  auto partner = Kokkos::create_mirror_view(Kokkos::subview(I.con.partner, range));
  auto pn = Kokkos::create_mirror_view(Kokkos::subview(I.con.pn, range));
  auto pt = Kokkos::create_mirror_view(Kokkos::subview(I.con.pt, range));
  auto pm = Kokkos::create_mirror_view(Kokkos::subview(I.con.pm, range));
  Kokkos::deep_copy(partner, kNoContact);
  std::vector<int> used(static_cast<std::size_t>(I.slot_capacity[k]), 0);
  const double h = I.params[k].time_step;
  for (const auto& c : contacts) {
    if (c.i < 0 || c.i >= st.count || c.j >= st.count || (c.j >= 0 && c.j <= c.i))
      throw std::out_of_range("Batch::set_contacts: no contact " + std::to_string(c.i) + "-" +
                              std::to_string(c.j));
    int& n = used[static_cast<std::size_t>(c.i)];
    if (n >= kSlots) continue;  // more than a disk can own: no warm start for the rest
    const int slot = c.i * kSlots + n++;
    partner(slot) = c.j < 0 ? kFloor : first + c.j;
    pn(slot) = h * c.normal;
    pt(slot) = h * c.tangential;
    pm(slot) = h * c.moment;
  }
  Kokkos::deep_copy(Kokkos::subview(I.con.partner, range), partner);
  Kokkos::deep_copy(Kokkos::subview(I.con.pn, range), pn);
  Kokkos::deep_copy(Kokkos::subview(I.con.pt, range), pt);
  Kokkos::deep_copy(Kokkos::subview(I.con.pm, range), pm);
  I.last_stepped[k] = I.batch_steps;  // these buffers now hold the system's warm start
}

std::vector<Disk> Batch::disks(int s) const {
  auto& I = *impl_;
  const auto& st = I.status.at(static_cast<std::size_t>(s));
  const int first = I.offsets[static_cast<std::size_t>(s)];
  const auto range = std::make_pair(first, first + st.count);
  auto get = [&](const DView<double>& v) {
    auto sub = Kokkos::subview(v, range);
    auto h = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), sub);
    return h;
  };
  auto x = get(I.part.x), y = get(I.part.y), th = get(I.part.theta);
  auto vx = get(I.part.vx), vy = get(I.part.vy), w = get(I.part.w);
  auto r = get(I.part.radius), im = get(I.part.inv_mass), iI = get(I.part.inv_inertia);
  auto yd = get(I.part.y_deposit);
  std::vector<Disk> out(static_cast<std::size_t>(st.count));
  for (int k = 0; k < st.count; ++k) {
    Disk& d = out[static_cast<std::size_t>(k)];
    d.x = x(k);
    d.y = y(k);
    d.theta = th(k);
    d.vx = vx(k);
    d.vy = vy(k);
    d.w = w(k);
    d.radius = r(k);
    d.fixed = im(k) == 0.0;
    d.lock_rotation = !d.fixed && iI(k) == 0.0;
    d.y_deposit = yd(k);
  }
  return out;
}

std::vector<ContactForce> Batch::contacts(int s) const {
  auto& I = *impl_;
  const auto& st = I.status.at(static_cast<std::size_t>(s));
  const int first = I.offsets[static_cast<std::size_t>(s)];
  const auto range = std::make_pair(first * kSlots, (first + st.count) * kSlots);
  auto geti = [&](const DView<int>& v) {
    return Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), Kokkos::subview(v, range));
  };
  auto getd = [&](const DView<double>& v) {
    return Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), Kokkos::subview(v, range));
  };
  // Partner and impulse arrays are swapped every batch step: a system that sat out an odd
  // number of steps since its last one has its contacts in the other buffer. (The geometry
  // arrays are not swapped; a system that sat out steps keeps its own.)
  const bool other = (I.batch_steps - I.last_stepped[static_cast<std::size_t>(s)]) % 2 == 1;
  auto partner = geti(other ? I.con.prev_partner : I.con.partner);
  auto nx = getd(I.con.nx), ny = getd(I.con.ny), gap = getd(I.con.gap);
  auto pn = getd(other ? I.con.prev_pn : I.con.pn), pt = getd(other ? I.con.prev_pt : I.con.pt),
       pm = getd(other ? I.con.prev_pm : I.con.pm);
  const double h = I.params[static_cast<std::size_t>(s)].time_step;
  std::vector<ContactForce> out;
  for (int c = 0; c < st.count * kSlots; ++c) {
    if (partner(c) == kNoContact) continue;
    ContactForce f;
    f.i = c / kSlots;
    f.j = partner(c) == kFloor ? -1 : partner(c) - first;
    f.nx = nx(c);
    f.ny = ny(c);
    f.gap = gap(c);
    f.normal = pn(c) / h;
    f.tangential = pt(c) / h;
    f.moment = pm(c) / h;
    out.push_back(f);
  }
  return out;
}

Batch::SystemState Batch::state(int s) const {
  auto& I = *impl_;
  const auto k = static_cast<std::size_t>(s);
  SystemState out;
  out.status = I.status.at(k);
  out.disks = disks(s);
  const int first = I.offsets[k], count = out.status.count;
  auto host = [](const auto& v, std::pair<int, int> range) {
    return Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), Kokkos::subview(v, range));
  };
  const auto disk_range = std::make_pair(first, first + count);
  for (auto [to, from] :
       {std::make_pair(&out.y_mark, I.part.y_mark), std::make_pair(&out.inv_mass, I.part.inv_mass),
        std::make_pair(&out.inv_inertia, I.part.inv_inertia)}) {
    const auto h = host(from, disk_range);
    to->assign(h.data(), h.data() + count);
  }
  // The buffers that hold the system's last impulses (see contacts()).
  const bool other = (I.batch_steps - I.last_stepped[k]) % 2 == 1;
  const auto range = std::make_pair(first * kSlots, (first + count) * kSlots);
  const auto partner = host(other ? I.con.prev_partner : I.con.partner, range);
  const auto pn = host(other ? I.con.prev_pn : I.con.pn, range);
  const auto pt = host(other ? I.con.prev_pt : I.con.pt, range);
  const auto pm = host(other ? I.con.prev_pm : I.con.pm, range);
  const auto nx = host(I.con.nx, range), ny = host(I.con.ny, range), gap = host(I.con.gap, range);
  for (int c = 0; c < count * kSlots; ++c) {
    if (partner(c) == kNoContact) continue;
    out.slot.push_back(c);
    out.partner.push_back(partner(c) == kFloor ? -1 : partner(c) - first);
    out.pn.push_back(pn(c));
    out.pt.push_back(pt(c));
    out.pm.push_back(pm(c));
    out.nx.push_back(nx(c));
    out.ny.push_back(ny(c));
    out.gap.push_back(gap(c));
  }
  const auto one = std::make_pair(s, s + 1);
  out.draws = host(I.sys.draws, one)(0);
  out.speed = host(I.sys.max_speed, one)(0);
  out.centre_speed = host(I.sys.max_centre_speed, one)(0);
  out.gravity_on = I.params[k].gravity_on;
  out.status.newton_steps = I.newton_steps[k];
  out.pace = solver_pace(s);
  return out;
}

void Batch::restore(int s, const SystemState& state) {
  auto& I = *impl_;
  const auto k = static_cast<std::size_t>(s);
  const int count = I.status.at(k).count;
  const std::size_t n = state.slot.size();
  const auto disks = state.disks.size();
  bool fits =
      static_cast<int>(disks) == count && state.status.count == count && state.partner.size() == n;
  for (const auto* v : {&state.y_mark, &state.inv_mass, &state.inv_inertia})
    fits = fits && v->size() == disks;
  for (const auto* v : {&state.pn, &state.pt, &state.pm, &state.nx, &state.ny, &state.gap})
    fits = fits && v->size() == n;
  if (!fits)
    throw std::invalid_argument("Batch::restore: the state does not fit system " +
                                std::to_string(s) + " (reset it with the state's disks first)");
  const int first = I.offsets[k];
  auto put = [&](const DView<double>& v, auto f) {
    auto sub = Kokkos::subview(v, std::make_pair(first, first + count));
    auto h = Kokkos::create_mirror_view(sub);
    for (int a = 0; a < count; ++a) h(a) = f(a);
    Kokkos::deep_copy(sub, h);
  };
  // reset() wraps x into the box, which may round it, and computes the masses on the host
  // (deposited disks got theirs on the device).
  put(I.part.x, [&](int a) { return state.disks[static_cast<std::size_t>(a)].x; });
  for (auto [to, from] : {std::make_pair(I.part.y_mark, &state.y_mark),
                          std::make_pair(I.part.inv_mass, &state.inv_mass),
                          std::make_pair(I.part.inv_inertia, &state.inv_inertia)}) {
    const std::vector<double>& values = *from;  // (C++17 lambdas cannot capture a binding)
    put(to, [&](int a) { return values[static_cast<std::size_t>(a)]; });
  }
  // The impulses go where the next step's warm start reads them (as set_contacts).
  const auto range = std::make_pair(first * kSlots, (first + I.slot_capacity[k]) * kSlots);
  auto partner = Kokkos::create_mirror_view(Kokkos::subview(I.con.partner, range));
  auto pn = Kokkos::create_mirror_view(Kokkos::subview(I.con.pn, range));
  auto pt = Kokkos::create_mirror_view(Kokkos::subview(I.con.pt, range));
  auto pm = Kokkos::create_mirror_view(Kokkos::subview(I.con.pm, range));
  auto nx =
      Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), Kokkos::subview(I.con.nx, range));
  auto ny =
      Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), Kokkos::subview(I.con.ny, range));
  auto gap =
      Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), Kokkos::subview(I.con.gap, range));
  Kokkos::deep_copy(partner, kNoContact);
  for (std::size_t c = 0; c < n; ++c) {
    const int slot = state.slot[c], j = state.partner[c];
    if (slot < 0 || slot >= count * kSlots || j < -1 || j >= count)
      throw std::invalid_argument("Batch::restore: contact slot " + std::to_string(slot) +
                                  " with partner " + std::to_string(j) + " is not in system " +
                                  std::to_string(s));
    partner(slot) = j < 0 ? kFloor : first + j;
    pn(slot) = state.pn[c];
    pt(slot) = state.pt[c];
    pm(slot) = state.pm[c];
    nx(slot) = state.nx[c];
    ny(slot) = state.ny[c];
    gap(slot) = state.gap[c];
  }
  Kokkos::deep_copy(Kokkos::subview(I.con.partner, range), partner);
  Kokkos::deep_copy(Kokkos::subview(I.con.pn, range), pn);
  Kokkos::deep_copy(Kokkos::subview(I.con.pt, range), pt);
  Kokkos::deep_copy(Kokkos::subview(I.con.pm, range), pm);
  Kokkos::deep_copy(Kokkos::subview(I.con.nx, range), nx);
  Kokkos::deep_copy(Kokkos::subview(I.con.ny, range), ny);
  Kokkos::deep_copy(Kokkos::subview(I.con.gap, range), gap);
  I.last_stepped[k] = I.batch_steps;
  auto set = [s](const auto& view, auto value) {
    Kokkos::deep_copy(Kokkos::subview(view, s), value);
  };
  set(I.sys.draws, state.draws);
  set(I.sys.max_speed, state.speed);
  set(I.sys.max_centre_speed, state.centre_speed);
  set_gravity(s, state.gravity_on);
  I.status[k] = state.status;
  I.newton_steps[k] = state.status.newton_steps;
  set_solver_pace(s, state.pace);
  I.upload_status_active();
}

double Batch::max_overlap(int s) const {
  const auto d = disks(s);
  const double width = params(s).width;
  double worst = 0.0;
  // Bucket by column of width >= the largest diameter; compare within neighbouring columns.
  double rmax = 0.0;
  for (const auto& a : d) rmax = std::max(rmax, a.radius);
  const int ncol = std::max(1, static_cast<int>(width / (2.0 * rmax + 1e-12)));
  std::vector<std::vector<int>> col(static_cast<std::size_t>(ncol));
  for (std::size_t k = 0; k < d.size(); ++k) {
    worst = std::max(worst, d[k].radius - d[k].y);
    int c = std::min(ncol - 1, static_cast<int>(d[k].x / width * ncol));
    col[static_cast<std::size_t>(c)].push_back(static_cast<int>(k));
  }
  for (int c = 0; c < ncol; ++c) {
    for (int a : col[static_cast<std::size_t>(c)]) {
      const int span = ncol < 3 ? ncol : 3;
      for (int e = 0; e < span; ++e) {
        const int cc = ncol < 3 ? e : (c - 1 + e + ncol) % ncol;
        for (int b : col[static_cast<std::size_t>(cc)]) {
          if (b <= a) continue;
          const auto& p = d[static_cast<std::size_t>(a)];
          const auto& q = d[static_cast<std::size_t>(b)];
          const double dx = periodic_delta(q.x - p.x, width);
          const double dy = q.y - p.y;
          const double ov = p.radius + q.radius - std::sqrt(dx * dx + dy * dy);
          worst = std::max(worst, ov);
        }
      }
    }
  }
  return worst;
}

}  // namespace loosepack
