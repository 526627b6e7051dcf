// The team solver colours each system inside its team (ColouredAcceleratedGaussSeidel::
// colour_system): on two hand-made systems, a chain of five disks on the floor and a triangle,
// contacts that share a disk get different colours, the colours are those of the batch-wide
// Jones-Plassmann rounds (the colouring the team solver's results were first built on), and each
// system's contact list is grouped by colour in slot order with its own colour count. A system
// keeps its colouring from step to step while its contact pairs stay.
#include <gtest/gtest.h>

#include <algorithm>
#include <any>
#include <string>
#include <utility>
#include <vector>

#include "kernels/colouring.hpp"
#include "kernels/solver.hpp"
#include "loosepack/params.hpp"

namespace loosepack {
namespace {

using Solver = ColouredAcceleratedGaussSeidel<Effects<true, true, true>>;

// Disks 0-4 are system 0, 5-7 system 1. Contacts are owned by their lower disk.
const std::vector<std::pair<int, int>> kContacts = {{0, kFloor}, {0, 1}, {1, 2}, {2, 3},
                                                    {3, 4},      {5, 6}, {5, 7}, {6, 7}};
constexpr int kDisks = 8, kSystems = 2;

struct Graph {
  SystemViews sys;
  ParticleViews part;
  ContactViews con;
  std::vector<int> slot;         // of each of kContacts
  std::vector<std::any> memory;  // of the bundles' views, which count no references (KView)
  template <class T>
  void keep(KView<T>& field, const DView<T>& view) {
    field = view;
    memory.push_back(view);
  }
};

template <class T>
DView<T> from_host(const char* name, const std::vector<T>& v) {
  DView<T> d(std::string(name), v.size());
  auto h = Kokkos::create_mirror_view(d);
  for (std::size_t k = 0; k < v.size(); ++k) h(k) = v[k];
  Kokkos::deep_copy(d, h);
  return d;
}

template <class View>
std::vector<typename View::non_const_value_type> to_host(const View& d) {
  auto h = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), d);
  return {h.data(), h.data() + h.extent(0)};
}

Graph graph(const std::vector<std::pair<int, int>>& contacts = kContacts) {
  std::vector<int> partner(kDisks * kSlots, kNoContact), n_incident(kDisks, 0),
      incident(kDisks * kIncident, -1), owned(kDisks, 0), slots;
  for (const auto& [i, j] : contacts) {
    const int c = i * kSlots + owned[i]++;
    slots.push_back(c);
    partner[c] = j;
    incident[i * kIncident + n_incident[i]++] = c;
    if (j >= 0) incident[j * kIncident + n_incident[j]++] = c;
  }
  Graph g;
  g.keep(g.sys.offset, from_host<int>("offset", {0, 5}));
  g.keep(g.sys.count, from_host<int>("count", {5, 3}));
  g.keep(g.part.system, from_host<int>("system", {0, 0, 0, 0, 0, 1, 1, 1}));
  g.keep(g.part.n_incident, from_host("n_incident", n_incident));
  g.keep(g.part.incident, from_host("incident", incident));
  g.keep(g.con.partner, from_host("partner", partner));
  g.keep(g.con.colour, DView<int>("colour", kDisks * kSlots));
  g.slot = slots;
  return g;
}

// The batch-wide colouring: rounds over every contact of the batch until none is left.
std::vector<int> batch_colours(const Graph& g) {
  Kokkos::parallel_for(kDisks * kSlots, ColourReset{g.con});
  for (int round = 0;; ++round) {
    int uncoloured = 0;
    Kokkos::parallel_reduce(kDisks * kSlots, ColourRound{g.sys, g.part, g.con, round},
                            uncoloured);
    if (uncoloured == 0) break;
  }
  return to_host(g.con.colour);
}

// The team solver's colouring, each system by a team of up to 4 threads (1 on Serial), so that
// an OpenMP build checks the rounds' barriers: with `start`, the start of a step (which keeps a
// colouring whose contact pairs stay), else the colouring and grouping themselves. Its colour
// count per system. (A free function: CUDA's extended lambdas may not live in a test's body.)
std::vector<int> team_colours(const Graph& g, const Solver& solver, bool start = false) {
  DView<int> n_colours("n_colours", kSystems);
  const SystemViews sys = g.sys;  // (the lambda copies views only)
  const auto colour = KOKKOS_LAMBDA(const Solver::Member& team) {
    const int s = team.league_rank();
    const SlotRange range = system_slots(sys, s);
    const int base = range.first + s;
    int n = 0;
    if (start) {
      n = solver.start_step(team, s, range, base);
    } else {
      n = solver.colour_system(team, range);
      solver.group_by_colour(team, range, base, n);
    }
    Kokkos::single(Kokkos::PerTeam(team), [&]() { n_colours(s) = n; });
  };
  const int team_size = std::min(
      4,
      Kokkos::TeamPolicy<ExecSpace>(kSystems, 1).team_size_max(colour, Kokkos::ParallelForTag()));
  Kokkos::parallel_for(Kokkos::TeamPolicy<ExecSpace>(kSystems, team_size), colour);
  return to_host(n_colours);
}

TEST(TeamColouring, ContactsSharingADiskDifferAndMatchTheBatchRounds) {
  const Graph g = graph();
  const std::vector<int> expected = batch_colours(g);
  Solver solver{g.sys,
                g.part,
                g.con,
                DView<int>(),
                DView<int>("list", kDisks * kSlots),
                DView<int>("starts", kDisks * kSlots + kSystems),
                1.0,
                0,
                {},
                DView<int>()};          // no sweeps: nothing packed
  Kokkos::deep_copy(g.con.colour, -3);  // the team must reset the colours itself
  const auto n = team_colours(g, solver);
  const auto colour = to_host(g.con.colour), list = to_host(solver.list),
             starts = to_host(solver.starts);
  EXPECT_EQ(colour, expected);
  // A chain needs two colours at least, a triangle three.
  EXPECT_GE(n[0], 2);
  EXPECT_GE(n[1], 3);
  for (std::size_t a = 0; a < kContacts.size(); ++a)
    for (std::size_t b = a + 1; b < kContacts.size(); ++b) {
      const auto [i, j] = kContacts[a];
      const auto [k, l] = kContacts[b];
      const bool share = i == k || (j >= 0 && (j == k || j == l)) || (l >= 0 && i == l);
      if (share) {
        EXPECT_NE(colour[g.slot[a]], colour[g.slot[b]]) << "contacts " << a << ", " << b;
      }
    }
  // Each system's list: its colour-k slots, in slot order, between starts[base + k] and
  // starts[base + k + 1].
  const int offsets[kSystems] = {0, 5}, counts[kSystems] = {5, 3};
  for (int s = 0; s < kSystems; ++s) {
    const int first = offsets[s] * kSlots, end = (offsets[s] + counts[s]) * kSlots,
              base = first + s;
    EXPECT_EQ(starts[base], first);
    for (int k = 0; k < n[s]; ++k) {
      std::vector<int> want, got;
      for (int c = first; c < end; ++c)
        if (colour[c] == k) want.push_back(c);
      for (int a = starts[base + k]; a < starts[base + k + 1]; ++a) got.push_back(list[a]);
      EXPECT_EQ(got, want) << "system " << s << ", colour " << k;
      EXPECT_FALSE(want.empty()) << "system " << s << ", colour " << k;
    }
  }
}

// A system whose contact pairs are those of its last colouring keeps it; one whose pairs
// changed is coloured again, as a batch-wide colouring colours its new pairs. The colours are
// overwritten with a mark before each step's start: a kept colouring leaves the mark.
TEST(TeamColouring, ASystemKeepsItsColouringWhileItsContactPairsStay) {
  Graph g = graph();
  const std::size_t n_slots = kDisks * kSlots;
  g.keep(g.sys.colours, DView<int>("colours", kSystems));
  g.keep(g.sys.coloured_count, DView<int>("coloured_count", kSystems));
  g.keep(g.con.coloured_partner, DView<int>("coloured_partner", n_slots));
  const Solver solver{g.sys,
                      g.part,
                      g.con,
                      DView<int>(),
                      DView<int>("list", n_slots),
                      DView<int>("starts", n_slots + kSystems),
                      1.0,
                      0,
                      {},
                      DView<int>()};  // no sweeps: nothing packed
  const auto colours_now = [&]() { return to_host(g.con.colour); };
  constexpr int kMark = -3;

  const std::vector<int> fresh = batch_colours(graph());
  Kokkos::deep_copy(g.con.colour, kMark);
  const auto first = team_colours(g, solver, true);
  EXPECT_EQ(colours_now(), fresh);  // the first step colours every system
  const auto list = to_host(solver.list), starts = to_host(solver.starts);

  // The same pairs: nothing is coloured again, the lists stay.
  Kokkos::deep_copy(g.con.colour, kMark);
  EXPECT_EQ(team_colours(g, solver, true), first);
  EXPECT_EQ(colours_now(), std::vector<int>(n_slots, kMark));
  EXPECT_EQ(to_host(solver.list), list);
  EXPECT_EQ(to_host(solver.starts), starts);

  // The triangle 5-6-7 loses its pair (6, 7) and system 1 holds the same disks: it alone is
  // coloured again, with two colours.
  std::vector<std::pair<int, int>> opened = kContacts;
  opened.erase(std::find(opened.begin(), opened.end(), std::make_pair(6, 7)));
  const Graph changed = graph(opened);
  Kokkos::deep_copy(g.con.partner, changed.con.partner);
  Kokkos::deep_copy(g.part.n_incident, changed.part.n_incident);
  Kokkos::deep_copy(g.part.incident, changed.part.incident);
  const std::vector<int> fresh_opened = batch_colours(changed);
  Kokkos::deep_copy(g.con.colour, kMark);
  const auto after = team_colours(g, solver, true);
  EXPECT_EQ(after[0], first[0]);
  EXPECT_EQ(after[1], 2);
  const auto colour = colours_now();
  const int system1 = 5 * kSlots;
  for (int c = 0; c < system1; ++c) EXPECT_EQ(colour[c], kMark) << "slot " << c;
  for (int c = system1; c < static_cast<int>(n_slots); ++c)
    EXPECT_EQ(colour[c], fresh_opened[c]) << "slot " << c;
}

}  // namespace
}  // namespace loosepack
