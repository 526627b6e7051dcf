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

// The provenance of a merged file, from the files merged.
RunInfo merged_info(const std::vector<PartFile>& files, long unfinished) {
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

// "shard K/N".
std::string shard_name(int k, int n) {
  return "shard " + std::to_string(k) + "/" + std::to_string(n);
}

// Member ids as ranges: "1, 4 to 6, 9".
std::string id_ranges(const std::vector<std::uint64_t>& ids) {
  std::string out;
  for (std::size_t i = 0; i < ids.size();) {
    std::size_t j = i;
    while (j + 1 < ids.size() && ids[j + 1] == ids[j] + 1) ++j;
    out += (out.empty() ? "" : ", ") + std::to_string(ids[i]) +
           (j > i ? " to " + std::to_string(ids[j]) : "");
    i = j + 1;
  }
  return out;
}

// The scan of the files, from the first's scan text (with the backend's defaults resolved as a
// run of all its members resolves them); every other file's settings checked against it.
Scan scan_of(const std::vector<PartFile>& files) {
  const auto parse = [](const PartFile& f) {
    try {
      return parse_scan(f.scan_text, f.scan_file);
    } catch (const ScanError& e) {
      throw ShardError(f.path + ": its scan text: " + e.what());
    }
  };
  const PartFile& first = files.front();
  Scan scan = parse(first);
  for (const auto& f : files) {
    if (f.scan_text == first.scan_text) continue;
    const std::string differs =
        first_difference(scan.content, parse(f).content, first.path, f.path);
    if (!differs.empty())
      throw ShardError(f.path + " holds members of another scan than " + first.path + ": " +
                       differs);
  }
  resolve_backend_defaults(scan, members_of(scan).size());
  return scan;
}

// The shards' split of the files that are shards: N, or 0 when none is. Shards of two splits are
// refused, a shard given twice, and a split into more shards than the scan's `members`.
int split_of(const std::vector<PartFile>& files, std::size_t members) {
  std::map<int, std::string> given;  // shard -> its file
  const PartFile* first = nullptr;
  for (const auto& f : files) {
    if (f.info.shards == 0) continue;
    if (f.info.shard < 0 || f.info.shard >= f.info.shards)  // what no run writes: a damaged file
      throw ShardError(f.path + ": shard " + std::to_string(f.info.shard) +
                       " is no shard of a split into " + std::to_string(f.info.shards));
    if (!first) first = &f;
    if (f.info.shards != first->info.shards)
      throw ShardError(f.path + " is " + shard_name(f.info.shard, f.info.shards) + ", " +
                       first->path + " one of " + std::to_string(first->info.shards) +
                       ": merge the shards of one split");
    const auto [at, fresh] = given.emplace(f.info.shard, f.path);
    if (!fresh)
      throw ShardError(at->second + " and " + f.path + " are both " +
                       shard_name(f.info.shard, f.info.shards) + " (the same shard given twice?)");
  }
  if (!first) return 0;
  if (static_cast<std::size_t>(first->info.shards) > members)  // what no run writes: a damaged file
    throw ShardError(first->path + ": shards = " + std::to_string(first->info.shards) +
                     " is no split of its scan's " + std::to_string(members) + " members");
  return first->info.shards;
}

// The members of `f`, decoded; a shard's file holds only its shard's.
std::vector<MemberResult> members_in(const PartFile& f, const std::vector<Member>& all,
                                     std::uint64_t fingerprint) {
  const PartRemedies remedy{
      "run its members again",
      "merge it with the loosepack build that ran it (its git_commit attribute; loosepack "
      "--version)"};
  CheckpointPart part;
  try {
    part =
        decode_checkpoint_part(f.members, all, fingerprint, f.path + ": members_encoded", remedy);
  } catch (const CheckpointError& e) {
    throw ShardError(e.what());
  }
  if (!part.running.empty())
    throw ShardError(f.path + ": members_encoded holds members that had not finished");
  if (f.info.shards > 0) {
    std::set<std::uint64_t> own;
    for (const auto& m : shard_of(all, f.info.shard, f.info.shards)) own.insert(m.id);
    for (const auto& r : part.finished)
      if (!own.count(r.member.id))
        throw ShardError(f.path + ": member " + std::to_string(r.member.id) + " is not one of " +
                         shard_name(f.info.shard, f.info.shards) + "'s (was the file edited?)");
  }
  return std::move(part.finished);
}

// What the files leave out of the scan's members (`held` by member id): with shards of a split
// N among them, by shard ("shard 1/3" for a shard of which no member is held, "3 members of
// shard 2/4 (FILE)"), else as member ids ("members 1, 4 to 6").
std::vector<std::string> left_out(const std::vector<PartFile>& files,
                                  const std::vector<Member>& all,
                                  const std::map<std::uint64_t, std::string>& held, int n) {
  std::vector<std::string> out;
  if (n == 0) {
    std::vector<std::uint64_t> ids;
    for (const auto& m : all)
      if (!held.count(m.id)) ids.push_back(m.id);
    if (!ids.empty()) out.push_back((ids.size() == 1 ? "member " : "members ") + id_ranges(ids));
    return out;
  }
  for (int k = 0; k < n; ++k) {
    const auto own = shard_of(all, k, n);
    std::size_t missing = 0;
    for (const auto& m : own) missing += held.count(m.id) ? 0 : 1;
    if (missing == 0) continue;
    const auto file = std::find_if(files.begin(), files.end(), [&](const PartFile& f) {
      return f.info.shards == n && f.info.shard == k;
    });
    if (missing == own.size() && file == files.end())
      out.push_back(shard_name(k, n));
    else
      out.push_back(std::to_string(missing) + (missing == 1 ? " member of " : " members of ") +
                    shard_name(k, n) + (file == files.end() ? "" : " (" + file->path + ")"));
  }
  return out;
}

}  // namespace

MergedParts read_parts(const std::vector<std::string>& paths) {
  std::vector<PartFile> files;
  for (const auto& p : paths) {
    try {
      files.push_back(read_part_file(p));
    } catch (const std::runtime_error& e) {
      throw ShardError(e.what());
    }
  }
  if (files.empty()) throw ShardError("no files to merge");
  // The merged file takes the first file's scan text: files of no shard first, then shards by
  // their index, in whatever order the files are given (a stable sort keeps the rest's order).
  std::stable_sort(files.begin(), files.end(), [](const PartFile& a, const PartFile& b) {
    return a.info.shard < b.info.shard;
  });
  MergedParts out;
  out.scan = scan_of(files);
  const auto all = members_of(out.scan);
  const int n = split_of(files, all.size());
  const std::uint64_t fingerprint = scan_fingerprint(out.scan);
  std::map<std::uint64_t, std::string> held;  // member id -> the file that holds it
  for (const auto& f : files)
    for (auto& r : members_in(f, all, fingerprint)) {
      const auto [at, fresh] = held.emplace(r.member.id, f.path);
      if (!fresh)
        throw ShardError(at->second + " and " + f.path + " both hold member " +
                         std::to_string(r.member.id) + ": merge files of disjoint members");
      out.members.push_back(std::move(r));
    }
  out.missing = left_out(files, all, held, n);
  std::sort(out.members.begin(), out.members.end(),
            [](const MemberResult& a, const MemberResult& b) { return a.member.id < b.member.id; });
  out.info = merged_info(files, static_cast<long>(all.size() - out.members.size()));
  out.snapshots =
      std::any_of(files.begin(), files.end(), [](const PartFile& f) { return f.snapshots; });
  return out;
}

}  // namespace loosepack
