// Shards of a scan and their merge (include/loosepack/shards.hpp).
#include "loosepack/shards.hpp"

#include <algorithm>
#include <map>
#include <regex>
#include <set>

#include "loosepack/checkpoint.hpp"
#include "loosepack/scan.hpp"

namespace loosepack {

std::pair<int, int> parse_shard(const std::string& text) {
  std::smatch m;
  if (!std::regex_match(text, m, std::regex("([0-9]{1,9})/([0-9]{1,9})")))
    throw ShardError("--shard " + text + ": give K/N, shard K of N counted from 0 (0/4 to 3/4)");
  const int k = std::stoi(m[1].str()), n = std::stoi(m[2].str());
  if (n < 1) throw ShardError("--shard " + text + ": N must be at least 1");
  if (k >= n)
    throw ShardError("--shard " + text + ": K must be below N (0/" + std::to_string(n) + " to " +
                     std::to_string(n - 1) + "/" + std::to_string(n) + ")");
  return {k, n};
}

std::vector<Member> shard_of(const std::vector<Member>& members, int k, int n) {
  const auto shards = shard_members(members, n);
  std::vector<Member> out;
  for (std::size_t i : shards.at(static_cast<std::size_t>(k))) out.push_back(members[i]);
  return out;
}

namespace {

// The provenance of a merged file, from its shards' files.
RunInfo merged_info(const std::vector<ShardFile>& files, long unfinished) {
  RunInfo info;
  info.ranks = 0;
  for (const auto& f : files) {
    if (info.start_time.empty() || f.info.start_time < info.start_time)
      info.start_time = f.info.start_time;
    info.end_time = std::max(info.end_time, f.info.end_time);
    info.wall_seconds += f.info.wall_seconds;
    info.ranks += f.info.ranks;
    info.merged_from.push_back(f.path);
  }
  info.members_unfinished = unfinished;
  return info;
}

}  // namespace

MergedShards read_shards(const std::vector<std::string>& paths) {
  std::vector<ShardFile> files;
  for (const auto& p : paths) {
    try {
      files.push_back(read_shard_file(p));
    } catch (const std::runtime_error& e) {
      throw ShardError(e.what());
    }
  }
  if (files.empty()) throw ShardError("no shard files to merge");
  // The lowest shard's scan text is the merged file's, in whatever order the files are given.
  std::stable_sort(files.begin(), files.end(), [](const ShardFile& a, const ShardFile& b) {
    return a.info.shard < b.info.shard;
  });
  const ShardFile& first = files.front();
  // A shard's scan settings (Scan::content), which an edit of the scan file's comments leaves.
  const auto content_of = [](const ShardFile& f) {
    try {
      return parse_scan(f.scan_text, f.scan_file).content;
    } catch (const ScanError& e) {
      throw ShardError(f.path + ": its scan text: " + e.what());
    }
  };
  MergedShards out;
  try {
    out.scan = parse_scan(first.scan_text, first.scan_file);
  } catch (const ScanError& e) {
    throw ShardError(first.path + ": its scan text: " + e.what());
  }
  const auto all = members_of(out.scan);
  resolve_backend_defaults(out.scan, all.size());
  const int n = first.info.shards;
  if (n < 1 || static_cast<std::size_t>(n) > all.size())  // what no run writes: a damaged file
    throw ShardError(first.path + ": shards = " + std::to_string(n) +
                     " is no split of its scan's " + std::to_string(all.size()) + " members");
  const auto name = [n](int k) { return std::to_string(k) + "/" + std::to_string(n); };
  const PartRemedies remedy{
      "run that shard again",
      "merge it with the loosepack build that ran it (its git_commit attribute; loosepack "
      "--version)"};
  const std::uint64_t fingerprint = scan_fingerprint(out.scan);
  std::map<int, std::string> given;  // shard -> its file
  for (const auto& f : files) {
    if (f.scan_text != first.scan_text) {
      const std::string differs =
          first_difference(out.scan.content, content_of(f), first.path, f.path);
      if (!differs.empty())
        throw ShardError(f.path + " is a shard of another scan than " + first.path + ": " +
                         differs);
    }
    if (f.info.shards != n || f.info.shard < 0 || f.info.shard >= n)
      throw ShardError(f.path + " is shard " + std::to_string(f.info.shard) + "/" +
                       std::to_string(f.info.shards) + ", " + first.path + " one of " +
                       std::to_string(n) + ": merge the shards of one split");
    const auto [at, fresh] = given.emplace(f.info.shard, f.path);
    if (!fresh)
      throw ShardError(at->second + " and " + f.path + " are both shard " + name(f.info.shard) +
                       " (the same shard given twice?)");
    CheckpointPart part;
    try {
      part =
          decode_checkpoint_part(f.members, all, fingerprint, f.path + ": shard_members", remedy);
    } catch (const CheckpointError& e) {
      throw ShardError(e.what());
    }
    if (!part.running.empty())
      throw ShardError(f.path + ": shard_members holds members that had not finished");
    std::set<std::uint64_t> own;
    for (const auto& m : shard_of(all, f.info.shard, n)) own.insert(m.id);
    for (auto& r : part.finished) {
      if (!own.count(r.member.id))
        throw ShardError(f.path + ": member " + std::to_string(r.member.id) + " is not one of " +
                         "shard " + name(f.info.shard) + "'s (was the file edited?)");
      own.erase(r.member.id);
      out.members.push_back(std::move(r));
    }
    if (!own.empty())  // a shard's file of its finished members only (--finished-only)
      out.missing.push_back(std::to_string(own.size()) + " members of shard " + name(f.info.shard) +
                            " (" + f.path + ")");
  }
  for (int k = 0; k < n; ++k)
    if (!given.count(k)) out.missing.push_back("shard " + name(k));
  std::sort(out.members.begin(), out.members.end(),
            [](const MemberResult& a, const MemberResult& b) { return a.member.id < b.member.id; });
  out.info = merged_info(files, static_cast<long>(all.size() - out.members.size()));
  return out;
}

}  // namespace loosepack
