// Fault injection for the failure-handling tests (tests/failure_test.sh), kept out of the
// scheduler: LOOSEPACK_INJECT_NAN=<member id> starts that member with one disk of NaN velocity,
// which fails it at its first dynamic step.
#pragma once
#include <cmath>
#include <cstdlib>
#include <string>

#include "loosepack/protocols.hpp"

namespace loosepack {

inline void inject_faults(const Member& m, SystemSetup& setup) {
  const char* nan_member = std::getenv("LOOSEPACK_INJECT_NAN");
  if (!nan_member || std::to_string(m.id) != nan_member) return;
  Disk d;
  d.x = 0.5 * m.params.width;
  d.y = m.params.radius;
  d.radius = m.params.radius;
  d.vy = std::nan("");
  setup.disks.insert(setup.disks.begin(), d);
}

}  // namespace loosepack
