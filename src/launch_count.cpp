#include "src/launch_count.hpp"

#include <Kokkos_Core.hpp>
#include <atomic>
#include <cstdint>

namespace loosepack {

namespace {

namespace tools = Kokkos::Tools::Experimental;

std::atomic<long> g_launches{0}, g_copies{0};
// The callbacks set before ours (a loaded tool library's), called after counting.
tools::EventSet g_before;

void on_for(const char* name, const std::uint32_t device, std::uint64_t* id) {
  g_launches.fetch_add(1, std::memory_order_relaxed);
  if (g_before.begin_parallel_for) g_before.begin_parallel_for(name, device, id);
}
void on_reduce(const char* name, const std::uint32_t device, std::uint64_t* id) {
  g_launches.fetch_add(1, std::memory_order_relaxed);
  if (g_before.begin_parallel_reduce) g_before.begin_parallel_reduce(name, device, id);
}
void on_scan(const char* name, const std::uint32_t device, std::uint64_t* id) {
  g_launches.fetch_add(1, std::memory_order_relaxed);
  if (g_before.begin_parallel_scan) g_before.begin_parallel_scan(name, device, id);
}
void on_copy(Kokkos::Tools::SpaceHandle dst_space, const char* dst_name, const void* dst,
             Kokkos::Tools::SpaceHandle src_space, const char* src_name, const void* src,
             std::uint64_t bytes) {
  g_copies.fetch_add(1, std::memory_order_relaxed);
  if (g_before.begin_deep_copy)
    g_before.begin_deep_copy(dst_space, dst_name, dst, src_space, src_name, src, bytes);
}

}  // namespace

void count_launches() {
  static const bool started = [] {
    g_before = tools::get_callbacks();
    tools::set_begin_parallel_for_callback(on_for);
    tools::set_begin_parallel_reduce_callback(on_reduce);
    tools::set_begin_parallel_scan_callback(on_scan);
    tools::set_begin_deep_copy_callback(on_copy);
    return true;
  }();
  (void)started;
}

LaunchCounts launch_counts() {
  return {g_launches.load(std::memory_order_relaxed), g_copies.load(std::memory_order_relaxed)};
}

}  // namespace loosepack
