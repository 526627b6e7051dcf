// The loosepack command-line program.
#include <unistd.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <CLI/CLI.hpp>
#include <Kokkos_Core.hpp>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>
#include <vector>

#include "fault_injection.hpp"
#include "loosepack/checkpoint.hpp"
#include "loosepack/export.hpp"
#include "loosepack/observables.hpp"
#include "loosepack/output.hpp"
#include "loosepack/parallel.hpp"
#include "loosepack/protocols.hpp"
#include "loosepack/scan.hpp"
#include "loosepack/shards.hpp"
#include "loosepack_git_commit.hpp"
#include "output_lock.hpp"
#include "replace_file.hpp"

using namespace loosepack;

namespace {

std::string utc_now() {
  std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return buf;
}

// Why `out` cannot take a result file ("" when it can): it must be a new name in a writable
// directory or an existing regular file, and not the input the command reads, and the names
// written beside it (its temporary, lock and checkpoint) must fit the file system's limit on a
// name, or a run would compute its members and then fail to write them.
std::string output_path_problem(const std::string& out, const std::string& input) {
  namespace fs = std::filesystem;
  if (out.empty()) return "the output path is empty";
  std::error_code ec;
  const fs::file_status st = fs::symlink_status(out, ec);
  if (fs::exists(st)) {
    if (fs::is_symlink(st)) return out + " is a symbolic link (give the file it points to)";
    if (fs::is_directory(st)) return out + " is a directory (give a file name in it)";
    if (!fs::is_regular_file(st)) return out + " is not a regular file (a device, FIFO or socket)";
    if (fs::equivalent(out, input, ec)) return out + " is the input file " + input;
  }
  const std::string dir = directory_of_path(out);
  if (!fs::is_directory(dir, ec))
    return fs::exists(dir, ec)
               ? dir + " (of " + out + ") is not a directory"
               : "the directory " + dir + " of " + out + " does not exist (make it first)";
  if (::access(dir.c_str(), W_OK) != 0)
    return "cannot write into " + dir + " (for " + out + "): " + std::strerror(errno);
  long most = ::pathconf(dir.c_str(), _PC_NAME_MAX);
  if (most <= 0) most = 255;
  for (const std::string& beside :
       {temporary_of(out, kLargestPid), out + ".lock",
        temporary_of(checkpoint_directory(out), kLargestPid)}) {  // the checkpoint on its way out
    const std::string name = fs::path(beside).filename().string();
    if (static_cast<long>(name.size()) > most)
      return "the name of " + out + " is too long: the program writes " + name + " beside it, " +
             std::to_string(name.size()) + " characters where the file system allows " +
             std::to_string(most) + "; give a shorter one";
  }
  return "";
}

// Why the output's file system clearly cannot take the results of the members to compute (""
// when it may): a first check, before any work, at 48 bytes for each disk a member can hold
// (member_capacity, the hexagonal packing's count), what a finished member's disks and events
// take in the checkpoint (x, y_i, y_e, radius; one event a disk in A) with room to spare in
// loose deposits. Its contacts take 56 bytes each on top, up to about 170 bytes a disk in a dense
// packing, and trajectories (observables.trajectory_every) more: a run can still fill the disk
// later, and then it keeps what it saved and says how to go on (save_checkpoint).
std::string space_problem(const std::string& out, const std::vector<Member>& members) {
  constexpr double kBytesPerDisk = 48.0;
  double bytes = 0.0;
  for (const auto& m : members) bytes += kBytesPerDisk * member_capacity(m.params);
  std::error_code ec;
  const auto space = std::filesystem::space(directory_of_path(out), ec);
  const double free = free_bytes_or_injected(static_cast<double>(space.available));
  if (ec || free >= bytes) return "";
  std::ostringstream o;
  o << "the file system of " << out << " has " << free / 1048576.0
    << " MiB free; the checkpoint of the members this run computes needs at least "
    << bytes / 1048576.0 << " MiB (more with their contacts)";
  return o.str();
}

// Why the checkpoint directory `ck_dir` cannot take this run's checkpoints ("" when it can):
// something that is not a directory at its path, or a directory this process cannot write
// into. Checked before any work, so that a run does not compute its members and then lose them
// at its first checkpoint.
std::string checkpoint_path_problem(const std::string& ck_dir) {
  std::error_code ec;
  if (!std::filesystem::exists(ck_dir, ec)) return "";
  if (!std::filesystem::is_directory(ck_dir, ec))
    return ck_dir + " is not a directory, where this run keeps its checkpoint: move it away";
  if (::access(ck_dir.c_str(), W_OK | X_OK) != 0)
    return "cannot write into the checkpoint " + ck_dir + ": " + std::strerror(errno);
  return "";
}

// The signals that stop a run with its checkpoint saved: an interrupt, a batch system's end of
// the job or its warning before it (SIGUSR1, SIGUSR2, SIGXCPU as a scheduler may be set to
// send), a closed terminal.
constexpr std::pair<int, const char*> kStopSignals[] = {{SIGINT, "SIGINT"},   {SIGTERM, "SIGTERM"},
                                                        {SIGHUP, "SIGHUP"},   {SIGUSR1, "SIGUSR1"},
                                                        {SIGUSR2, "SIGUSR2"}, {SIGXCPU, "SIGXCPU"}};

const char* signal_name(int s) {
  for (const auto& [number, name] : kStopSignals)
    if (number == s) return name;
  return "a signal";
}

// Set by a stop signal: the run stops at the end of the step, checkpoints and exits. A second
// SIGINT or SIGTERM ends the program at once (a user's, or a batch system's last word); the
// others are not repeated by a user and may be by the system (SIGXCPU every CPU second past the
// soft limit), so a repeat of them leaves the saving to go on. Where g_say_stop is set (rank 0
// of a run that talks, while its members are computed) the first one is acknowledged at once,
// since the saving can take a while.
volatile std::sig_atomic_t g_signal = 0;
volatile std::sig_atomic_t g_say_stop = 0;
extern "C" void on_signal(int s) {
  if (g_signal != 0) {
    if (s != SIGINT && s != SIGTERM) return;
    std::signal(s, SIG_DFL);
    std::raise(s);
    return;
  }
  g_signal = s;
  static constexpr char kSaving[] =
      "loosepack: stopping at the end of the step to save the checkpoint (a second SIGINT or "
      "SIGTERM ends the program at once, unsaved)\n";
  const int saved = errno;  // the interrupted code may read it (a write to a closed stderr sets it)
  if (g_say_stop) (void)!::write(STDERR_FILENO, kSaving, sizeof kSaving - 1);
  errno = saved;
}

// The exit codes of the program (docs/OUTPUT.md, "Exit codes").
enum ExitCode {
  kOk = 0,
  kError = 1,          // a failure while running or writing (the message says what)
  kInvalid = 2,        // invalid input: the command line, the scan file, the output path
  kMembersFailed = 3,  // the file is written, but some members failed (see the messages)
};

struct RunOptions {
  std::string scan_path, out_path = "out.h5";
  bool quiet = false, snapshots = false, timing = false, resume = false, force = false,
       dry_run = false, finished_only = false;
  int batch_size = 0;
  double checkpoint_every = 300.0;  // seconds between checkpoints; 0: after every member
  long member = -1;                 // run only this member (re-running a failed one)
  std::string shard;                // "K/N": run shard K of N only (include/loosepack/shards.hpp)
};

// `s` as one word of a POSIX shell command: as it is where it is made of safe characters only,
// else in single quotes (a command the program prints must work when pasted).
std::string shell_word(const std::string& s) {
  const auto safe = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || std::strchr("_./=+,:@%-", c) != nullptr;
  };
  if (!s.empty() && std::all_of(s.begin(), s.end(), safe)) return s;
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// Tells the user of each failed member of `results` and how to run it again; returns how many.
int report_failures(const std::vector<MemberResult>& results, const std::string& scan_path) {
  int failed = 0;
  for (const auto& r : results) {
    if (r.ok()) continue;
    ++failed;
    std::cerr << "loosepack: member " << r.member.id << " (point " << r.member.point << ", seed "
              << r.member.seed_index << ", Bo " << r.member.params.bond_number
              << ") failed: " << failure_message(r.failure)
              << "; excluded from the aggregates, its state at the failure is in the output; "
                 "re-run it alone with: loosepack run "
              << shell_word(scan_path) << " --member " << r.member.id << " -o member-"
              << r.member.id << ".h5\n";
  }
  return failed;
}

// Warns of each point whose nu_lower_half is a mean over fewer than its finished members
// (members_left_out_note), and of each protocol-C point with collapses stopped while still moving
// (capped_collapses_note). Said even with -q.
void report_members_left_out(const std::vector<PointResult>& points) {
  for (const auto& p : points) {
    const std::string note = members_left_out_note(p.point.index, p.point.protocol,
                                                   p.nu_lower_half.n, p.members - p.failed);
    if (!note.empty()) std::cerr << "loosepack: warning: " << note << "\n";
    if (p.point.protocol != Protocol::C) continue;
    const std::string capped = capped_collapses_note(p.point.index, p.m_failure, p.m_capped);
    if (!capped.empty()) std::cerr << "loosepack: warning: " << capped << "\n";
  }
}

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}
// The program's start (its static initialisation), for `run --timing`'s account of a run's wall
// time.
const Clock::time_point kProgramStart = Clock::now();

// A long time in the unit a reader would use ("2.5 hours", "1.3 years"), for the ETA and the
// dry run's estimate, whose seconds stay as they are for scripts; empty under 2 minutes.
std::string in_words(double seconds) {
  struct Unit {
    double seconds;
    const char* name;
  };
  constexpr double kDay = 86400.0;
  const Unit units[] = {
      {365.25 * kDay, "years"}, {kDay, "days"}, {3600.0, "hours"}, {60.0, "minutes"}};
  if (!(seconds >= 120.0)) return "";
  for (const Unit& u : units)
    if (seconds >= u.seconds) {
      char text[64];
      std::snprintf(text, sizeof text, "%.1f %s", seconds / u.seconds, u.name);
      return text;
    }
  return "";
}

// Claims `out` for a command that writes it (a run, or analyse -o and merge from the files
// `inputs`): a path that can take a result file and is none of the inputs, the lock (no run or
// other command writes it now), an existing file only with `force` (looked for under the lock,
// so that a run that has just finished and let go of it is seen), and the temporaries of one
// that died while writing it or its checkpoint removed. "" when claimed, else why not.
std::string claim_output_path(OutputLock& lock, const std::string& out,
                              const std::vector<std::string>& inputs, bool force) {
  std::string why = inputs.empty() ? output_path_problem(out, "") : "";
  for (const auto& in : inputs)
    if (why.empty()) why = output_path_problem(out, in);
  if (why.empty()) why = lock.acquire(out);
  if (!lock.warning().empty()) std::cerr << "loosepack: " << lock.warning() << "\n";
  if (why.empty() && !force && std::filesystem::exists(out))
    why = "the output file " + out + " exists; add --force to replace it";
  if (!why.empty()) return why;
  // What a run that died left: a temporary of the file, of the checkpoint (renamed on its way
  // out) and of a checkpoint part.
  const std::string ck = checkpoint_directory(out);
  std::vector<std::string> stale = remove_stale_temporaries(out);
  for (const auto& f : remove_stale_temporaries(ck, true)) stale.push_back(f);
  for (const auto& f : remove_stale_temporaries_in(ck, "")) stale.push_back(f);
  for (const auto& f : stale)
    std::cerr << "loosepack: removed " << f << ", left by a run that ended while writing\n";
  return why;
}

// `loosepack run`: one object per run, its steps top-down in run() below.
class RunCommand {
 public:
  RunCommand(const RunOptions& o, Ranks& ranks) : o(o), ranks(ranks), talk(ranks.root()) {}
  int run();

 private:
  int load();
  int select_members();
  int other_selection() const;
  int dry_run() const;
  int claim_output();
  int claim_space();
  int read_checkpoint();
  std::string run_again_note() const;
  void remove_superseded_parts() const;
  void share_out();
  void announce() const;
  void announce_cost() const;
  RunHooks hooks();
  void save_checkpoint();
  void write_checkpoint();
  void save_after_error(const std::string& who);
  void show(bool force);
  int compute();
  void print_timing() const;
  void print_cost_per_disk(const StageCost& solve) const;
  void print_wall_time() const;
  int wait_for_ranks();
  int collect_and_write();
  int write_finished();
  int write();
  void say(const std::string& s) const {
    if (talk) std::cerr << "loosepack: " << s << "\n";
  }
  // The command that goes on with this run from its checkpoint: the members it selects and what
  // it writes (--snapshots) as given, and --force where the output file is there to replace
  // (it was when the run began with --force, or the run wrote its finished members into it).
  std::string resume_command(bool output_written = false) const {
    const std::string flags = selection();
    return "loosepack run " + shell_word(o.scan_path) + " -o " + shell_word(o.out_path) +
           (flags.empty() ? "" : " " + flags) + (snapshots ? " --snapshots" : "") + " --resume" +
           (o.force || output_written ? " --force" : "");
  }
  // The options that select this run's members (--member, --shard, K/N as parsed), or "" for
  // the whole scan.
  std::string selection() const {
    if (o.member >= 0) return "--member " + std::to_string(o.member);
    return info.shards == 0 ? "" : "--" + shard_name();
  }
  // "shard K/N" of a run of one shard.
  std::string shard_name() const {
    return "shard " + std::to_string(info.shard) + "/" + std::to_string(info.shards);
  }

  const RunOptions& o;
  Ranks& ranks;
  const bool talk;  // only rank 0 talks to the user
  // Whether the file holds the final states (--snapshots): as given, or as the run that wrote
  // the checkpoint this one resumes asked (its checkpoint holds them either way).
  bool snapshots = o.snapshots;
  Scan scan;
  std::vector<Member> all_members, members;
  // Members finished before (from the checkpoint), their ids; those to compute, those of them
  // that had started (with their snapshots), and this rank's share.
  std::vector<MemberResult> results;
  std::set<std::uint64_t> resumed;
  long resumed_disks = 0;  // the disks of the members finished before the resume
  std::vector<Member> todo, mine;
  std::vector<MemberSnapshot> started;
  std::vector<double> shard_cost;  // expected cost of each rank's share
  double expected_s = 0.0, expected_wall_s = 0.0;  // the model's CPU s left: all, busiest rank
  std::string ck_dir, part;
  std::uint64_t fingerprint = 0;  // of the scan, in every checkpoint part (computed once)
  bool selection_written = false;  // the checkpoint's `selection` file, by this rank
  CheckpointContents ck;
  // This rank's members finished since the last checkpoint, the finished parts written so far,
  // and the latest snapshot of each of its running members.
  std::vector<MemberResult> fresh;
  int finished_parts = 0;
  bool running_part_holds = false;  // whether the running part on disk holds any snapshot
  bool running_saved = true;        // whether the running part on disk holds `running` as it is
  std::map<std::uint64_t, MemberSnapshot> running;
  std::vector<MemberResult> computed;
  RunInfo info;
  Clock::time_point t0 = Clock::now(), last_shown = t0, last_sent = t0, last_checkpoint = t0,
                    last_snapshots = t0;
  std::vector<Progress> latest;  // every rank's, on rank 0
  std::vector<char> final;       // which ranks have finished
  Progress own;                  // this rank's latest
  std::vector<StageCost> stages;
  Clock::time_point computed_at;  // the members computed and checkpointed (print_wall_time)
  OutputLock lock;  // rank 0: the output and its checkpoint are this run's
};

int RunCommand::run() {
  if (const int rc = load()) return rc;
  if (o.dry_run) return o.resume && read_checkpoint() != 0 ? kInvalid : dry_run();
  if (const int rc = read_checkpoint()) return rc;
  if (o.finished_only) return write_finished();
  remove_superseded_parts();
  if (claim_space() != 0) return kInvalid;
  share_out();
  announce();
  g_say_stop = talk && !o.quiet;  // a stop is acknowledged while members are computed
  if (const int rc = compute()) return rc;
  const int stopped = wait_for_ranks();  // the last progress line, then the timing after it
  g_say_stop = 0;
  print_timing();
  if (stopped) return stopped;
  const int rc = collect_and_write();
  print_wall_time();
  return rc;
}

// The scan, and the members to run (all, or the one of --member).
int RunCommand::load() {
  try {
    scan = load_scan(o.scan_path);
  } catch (const ScanError& e) {
    say(std::string("invalid scan: ") + e.what());
    return kInvalid;
  }
  if (o.batch_size > 0) scan.batch_size = o.batch_size;
  for (const auto& w : scan.warnings) say("warning: " + w);
  if (const std::string why = output_path_problem(o.out_path, o.scan_path); !why.empty()) {
    say(why);
    return kInvalid;
  }
  all_members = members_of(scan);
  if (const int rc = select_members()) return rc;
  // Said before the output is claimed: an existing -o asks for --force, which would not help.
  if (o.resume && !std::filesystem::exists(checkpoint_directory(o.out_path))) {
    say("--resume: no checkpoint " + checkpoint_directory(o.out_path) +
        " (written next to the output file given by -o)");
    return kInvalid;
  }
  if (!o.dry_run && claim_output() != 0) return kInvalid;
  resolve_backend_defaults(scan, members.size());
  return 0;
}

// The members this run computes: all, the one of --member, or the shard of --shard.
int RunCommand::select_members() {
  members = all_members;
  if (o.member >= 0) {
    if (o.member >= static_cast<long>(all_members.size())) {
      say("--member " + std::to_string(o.member) + ": the scan has members 0 to " +
          std::to_string(all_members.size() - 1));
      return kInvalid;
    }
    members = {all_members[static_cast<std::size_t>(o.member)]};
  }
  if (o.shard.empty()) return 0;
  try {
    std::tie(info.shard, info.shards) = parse_shard(o.shard);
  } catch (const ShardError& e) {
    say(e.what());
    return kInvalid;
  }
  if (static_cast<std::size_t>(info.shards) > all_members.size()) {
    say("--shard " + o.shard + ": the scan has " + std::to_string(all_members.size()) +
        " members, too few for " + std::to_string(info.shards) + " shards");
    return kInvalid;
  }
  members = shard_of(all_members, info.shard, info.shards);
  return 0;
}

// Rank 0 claims the output (claim_output_path) and holds its lock, and so its checkpoint's, for
// the whole run; every rank learns whether the run goes on.
int RunCommand::claim_output() {
  std::string why;
  if (ranks.root()) why = claim_output_path(lock, o.out_path, {o.scan_path}, o.force);
  if (!why.empty()) say(why);
  return ranks.broadcast(why.empty() ? 0 : 1);
}

// Rank 0 checks that the output's file system has room for the checkpoint and the results of
// the members left to compute (those a checkpoint holds finished have theirs); every rank
// learns whether the run goes on.
int RunCommand::claim_space() {
  const std::string why = ranks.root() ? space_problem(o.out_path, todo) : "";
  if (!why.empty()) say(why);
  return ranks.broadcast(why.empty() ? 0 : 1);
}

// Rank 0: 1 (said why) when the checkpoint records another selection of members than this
// run's, or a damaged record of it; 0 when it records this run's or none (a checkpoint of a
// build that wrote no record: its members are checked instead, in read_checkpoint).
int RunCommand::other_selection() const {
  std::optional<std::string> wrote;
  try {
    wrote = read_checkpoint_selection(ck_dir);
  } catch (const CheckpointError& e) {
    say(e.what());
    return 1;
  }
  if (!wrote || *wrote == selection()) return 0;
  say(ck_dir + " was written by a run of " + selection_name(*wrote) + ", this one selects " +
      selection_name(selection()) + ": resume with the options that wrote it");
  return 1;
}

// The finished members of an interrupted run and the snapshots of its running ones, read by
// every rank before any rank writes a part of its own; what is left to compute.
int RunCommand::read_checkpoint() {
  ck_dir = checkpoint_directory(o.out_path);
  const bool ck_exists = std::filesystem::exists(ck_dir);
  if (const std::string why = checkpoint_path_problem(ck_dir); !why.empty()) {
    say(why);
    return kInvalid;
  }
  if (ck_exists && !o.resume) {
    say("a checkpoint of an interrupted run exists: " + ck_dir +
        "; add --resume to continue it, or delete it to start afresh");
    return kInvalid;
  }
  if (ranks.broadcast(ranks.root() ? other_selection() : 0) != 0) return kInvalid;
  try {
    ck = loosepack::read_checkpoint(ck_dir, scan);
  } catch (const CheckpointError& e) {
    say(e.what());
    return kInvalid;
  }
  ranks.barrier();
  std::set<std::uint64_t> selected;
  for (const auto& m : members) selected.insert(m.id);
  // A checkpoint without a record of its selection (other_selection) that holds members this run
  // does not select: going on would drop them, and removing it at the end would lose them.
  const auto outside = [&](std::uint64_t id) { return selected.count(id) == 0; };
  if (std::any_of(ck.members.begin(), ck.members.end(),
                  [&](const MemberResult& r) { return outside(r.member.id); }) ||
      std::any_of(ck.running.begin(), ck.running.end(),
                  [&](const MemberSnapshot& s) { return outside(s.result.member.id); })) {
    say(ck_dir + " holds members this run does not select: it was written by a run of another " +
        "--shard or --member, or of the whole scan; resume with the options that wrote it");
    return kInvalid;
  }
  for (auto& r : ck.members)
    if (selected.count(r.member.id)) {
      resumed.insert(r.member.id);
      resumed_disks += static_cast<long>(r.x.size());
      results.push_back(std::move(r));
    }
  for (const auto& m : members)
    if (!resumed.count(m.id)) todo.push_back(m);
  // Members that had started go on from their snapshots (every rank has them all).
  for (auto& snap : ck.running)
    if (selected.count(snap.result.member.id)) {
      started.push_back(std::move(snap));
    }
  part = checkpoint_part(ck_dir, ck.generation + 1, ranks.rank());
  fingerprint = scan_fingerprint(scan);
  if (ck.snapshots && !snapshots) {
    snapshots = true;
    if (!o.quiet)
      say("--snapshots: the run that wrote " + ck_dir +
          " asked for the final states; this one writes them too");
  }
  return 0;
}

// Rank 0, once every rank has read the checkpoint: the running parts that later records replace
// (CheckpointContents::superseded) go; one that cannot be removed stays, read and replaced again.
void RunCommand::remove_superseded_parts() const {
  if (!ranks.root()) return;
  std::error_code ec;
  for (const auto& file : ck.superseded) std::filesystem::remove(file, ec);
}

// This rank's share of the members to compute, balanced by what the cost model leaves of each
// (share_over_ranks), so that a resumed run's ranks end together.
void RunCommand::share_out() {
  const RankShares shares = share_over_ranks(todo, started, ranks.size());
  for (std::size_t k : shares.members[static_cast<std::size_t>(ranks.rank())])
    mine.push_back(todo[k]);
  shard_cost = shares.expected;
  for (double left : shares.left) {
    expected_s += left * kSecondsPerCostUnit;
    expected_wall_s = std::max(expected_wall_s, left * kSecondsPerCostUnit);
  }
  latest.resize(static_cast<std::size_t>(ranks.size()));
  final.assign(static_cast<std::size_t>(ranks.size()), 0);
}

void RunCommand::announce() const {
  if (o.quiet || !talk) return;
  std::cerr << "loosepack: scan '" << scan.name << "': " << scan.points.size() << " points x "
            << scan.seeds << " seeds = " << all_members.size() << " members";
  if (o.member >= 0) std::cerr << " (running member " << o.member << " only)";
  if (info.shards > 0) std::cerr << " (" << shard_name() << ": " << members.size() << " of them)";
  std::cerr << ", batches of " << scan.batch_size << " on " << Kokkos::DefaultExecutionSpace::name()
            << ", solver " << solver_kind_name(scan.solver.kind);
  if (scan.solver.sweeps_per_launch > 0)
    std::cerr << " (at most " << scan.solver.sweeps_per_launch << " sweeps a launch)";
  if (scan.solver.fused_step) std::cerr << ", fused step (one launch a step)";
  if (ranks.size() > 1) std::cerr << ", " << ranks.size() << " MPI ranks";
  std::cerr << "\n";
  if (o.resume)
    std::cerr << "loosepack: resuming from " << ck_dir << ": " << resumed.size() << " of "
              << members.size() << " members finished, computing the other " << todo.size() << " ("
              << started.size() << " of them from where they were)\n";
  if (o.resume && ck.run_again > 0) std::cerr << "loosepack: " << run_again_note() << "\n";
  if (!todo.empty()) announce_cost();
}

// What the cost model expects of the members to compute, as `--dry-run` prints it, and how
// long on this run's ranks.
void RunCommand::announce_cost() const {
  char seconds[32];
  std::snprintf(seconds, sizeof seconds, "%.3g", expected_s);
  std::cerr << "loosepack: the cost model expects about " << seconds << " CPU s";
  if (const std::string words = in_words(expected_s); !words.empty())
    std::cerr << " (" << words << " of one core)";
  if (ranks.size() > 1)
    if (const std::string words = in_words(expected_wall_s); !words.empty())
      std::cerr << ", about " << words << " on the " << ranks.size() << " ranks";
  std::cerr << ", right within a factor of a few (`--dry-run` gives it by point)\n";
}

// What a resume under another protocol.max_collapse_time than the checkpoint's computes again.
std::string RunCommand::run_again_note() const {
  std::ostringstream note;
  note << ck.run_again << (ck.run_again == 1 ? " member" : " members") << " of " << ck_dir
       << " collapsed otherwise than protocol.max_collapse_time = "
       << scan.protocol.max_collapse_time
       << " sqrt(R/g) lets a collapse end (stopped at another cap, or past this one): "
       << (ck.run_again == 1 ? "it runs" : "they run") << " again from the start";
  return note.str();
}

// This rank's checkpoint: the members finished since the last one in a new part of their own
// (each member encoded once), then the snapshots of the running ones (docs/OUTPUT.md).
void RunCommand::save_checkpoint() {
  if (fresh.empty() && running.empty()) return;
  try {
    write_checkpoint();
  } catch (const std::runtime_error& e) {  // a full disk: say how to go on once there is room
    throw std::runtime_error(std::string(e.what()) + "; " + ck_dir +
                             " keeps what was saved before: once the cause is fixed, continue "
                             "with: " +
                             resume_command());
  }
}

// After an error the run cannot go on from: the members finished since the last checkpoint
// are saved, where the disk allows (the error of a failed save already said what was kept).
void RunCommand::save_after_error(const std::string& who) {
  try {
    if (!fresh.empty()) save_checkpoint();
  } catch (const std::exception&) {
    return;
  }
  if (!std::filesystem::exists(ck_dir)) return;  // nothing finished yet, nothing saved before
  std::cerr << "loosepack: " << who << "the members it had finished are saved in " << ck_dir
            << "; once the cause is fixed, continue with: " << resume_command() << "\n";
}

void RunCommand::write_checkpoint() {
  // A new checkpoint directory is flushed into its parent, so that a power loss cannot take the
  // whole checkpoint with it once its parts are on the disk.
  if (std::filesystem::create_directories(ck_dir)) sync_path(directory_of_path(ck_dir));
  if (!selection_written) {  // by every rank, before its first part: no part lies there without it
    write_checkpoint_selection(ck_dir, selection(), snapshots, scan);
    selection_written = true;
  }
  if (!fresh.empty()) {
    const int generation = ck.generation + 1;
    write_checkpoint_part(checkpoint_part(ck_dir, generation, ranks.rank(), ++finished_parts),
                          fingerprint, fresh);
    fresh.clear();
  }
  // The running part, unless it would stay empty (each write is flushed to the disk; with
  // --checkpoint-every 0 and no snapshots taken, every finished member would write one) or
  // unchanged since it was written (a stop's snapshots, written when taken, not again at the end).
  if (!running_saved && (!running.empty() || running_part_holds)) {
    std::vector<MemberSnapshot> snaps;
    for (const auto& [id, snap] : running) snaps.push_back(snap);
    write_checkpoint_part(part, fingerprint, {}, snaps);
    running_part_holds = !snaps.empty();
  }
  running_saved = true;
  // A tall deposit's snapshot is megabytes; glibc keeps freed buffers in the heap, so a run
  // would grow by a few encodings' worth over its checkpoints (tests/soak_test.sh). Hand them
  // back.
#if defined(__GLIBC__)
  malloc_trim(0);
#endif
}

namespace {
// A ratio as the progress line says it: "2.7 times", "6420 times".
std::string times(double ratio) {
  char buf[32];
  std::snprintf(buf, sizeof buf, ratio >= 10.0 ? "%.0f times" : "%.2g times", ratio);
  return buf;
}

// ", at R times the rest speed" for a speed over the rest speed, nothing where it is not known
// (negative: Progress::relax_speed).
std::string at_speed(double ratio) {
  return ratio >= 0.0 ? ", at " + times(ratio) + " the rest speed" : "";
}
}  // namespace

// Progress of all ranks, on rank 0, at most every 2 s unless forced; the line of every member
// finished only when forced.
void RunCommand::show(bool force) {
  if (o.quiet || !talk) return;
  if (!force && seconds_since(last_shown) < 2.0) return;
  last_shown = Clock::now();
  Progress p;
  double done_cost = 0.0, start_cost = 0.0, total_cost = 0.0;
  for (std::size_t r = 0; r < latest.size(); ++r) {
    p.members_done += latest[r].members_done;
    p.disks_deposited += latest[r].disks_deposited;
    p.disks_before += latest[r].disks_before;
    // The longest collapse and relaxation of all ranks, with their speeds.
    if (latest[r].collapsing > 0 &&
        (p.collapsing == 0 || latest[r].collapse_steps > p.collapse_steps)) {
      p.collapse_steps = latest[r].collapse_steps;
      p.collapse_speed = latest[r].collapse_speed;
      p.collapse_mean_speed = latest[r].collapse_mean_speed;
    }
    p.collapsing += latest[r].collapsing;
    if (latest[r].relaxing_long > 0 &&
        (p.relaxing_long == 0 || latest[r].relax_steps > p.relax_steps)) {
      p.relax_steps = latest[r].relax_steps;
      p.relax_speed = latest[r].relax_speed;
    }
    p.relaxing_long += latest[r].relaxing_long;
    done_cost += (final[r] ? 1.0 : latest[r].fraction) * shard_cost[r];
    start_cost += latest[r].start_fraction * shard_cost[r];
    total_cost += shard_cost[r];
  }
  p.disks_deposited += resumed_disks;  // the members the checkpoint held finished
  p.disks_before += resumed_disks;
  p.fraction = total_cost > 0.0 ? done_cost / total_cost : 1.0;
  p.start_fraction = total_cost > 0.0 ? start_cost / total_cost : 0.0;
  const double el = seconds_since(t0);
  const bool finished = p.members_done == static_cast<int>(todo.size());
  if (finished && !force) return;  // the last line is wait_for_ranks', once
  // The rate counts this run's disks only: those deposited before a resume took no time here.
  const long disks_here = p.disks_deposited - p.disks_before;
  std::fprintf(stderr, "  %d/%zu members, %ld disks deposited",
               p.members_done + static_cast<int>(resumed.size()), members.size(),
               p.disks_deposited);
  if (p.disks_before > 0) std::fprintf(stderr, " (%ld before the resume)", p.disks_before);
  std::fprintf(stderr, ", %.0f disks/s, %.0f s elapsed", el > 0 ? disks_here / el : 0.0, el);
  if (p.collapsing > 0) {
    std::fprintf(stderr, ", %d collapsing (the longest for %ld steps%s", p.collapsing,
                 p.collapse_steps, at_speed(p.collapse_speed).c_str());
    if (p.collapse_mean_speed >= 0.0)
      std::fprintf(stderr, ", averaged %s", times(p.collapse_mean_speed).c_str());
    std::fprintf(stderr, ")");
  }
  if (p.relaxing_long > 0)
    std::fprintf(stderr, ", %d relaxing for %ld steps or more (the longest for %ld%s)",
                 p.relaxing_long, kLongRelaxation, p.relax_steps, at_speed(p.relax_speed).c_str());
  if (const double eta = run_eta(latest, final, p, el); eta >= 0.0 && !finished) {
    const std::string words = in_words(eta);
    const std::string spelled = words.empty() ? "" : " (" + words + ")";
    std::fprintf(stderr, ", about %.0f%% done, rough ETA %.0f s%s", 100.0 * p.fraction, eta,
                 spelled.c_str());
  }
  std::fprintf(stderr, "\n");
}

RunHooks RunCommand::hooks() {
  RunHooks h;
  h.stop = &g_signal;
  if (o.timing) h.stage_costs = &stages;
  // A signal that reaches one rank stops the run on every rank (wait_for_ranks): rank 0 learns
  // of another rank's stop from its final message, the others of rank 0's stop notice.
  h.progress = [this](const Progress& p) {
    own = p;
    if (talk) {
      latest[0] = p;
      if (const int stopped = ranks.receive_progress(latest, final, false); stopped && !g_signal)
        g_signal = stopped;
      show(false);
    } else if (seconds_since(last_sent) >= 1.0) {
      last_sent = Clock::now();
      ranks.send_progress(p, false);
      if (const int stopped = ranks.poll_stop(); stopped && !g_signal) g_signal = stopped;
    }
  };
  h.finished = [this](const MemberResult& r) {
    fresh.push_back(r);
    if (running.erase(r.member.id) > 0) running_saved = false;
    if (seconds_since(last_checkpoint) >= o.checkpoint_every) {
      save_checkpoint();
      last_checkpoint = Clock::now();
    }
  };
  // Running members are saved every --checkpoint-every seconds and at a stop (with 0, only at
  // a stop: a snapshot of a tall deposit is as large as a finished member).
  h.snapshot_wanted = [this]() {
    return o.checkpoint_every > 0.0 && seconds_since(last_snapshots) >= o.checkpoint_every;
  };
  // A member still inside a step when the stop's grace ran out keeps the snapshot it had, if any.
  h.missed_at_stop = [this, grace = h.stop_grace](const std::vector<std::uint64_t>& ids) {
    const std::string who = ranks.size() > 1 ? "rank " + std::to_string(ranks.rank()) + ": " : "";
    for (const std::uint64_t id : ids) {
      std::ostringstream os;
      os << "loosepack: " << who << "member " << id << " was still inside a step " << grace
         << " s after the stop, so the checkpoint ";
      const bool resumed_from = std::any_of(
          started.begin(), started.end(), [&](const auto& s) { return s.result.member.id == id; });
      if (running.count(id) > 0)
        os << "keeps its snapshot from " << std::fixed << std::setprecision(0)
           << seconds_since(last_snapshots) << " s before (a resume repeats that work)";
      else if (resumed_from)
        os << "keeps the snapshot this run went on from (a resume repeats this run's work on it)";
      else
        os << "has no snapshot of it (a resume starts it again)";
      std::cerr << os.str() << "\n";
    }
  };
  h.snapshots = [this](std::vector<MemberSnapshot> snaps) {
    for (auto& snap : snaps) running[snap.result.member.id] = std::move(snap);
    running_saved = false;
    save_checkpoint();
    last_snapshots = last_checkpoint = Clock::now();
  };
  return h;
}

// This rank's members.
int RunCommand::compute() {
  t0 = last_shown = last_sent = last_checkpoint = last_snapshots = Clock::now();
  info.start_time = utc_now();
  info.ranks = ranks.size();
  try {
    computed = run_members(scan, mine, hooks(), started);
    // Everything computed is in the checkpoint before the gather and the final write, so that
    // neither a long wait for the other ranks nor a failed write (a full disk) loses it.
    save_checkpoint();
    computed_at = Clock::now();
  } catch (const std::exception& e) {
    const std::string who = ranks.size() > 1 ? "rank " + std::to_string(ranks.rank()) + ": " : "";
    std::cerr << "loosepack: " << who << e.what() << "\n";
    save_after_error(who);
    ranks.abort(1);  // the other ranks would wait for this one forever
    return kError;
  }
  fresh.clear();
  return 0;
}

// A batch's stages (the whole batch's, or the regions' "region ..." when `solve` is theirs) per
// disk of the systems they stepped: what a step costs for the size of its systems, in all and
// outside the solve and the Newton rounds (docs/PERFORMANCE.md, "Scaling with system size").
void RunCommand::print_cost_per_disk(const StageCost& solve) const {
  // The row "solve", or with solver.fused_step "system_step" (the whole step, the solve
  // inside), of the batch or of the regions ("region ...").
  const auto ends_with = [&](const std::string& tail) {
    return solve.name.size() >= tail.size() &&
           solve.name.compare(solve.name.size() - tail.size(), tail.size(), tail) == 0;
  };
  const std::string row = ends_with("system_step") ? "system_step" : "solve";
  const std::string prefix = solve.name.substr(0, solve.name.size() - row.size());
  const auto of_batch = [&](const std::string& name) {
    if (!prefix.empty()) return name.rfind(prefix, 0) == 0;
    return name.rfind("region ", 0) != 0 && name != "scheduler" && name != "snapshots";
  };
  double all = 0.0, solving = 0.0;
  for (const auto& st : stages) {
    if (!of_batch(st.name)) continue;
    all += st.seconds;
    if (st.name == prefix + "solve" || st.name == prefix + "newton") solving += st.seconds;
  }
  const double disk_steps = static_cast<double>(solve.disk_steps);
  if (row == "system_step") {
    std::fprintf(stderr,
                 "  %s: %.0f disks a system step; the step's stages %.3g microseconds a disk "
                 "(the solve among them)\n",
                 solve.name.c_str(), disk_steps / static_cast<double>(solve.system_steps),
                 1e6 * all / disk_steps);
    return;
  }
  std::fprintf(stderr,
               "  %s: %.0f disks a system step; the step's stages %.3g microseconds a disk, "
               "%.3g of them outside the solve and the Newton rounds\n",
               solve.name.c_str(), disk_steps / static_cast<double>(solve.system_steps),
               1e6 * all / disk_steps, 1e6 * (all - solving) / disk_steps);
}

void RunCommand::print_timing() const {
  if (!o.timing || !talk) return;
  double total = 0.0;
  for (const auto& st : stages) total += st.seconds;
  std::fprintf(stderr,
               "loosepack: cost per stage of the step (fenced, rank 0): wall time, and kernel "
               "launches and deep copies per step\n");
  // With the solve split over launches a batch step is one launch of it, and a system's step
  // may take several.
  const bool split = scan.solver.sweeps_per_launch > 0;
  if (split)
    std::fprintf(stderr,
                 "  (a step here is the batch's: one launch of the solve, at most %d "
                 "sweeps of each system)\n",
                 scan.solver.sweeps_per_launch);
  for (const auto& st : stages) {
    const double per_step = st.steps > 0 ? 1.0 / static_cast<double>(st.steps) : 0.0;
    std::fprintf(stderr, "  %-22s %10.3f s  %5.1f %%  %8.2f launches  %8.2f copies\n",
                 st.name.c_str(), st.seconds, total > 0 ? 100.0 * st.seconds / total : 0.0,
                 st.launches * per_step, st.copies * per_step);
  }
  // The batch's steps, then the regions' (their stages are named "region ..."), then the
  // scheduler's loop between the batch's steps and the snapshots taken in it, so that a stage's
  // seconds per step can be told.
  const auto steps_of = [](const StageCost& st) {
    if (st.name.rfind("region ", 0) == 0) return " steps of the regions";
    return st.name == "scheduler" ? " passes of the scheduler's loop" : " steps of the batch";
  };
  std::string over;
  for (std::size_t k = 0; k < stages.size(); ++k)
    if (k == 0 || stages[k].steps != stages[k - 1].steps || stages[k].name == "scheduler")
      over += (over.empty() ? "" : ", ") + std::to_string(stages[k].steps) + steps_of(stages[k]);
  if (!over.empty()) std::fprintf(stderr, "  over %s\n", over.c_str());
  for (const auto& st : stages) {
    if (st.slowest_sweeps == 0) continue;
    std::fprintf(stderr,
                 "  %s: %.1f systems a launch, their sweeps %.1f %% of the launch's slowest "
                 "system's\n",
                 st.name.c_str(), static_cast<double>(st.system_steps) / st.steps,
                 100.0 * st.sweeps / st.slowest_sweeps);
    std::fprintf(stderr, "  %s: %.1f sweeps a launch by its slowest system\n", st.name.c_str(),
                 static_cast<double>(st.launch_sweeps) / st.steps);
    if (st.finished_steps < st.system_steps)  // solver.sweeps_per_launch
      std::fprintf(stderr, "  %s: %.1f system steps ended a launch\n", st.name.c_str(),
                   static_cast<double>(st.finished_steps) / st.steps);
    else if (st.disk_steps > 0)
      print_cost_per_disk(st);
  }
  for (const auto& st : stages)
    if (st.team_size > 0)
      std::fprintf(stderr, "  %s: %d threads a team\n", st.name.c_str(), st.team_size);
}

// With --timing, after the file is written: the run's wall time before its members (the
// backend's start, the scan, the checkpoint read), running them (the loop of the table above,
// and around it the batch's set-up and the last checkpoint) and after them (the other ranks'
// members awaited and gathered, the analysis and the file).
void RunCommand::print_wall_time() const {
  if (!o.timing || !talk) return;
  double loop = 0.0;
  for (const auto& st : stages) loop += st.seconds;
  const auto between = [](Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double>(b - a).count();
  };
  const double members = between(t0, computed_at);
  std::fprintf(stderr,
               "loosepack: wall time %.3f s: %.3f s before the members (start-up, the scan, the "
               "checkpoint), %.3f s running them (the loop above %.3f s, the batch's set-up "
               "and the last checkpoint %.3f s), %.3f s after them (gathered, analysed, "
               "written)\n",
               seconds_since(kProgramStart), between(kProgramStart, t0), members, loop,
               members - loop, between(computed_at, Clock::now()));
}

// Rank 0 shows progress until every rank is done, finished or stopped. A rank stopped by a
// signal stops the run, as does a signal to a rank that has finished its share while others
// compute: rank 0 tells the ranks still computing to stop, and waits until each has saved its
// checkpoint and said so, so that no rank waits for another that has gone. Then every rank
// learns whether the run stopped; at a stop rank 0 says what was saved and how to go on, and
// the exit code is 128 + the signal on every rank.
int RunCommand::wait_for_ranks() {
  int stop = g_signal;
  if (talk) {
    final[0] = 1;
    bool told = false;
    while (std::find(final.begin(), final.end(), 0) != final.end()) {
      if (const int stopped = ranks.receive_progress(latest, final, true); stopped && !stop)
        stop = stopped;
      if (!stop) stop = g_signal;  // a signal to rank 0 once its own share is done
      if (stop && !told) {
        ranks.send_stop(stop, final);
        told = true;
      }
      if (!stop) show(false);
    }
    if (!stop) show(true);
    stop = ranks.decide(stop);
  } else {
    ranks.send_progress(own, true, g_signal);
    stop = ranks.await_verdict(own, g_signal);
  }
  if (!stop) return 0;
  if (!talk) return 128 + stop;
  const std::string by = signal_name(stop);
  if (ranks.size() == 1 && !std::filesystem::exists(ck_dir))
    say("interrupted by " + by + " before anything could be saved; start the run again");
  else
    say("interrupted by " + by +
        ": finished members, and where the running ones were, are saved in " + ck_dir +
        "; continue with: " + resume_command());
  return 128 + stop;
}

// Rank 0 collects every rank's members, reports the failed ones and writes the file.
int RunCommand::collect_and_write() {
  // Rank 0 takes its own members as they are: only the others' travel encoded.
  const auto shares = ranks.gather(talk ? std::string() : encode_members(computed));
  if (!talk) return 0;
  try {
    for (std::size_t r = 0; r < shares.size(); ++r) {
      auto got = r == 0 ? std::move(computed)
                        : decode_members(shares[r], scan, "results of rank " + std::to_string(r));
      for (auto& m : got) results.push_back(std::move(m));
    }
  } catch (const CheckpointError& e) {
    say(e.what());
    return kError;
  }
  return write();
}

// `--finished-only`: the file of the members the checkpoint holds finished, computing nothing;
// the checkpoint stays, so that `--resume --force` goes on with the others.
int RunCommand::write_finished() {
  if (!talk) return kOk;
  if (results.empty()) {
    say("--finished-only: no member of " + ck_dir + " has finished yet; nothing written");
    return kInvalid;
  }
  info.start_time = utc_now();
  return write();
}

// Rank 0 writes the file of `results`: reports the failed members, aggregates, analyses, and
// removes the checkpoint (kept with --finished-only, whose results lack the unfinished members).
int RunCommand::write() {
  std::sort(results.begin(), results.end(),
            [](const MemberResult& a, const MemberResult& b) { return a.member.id < b.member.id; });
  info.end_time = utc_now();
  info.members_unfinished = static_cast<long>(members.size() - results.size());
  info.wall_seconds = seconds_since(t0);
  const int failed = report_failures(results, o.scan_path);
  try {
    inject_write_failure();
    report_members_left_out(write_member_results(o.out_path, scan, info, results, snapshots));
  } catch (const std::exception& e) {
    say(std::string(e.what()) + "; the results are kept in " + ck_dir +
        ": once the cause is fixed, write the file with: " + resume_command() +
        (o.finished_only ? " --finished-only" : ""));
    return kError;
  }
  if (o.finished_only) {
    if (!o.quiet)
      std::cerr << "loosepack: wrote " << o.out_path << " with the " << results.size() << " of "
                << members.size() << " members finished so far (" << failed
                << " failed); the checkpoint " << ck_dir << " stays: continue with "
                << resume_command(true) << "\n";
  } else {
    const std::string left = remove_checkpoint(ck_dir);
    if (!o.quiet)
      std::cerr << "loosepack: wrote " << o.out_path << " (" << info.wall_seconds << " s, "
                << failed << " failed members)\n";
    // The file is complete; a checkpoint left beside it would make the next run of this output
    // take it for an interrupted run's.
    if (!left.empty())
      say(left +
          ": the result file is complete and holds everything the checkpoint did; delete "
          "the checkpoint by hand before the next run that writes " +
          o.out_path);
  }
  return failed > 0 ? kMembersFailed : kOk;
}

// The members to compute (with --resume, those the checkpoint does not hold finished), point by
// point, and what the cost model expects them to take; nothing runs.
int RunCommand::dry_run() const {
  if (!talk) return kOk;
  std::string selected;
  if (o.member >= 0) selected = " (one member selected)";
  if (info.shards > 0)
    selected = " (" + shard_name() + ": " + std::to_string(members.size()) + " of them)";
  std::printf("# scan '%s': %zu points x %d seeds = %zu members%s\n", scan.name.c_str(),
              scan.points.size(), scan.seeds, all_members.size(), selected.c_str());
  if (o.resume)
    std::printf(
        "# resuming from %s: %zu of %zu members finished, %zu to compute (%zu of them from "
        "where they were)\n",
        ck_dir.c_str(), resumed.size(), members.size(), todo.size(), started.size());
  if (o.resume && ck.run_again > 0) std::printf("# %s\n", run_again_note().c_str());
  std::printf(
      "%-6s %-5s %-10s %-8s %-8s %-8s %-8s %s\n", "point", "prot", "Bo", "r_capt", "width",
      "height", "members",
      o.resume ? "expected CPU s per member, of what is left" : "expected CPU s per member");
  // A member that goes on from its snapshot has the share its snapshot had done behind it.
  const auto& listed = o.resume ? todo : members;
  const std::vector<double> left = costs_left(listed, started);
  std::map<int, std::pair<int, double>> of_point;  // members, CPU s (right within a few times)
  for (std::size_t k = 0; k < listed.size(); ++k) {
    auto& [members_there, seconds] = of_point[listed[k].point];
    ++members_there;
    seconds += left[k] * kSecondsPerCostUnit;
  }
  double total = 0.0;
  for (const auto& pt : scan.points) {
    const auto there = of_point.find(pt.index);
    if (there == of_point.end()) continue;
    const auto [n, cost] = there->second;
    total += cost;
    std::printf("%04d   %-5s %-10g %-8g %-8g %-8g %-8d %.3g\n", pt.index,
                protocol_name(pt.protocol).c_str(), pt.params.bond_number, pt.params.capture_radius,
                pt.params.width, pt.params.height, n, cost / n);
  }
  const std::string words = in_words(total);
  const std::string spelled = words.empty() ? "" : ", " + words + " of one core";
  std::printf(
      "# expected: about %.3g CPU s in all%s (the cost model, right within a factor of a "
      "few: docs/PERFORMANCE.md, \"What a member costs\")\n",
      total, spelled.c_str());
  const bool regions = scan.protocol.region_radius > 0.0 &&
                       std::any_of(scan.points.begin(), scan.points.end(), [](const ScanPoint& p) {
                         return p.protocol == Protocol::A && std::isfinite(p.params.bond_number);
                       });
  if (regions)
    std::printf(
        "# protocol.region_radius is set: the model prices protocol-A members relaxed in "
        "regions as growing above 60 R like H^2.3 at Bo <= 1, H^2.9 at 10, H^3.5-3.6 at "
        "1e2-3e2 and H^3.0 at 1e3, with fewer avalanches above 1e3; the recorded region runs "
        "took 0.68 to 1.58 of it from Bo = 0 to 1e3 (60 R to 800 R tall) and 0.53 to 2.0 "
        "above (60 R to 400 R), where a member that avalanches costs a hundred times one that "
        "does not "
        "(docs/PERFORMANCE.md, \"What a member costs\")\n");
  if (!o.force && std::filesystem::exists(o.out_path))
    std::printf("# %s exists: the run would be refused without --force\n", o.out_path.c_str());
  if (const std::string why = checkpoint_path_problem(checkpoint_directory(o.out_path));
      !why.empty())
    std::printf("# %s: the run would be refused\n", why.c_str());
  else if (!o.resume && std::filesystem::exists(checkpoint_directory(o.out_path)))
    std::printf(
        "# a checkpoint of an interrupted run exists (%s): the run would be refused "
        "without --resume\n",
        checkpoint_directory(o.out_path).c_str());
  return kOk;
}

int run(const RunOptions& o, Ranks& ranks) { return RunCommand(o, ranks).run(); }

}  // namespace

namespace {

// The build: version, commit, Kokkos and its backend, the threads it runs on, MPI.
std::string version_text() {
  std::ostringstream o;
  o << "loosepack " << LOOSEPACK_VERSION << " (commit " << LOOSEPACK_GIT_COMMIT << ")\n"
    << "Kokkos " << KOKKOS_VERSION / 10000 << "." << KOKKOS_VERSION / 100 % 100 << "."
    << KOKKOS_VERSION % 100 << ", " << Kokkos::DefaultExecutionSpace::name() << " backend, "
    << Kokkos::DefaultExecutionSpace().concurrency() << " thread(s)\n"
#ifdef LOOSEPACK_WITH_MPI
    << "MPI: yes (members shard over the ranks of mpirun)\n";
#else
    << "MPI: no (built without)\n";
#endif
  return o.str();
}

// The command line without Kokkos's own options (--kokkos-...), which Kokkos reads itself.
std::vector<char*> without_kokkos_options(int argc, char** argv) {
  std::vector<char*> out;
  for (int k = 0; k < argc; ++k)
    if (std::strncmp(argv[k], "--kokkos-", 9) != 0) out.push_back(argv[k]);
  return out;
}

// A count or an index: the whole number CLI11's range check would call out of range (2.0).
const CLI::Validator kWholeNumber(
    [](const std::string& text) {
      char* end = nullptr;
      errno = 0;
      (void)std::strtoll(text.c_str(), &end, 10);
      return !text.empty() && *end == '\0' && errno == 0 ? std::string()
                                                         : "'" + text + "' is not a whole number";
    },
    "INT");

// `loosepack run`'s options, into `o`.
CLI::App* add_run_command(CLI::App& app, RunOptions& o) {
  auto* run_cmd = app.add_subcommand(
      "run",
      "Run a scan file and write one HDF5 result file (under mpirun: members sharded over "
      "the ranks, rank 0 writes)");
  run_cmd->add_option("scan", o.scan_path, "scan file (TOML)")
      ->required()
      ->check(CLI::ExistingFile);
  run_cmd
      ->add_option("-o,--output", o.out_path,
                   "result file (HDF5), written atomically; refused if it exists, unless --force")
      ->capture_default_str();
  run_cmd->add_flag("--force", o.force, "replace an existing result file");
  run_cmd->add_flag("--dry-run", o.dry_run,
                    "print each scan point's members and the cost model's estimate, run "
                    "nothing (with --resume: the members the checkpoint does not hold finished)");
  run_cmd->add_flag("-q,--quiet", o.quiet, "no progress on stderr");
  run_cmd->add_option("--batch-size", o.batch_size, "systems per batch (overrides scan.batch_size)")
      ->check(kWholeNumber)
      ->check(CLI::Range(1, 1000000));
  run_cmd->add_flag("--snapshots", o.snapshots,
                    "store every member's final disks (x, y_i, y_e, r) and contact forces");
  run_cmd->add_flag("--timing", o.timing,
                    "print each stage's wall time, launches and copies per step, and the "
                    "solve's balance across the batch's systems, at the end");
  run_cmd->add_flag("--resume", o.resume,
                    "continue an interrupted run from its checkpoint (OUTPUT.checkpoint/)");
  run_cmd
      ->add_flag("--finished-only", o.finished_only,
                 "with --resume: write the file of the members the checkpoint holds finished, "
                 "compute nothing, and keep the checkpoint (a later --resume --force goes on)")
      ->needs("--resume");
  run_cmd
      ->add_option(
          "--checkpoint-every", o.checkpoint_every,
          "seconds between checkpoints of finished members and of where the running ones are "
          "(0: after every member, running ones only at a stop)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e9))
      ->check(CLI::Validator(
          [](const std::string& text) {
            return std::isfinite(std::strtod(text.c_str(), nullptr))
                       ? std::string()
                       : std::string("must be a finite number of seconds");
          },
          "FINITE"));
  auto* member =
      run_cmd
          ->add_option("--member", o.member, "run only this member (id as printed for a failure)")
          ->check(kWholeNumber)
          ->check(CLI::Range(0L, 1000000000L));
  run_cmd
      ->add_option("--shard", o.shard,
                   "K/N: run shard K of N only (0 <= K < N; the members rank K of an N-rank run "
                   "computes), one file each, for loosepack merge")
      ->check(CLI::Validator(
          [](const std::string& text) {
            return text.empty() ? std::string("give K/N") : std::string();
          },
          "K/N"))
      ->excludes(member);
  return run_cmd;
}

// The subcommands that read a result file: summary, analyse, export.
struct FileCommands {
  CLI::App *summary = nullptr, *analyse = nullptr, *exporter = nullptr;
  std::string summary_path, analyse_path, analyse_out, export_path, export_format = "xdmf";
  bool analyse_force = false;
  ExportSelection export_selection;
};

// The result file a command reads, its one positional argument.
void add_result_file(CLI::App& command, std::string& path) {
  command.add_option("file", path, "result file (HDF5)")->required()->check(CLI::ExistingFile);
}

void add_file_commands(CLI::App& app, FileCommands& f) {
  f.summary = app.add_subcommand("summary", "Print a table per scan point of a result file");
  add_result_file(*f.summary, f.summary_path);
  f.analyse = app.add_subcommand(
      "analyse",
      "Recompute the fits of a result file from the aggregates it stores (a file of "
      "an older program gets the current analysis without a rerun)");
  add_result_file(*f.analyse, f.analyse_path);
  f.analyse
      ->add_option("-o,--output", f.analyse_out,
                   "write here instead of replacing FILE (atomically, either way); an "
                   "existing file is refused unless --force")
      ->check(CLI::Validator(  // an empty -o would mean FILE itself
          [](std::string& path) { return path.empty() ? std::string("an empty path") : ""; },
          "PATH"));
  f.analyse->add_flag("--force", f.analyse_force, "replace an existing -o file");
  f.exporter = app.add_subcommand(
      "export",
      "Write viewer files next to a result file from its snapshots and trajectories: XDMF "
      "for ParaView (reading the result file in place) or extended XYZ for OVITO");
  add_result_file(*f.exporter, f.export_path);
  f.exporter->add_option("--format", f.export_format, "xdmf or extxyz")
      ->capture_default_str()
      ->check(CLI::IsMember({"xdmf", "extxyz"}));
  f.exporter->add_option("--point", f.export_selection.point, "this scan point only")
      ->check(kWholeNumber)
      ->check(CLI::Range(0, 1000000));
  f.exporter->add_option("--seed", f.export_selection.seed, "this seed index only")
      ->check(kWholeNumber)
      ->check(CLI::Range(0, 1000000000));
}

// `loosepack analyse`: the output checked and locked as a run's, then written atomically.
int analyse_command(const FileCommands& f) {
  const std::string out = f.analyse_out.empty() ? f.analyse_path : f.analyse_out;
  // The input by another spelling of its path (./FILE) is in place too; another link to the same
  // file is not (the write replaces the path it is given), and output_path_problem refuses it.
  std::error_code e1, e2;
  const auto out_path = std::filesystem::weakly_canonical(out, e1);
  const auto in_path = std::filesystem::weakly_canonical(f.analyse_path, e2);
  const bool in_place = out == f.analyse_path || (!e1 && !e2 && out_path == in_path);
  OutputLock lock;
  if (const std::string why = claim_output_path(
          lock, out, in_place ? std::vector<std::string>{} : std::vector{f.analyse_path},
          in_place || f.analyse_force);
      !why.empty()) {
    std::cerr << "loosepack: " << why
              << (in_place ? "; `loosepack analyse FILE -o NEW.h5` writes the analysis into a "
                             "copy elsewhere"
                           : "")
              << "\n";
    return kInvalid;
  }
  reanalyse(f.analyse_path, out);
  std::cerr << "loosepack: wrote the analysis of " << f.analyse_path
            << (in_place ? " into it" : " into " + out) << "\n";
  return kOk;
}

// `loosepack merge`'s options.
struct MergeOptions {
  CLI::App* command = nullptr;
  std::vector<std::string> parts;
  std::string out_path;
  bool force = false, snapshots = false, quiet = false, partial = false;
};

void add_merge_command(CLI::App& app, MergeOptions& m) {
  m.command = app.add_subcommand(
      "merge",
      "Merge the files of some of one scan's members (loosepack run SCAN --shard K/N, --member "
      "N or --resume --finished-only, merge --partial) into the file one run of them all "
      "writes");
  m.command->add_option("files", m.parts, "the result files (HDF5)")
      ->required()
      ->check(CLI::ExistingFile);
  m.command
      ->add_option("-o,--output", m.out_path,
                   "merged result file (HDF5), written atomically; refused if it exists, unless "
                   "--force")
      ->required();
  m.command->add_flag("--force", m.force, "replace an existing result file");
  m.command->add_flag("--snapshots", m.snapshots,
                      "store every member's final disks and contact forces (as run --snapshots)");
  m.command->add_flag("--partial", m.partial,
                      "merge files that leave members out (shards not given, files of the "
                      "members finished only): a file of those at hand");
  m.command->add_flag("-q,--quiet", m.quiet, "no message when done");
}

// `loosepack merge`: the output checked and locked as a run's; the files read and checked whole
// before anything is written.
int merge_command(const MergeOptions& m) {
  OutputLock lock;
  if (const std::string why = claim_output_path(lock, m.out_path, m.parts, m.force); !why.empty()) {
    std::cerr << "loosepack: " << why << "\n";
    return kInvalid;
  }
  MergedParts merged;
  try {
    merged = read_parts(m.parts);
  } catch (const ShardError& e) {
    std::cerr << "loosepack: " << e.what() << "\n";
    return kInvalid;
  } catch (const std::exception& e) {  // a file HDF5 reads wrong, memory
    std::cerr << "loosepack: " << e.what() << "\n";
    return kError;
  }
  std::string missing;
  for (const auto& what : merged.missing) missing += (missing.empty() ? "" : ", ") + what;
  if (!missing.empty() && !m.partial) {
    std::cerr << "loosepack: the files leave members out (" << missing
              << "): merge them all, or add --partial to merge those at hand\n";
    return kInvalid;
  }
  const int failed = report_failures(merged.members, merged.scan.file);
  // Files whose runs stored the final states (run --snapshots) merge into a file with them, as
  // a resume of such a run writes them.
  const bool snapshots = m.snapshots || merged.snapshots;
  if (snapshots && !m.snapshots && !m.quiet)
    std::cerr << "loosepack: the files hold their members' final states (run --snapshots): the "
                 "merged file holds them too\n";
  try {
    report_members_left_out(
        write_member_results(m.out_path, merged.scan, merged.info, merged.members, snapshots));
  } catch (const std::exception& e) {
    std::cerr << "loosepack: " << e.what() << "\n";
    return kError;
  }
  if (!missing.empty())  // said even with -q: the file is not the whole scan's
    std::cerr << "loosepack: " << m.out_path << " leaves out " << missing << "\n";
  if (!m.quiet)
    std::cerr << "loosepack: wrote " << m.out_path << " with " << merged.members.size()
              << " members from " << m.parts.size() << " files (" << failed << " failed members)\n";
  return failed > 0 ? kMembersFailed : kOk;
}

// summary, analyse or export, on rank 0.
int file_command(const FileCommands& f) {
  const std::string& in = *f.analyse ? f.analyse_path : *f.exporter ? f.export_path
                                                                    : f.summary_path;
  if (const std::string problem = result_file_problem(in); !problem.empty()) {
    std::cerr << "loosepack: " << problem << "\n";
    return kInvalid;
  }
  try {
    if (*f.analyse) return analyse_command(f);
    if (*f.exporter) {
      const auto format = f.export_format == "xdmf" ? ExportFormat::Xdmf : ExportFormat::Extxyz;
      for (const auto& file : export_viewer_files(f.export_path, format, f.export_selection))
        std::cout << file << "\n";
      return kOk;
    }
    std::ostringstream text;  // printed whole, or not at all when the file is refused
    print_summary(f.summary_path, text);
    std::cout << text.str();
  } catch (const std::invalid_argument& e) {  // a selection the file does not have
    std::cerr << "loosepack: " << e.what() << "\n";
    return kInvalid;
  } catch (const DamagedResultFile& e) {
    std::cerr << "loosepack: " << e.what() << "\n";
    return kInvalid;
  } catch (const ScanError& e) {  // a scan_text this program does not accept
    std::cerr << "loosepack: " << e.what() << "\n";
    return kInvalid;
  } catch (const std::exception& e) {
    std::cerr << "loosepack: " << e.what() << "\n";
    return kError;
  }
  return kOk;
}

}  // namespace

int main(int argc, char** argv) {
  // A reader of stdout or stderr that goes away (`| head`) makes writes fail, not the program
  // die: a run goes on to write its file.
  std::signal(SIGPIPE, SIG_IGN);
  // Each line of stderr goes out in one write (stdio holds it to its newline), so that what
  // mpirun prints while the ranks start, or another rank's line, never lands inside one.
  std::setvbuf(stderr, nullptr, _IOLBF, 1 << 14);
  std::cerr.unsetf(std::ios::unitbuf);
  Ranks ranks(argc, argv);
  CLI::App app{
      "loosepack: ensembles of 2D cohesive granular deposits (contact dynamics)\n"
      "Exit codes: 0 done, 1 an error while running or writing, 2 invalid input, 3 the "
      "file is written but members failed, 128+N stopped by signal N (resume with "
      "--resume). Kokkos options (--kokkos-threads=N, ...) pass through."};
  // Usage errors start with the program's name, as its own messages do (the subcommands added
  // below inherit it).
  app.failure_message([](const CLI::App* a, const CLI::Error& e) {
    return "loosepack: " + CLI::FailureMessage::simple(a, e);
  });
  app.require_subcommand(0, 1);
  bool version = false;
  app.add_flag("--version", version, "print the version, the Kokkos backend and MPI, and exit");
  RunOptions o;
  CLI::App* run_cmd = add_run_command(app, o);
  FileCommands files;
  add_file_commands(app, files);
  MergeOptions merge;
  add_merge_command(app, merge);
  std::vector<char*> args = without_kokkos_options(argc, argv);
  std::set<std::string> subcommands;
  std::string names;
  for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
    subcommands.insert(sub->get_name());
    names += (names.empty() ? "" : ", ") + sub->get_name();
  }
  if (args.size() > 1 && args[1][0] != '-' && !subcommands.count(args[1])) {
    if (ranks.root())
      std::cerr << "loosepack: unknown subcommand '" << args[1] << "' (" << names
                << "; loosepack --help)\n";
    return kInvalid;
  }
  try {
    app.parse(static_cast<int>(args.size()), args.data());
  } catch (const CLI::ParseError& e) {
    const int rc = ranks.root() ? app.exit(e) : e.get_exit_code();
    return rc == 0 ? kOk : kInvalid;  // --help exits 0; every usage error 2
  }

  // Kokkos reads its own options (--kokkos-threads=N, ...) and environment (KOKKOS_NUM_THREADS);
  // one it cannot read throws, which is invalid input, not a crash.
  std::optional<Kokkos::ScopeGuard> kokkos;
  try {
    kokkos.emplace(argc, argv);
  } catch (const std::exception& e) {
    std::string why = e.what();
    why = why.substr(0, why.find('\n'));  // Kokkos's first line; a traceback note follows it
    if (ranks.root())
      std::cerr << "loosepack: a Kokkos option (--kokkos-...) or KOKKOS_ variable could not be "
                   "read ("
                << why << "): give it a valid value (loosepack --help)\n";
    return kInvalid;
  }
  if (version) {
    if (ranks.root()) std::cout << version_text();
    return kOk;
  }
  if (app.get_subcommands().empty()) {
    if (ranks.root())
      std::cerr << "loosepack: a subcommand is required: " << names << " (loosepack --help)\n";
    return kInvalid;
  }
  if (*run_cmd) {
    for (const auto& [number, name] : kStopSignals) std::signal(number, on_signal);
    return run(o, ranks);
  }
  if (*merge.command) return ranks.root() ? merge_command(merge) : kOk;
  return ranks.root() ? file_command(files) : kOk;
}
