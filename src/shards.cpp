// Shards of a scan and their merge (include/loosepack/shards.hpp).
#include "loosepack/shards.hpp"

#include <algorithm>
#include <map>
#include <regex>

#include "loosepack/checkpoint.hpp"
#include "loosepack/scan.hpp"

namespace loosepack {

std::pair<int, int> parse_shard(const std::string& text) {
  std::smatch m;
  if (!std::regex_match(text, m, std::regex("([0-9]{1,9})/([0-9]{1,9})")))
    throw ShardError("--shard " + text + ": give K/N, shard K of N counted from 0 (0/4 to 3/4)");
  const int k = std::stoi(m[1].str()), n = std::stoi(m[2].str());
  if (n < 1 || k >= n)
    throw ShardError("--shard " + text + ": K must be at least 0 and below N (0/" +
                     std::to_string(std::max(n, 1)) + " to " + std::to_string(std::max(n, 1) - 1) +
                     "/" + std::to_string(std::max(n, 1)) + ")");
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
  const ShardFile& first = files.front();
  MergedShards out;
  try {
    out.scan = parse_scan(first.scan_text, first.scan_file);
  } catch (const ScanError& e) {
    throw ShardError(first.path + ": its scan text: " + e.what());
  }
  const auto all = members_of(out.scan);
  resolve_backend_defaults(out.scan, all.size());
  const PartRemedies remedy{
      "run that shard again",
      "merge it with the loosepack build that ran it (its git_commit attribute; loosepack "
      "--version)"};
  std::map<std::uint64_t, std::string> holder;  // member id -> the file that holds it
  for (const auto& f : files) {
    if (f.scan_text != first.scan_text)
      throw ShardError(f.path + " is a shard of another scan file than " + first.path +
                       " (their scan_text differs)");
    CheckpointPart part;
    try {
      part = decode_checkpoint_part(f.members, out.scan, f.path + ": shard_members", remedy);
    } catch (const CheckpointError& e) {
      throw ShardError(e.what());
    }
    if (!part.running.empty())
      throw ShardError(f.path + ": shard_members holds members that had not finished");
    for (auto& r : part.finished) {
      const auto [at, fresh] = holder.emplace(r.member.id, f.path);
      if (!fresh)
        throw ShardError("member " + std::to_string(r.member.id) + " is in both " + at->second +
                         " and " + f.path + " (the same shard given twice?)");
      out.members.push_back(std::move(r));
    }
  }
  std::sort(out.members.begin(), out.members.end(),
            [](const MemberResult& a, const MemberResult& b) { return a.member.id < b.member.id; });
  out.info = merged_info(files, static_cast<long>(all.size() - out.members.size()));
  return out;
}

}  // namespace loosepack
