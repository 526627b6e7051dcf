// Fault injection for the failure-handling tests (tests/failure_test.sh), kept out of the
// scheduler and the command: LOOSEPACK_INJECT_NAN=<member id> starts that member with one disk
// of NaN velocity, which fails it at its first dynamic step; LOOSEPACK_INJECT_OVERLAP=<member
// id> starts it with two disks on the floor overlapping by 0.5 R (contact dynamics holds an
// overlap; the member fails at its end, Failure::Overlap); LOOSEPACK_INJECT_WRITE_FAILURE=1
// makes the final write of a run fail, as a full disk would; LOOSEPACK_INJECT_FREE_BYTES=<n>
// stands for the free space of the output's file system; LOOSEPACK_INJECT_ERROR=<member id>
// throws when that member starts, as an error the run cannot go on from would (memory);
// LOOSEPACK_INJECT_ESCAPE=<member id> starts it with a fixed disk above H + 4 R_max, where a disk
// of a solution that blew up ends (the member fails at its end, Failure::Escaped).
#pragma once
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "loosepack/geometry.hpp"
#include "loosepack/protocols.hpp"

namespace loosepack {

inline bool injected_into(const char* variable, const Member& m) {
  const char* member = std::getenv(variable);
  return member && std::to_string(m.id) == member;
}

inline void inject_faults(const Member& m, SystemSetup& setup) {
  Disk d;
  d.x = 0.5 * m.params.width;
  d.y = m.params.radius;
  d.radius = m.params.radius;
  if (injected_into("LOOSEPACK_INJECT_NAN", m)) {
    d.vy = std::nan("");
    setup.disks.insert(setup.disks.begin(), d);
  }
  if (injected_into("LOOSEPACK_INJECT_OVERLAP", m)) {  // two disks on the floor, 0.5 R deep
    Disk e = d;
    e.x += 1.5 * d.radius;
    setup.disks.insert(setup.disks.begin(), {d, e});
  }
  if (injected_into("LOOSEPACK_INJECT_ESCAPE", m)) {
    Disk high = d;
    high.y = escape_height(m.params) + 2.0 * d.radius;
    high.fixed = true;
    setup.disks.insert(setup.disks.begin(), high);
  }
}

// Where a member starts in its slot.
inline void inject_error(const Member& m) {
  if (injected_into("LOOSEPACK_INJECT_ERROR", m))
    throw std::runtime_error("member " + std::to_string(m.id) +
                             " could not start (LOOSEPACK_INJECT_ERROR)");
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
