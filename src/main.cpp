// The loosepack command-line program.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <Kokkos_Core.hpp>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <iostream>

#include "loosepack/observables.hpp"
#include "loosepack/output.hpp"
#include "loosepack/protocols.hpp"
#include "loosepack/scan.hpp"

using namespace loosepack;

namespace {

std::string utc_now() {
  std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

std::string directory_of(const std::string& path) {
  const auto k = path.find_last_of('/');
  return k == std::string::npos ? "." : (k == 0 ? "/" : path.substr(0, k));
}

int run(const std::string& scan_path, const std::string& out_path, bool quiet, int batch_size,
        bool snapshots, bool timing) {
  Scan scan;
  try {
    scan = load_scan(scan_path);
  } catch (const ScanError& e) {
    std::cerr << "loosepack: invalid scan: " << e.what() << "\n";
    return 2;
  }
  if (batch_size > 0) scan.batch_size = batch_size;
  for (const auto& w : scan.warnings) std::cerr << "loosepack: warning: " << w << "\n";
  if (::access(directory_of(out_path).c_str(), W_OK) != 0) {
    std::cerr << "loosepack: cannot write into " << directory_of(out_path) << " (for " << out_path
              << ")\n";
    return 2;
  }
  const auto members = members_of(scan);
  if (!quiet)
    std::cerr << "loosepack: scan '" << scan.name << "': " << scan.points.size() << " points x "
              << scan.seeds << " seeds = " << members.size() << " members, batches of "
              << scan.batch_size << " on " << Kokkos::DefaultExecutionSpace::name() << "\n";
  RunInfo info;
  info.start_time = utc_now();
  const auto t0 = std::chrono::steady_clock::now();
  auto last = t0;
  auto progress = [&](const Progress& p) {
    if (quiet) return;
    const auto now = std::chrono::steady_clock::now();
    const bool final = p.members_done == p.members_total;
    if (!final && std::chrono::duration<double>(now - last).count() < 2.0) return;
    last = now;
    const double el = std::chrono::duration<double>(now - t0).count();
    std::fprintf(stderr, "  %d/%d members, %ld disks deposited, %.0f disks/s, %.0f s elapsed",
                 p.members_done, p.members_total, p.disks_deposited,
                 el > 0 ? p.disks_deposited / el : 0.0, el);
    if (p.fraction > 0.01 && !final)
      std::fprintf(stderr, ", about %.0f%% done, rough ETA %.0f s", 100.0 * p.fraction,
                   el * (1.0 - p.fraction) / p.fraction);
    std::fprintf(stderr, "\n");
  };
  std::vector<std::pair<std::string, double>> stages;
  const auto results = run_members(scan, members, progress, timing ? &stages : nullptr);
  if (timing) {
    double total = 0.0;
    for (const auto& st : stages) total += st.second;
    std::fprintf(stderr, "loosepack: time per stage of the step (fenced)\n");
    for (const auto& [name, sec] : stages)
      std::fprintf(stderr, "  %-10s %10.3f s  %5.1f %%\n", name.c_str(), sec,
                   total > 0 ? 100.0 * sec / total : 0.0);
  }
  info.end_time = utc_now();
  info.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  int failed = 0;
  for (const auto& r : results) {
    if (r.ok()) continue;
    ++failed;
    std::cerr << "loosepack: member " << r.member.id << " (point " << r.member.point << ", seed "
              << r.member.seed_index << ", Bo " << r.member.params.bond_number
              << ") failed: " << failure_message(r.failure) << "\n";
  }
  const auto points = aggregate(scan, results);
  try {
    write_results(out_path, scan, info, points, analyse(scan, points), results, snapshots);
  } catch (const std::exception& e) {
    std::cerr << "loosepack: " << e.what() << "\n";
    return 1;
  }
  if (!quiet)
    std::cerr << "loosepack: wrote " << out_path << " (" << info.wall_seconds << " s, " << failed
              << " failed members)\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"loosepack: ensembles of 2D cohesive granular deposits (contact dynamics)"};
  app.require_subcommand(1);
  std::string scan_path, out_path = "out.h5", summary_path;
  bool quiet = false, snapshots = false;
  int batch_size = 0;
  auto* run_cmd = app.add_subcommand("run", "Run a scan file and write one HDF5 result file");
  run_cmd->add_option("scan", scan_path, "scan file (TOML)")->required()->check(CLI::ExistingFile);
  run_cmd->add_option("-o,--output", out_path, "result file (HDF5), written atomically");
  run_cmd->add_flag("-q,--quiet", quiet, "no progress on stderr");
  run_cmd->add_option("--batch-size", batch_size, "systems per batch (overrides scan.batch_size)")
      ->check(CLI::Range(1, 1000000));
  run_cmd->add_flag("--snapshots", snapshots,
                    "store every member's final disks (x, y_i, y_e, r) and contact forces");
  bool timing = false;
  run_cmd->add_flag("--timing", timing, "print the wall time per stage of the step at the end");
  auto* sum_cmd = app.add_subcommand("summary", "Print a table per scan point of a result file");
  sum_cmd->add_option("file", summary_path, "result file (HDF5)")
      ->required()
      ->check(CLI::ExistingFile);
  CLI11_PARSE(app, argc, argv);

  Kokkos::ScopeGuard kokkos(argc, argv);
  if (*run_cmd) return run(scan_path, out_path, quiet, batch_size, snapshots, timing);
  try {
    print_summary(summary_path, std::cout);
  } catch (const std::exception& e) {
    std::cerr << "loosepack: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
