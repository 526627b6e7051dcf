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
  // Members of the scan a file of an unfinished run leaves out (`run --finished-only`).
  long members_unfinished = 0;
  // A shard's file (`run --shard K/N`): K and N (-1 and 0 otherwise).
  int shard = -1, shards = 0;
  // A merged file: the files it was merged from.
  std::vector<std::string> merged_from;
};

// Writes `path` via a temporary file in the same directory and a rename, so an existing file
// is replaced only by a complete one. Throws std::runtime_error on failure.
void write_results(const std::string& path, const Scan& scan, const RunInfo& info,
                   const std::vector<PointResult>& points, const Analysis& analysis,
                   const std::vector<MemberResult>& members, bool snapshots);

// The one way from members to a result file: aggregates `members` (in member order), analyses
// the points and writes `path` (write_results). The points that no member of `members` belongs
// to are left out (a file of one member, of a shard, or of the members finished so far; a run of
// the whole scan has every point's members, failed ones included). A file of fewer than all of
// the scan's members, and a shard's, carries them encoded (/members_encoded) for `loosepack
// merge`. Returns the points written.
std::vector<PointResult> write_member_results(const std::string& path, const Scan& scan,
                                              const RunInfo& info,
                                              const std::vector<MemberResult>& members,
                                              bool snapshots);

// Where a point's nu_lower_half is a mean over `over` of its `finished` members, fewer than all
// (a collapse that took a member's top below 2 lower_half_from leaves its final band empty and
// its value NaN): a line saying so, for the run's warning and the summary; else "".
std::string members_left_out_note(int point, Protocol protocol, int over, int finished);
// The note for a protocol-C point some of whose finished members' collapses were stopped at
// protocol.max_collapse_time while still moving (members' `failure` and `capped`, in the file's
// order), or "" when none was.
std::string capped_collapses_note(int point, const std::vector<double>& failure,
                                  const std::vector<double>& capped);

// What `loosepack merge` reads of a file of some of a scan's members: the scan file's text and
// name, the run's provenance and its members' bytes (a checkpoint part, /members_encoded).
// Throws std::runtime_error naming the file when it is not a loosepack result file, or holds no
// encoded members (a file of a whole scan).
struct PartFile {
  std::string path, scan_text, scan_file, members;
  RunInfo info;
  bool snapshots = false;  // it holds its members' final states (run --snapshots)
};
PartFile read_part_file(const std::string& path);

// Recomputes the analysis of result file `in` from what it stores (its scan_text, the
// aggregated profiles, avalanche bins, histograms and scalars) and writes it with the fits
// replaced to `out` (which may be `in`), through a temporary file and a rename: a file of an
// older program gets the current analysis without a rerun. Throws DamagedResultFile (or
// ScanError for a scan text this program no longer accepts) naming the file and the object
// where `in` cannot be read, std::runtime_error where `out` cannot be written.
void reanalyse(const std::string& in, const std::string& out);

// A result file that opens as one (result_file_problem says nothing) but lacks what a command
// reads or holds what no run writes: a damaged or edited file, invalid input (exit 2). The
// message names the file and, in `what`, the object.
class DamagedResultFile : public std::runtime_error {
 public:
  DamagedResultFile(const std::string& path, const std::string& what)
      : std::runtime_error(path + ": " + what + " (the file is damaged or was edited)") {}
};

// Why `path` is not a result file that can be read, or "": not an HDF5 file HDF5 can open (a
// wrong or damaged file, such as one cut short), or an HDF5 file without `/points` and
// `/scan_text` (another program's, or an export's contacts file). Checked first, so that such a
// file is named as invalid input.
std::string result_file_problem(const std::string& path);

// One line per scan point: parameters and headline observables.
void print_summary(const std::string& path, std::ostream& out);

// Reading back (tests, tools): a dataset of doubles, an attribute of a group.
std::vector<double> read_dataset(const std::string& path, const std::string& name);
double read_attribute_double(const std::string& path, const std::string& object,
                             const std::string& name);
std::string read_attribute_string(const std::string& path, const std::string& object,
                                  const std::string& name);
// The scan file a result file was computed from (the dataset /scan_text; older files: the root
// attribute).
std::string read_scan_text(const std::string& path);

}  // namespace loosepack
