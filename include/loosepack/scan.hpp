// A scan: the TOML file a user writes, validated and expanded into scan points and members.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "loosepack/params.hpp"

namespace loosepack {

enum class Protocol {
  A,  // slow deposition under gravity, relaxing to rest after every disk
  B,  // ballistic deposition with capture radius, no dynamics
  C,  // B, then gravity switched on: collapse to rest
};
std::string protocol_name(Protocol p);
// The protocol named "A", "B" or "C"; false for any other name.
bool protocol_from_name(const std::string& name, Protocol& p);

// The solver tolerance [h m g] a protocol runs with when the scan file sets none. From the
// accuracy/time study (docs/PERFORMANCE.md, "Accuracy against time"): 1e-3 for the slow
// deposition A; 3e-4 for the collapse C, where it is faster than 1e-3 (a loosely solved collapse
// creeps longer before rest) and follows the tightly converged reference. B has no dynamics.
inline double default_tolerance(Protocol p) { return p == Protocol::A ? 1e-3 : 3e-4; }

// The Newton rounds (SolverSettings::newton_every) a member runs with when the scan file sets
// none: the solver's default from Bo = kNewtonFromBond on, none below it. Against NNCG alone
// (docs/PERFORMANCE.md, "Newton steps") the rounds make protocol A 2.7-3.6 times faster at
// Bo = 1e3 and 1.08-1.22 times at 3e2, where the sweeps crawl through a loose cohesive network;
// from Bo = 0 to 1e2 they rarely pay and cost 1.07-1.32 times the CPU (protocols A and C).
constexpr double kNewtonFromBond = 200.0;
inline int default_newton_every(const SystemParams& params) {
  return params.bond_number >= kNewtonFromBond ? SolverSettings{}.newton_every : 0;
}

// The solver's sweep cap per step a member runs with when the scan file sets none. From the
// accuracy/time study and whole runs (docs/PERFORMANCE.md, "The sweep cap"): for A it grows with
// the box, 0.2 sweeps per R^2 of width x height (about two per disk of a loose deposit), between
// 300 and 2 000. In a small deposit a capped step is a stall that the next steps finish (24 R x
// 48-72 R at Bo = 1e2 and 1e3: 300 is 1.3-1.5x faster than 2 000, the observables within 0.7
// sigma); a larger one has steps that converge slowly and need more (40 R x 120 R, ~580 disks:
// 300 took 1.6x the sweeps of 1 000). C keeps 2 000: a collapse stopped early creeps (300: 1.5x
// the sweeps).
inline int default_max_sweeps(Protocol p, const SystemParams& params) {
  if (p != Protocol::A) return 2000;
  const double area = params.width * params.height / (params.radius * params.radius);
  return static_cast<int>(std::lround(std::clamp(0.2 * area, 300.0, 2000.0)));
}

// How the observables are measured (MODEL.md, "Observables").
struct ObservableSettings {
  double strip_width = 3.97;      // w of the volume fraction profile nu(y) [R]
  double lower_half_from = 50.0;  // nu_lower_half: mean nu between this height and H/2 [R]
  double bin_width = 4.0;         // avalanche profile bins in y_i and y_e (2 diameters) [R]
  double abs_dy_bin = 0.5;        // |Delta y| histogram bin [R]
  double cut_bottom = 20.0;       // |Delta y| histogram without the bottom ... [R]
  double cut_top = 20.0;          // ... and the top of the final deposit [R]
  // Whether the scan file sets the three lengths above. Where it does not, a point uses the
  // paper's value where it fits its box and a fraction of H where not (the *_at functions), so
  // that every box runs with the defaults.
  bool lower_half_from_given = false, cut_bottom_given = false, cut_top_given = false;
  // The lengths of a point of height H: the file's, else min(50 R, H/4) and min(20 R, H/6).
  double lower_half_from_at(double height) const {
    return lower_half_from_given ? lower_half_from : std::min(lower_half_from, height / 4.0);
  }
  double cut_bottom_at(double height) const {
    return cut_bottom_given ? cut_bottom : std::min(cut_bottom, height / 6.0);
  }
  double cut_top_at(double height) const {
    return cut_top_given ? cut_top : std::min(cut_top, height / 6.0);
  }
  double event_threshold = 0.1;   // a disk counts as moved in an avalanche beyond this [R]
  int trajectory_every = 0;       // record the trajectory of every k-th disk (0: none)
  int trajectory_interval = 100;  // C: steps between trajectory samples during the collapse
};

// When protocol A's deposition stops (docs/MODEL.md, "Protocols").
enum class StopRule {
  FirstOver,  // at the first drop whose top would pass H
  NoRoom,     // the paper's: a drop that would pass H is drawn again among the abscissae where a
              // disk still lands below H (src/room_below.hpp); it stops where there are none
};
constexpr StopRule kStopRules[] = {StopRule::FirstOver, StopRule::NoRoom};
inline const char* stop_rule_name(StopRule r) {
  return r == StopRule::NoRoom ? "no_room" : "first_over";
}

// Limits of the protocols' dynamics.
struct ProtocolSettings {
  double max_relax_time = 20.0;       // A: relaxation after one disk is capped here [sqrt(R/g)]
  double max_collapse_time = 3000.0;  // C: the collapse is capped here [sqrt(R/g)]
  // A member fails (Failure::Unconverged) when its solver hits the sweep cap on every step
  // for this long in a row [sqrt(R/g)].
  double max_unconverged_time = 1000.0;
  // A: relaxation regions (docs/MODEL.md): after each disk only the disks within this radius of
  // it (and of every disk that moves) are stepped, the rest held fixed [R]; 0: the whole system.
  double region_radius = 0.0;
  // A with regions: after every k-th disk the whole system is stepped to rest as well (1: after
  // every disk, which keeps the rest criterion of the whole system on every event).
  int region_check_every = 1;
  int region_max_disks = 4000;  // a larger region relaxes in the whole system instead
  StopRule stop_rule = StopRule::FirstOver;  // A: when the deposition stops
};

struct ScanPoint {
  int index = 0;
  Protocol protocol = Protocol::A;
  SystemParams params;
};

struct Scan {
  std::string file;  // path as given
  std::string text;  // the whole scan file
  // What identifies the scan to a checkpoint and to a merge of shards: its settings as parsed
  // and written out again by toml++ (keys sorted; no comments, blank lines or spacing; a
  // real-valued key's 12 and 12.0 the same), without what changes no member's result (the batch
  // size, the sweeps a launch: identity_of in src/scan.cpp), under a first line naming the
  // version of the toml++ headers
  // it was built with (another version may write a number otherwise, so a build against it
  // counts the same file as another scan: the safe side).
  std::string content;
  // What a checkpoint's fingerprint is made of: `content` less protocol.max_collapse_time, which
  // a resume may change (each member of the checkpoint is kept where the new cap gives it the
  // same result, and runs again where not: read_checkpoint, src/checkpoint.cpp).
  std::string resume_identity;
  std::string name = "scan";
  std::uint64_t seed = 1;
  int seeds = 1;          // members per scan point
  int batch_size = 0;     // systems advanced together; 0: default_batch_size() (protocols.hpp)
  SolverSettings solver;  // tolerance, max_sweeps and newton_every only count where given
  bool tolerance_given = false;   // [solver] tolerance set in the file, for every protocol
  bool max_sweeps_given = false;  // [solver] max_sweeps set in the file, for every protocol
  bool newton_every_given = false;  // [solver] newton_every set in the file, for every member
  // [solver] kind set in the file; else the backend's default (resolve_backend_defaults). A
  // Scan built in code that sets solver.kind sets this too.
  bool solver_kind_given = false;
  // [solver] sweeps_per_launch set in the file; else the backend's default for the team solver
  // (resolve_backend_defaults). A Scan built in code that sets it to 0 sets this too.
  bool sweeps_per_launch_given = false;
  // [solver] fused_step set in the file; else the backend's default (default_fused_step).
  bool fused_step_given = false;
  RestSettings rest;
  ObservableSettings observables;
  ProtocolSettings protocol;
  std::vector<ScanPoint> points;
  std::vector<std::string> warnings;  // valid but questionable choices, printed by the program
  int members() const { return static_cast<int>(points.size()) * seeds; }
  // The solver tolerance of a member of protocol p: the file's, else the protocol's default.
  double tolerance(Protocol p) const {
    return tolerance_given ? solver.tolerance : default_tolerance(p);
  }
  // The sweep cap of a member of protocol p with these parameters: the file's, else the default.
  int max_sweeps(Protocol p, const SystemParams& params) const {
    return max_sweeps_given ? solver.max_sweeps : default_max_sweeps(p, params);
  }
  // The Newton rounds of a member with these parameters: the file's, else the default.
  int newton_every(const SystemParams& params) const {
    return newton_every_given ? solver.newton_every : default_newton_every(params);
  }
};

// Thrown for any invalid scan file; the message names file:line:column and the key.
class ScanError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

Scan load_scan(const std::string& path);
Scan parse_scan(const std::string& text, const std::string& file);

// The first setting in which two scans' identities (Scan::content) differ, as "key 'K' is `V` in
// <a_name> and `W` in <b_name>" (`(none)` for a key one of them lacks; K such as
// `system.height` or `point[1].height`), or "" where they are the same settings.
std::string first_difference(const std::string& a, const std::string& b, const std::string& a_name,
                             const std::string& b_name);

}  // namespace loosepack
