// Shards: the members of one scan split into N parts that run apart (`loosepack run SCAN
// --shard K/N`, one job of a batch system's job array each), each writing a result file of its
// own, and merged into the file one run of the whole scan writes (`loosepack merge`). A shard
// is what rank K of an N-rank run computes; its file carries its members as a checkpoint part
// encodes them, which is how MPI ranks send theirs to rank 0.
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

// The members of shard k of n: rank k's share of an n-rank run (shard_members), in member order.
std::vector<Member> shard_of(const std::vector<Member>& members, int k, int n);

// The shard files of one split of one scan, read for a merge: the scan (from their scan text,
// with the backend's defaults resolved as a run of all its members resolves them), every member
// they hold in member order, the provenance of the whole (the first start, the last end, the
// files' wall seconds and MPI ranks summed, the files merged, the members none of them holds),
// and what the files leave out: shards not given, and shards of which a file holds only the
// members finished (`run --resume --finished-only`). Throws ShardError for a file that is not a
// shard's, is damaged or was written by another build, for shards of different scan files or
// splits, a shard given twice, and a member that is not its shard's.
struct MergedShards {
  Scan scan;
  std::vector<MemberResult> members;
  RunInfo info;
  std::vector<std::string> missing;  // "shard 1/4", "3 members of shard 2/4 (FILE)"
};
MergedShards read_shards(const std::vector<std::string>& paths);

}  // namespace loosepack
