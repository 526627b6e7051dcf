// Fault injection for the failure-handling tests (tests/failure_test.sh), kept out of the
// scheduler and the command: LOOSEPACK_INJECT_NAN=<member id> starts that member with one disk
// of NaN velocity, which fails it at its first dynamic step; LOOSEPACK_INJECT_WRITE_FAILURE=1
// makes the final write of a run fail, as a full disk would; LOOSEPACK_INJECT_FREE_BYTES=<n>
// stands for the free space of the output's file system.
#pragma once
#include <cmath>
#include <cstdlib>
#include <stdexcept>
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

inline void inject_write_failure() {
  const char* fail = std::getenv("LOOSEPACK_INJECT_WRITE_FAILURE");
  if (fail && std::string(fail) == "1")
    throw std::runtime_error("cannot write the result file (LOOSEPACK_INJECT_WRITE_FAILURE)");
}

// The free space to check the run against: the file system's, or the injected figure.
inline double free_bytes_or_injected(double free) {
  const char* injected = std::getenv("LOOSEPACK_INJECT_FREE_BYTES");
  return injected ? std::atof(injected) : free;
}

}  // namespace loosepack
