// What the program asks of Kokkos, counted for `loosepack run --timing`: kernel launches
// (parallel_for, parallel_reduce and parallel_scan, the fills of new views included) and deep
// copies (fills included). On a device backend a copy between device and host memory, a fill
// without an execution space and a reduction into a host value each make the host wait for the
// device. The counts come from Kokkos Tools callbacks;
// a tool library the user loaded (KOKKOS_PROFILE_LIBRARY) still receives its own.
#pragma once

namespace loosepack {

struct LaunchCounts {
  long launches = 0, copies = 0;
};

// Starts counting (once; later calls do nothing). Call after Kokkos::initialize.
void count_launches();
// The counts since counting started.
LaunchCounts launch_counts();

}  // namespace loosepack
