// Relaxation regions of protocol A (docs/MODEL.md, "Relaxation regions"): after a disk is
// deposited on a tall deposit, almost all of it is at rest. Instead of stepping the whole system
// until it is at rest again, the disks within a radius of the new disk are stepped in a small
// system of their own (a slot of a second batch), with the disks around them held fixed; when
// motion reaches the region's margin the region grows around every moving disk. When the region
// is at rest its disks are written back into the whole system, whose rest is then checked there
// by the protocol: rest.steps steps without a disk above the check's speed, converged or not
// (docs/MODEL.md, "Relaxation regions").
#pragma once
#include <memory>
#include <vector>

#include "loosepack/batch.hpp"

namespace loosepack {

struct RegionState;

struct RegionSettings {
  double radius = 0.0;      // [R]: disks within this distance of a seed move; 0: no regions
  int max_disks = 0;        // moving and fixed disks a region slot holds
  double max_height = 0.0;  // tallest region a slot's grid holds [R]
};

// The height of a region slot's grid for regions of this radius in systems at most `tallest`
// high: min(tallest, 4 radius + 40 R) + 4 R (docs/MODEL.md, "Relaxation regions").
double region_slot_height(double radius, double tallest);

class Regions {
 public:
  struct Point {
    double x = 0.0, y = 0.0;
  };
  // One region slot per system of the whole batch; every slot's grid holds a region
  // settings.max_height tall of any of `systems`.
  Regions(int slots, const std::vector<SystemParams>& systems, const RegionSettings& settings,
          const SolverSettings& solver, const RestSettings& rest);
  ~Regions();
  Regions(const Regions&) = delete;
  Regions& operator=(const Regions&) = delete;

  // Starts relaxing system s of `whole` in region slot s: the disks within the radius of a seed
  // move, those within contact reach of them are held fixed. False (nothing started) when the
  // region does not fit the slot or no disk would move in it (no seed, or only fixed disks near
  // one): the caller relaxes the whole system instead. The small system is solved to
  // `tolerance` [h m g] (the whole system's). `radius` > 0 replaces the settings' radius for
  // this region and the regions it grows into.
  bool begin(Batch& whole, int s, const std::vector<Point>& seeds, double tolerance,
             double radius = 0.0);
  // One step of every running region.
  void step();

  enum class State {
    Running,    // still moving inside the region (it may have grown)
    Rested,     // at rest by the rest criterion; written back into the whole system
    RelaxWhole  // relax the whole system: the region outgrew the slot (written back), failed
                // (nothing written back), or no region runs in slot s
  };
  // After step(): the state of region s. Grows the region (a new small system around every
  // disk that moves) when a disk faster than the rest speed is further than 0.6 radius
  // from every seed.
  State poll(Batch& whole, int s);
  // Writes region s back into the whole system and stops it (a relaxation cut at its cap).
  void stop(Batch& whole, int s);

  // Region s as it runs, for a member's snapshot (its small system between two steps).
  RegionState state(int s) const;
  // Region slot s goes on from `state`, taken of system s of `whole` as `whole` is now (the
  // whole system restored from the same snapshot): its steps from here are those the region
  // would have taken. Throws std::invalid_argument where the state does not fit `whole`.
  void resume(const Batch& whole, int s, const RegionState& state);

  const SystemStatus& status(int s) const;  // of the current small system of slot s
  long steps(int s) const;  // all steps of slot s, all its regions, since construction
  long sweeps(int s) const;
  const std::vector<StageCost>& stage_costs() const;
  void set_timing(bool on);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Where a running region was cut from the whole system: what Regions keeps of it besides its
// small system.
struct RegionCut {
  std::vector<int> index;  // the disk of the whole system behind each disk of the region
  std::vector<char> moving;
  std::vector<Regions::Point> seeds;
  double radius = 0.0;     // disks within it of a seed move
  double y0 = 0.0;         // the region's y = the whole system's y - y0
  double height = 0.0;     // of the small system's box
  double tolerance = 0.0;  // the whole system's solver tolerance
};

// A running region between two steps, as a member's snapshot keeps it.
struct RegionState {
  RegionCut cut;
  Batch::SystemState system;  // its small system
};

// Whether `state` can be a running region of a system of `whole_disks` disks: one entry per disk
// of its small system, each the whole system's, seeds, frame, box and tolerance finite, radius
// and box positive (what Regions::resume and the checkpoint reader check).
bool holds_together(const RegionState& state, int whole_disks);

// The disks within `radius` of a seed (moving), and those further out but within `reach` of the
// moving ones (fixed), in increasing index order; periodic in x with period `width`.
struct RegionSelection {
  std::vector<int> index;
  std::vector<char> moving;
};
RegionSelection select_region(const std::vector<Disk>& disks,
                              const std::vector<Regions::Point>& seeds, double width, double radius,
                              double reach);

}  // namespace loosepack
