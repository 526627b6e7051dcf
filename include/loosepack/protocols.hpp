// The protocols of MODEL.md run on batches of ensemble members.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "loosepack/batch.hpp"
#include "loosepack/scan.hpp"

namespace loosepack {

// One ensemble member: a scan point and a seed.
struct Member {
  int point = 0;
  int seed_index = 0;
  std::uint64_t id = 0;  // point * seeds + seed_index: keys the random stream
  Protocol protocol = Protocol::A;
  SystemParams params;
};

std::vector<Member> members_of(const Scan& scan);

// One deposition event of protocol A.
struct AvalancheEvent {
  int moved = 0;          // disks that moved more than the threshold in y
  double downward = 0.0;  // their summed downward displacement [R]
  long steps = 0;         // steps to rest
  bool capped = false;    // hit max_relax_time before rest
};

struct MemberResult {
  Member member;
  Failure failure = Failure::None;
  std::vector<double> x, y_i, y_e, radius;  // per disk, in deposition order
  std::vector<AvalancheEvent> events;       // protocol A
  std::vector<ContactForce> contacts;       // final contact forces (force chains, paper fig. 1)
  // Trajectories of every k-th disk (observables.trajectory_every = k > 0), one row per sample:
  // when (A: disks deposited so far; C: collapse step), which disk, where.
  std::vector<double> trajectory_time, trajectory_disk, trajectory_x, trajectory_y;
  long steps = 0, sweeps = 0;
  int capped = 0;          // A: events that hit the cap; C: 1 if the collapse hit its cap
  double wall_time = 0.0;  // seconds the member held its batch slot (shared with the others)
  bool ok() const { return failure == Failure::None; }
};

// Called after each finished member (and periodically with done == false for progress).
struct Progress {
  int members_done = 0;
  int members_total = 0;
  long disks_deposited = 0;
  // Rough estimate of the fraction of the run's cost done (see the cost model in
  // run_members): for the ETA only.
  double fraction = 0.0;
};
using ProgressFn = std::function<void(const Progress&)>;

// Run the members on one batch of scan.batch_size slots: members of any protocol advance
// together, and a finished member's slot takes the next member. Results in member order.
// stage_seconds, when given, receives the wall time per named stage of the batch step.
std::vector<MemberResult> run_members(
    const Scan& scan, const std::vector<Member>& members, const ProgressFn& progress = {},
    std::vector<std::pair<std::string, double>>* stage_seconds = nullptr);

// Grid capacity for one member: enough slots for the densest packing below H.
int member_capacity(const SystemParams& p);

}  // namespace loosepack
