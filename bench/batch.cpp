// Batch scaling (docs/PERFORMANCE.md, "Batch scaling"): the same members run through
// loosepack::run_members in batches of 1, 4, 16, 64 (and 256 with --full) systems, against the same
// members run one after another in a batch of one (the "separate runs": one member per batch slot,
// no other system in the kernels). Prints one JSON record per run:
//
//   separate        every member alone, in order; its wall time per member is the baseline
//   batch           B members in one batch of B slots: deposited disks per second, members per
//                   hour, wall per member, and the cost relative to the separate runs of the
//                   same B members (t_batch / sum of their separate walls; < 1: the batch helps)
//   batch_vs_separate  the largest batch of at most 64 against its separate runs (the issue's
//                   target: at most 1.2)
//
// Members are keyed by (scan seed, member id), so a member deposits the same disks whatever its
// batch (the bit-identical batch tests); the records check it by their disk counts, and the
// program exits 1 when a batch's disks differ or a member fails.
//
//   bench_batch [--tiny] [--full] [--sizes 1,4,16,64] [--protocol A|C] [--width W]
//               [--height H] [--bo B]
#include <Kokkos_Core.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <sstream>
#include <string>
#include <vector>

#include "bench/options.hpp"
#include "bench/record.hpp"
#include "loosepack/protocols.hpp"

using namespace loosepack;

namespace {

struct Workload {
  std::string protocol = "A";
  double width = 24.0, height = 24.0, bond_number = 1e2;
  std::string toml(int seeds) const {
    std::ostringstream o;
    o.precision(17);
    o << "[scan]\nname = \"bench_batch\"\nseed = 2026\nseeds = " << seeds << "\nprotocol = \""
      << protocol << "\"\nbatch_size = 1\n"
      << "[system]\nwidth = " << width << "\nheight = " << height
      << "\nbond_number = " << bond_number
      << "\nfriction = 0.3\nrolling_friction = 0.1\ncohesion_range = 0.01\n"
      << "time_step = " << (protocol == "C" ? 0.003 : 0.01) << "\n"
      << "[solver]\ntolerance = 1e-3\n"
      << "[observables]\nlower_half_from = " << std::min(4.0, height / 4.0) << "\n";
    return o.str();
  }
  std::string json() const {
    return "\"workload\": {\"protocol\": " + bench::json_string(protocol) +
           ", \"width\": " + bench::json_number(width) +
           ", \"height\": " + bench::json_number(height) +
           ", \"bond_number\": " + bench::json_number(bond_number) +
           ", \"solver\": \"accelerated_gauss_seidel\", \"tolerance\": 1e-3, \"max_sweeps\": " +
           std::to_string(bench::default_cap(protocol, width, height)) + "}";
  }
};

struct Run {
  double wall = 0.0, core_share = 0.0;
  long disks = 0, steps = 0, sweeps = 0;
  int failed = 0;
  std::vector<double> member_wall;  // per member, seconds it held its slot
  std::vector<long> member_disks;
};

Run run(const Scan& base, int batch_size, const std::vector<Member>& members) {
  Scan scan = base;
  scan.batch_size = batch_size;
  const double cpu0 = bench::process_cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  const auto results = run_members(scan, members);
  Run r;
  r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.core_share = (bench::process_cpu_seconds() - cpu0) / r.wall;
  for (const auto& m : results) {
    r.disks += static_cast<long>(m.x.size());
    r.steps += m.steps;
    r.sweeps += m.sweeps;
    r.failed += m.ok() ? 0 : 1;
    r.member_wall.push_back(m.wall_time);
    r.member_disks.push_back(static_cast<long>(m.x.size()));
  }
  return r;
}

double sum_first(const std::vector<double>& v, std::size_t n) {
  double s = 0.0;
  for (std::size_t k = 0; k < n && k < v.size(); ++k) s += v[k];
  return s;
}

void print(const std::string& study, const Workload& w, const std::string& fields) {
  std::printf("{\"study\": \"%s\", %s, %s, %s}\n", study.c_str(),
              bench::Environment().json().c_str(), w.json().c_str(), fields.c_str());
  std::fflush(stdout);
}

int usage() {
  std::fprintf(stderr,
               "usage: bench_batch [--tiny] [--full] [--sizes 1,4,16,64] [--protocol A|C] "
               "[--width W] [--height H] [--bo B]\n");
  return 2;
}

// The command line into w and sizes (sorted); false where it is not understood.
bool parse_options(int argc, char** argv, Workload& w, std::vector<int>& sizes) {
  bool full = false;
  for (int a = 1; a < argc; ++a) {
    const std::string f = argv[a];
    const bool has_value = a + 1 < argc;
    if (f == "--tiny") {
      w.width = 8.0;
      w.height = 8.0;
      sizes = {1, 2};
    } else if (f == "--full") {
      full = true;
    } else if (f == "--sizes" && has_value) {
      sizes = bench::parse_list(argv[++a]);
    } else if (f == "--protocol" && has_value) {
      w.protocol = argv[++a];
    } else if (f == "--width" && has_value) {
      w.width = std::atof(argv[++a]);
    } else if (f == "--height" && has_value) {
      w.height = std::atof(argv[++a]);
    } else if (f == "--bo" && has_value) {
      w.bond_number = std::atof(argv[++a]);
    } else {
      return false;
    }
  }
  if (full && std::find(sizes.begin(), sizes.end(), 256) == sizes.end()) sizes.push_back(256);
  std::sort(sizes.begin(), sizes.end());
  return !sizes.empty() && sizes.front() >= 1 && (w.protocol == "A" || w.protocol == "C");
}

void print_separate(const Workload& w, const Run& separate, int members) {
  std::ostringstream f;
  f << "\"members\": " << members << ", \"wall_s\": " << bench::json_number(separate.wall)
    << ", \"core_share\": " << bench::json_number(separate.core_share)
    << ", \"disks\": " << separate.disks << ", \"steps\": " << separate.steps
    << ", \"sweeps\": " << separate.sweeps << ", \"failed\": " << separate.failed
    << ", \"wall_per_member_s\": " << bench::json_number(separate.wall / members)
    << ", \"disks_per_s\": " << bench::json_number(separate.disks / separate.wall)
    << ", \"member_wall_s\": [";
  for (std::size_t k = 0; k < separate.member_wall.size(); ++k)
    f << (k ? ", " : "") << bench::json_number(separate.member_wall[k]);
  f << "]";
  print("separate", w, f.str());
}

// The batch of the first b members against their separate runs (and against a batch of one's time
// per member, per_member_b1, NaN until that ran): its record printed, what it broke appended to
// `broken`; returns its wall time.
double run_batch(const Scan& scan, const Workload& w, const std::vector<Member>& all, int b,
                 const Run& separate, double per_member_b1, std::vector<std::string>& broken) {
  const std::vector<Member> members(all.begin(), all.begin() + b);
  const Run r = run(scan, b, members);
  const double separate_b = sum_first(separate.member_wall, static_cast<std::size_t>(b));
  // The same members deposit the same disks in any batch.
  bool same = r.member_disks.size() == static_cast<std::size_t>(b);
  for (int k = 0; same && k < b; ++k)
    same = r.member_disks[static_cast<std::size_t>(k)] ==
           separate.member_disks[static_cast<std::size_t>(k)];
  const double per_member = r.wall / b;
  const double baseline = b == 1 ? per_member : per_member_b1;  // a batch of 1's, per member
  std::ostringstream f;
  f << "\"batch_size\": " << b << ", \"members\": " << b
    << ", \"wall_s\": " << bench::json_number(r.wall)
    << ", \"core_share\": " << bench::json_number(r.core_share) << ", \"disks\": " << r.disks
    << ", \"steps\": " << r.steps << ", \"sweeps\": " << r.sweeps << ", \"failed\": " << r.failed
    << ", \"disks_per_s\": " << bench::json_number(r.disks / r.wall)
    << ", \"members_per_hour\": " << bench::json_number(3600.0 * b / r.wall)
    << ", \"wall_per_member_s\": " << bench::json_number(per_member)
    << ", \"separate_wall_s\": " << bench::json_number(separate_b)
    << ", \"cost_relative_to_separate\": " << bench::json_number(r.wall / separate_b)
    << ", \"cost_per_member_relative_to_batch_1\": " << bench::json_number(per_member / baseline)
    << ", \"same_disks_as_separate\": " << (same ? "true" : "false");
  print("batch", w, f.str());
  if (!same)
    broken.push_back("a batch of " + std::to_string(b) +
                     " deposited other disks than its members' separate runs");
  if (r.failed > 0)
    broken.push_back(std::to_string(r.failed) + " member(s) failed in a batch of " +
                     std::to_string(b));
  return r.wall;
}

}  // namespace

int main(int argc, char** argv) {
  Kokkos::ScopeGuard kokkos(argc, argv);
  Workload w;
  std::vector<int> sizes = {1, 4, 16, 64};
  if (!parse_options(argc, argv, w, sizes)) return usage();
  const int n_max = sizes.back();
  Scan scan;
  try {
    scan = parse_scan(w.toml(n_max), "bench_batch.toml");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_batch: %s\n", e.what());
    return 1;
  }
  const std::vector<Member> all = members_of(scan);

  // The baseline: every member alone, one after another.
  const Run separate = run(scan, 1, all);
  print_separate(w, separate, n_max);
  double per_member_b1 = NAN;
  int compare_size = 0;
  double compare_batch = NAN;
  std::vector<std::string> broken;  // the invariants a batch broke (its exit status says so)
  for (int b : sizes) {
    const double wall = run_batch(scan, w, all, b, separate, per_member_b1, broken);
    if (b == 1) per_member_b1 = wall;
    if (b <= 64) {
      compare_size = b;
      compare_batch = wall;
    }
  }
  if (compare_size > 0) {
    const double compare_separate =
        sum_first(separate.member_wall, static_cast<std::size_t>(compare_size));
    std::ostringstream f;
    f << "\"members\": " << compare_size
      << ", \"batch_wall_s\": " << bench::json_number(compare_batch)
      << ", \"separate_wall_s\": " << bench::json_number(compare_separate)
      << ", \"ratio\": " << bench::json_number(compare_batch / compare_separate)
      << ", \"target_ratio_at_most\": 1.2";
    print("batch_vs_separate", w, f.str());
  }
  for (const auto& why : broken) std::cerr << "bench_batch: " << why << "\n";
  return broken.empty() ? 0 : 1;
}
