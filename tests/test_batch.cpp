// The batch's time step as a pipeline: its stages in order (and documented so), and the
// specialised kernels chosen from the systems active now.
#include <gtest/gtest.h>

#include <Kokkos_Core.hpp>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "kernels/solver.hpp"
#include "loosepack/batch.hpp"
#include "loosepack/scenes.hpp"
#include "src/launch_count.hpp"

using namespace loosepack;
using namespace loosepack::scenes;

namespace {
std::vector<std::string> stage_names() {
  std::vector<std::string> names;
  for (int k = 0; k < kStepStages; ++k) names.emplace_back(stage_name(static_cast<StepStage>(k)));
  return names;
}

// A cohesive pile with friction and rolling friction: every effect on.
SystemParams cohesive_params() {
  SystemParams p = column_params(6);
  p.bond_number = 10.0;
  p.cohesion_range = 0.01;
  return p;
}
}  // namespace

// Timing lists every stage once, in the enum's order, with the Newton rounds right after the
// solve they belong to.
TEST(Batch, StepStagesAreTimedInOrder) {
  Batch batch({setup(cohesive_params(), column(6, 10.0))});
  batch.set_timing(true);
  for (int k = 0; k < 5; ++k) batch.step();
  std::vector<std::string> timed;
  for (const auto& cost : batch.stage_costs()) {
    EXPECT_GE(cost.seconds, 0.0) << cost.name;
    EXPECT_EQ(cost.steps, 5) << cost.name;
    if (cost.name != "newton") timed.push_back(cost.name);
  }
  EXPECT_EQ(timed, stage_names());
}

// The solve's balance: the active systems, their disks, their sweeps, the sweeps had each swept
// as long as its step's slowest, and the slowest's, summed over the steps from the systems' own
// status after each step.
TEST(Batch, SolveBalanceSumsEachStepsSweepsAndItsSlowest) {
  auto falling = column(4, 10.0);  // disks apart: they land on one another at different steps
  for (std::size_t k = 0; k < falling.size(); ++k) falling[k].y += 0.05 * static_cast<double>(k);
  Batch batch({setup(cohesive_params(), column(6, 10.0)), setup(cohesive_params(), falling)});
  batch.set_timing(true);
  long system_steps = 0, disk_steps = 0, sweeps = 0, slowest_sweeps = 0, launch_sweeps = 0;
  bool unequal = false;
  for (int k = 0; k < 40; ++k) {
    batch.step();
    long active = 0, sum = 0, slowest = 0;
    for (int s = 0; s < batch.size(); ++s) {
      if (!batch.status(s).active) continue;
      ++active;
      disk_steps += batch.status(s).count;
      sum += batch.status(s).last_sweeps;
      slowest = std::max<long>(slowest, batch.status(s).last_sweeps);
    }
    unequal = unequal || active * slowest > sum;
    system_steps += active;
    sweeps += sum;
    slowest_sweeps += active * slowest;
    launch_sweeps += slowest;
  }
  ASSERT_TRUE(unequal) << "the two columns swept alike at every step: the scene tests nothing";
  for (const auto& cost : batch.stage_costs())
    if (cost.name == "solve") {
      EXPECT_EQ(cost.system_steps, system_steps);
      EXPECT_EQ(cost.disk_steps, disk_steps);
      EXPECT_EQ(cost.disk_steps, 10 * cost.system_steps / 2);  // 6 and 4 disks, both active
      EXPECT_EQ(cost.sweeps, sweeps);
      EXPECT_EQ(cost.slowest_sweeps, slowest_sweeps);
      EXPECT_EQ(cost.launch_sweeps, launch_sweeps);
      EXPECT_EQ(cost.finished_steps, cost.system_steps);  // one launch a step
      EXPECT_LT(cost.sweeps, cost.slowest_sweeps);
      return;
    }
  FAIL() << "no solve stage";
}

namespace {
// Three systems that need unequal sweeps a step: a cohesive column, and random drops with
// cohesion and without.
std::vector<SystemSetup> unequal_systems() {
  SystemParams dry = column_params(10);
  dry.width = 12.0;
  SystemParams wet = dry;
  wet.bond_number = 10.0;
  wet.cohesion_range = 0.01;
  return {setup(cohesive_params(), column(6, 10.0)), setup(wet, random_drop(24, 12.0, 1)),
          setup(dry, random_drop(20, 12.0, 2))};
}

void expect_same_disks(const std::vector<Disk>& a, const std::vector<Disk>& b, int s) {
  ASSERT_EQ(a.size(), b.size()) << "system " << s;
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].x, b[k].x) << "system " << s << " disk " << k;
    EXPECT_EQ(a[k].y, b[k].y) << "system " << s << " disk " << k;
    EXPECT_EQ(a[k].theta, b[k].theta) << "system " << s << " disk " << k;
    EXPECT_EQ(a[k].vx, b[k].vx) << "system " << s << " disk " << k;
    EXPECT_EQ(a[k].vy, b[k].vy) << "system " << s << " disk " << k;
    EXPECT_EQ(a[k].w, b[k].w) << "system " << s << " disk " << k;
  }
}

// Runs `f` (a read or write of one system, with the batch's timing on) and expects one kernel
// launch and one copy of it.
template <class F>
void once(const F& f) {
  const LaunchCounts before = launch_counts();
  f();
  const LaunchCounts after = launch_counts();
  EXPECT_EQ(after.launches - before.launches, 1);
  EXPECT_EQ(after.copies - before.copies, 1);
}
// Steps `batch` until system s has finished target[s] steps: a system that has them sits out
// the calls after (once its step has ended), one that has fewer takes part again. Returns the
// calls that left a system inside its step (its solve going on in the next launch).
long step_to(Batch& batch, const std::vector<long>& target) {
  long paused = 0;
  for (int calls = 0; calls < 100000; ++calls) {
    bool any = false;
    for (int s = 0; s < batch.size(); ++s) {
      const auto& st = batch.status(s);
      const bool wanted = st.mid_step || st.steps < target[static_cast<std::size_t>(s)];
      if (st.active != wanted && !st.mid_step && st.failure == Failure::None)
        batch.set_active(s, wanted);
      any = any || batch.status(s).active;
    }
    if (!any) return paused;
    batch.step();
    for (int s = 0; s < batch.size(); ++s) paused += batch.status(s).mid_step ? 1 : 0;
  }
  ADD_FAILURE() << "the systems did not reach their steps";
  return paused;
}
}  // namespace

// solver.sweeps_per_launch splits a step's solve over launches: a system that needs more
// sweeps goes on in the next step() while the others take their next steps. Its iterates are
// those of one launch, so after the same number of finished steps every system's disks and
// sweeps are the same bit for bit as with whole solves.
// Teams of the backend's size and of two threads (one on Serial).
class SweepsPerLaunch : public testing::TestWithParam<int> {};

TEST_P(SweepsPerLaunch, GiveTheSameStepsBitForBit) {
  SolverSettings whole;
  whole.kind = SolverKind::ColouredAcceleratedGaussSeidel;
  whole.team_size = GetParam();
  SolverSettings split = whole;
  split.sweeps_per_launch = 4;
  constexpr long kSteps = 60;
  Batch lockstep(unequal_systems(), whole), ticking(unequal_systems(), split);
  ticking.set_timing(true);
  for (long k = 0; k < kSteps; ++k) lockstep.step();
  const long paused = step_to(ticking, std::vector<long>(3, kSteps));
  ASSERT_GT(paused, 0) << "no solve needed more than 4 sweeps: the scene tests nothing";
  for (int s = 0; s < ticking.size(); ++s) {
    EXPECT_EQ(ticking.status(s).steps, kSteps) << "system " << s;
    EXPECT_EQ(ticking.status(s).sweeps, lockstep.status(s).sweeps) << "system " << s;
    EXPECT_EQ(ticking.status(s).failure, Failure::None) << "system " << s;
    expect_same_disks(ticking.disks(s), lockstep.disks(s), s);
  }
  // The balance counts launches: every system in a launch sweeps at most 4 times in it.
  int solves = 0;
  for (const auto& cost : ticking.stage_costs())
    if (cost.name == "solve") {
      ++solves;
      EXPECT_EQ(cost.finished_steps, kSteps * ticking.size());
      EXPECT_GT(cost.system_steps, cost.finished_steps);
      EXPECT_LE(cost.slowest_sweeps, 4 * cost.system_steps);
      EXPECT_LE(cost.launch_sweeps, 4 * cost.steps);
    }
  EXPECT_EQ(solves, 1) << "the stage costs hold no solve stage";
}

INSTANTIATE_TEST_SUITE_P(Batch, SweepsPerLaunch, testing::Values(0, 2));

// A system inside a step cannot be taken out of the batch: the step ends first.
TEST(Batch, SystemInsideAStepStaysActive) {
  SolverSettings split;
  split.kind = SolverKind::ColouredAcceleratedGaussSeidel;
  split.sweeps_per_launch = 2;
  Batch batch(unequal_systems(), split);
  for (int k = 0; k < 200; ++k) {
    batch.step();
    for (int s = 0; s < batch.size(); ++s)
      if (batch.status(s).mid_step) {
        EXPECT_THROW(batch.set_active(s, false), std::logic_error);
        EXPECT_TRUE(batch.status(s).active);
        return;
      }
  }
  FAIL() << "no solve went on over launches";
}

// solver.fused_step runs every stage of a system's step in its own team, one launch a step: the
// same stages over the same disks, so after the same steps every system's disks, contacts,
// sweeps and status are the same bit for bit as the staged step's. With each solver a team can
// run, a solve split over launches, the accelerated solver's Newton rounds (a system due for
// one stays inside its step for it), the overlap correction, and a system that sits out steps
// while the others go on.
struct FusedCase {
  const char* name;
  SolverKind kind;
  int sweeps_per_launch, newton_every;
  double overlap_correction;
};
void PrintTo(const FusedCase& c, std::ostream* os) { *os << c.name; }
class FusedStep : public testing::TestWithParam<FusedCase> {};

TEST_P(FusedStep, GivesTheSameStepsBitForBit) {
  SolverSettings staged;
  staged.kind = GetParam().kind;
  staged.newton_every = GetParam().newton_every;
  staged.sweeps_per_launch = GetParam().sweeps_per_launch;
  staged.overlap_correction = GetParam().overlap_correction;
  SolverSettings fused = staged;
  fused.fused_step = true;
  Batch a(unequal_systems(), staged), b(unequal_systems(), fused);
  long paused = 0;
  const std::vector<std::vector<long>> targets = {{20, 20, 20}, {40, 40, 20}, {60, 60, 60}};
  for (const auto& target : targets) {
    step_to(a, target);
    paused += step_to(b, target);
  }
  if (GetParam().sweeps_per_launch > 0 || GetParam().newton_every > 0) {
    EXPECT_GT(paused, 0) << "no solve went on over launches: the case tests nothing";
  }
  long newton = 0;
  for (int s = 0; s < a.size(); ++s) {
    const auto &sa = a.status(s), &sb = b.status(s);
    EXPECT_EQ(sa.steps, 60) << "system " << s;
    EXPECT_EQ(sb.steps, 60) << "system " << s;
    EXPECT_EQ(sa.failure, Failure::None) << "system " << s;
    EXPECT_EQ(sa.sweeps, sb.sweeps) << "system " << s;
    EXPECT_EQ(sa.newton_steps, sb.newton_steps) << "system " << s;
    EXPECT_EQ(sa.max_speed, sb.max_speed) << "system " << s;
    EXPECT_EQ(sa.converged, sb.converged) << "system " << s;
    EXPECT_EQ(sa.rest_steps, sb.rest_steps) << "system " << s;
    newton += sb.newton_steps;
    expect_same_disks(a.disks(s), b.disks(s), s);
    const auto ca = a.contacts(s), cb = b.contacts(s);
    ASSERT_EQ(ca.size(), cb.size()) << "system " << s;
    for (std::size_t c = 0; c < ca.size(); ++c) {
      EXPECT_EQ(ca[c].i, cb[c].i) << "system " << s << " contact " << c;
      EXPECT_EQ(ca[c].j, cb[c].j) << "system " << s << " contact " << c;
      EXPECT_EQ(ca[c].normal, cb[c].normal) << "system " << s << " contact " << c;
      EXPECT_EQ(ca[c].tangential, cb[c].tangential) << "system " << s << " contact " << c;
    }
  }
  if (GetParam().newton_every > 0) {
    EXPECT_GT(newton, 0) << "no Newton step: the case tests nothing";
  }
}

INSTANTIATE_TEST_SUITE_P(
    Batch, FusedStep,
    testing::Values(FusedCase{"team", SolverKind::ColouredAcceleratedGaussSeidel, 0, 0, 0.0},
                    FusedCase{"team_split", SolverKind::ColouredAcceleratedGaussSeidel, 4, 0, 0.0},
                    FusedCase{"accelerated", SolverKind::AcceleratedGaussSeidel, 0, 0, 0.0},
                    FusedCase{"accelerated_newton", SolverKind::AcceleratedGaussSeidel, 0, 1, 0.0},
                    FusedCase{"sequential_overlap", SolverKind::SequentialGaussSeidel, 0, 0, 0.2}),
    [](const testing::TestParamInfo<FusedCase>& info) { return std::string(info.param.name); });

// SystemSetup::newton_every gives each system its own Newton rounds: in a batch where one
// cohesive column takes rounds and a copy of it none (nor the random drops), each system steps
// bit for bit as in a batch whose solver settings give every system its rounds (or none), staged
// and fused.
TEST(Batch, NewtonRoundsAreEachSystemsOwn) {
  auto systems = unequal_systems();
  systems.push_back(systems.front());  // the column again
  const std::vector<long> steps(systems.size(), 60);
  for (const bool fused : {false, true}) {
    SCOPED_TRACE(fused ? "fused step" : "staged step");
    SolverSettings off, on;
    off.kind = on.kind = SolverKind::AcceleratedGaussSeidel;
    off.fused_step = on.fused_step = fused;
    off.newton_every = 0;
    on.newton_every = 1;
    auto mixed = systems;
    for (std::size_t s = 0; s < mixed.size(); ++s) mixed[s].newton_every = s == 0 ? 1 : 0;
    Batch each(mixed, off), all_on(systems, on), all_off(systems, off);
    for (Batch* b : {&each, &all_on, &all_off}) step_to(*b, steps);
    EXPECT_EQ(each.newton_every(0), 1);
    EXPECT_EQ(each.newton_every(3), 0);
    EXPECT_GT(each.status(0).newton_steps, 0) << "no Newton step: the case tests nothing";
    EXPECT_GT(all_on.status(3).newton_steps, 0) << "the copy would take no rounds either";
    for (int s = 0; s < each.size(); ++s) {
      const Batch& alone = s == 0 ? all_on : all_off;
      EXPECT_EQ(each.status(s).steps, 60) << "system " << s;
      EXPECT_EQ(each.status(s).sweeps, alone.status(s).sweeps) << "system " << s;
      EXPECT_EQ(each.status(s).newton_steps, alone.status(s).newton_steps) << "system " << s;
      expect_same_disks(each.disks(s), alone.disks(s), s);
    }
  }
}

// A fused step is one launch and one copy (the status read back), and timing shows it as one
// row beside the status's.
TEST(Batch, AFusedStepIsOneLaunchAndOneCopy) {
  SolverSettings fused;
  fused.kind = SolverKind::ColouredAcceleratedGaussSeidel;
  fused.fused_step = true;
  Batch batch(unequal_systems(), fused);
  batch.set_timing(true);
  batch.step();  // the first step copies the active flags
  once([&] { batch.step(); });
  std::vector<std::string> rows;
  for (const auto& cost : batch.stage_costs()) {
    rows.push_back(cost.name);
    EXPECT_EQ(cost.steps, 2) << cost.name;
  }
  EXPECT_EQ(rows, (std::vector<std::string>{"system_step", "status"}));
  EXPECT_EQ(batch.stage_costs().front().launches, 2);
  EXPECT_EQ(batch.stage_costs().front().finished_steps, 2 * batch.size());
}

// The solvers that sweep the whole batch at once have no fused step.
TEST(Batch, AFusedStepNeedsASolverOfTheSystemsOwnTeam) {
  for (SolverKind kind : {SolverKind::Jacobi, SolverKind::GaussSeidel}) {
    SolverSettings fused;
    fused.kind = kind;
    fused.fused_step = true;
    EXPECT_THROW(Batch(unequal_systems(), fused), std::invalid_argument) << solver_kind_name(kind);
  }
}

// solver.team_size asks for threads per system's team; more than the backend's largest team
// (1 on Serial, the threads on OpenMP) are lowered to it instead of failing the launch.
TEST(Batch, TeamSizeIsLoweredToTheBackendsLargestTeam) {
  SolverSettings solver;
  solver.kind = SolverKind::ColouredAcceleratedGaussSeidel;
  solver.team_size = 1024;
  Batch batch({setup(cohesive_params(), column(6, 10.0))}, solver);
  batch.set_timing(true);
  for (int k = 0; k < 3; ++k) batch.step();
  const bool host =
      Kokkos::SpaceAccessibility<Kokkos::HostSpace,
                                 Kokkos::DefaultExecutionSpace::memory_space>::accessible;
  for (const auto& cost : batch.stage_costs())
    if (cost.name == "solve") {
      // A host team is at most the backend's threads; a device's, what the policy allows for
      // the solver's kernel (its registers and the effects the batch has: all three here).
      const int largest = host ? Kokkos::DefaultExecutionSpace().concurrency()
                               : Kokkos::TeamPolicy<ExecSpace>(1, 1).team_size_max(
                                     ColouredAcceleratedGaussSeidel<Effects<true, true, true>>{},
                                     Kokkos::ParallelForTag());
      EXPECT_EQ(cost.team_size, std::min(1024, largest));
      EXPECT_EQ(batch.status(0).failure, Failure::None);
      return;
    }
  FAIL() << "no solve stage";
}

// The team solver colours and solves each system inside its team: its solve stage is one
// launch of the team kernel every step, however many colours the contacts need, with no copy
// and no round trip per colour (the margin stage resets the sweep counters).
TEST(Batch, TeamSolverSolvesInOneLaunchPerStep) {
  SolverSettings solver;
  solver.kind = SolverKind::ColouredAcceleratedGaussSeidel;
  Batch batch({setup(cohesive_params(), column(6, 10.0))}, solver);
  batch.set_timing(true);
  for (int k = 0; k < 5; ++k) batch.step();
  for (const auto& cost : batch.stage_costs())
    if (cost.name == "solve") {
      EXPECT_EQ(cost.launches, cost.steps);
      EXPECT_EQ(cost.copies, 0);
      return;
    }
  FAIL() << "no solve stage";
}

// docs/MODEL.md, "Time step", lists the stages by name in the order they run: its numbered
// items' first `name` are exactly the enum's names.
TEST(Batch, StepStagesAreDocumentedInOrder) {
  std::ifstream in(std::string(LOOSEPACK_SOURCE_DIR) + "/docs/MODEL.md");
  ASSERT_TRUE(in) << "docs/MODEL.md not found";
  std::stringstream text;
  text << in.rdbuf();
  const std::string doc = text.str();
  const auto from = doc.find("## Time step");
  ASSERT_NE(from, std::string::npos) << "docs/MODEL.md has no section \"Time step\"";
  const auto to = doc.find("\n## ", from + 1);
  const std::string section = doc.substr(from, to - from);
  const std::regex item(R"(\n(\d+)\. `([a-z_]+)`)");
  std::vector<std::string> listed;
  int number = 0;
  for (auto it = std::sregex_iterator(section.begin(), section.end(), item);
       it != std::sregex_iterator(); ++it) {
    EXPECT_EQ(std::stoi((*it)[1]), ++number) << "items numbered in order";
    listed.push_back((*it)[2]);
  }
  EXPECT_EQ(listed, stage_names());
}

// The solve is specialised on the effects of the systems active now: a cohesive member that
// stops (or leaves its slot) no longer holds the rest of the batch on the general kernel. And
// the kernels only skip terms that are exactly zero for the systems without the effect, so a
// frictionless column steps bit for bit the same beside a cohesive rolling pile as alone.
TEST(Batch, KernelFollowsTheActiveSystems) {
  const SystemParams bare = bare_params();
  Batch both({setup(cohesive_params(), column(6, 10.0)), setup(bare, column(4, 5.0))});
  Batch alone({setup(bare, column(4, 5.0))});
  auto effects = both.kernel_effects();
  EXPECT_TRUE(effects.cohesion && effects.friction && effects.rolling);
  effects = alone.kernel_effects();
  EXPECT_FALSE(effects.cohesion || effects.friction || effects.rolling);
  for (int k = 0; k < 30; ++k) {
    both.step();
    alone.step();
  }
  const auto a = both.disks(1), b = alone.disks(0);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].x, b[k].x);
    EXPECT_EQ(a[k].y, b[k].y);
    EXPECT_EQ(a[k].vy, b[k].vy);
  }
  both.set_active(0, false);
  effects = both.kernel_effects();
  EXPECT_FALSE(effects.cohesion || effects.friction || effects.rolling);
  both.set_active(0, true);
  EXPECT_TRUE(both.kernel_effects().cohesion);
  SystemParams next = cohesive_params();  // the next member: the same box, no effect on
  next.bond_number = next.friction = next.rolling_friction = 0.0;
  both.reset(0, setup(next, column(6, 10.0)));
  effects = both.kernel_effects();
  EXPECT_FALSE(effects.cohesion || effects.friction || effects.rolling);
}

// Reading a system back is one kernel and one copy (on a device, one transfer and one wait),
// whatever it holds: its disks, its contacts, its whole state. The state gives what the other
// reads give, and its random draws beyond 32 bits survive the trip (a state restored with them
// reads them back).
TEST(Batch, ASystemReadsBackInOneCopy) {
  std::vector<SystemSetup> setups = unequal_systems();
  Batch batch(setups);
  for (int k = 0; k < 500; ++k) batch.step();  // the drops have landed
  batch.set_timing(true);                      // counts launches and copies (src/launch_count.hpp)
  for (int s = 0; s < batch.size(); ++s) {
    std::vector<Disk> disks;
    std::vector<ContactForce> contacts;
    Batch::SystemState state;
    once([&] { disks = batch.disks(s); });
    once([&] { contacts = batch.contacts(s); });
    once([&] { state = batch.state(s); });
    ASSERT_FALSE(contacts.empty()) << "system " << s;
    expect_same_disks(state.disks, disks, s);
    ASSERT_EQ(state.partner.size(), contacts.size()) << "system " << s;
    const double h = batch.params(s).time_step;
    for (std::size_t c = 0; c < contacts.size(); ++c) {
      EXPECT_EQ(state.slot[c] / kSlots, contacts[c].i);
      EXPECT_EQ(state.partner[c], contacts[c].j);
      EXPECT_EQ(state.pn[c] / h, contacts[c].normal);
      EXPECT_EQ(state.gap[c], contacts[c].gap);
    }
    EXPECT_EQ(state.speed, batch.status(s).max_speed) << "system " << s;
  }
  Batch::SystemState far = batch.state(1);
  far.draws = (std::uint64_t{1} << 40) + 12345;
  SystemSetup su = setups[1];
  su.disks = far.disks;
  batch.reset(1, su);
  batch.restore(1, far);
  EXPECT_EQ(batch.state(1).draws, far.draws);
}

// A system's disks load into the periodic box as given where they lie within it, to the bit (x =
// 0.1 in a box 200 R wide: fmod(fmod(x, L) + L, L) gives 0.1 - 5.7e-15), and shifted by whole
// periods where they lie outside it.
TEST(Batch, DisksLoadIntoTheBoxWithoutRounding) {
  SystemParams p = bare_params(200.0, 20.0);
  p.gravity_on = false;
  std::vector<Disk> d(3);
  d[0].x = 0.1;
  d[1].x = -0.25;  // 199.75
  d[2].x = 210.5;  // 10.5
  for (std::size_t k = 0; k < 3; ++k) d[k].y = 5.0 + 3.0 * static_cast<double>(k);
  Batch batch({setup(p, d)});
  const auto loaded = batch.disks(0);
  EXPECT_EQ(loaded[0].x, 0.1);
  EXPECT_EQ(loaded[1].x, 200.0 - 0.25);
  EXPECT_EQ(loaded[2].x, 10.5);
}

// Writing a system is one kernel and one copy too (on a device, one transfer and no wait), and a
// write that names a disk twice, a disk or a contact slot that is not there changes nothing.
// Disks by index: the values read back as written (x wrapped into the box), and the fastest disk
// as written for the next step's margin.
TEST(Batch, DisksAreWrittenInOneCopy) {
  Batch batch(unequal_systems());
  for (int k = 0; k < 500; ++k) batch.step();
  batch.set_timing(true);
  const int s = 1;
  const double width = batch.params(s).width;
  std::vector<Disk> expect = batch.disks(s);
  const int last = static_cast<int>(expect.size()) - 1;
  std::vector<Disk> written{expect[static_cast<std::size_t>(last)], expect[0]};
  written[0].x += width + 0.25;  // wraps into the box
  written[0].vx = 2.0;
  written[1].y += 0.125;
  written[1].w = 0.5;
  EXPECT_THROW(batch.set_disks(s, {0, 0}, {written[1], written[1]}), std::invalid_argument);
  EXPECT_THROW(batch.set_disks(s, {last + 1}, {written[0]}), std::out_of_range);
  expect_same_disks(batch.disks(s), expect, s);
  once([&] { batch.set_disks(s, {last, 0}, written); });
  expect[static_cast<std::size_t>(last)] = written[0];
  expect[0] = written[1];
  // Wrapped into [0, width) by a whole period where outside it (x - L_x is exact for x in
  // [L_x, 2 L_x)), an x within kept exactly.
  double& moved = expect[static_cast<std::size_t>(last)].x;
  ASSERT_TRUE(moved >= width && moved < 2.0 * width);
  moved -= width;
  expect_same_disks(batch.disks(s), expect, s);
  double fastest = 0.0;  // as the device measures a disk's speed (kernels/integrate.hpp)
  for (const auto& d : expect)
    fastest = std::max({fastest, std::sqrt(d.vx * d.vx + d.vy * d.vy), std::fabs(d.radius * d.w)});
  EXPECT_EQ(batch.state(s).speed, fastest);
}

// Contacts' impulses: a contact left out leaves its slot empty.
TEST(Batch, ContactsAreWrittenInOneCopy) {
  Batch batch(unequal_systems());
  for (int k = 0; k < 500; ++k) batch.step();
  batch.set_timing(true);
  const int s = 1;
  std::vector<ContactForce> contacts = batch.contacts(s);
  ASSERT_GT(contacts.size(), 1u);
  std::vector<ContactForce> bad = contacts;
  bad.front().normal *= 2.0;
  bad.back().j = bad.back().i;  // no contact of a disk with itself
  EXPECT_THROW(batch.set_contacts(s, bad), std::out_of_range);
  EXPECT_EQ(batch.contacts(s).front().normal, contacts.front().normal);
  contacts.pop_back();
  for (auto& c : contacts) c.normal *= 2.0;
  once([&] { batch.set_contacts(s, contacts); });
  const auto back = batch.contacts(s);
  ASSERT_EQ(back.size(), contacts.size());
  const double h = batch.params(s).time_step;
  for (std::size_t c = 0; c < back.size(); ++c) {
    EXPECT_EQ(back[c].i, contacts[c].i);
    EXPECT_EQ(back[c].j, contacts[c].j);
    EXPECT_EQ(back[c].normal, h * contacts[c].normal / h);
  }
}

// A whole state restored reads back as it was, its gravity included: disks in flight keep their
// speed without it and gain g h with it.
TEST(Batch, AStateIsRestoredInOneCopy) {
  std::vector<SystemSetup> setups = unequal_systems();
  Batch batch(setups);
  for (int k = 0; k < 500; ++k) batch.step();
  batch.set_timing(true);
  const int s = 1;
  Batch::SystemState was = batch.state(s);
  for (int k = 0; k < 50; ++k) batch.step();
  SystemSetup su = setups[s];
  su.disks = was.disks;
  batch.reset(s, su);
  Batch::SystemState off_slot = was;  // a contact slot outside the system
  off_slot.slot.back() = static_cast<int>(was.disks.size()) * kSlots;
  EXPECT_THROW(batch.restore(s, off_slot), std::invalid_argument);
  EXPECT_TRUE(batch.contacts(s).empty());  // as reset left it
  once([&] { batch.restore(s, was); });
  const Batch::SystemState now = batch.state(s);
  expect_same_disks(now.disks, was.disks, s);
  EXPECT_EQ(now.slot, was.slot);
  EXPECT_EQ(now.partner, was.partner);
  EXPECT_EQ(now.pn, was.pn);
  EXPECT_EQ(now.gap, was.gap);
  EXPECT_EQ(now.nx, was.nx);
  EXPECT_EQ(now.y_mark, was.y_mark);
  EXPECT_EQ(now.inv_mass, was.inv_mass);
  EXPECT_EQ(now.draws, was.draws);
  EXPECT_EQ(now.speed, was.speed);
  EXPECT_EQ(now.centre_speed, was.centre_speed);

  std::vector<Disk> flying;  // apart from each other and from the floor
  for (double x : {3.0, 9.0, 15.0}) {
    flying.push_back(column(1, x)[0]);
    flying.back().y = 6.0;
  }
  Batch free({setup(cohesive_params(), flying)});
  for (bool on : {false, true}) {
    Batch::SystemState state = free.state(0);
    state.gravity_on = on;
    free.reset(0, setup(cohesive_params(), flying));
    free.restore(0, state);
    free.step();
    const double g = on ? cohesive_params().gravity : 0.0;
    for (const auto& d : free.disks(0)) EXPECT_NEAR(d.vy, -g * free.params(0).time_step, 1e-15);
  }
}

// The scheduler moves systems in and out of the step between two steps: the device learns the
// active flags once, before the next step, however many changed (a copy at each change was
// about 25 copies a step for 4 096 members of protocol A: docs/PERFORMANCE.md), and the step
// moves exactly the systems active then.
TEST(Batch, ActiveFlagsReachTheDeviceOnceBeforeTheNextStep) {
  auto falling = column(3, 10.0);
  for (auto& d : falling) d.y += 1.0;  // every step moves every active system
  std::vector<SystemSetup> setups;
  for (int s = 0; s < 6; ++s) setups.push_back(setup(cohesive_params(), falling));
  Batch batch(setups);
  batch.set_timing(true);  // counts launches and copies (src/launch_count.hpp)
  batch.step();
  const LaunchCounts before = launch_counts();
  for (int s = 0; s < 6; ++s) batch.set_active(s, false);
  for (int s : {1, 4}) batch.set_active(s, true);
  EXPECT_EQ(launch_counts().copies, before.copies);  // nothing copied yet
  std::vector<std::vector<Disk>> was;
  for (int s = 0; s < 6; ++s) was.push_back(batch.disks(s));
  const LaunchCounts at_step = launch_counts();
  long stage_copies = 0;
  for (const auto& cost : batch.stage_costs()) stage_copies -= cost.copies;
  batch.step();
  for (const auto& cost : batch.stage_costs()) stage_copies += cost.copies;
  EXPECT_EQ(launch_counts().copies - at_step.copies - stage_copies, 1);  // the flags, once
  for (int s = 0; s < 6; ++s) {
    const bool active = s == 1 || s == 4;
    EXPECT_EQ(batch.status(s).active, active) << "system " << s;
    EXPECT_EQ(batch.disks(s)[2].y != was[static_cast<std::size_t>(s)][2].y, active)
        << "system " << s;
  }
  // A new member in a slot that sat out, left out of the step before its first: it stays put.
  batch.reset(0, setup(cohesive_params(), falling));
  batch.set_active(0, false);
  batch.step();
  EXPECT_EQ(batch.disks(0)[2].y, falling[2].y);
  EXPECT_NE(batch.disks(1)[2].y, was[1][2].y);
}
