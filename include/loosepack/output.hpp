// The HDF5 result file (layout in docs/OUTPUT.md), written atomically, and its summary.
#pragma once
#include <ostream>
#include <string>
#include <vector>

#include "loosepack/analysis.hpp"
#include "loosepack/observables.hpp"

namespace loosepack {

struct RunInfo {
  std::string start_time, end_time;  // ISO 8601, UTC
  double wall_seconds = 0.0;
  int ranks = 1;
};

// Writes `path` via a temporary file in the same directory and a rename, so an existing file
// is replaced only by a complete one. Throws std::runtime_error on failure.
void write_results(const std::string& path, const Scan& scan, const RunInfo& info,
                   const std::vector<PointResult>& points, const Analysis& analysis,
                   const std::vector<MemberResult>& members, bool snapshots);

// One line per scan point: parameters and headline observables.
void print_summary(const std::string& path, std::ostream& out);

// Reading back (tests, tools): a dataset of doubles, an attribute of a group.
std::vector<double> read_dataset(const std::string& path, const std::string& name);
double read_attribute_double(const std::string& path, const std::string& object,
                             const std::string& name);
std::string read_attribute_string(const std::string& path, const std::string& object,
                                  const std::string& name);

}  // namespace loosepack
