// Relaxation regions of protocol A: a small system per region in a second batch, cut out of the
// whole system around the seeds, stepped until at rest, grown when motion reaches its margin,
// and written back.
#include "loosepack/region.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_map>

#include "kernels/state.hpp"
#include "loosepack/geometry.hpp"

namespace loosepack {

namespace {

// A region grows when a moving disk comes this fraction of its radius near its edge.
constexpr double kGrowthBand = 0.4;

// Seeds binned in cells at least `cutoff` on a side (L_x / floor(L_x / cutoff) wide, periodic in
// x): the (squared) distance from a point to the nearest seed, exact whenever it is below the
// cutoff.
class SeedGrid {
 public:
  SeedGrid() = default;
  SeedGrid(const std::vector<Regions::Point>& seeds, double width, double cutoff)
      : seeds_(seeds), width_(width), cell_(cutoff) {
    nx_ = std::max(1, static_cast<int>(std::floor(width / cutoff)));
    for (std::size_t k = 0; k < seeds.size(); ++k)
      cells_[key(column(seeds[k].x), row(seeds[k].y))].push_back(static_cast<int>(k));
  }
  // The smallest squared distance from (x, y) to a seed, or some squared distance at most
  // `enough` as soon as one is found (callers that only compare with a threshold pass its
  // square). Exact whenever it is below the cutoff squared; infinity when no seed is that near.
  double nearest_squared(double x, double y, double enough) const {
    double best = std::numeric_limits<double>::infinity();
    const int cx = column(x), cy = row(y);
    const int ncols = nx_ < 3 ? nx_ : 3;
    static constexpr int kOrder[3] = {0, -1, 1};  // the point's own cell first
    for (int e = 0; e < ncols; ++e) {
      const int col = nx_ < 3 ? e : (cx + kOrder[e] + nx_) % nx_;
      for (int dy_cell : kOrder) {
        const auto it = cells_.find(key(col, cy + dy_cell));
        if (it == cells_.end()) continue;
        for (int k : it->second) {
          const auto& p = seeds_[static_cast<std::size_t>(k)];
          const double dx = periodic_delta(x - p.x, width_), dy = y - p.y;
          best = std::min(best, dx * dx + dy * dy);
          if (best <= enough) return best;
        }
      }
    }
    return best;
  }

 private:
  int column(double x) const {
    const int c = static_cast<int>(std::floor(x / width_ * nx_));
    return std::clamp(c, 0, nx_ - 1);
  }
  int row(double y) const { return static_cast<int>(std::floor(y / cell_)); }
  static long long key(int col, int row) {
    return static_cast<long long>(row) * (1LL << 32) + static_cast<long long>(col);
  }
  std::vector<Regions::Point> seeds_;
  double width_ = 1.0, cell_ = 1.0;
  int nx_ = 1;
  std::unordered_map<long long, std::vector<int>> cells_;
};

}  // namespace

RegionSelection select_region(const std::vector<Disk>& disks,
                              const std::vector<Regions::Point>& seeds, double width, double radius,
                              double reach) {
  const SeedGrid grid(seeds, width, radius + reach);
  RegionSelection out;
  for (std::size_t k = 0; k < disks.size(); ++k) {
    const double d2 = grid.nearest_squared(disks[k].x, disks[k].y, radius * radius);
    if (d2 > (radius + reach) * (radius + reach)) continue;
    out.index.push_back(static_cast<int>(k));
    out.moving.push_back(d2 <= radius * radius && !disks[k].fixed ? 1 : 0);
  }
  return out;
}

struct Regions::Impl {
  RegionSettings settings;
  RestSettings rest;
  std::unique_ptr<Batch> batch;
  struct Slot {
    bool running = false;
    RegionCut cut;
    SeedGrid grid;  // of cut.seeds
    long done_steps = 0, done_sweeps = 0;
  };
  std::vector<Slot> slots;

  // The small system of a region of system s of `whole`: its disks (in the region's frame) in a
  // box `height` tall, solved as the whole system is, to `tolerance`.
  SystemSetup setup(const Batch& whole, int s, double height, double tolerance,
                    std::vector<Disk> disks) const {
    SystemSetup su;
    su.params = whole.params(s);
    su.params.height = height;
    su.capacity = settings.max_disks;
    su.tolerance = tolerance;
    su.max_sweeps = whole.max_sweeps(s);
    su.newton_every = whole.newton_every(s);
    su.disks = std::move(disks);
    return su;
  }
  // Slot s runs the region of this cut.
  void start(const Batch& whole, int s, RegionCut cut) {
    Slot& sl = slots.at(static_cast<std::size_t>(s));
    sl.running = true;
    sl.grid = SeedGrid(cut.seeds, whole.params(s).width, cut.radius);
    sl.cut = std::move(cut);
  }

  // Positions and velocities of the moving disks, the impulses of every contact with a moving
  // disk (the whole system keeps its impulses between fixed disks), and the solver's pace.
  void write_back(Batch& whole, int s, const std::vector<Disk>& region) {
    const Slot& sl = slots[static_cast<std::size_t>(s)];
    std::vector<int> idx;
    std::vector<Disk> out;
    std::vector<char> moved(static_cast<std::size_t>(whole.status(s).count), 0);
    for (std::size_t k = 0; k < sl.cut.index.size(); ++k) {
      if (!sl.cut.moving[k]) continue;
      Disk d = region[k];
      d.y += sl.cut.y0;
      idx.push_back(sl.cut.index[k]);
      out.push_back(d);
      moved[static_cast<std::size_t>(sl.cut.index[k])] = 1;
    }
    whole.set_disks(s, idx, out);
    std::vector<ContactForce> contacts;
    for (const auto& c : whole.contacts(s))
      if (!moved[static_cast<std::size_t>(c.i)] &&
          (c.j < 0 || !moved[static_cast<std::size_t>(c.j)]))
        contacts.push_back(c);
    for (auto c : batch->contacts(s)) {
      if (!sl.cut.moving[static_cast<std::size_t>(c.i)] &&
          (c.j < 0 || !sl.cut.moving[static_cast<std::size_t>(c.j)]))
        continue;
      c.i = sl.cut.index[static_cast<std::size_t>(c.i)];
      if (c.j >= 0) c.j = sl.cut.index[static_cast<std::size_t>(c.j)];
      contacts.push_back(c);
    }
    whole.set_contacts(s, contacts);
    whole.set_solver_pace(s, batch->solver_pace(s));
  }
  void end(int s) {
    Slot& sl = slots[static_cast<std::size_t>(s)];
    const auto& st = batch->status(s);
    sl.done_steps += st.steps;
    sl.done_sweeps += st.sweeps;
    sl.running = false;
    batch->set_active(s, false);
  }
};

namespace {
constexpr double kRegionHeadroom = 4.0;  // [R] above the tallest system a region slot holds
}  // namespace

double region_slot_height(double radius, double tallest) {
  return std::min(tallest, 4.0 * radius + 40.0) + kRegionHeadroom;
}

Regions::Regions(int n, const std::vector<SystemParams>& systems, const RegionSettings& settings,
                 const SolverSettings& solver, const RestSettings& rest)
    : impl_(std::make_unique<Impl>()) {
  if (!(settings.radius > 0.0)) throw std::invalid_argument("Regions: radius must be positive");
  if (systems.empty()) throw std::invalid_argument("Regions: no systems");
  impl_->settings = settings;
  impl_->rest = rest;
  int cells = 0;
  for (const auto& p : systems) {
    SystemSetup su;
    su.params = p;
    su.params.height = settings.max_height;
    cells = std::max(cells, grid_cells_needed(su));
  }
  std::vector<SystemSetup> setups(static_cast<std::size_t>(std::max(n, 1)));
  for (auto& su : setups) {
    su.params = systems.front();
    su.params.height = settings.max_height;
    su.capacity = settings.max_disks;
    su.grid_cells = cells;
  }
  impl_->batch = std::make_unique<Batch>(setups, solver, rest);
  impl_->slots.resize(setups.size());
  for (int s = 0; s < impl_->batch->size(); ++s) impl_->batch->set_active(s, false);
}

Regions::~Regions() = default;

bool Regions::begin(Batch& whole, int s, const std::vector<Point>& seeds, double tolerance,
                    double radius) {
  auto& I = *impl_;
  const std::vector<Disk> disks = whole.disks(s);
  const SystemParams& pr = whole.params(s);
  double rmax = pr.radius;
  for (const auto& d : disks) rmax = std::max(rmax, d.radius);
  // Contact reach of a moving disk: the largest detection margin a region of this system's grid
  // allows, from its own height (region_slot_height of it: the slots' height, or less in a lower
  // system), so that the scan's other points do not change its regions.
  const double own_height = std::min(I.settings.max_height, pr.height + kRegionHeadroom);
  const double reach = contact_reach(pr, rmax, grid_margin(pr, own_height));
  if (!(radius > 0.0)) radius = I.settings.radius;
  const RegionSelection sel = select_region(disks, seeds, pr.width, radius, reach);
  const bool moves =
      std::any_of(sel.moving.begin(), sel.moving.end(), [](char m) { return m != 0; });
  if (!moves || static_cast<int>(sel.index.size()) > I.settings.max_disks) return false;
  // The floor of the small system: the whole system's floor when the region comes near it,
  // else out of everyone's reach (two radii below the lowest disk and further below every seed
  // than the radius, so that no disk reaches it without growing the region first).
  double lowest = std::numeric_limits<double>::infinity(), top = 0.0;
  for (int k : sel.index) {
    const Disk& d = disks[static_cast<std::size_t>(k)];
    lowest = std::min(lowest, d.y - d.radius);
    top = std::max(top, d.y + d.radius);
  }
  for (const auto& p : seeds) lowest = std::min(lowest, p.y - radius);
  const double y0 = std::max(0.0, lowest - 2.0 * pr.radius);
  const double height = top - y0 + 2.0 * pr.radius;
  std::vector<Disk> in_region;
  for (std::size_t k = 0; k < sel.index.size(); ++k) {
    Disk d = disks[static_cast<std::size_t>(sel.index[k])];
    d.y -= y0;
    if (!sel.moving[k]) {  // held where it is: no velocity (a fixed disk keeps its own)
      d.fixed = true;
      d.vx = d.vy = d.w = 0.0;
    }
    in_region.push_back(d);
  }
  try {
    I.batch->reset(s, I.setup(whole, s, height, tolerance, std::move(in_region)));
  } catch (const std::invalid_argument&) {
    return false;  // more grid cells than the slot holds: too tall
  }
  // Warm start from the whole system's impulses between the region's disks.
  std::vector<int> local(disks.size(), -1);
  for (std::size_t k = 0; k < sel.index.size(); ++k)
    local[static_cast<std::size_t>(sel.index[k])] = static_cast<int>(k);
  std::vector<ContactForce> contacts;
  for (auto c : whole.contacts(s)) {
    if (c.j < 0 && y0 > 0.0) continue;  // the region's floor is not the real one
    const bool floor = c.j < 0;
    c.i = local[static_cast<std::size_t>(c.i)];
    if (!floor) c.j = local[static_cast<std::size_t>(c.j)];
    if (c.i < 0 || (!floor && c.j < 0)) continue;  // a disk outside the region
    contacts.push_back(c);
  }
  I.batch->set_contacts(s, contacts);
  // The pace of the Newton rounds learned on this deposit so far, not afresh for every region.
  I.batch->set_solver_pace(s, whole.solver_pace(s));
  I.batch->set_active(s, true);
  I.start(whole, s, RegionCut{sel.index, sel.moving, seeds, radius, y0, height, tolerance});
  return true;
}

void Regions::step() { impl_->batch->step(); }

Regions::State Regions::poll(Batch& whole, int s) {
  auto& I = *impl_;
  auto& sl = I.slots.at(static_cast<std::size_t>(s));
  if (!sl.running) return State::RelaxWhole;
  const auto& st = I.batch->status(s);
  if (st.failure != Failure::None) {
    I.end(s);  // nothing written back: the whole system relaxes from where it was
    return State::RelaxWhole;
  }
  if (!st.at_rest && !(st.rest_speed(I.rest.spin) > I.rest.speed))
    return State::Running;  // nothing to grow
  const std::vector<Disk> region = I.batch->disks(s);
  if (st.at_rest) {
    I.write_back(whole, s, region);
    I.end(s);
    return State::Rested;
  }
  // Grow when a moving disk is in the margin; the new seeds are every moving disk.
  bool grow = false;
  std::vector<Point> fresh;
  const double inner = (1.0 - kGrowthBand) * sl.cut.radius;
  for (std::size_t k = 0; k < region.size(); ++k) {
    if (!sl.cut.moving[k] || !(speed(region[k], I.rest.spin) > I.rest.speed)) continue;
    const Point p{region[k].x, region[k].y + sl.cut.y0};
    fresh.push_back(p);
    if (!grow && sl.grid.nearest_squared(p.x, p.y, inner * inner) > inner * inner) grow = true;
  }
  if (!grow) return State::Running;
  std::vector<Point> seeds = sl.cut.seeds;
  seeds.insert(seeds.end(), fresh.begin(), fresh.end());
  I.write_back(whole, s, region);
  I.end(s);
  return begin(whole, s, seeds, sl.cut.tolerance, sl.cut.radius) ? State::Running
                                                                 : State::RelaxWhole;
}

void Regions::stop(Batch& whole, int s) {
  auto& I = *impl_;
  if (!I.slots.at(static_cast<std::size_t>(s)).running) return;
  if (I.batch->status(s).failure == Failure::None) I.write_back(whole, s, I.batch->disks(s));
  I.end(s);
}

RegionState Regions::state(int s) const {
  const auto& sl = impl_->slots.at(static_cast<std::size_t>(s));
  if (!sl.running)
    throw std::logic_error("Regions::state: region " + std::to_string(s) + " is not running");
  return {sl.cut, impl_->batch->state(s)};
}

bool holds_together(const RegionState& state, int whole_disks) {
  const RegionCut& cut = state.cut;
  const std::size_t n = cut.index.size();
  bool fits = n > 0 && cut.moving.size() == n && state.system.disks.size() == n &&
              !cut.seeds.empty() && cut.radius > 0.0 && cut.height > 0.0;
  for (int k : cut.index) fits = fits && k >= 0 && k < whole_disks;
  for (const auto& p : cut.seeds) fits = fits && std::isfinite(p.x) && std::isfinite(p.y);
  for (double v : {cut.radius, cut.y0, cut.height, cut.tolerance}) fits = fits && std::isfinite(v);
  return fits;
}

void Regions::resume(const Batch& whole, int s, const RegionState& state) {
  auto& I = *impl_;
  const RegionCut& cut = state.cut;
  if (!holds_together(state, whole.status(s).count) ||
      static_cast<int>(cut.index.size()) > I.settings.max_disks)
    throw std::invalid_argument("the relaxation region does not fit system " + std::to_string(s));
  I.batch->reset(s, I.setup(whole, s, cut.height, cut.tolerance, state.system.disks));
  I.batch->restore(s, state.system);
  I.start(whole, s, cut);
}

const SystemStatus& Regions::status(int s) const { return impl_->batch->status(s); }
long Regions::steps(int s) const {
  const auto& sl = impl_->slots.at(static_cast<std::size_t>(s));
  return sl.done_steps + (sl.running ? impl_->batch->status(s).steps : 0);
}
long Regions::sweeps(int s) const {
  const auto& sl = impl_->slots.at(static_cast<std::size_t>(s));
  return sl.done_sweeps + (sl.running ? impl_->batch->status(s).sweeps : 0);
}
const std::vector<StageCost>& Regions::stage_costs() const {
  return impl_->batch->stage_costs();
}
void Regions::set_timing(bool on) { impl_->batch->set_timing(on); }

}  // namespace loosepack
