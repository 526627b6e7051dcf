// Encoding of finished members, and checkpoint part files built on it.
#include "loosepack/checkpoint.hpp"

#include <Kokkos_Core.hpp>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <type_traits>

#include "kernels/state.hpp"
#include "loosepack_git_commit.hpp"
#include "replace_file.hpp"

namespace loosepack {

namespace fs = std::filesystem;

namespace {

// "LPCKPT" and the format's version: 02 holds snapshots inside relaxation regions, 03 the
// averaged rest test's state of every system.
constexpr char kMagic[8] = {'L', 'P', 'C', 'K', 'P', 'T', '0', '3'};
constexpr std::uint32_t kByteOrder = 0x01020304u;  // refuses a file from the other endianness

std::uint64_t fnv1a(const char* data, std::size_t n, std::uint64_t h = 14695981039346656037ull) {
  for (std::size_t k = 0; k < n; ++k) {
    h ^= static_cast<unsigned char>(data[k]);
    h *= 1099511628211ull;
  }
  return h;
}

class Writer {
 public:
  explicit Writer(std::string& out) : out_(out) {}
  template <class T>
  void put(T v) {
    static_assert(std::is_trivially_copyable<T>::value, "plain values only");
    const auto* p = reinterpret_cast<const char*>(&v);
    out_.append(p, sizeof(T));
  }
  template <class T>
  void put(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable<T>::value, "plain values only");
    put<std::uint64_t>(v.size());
    if (!v.empty()) out_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }

 private:
  std::string& out_;
};

class Reader {
 public:
  Reader(const std::string& in, std::size_t at, const std::string& what)
      : in_(in), at_(at), what_(what) {}
  template <class T>
  T get() {
    need(sizeof(T));
    T v;
    std::memcpy(&v, in_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return v;
  }
  template <class T = double>
  std::vector<T> vec() {
    const auto n = get<std::uint64_t>();
    if (n > (in_.size() - at_) / sizeof(T)) fail("a vector runs past the end");
    std::vector<T> v(n);
    if (n > 0) std::memcpy(v.data(), in_.data() + at_, n * sizeof(T));  // (an empty one: no data)
    at_ += n * sizeof(T);
    return v;
  }
  std::size_t at() const { return at_; }
  [[noreturn]] void fail(const std::string& why) const {
    throw CheckpointError(what_ + ": " + why + " at byte " + std::to_string(at_));
  }

 private:
  void need(std::size_t n) const {
    if (in_.size() - at_ < n) fail("truncated");
  }
  const std::string& in_;
  std::size_t at_;
  std::string what_;
};

void encode(Writer& w, const MemberResult& r) {
  w.put<std::uint64_t>(r.member.id);
  w.put<std::int32_t>(static_cast<std::int32_t>(r.failure));
  w.put<std::int64_t>(r.steps);
  w.put<std::int64_t>(r.sweeps);
  w.put<std::int32_t>(r.capped);
  w.put<double>(r.wall_time);
  for (const auto* v : {&r.x, &r.y_i, &r.y_e, &r.radius, &r.vx, &r.vy, &r.w, &r.trajectory_time,
                        &r.trajectory_disk, &r.trajectory_x, &r.trajectory_y})
    w.put(*v);
  w.put<std::uint64_t>(r.events.size());
  for (const auto& e : r.events) {
    w.put<std::int32_t>(e.moved);
    w.put<double>(e.downward);
    w.put<std::int64_t>(e.steps);
    w.put<std::uint8_t>(e.capped ? 1 : 0);
  }
  w.put<std::uint64_t>(r.contacts.size());
  for (const auto& c : r.contacts) {
    w.put<std::int32_t>(c.i);
    w.put<std::int32_t>(c.j);
    for (double v : {c.nx, c.ny, c.gap, c.normal, c.tangential, c.moment}) w.put<double>(v);
  }
}

MemberResult decode(Reader& in, const std::vector<Member>& members) {
  MemberResult r;
  const auto id = in.get<std::uint64_t>();
  if (id >= members.size())
    in.fail("member " + std::to_string(id) + " is not in the scan (it has " +
            std::to_string(members.size()) + ")");
  r.member = members[id];
  const auto failure = in.get<std::int32_t>();
  if (failure < 0 || failure > static_cast<std::int32_t>(Failure::Runaway))
    in.fail("unknown failure code " + std::to_string(failure));
  r.failure = static_cast<Failure>(failure);
  r.steps = in.get<std::int64_t>();
  r.sweeps = in.get<std::int64_t>();
  r.capped = in.get<std::int32_t>();
  r.wall_time = in.get<double>();
  for (auto* v : {&r.x, &r.y_i, &r.y_e, &r.radius, &r.vx, &r.vy, &r.w, &r.trajectory_time,
                  &r.trajectory_disk, &r.trajectory_x, &r.trajectory_y})
    *v = in.vec();
  const auto n_events = in.get<std::uint64_t>();
  for (std::uint64_t k = 0; k < n_events; ++k) {
    AvalancheEvent e;
    e.moved = in.get<std::int32_t>();
    e.downward = in.get<double>();
    e.steps = in.get<std::int64_t>();
    e.capped = in.get<std::uint8_t>() != 0;
    r.events.push_back(e);
  }
  const auto n_contacts = in.get<std::uint64_t>();
  for (std::uint64_t k = 0; k < n_contacts; ++k) {
    ContactForce c;
    c.i = in.get<std::int32_t>();
    c.j = in.get<std::int32_t>();
    for (double* v : {&c.nx, &c.ny, &c.gap, &c.normal, &c.tangential, &c.moment})
      *v = in.get<double>();
    r.contacts.push_back(c);
  }
  return r;
}

std::vector<MemberResult> decode_from(Reader& in, const std::vector<Member>& members) {
  const auto n = in.get<std::uint64_t>();
  std::vector<MemberResult> out;
  for (std::uint64_t k = 0; k < n; ++k) out.push_back(decode(in, members));
  return out;
}

// A system's state: its disks, contacts and impulses, stream, status and pace.
void encode(Writer& w, const Batch::SystemState& sys) {
  std::vector<double> disk;
  std::vector<std::uint8_t> flags;
  for (const Disk& d : sys.disks) {
    disk.insert(disk.end(), {d.x, d.y, d.theta, d.vx, d.vy, d.w, d.radius, d.y_deposit});
    flags.push_back(static_cast<std::uint8_t>((d.fixed ? 1 : 0) | (d.lock_rotation ? 2 : 0)));
  }
  w.put(disk);
  w.put(flags);
  for (const auto* v : {&sys.y_mark, &sys.inv_mass, &sys.inv_inertia, &sys.pn, &sys.pt, &sys.pm,
                        &sys.nx, &sys.ny, &sys.gap})
    w.put(*v);
  w.put(sys.slot);
  w.put(sys.partner);
  w.put<std::uint64_t>(sys.draws);
  w.put<double>(sys.speed);
  w.put<double>(sys.centre_speed);
  w.put<std::uint8_t>(sys.gravity_on ? 1 : 0);
  const SystemStatus& ss = sys.status;
  for (bool b : {ss.active, ss.converged, ss.at_rest}) w.put<std::uint8_t>(b ? 1 : 0);
  w.put<std::int32_t>(static_cast<std::int32_t>(ss.failure));
  for (int v : {ss.count, ss.last_sweeps, ss.rest_steps}) w.put<std::int32_t>(v);
  for (long v : {ss.steps, ss.sweeps, ss.newton_steps}) w.put<std::int64_t>(v);
  w.put<double>(ss.max_speed);
  w.put<double>(ss.max_centre_speed);
  w.put<std::int32_t>(sys.pace.wait);
  w.put<double>(sys.pace.credit);
  for (int v : {sys.span_steps, sys.span_step, sys.spans}) w.put<std::int32_t>(v);
  w.put<double>(sys.span_change);
  w.put<double>(ss.mean_speed);
  w.put(sys.span);
}

// A running member's snapshot: its result so far, its stage, its system and its
// relaxation region's, if it is in one.
void encode(Writer& w, const MemberSnapshot& snap) {
  encode(w, snap.result);
  w.put<std::int32_t>(static_cast<std::int32_t>(snap.phase));
  const MemberStage& st = snap.stage;
  for (long v : {st.steps, st.cap, st.moved_until, st.unconverged, st.deposited})
    w.put<std::int64_t>(v);
  w.put<double>(st.filled);
  for (bool b : {st.gave_up, st.checking, st.event_capped, st.event_open, st.final_check})
    w.put<std::uint8_t>(b ? 1 : 0);
  w.put<std::int32_t>(st.below_wake);
  w.put<std::int32_t>(st.rounds);
  w.put(st.column_top);
  encode(w, snap.system);
  w.put<std::uint8_t>(snap.region ? 1 : 0);
  if (!snap.region) return;
  const RegionCut& cut = snap.region->cut;
  w.put(cut.index);
  w.put(std::vector<std::uint8_t>(cut.moving.begin(), cut.moving.end()));
  std::vector<double> seeds;
  for (const auto& p : cut.seeds) seeds.insert(seeds.end(), {p.x, p.y});
  w.put(seeds);
  for (double v : {cut.radius, cut.y0, cut.height, cut.tolerance}) w.put<double>(v);
  encode(w, snap.region->system);
}

// A system's state (encode above); `what` names it in a message.
Batch::SystemState decode_system(Reader& in, const std::string& what) {
  Batch::SystemState sys;
  const auto disk = in.vec();
  const auto flags = in.vec<std::uint8_t>();
  if (disk.size() != 8 * flags.size()) in.fail("the disks of " + what + " do not match");
  for (std::size_t k = 0; k < flags.size(); ++k) {
    const double* d = disk.data() + 8 * k;
    Disk a;
    a.x = d[0], a.y = d[1], a.theta = d[2], a.vx = d[3], a.vy = d[4], a.w = d[5];
    a.radius = d[6], a.y_deposit = d[7];
    a.fixed = (flags[k] & 1) != 0;
    a.lock_rotation = (flags[k] & 2) != 0;
    if (!std::isfinite(a.x) || !std::isfinite(a.y) || !(a.radius > 0.0) || !std::isfinite(a.radius))
      in.fail("a disk of " + what + " is not in its box");
    sys.disks.push_back(a);
  }
  for (auto* v : {&sys.y_mark, &sys.inv_mass, &sys.inv_inertia, &sys.pn, &sys.pt, &sys.pm, &sys.nx,
                  &sys.ny, &sys.gap})
    *v = in.vec();
  sys.slot = in.vec<int>();
  sys.partner = in.vec<int>();
  sys.draws = in.get<std::uint64_t>();
  sys.speed = in.get<double>();
  sys.centre_speed = in.get<double>();
  sys.gravity_on = in.get<std::uint8_t>() != 0;
  SystemStatus& ss = sys.status;
  for (bool* b : {&ss.active, &ss.converged, &ss.at_rest}) *b = in.get<std::uint8_t>() != 0;
  ss.failure = static_cast<Failure>(in.get<std::int32_t>());
  for (int* v : {&ss.count, &ss.last_sweeps, &ss.rest_steps}) *v = in.get<std::int32_t>();
  for (long* v : {&ss.steps, &ss.sweeps, &ss.newton_steps}) *v = in.get<std::int64_t>();
  ss.max_speed = in.get<double>();
  ss.max_centre_speed = in.get<double>();
  sys.pace.wait = in.get<std::int32_t>();
  sys.pace.credit = in.get<double>();
  for (int* v : {&sys.span_steps, &sys.span_step, &sys.spans}) *v = in.get<std::int32_t>();
  sys.span_change = in.get<double>();
  ss.mean_speed = in.get<double>();
  sys.span = in.vec();
  // What Batch::restore needs of a state, checked now rather than when the member gets a slot.
  const std::size_t disks = sys.disks.size(), n = sys.slot.size();
  bool fits =
      ss.count == static_cast<int>(disks) && ss.failure == Failure::None && sys.partner.size() == n;
  for (const auto* v : {&sys.y_mark, &sys.inv_mass, &sys.inv_inertia})
    fits = fits && v->size() == disks;
  for (const auto* v : {&sys.pn, &sys.pt, &sys.pm, &sys.nx, &sys.ny, &sys.gap})
    fits = fits && v->size() == n;
  for (std::size_t c = 0; c < n; ++c)
    fits = fits && sys.slot[c] >= 0 && sys.partner[c] >= -1 &&
           sys.partner[c] < static_cast<int>(disks);
  fits = fits && sys.span.size() == disks * kSpanFields && sys.span_steps >= 0 &&
         sys.span_step >= 0 && (sys.span_steps == 0 || sys.span_step < sys.span_steps) &&
         sys.spans >= 0;
  if (!fits) in.fail("the state of " + what + " does not hold together");
  return sys;
}

// The relaxation region of `who` (encode above), in a system of `whole` disks.
RegionState decode_region(Reader& in, int whole, const std::string& who) {
  RegionState rg;
  RegionCut& cut = rg.cut;
  cut.index = in.vec<int>();
  const auto moving = in.vec<std::uint8_t>();
  cut.moving.assign(moving.begin(), moving.end());
  const auto seeds = in.vec();
  for (std::size_t k = 0; k + 1 < seeds.size(); k += 2)
    cut.seeds.push_back({seeds[k], seeds[k + 1]});
  for (double* v : {&cut.radius, &cut.y0, &cut.height, &cut.tolerance}) *v = in.get<double>();
  rg.system = decode_system(in, "the relaxation region of " + who);
  if (seeds.size() % 2 != 0 || !holds_together(rg, whole))
    in.fail("the relaxation region of " + who + " does not fit its system");
  return rg;
}

MemberSnapshot decode_snapshot(Reader& in, const std::vector<Member>& members) {
  MemberSnapshot snap;
  snap.result = decode(in, members);
  snap.phase = static_cast<MemberPhase>(in.get<std::int32_t>());
  if (!goes_on_from(snap.phase)) in.fail("a running member in no phase it can go on from");
  MemberStage& st = snap.stage;
  for (long* v : {&st.steps, &st.cap, &st.moved_until, &st.unconverged, &st.deposited})
    *v = in.get<std::int64_t>();
  st.filled = in.get<double>();
  for (bool* b : {&st.gave_up, &st.checking, &st.event_capped, &st.event_open, &st.final_check})
    *b = in.get<std::uint8_t>() != 0;
  st.below_wake = in.get<std::int32_t>();
  st.rounds = in.get<std::int32_t>();
  st.column_top = in.vec();
  const std::string who = "running member " + std::to_string(snap.result.member.id);
  snap.system = decode_system(in, who);
  const bool in_region = in.get<std::uint8_t>() != 0;
  if (in_region != (snap.phase == MemberPhase::Region))
    in.fail(who + (in_region ? " has a relaxation region outside one"
                             : " is in a relaxation region without its state"));
  if (!in_region) return snap;
  snap.region = decode_region(in, snap.system.status.count, who);
  return snap;
}

}  // namespace

namespace {
// The program as a checkpoint's fingerprint knows it: version, commit, backend.
std::string program_identity() {
  return std::string("loosepack ") + LOOSEPACK_VERSION + " (commit " + LOOSEPACK_GIT_COMMIT + ", " +
         Kokkos::DefaultExecutionSpace::name() + ")";
}
}  // namespace

std::uint64_t scan_fingerprint(const Scan& scan) {
  const std::string program = program_identity();
  return fnv1a(scan.resume_identity.data(), scan.resume_identity.size(),
               fnv1a(program.data(), program.size()));
}

std::string encode_members(const std::vector<MemberResult>& results) {
  std::string out;
  Writer w(out);
  w.put<std::uint64_t>(results.size());
  for (const auto& r : results) encode(w, r);
  return out;
}

std::vector<MemberResult> decode_members(const std::string& bytes, const Scan& scan,
                                         const std::string& what) {
  Reader in(bytes, 0, what);
  auto out = decode_from(in, members_of(scan));
  if (in.at() != bytes.size()) in.fail("unexpected bytes after the last member");
  return out;
}

std::string checkpoint_directory(const std::string& output_path) {
  return output_path + ".checkpoint";
}

namespace {
// How the `selection` file names a run of the whole scan (an empty file is a damaged one).
constexpr const char* kWholeScan = "the whole scan";
}  // namespace

std::string selection_name(const std::string& selection) {
  return selection.empty() ? kWholeScan : selection;
}

void write_checkpoint_selection(const std::string& directory, const std::string& selection,
                                bool snapshots, const Scan& scan) {
  replace_file(directory + "/scan", [&](const std::string& tmp) {
    write_bytes(tmp, program_identity() + "\n" + scan.resume_identity);
  });
  if (snapshots)
    replace_file(directory + "/snapshots",
                 [&](const std::string& tmp) { write_bytes(tmp, "--snapshots\n"); });
  replace_file(directory + "/selection",
               [&](const std::string& tmp) { write_bytes(tmp, selection_name(selection) + "\n"); });
}

std::optional<std::string> read_checkpoint_selection(const std::string& directory) {
  const std::string path = directory + "/selection";
  std::error_code ec;
  if (!fs::exists(path, ec) && !ec) return std::nullopt;
  std::ifstream f(path);
  std::string line;
  const bool read = static_cast<bool>(std::getline(f, line));
  unsigned long a = 0, b = 0;
  char end = 0;
  const bool known = line == kWholeScan ||
                     std::sscanf(line.c_str(), "--member %lu%c", &a, &end) == 1 ||
                     std::sscanf(line.c_str(), "--shard %lu/%lu%c", &a, &b, &end) == 2;
  if (!read || !known)
    throw CheckpointError(path + " (the --member or --shard of the run that wrote " + directory +
                          ") cannot be read or is damaged: write that option into it (\"" +
                          kWholeScan + "\" for none), or delete " + directory +
                          " to start the run again");
  return line == kWholeScan ? std::string() : line;
}

std::string checkpoint_part(const std::string& directory, int generation, int rank, int finished) {
  return directory + "/part-" + std::to_string(generation) + "-" + std::to_string(rank) +
         (finished > 0 ? "-" + std::to_string(finished) : std::string()) + ".bin";
}

std::string checkpoint_part_bytes(std::uint64_t fingerprint,
                                  const std::vector<MemberResult>& results,
                                  const std::vector<MemberSnapshot>& running) {
  std::string bytes(kMagic, sizeof kMagic);
  Writer w(bytes);
  w.put<std::uint32_t>(kByteOrder);
  w.put<std::uint64_t>(fingerprint);
  bytes += encode_members(results);
  w.put<std::uint64_t>(running.size());
  for (const auto& snap : running) encode(w, snap);
  w.put<std::uint64_t>(fnv1a(bytes.data(), bytes.size()));
  return bytes;
}

void write_checkpoint_part(const std::string& file, std::uint64_t fingerprint,
                           const std::vector<MemberResult>& results,
                           const std::vector<MemberSnapshot>& running) {
  const std::string bytes = checkpoint_part_bytes(fingerprint, results, running);
  replace_file(file, [&](const std::string& tmp) { write_bytes(tmp, bytes); });
}

CheckpointPart decode_checkpoint_part(const std::string& bytes, const std::vector<Member>& members,
                                      std::uint64_t fingerprint, const std::string& what,
                                      const PartRemedies& remedy) {
  constexpr std::size_t kHeader = sizeof kMagic + sizeof(std::uint32_t) + sizeof(std::uint64_t);
  if (bytes.size() < kHeader + 2 * sizeof(std::uint64_t) ||
      std::memcmp(bytes.data(), kMagic, sizeof kMagic - 2) != 0)
    throw CheckpointError(what +
                          " is not a loosepack checkpoint or is truncated: " + remedy.damaged);
  const bool version = std::isdigit(static_cast<unsigned char>(bytes[6])) &&
                       std::isdigit(static_cast<unsigned char>(bytes[7]));
  if (!version) throw CheckpointError(what + " is not a loosepack checkpoint: " + remedy.damaged);
  if (std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0)
    throw CheckpointError(what + " has another checkpoint format (" + bytes.substr(0, 8) +
                          ", this build's " + std::string(kMagic, sizeof kMagic) +
                          "): " + remedy.other_build);
  const std::size_t body = bytes.size() - sizeof(std::uint64_t);
  std::uint64_t stored;
  std::memcpy(&stored, bytes.data() + body, sizeof stored);
  if (stored != fnv1a(bytes.data(), body))
    throw CheckpointError(what + " is corrupt or truncated (checksum mismatch): " + remedy.damaged);
  Reader in(bytes, sizeof kMagic, what);
  if (in.get<std::uint32_t>() != kByteOrder)
    throw CheckpointError(what + " was written on a machine of another byte order");
  if (in.get<std::uint64_t>() != fingerprint)
    throw CheckpointError(
        what +
        " belongs to a scan of other settings or another loosepack build: " + remedy.other_build);
  CheckpointPart part;
  part.finished = decode_from(in, members);
  const auto n_running = in.get<std::uint64_t>();
  for (std::uint64_t k = 0; k < n_running; ++k)
    part.running.push_back(decode_snapshot(in, members));
  if (in.at() != body) in.fail("unexpected bytes after the last member");
  return part;
}

namespace {
// What tells the checkpoint's scan and program from these (its `scan` file against them): the
// program that wrote it, or the first setting that differs, with both values.
std::string what_differs(const std::string& directory, const Scan& scan) {
  std::ifstream f(directory + "/scan");
  std::string program;
  if (!std::getline(f, program))  // a checkpoint of a build that wrote no `scan`
    return "a setting of the scan file was changed, or the program rebuilt, since";
  if (program != program_identity())
    return "it was written by " + program + ", this is " + program_identity();
  const std::string theirs((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const std::string differs =
      first_difference(theirs, scan.resume_identity, "the checkpoint's scan", "this one");
  return differs.empty() ? "a setting of the scan file was changed since" : differs;
}
}  // namespace

namespace {
// A resume may change protocol.max_collapse_time (it is not in the fingerprint:
// Scan::resume_identity). A collapse that ended, at rest or in a failure, within the new cap's
// steps ends the same under it; one stopped at its cap has the result of that cap alone; a
// collapse still running goes on under the new cap while it has not reached it. Protocols A and B
// have no collapse. The steps of member `m`'s collapse under this scan's cap, as its run counts
// them (MemberRun::start_collapse):
long collapse_cap_steps(const Member& m, const Scan& scan) {
  return steps_in(scan.protocol.max_collapse_time, m.params.time_step);
}
bool same_under_cap(const MemberResult& r, const Scan& scan) {
  if (r.member.protocol != Protocol::C) return true;
  const long cap = collapse_cap_steps(r.member, scan);
  return r.capped != 0 ? r.steps == cap : r.steps <= cap;
}
bool goes_on_under_cap(MemberSnapshot& snap, const Scan& scan) {
  if (snap.phase != MemberPhase::Collapse) return true;
  const long cap = collapse_cap_steps(snap.result.member, scan);
  if (snap.stage.steps >= cap) return false;
  snap.stage.cap = cap;
  return true;
}
}  // namespace

CheckpointContents read_checkpoint(const std::string& directory, const Scan& scan) {
  CheckpointContents out;
  std::error_code ec;
  if (!fs::is_directory(directory, ec)) return out;
  std::vector<std::string> files;
  for (fs::directory_iterator it(directory, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.rfind("part-", 0) == 0 && name.size() > 4 &&
        name.compare(name.size() - 4, 4, ".bin") == 0)
      files.push_back(it->path().string());
  }
  if (ec) throw CheckpointError("cannot list the checkpoint " + directory + ": " + ec.message());
  std::sort(files.begin(), files.end());
  const PartRemedies remedy{
      "delete that part alone to keep the others (its members run again), or " + directory +
          " to start the run again",
      what_differs(directory, scan) +
          ": restore the scan file's settings or that build, or delete " + directory +
          " to start the run again"};
  const auto members = members_of(scan);
  const std::uint64_t fingerprint = scan_fingerprint(scan);
  std::map<std::uint64_t, MemberResult> finished;
  std::map<std::uint64_t, std::pair<int, MemberSnapshot>> running;  // the latest generation's
  struct RunningPart {
    std::string file;
    int generation;
    std::vector<std::uint64_t> ids;
  };
  std::vector<RunningPart> running_parts;
  for (const auto& file : files) {
    std::string bytes;
    try {
      bytes = read_bytes(file);
    } catch (const std::runtime_error& e) {  // unreadable: not ours, or the disk's error
      throw CheckpointError(std::string(e.what()) + "; once it can be read, resume; or " +
                            remedy.damaged);
    }
    CheckpointPart part =
        decode_checkpoint_part(bytes, members, fingerprint, "checkpoint " + file, remedy);
    // A member finished twice (under another collapse cap, then run again under this one): the
    // record that this scan's cap ends the same is kept, whichever part came first.
    for (auto& r : part.finished) {
      const auto id = r.member.id;
      const auto [it, fresh] = finished.try_emplace(id, std::move(r));
      if (!fresh && !same_under_cap(it->second, scan) && same_under_cap(r, scan))
        it->second = std::move(r);
    }
    int generation = 0;
    std::sscanf(fs::path(file).filename().string().c_str(), "part-%d-", &generation);
    const bool running_part = part.finished.empty();  // snapshots alone: part-G-R.bin
    if (running_part) running_parts.push_back({file, generation, {}});
    for (auto& snap : part.running) {
      if (running_part) running_parts.back().ids.push_back(snap.result.member.id);
      auto& latest = running[snap.result.member.id];
      if (generation >= latest.first) latest = {generation, std::move(snap)};
    }
    out.generation = std::max(out.generation, generation);
    ++out.parts;
  }
  std::set<std::uint64_t> kept, going_on;
  for (auto& [id, r] : finished)
    if (same_under_cap(r, scan)) {
      kept.insert(id);
      out.members.push_back(std::move(r));
    }
  for (auto& [id, snap] : running)
    if (!kept.count(id) && goes_on_under_cap(snap.second, scan)) {
      going_on.insert(id);
      out.running.push_back(std::move(snap.second));
    }
  for (const auto& [id, r] : finished)
    out.run_again += kept.count(id) || going_on.count(id) ? 0 : 1;
  for (const auto& [id, snap] : running)
    out.run_again += finished.count(id) || going_on.count(id) ? 0 : 1;
  for (const auto& p : running_parts)
    if (p.generation < out.generation &&
        std::all_of(p.ids.begin(), p.ids.end(), [&](std::uint64_t id) {
          return kept.count(id) || running.at(id).first > p.generation;
        }))
      out.superseded.push_back(p.file);
  out.snapshots = fs::exists(directory + "/snapshots");
  return out;
}

std::string remove_checkpoint(const std::string& directory) {
  // Renamed first, at once: a run stopped while the parts are being deleted leaves a temporary
  // (removed by the next run that claims the output), never a checkpoint that looks like an
  // interrupted run's beside the complete result.
  const std::string gone = temporary_of(directory);
  std::error_code ec;
  fs::rename(directory, gone, ec);
  if (ec == std::errc::no_such_file_or_directory) return "";  // none was written
  if (ec) return "cannot remove " + directory + ": " + ec.message();
  fs::remove_all(gone, ec);
  return ec ? "cannot remove " + gone + " (" + directory +
                  ", renamed on its way out): " + ec.message()
            : "";
}

}  // namespace loosepack
