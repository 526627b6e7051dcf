// The device state of a batch: allocating its views, loading a system into a slot, reading a
// system's disks and contacts, and its whole state for a checkpoint and back.
#include "batch_impl.hpp"

namespace loosepack {

GridShape grid_shape(const SystemSetup& su) {
  const auto& pr = su.params;
  double rmax = largest_radius(pr);
  for (const auto& d : su.disks) rmax = std::max(rmax, d.radius);
  GridShape g;
  // No disk moves faster than a fall through the whole box.
  g.max_margin = grid_margin(pr, box_top(pr, rmax));
  g.cell = contact_reach(pr, rmax, g.max_margin);
  g.nx = std::max(1, static_cast<int>(std::floor(pr.width / g.cell)));
  g.ny = std::max(1, static_cast<int>(std::ceil(box_top(pr, rmax) / g.cell)));
  return g;
}

int grid_cells_needed(const SystemSetup& setup) {
  const GridShape g = grid_shape(setup);
  return g.nx * g.ny;
}

// The views of a batch for these systems, each slot sized for its setup, then every system
// loaded.
void Batch::Impl::allocate(const std::vector<SystemSetup>& setups) {
  const std::vector<int> cell_offset = lay_out(setups);
  allocate_systems(cell_offset);
  allocate_particles();
  allocate_contacts();
  own(grid.cell_start, "cell_start", static_cast<std::size_t>(n_cells) + 1);
  own(grid.cell_fill, "cell_fill", static_cast<std::size_t>(n_cells));
  own(grid.cell_particles, "cell_particles", static_cast<std::size_t>(n_particles));
  const auto S = static_cast<std::size_t>(n_systems);
  params.resize(S);
  status.assign(S, SystemStatus{});
  sweeps_before.assign(S, 0);
  for (std::size_t s = 0; s < S; ++s) load(static_cast<int>(s), setups[s]);
}

// Each system's slots of disks and grid cells in the batch's arrays; returns where each
// system's cells begin.
std::vector<int> Batch::Impl::lay_out(const std::vector<SystemSetup>& setups) {
  n_systems = static_cast<int>(setups.size());
  if (n_systems == 0) throw std::invalid_argument("Batch: no systems");
  const auto S = static_cast<std::size_t>(n_systems);
  offsets.resize(S);
  slot_capacity.resize(S);
  slot_cells.resize(S);
  std::vector<int> cell_offset(S);
  // Disk, contact and cell indices of the whole batch are ints: refuse a batch beyond them.
  const long long kMaxIndex = std::numeric_limits<int>::max() / kIncident;
  long long particles = 0, cells = 0;
  for (const auto& su : setups) {
    particles += std::max<long long>({su.capacity, static_cast<long long>(su.disks.size()), 1});
    cells += std::max(su.grid_cells, grid_cells_needed(su)) + 1;
  }
  if (particles > kMaxIndex || cells > kMaxIndex)
    throw std::invalid_argument(
        "Batch: " + std::to_string(S) + " systems need " + std::to_string(particles) +
        " disk slots and " + std::to_string(cells) + " grid cells, more than one batch " +
        "indexes (" + std::to_string(kMaxIndex) + "): use a smaller batch size");
  for (std::size_t s = 0; s < S; ++s) {
    const auto& su = setups[s];
    slot_capacity[s] = std::max({su.capacity, static_cast<int>(su.disks.size()), 1});
    slot_cells[s] = std::max(su.grid_cells, grid_cells_needed(su));
    offsets[s] = n_particles;
    n_particles += slot_capacity[s];
    cell_offset[s] = n_cells;
    n_cells += slot_cells[s] + 1;  // one to spare: where the fused step's grid ends the system's
  }
  return cell_offset;
}

// The per-system views, and the host's counters and mirrors of them.
void Batch::Impl::allocate_systems(const std::vector<int>& cell_offset) {
  const auto S = static_cast<std::size_t>(n_systems);
  own(sys.offset, "offset", S);
  own(sys.capacity, "capacity", S);
  own(sys.count, "count", S);
  own(sys.width, "width", S);
  own(sys.height, "height", S);
  own(sys.radius, "radius", S);
  own(sys.polydispersity, "polydispersity", S);
  own(sys.disk_density, "disk_density", S);
  own(sys.capture_radius, "capture_radius", S);
  own(sys.gravity_x, "gravity_x", S);
  own(sys.gravity_y, "gravity_y", S);
  own(sys.cohesive_force, "cohesive_force", S);
  own(sys.cohesion_range, "cohesion_range", S);
  own(sys.friction, "friction", S);
  own(sys.rolling_friction, "rolling_friction", S);
  own(sys.time_step, "time_step", S);
  own(sys.weight, "weight", S);
  own(sys.tolerance, "tolerance", S);
  own(sys.step_tolerance, "step_tolerance", S);
  own(sys.max_sweeps, "max_sweeps", S);
  own(sys.floor_cohesion, "floor_cohesion", S);
  own(sys.seed, "seed", S);
  own(sys.member, "member", S);
  own(sys.draws, "draws", S);
  own(sys.cell_size, "cell_size", S);
  own(sys.grid_nx, "grid_nx", S);
  own(sys.grid_ny, "grid_ny", S);
  own(sys.cell_offset, "cell_offset", S);
  own(sys.active, "active", S);
  own(sys.unconverged, "unconverged", S);
  own(sys.failure, "failure", S);
  own(sys.sweep_change, "sweep_change", S);
  own(sys.max_speed, "max_speed", S);
  own(sys.max_centre_speed, "max_centre_speed", S);
  own(sys.margin, "margin", S);
  own(sys.max_margin, "max_margin", S);
  own(sys.gradient2, "gradient2", S);
  own(sys.mid_step, "mid_step", S);
  own(sys.colours, "colours", S);
  own(sys.coloured_count, "coloured_count", S);
  own(sys.span_steps, "span_steps", S);
  own(sys.span_step, "span_step", S);
  own(sys.spans, "spans", S);
  own(sys.span_change, "span_change", S);
  own(sys.mean_speed, "mean_speed", S);
  sweeps_this_step = alloc<int>("sweeps_this_step", S);
  sweep_limit = alloc<int>("sweep_limit", S);
  sweep_limit_host = Kokkos::create_mirror_view(sweep_limit);
  launched.assign(static_cast<std::size_t>(S), 0);
  newton_steps.assign(static_cast<std::size_t>(S), 0);
  sweep_cap.assign(static_cast<std::size_t>(S), solver.max_sweeps);
  newton_every.assign(static_cast<std::size_t>(S), solver.newton_every);
  newton_pace.assign(static_cast<std::size_t>(S), NewtonPace{2 * solver.newton_every});
  newton_factor.resize(static_cast<std::size_t>(S));
  for (auto& f : newton_factor) f = std::make_unique<KluFactor>();
  report = alloc<double>("status_report", static_cast<std::size_t>(S) * kStatusFields);
  host_report = Kokkos::create_mirror_view(report);
  newton_host.unconverged = Kokkos::create_mirror_view(sys.unconverged);
  newton_host.sweeps = Kokkos::create_mirror_view(sweeps_this_step);
  request = alloc<int>("request", S);
  request_x = alloc<double>("request_x", S);
  reply = alloc<double>("reply", 4 * S);
  scheduler_host = {Kokkos::create_mirror_view(request), Kokkos::create_mirror_view(sys.active),
                    Kokkos::create_mirror_view(request_x), Kokkos::create_mirror_view(reply)};
  load_system = alloc<SlotLoad>("load_system", 1);
  const int largest = *std::max_element(slot_capacity.begin(), slot_capacity.end());
  load_disks = alloc<double>("load_disks", static_cast<std::size_t>(kSlotDiskFields * largest));
  load_host = {Kokkos::create_mirror_view(load_system), Kokkos::create_mirror_view(load_disks)};
  slot_staging = alloc<double>("slot_staging",
                               static_cast<std::size_t>(slot_span_at(largest, kSpanFields, 0)));
  slot_host = Kokkos::create_mirror_view(slot_staging);
  fill_from(sys.offset, S, [&](std::size_t s) { return offsets[s]; });
  fill_from(sys.capacity, S, [&](std::size_t s) { return slot_capacity[s]; });
  fill_from(sys.cell_offset, S, [&](std::size_t s) { return cell_offset[s]; });
}

// The per-disk views, each disk slot marked with its system.
void Batch::Impl::allocate_particles() {
  const auto S = static_cast<std::size_t>(n_systems);
  const auto P = static_cast<std::size_t>(n_particles);
  own(part.system, "system", P);
  own(part.x, "x", P);
  own(part.y, "y", P);
  own(part.theta, "theta", P);
  own(part.vx, "vx", P);
  own(part.vy, "vy", P);
  own(part.w, "w", P);
  own(part.vfx, "vfx", P);
  own(part.vfy, "vfy", P);
  own(part.wf, "wf", P);
  own(part.radius, "radius", P);
  own(part.inv_mass, "inv_mass", P);
  own(part.inv_inertia, "inv_inertia", P);
  own(part.y_deposit, "y_deposit", P);
  own(part.y_mark, "y_mark", P);
  own(part.span, "span", P * kSpanFields);
  own(part.cell, "cell", P);
  own(part.n_incident, "n_incident", P);
  own(part.incident, "incident", P * kIncident);
  {
    auto h = Kokkos::create_mirror_view(part.system);
    for (std::size_t s = 0; s < S; ++s)
      for (int k = 0; k < slot_capacity[s]; ++k) h(offsets[s] + k) = static_cast<int>(s);
    Kokkos::deep_copy(part.system, h);
  }
  // No slot belongs to a cell until the first grid build.
  Kokkos::deep_copy(part.cell, -1);
}

// The per-contact views: kSlots contact slots per disk slot, and what the solver kind needs.
void Batch::Impl::allocate_contacts() {
  const auto NC = static_cast<std::size_t>(n_particles) * kSlots;
  own(con.partner, "partner", NC);
  Kokkos::deep_copy(con.partner, kNoContact);
  own(con.nx, "cnx", NC);
  own(con.ny, "cny", NC);
  own(con.gap, "gap", NC);
  own(con.rc, "rc", NC);
  own(con.wn, "wn", NC);
  own(con.wa, "wa", NC);
  own(con.wb, "wb", NC);
  own(con.wc, "wc", NC);
  own(con.lower, "lower", NC);
  own(con.pn, "pn", NC);
  own(con.pt, "pt", NC);
  own(con.pm, "pm", NC);
  own(con.colour, "colour", NC);
  if (solver.kind == SolverKind::AcceleratedGaussSeidel) {
    own(con.start_pn, "start_pn", NC);
    own(con.start_pt, "start_pt", NC);
    own(con.start_pm, "start_pm", NC);
    own(con.dir_pn, "dir_pn", NC);
    own(con.dir_pt, "dir_pt", NC);
    own(con.dir_pm, "dir_pm", NC);
  }
  colour_list = alloc<int>("colour_list", NC);
  if (solver.kind == SolverKind::ColouredAcceleratedGaussSeidel) {
    system_colour_start =
        alloc<int>("system_colour_start", NC + static_cast<std::size_t>(n_systems));
    own(con.coloured_partner, "coloured_partner", NC);
    packed_owner = alloc<int>("packed_owner", NC);
    own(packed.partner, "packed_partner", NC);
    for (KView<double>* v :
         {&packed.gap, &packed.nx, &packed.ny, &packed.rc, &packed.wn, &packed.wa, &packed.wb,
          &packed.wc, &packed.lower, &packed.pn, &packed.pt, &packed.pm, &packed.start_pn,
          &packed.start_pt, &packed.start_pm, &packed.dir_pn, &packed.dir_pt, &packed.dir_pm})
      own(*v, "packed", NC);
  }
  colour_start = alloc<int>("colour_start", 2);
  colour_fill = alloc<int>("colour_fill", 1);
}

namespace {
// What LoadSlot writes of a system's own values (SystemViews); the tolerance and the sweep cap
// as the batch resolved them.
SlotLoad slot_load_of(const SystemSetup& su, const GridShape& g, double tolerance, int max_sweeps) {
  const SystemParams& pr = su.params;
  SlotLoad v{};
  v.count = static_cast<int>(su.disks.size());
  v.width = pr.width;
  v.height = pr.height;
  v.radius = pr.radius;
  v.polydispersity = pr.polydispersity;
  v.disk_density = pr.disk_density;
  v.capture_radius = pr.capture_radius;
  v.gravity_x = pr.gravity_x();
  v.gravity_y = pr.gravity_y();
  v.cohesive_force = pr.cohesive_force();
  v.cohesion_range = pr.cohesion_range;
  v.friction = pr.friction;
  v.rolling_friction = pr.rolling_friction;
  v.time_step = pr.time_step;
  const double weight = pr.reference_mass() * pr.gravity;
  v.weight = weight > 0.0 ? weight : 1.0;
  v.tolerance = tolerance;
  v.max_sweeps = max_sweeps;
  v.floor_cohesion = pr.floor_cohesion ? 1 : 0;
  v.seed = su.seed;
  v.member = su.member;
  v.cell_size = g.cell;
  v.max_margin = g.max_margin;
  v.grid_nx = g.nx;
  v.grid_ny = g.ny;
  for (const auto& d : su.disks) v.max_speed = std::max(v.max_speed, loosepack::speed(d));
  return v;
}

// The system's disks as LoadSlot reads them, into h: field after field, `cap` values each, zeros
// past the system's disks.
void stage_disks(const SystemSetup& su, int cap, const DView<double>::HostMirror& h) {
  const SystemParams& pr = su.params;
  const int count = static_cast<int>(su.disks.size());
  const double width = pr.width;
  auto mass = [&](const Disk& d) { return pr.disk_density * M_PI * d.radius * d.radius; };
  auto put = [&](SlotDiskField field, auto f) {
    for (int a = 0; a < cap; ++a)
      h(field * cap + a) = a < count ? f(su.disks[static_cast<std::size_t>(a)]) : 0.0;
  };
  put(kLoadX, [&](const Disk& d) { return wrap_into_box(d.x, width); });
  put(kLoadY, [](const Disk& d) { return d.y; });
  put(kLoadTheta, [](const Disk& d) { return d.theta; });
  put(kLoadVx, [](const Disk& d) { return d.vx; });
  put(kLoadVy, [](const Disk& d) { return d.vy; });
  put(kLoadW, [](const Disk& d) { return d.w; });
  put(kLoadRadius, [](const Disk& d) { return d.radius; });
  put(kLoadInvMass, [&](const Disk& d) { return d.fixed ? 0.0 : 1.0 / mass(d); });
  put(kLoadInvInertia, [&](const Disk& d) {
    return (d.fixed || d.lock_rotation) ? 0.0 : 2.0 / (mass(d) * d.radius * d.radius);
  });
  put(kLoadYDeposit, [](const Disk& d) { return d.y_deposit; });
  put(kLoadYMark, [](const Disk& d) { return d.y; });
}
}  // namespace

// Puts one system into slot s: parameters, grid shape, disks; contacts and status cleared. The
// host gathers them into the staging views, which reach the device in two copies, and LoadSlot
// puts them in place.
void Batch::Impl::load(int s, const SystemSetup& su) {
  const auto k = static_cast<std::size_t>(s);
  const int count = static_cast<int>(su.disks.size());
  if (std::max(su.capacity, count) > slot_capacity[k])
    throw std::invalid_argument(
        "Batch: system needs " + std::to_string(std::max(su.capacity, count)) +
        " disk slots, the batch slot has " + std::to_string(slot_capacity[k]));
  const GridShape g = grid_shape(su);
  if (g.nx * g.ny > slot_cells[k])
    throw std::invalid_argument("Batch: system needs " + std::to_string(g.nx * g.ny) +
                                " grid cells, the batch slot has " + std::to_string(slot_cells[k]));
  for (const auto& d : su.disks)
    if (!(d.radius > 0.0)) throw std::invalid_argument("Batch: disk radius must be positive");
  params[k] = su.params;
  sweep_cap[k] = su.max_sweeps > 0 ? su.max_sweeps : solver.max_sweeps;
  newton_every[k] = su.newton_every >= 0 ? su.newton_every : solver.newton_every;

  const int first = offsets[k], cap = slot_capacity[k];
  const double tolerance = su.tolerance > 0.0 ? su.tolerance : solver.tolerance;
  load_host.system(0) = slot_load_of(su, g, tolerance, sweep_cap[k]);
  stage_disks(su, cap, load_host.disks);
  Kokkos::deep_copy(load_system, load_host.system);
  const auto used = std::make_pair(std::size_t{0}, static_cast<std::size_t>(kSlotDiskFields * cap));
  Kokkos::deep_copy(Kokkos::subview(load_disks, used), Kokkos::subview(load_host.disks, used));
  Kokkos::parallel_for("load_slot", Kokkos::RangePolicy<ExecSpace>(0, cap * kSlots),
                       LoadSlot{sys, part, con, load_system, load_disks, s, first, cap});

  status[k] = SystemStatus{};
  status[k].active = true;
  status[k].count = count;
  newton_steps[k] = 0;
  newton_pace[k] = NewtonPace{shortest_newton_wait(s)};
  newton_factor[k] = std::make_unique<KluFactor>();
}

// The flags last copied are in their host mirror: all of them are copied once where one of the
// host's differs (on a host backend the mirror is sys.active itself, and the copy a no-op).
void Batch::Impl::upload_changed_active() {
  const auto n = static_cast<std::size_t>(n_systems);
  for (std::size_t s = 0; s < n; ++s)
    if ((scheduler_host.active(s) != 0) != status[s].active)
      return fill_from(sys.active, scheduler_host.active, n,
                       [&](std::size_t t) { return status[t].active ? 1 : 0; });
}

void Batch::reset(int s, const SystemSetup& setup) {
  if (s < 0 || s >= size()) throw std::out_of_range("Batch::reset: no system " + std::to_string(s));
  impl_->load(s, setup);
}

void Batch::set_disks(int s, const std::vector<int>& index, const std::vector<Disk>& disks) {
  auto& I = *impl_;
  const auto k = static_cast<std::size_t>(s);
  const int count = I.status.at(k).count;
  if (index.size() != disks.size()) throw std::invalid_argument("Batch::set_disks: sizes differ");
  std::vector<char> given(static_cast<std::size_t>(count), 0);
  for (int a : index) {
    if (a < 0 || a >= count)
      throw std::out_of_range("Batch::set_disks: no disk " + std::to_string(a));
    if (given[static_cast<std::size_t>(a)]++)
      throw std::invalid_argument("Batch::set_disks: disk " + std::to_string(a) + " given twice");
  }
  const int n = static_cast<int>(index.size());
  const double width = I.params[k].width;
  const auto& h = I.slot_host;
  for (int j = 0; j < n; ++j) {
    const Disk& d = disks[static_cast<std::size_t>(j)];
    const auto put = [&](int field, double v) { h(slot_disk_at(n, field, j)) = v; };
    put(kLoadX, wrap_into_box(d.x, width));
    put(kLoadY, d.y);
    put(kLoadTheta, d.theta);
    put(kLoadVx, d.vx);
    put(kLoadVy, d.vy);
    put(kLoadW, d.w);
    put(kWrittenIndex, index[static_cast<std::size_t>(j)]);
  }
  I.write_slot(s, SlotPart::Disks, n);
}

namespace {
// Stages no contact in any of the count * kSlots contact slots of a write (slot_contact_at).
void stage_no_contacts(const DView<double>::HostMirror& h, int count) {
  for (int c = 0; c < count * kSlots; ++c) h(slot_contact_at(count, kSlotPartner, c)) = kNoContact;
}
}  // namespace

void Batch::set_contacts(int s, const std::vector<ContactForce>& contacts) {
  auto& I = *impl_;
  const auto k = static_cast<std::size_t>(s);
  const int count = I.status.at(k).count, first = I.offsets[k];
  for (const auto& c : contacts)
    if (c.i < 0 || c.i >= count || c.j >= count || (c.j >= 0 && c.j <= c.i))
      throw std::out_of_range("Batch::set_contacts: no contact " + std::to_string(c.i) + "-" +
                              std::to_string(c.j));
  const auto& h = I.slot_host;
  stage_no_contacts(h, count);
  std::vector<int> used(static_cast<std::size_t>(count), 0);
  const double step = I.params[k].time_step;
  for (const auto& c : contacts) {
    int& n = used[static_cast<std::size_t>(c.i)];
    if (n >= kSlots) continue;  // more than a disk can own: no warm start for the rest
    const int slot = c.i * kSlots + n++;
    const auto put = [&](int field, double v) { h(slot_contact_at(count, field, slot)) = v; };
    put(kSlotPartner, c.j < 0 ? kFloor : first + c.j);
    put(kSlotPn, step * c.normal);
    put(kSlotPt, step * c.tangential);
    put(kSlotPm, step * c.moment);
  }
  I.write_slot(s, SlotPart::Contacts);
}

namespace {
// The range of the staging layout that a read or write of `what` fills and copies: its disks
// (which end at disks_end), its contact slots, or all of it with the values.
std::pair<std::size_t, std::size_t> staged_part(SlotPart what, int count, int disks_end) {
  const int from = what == SlotPart::Contacts ? kSlotDiskFields * count : 0;
  const int to = what == SlotPart::Disks      ? disks_end
                 : what == SlotPart::Contacts ? slot_value_at(count, 0)
                                              : slot_span_at(count, kSpanFields, 0);
  return {static_cast<std::size_t>(from), static_cast<std::size_t>(to)};
}
}  // namespace

void Batch::Impl::write_slot(int s, SlotPart what, int n) {
  const auto k = static_cast<std::size_t>(s);
  const int count = status.at(k).count;
  const auto part_written = staged_part(what, count, slot_disk_at(n, kWrittenIndex + 1, 0));
  Kokkos::deep_copy(Kokkos::subview(slot_staging, part_written),
                    Kokkos::subview(slot_host, part_written));
  Kokkos::parallel_for(
      "write_slot", Kokkos::TeamPolicy<ExecSpace>(1, Kokkos::AUTO),
      WriteSlot{sys, part, con, slot_staging, s, offsets[k], count, slot_capacity[k], n, what});
}

DView<double>::HostMirror Batch::Impl::read_slot(int s, SlotPart what) {
  const auto k = static_cast<std::size_t>(s);
  const int count = status.at(k).count;
  const int range = what == SlotPart::Disks      ? count
                    : what == SlotPart::Contacts ? count * kSlots
                                                 : std::max(1, count * kSlots);
  Kokkos::parallel_for("read_slot", Kokkos::RangePolicy<ExecSpace>(0, range),
                       ReadSlot{sys, part, con, slot_staging, s, offsets[k], count, what});
  const auto part_read = staged_part(what, count, slot_disk_at(count, kSlotDiskFields, 0));
  Kokkos::deep_copy(Kokkos::subview(slot_host, part_read),
                    Kokkos::subview(slot_staging, part_read));
  return slot_host;
}

namespace {

// The disks of a slot read back (Batch::Impl::read_slot).
std::vector<Disk> disks_read(const DView<double>::HostMirror& h, int count) {
  std::vector<Disk> out(static_cast<std::size_t>(count));
  for (int a = 0; a < count; ++a) {
    auto v = [&](int field) { return h(slot_disk_at(count, field, a)); };
    Disk& d = out[static_cast<std::size_t>(a)];
    d.x = v(kLoadX);
    d.y = v(kLoadY);
    d.theta = v(kLoadTheta);
    d.vx = v(kLoadVx);
    d.vy = v(kLoadVy);
    d.w = v(kLoadW);
    d.radius = v(kLoadRadius);
    d.fixed = v(kLoadInvMass) == 0.0;
    d.lock_rotation = !d.fixed && v(kLoadInvInertia) == 0.0;
    d.y_deposit = v(kLoadYDeposit);
  }
  return out;
}

// Field `field` (SlotContactField) of contact slot c of a slot of `count` disks read back with
// its contacts.
double contact_read(const DView<double>::HostMirror& h, int count, int field, int c) {
  return h(slot_contact_at(count, field, c));
}

// The partner of contact slot c as the system numbers its disks: -1 for the floor, kNoContact
// for an empty slot.
int partner_read(const DView<double>::HostMirror& h, int count, int first, int c) {
  const int p = static_cast<int>(contact_read(h, count, kSlotPartner, c));
  return p == kNoContact ? kNoContact : p == kFloor ? -1 : p - first;
}

}  // namespace

std::vector<Disk> Batch::disks(int s) const {
  const int count = impl_->status.at(static_cast<std::size_t>(s)).count;
  return disks_read(impl_->read_slot(s, SlotPart::Disks), count);
}

std::vector<ContactForce> Batch::contacts(int s) const {
  auto& I = *impl_;
  const auto k = static_cast<std::size_t>(s);
  const int count = I.status.at(k).count, first = I.offsets[k];
  const auto h = I.read_slot(s, SlotPart::Contacts);
  const double step = I.params[k].time_step;
  std::vector<ContactForce> out;
  for (int c = 0; c < count * kSlots; ++c) {
    const int j = partner_read(h, count, first, c);
    if (j == kNoContact) continue;
    auto v = [&](int field) { return contact_read(h, count, field, c); };
    ContactForce f;
    f.i = c / kSlots;
    f.j = j;
    f.nx = v(kSlotNx);
    f.ny = v(kSlotNy);
    f.gap = v(kSlotGap);
    f.normal = v(kSlotPn) / step;
    f.tangential = v(kSlotPt) / step;
    f.moment = v(kSlotPm) / step;
    out.push_back(f);
  }
  return out;
}

Batch::SystemState Batch::state(int s) const {
  auto& I = *impl_;
  const auto k = static_cast<std::size_t>(s);
  SystemState out;
  out.status = I.status.at(k);
  const int first = I.offsets[k], count = out.status.count;
  const auto h = I.read_slot(s, SlotPart::State);
  out.disks = disks_read(h, count);
  for (auto [to, field] :
       {std::make_pair(&out.y_mark, kLoadYMark), std::make_pair(&out.inv_mass, kLoadInvMass),
        std::make_pair(&out.inv_inertia, kLoadInvInertia)})
    to->assign(h.data() + slot_disk_at(count, field, 0),
               h.data() + slot_disk_at(count, field + 1, 0));
  for (int c = 0; c < count * kSlots; ++c) {
    const int j = partner_read(h, count, first, c);
    if (j == kNoContact) continue;
    auto v = [&](int field) { return contact_read(h, count, field, c); };
    out.slot.push_back(c);
    out.partner.push_back(j);
    out.pn.push_back(v(kSlotPn));
    out.pt.push_back(v(kSlotPt));
    out.pm.push_back(v(kSlotPm));
    out.nx.push_back(v(kSlotNx));
    out.ny.push_back(v(kSlotNy));
    out.gap.push_back(v(kSlotGap));
  }
  const auto value = [&](SlotValue v) { return h(slot_value_at(count, v)); };
  out.draws = (static_cast<std::uint64_t>(value(kSlotDrawsHigh)) << 32) |
              static_cast<std::uint64_t>(value(kSlotDrawsLow));
  out.speed = value(kSlotMaxSpeed);
  out.centre_speed = value(kSlotCentreSpeed);
  out.span_steps = static_cast<int>(value(kSlotSpanSteps));
  out.span_step = static_cast<int>(value(kSlotSpanStep));
  out.spans = static_cast<int>(value(kSlotSpans));
  out.span_change = value(kSlotSpanChange);
  out.status.mean_speed = value(kSlotMeanSpeed);
  for (int a = 0; a < count; ++a)
    for (int field = 0; field < kSpanFields; ++field)
      out.span.push_back(h(slot_span_at(count, field, a)));
  out.gravity_on = I.params[k].gravity_on;
  out.status.newton_steps = I.newton_steps[k];
  out.pace = solver_pace(s);
  return out;
}

void Batch::restore(int s, const SystemState& state) {
  auto& I = *impl_;
  const auto k = static_cast<std::size_t>(s);
  const int count = I.status.at(k).count;
  const std::size_t n = state.slot.size();
  const auto disks = state.disks.size();
  bool fits =
      static_cast<int>(disks) == count && state.status.count == count && state.partner.size() == n;
  for (const auto* v : {&state.y_mark, &state.inv_mass, &state.inv_inertia})
    fits = fits && v->size() == disks;
  for (const auto* v : {&state.pn, &state.pt, &state.pm, &state.nx, &state.ny, &state.gap})
    fits = fits && v->size() == n;
  fits = fits && state.span.size() == disks * kSpanFields;
  if (!fits)
    throw std::invalid_argument("Batch::restore: the state does not fit system " +
                                std::to_string(s) + " (reset it with the state's disks first)");
  for (std::size_t c = 0; c < n; ++c) {
    const int slot = state.slot[c], j = state.partner[c];
    if (slot < 0 || slot >= count * kSlots || j < -1 || j >= count)
      throw std::invalid_argument("Batch::restore: contact slot " + std::to_string(slot) +
                                  " with partner " + std::to_string(j) + " is not in system " +
                                  std::to_string(s));
  }
  const int first = I.offsets[k];
  const auto& h = I.slot_host;
  // reset() wraps x into the box, which may round it, and computes the masses on the host
  // (deposited disks got theirs on the device).
  for (int a = 0; a < count; ++a) {
    const auto d = static_cast<std::size_t>(a);
    h(slot_disk_at(count, kLoadX, a)) = state.disks[d].x;
    h(slot_disk_at(count, kLoadYMark, a)) = state.y_mark[d];
    h(slot_disk_at(count, kLoadInvMass, a)) = state.inv_mass[d];
    h(slot_disk_at(count, kLoadInvInertia, a)) = state.inv_inertia[d];
    for (int field = 0; field < kSpanFields; ++field)
      h(slot_span_at(count, field, a)) =
          state.span[d * kSpanFields + static_cast<std::size_t>(field)];
  }
  // The impulses go where the next step's warm start reads them (as set_contacts).
  stage_no_contacts(h, count);
  for (std::size_t c = 0; c < n; ++c) {
    const auto put = [&](int field, double v) {
      h(slot_contact_at(count, field, state.slot[c])) = v;
    };
    put(kSlotPartner, state.partner[c] < 0 ? kFloor : first + state.partner[c]);
    put(kSlotPn, state.pn[c]);
    put(kSlotPt, state.pt[c]);
    put(kSlotPm, state.pm[c]);
    put(kSlotNx, state.nx[c]);
    put(kSlotNy, state.ny[c]);
    put(kSlotGap, state.gap[c]);
  }
  I.params[k].gravity_on = state.gravity_on;
  const auto value = [&](SlotValue v, double x) { h(slot_value_at(count, v)) = x; };
  value(kSlotDrawsHigh, static_cast<double>(state.draws >> 32));
  value(kSlotDrawsLow, static_cast<double>(state.draws & 0xffffffffu));
  value(kSlotMaxSpeed, state.speed);
  value(kSlotCentreSpeed, state.centre_speed);
  value(kSlotGravityX, I.params[k].gravity_x());
  value(kSlotGravityY, I.params[k].gravity_y());
  value(kSlotSpanSteps, state.span_steps);
  value(kSlotSpanStep, state.span_step);
  value(kSlotSpans, state.spans);
  value(kSlotSpanChange, state.span_change);
  value(kSlotMeanSpeed, state.status.mean_speed);
  I.write_slot(s, SlotPart::State);
  I.status[k] = state.status;
  I.newton_steps[k] = state.status.newton_steps;
  set_solver_pace(s, state.pace);
}

double Batch::max_overlap(int s) const { return loosepack::max_overlap(disks(s), params(s).width); }

double max_overlap(const std::vector<Disk>& d, double width) {
  double worst = 0.0;
  // Bucket by column of width >= the largest diameter; compare within neighbouring columns.
  double rmax = 0.0;
  for (const auto& a : d) rmax = std::max(rmax, a.radius);
  const int ncol = std::max(1, static_cast<int>(width / (2.0 * rmax + 1e-12)));
  std::vector<std::vector<int>> col(static_cast<std::size_t>(ncol));
  for (std::size_t k = 0; k < d.size(); ++k) {
    worst = std::max(worst, d[k].radius - d[k].y);
    int c = std::min(ncol - 1, static_cast<int>(d[k].x / width * ncol));
    col[static_cast<std::size_t>(c)].push_back(static_cast<int>(k));
  }
  for (int c = 0; c < ncol; ++c) {
    for (int a : col[static_cast<std::size_t>(c)]) {
      const int span = ncol < 3 ? ncol : 3;
      for (int e = 0; e < span; ++e) {
        const int cc = ncol < 3 ? e : (c - 1 + e + ncol) % ncol;
        for (int b : col[static_cast<std::size_t>(cc)]) {
          if (b <= a) continue;
          const auto& p = d[static_cast<std::size_t>(a)];
          const auto& q = d[static_cast<std::size_t>(b)];
          const double dx = periodic_delta(q.x - p.x, width);
          const double dy = q.y - p.y;
          const double ov = p.radius + q.radius - std::sqrt(dx * dx + dy * dy);
          worst = std::max(worst, ov);
        }
      }
    }
  }
  return worst;
}

}  // namespace loosepack
