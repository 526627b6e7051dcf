// Helpers of the tests that run scans end to end (tests/test_protocols.cpp, test_run.cpp,
// test_output.cpp), and the step tolerance at rest that test_region.cpp shares.
#pragma once
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "loosepack/observables.hpp"
#include "loosepack/protocols.hpp"

namespace loosepack::run_helpers {
inline Scan scan_of(const std::string& text) { return parse_scan(text, "test.toml"); }

// A fresh directory under /tmp, removed with everything in it.
struct TempDir {
  std::string path;
  TempDir() {
    char dir[] = "/tmp/loosepack-test-XXXXXX";
    if (!mkdtemp(dir)) throw std::runtime_error("mkdtemp failed");
    path = dir;
  }
  ~TempDir() { std::filesystem::remove_all(path); }
  std::string operator/(const std::string& name) const { return path + "/" + name; }
};

// Every member of a scan, run in the scan's batches.
inline std::vector<MemberResult> run_all(const Scan& scan) {
  return run_members(scan, members_of(scan));
}

inline std::vector<PointResult> run(const Scan& scan) { return aggregate(scan, run_all(scan)); }

// Least-squares slope of y against x, with its standard error.
inline std::pair<double, double> slope(const std::vector<double>& x, const std::vector<double>& y) {
  const double n = static_cast<double>(x.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    sx += x[k];
    sy += y[k];
    sxx += x[k] * x[k];
    sxy += x[k] * y[k];
  }
  const double b = (n * sxy - sx * sy) / (n * sxx - sx * sx);
  const double a = (sy - b * sx) / n;
  double rss = 0;
  for (std::size_t k = 0; k < x.size(); ++k) rss += std::pow(y[k] - a - b * x[k], 2);
  const double se = std::sqrt(rss / (n - 2) / (sxx - sx * sx / n));
  return {b, se};
}

// The floor's normal force on a member's final deposit, and the deposit's weight (m g with
// m = r^2, m = 1 at R = 1, g = 1): equal for a deposit at rest.
inline std::pair<double, double> floor_force_and_weight(const MemberResult& r) {
  double floor = 0.0, weight = 0.0;
  for (const auto& c : r.contacts)
    if (c.j < 0) floor += c.normal;
  for (double rad : r.radius) weight += rad * rad;
  return {floor, weight};
}

// What a step's solve may leave a contact's force off at rest [m g]: the solve ends when no
// impulse changes by more than the step's tolerance in a sweep, max(tolerance, kappa v_max / (g
// max(h, h_kappa))) [h m g] (SolverSettings::relative_tolerance kappa, kRelativeToleranceStep
// h_kappa), and at rest v_max is below the rest speed
// (rest_speed, in sqrt(g R)).
inline double step_tolerance_at_rest(double tolerance, double kappa, double rest_speed,
                                     const SystemParams& p) {
  const double v_rest = rest_speed * std::sqrt(p.gravity * p.radius);
  const double step =
      std::max(p.time_step, kRelativeToleranceStep * std::sqrt(p.radius / p.gravity));
  return std::max(tolerance, kappa * v_rest / (p.gravity * step));
}

// A deposit at rest: the floor contacts' forces sum to its weight (the forces between disks
// cancel, cohesive ones too), each off by about the step's tolerance at rest, so the sum by the
// contacts' count times it (a scale, not a strict bound: a creep below the rest speed adds its
// momentum changes).
inline void expect_floor_carries_the_weight(const MemberResult& r, const Scan& scan) {
  const auto [floor, weight] = floor_force_and_weight(r);
  const double per_contact =
      step_tolerance_at_rest(scan.tolerance(r.member.protocol), scan.solver.relative_tolerance,
                             scan.rest.speed, r.member.params);
  EXPECT_NEAR(floor, weight, per_contact * static_cast<double>(r.contacts.size()))
      << r.contacts.size() << " contacts, " << per_contact << " m g each";
}

// Protocol A with observables.trajectory_every = every: each sampled disk's trajectory starts
// once it is deposited and ends where the disk ends.
inline void expect_trajectories_end_at_final_positions(const MemberResult& r, std::size_t every) {
  ASSERT_FALSE(r.trajectory_time.empty());
  for (std::size_t d = 0; d < r.y_e.size(); d += every) {
    double last_t = -1, x = 0, y = 0, first_t = 1e300;
    for (std::size_t k = 0; k < r.trajectory_time.size(); ++k) {
      if (r.trajectory_disk[k] != static_cast<double>(d)) continue;
      first_t = std::min(first_t, r.trajectory_time[k]);
      if (r.trajectory_time[k] >= last_t) {
        last_t = r.trajectory_time[k];
        x = r.trajectory_x[k];
        y = r.trajectory_y[k];
      }
    }
    EXPECT_EQ(x, r.x[d]) << "disk " << d;
    EXPECT_EQ(y, r.y_e[d]) << "disk " << d;
    EXPECT_GE(first_t, static_cast<double>(d + 1));  // sampled only once deposited
  }
}

// One scan text run twice: in batches of one system and in batches of `many`.
struct BatchedRuns {
  Scan one, many;
  std::vector<MemberResult> alone, batched;
};
inline BatchedRuns run_alone_and_batched(const std::string& text, int many) {
  BatchedRuns r{scan_of(text), scan_of(text), {}, {}};
  r.one.batch_size = 1;
  r.many.batch_size = many;
  r.alone = run_all(r.one);
  r.batched = run_all(r.many);
  return r;
}
}  // namespace loosepack::run_helpers
