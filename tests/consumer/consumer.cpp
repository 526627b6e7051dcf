// Runs one small scan through the installed library: two members of protocol A at Bo = 0 in a
// 12 R x 12 R box, aggregated; prints the members, the disks and nu_lower_half with its error.
#include <cstdio>

#include <Kokkos_Core.hpp>

#include "loosepack/observables.hpp"
#include "loosepack/protocols.hpp"
#include "loosepack/scan.hpp"

int main(int argc, char** argv) {
  Kokkos::ScopeGuard kokkos(argc, argv);
  loosepack::Scan scan = loosepack::parse_scan(
      "[scan]\nseeds = 2\nprotocol = \"A\"\n[system]\nwidth = 12\nheight = 12\nbond_number = 0\n",
      "consumer.toml");
  const auto members = loosepack::members_of(scan);
  loosepack::resolve_backend_defaults(scan, members.size());
  const auto results = loosepack::run_members(scan, members);
  const auto points = loosepack::aggregate(scan, results);
  std::size_t disks = 0;
  for (const auto& r : results) disks += r.y_e.size();
  std::printf("members %zu disks %zu nu_lower_half %.4f +- %.4f\n", results.size(), disks,
              points.at(0).nu_lower_half.mean, points.at(0).nu_lower_half.sem);
  return 0;
}
