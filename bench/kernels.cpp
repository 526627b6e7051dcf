// Kernel benchmarks on realistic batches (docs/PERFORMANCE.md, "Kernel benchmarks"): the stages of
// a time step (neighbour grid, contact build, one Jacobi sweep, colouring, one coloured
// Gauss-Seidel sweep, one sweep of the host's accelerated Gauss-Seidel, integration) on a batch of
// S systems of N disks, loose and dense, beside a STREAM-like copy measured in the same run.
//
//   loose: a ballistic deposit (Batch::deposit, DropRule::Capture, r_capt = 1, gravity off while
//          it is built), then gravity on at Bo = 1e3: the start of protocol C's collapse.
//   dense: a hexagonal packing standing on the floor, gravity on, Bo = 0.
//   loose_sorted: the loose deposits renumbered in space (contacts and sweeps only).
//   All mu = 0.3, mu_r = 0.1 (the default scene's), h = 0.01, width 60 R.
//
// Every stage is timed kernel by kernel through Kokkos' tool callbacks (begin/end of every
// parallel_for/reduce/scan, by label), so the Batch API needs no hook: one benchmark iteration is
// one Batch::step() of a batch whose solver does exactly `--sweeps` sweeps (tolerance 0), and the
// time reported is the summed time of the stage's kernels in that step (divided by the step's
// sweeps for the sweep stages). With the Serial backend kernels run synchronously, so a kernel's
// begin/end are its true bounds; the few deep_copy calls of a step are not counted.
//
// Counters (in the JSON output): contacts and disks in the batch, contacts per second per core
// (mean and best iteration), and for the sweeps the bytes one sweep reads and writes per contact,
// counted from kernels/solver.hpp (see sweep_bytes), the bandwidth that implies and its ratio to
// the copy bandwidth measured first in the same run (copy/start; copy/end repeats it last); the
// same in whole cache lines (sweep_line_bytes); core_share, the share of a core the benchmark
// got (thread CPU time / wall time: below 1 when other processes compete).
//
//   bench_kernels [--tiny] [--systems S] [--disks N] [--steps K] [--sweeps M] [--copy-mb MB]
//                 [Google Benchmark flags; JSON to stdout unless --benchmark_format says else]
#include <benchmark/benchmark.h>

#include <Kokkos_Core.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "bench/record.hpp"
#include "kernels/state.hpp"
#include "loosepack/batch.hpp"
#include "loosepack/scenes.hpp"

using namespace loosepack;

namespace {

struct Config {
  int systems = 64;
  int disks = 3000;
  double width = 60.0;
  int steps = 10;          // benchmark iterations (time steps) per stage
  int sweeps = 8;          // solver sweeps per step
  double copy_mb = 256.0;  // size of each of the two views of the copy
  int copy_reps = 10;
};
Config g_config;
// The most systems that failed (contact overflow, a non-finite value) in any one benchmark: a
// stage timed on a broken state measures nothing, so the run exits 1.
int g_failed_systems = 0;

// --- Kernel clock: Kokkos tool callbacks time every kernel by label. -------------------------

struct KernelClock {
  std::map<std::string, std::size_t> index;
  std::vector<double> seconds;
  std::vector<long> calls;
  std::chrono::steady_clock::time_point start;

  std::size_t id(const std::string& name) {
    auto it = index.find(name);
    if (it != index.end()) return it->second;
    index.emplace(name, seconds.size());
    seconds.push_back(0.0);
    calls.push_back(0);
    return seconds.size() - 1;
  }
  double total(const std::vector<std::string>& names) {
    double t = 0.0;
    for (const auto& n : names) t += seconds[id(n)];
    return t;
  }
  long count(const std::string& name) { return calls[id(name)]; }
};
KernelClock g_clock;

void kernel_begin(const char* name, const std::uint32_t, std::uint64_t* kernel) {
  *kernel = g_clock.id(name);
  g_clock.start = std::chrono::steady_clock::now();
}
void kernel_end(std::uint64_t kernel) {
  const auto now = std::chrono::steady_clock::now();
  g_clock.seconds[kernel] += std::chrono::duration<double>(now - g_clock.start).count();
  g_clock.calls[kernel] += 1;
}

void install_kernel_clock() {
  namespace T = Kokkos::Tools::Experimental;
  T::set_begin_parallel_for_callback(kernel_begin);
  T::set_end_parallel_for_callback(kernel_end);
  T::set_begin_parallel_reduce_callback(kernel_begin);
  T::set_end_parallel_reduce_callback(kernel_end);
  T::set_begin_parallel_scan_callback(kernel_begin);
  T::set_end_parallel_scan_callback(kernel_end);
}

// The stages of a step and the kernels (labels in src/batch.cpp, kernels/grid.hpp) of each.
struct Stage {
  const char* name;
  std::vector<std::string> kernels;
  bool per_sweep;
};
const Stage kGrid{"grid", {"grid_bin", "grid_scan", "grid_fill", "grid_sort_cells"}, false};
const Stage kContacts{
    "contacts", {"contacts", "incident", "incident_sort", "mobility", "warm_start"}, false};
const Stage kJacobi{"jacobi_sweep", {"jacobi_contacts", "jacobi_bodies", "convergence"}, true};
const Stage kColouring{
    "colouring",
    {"colour_reset", "colour_round", "colour_count", "colour_scan", "colour_fill"},
    false};
const Stage kGaussSeidel{"gauss_seidel_sweep", {"gauss_seidel_colour", "convergence"}, true};
// The host's default solver (one thread per system, NNCG), without Newton rounds: all of a step's
// sweeps in one launch, so its time is divided by the sweeps a step (--sweeps).
const Stage kAcceleratedGaussSeidel{
    "accelerated_gauss_seidel_sweep", {"accelerated_gauss_seidel"}, true};
const Stage kIntegrate{"integrate", {"integrate"}, false};

// --- Packings. --------------------------------------------------------------------------------

// LooseSorted: the loose deposits with their disks renumbered in space (rows of 2 R, then x),
// to see what the deposition order (random in x) costs the gathers of the partner's state.
enum class Packing { Loose, LooseSorted, Dense };
const char* packing_name(Packing p) {
  switch (p) {
    case Packing::Loose:
      return "loose";
    case Packing::LooseSorted:
      return "loose_sorted";
    case Packing::Dense:
      return "dense";
  }
  return "unknown";
}

SystemParams base_params() {
  SystemParams p;
  p.width = g_config.width;
  p.friction = 0.3;
  p.rolling_friction = 0.1;
  p.time_step = 0.01;
  return p;
}

// Ballistic deposits of every system, built in one batch (one random stream per system).
std::vector<SystemSetup> loose_setups() {
  const int S = g_config.systems, N = g_config.disks;
  SystemParams p = base_params();
  p.bond_number = 1e3;
  p.capture_radius = 1.0;
  // Bulk volume fraction of ballistic deposition is about 0.33: room for the loosest.
  p.height = 1.4 * N * M_PI / (0.33 * p.width) + 10.0;
  p.gravity_on = false;
  std::vector<SystemSetup> setups(static_cast<std::size_t>(S));
  for (int s = 0; s < S; ++s) {
    setups[static_cast<std::size_t>(s)].params = p;
    setups[static_cast<std::size_t>(s)].capacity = N;
    setups[static_cast<std::size_t>(s)].seed = 20261122;
    setups[static_cast<std::size_t>(s)].member = static_cast<std::uint64_t>(s);
  }
  {
    Batch builder(setups);
    const std::vector<char> all(static_cast<std::size_t>(S), 1);
    for (int k = 0; k < N; ++k)
      for (const auto& d : builder.deposit(all, DropRule::Capture))
        if (!d.placed) throw std::runtime_error("loose packing: a disk did not fit below H");
    for (int s = 0; s < S; ++s) setups[static_cast<std::size_t>(s)].disks = builder.disks(s);
  }
  for (auto& su : setups) su.params.gravity_on = true;
  return setups;
}

// Hexagonal packing: rows of touching disks on the floor, alternate rows shifted by R.
std::vector<SystemSetup> dense_setups() {
  const int S = g_config.systems, N = g_config.disks;
  SystemParams p = base_params();
  p.bond_number = 0.0;
  const int per_row = static_cast<int>(p.width / 2.0);
  const int rows = (N + per_row - 1) / per_row;
  p.height = 2.0 + rows * std::sqrt(3.0) + 5.0;
  std::vector<Disk> disks = scenes::hexagonal(per_row, rows);
  disks.resize(static_cast<std::size_t>(N));
  for (auto& d : disks) d.y_deposit = d.y;
  std::vector<SystemSetup> setups(static_cast<std::size_t>(S));
  for (int s = 0; s < S; ++s) {
    auto& su = setups[static_cast<std::size_t>(s)];
    su.params = p;
    su.disks = disks;
    su.capacity = N;
    su.seed = 20261122;
    su.member = static_cast<std::uint64_t>(s);
  }
  return setups;
}

std::vector<SystemSetup> sorted(std::vector<SystemSetup> setups) {
  for (auto& su : setups)
    std::sort(su.disks.begin(), su.disks.end(), [](const Disk& a, const Disk& b) {
      const int ra = static_cast<int>(a.y / 2.0), rb = static_cast<int>(b.y / 2.0);
      return ra != rb ? ra < rb : a.x < b.x;
    });
  return setups;
}

const std::vector<SystemSetup>& setups_of(Packing p) {
  static std::map<Packing, std::vector<SystemSetup>> cache;
  auto it = cache.find(p);
  if (it != cache.end()) return it->second;
  switch (p) {
    case Packing::Loose:
      return cache.emplace(p, loose_setups()).first->second;
    case Packing::LooseSorted:
      return cache.emplace(p, sorted(setups_of(Packing::Loose))).first->second;
    case Packing::Dense:
      break;
  }
  return cache.emplace(p, dense_setups()).first->second;
}

// One batch at a time (a 64 x 3000 batch holds about 200 MB of contact arrays).
struct Current {
  Packing packing;
  SolverKind kind;
  std::unique_ptr<Batch> batch;
};
std::unique_ptr<Current> g_current;

Batch& batch_for(Packing p, SolverKind kind) {
  if (!g_current || g_current->packing != p || g_current->kind != kind) {
    g_current.reset();
    SolverSettings solver;
    solver.kind = kind;
    solver.tolerance = 0.0;  // never converged: exactly max_sweeps sweeps per step
    solver.max_sweeps = g_config.sweeps;
    solver.newton_every = 0;  // sweeps only
    auto c = std::make_unique<Current>();
    c->packing = p;
    c->kind = kind;
    c->batch = std::make_unique<Batch>(setups_of(p), solver);
    // Two steps first: contacts found and warm-started as in a running simulation.
    for (int k = 0; k < 2; ++k) c->batch->step();
    g_current = std::move(c);
  }
  return *g_current->batch;
}

struct Census {
  double disks = 0, contacts = 0, floor = 0;
  int failed = 0;
};
Census census(const Batch& b) {
  Census c;
  for (int s = 0; s < b.size(); ++s) {
    c.disks += b.status(s).count;
    c.failed += b.status(s).failure != Failure::None ? 1 : 0;
    for (const auto& f : b.contacts(s)) {
      c.contacts += 1;
      c.floor += f.j < 0 ? 1 : 0;
    }
  }
  return c;
}

// Bytes one sweep reads and writes, counted from kernels/solver.hpp for the kernels these
// batches run (Effects<cohesion, friction, rolling> all on: mu_r > 0 selects them). Per-system
// parameters (a few hundred bytes, cache-resident) are not counted; every other element a
// kernel touches is counted once per touch of its kernel, as if nothing stayed in cache between
// contacts. P disks, C contacts of which F with the floor.
//   Jacobi, contact kernel (every slot of every disk):  partner 4 B x kSlots per disk; per contact
//     12 contact doubles read (wn nx ny gap lower pn pt pm rc wa wb wc) and 3 written (pn pt pm),
//     system index of i, 4 doubles of i (vx vy w radius), and of j unless the floor.
//   Jacobi, body kernel (per disk): system, cell, n_incident, 6 doubles read (vfx vfy wf
//     inv_mass inv_inertia radius), 3 written (vx vy w); per incidence (2 per disk pair, 1 per
//     floor contact) its slot index and 5 doubles (nx ny pn pt pm).
//   Gauss-Seidel (per contact of a colour): list entry, partner, system index, the 12 + 3
//     contact doubles, and for i and for j (unless the floor) vx vy w radius inv_mass
//     inv_inertia read and vx vy w written.
double sweep_bytes(bool jacobi, double P, double C, double F) {
  const double d = 8.0, i = 4.0;
  if (jacobi) {
    const double contact_kernel = i * kSlots * P + C * (15 * d + i + 4 * d) + (C - F) * 4 * d;
    const double body_kernel = P * (3 * i + 9 * d) + (2 * C - F) * (i + 5 * d);
    return contact_kernel + body_kernel;
  }
  return C * (3 * i + 15 * d + 9 * d) + (C - F) * 9 * d;
}

// CPU time of this thread: over a benchmark, cpu / wall is the share of a core the run got
// (below 1 when other processes compete for the cores).
double thread_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

struct CoreShare {
  double cpu0 = thread_cpu_seconds();
  std::chrono::steady_clock::time_point wall0 = std::chrono::steady_clock::now();
  double fraction() const {
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    return (thread_cpu_seconds() - cpu0) / wall;
  }
};

// The same sweep counted in whole 64-byte cache lines, a lower bound of what the memory system
// moves when the batch does not fit in cache. The contact arrays hold kSlots slots per disk
// (structure of arrays: one line per disk per double array), so a disk with one contact moves
// the same lines as a disk with six. Lines of partners and of partner-owned slots are taken as
// cached (index-local neighbours), which makes this a lower bound.
//   Jacobi, per disk: partner (kSlots ints), 12 contact arrays read and 3 written back (one line
//     each), system and 4 doubles of i; body kernel: 3 ints and 6 doubles read, 3 doubles
//     written (with write-allocate), kIncident slot ids, the lines of its own slots in the 5
//     arrays it gathers (nx ny pn pt pm).
//   Gauss-Seidel, per contact: contacts of one colour belong to different disks (a disk's
//     slots share body i), so consecutive ones lie kSlots slots apart: one line per contact in
//     each of the 12 + 3 contact arrays, half a line of partner, the list entry, and the disk
//     state of i and j as counted above.
double sweep_line_bytes(bool jacobi, double P, double C, double F) {
  const double line = 64.0, d = 8.0, i = 4.0;
  if (jacobi)
    return P * (i * kSlots + 15 * line + (i + 4 * d) + 3 * i + 6 * d + 2 * 3 * d + i * kIncident +
                5 * line);
  return C * (i + line / 2 + 15 * line + 9 * d) + (C - F) * 9 * d;
}

// --- Copy bandwidth (STREAM "copy": b = a, bytes counted 2 x 8 per element). ------------------

double g_copy_best_gbs = NAN;  // copy/start: the reference of the ratios

void copy_benchmark(benchmark::State& st, double mb, bool reference) {
  const auto n = static_cast<std::size_t>(mb * 1024 * 1024 / 8);
  Kokkos::View<double*> a("copy_a", n), b("copy_b", n);
  Kokkos::deep_copy(a, 1.0);
  Kokkos::deep_copy(b, 0.0);  // first touch of both before timing
  double best = std::numeric_limits<double>::infinity(), sum = 0;
  const CoreShare share;
  for (auto _ : st) {
    Kokkos::fence();
    const auto t0 = std::chrono::steady_clock::now();
    Kokkos::parallel_for(
        "stream_copy", Kokkos::RangePolicy<>(0, n), KOKKOS_LAMBDA(std::size_t k) { b(k) = a(k); });
    Kokkos::fence();
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    st.SetIterationTime(t);
    best = std::min(best, t);
    sum += t;
  }
  const double bytes = 2.0 * 8.0 * static_cast<double>(n);
  const double mean = sum / static_cast<double>(st.iterations());
  st.counters["core_share"] = share.fraction();
  st.counters["bytes"] = bytes;
  st.counters["GB_per_s_best"] = bytes / best / 1e9;
  st.counters["GB_per_s_mean"] = bytes / mean / 1e9;
  st.SetBytesProcessed(static_cast<std::int64_t>(bytes) * st.iterations());
  if (reference) g_copy_best_gbs = bytes / best / 1e9;
}

// --- Stage benchmarks. ------------------------------------------------------------------------

void stage_benchmark(benchmark::State& st, Packing packing, SolverKind kind, const Stage& stage) {
  Batch& batch = batch_for(packing, kind);
  const Census before = census(batch);
  double best = std::numeric_limits<double>::infinity(), sum = 0, step_sum = 0, sweeps = 0;
  const CoreShare share;
  for (auto _ : st) {
    const double t0 = g_clock.total(stage.kernels);
    const long s0 = g_clock.count("convergence");
    const auto w0 = std::chrono::steady_clock::now();
    batch.step();
    step_sum += std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
    // A solver that tests convergence in a kernel of its own counts its sweeps there; the
    // accelerated solver sweeps exactly max_sweeps times in one launch (tolerance 0).
    const long n_sweeps = kind == SolverKind::AcceleratedGaussSeidel
                              ? g_config.sweeps
                              : g_clock.count("convergence") - s0;
    sweeps += static_cast<double>(n_sweeps);
    const double t = (g_clock.total(stage.kernels) - t0) / (stage.per_sweep ? n_sweeps : 1);
    st.SetIterationTime(t);
    best = std::min(best, t);
    sum += t;
  }
  const double core_share = share.fraction();
  const Census after = census(batch);
  const double iters = static_cast<double>(st.iterations());
  const double mean = sum / iters;
  const double P = 0.5 * (before.disks + after.disks);
  const double C = 0.5 * (before.contacts + after.contacts);
  const double F = 0.5 * (before.floor + after.floor);
  const double cores = Kokkos::DefaultExecutionSpace::concurrency();
  st.counters["core_share"] = core_share;
  st.counters["systems"] = batch.size();
  st.counters["disks"] = P;
  st.counters["contacts"] = C;
  st.counters["contacts_start"] = before.contacts;
  st.counters["contacts_end"] = after.contacts;
  st.counters["failed_systems"] = after.failed;
  g_failed_systems = std::max(g_failed_systems, after.failed);
  st.counters["sweeps_per_step"] = sweeps / iters;
  st.counters["step_s_mean"] = step_sum / iters;
  st.counters["s_best"] = best;
  st.counters["contacts_per_s_per_core"] = C / mean / cores;
  st.counters["contacts_per_s_per_core_best"] = C / best / cores;
  st.counters["disks_per_s_per_core"] = P / mean / cores;
  if (stage.per_sweep && kind != SolverKind::AcceleratedGaussSeidel) {
    const double bytes = sweep_bytes(kind == SolverKind::Jacobi, P, C, F);
    st.counters["bytes_per_contact"] = bytes / C;
    st.counters["GB_per_s_mean"] = bytes / mean / 1e9;
    st.counters["GB_per_s_best"] = bytes / best / 1e9;
    st.counters["copy_GB_per_s_best"] = g_copy_best_gbs;
    st.counters["ratio_to_copy_best"] = bytes / best / 1e9 / g_copy_best_gbs;
    st.counters["ratio_to_copy_mean"] = bytes / mean / 1e9 / g_copy_best_gbs;
    const double lines = sweep_line_bytes(kind == SolverKind::Jacobi, P, C, F);
    st.counters["line_bytes_per_contact"] = lines / C;
    st.counters["line_GB_per_s_best"] = lines / best / 1e9;
    st.counters["line_ratio_to_copy_best"] = lines / best / 1e9 / g_copy_best_gbs;
  }
  st.SetLabel(std::string(packing_name(packing)) + ", " + solver_kind_name(kind));
}

void register_all() {
  // The reference (two views far larger than the caches), and one of 1/16 the size to show
  // what a cache-resident working set gets.
  benchmark::RegisterBenchmark(
      "copy/start", [](benchmark::State& st) { copy_benchmark(st, g_config.copy_mb, true); })
      ->UseManualTime()
      ->Iterations(g_config.copy_reps)
      ->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark(
      "copy/small", [](benchmark::State& st) { copy_benchmark(st, g_config.copy_mb / 16, false); })
      ->UseManualTime()
      ->Iterations(g_config.copy_reps)
      ->Unit(benchmark::kMillisecond);
  for (Packing p : {Packing::Loose, Packing::LooseSorted, Packing::Dense}) {
    const std::string prefix = std::string(packing_name(p)) + "/";
    std::vector<std::pair<SolverKind, const Stage*>> plan = {
        {SolverKind::Jacobi, &kGrid},
        {SolverKind::Jacobi, &kContacts},
        {SolverKind::Jacobi, &kJacobi},
        {SolverKind::Jacobi, &kIntegrate},
        {SolverKind::GaussSeidel, &kColouring},
        {SolverKind::GaussSeidel, &kGaussSeidel},
        {SolverKind::AcceleratedGaussSeidel, &kAcceleratedGaussSeidel}};
    if (p == Packing::LooseSorted)  // the order matters for the gathers: contacts and sweeps
      plan = {{SolverKind::Jacobi, &kContacts},
              {SolverKind::Jacobi, &kJacobi},
              {SolverKind::GaussSeidel, &kGaussSeidel},
              {SolverKind::AcceleratedGaussSeidel, &kAcceleratedGaussSeidel}};
    for (const auto& [kind, stage] : plan)
      benchmark::RegisterBenchmark((prefix + stage->name).c_str(),
                                   [p, kind = kind, stage = stage](benchmark::State& st) {
                                     stage_benchmark(st, p, kind, *stage);
                                   })
          ->UseManualTime()
          ->Iterations(g_config.steps)
          ->Unit(benchmark::kMicrosecond);
  }
  benchmark::RegisterBenchmark(
      "copy/end", [](benchmark::State& st) { copy_benchmark(st, g_config.copy_mb, false); })
      ->UseManualTime()
      ->Iterations(g_config.copy_reps)
      ->Unit(benchmark::kMillisecond);
}

int usage() {
  std::fprintf(stderr,
               "usage: bench_kernels [--tiny] [--systems S] [--disks N] [--steps K] [--sweeps M] "
               "[--copy-mb MB] [Google Benchmark flags]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  Kokkos::ScopeGuard kokkos(argc, argv);
  // Our flags first; the rest go to Google Benchmark (JSON to stdout unless told otherwise).
  std::vector<char*> rest = {argv[0], const_cast<char*>("--benchmark_format=json")};
  for (int a = 1; a < argc; ++a) {
    const std::string f = argv[a];
    const bool has_value = a + 1 < argc;
    if (f == "--tiny") {
      g_config.systems = 2;
      g_config.disks = 200;
      g_config.width = 20.0;
      g_config.steps = 2;
      g_config.sweeps = 4;
      g_config.copy_mb = 4.0;
      g_config.copy_reps = 3;
    } else if (f == "--systems" && has_value) {
      g_config.systems = std::atoi(argv[++a]);
    } else if (f == "--disks" && has_value) {
      g_config.disks = std::atoi(argv[++a]);
    } else if (f == "--steps" && has_value) {
      g_config.steps = std::atoi(argv[++a]);
    } else if (f == "--sweeps" && has_value) {
      g_config.sweeps = std::atoi(argv[++a]);
    } else if (f == "--copy-mb" && has_value) {
      g_config.copy_mb = std::atof(argv[++a]);
    } else if (f.rfind("--benchmark_", 0) == 0) {
      rest.push_back(argv[a]);
    } else {
      return usage();
    }
  }
  if (g_config.systems < 1 || g_config.disks < 1 || g_config.steps < 1 || g_config.sweeps < 1 ||
      !(g_config.copy_mb > 0))
    return usage();
  install_kernel_clock();
  register_all();
  int n = static_cast<int>(rest.size());
  benchmark::Initialize(&n, rest.data());
  if (benchmark::ReportUnrecognizedArguments(n, rest.data())) return 2;
  for (const auto& [k, v] : bench::Environment().strings())
    if (k != "date") benchmark::AddCustomContext(k, v);  // Google Benchmark writes its own
  benchmark::AddCustomContext(
      "workload", std::to_string(g_config.systems) + " systems x " +
                      std::to_string(g_config.disks) + " disks, width " +
                      bench::json_number(g_config.width) + " R, " +
                      std::to_string(g_config.sweeps) + " sweeps per step (tolerance 0), " +
                      std::to_string(g_config.steps) + " steps per stage; copy 2 x " +
                      bench::json_number(g_config.copy_mb) + " MB, best of " +
                      std::to_string(g_config.copy_reps));
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  g_current.reset();
  if (g_failed_systems > 0) {
    std::fprintf(stderr, "bench_kernels: %d system(s) of a benchmark failed (failed_systems)\n",
                 g_failed_systems);
    return 1;
  }
  return 0;
}
