// Finished members as bytes: the checkpoint files of an interrupted run (with snapshots of the
// members still running) and the messages that carry results between MPI ranks use the same
// encoding (layout in docs/OUTPUT.md).
#pragma once
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "loosepack/protocols.hpp"

namespace loosepack {

// Thrown for a checkpoint that cannot be used: written for another scan or program, corrupt or
// truncated. The message names the file and says what to do.
class CheckpointError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Identifies what a checkpoint belongs to: the scan file's settings (Scan::resume_identity: an
// edit of its comments or layout leaves them, and so does protocol.max_collapse_time, whose
// members read_checkpoint checks one by one) and the program (version, commit and Kokkos
// backend), since another build may give other bits.
std::uint64_t scan_fingerprint(const Scan& scan);

// Member results as bytes and back. Doubles travel bit for bit. Decoding takes each member's
// parameters from the scan (by member id) and throws CheckpointError naming `what` when the
// bytes are short, too long or name a member the scan does not have.
std::string encode_members(const std::vector<MemberResult>& results);
std::vector<MemberResult> decode_members(const std::string& bytes, const Scan& scan,
                                         const std::string& what);

// A checkpoint is a directory (next to the output file, `<output>.checkpoint/`) of part files.
// Each rank of a run writes the members it finished since its last checkpoint into a new part,
// written once (`part-<generation>-<rank>-<k>.bin`, k = 1, 2, ...), and the snapshots of its
// running members into one part rewritten at every checkpoint (`part-<generation>-<rank>.bin`,
// `finished` = 0), after the finished one: a member is encoded once, however long the run. A
// resumed run reads every part and writes new ones under the next generation, so no part is
// ever rewritten by another run.
std::string checkpoint_directory(const std::string& output_path);
// The members the run that writes a checkpoint selects, as its command line names them
// (`--member N`, `--shard K/N`, or empty for the whole scan), in `<directory>/selection`,
// written by each rank before its first part: a resume must select the same. Reading gives
// std::nullopt where the file does not exist (a checkpoint of a build that wrote none) and
// throws CheckpointError where it cannot be read or names no selection. With `snapshots` (the
// run asked for --snapshots) the file `<directory>/snapshots` says so, and a resume writes them.
// The file `<directory>/scan` holds the program and the scan's identity (Scan::resume_identity)
// the fingerprint is made of, so that a refused resume can say what differs.
void write_checkpoint_selection(const std::string& directory, const std::string& selection,
                                bool snapshots, const Scan& scan);
std::optional<std::string> read_checkpoint_selection(const std::string& directory);
// A selection as the file and the messages name it: itself, or "the whole scan" where empty.
std::string selection_name(const std::string& selection);
std::string checkpoint_part(const std::string& directory, int generation, int rank,
                            int finished = 0);

// One part as bytes: header with the fingerprint, the encoded members, snapshots of the
// running members, and a checksum of all of it. A part file holds these bytes, and so does a
// shard's result file (`run --shard`, docs/OUTPUT.md).
std::string checkpoint_part_bytes(std::uint64_t fingerprint,
                                  const std::vector<MemberResult>& results,
                                  const std::vector<MemberSnapshot>& running = {});
// Writes one part's bytes atomically (temporary file, then rename).
void write_checkpoint_part(const std::string& file, std::uint64_t fingerprint,
                           const std::vector<MemberResult>& results,
                           const std::vector<MemberSnapshot>& running = {});

// Every finished member in the directory's parts (each member once, in member order), the
// latest snapshot (from the highest generation) of every member not finished, and the highest
// generation found (0 when the directory has no parts). Throws CheckpointError for a part of
// another scan or program, or a corrupt or truncated part.
struct CheckpointContents {
  std::vector<MemberResult> members;
  std::vector<MemberSnapshot> running;
  int generation = 0;
  int parts = 0;
  bool snapshots = false;  // the run that wrote it asked for --snapshots
  // Members it holds that run again from the start: collapses that end otherwise under this
  // scan's protocol.max_collapse_time (stopped at another cap, or past this one).
  int run_again = 0;
  // Running parts of earlier generations whose every snapshot a later record replaces (its
  // member's snapshot in a later generation's part, or its finished record kept): a resumed run
  // removes them, so that a checkpoint does not grow by a copy of the snapshots each resume.
  std::vector<std::string> superseded;
};
CheckpointContents read_checkpoint(const std::string& directory, const Scan& scan);

// One part's bytes back: its finished members and the snapshots of its running ones, of the
// scan whose members are `members` (members_of) and fingerprint `fingerprint`
// (scan_fingerprint). Checks the format, the checksum, the byte order and the fingerprint;
// throws CheckpointError naming `what` and saying what to do: `damaged` for bytes that are not
// a whole part, `other_build` for a part of another format, scan or build.
struct PartRemedies {
  std::string damaged, other_build;
};
struct CheckpointPart {
  std::vector<MemberResult> finished;
  std::vector<MemberSnapshot> running;
};
CheckpointPart decode_checkpoint_part(const std::string& bytes, const std::vector<Member>& members,
                                      std::uint64_t fingerprint, const std::string& what,
                                      const PartRemedies& remedy);

// Removes the directory's part files and the directory (after a complete result was written):
// renamed to a temporary at once, then deleted; returns what failed ("cannot remove DIR:
// reason"), or "".
std::string remove_checkpoint(const std::string& directory);

}  // namespace loosepack
