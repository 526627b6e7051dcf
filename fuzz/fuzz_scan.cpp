// libFuzzer target for the scan-file parser and validator (docs/SCAN.md, "Fuzzing").
// parse_scan must return a valid Scan or throw ScanError; any other exception, crash,
// sanitizer report, hang or huge allocation is a bug. Only ScanError is caught here, so
// everything else reaches libFuzzer. A scan that parses also goes through the cheap
// consumers a run calls first (members, per-member capacity, grid cells), so a validation
// gap that makes them overflow or allocate absurdly shows up here too.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "loosepack/batch.hpp"
#include "loosepack/protocols.hpp"
#include "loosepack/scan.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  loosepack::Scan scan;
  try {
    scan = loosepack::parse_scan(text, "fuzz.toml");
  } catch (const loosepack::ScanError&) {
    return 0;
  }
  // A valid scan: the invariants the rest of the program relies on (batch_size 0: the
  // backend's default, protocols.hpp).
  if (scan.points.empty() || scan.seeds < 1 || scan.batch_size < 0) std::abort();
  const auto members = loosepack::members_of(scan);
  if (members.size() != scan.points.size() * static_cast<std::size_t>(scan.seeds)) std::abort();
  for (const auto& pt : scan.points) {
    const auto& p = pt.params;
    if (!std::isfinite(p.width) || !std::isfinite(p.height) || !std::isfinite(p.radius))
      std::abort();
    if (loosepack::member_capacity(p) < 1) std::abort();
    loosepack::SystemSetup su;
    su.params = p;
    if (loosepack::grid_cells_needed(su) < 1) std::abort();
  }
  return 0;
}
