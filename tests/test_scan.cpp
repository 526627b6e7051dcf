// Scan files: expansion of axes, and every rejected case with its message.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "loosepack/geometry.hpp"
#include "loosepack/scan.hpp"
#include "loosepack/settings.hpp"
#include "tests/scan_errors.hpp"

using namespace loosepack;

using scan_errors::error_of;

TEST(Scan, AxesCombineAsAGrid) {
  const auto scan = parse_scan(R"(
[scan]
seeds = 3
protocol = ["A", "C"]
[system]
bond_number = { from = 1, to = 1e4, points = 5, log = true, also = [0] }
friction = [0.3, 0.5]
)",
                               "ok.toml");
  ASSERT_EQ(scan.points.size(), 2u * 6u * 2u);
  EXPECT_EQ(scan.members(), 72);
  // protocol slowest, then bond_number (declared order of the system keys), then friction
  EXPECT_EQ(scan.points[0].protocol, Protocol::A);
  EXPECT_EQ(scan.points[0].params.bond_number, 0.0);  // `also` merged in order
  EXPECT_DOUBLE_EQ(scan.points[1].params.friction, 0.5);
  EXPECT_EQ(scan.points[2].params.bond_number, 1.0);
  EXPECT_EQ(scan.points[4].params.bond_number, 10.0);  // log spacing, a decade apart, exactly
  EXPECT_EQ(scan.points[12].protocol, Protocol::C);
}

// Scan::content, what checkpoints and merges identify a scan by: the same settings written with
// comments, other spacing and keys in another order give the same content, which names the
// toml++ that wrote it and parses to itself, and so does another batch size,
// solver.sweeps_per_launch or fused_step; any value that differs, in type (12, 12.0) or in its last
// bit, gives another.
TEST(Scan, ContentIsTheSettingsWithoutCommentsOrLayoutOrWhatNoResultDependsOn) {
  const std::string text =
      "[scan]\nseeds = 2\nprotocol = \"A\"\n[system]\nwidth = 12\nfriction = 0.1\n"
      "bond_number = [10, 100]\n";
  const Scan scan = parse_scan(text, "a.toml");
  const Scan same = parse_scan(
      "# the same settings\n[system]\nbond_number=[ 10,100 ]  # Bo\nfriction = 0.1\n\nwidth = 12\n"
      "[scan]\nprotocol = 'A'\nseeds = 2\n",
      "b.toml");
  EXPECT_EQ(same.content, scan.content);
  EXPECT_EQ(scan.content.rfind("# written by toml++ ", 0), 0u);
  EXPECT_EQ(parse_scan(scan.content, "c.toml").content, scan.content);
  // The batch size changes no member's result: it is not part of the scan's identity.
  const std::string after_header = text.substr(text.find("seeds"));
  EXPECT_EQ(parse_scan("[scan]\nbatch_size = 7\n" + after_header, "e.toml").content, scan.content);
  const std::string system = text.substr(text.find("[system]"));
  EXPECT_EQ(parse_scan("[scan]\nbatch_size = 7\n" + system, "f.toml").content,
            parse_scan(system, "g.toml").content);
  // Nor are solver.sweeps_per_launch and fused_step (SettingKey::changes_no_result); the solver's
  // other keys are.
  const std::string team = "[solver]\nkind = \"coloured_accelerated_gauss_seidel\"\n";
  const auto content = [&](const std::string& solver) {
    return parse_scan(solver + text, "h.toml").content;
  };
  EXPECT_EQ(content(team + "sweeps_per_launch = 8\n"), content(team));
  EXPECT_EQ(content(team + "fused_step = true\n"), content(team));
  EXPECT_EQ(content(team + "sweeps_per_launch = 8\nnewton_every = 3\n"),
            content(team + "newton_every = 3\n"));
  EXPECT_NE(content(team + "newton_every = 3\n"), content(team));
  const auto with = [&](const std::string& from, const std::string& to) {
    std::string t = text;
    t.replace(t.find(from), from.size(), to);
    return parse_scan(t, "d.toml").content;
  };
  // A number spelt otherwise is the same setting (a real-valued key's integers are reals there);
  // another value is not.
  EXPECT_EQ(with("width = 12", "width = 12.0"), scan.content);
  EXPECT_EQ(with("[10, 100]", "[1e1, 100.0]"), scan.content);
  EXPECT_NE(with("width = 12", "width = 13"), scan.content);
  EXPECT_NE(with("friction = 0.1", "friction = 0.10000000000000002"), scan.content);
  EXPECT_NE(with("[10, 100]", "[100, 10]"), scan.content);
}

// Two scans' first differing setting, named by its key: a value, a key on one side only, a
// [[point]] table's key by the table's index; none where only a number's spelling differs.
TEST(Scan, FirstDifferenceNamesTheKey) {
  const auto content = [](const std::string& text) { return parse_scan(text, "s.toml").content; };
  const std::string points =
      "[system]\nwidth = 20\n[[point]]\nheight = 30\n[[point]]\nheight = 40\n"
      "[observables]\nlower_half_from = 2\n";
  std::string taller = points;
  taller.replace(taller.find("height = 40"), 11, "height = 50");
  EXPECT_EQ(first_difference(content(points), content(taller), "A", "B"),
            "key 'point[1].height' is `40.0` in A and `50.0` in B");
  std::string spelt = points;
  spelt.replace(spelt.find("width = 20"), 10, "width = 2e1");
  EXPECT_EQ(first_difference(content(points), content(spelt), "A", "B"), "");
  const std::string seeded = "[scan]\nseeds = 3\n" + points;
  EXPECT_EQ(first_difference(content(points), content(seeded), "A", "B"),
            "key 'scan.seeds' is `(none)` in A and `3` in B");
}

// A logarithmic range holds its decades exactly (each 10^k, so a point compares equal to the
// number a user writes), with `also` values merged in ascending order and infinity last; values
// between decades are spaced evenly in log10.
TEST(Scan, LogRangesAreExactDecadesWithAlsoInOrder) {
  const auto scan = parse_scan(
      "[system]\nbond_number = { from = 1, to = 1e4, points = 3, log = true, also = [\"inf\", 0, "
      "100] }\n",
      "ok.toml");
  std::vector<double> bo;
  for (const auto& p : scan.points) bo.push_back(p.params.bond_number);
  EXPECT_EQ(bo, (std::vector<double>{0.0, 1.0, 100.0, 10000.0, INFINITY}));
  const auto fine = parse_scan(
      "[system]\nbond_number = { from = 1, to = 1e3, points = 7, log = true }\n", "ok.toml");
  ASSERT_EQ(fine.points.size(), 7u);
  for (std::size_t k = 0; k < 7; k += 2)
    EXPECT_EQ(fine.points[k].params.bond_number, std::pow(10.0, static_cast<double>(k / 2)));
  EXPECT_NEAR(fine.points[1].params.bond_number, std::sqrt(10.0), 1e-12);
}

TEST(Scan, InfiniteBondNumberIsAccepted) {
  const auto scan = parse_scan("[system]\nbond_number = [0, \"inf\"]\n", "ok.toml");
  ASSERT_EQ(scan.points.size(), 2u);
  EXPECT_TRUE(std::isinf(scan.points[1].params.bond_number));
}

// Without [solver] tolerance each protocol runs with its own default; with it, every protocol
// runs with the file's.
TEST(Scan, ToleranceIsTheProtocolDefaultUnlessSet) {
  const auto plain = parse_scan("[scan]\nprotocol = [\"A\", \"C\"]\n", "plain.toml");
  EXPECT_FALSE(plain.tolerance_given);
  EXPECT_EQ(plain.tolerance(Protocol::A), default_tolerance(Protocol::A));
  EXPECT_EQ(plain.tolerance(Protocol::C), default_tolerance(Protocol::C));
  EXPECT_LT(default_tolerance(Protocol::C), default_tolerance(Protocol::A));
  const auto set =
      parse_scan("[scan]\nprotocol = [\"A\", \"C\"]\n[solver]\ntolerance = 2e-4\n", "set.toml");
  EXPECT_TRUE(set.tolerance_given);
  EXPECT_EQ(set.tolerance(Protocol::A), 2e-4);
  EXPECT_EQ(set.tolerance(Protocol::C), 2e-4);
}

// Protocol A's default sweep cap grows with the box, 0.2 per R^2 between 300 and 2 000 (small
// deposits stall, larger ones converge slowly: docs/PERFORMANCE.md, "The sweep cap"); C keeps
// 2 000; a cap in the file holds for every protocol and box.
TEST(Scan, SweepCapIsTheProtocolDefaultUnlessSet) {
  auto box = [](double width, double height) {
    SystemParams p;
    p.width = width;
    p.height = height;
    return p;
  };
  const auto small = box(24, 24), mid = box(40, 120), paper = box(200, 800);
  const auto plain = parse_scan("[scan]\nprotocol = [\"A\", \"C\"]\n", "plain.toml");
  EXPECT_FALSE(plain.max_sweeps_given);
  EXPECT_EQ(plain.max_sweeps(Protocol::A, small), 300);
  EXPECT_EQ(plain.max_sweeps(Protocol::A, mid), 960);  // 0.2 x 40 x 120
  EXPECT_EQ(plain.max_sweeps(Protocol::A, paper), 2000);
  auto half_radius = mid;
  half_radius.radius = 0.5;  // the same box in units of R^2 is four times the area
  EXPECT_EQ(plain.max_sweeps(Protocol::A, half_radius), 2000);
  for (const auto& p : {small, mid, paper}) EXPECT_EQ(plain.max_sweeps(Protocol::C, p), 2000);
  const auto set =
      parse_scan("[scan]\nprotocol = [\"A\", \"C\"]\n[solver]\nmax_sweeps = 777\n", "set.toml");
  EXPECT_TRUE(set.max_sweeps_given);
  EXPECT_EQ(set.max_sweeps(Protocol::A, small), 777);
  EXPECT_EQ(set.max_sweeps(Protocol::A, paper), 777);
  EXPECT_EQ(set.max_sweeps(Protocol::C, small), 777);
}

// Newton rounds by Bond number unless the file sets them: the solver's default from
// kNewtonFromBond on, none below (and none without cohesion); the file's value for every member.
TEST(Scan, NewtonStepsFollowTheBondNumberUnlessSet) {
  EXPECT_GT(SolverSettings{}.newton_every, 0);
  SystemParams weak, strong, dry;
  weak.bond_number = 0.5 * kNewtonFromBond;
  strong.bond_number = kNewtonFromBond;
  dry.bond_number = 0.0;
  const Scan plain = parse_scan("[scan]\nname = \"plain\"\n", "plain.toml");
  EXPECT_FALSE(plain.newton_every_given);
  EXPECT_EQ(plain.newton_every(strong), SolverSettings{}.newton_every);
  EXPECT_EQ(plain.newton_every(weak), 0);
  EXPECT_EQ(plain.newton_every(dry), 0);
  for (const int n : {0, 3}) {
    const Scan set = parse_scan("[solver]\nnewton_every = " + std::to_string(n) + "\n", "n.toml");
    EXPECT_EQ(set.newton_every(strong), n);
    EXPECT_EQ(set.newton_every(weak), n);
  }
}

// batch_size: 0 unless set, which run_members and the program read as default_batch_size().
TEST(Scan, BatchSizeIsLeftToTheBackendUnlessSet) {
  EXPECT_EQ(parse_scan("[scan]\nname = \"plain\"\n", "plain.toml").batch_size, 0);
  EXPECT_EQ(parse_scan("[scan]\nbatch_size = 7\n", "seven.toml").batch_size, 7);
}

TEST(Scan, OverlapCorrectionIsOffUnlessSet) {
  EXPECT_EQ(parse_scan("[scan]\nname = \"plain\"\n", "plain.toml").solver.overlap_correction, 0.0);
  EXPECT_EQ(parse_scan("[solver]\noverlap_correction = 0.2\n", "on.toml").solver.overlap_correction,
            0.2);
}

TEST(Scan, RelativeToleranceIsTheSolversUnlessSet) {
  EXPECT_EQ(parse_scan("[scan]\nname = \"plain\"\n", "plain.toml").solver.relative_tolerance,
            SolverSettings{}.relative_tolerance);
  EXPECT_EQ(parse_scan("[solver]\nrelative_tolerance = 0\n", "off.toml").solver.relative_tolerance,
            0.0);
  EXPECT_EQ(
      parse_scan("[solver]\nrelative_tolerance = 3e-4\n", "set.toml").solver.relative_tolerance,
      3e-4);
}

TEST(Scan, RestNeedsAConvergedSolveUnlessSet) {
  EXPECT_TRUE(parse_scan("[scan]\nname = \"plain\"\n", "plain.toml").rest.converged);
  EXPECT_FALSE(parse_scan("[rest]\nconverged = false\n", "speeds.toml").rest.converged);
}

TEST(Scan, RejectsBadInputWithFileLineAndKey) {
  const std::vector<scan_errors::Case> cases = {
      {"[system]\nbond_number = -1\n", "bad.toml:2:15: key 'system.bond_number': Bo must be"},
      {"[system]\nfriction = [0.3, -0.1]\n", "key 'system.friction': mu must be finite and >= 0"},
      {"[system]\ncapture_radius = 0.5\n",
       "key 'system.capture_radius': r_capt must be in [1, 10]"},
      {"[system]\nheight = 3\n", "key 'system.height': H must be finite and >= 4 R"},
      {"[system]\nwidth = 2\n",
       "key 'system.width': L_x must be finite and >= 2 (2 R_max + d_c), here 4.02"},
      {"[system]\nwidth = \"inf\"\n",
       "key 'system.width': L_x must be finite and >= 2 (2 R_max + d_c), here 4.02"},
      {"[system]\nwidth = nan\n", "bad.toml:2:9: key 'system.width': nan is not a value"},
      {"[solver]\ntolerance = nan\n", "key 'solver.tolerance': nan is not a value"},
      {"[system]\nbond_number = [100, 1e3, 100]\n",
       "bad.toml:2:26: key 'system.bond_number': the value 100 is already in this axis"},
      {"[system]\nbond_number = [0,\n 100,\n -5]\n",  // the value, not the axis
       "bad.toml:4:2: key 'system.bond_number': Bo must be 0,"},
      {"[system]\nheight = { from = 20, to = 40, points = 1 }\n",
       "bad.toml:2:10: key 'system.height': points = 1 gives `from` alone"},
      {"[system]\nheight = { from = 20, to = 20, points = 3 }\n",
       "bad.toml:2:10: key 'system.height': from equals to: the range is one value, not 3"},
      {"[system]\nbond_number = { from = 1, to = 1.000000001, points = 3, log = true }\n",
       "bad.toml:2:15: key 'system.bond_number': from and to lie too close for 3 distinct points "
       "(they give 1)"},
      {"[system]\nfriction = { from = 0.3, to = 0.3000000000000001, points = 4 }\n",
       "bad.toml:2:12: key 'system.friction': from and to lie too close for 4 distinct points"},
      {"[system]\nbond_number = { from = 1, to = \"inf\", points = 2 }\n",
       "bad.toml:2:15: key 'system.bond_number': a linear range needs finite from and to"},
      {"[system]\nbond_number = 100\ntime_step = 1e-10\n",  // no rest.steps would do
       "bad.toml:3:13: key 'system.time_step': h = 1e-10 with rest.steps = 10: a disk set free"},
      {"[system]\nbond_number = 100\ntime_step = 1e-10\n",
       "[rest] steps would need 2e+07, beyond its bound of 1e+06"},
      {"[system]\nwidth = 12\nheight = 3\nradius = 0.5\n",  // a default band, refused at H
       "bad.toml:3:10: key 'system.height': observables.strip_width (its default, not set in "
       "the file) 3.97 must be at most H = 3"},
      {"[system]\nwidth = 12\nheight = 100\nradius = 0.5\n[[point]]\nheight = 3\n",  // its own H
       "bad.toml:6:10: key 'point.height': observables.strip_width (its default, not set in "
       "the file) 3.97 must be at most H = 3"},
      {"[scan]\nprotocol = [\"A\", \"B\", \"A\"]\n",
       "bad.toml:2:23: key 'scan.protocol': the value \"A\" is already in this axis"},
      {"[system]\nwidht = 20\n", "bad.toml:2:9: key 'system.widht': unknown key"},
      {"[system]\nbond_number = \"strong\"\n",
       "key 'system.bond_number': expected a number: Bo must be 0, in (0, 1e8], or \"inf\""},
      {"[scan]\nseeds = 0\n", "key 'scan.seeds': expected an integer in [1,"},
      {"[scan]\nname = \"\"\n", "bad.toml:2:8: key 'scan.name': expected a non-empty string"},
      {"[scan]\nname = \"two\\nlines\"\n",  // it would break the summary's "# scan" line
       "bad.toml:2:8: key 'scan.name': expected a non-empty string without control characters"},
      {"[scan]\nname = \"a\\u009Bb\"\n",  // a C1 control (CSI), which a terminal obeys
       "bad.toml:2:8: key 'scan.name': expected a non-empty string without control characters"},
      {"[scan]\nprotocol = \"D\"\n", "key 'scan.protocol': expected \"A\", \"B\" or \"C\""},
      {"[solver]\nkind = \"newton\"\n", "key 'solver.kind'"},
      {"[solver]\ntolerance = 2.0\n", "key 'solver.tolerance': value 2 outside the allowed range"},
      {"[solver]\nnewton_every = -1\n",
       "bad.toml:2:16: key 'solver.newton_every': expected an integer in [0,"},
      {"[solver]\noverlap_correction = 1.5\n",
       "bad.toml:2:22: key 'solver.overlap_correction': value 1.5 outside the allowed range "
       "[0, 1]"},
      {"[solver]\nrelative_tolerance = -1e-3\n",
       "bad.toml:2:22: key 'solver.relative_tolerance': value -0.001 outside the allowed range "
       "[0, 1]"},
      {"[solver]\nsweeps_per_launch = 8\n",
       "bad.toml:2:21: key 'solver.sweeps_per_launch': only the solver kind "
       "coloured_accelerated_gauss_seidel splits a step's solve over launches"},
      {"[solver]\nkind = \"accelerated_gauss_seidel\"\nsweeps_per_launch = 8\n",
       "bad.toml:3:21: key 'solver.sweeps_per_launch': only the solver kind"},
      {"[solver]\nkind = \"jacobi\"\nfused_step = true\n",
       "bad.toml:3:14: key 'solver.fused_step': a step runs in one launch only with a solver that "
       "sweeps each system in its own team: accelerated_gauss_seidel, "
       "coloured_accelerated_gauss_seidel or sequential_gauss_seidel, not jacobi"},
      {"[solver]\nfused_step = true\nkind = \"gauss_seidel\"\n",
       "bad.toml:2:14: key 'solver.fused_step': a step runs in one launch only"},
      {"[rest]\nsteps = 1.5\n", "key 'rest.steps': expected an integer"},
      {"[rest]\nconverged = 0\n", "bad.toml:2:13: key 'rest.converged': expected true or false"},
      {"[protocol]\nregion_radius = 3\n",
       "bad.toml:2:17: key 'protocol.region_radius': must be 0 (no regions) or at least 5 (in the "
       "file's length unit)"},
      {"[protocol]\nregion_check_every = 0\n", "key 'protocol.region_check_every': expected an"},
      {"[colour]\nred = 1\n",
       "key 'colour': unknown section (allowed: scan, system, solver, rest, protocol, "
       "observables)"},
      {"scan = 3\n",
       "bad.toml:1:8: key 'scan': expected a table ([scan], [system], [solver], [rest], "
       "[protocol], [observables]) or [[point]] tables"},
      {"[scan]\nseed_count = 3\n",
       "bad.toml:2:14: key 'scan.seed_count': unknown key (allowed: name, seed, seeds, "
       "batch_size, protocol)"},
      {"[system]\nbond_number = { from = 0, to = 10, points = 3, log = true }\n",
       "a logarithmic range needs finite positive from and to"},
      {"[scan]\nprotocol = \"C\"\n[system]\nbond_number = \"inf\"\n",
       "protocol C with Bo = inf has no collapse"},
      {"[system\nwidth = 3\n", "bad.toml:1:"},
      // A byte that is not UTF-8, at its own line and column, with no key named.
      {"[scan]\nseeds = 2\n\xff = 1\n", "bad.toml:3:1: byte 0xFF is not UTF-8 text"},
      {"[scan]\nname = \"a\xc3\"\n", "bad.toml:2:10: byte 0xC3 is not UTF-8 text"},
      // toml++'s own errors name the bare key; the section is added where the line sets a key.
      {"[system]\nwidth = 24\n[box]\n[protocol]\n# [scan]\nkind = \"A\"\nkind = \"C\"\n",
       "bad.toml:7:8: key 'protocol.kind': Error while parsing key-value pair: cannot redefine"},
      {"[system]\nwidth = 24\n[system]\n", "bad.toml:3:1: Error while parsing table header"},
      // A quoted header names its section too; one read no other way (an escape) names no key.
      {"[system]\nwidth = 24\n[\"scan\"]\nseeds = x\n", "bad.toml:4:9: key 'scan.seeds': "},
      {"[system]\nwidth = 24\n[\"sc\\u0061n\"]\nseeds = x\n", "bad.toml:4:9: Error"},
      {"[system]\nwidth = 24\n[\"scan.x\"]\nseeds = x\n", "bad.toml:4:9: Error"},
      {"[system]\nheight = 40\n[observables]\nlower_half_from = 30\n",
       "bad.toml:4:19: key 'observables.lower_half_from': 30 must lie below H/2 = 20"},
      {"[system]\nheight = [40, 8]\n[observables]\nstrip_width = 16\nlower_half_from = 1\n",
       "bad.toml:4:15: key 'observables.strip_width': 16 must be at most H = 8"},
      {"[system]\nheight = 12\n[observables]\ncut_bottom = 8\ncut_top = 8\n",
       "bad.toml:5:11: key 'observables.cut_top': cut_bottom + cut_top = 16 must lie below H = 12"},
      {"[system]\nheight = [12, 60]\n[observables]\ncut_bottom = 11\n",
       "bad.toml:4:14: key 'observables.cut_bottom': cut_bottom + cut_top = 13 must lie below H = "
       "12"},
      {"[system]\nbond_number = -inf\n", "bad.toml:2:15: key 'system.bond_number': Bo must be 0"},
      // An inf or a nan in an array: the key's own message (toml++'s writer, which makes the
      // scan's identity, must not see them: fuzz/corpus/crash_toml_writer_inf_in_array.toml).
      {"[system]\ncapture_radius = [1.0, -inf]\n",
       "bad.toml:2:24: key 'system.capture_radius': r_capt must be in [1, 10]"},
      {"[system]\nheight = [40, nan]\n", "bad.toml:2:15: key 'system.height': nan is not a value"},
      {"# nothing but a comment\n", "bad.toml: the scan file sets nothing"},
      {"[solver]\n", "bad.toml: the scan file sets nothing"},
      {"[system]\n[[point]]\n", "bad.toml: the scan file sets nothing"},
      {"[system]\nheight = 120\ntime_step = 1e-5\n",
       "bad.toml:3:13: key 'system.time_step': h = 1e-05 with rest.steps = 10: a disk set free "
       "falls only g h rest.steps = 0.0001 sqrt(gR) fast within the rest window, below 2 rest "
       "speeds (0.002), so rest would be declared before anything moved; set [rest] steps >= 200"},
  };
  scan_errors::expect_refused(cases);
}

// The width's bound is the box's own: twice a contact's reach from the largest disk, which a
// polydisperse packing makes larger than the defaults' 4.02.
TEST(Scan, TheWidthsBoundIsNamedForThePointsDisks) {
  SystemParams p;
  p.polydispersity = 0.3;
  std::ostringstream least;
  least << smallest_width(p);
  EXPECT_GT(smallest_width(p), 4.02 + 1.0);
  EXPECT_EQ(error_of("[system]\nwidth = 5\npolydispersity = 0.3\n"),
            "bad.toml:2:9: key 'system.width': L_x must be finite and >= 2 (2 R_max + d_c), here " +
                least.str());
}

// "inf" is offered where it is a value (the Bond number without gravity), not for keys that must
// be finite, nor for a range's ends of such a key; a value that is no number is told the key's
// range.
TEST(Scan, OnlyTheBondNumberIsOfferedInfinity) {
  const std::string bo = "expected a number: Bo must be 0, in (0, 1e8], or \"inf\" (";
  EXPECT_EQ(error_of("[system]\nwidth = \"wide\"\n"),
            "bad.toml:2:9: key 'system.width': expected a number: L_x must be finite and >= 2 (2 "
            "R_max + d_c), here 4.02");
  EXPECT_EQ(
      error_of("[system]\nheight = { from = 40, to = \"tall\", points = 2 }\n"),
      "bad.toml:2:28: key 'system.height.to': expected a number: H must be finite and >= 4 R");
  EXPECT_EQ(error_of("[system]\nbond_number = { from = 1, to = \"x\", points = 2 }\n")
                .rfind("bad.toml:2:32: key 'system.bond_number.to': " + bo, 0),
            0u);
  EXPECT_EQ(error_of("[[point]]\nwidth = \"x\"\n"),
            "bad.toml:2:9: key 'point.width': expected a number: L_x must be finite and >= 2 (2 "
            "R_max + d_c), here 4.02");
  EXPECT_EQ(error_of("[[point]]\nbond_number = \"x\"\n")
                .rfind("bad.toml:2:15: key 'point.bond_number': " + bo, 0),
            0u);
  EXPECT_EQ(error_of("[system]\nfriction = [0.3, \"rough\"]\n"),
            "bad.toml:2:18: key 'system.friction': expected a number: mu must be finite and >= 0");
}

// The rest window's bound g h rest.steps >= 2 rest.speed: where the file sets no time step the
// error points at rest.steps (or rest.speed), a rest window long enough makes a tiny time step
// valid, and ballistic points (no dynamics) are not bound by it. Where the file sets neither, h is
// the default of a large Bond number, 0.9 sqrt(d_c / (Bo g)), and the error points at the Bond
// number.
TEST(Scan, RestWindowMustLetAFallingDiskShow) {
  EXPECT_NE(error_of("[rest]\nspeed = 0.5\nsteps = 10\n[system]\nbond_number = 0\n")
                .find("bad.toml:3:9: key 'rest.steps': h = 0.01 with rest.steps = 10"),
            std::string::npos);
  // A rest speed set alone is where the error lies (the time step is the default's at Bo = 1e3,
  // 0.9 sqrt(d_c / (Bo g)) = 0.00284605).
  EXPECT_EQ(error_of("[rest]\nspeed = 0.5\n[system]\nwidth = 24\n")
                .rfind("bad.toml:2:9: key 'rest.speed': h = 0.00284605 with rest.steps = 10", 0),
            0u)
      << error_of("[rest]\nspeed = 0.5\n[system]\nwidth = 24\n");
  const std::string large_bo = error_of("[system]\nbond_number = 1e6\n");
  const double h = 0.9 * std::sqrt(0.01 / 1e6);
  const long need = static_cast<long>(std::ceil(2.0 * 1e-3 / h));
  EXPECT_EQ(large_bo.rfind("bad.toml:2:15: key 'system.bond_number': h = 9e-05 with rest.steps", 0),
            0u)
      << large_bo;
  EXPECT_NE(large_bo.find("set [rest] steps >= " + std::to_string(need) +
                          ", or a smaller rest.speed (docs/SCAN.md, [rest]); h is the default "
                          "time step at Bo = 1e+06"),
            std::string::npos)
      << large_bo;
  EXPECT_NO_THROW(
      parse_scan("[system]\nheight = 120\n[rest]\nsteps = 23\n[[point]]\ntime_step = "
                 "9e-5\n",
                 "ok.toml"));
  EXPECT_NO_THROW(parse_scan("[scan]\nprotocol = \"B\"\n[system]\nheight = 120\ntime_step = 1e-5\n",
                             "ok.toml"));
}

TEST(Scan, ExplicitPointsOverrideTheSystemDefaults) {
  const auto scan = parse_scan(R"(
[system]
width = 30
friction = 0.4
[[point]]
protocol = "A"
bond_number = 0
[[point]]
protocol = "C"
bond_number = 1000
capture_radius = 2.0
)",
                               "ok.toml");
  ASSERT_EQ(scan.points.size(), 2u);
  EXPECT_EQ(scan.points[0].protocol, Protocol::A);
  EXPECT_EQ(scan.points[0].params.bond_number, 0.0);
  EXPECT_EQ(scan.points[1].protocol, Protocol::C);
  EXPECT_EQ(scan.points[1].params.capture_radius, 2.0);
  EXPECT_EQ(scan.points[1].params.width, 30.0);
  EXPECT_EQ(scan.points[1].params.friction, 0.4);
  EXPECT_EQ(scan.points[1].index, 1);
}

TEST(Scan, ExplicitPointErrors) {
  EXPECT_NE(error_of("[system]\nbond_number = [1, 2]\n[[point]]\nwidth = 30\n")
                .find("key 'system.bond_number': axes and [[point]] tables do not mix"),
            std::string::npos);
  EXPECT_NE(error_of("[[point]]\nwidth = [30, 40]\n")
                .find("bad.toml:2:9: key 'point.width': a point takes single values"),
            std::string::npos);
  EXPECT_NE(error_of("[[point]]\nmu = 0.3\n").find("key 'point.mu': unknown key"),
            std::string::npos);
  EXPECT_NE(error_of("[[point]]\nfriction = -1\n")
                .find("bad.toml:2:12: key 'point.friction': mu must be finite and >= 0"),
            std::string::npos);
  // A point's error lies in its own table, not in the last point's that sets the key.
  EXPECT_NE(error_of("[system]\nwidth = 12\nheight = 12\n[[point]]\nprotocol = \"C\"\n"
                     "bond_number = \"inf\"\n[[point]]\nbond_number = 100\n")
                .find("bad.toml:6:15: key 'point.bond_number': protocol C with Bo = inf"),
            std::string::npos);
  EXPECT_NE(error_of("[system]\nwidth = 12\nheight = 300\n[[point]]\ntime_step = 0.05\n"
                     "[[point]]\ntime_step = 0.001\n")
                .find("bad.toml:5:13: key 'point.time_step': h = 0.05 is too large for H = 300"),
            std::string::npos);
}

// What the fuzzer (fuzz/fuzz_scan.cpp, scripts/fuzz.sh) found: each input made parse_scan or
// the first consumers of its scan allocate without bound, overflow or hit undefined
// behaviour; each is now a clear error. The inputs are in fuzz/corpus/ too.
TEST(Scan, RejectsWhatTheFuzzerFound) {
  const std::vector<scan_errors::Case> cases = {
      // a range of 2^31 - 1 points: an allocation of 16 GiB
      {"[system]\nbond_number = { from = 1, to = 2, points = 2147483647 }\n",
       "bad.toml:2:44: key 'system.bond_number.points': expected an integer in [1, 100000]"},
      // axes whose grid has 10^6 points
      {"[system]\nfriction = { from = 0, to = 1, points = 1000 }\n"
       "rolling_friction = { from = 0, to = 1, points = 1000 }\n",
       "bad.toml:3:20: key 'system.rolling_friction': this axis makes the grid 1000000 scan "
       "points; at most 100000"},
      // 2 x 10^6 members
      {"[scan]\nseeds = 1000000\n[system]\nbond_number = [0, 1]\n",
       "bad.toml:2:9: key 'scan.seeds': 2 scan points x 1000000 seeds make more than 1000000 "
       "members"},
      // member_capacity overflowed int (undefined behaviour)
      {"[system]\nwidth =922337203685477\n", "bad.toml:2:8: key 'system.width': the system is L_x"},
      {"[system]\nwidth = 1e4\nheight = 2e4\n",
       "bad.toml:3:10: key 'system.height': the system is L_x H / R^2 = 2e+08 > 1e+07"},
      // A small radius makes the area large: it is blamed, not the width beside it.
      {"[system]\nwidth = 300\nradius = 0.05\n",
       "bad.toml:3:10: key 'system.radius': the system is L_x H / R^2 = 1.8e+07 > 1e+07"},
      {"[system]\nradius = 1e-200\n",
       "bad.toml:2:10: key 'system.radius': R must be in [1e-6, 1e6]"},
      {"[system]\nradius = 1e200\nwidth = 4e200\nheight = 4e200\n",
       "key 'system.radius': R must be in [1e-6, 1e6]"},
      // toml++ 3.3.0 reached TOML_UNREACHABLE on U+0262 after a number (marzer/tomlplusplus#190)
      {"[system]\nwidth = [[[[[[[9220\xc9\xa2system]\n",
       "bad.toml:2:20: character U+262 is only allowed in comments and string values"},
      {"s = \"\"\"\\\n\xc2\xa7\"\"\"\n",
       "bad.toml:2:1: character U+A7 is only allowed in comments and string values (toml++ 3.3.0 "
       "mishandles U+00A1..U+0499, U+2C5E..U+2FFF, U+3001..U+3057 and U+FB26..U+FEFE elsewhere; a "
       "multi-line \"\"\" string is no such value, ''' is)"},
      {"[system]\n\"\xce\xbc\" = 0.3\n",
       "bad.toml:2:2: character U+3BC is only allowed in comments and string values"},
      // the first guard missed U+2C5E..U+3057 and U+FB26..U+FC05; the fuzzer found U+FBBB
      {"\xef\xae\xbb@", "bad.toml:1:1: character U+FBBB is only allowed in comments"},
      {"x = 1 \xe3\x81\x82\n", "bad.toml:1:7: character U+3042 is only allowed in comments"},
      // toml++ reads a bare value up to whitespace, ']', '}', ',' or '#', quotes included: a
      // quoted string inside it is no value (the fuzzer found the first one)
      {"[system]\nwth = [[[[[[[922''='0\xc9\xa2system]\n",
       "bad.toml:2:22: character U+262 is only allowed in comments"},
      {"x = 1='\xc9\xa2'\n", "bad.toml:1:8: character U+262 is only allowed in comments"},
      // a line that starts inside an array holds a value, not a key
      {"x = [\n1='\xc9\xa2'\n]\n", "bad.toml:2:4: character U+262 is only allowed in comments"},
  };
  scan_errors::expect_refused(cases);
  // Those characters stay fine in comments and string values.
  const auto scan = parse_scan(
      "# \xce\xbc = 0.3, \xc2\xa7 2\n[scan]\nname = \"d\xc3\xa9p\xc3\xb4t \xe2\x80\x94 t\" "
      "# \xce\xbc\n[system]\nwidth = 30 # \xc2\xb5\n",
      "ok.toml");
  EXPECT_EQ(scan.name, "d\xc3\xa9p\xc3\xb4t \xe2\x80\x94 t");
  EXPECT_EQ(parse_scan("[scan]\nname=\"\xc3\xa9\"\n", "ok.toml").name, "\xc3\xa9");
  EXPECT_EQ(scan.points[0].params.width, 30.0);
}

TEST(Scan, WarnsWhenTheTimeStepDoesNotResolveTheCohesiveBarrier) {
  // sqrt(2 m_n d_c / F_c) = sqrt(0.01 / Bo): 0.01 at Bo = 100, 0.001 at Bo = 1e4.
  const auto scan =
      parse_scan("[system]\ntime_step = 0.005\nbond_number = [0, 100, 1e4]\n", "w.toml");
  ASSERT_EQ(scan.warnings.size(), 1u);
  EXPECT_NE(scan.warnings[0].find("point 2 (Bo = 10000): time_step 0.005 exceeds"),
            std::string::npos)
      << scan.warnings[0];
}

// Protocol A drops its disks with their dynamics: a capture radius other than 1 changes nothing
// there. Its points run with capture_radius = 1 (as the output says), a grid of protocols and
// capture radii keeps one A point instead of repeating it, and the file is told so.
TEST(Scan, ProtocolAPointsRunWithCaptureRadiusOneOnce) {
  const auto scan = parse_scan(
      "[scan]\nprotocol = [\"A\", \"C\"]\n[system]\ncapture_radius = [1, 2, 3]\n", "r.toml");
  ASSERT_EQ(scan.warnings.size(), 1u);
  EXPECT_NE(scan.warnings[0].find("capture_radius acts in protocols B and C only; protocol A "
                                  "runs with capture_radius = 1, and 2 protocol-A points of the "
                                  "grid that differed from another only in it are left out"),
            std::string::npos)
      << scan.warnings[0];
  // [[point]] tables: the one left out is named as a table's, and the numbering said.
  const auto listed = parse_scan(
      "[system]\nwidth = 10.0\nheight = 8.0\n[[point]]\nbond_number = 0\ncapture_radius = 2\n"
      "[[point]]\nbond_number = 100\n[[point]]\nbond_number = 0\ncapture_radius = 3\n",
      "p.toml");
  ASSERT_EQ(listed.points.size(), 2u);
  EXPECT_NE(listed.warnings.at(0).find("1 protocol-A point ([[point]] table) that differed from "
                                       "another only in it is left out (the points are numbered "
                                       "without it)"),
            std::string::npos)
      << listed.warnings.at(0);
  ASSERT_EQ(scan.points.size(), 4u);
  std::vector<std::pair<Protocol, double>> got;
  for (const auto& sp : scan.points) got.emplace_back(sp.protocol, sp.params.capture_radius);
  const std::vector<std::pair<Protocol, double>> want = {
      {Protocol::A, 1.0}, {Protocol::C, 1.0}, {Protocol::C, 2.0}, {Protocol::C, 3.0}};
  EXPECT_EQ(got, want);
  for (std::size_t k = 0; k < scan.points.size(); ++k) EXPECT_EQ(scan.points[k].index, int(k));
  // An A point alone of another capture radius runs at 1, and nothing is left out.
  const auto alone = parse_scan("[system]\ncapture_radius = 2\n", "r.toml");
  ASSERT_EQ(alone.points.size(), 1u);
  EXPECT_EQ(alone.points[0].params.capture_radius, 1.0);
  EXPECT_EQ(alone.warnings.at(0).find("left out"), std::string::npos) << alone.warnings[0];
  EXPECT_TRUE(
      parse_scan("[scan]\nprotocol = [\"B\", \"C\"]\n[system]\ncapture_radius = 2\n", "r.toml")
          .warnings.empty());
}

// The default time step resolves the cohesive barrier at each point's own Bond number:
// 0.9 sqrt(2 m_n d_c / F_c) = 0.9 sqrt(d_c / (Bo g)), at most 0.01; a set time step wins.
TEST(Scan, DefaultTimeStepResolvesTheBarrierAtEachBondNumber) {
  const auto scan = parse_scan(
      "[system]\nwidth = 24\nheight = 24\ncohesion_range = 0.02\n"
      "bond_number = [0, 10, 100, 1e3, 1e4, \"inf\"]\n",
      "h.toml");
  ASSERT_EQ(scan.points.size(), 6u);
  EXPECT_TRUE(scan.warnings.empty());
  for (const auto& sp : scan.points) {
    const double bo = sp.params.bond_number;
    const double expected =
        bo > 0.0 && std::isfinite(bo) ? std::min(0.01, 0.9 * std::sqrt(0.02 / bo)) : 0.01;
    EXPECT_DOUBLE_EQ(sp.params.time_step, expected) << "Bo = " << bo;
  }
  EXPECT_LT(scan.points[3].params.time_step, 0.01);  // Bo = 1e3: 0.9 sqrt(2e-5)
  // Explicit points take the default at their own Bond number unless they or [system] set h.
  const auto pts = parse_scan(
      "[system]\nwidth = 24\nheight = 24\n"
      "[[point]]\nbond_number = 1e4\n"
      "[[point]]\nbond_number = 1e4\ntime_step = 5e-4\n",
      "p.toml");
  EXPECT_DOUBLE_EQ(pts.points[0].params.time_step, 0.9 * std::sqrt(0.01 / 1e4));
  EXPECT_EQ(pts.points[1].params.time_step, 5e-4);
  const auto set = parse_scan(
      "[system]\nwidth = 24\nheight = 24\ntime_step = 0.002\n"
      "[[point]]\nbond_number = 1e4\n",
      "s.toml");
  EXPECT_EQ(set.points[0].params.time_step, 0.002);
  // A system built in C++ from the defaults resolves the barrier too: Bo = 1e3, d_c = 0.01.
  EXPECT_DOUBLE_EQ(SystemParams{}.time_step, 0.9 * std::sqrt(0.01 / 1e3));
  EXPECT_DOUBLE_EQ(SystemParams{}.time_step,
                   parse_scan("[scan]\nprotocol = \"A\"\n", "e.toml").points[0].params.time_step);
}

// Every box runs with the defaults: the observables' lengths are the paper's where they fit
// the box (nu_lower_half from 50 R; cuts of 20 R) and min(50, H/4), min(20, H/6) below; a
// value the file sets holds (and is refused where it does not fit).
TEST(Scan, ObservableLengthsFollowTheBoxUnlessSet) {
  const auto scan = parse_scan("[scan]\nseeds = 2\n[system]\nwidth = 24\nheight = 24\n", "d.toml");
  EXPECT_TRUE(scan.warnings.empty());
  const auto& obs = scan.observables;
  EXPECT_EQ(obs.lower_half_from_at(24.0), 6.0);
  EXPECT_EQ(obs.cut_bottom_at(24.0), 4.0);
  EXPECT_EQ(obs.cut_top_at(24.0), 4.0);
  EXPECT_EQ(obs.lower_half_from_at(800.0), 50.0);
  EXPECT_EQ(obs.cut_top_at(800.0), 20.0);
  const auto set = parse_scan(
      "[system]\nwidth = 24\nheight = 24\n[observables]\nlower_half_from = 2\ncut_top = 1\n",
      "s.toml");
  EXPECT_EQ(set.observables.lower_half_from_at(24.0), 2.0);
  EXPECT_EQ(set.observables.cut_top_at(24.0), 1.0);
  EXPECT_EQ(set.observables.cut_bottom_at(24.0), 4.0);
  const std::string err =
      error_of("[system]\nwidth = 24\nheight = 24\n[observables]\nlower_half_from = 50\n");
  EXPECT_NE(err.find("bad.toml:5:19: key 'observables.lower_half_from'"), std::string::npos) << err;
}

// Jacobi without mass splitting diverges at a relaxation above 0.5: the scan is valid (its
// members would fail, not the run) but warned of.
TEST(Scan, WarnsOfJacobiWithoutMassSplittingAtLargeRelaxation) {
  const std::string base =
      "[system]\nwidth = 12\nheight = 12\n[solver]\nkind = \"jacobi\"\nmass_splitting = false\n";
  const auto loud = parse_scan(base + "relaxation = 1.0\n", "j.toml");
  ASSERT_EQ(loud.warnings.size(), 1u);
  EXPECT_NE(loud.warnings[0].find("without mass splitting diverges"), std::string::npos);
  EXPECT_TRUE(parse_scan(base + "relaxation = 0.5\n", "j.toml").warnings.empty());
  // With another solver the setting does nothing, and the file is told so.
  const auto other = parse_scan("[solver]\nmass_splitting = false\n", "j.toml");
  ASSERT_EQ(other.warnings.size(), 1u);
  EXPECT_NE(other.warnings[0].find("mass_splitting acts in the Jacobi solver only"),
            std::string::npos);
}

// Every scan file shipped in examples/ (the default job, the paper's figures) is valid.
TEST(Scan, EveryExampleScanFileIsValid) {
  namespace fs = std::filesystem;
  const fs::path root = fs::path(LOOSEPACK_SOURCE_DIR) / "examples";
  int checked = 0;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    if (e.path().extension() != ".toml") continue;
    SCOPED_TRACE(e.path().string());
    Scan scan;
    EXPECT_NO_THROW(scan = load_scan(e.path().string()));
    EXPECT_GT(scan.members(), 0);
    ++checked;
  }
  EXPECT_GE(checked, 20);
}

namespace {
// The keys docs/SCAN.md documents, as "section.key": the backquoted names in the first column
// of its tables, under a heading "## `[section]`", or written "section.key" (a bare name after
// one in the same cell, as in "`observables.cut_bottom`, `cut_top`", is of the same section).
std::set<std::string> documented_keys() {
  std::ifstream in(std::string(LOOSEPACK_SOURCE_DIR) + "/docs/SCAN.md");
  EXPECT_TRUE(in) << "docs/SCAN.md not found";
  const std::regex heading(R"(^## `\[([a-z_]+)\]`)"), name("`([a-z_.]+)`");
  std::set<std::string> keys;
  std::string line, section;
  while (std::getline(in, line)) {
    std::smatch m;
    if (line.rfind("## ", 0) == 0) section = std::regex_search(line, m, heading) ? m[1].str() : "";
    if (line.rfind("| `", 0) != 0) continue;
    const std::string cell = line.substr(1, line.find('|', 1) - 1);
    std::string cell_section = section;
    for (auto it = std::sregex_iterator(cell.begin(), cell.end(), name);
         it != std::sregex_iterator(); ++it) {
      const std::string n = (*it)[1];
      const auto dot = n.find('.');
      if (dot != std::string::npos) cell_section = n.substr(0, dot);
      keys.insert(dot != std::string::npos ? n : cell_section + "." + n);
    }
  }
  return keys;
}
}  // namespace

// docs/SCAN.md documents exactly the keys the parser takes: a key added to the settings table
// (include/loosepack/settings.hpp) or to [scan] or [system] and not to the docs fails here.
TEST(Scan, DocsListEveryKeyAndNoOther) {
  const auto keys = scan_file_keys();
  const std::set<std::string> parsed(keys.begin(), keys.end());
  EXPECT_EQ(parsed.size(), keys.size()) << "a key listed twice";
  EXPECT_EQ(documented_keys(), parsed);
}

// Values of the row's range other than `v`, nearest first: a quarter more or less (one more or
// less for an integer), then values a check across settings may need (a region radius of at
// least 5 R), then the range's ends.
namespace {
std::vector<double> other_values(const SettingKey& row, double v) {
  const bool integer = row.type == SettingKey::Type::Integer;
  std::vector<double> out;
  for (double w :
       {integer ? v + 1.0 : 1.25 * v, integer ? v - 1.0 : 0.8 * v, 0.5, 8.0, row.lo, row.hi})
    if (w >= row.lo && w <= row.hi && w != v && (!integer || w == std::floor(w))) out.push_back(w);
  return out;
}
}  // namespace

// Every row of the settings table carries a value other than its default into the scan, is
// refused just outside its range at either end with the range in the message, and names every
// key of its section when a key is unknown.
TEST(Scan, SettingsTableDrivesParsingAndErrors) {
  const Scan defaults;
  for (const auto& row : setting_keys()) {
    SCOPED_TRACE(std::string(row.section) + "." + row.key);
    if (row.type == SettingKey::Type::Real || row.type == SettingKey::Type::Integer) {
      // A value in range other than the default reaches the scan through the row's setter (the
      // first of other_values that the checks across settings accept).
      bool set = false;
      for (double value : other_values(row, row.get(defaults))) {
        std::ostringstream ok;
        ok.precision(17);
        ok << "[" << row.section << "]\n";
        if (std::string(row.key) == "sweeps_per_launch")  // the team solver's alone
          ok << "kind = \"coloured_accelerated_gauss_seidel\"\n";
        ok << row.key << " = ";
        if (row.type == SettingKey::Type::Integer)
          ok << static_cast<long>(value) << "\n";
        else
          ok << value << "\n";
        try {
          EXPECT_EQ(row.get(parse_scan(ok.str(), "ok.toml")), value);
          set = true;
          break;
        } catch (const ScanError&) {
        }
      }
      EXPECT_TRUE(set);
      // Below the range and above it: refused, naming the key, the range, its unit and what
      // the key means.
      const bool integer = row.type == SettingKey::Type::Integer;
      for (double outside : {row.lo - 1.0, 2.0 * row.hi + 1.0}) {
        std::ostringstream text;
        text << "[" << row.section << "]\n" << row.key << " = ";
        if (integer)
          text << static_cast<long>(outside) << "\n";
        else
          text << std::to_string(outside) << "\n";
        const std::string error = error_of(text.str());
        EXPECT_NE(error.find(std::string("key '") + row.section + "." + row.key + "'"),
                  std::string::npos)
            << error;
        EXPECT_NE(error.find(integer ? "expected an integer in [" : "outside the allowed range ["),
                  std::string::npos)
            << error;
        EXPECT_NE(
            error.find(std::string("] ") + row.unit + (*row.unit ? " (" : "(") + row.meaning + ")"),
            std::string::npos)
            << error;
      }
    }
  }
  for (const std::string section : {"solver", "rest", "protocol", "observables"}) {
    const std::string error = error_of("[" + section + "]\nno_such_key = 1\n");
    for (const auto& k : setting_keys_of(section))
      EXPECT_NE(error.find(k), std::string::npos) << section << ": " << error;
  }
}
