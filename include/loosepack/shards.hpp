// Shards: the members of one scan split into N parts that run apart (`loosepack run SCAN --shard
// K/N`, one job of a batch system's job array each), each writing a result file of its own, and
// merged into the file one run of the whole scan writes (`loosepack merge`). A shard is what rank K
// of an N-rank run started afresh computes; its file carries its members as a checkpoint part
// encodes them, which is how MPI ranks send theirs to rank 0. Every file of fewer than all of a
// scan's members carries them so (a member's, the finished ones'), and merges alike.
#pragma once
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "loosepack/output.hpp"
#include "loosepack/protocols.hpp"

namespace loosepack {

// Invalid shard input: a "K/N" that is not one, or files that cannot be merged. The message
// names the file and says what to do.
class ShardError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// "K/N" as (K, N), 0 <= K < N; throws ShardError saying what is wrong.
std::pair<int, int> parse_shard(const std::string& text);

// The members of shard k of n: rank k's share of an n-rank run that starts afresh (shard_members;
// a resumed run balances what is left instead), in member order.
std::vector<Member> shard_of(const std::vector<Member>& members, int k, int n);

// The files of some of one scan's members, read for a merge (`loosepack merge`): shards' files,
// files of one member (`run --member N`), of the members finished so far (`run --resume
// --finished-only`) and partial merges, each carrying its members encoded (members_encoded).
// Returns the scan (from the first file's scan text, files of no shard first and then shards by
// index, with the backend's defaults resolved as a run of all its members resolves them), every
// member they hold in member order, the provenance of the whole (the first start, the last end,
// the files' wall seconds and MPI ranks summed, the files merged, the members none of them
// holds), and what the files leave out: by shard where shards are among them ("shard 1/3",
// "3 members of shard 2/4 (FILE)"), else by member id ("members 1, 4 to 6"). Throws ShardError
// for a file that holds no encoded members, is damaged or was written by another build, for
// files of different scans, shards of different splits, a shard given twice, a member held by
// two files, and a member in a shard's file that is not its shard's.
struct MergedParts {
  Scan scan;
  std::vector<MemberResult> members;
  RunInfo info;
  std::vector<std::string> missing;
  bool snapshots = false;  // a file holds its members' final states (run --snapshots)
};
MergedParts read_parts(const std::vector<std::string>& paths);

}  // namespace loosepack
