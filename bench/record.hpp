// Where and how a benchmark figure was measured: date, machine, compiler, flags and Kokkos
// backend. The one home of these fields for the study programs' JSON records.
#pragma once
#include <Kokkos_Core.hpp>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "loosepack_git_commit.hpp"

#ifndef LOOSEPACK_COMPILER
#define LOOSEPACK_COMPILER "unknown"
#endif
// All compile flags of the build (LOOSEPACK_CXX_FLAGS, set in the top CMakeLists.txt).
#ifndef LOOSEPACK_CXX_FLAGS
#define LOOSEPACK_CXX_FLAGS "unknown"
#endif

namespace loosepack::bench {

inline std::string json_string(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') {
      o += '\\';
      o += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      o += ' ';
    } else {
      o += c;
    }
  }
  return o + "\"";
}

// A number for JSON: NaN and infinities become null.
inline std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream o;
  o.precision(6);
  o << v;
  return o.str();
}

// First "model name" of /proc/cpuinfo ("unknown" elsewhere).
inline std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) {
        auto v = line.substr(colon + 1);
        const auto first = v.find_first_not_of(' ');
        return first == std::string::npos ? v : v.substr(first);
      }
    }
  return "unknown";
}

inline int cpu_cores() { return static_cast<int>(std::thread::hardware_concurrency()); }

// 1-, 5- and 15-minute load averages at the time of the call (Linux; -1 elsewhere).
inline std::vector<double> load_average() {
  std::ifstream in("/proc/loadavg");
  std::vector<double> v(3, -1.0);
  in >> v[0] >> v[1] >> v[2];
  return v;
}

// UTC time of the call, ISO 8601.
inline std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// CPU time of this process; over a run, cpu / wall is the share of a core it got (below 1 when
// other processes compete for the cores; the Serial backend uses one core).
inline double process_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

inline std::string compile_flags() { return LOOSEPACK_CXX_FLAGS; }

// The environment of one measurement, read when constructed.
struct Environment {
  std::string date = utc_now(), cpu = cpu_model(), compiler = LOOSEPACK_COMPILER,
              flags = compile_flags(), backend = Kokkos::DefaultExecutionSpace::name(),
              commit = LOOSEPACK_GIT_COMMIT;
  int cores = cpu_cores(), concurrency = Kokkos::DefaultExecutionSpace::concurrency(),
      kokkos_version = KOKKOS_VERSION;
  std::vector<double> load = load_average();

  // As plain strings (Google Benchmark's custom context).
  std::vector<std::pair<std::string, std::string>> strings() const {
    return {{"date", date},
            {"cpu", cpu},
            {"cores", std::to_string(cores)},
            {"compiler", compiler},
            {"flags", flags},
            {"kokkos_backend", backend},
            {"kokkos_concurrency", std::to_string(concurrency)},
            {"kokkos_version", std::to_string(kokkos_version)},
            {"commit", commit},
            {"load_average",
             json_number(load[0]) + " " + json_number(load[1]) + " " + json_number(load[2])}};
  }
  // "\"env\": {...}" for one JSON record.
  std::string json() const {
    return "\"env\": {\"date\": " + json_string(date) + ", \"cpu\": " + json_string(cpu) +
           ", \"cores\": " + std::to_string(cores) + ", \"compiler\": " + json_string(compiler) +
           ", \"flags\": " + json_string(flags) + ", \"kokkos_backend\": " + json_string(backend) +
           ", \"kokkos_concurrency\": " + std::to_string(concurrency) +
           ", \"kokkos_version\": " + std::to_string(kokkos_version) +
           ", \"commit\": " + json_string(commit) + ", \"load_average\": [" + json_number(load[0]) +
           ", " + json_number(load[1]) + ", " + json_number(load[2]) + "]}";
  }
};

}  // namespace loosepack::bench
