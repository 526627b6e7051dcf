// The table of the scan file's settings sections (include/loosepack/settings.hpp).
#include "loosepack/settings.hpp"

#include <algorithm>

namespace loosepack {

namespace {

using Type = SettingKey::Type;

// A row of a Real, Integer or Bool key stored in the Scan member `field`.
#define LOOSEPACK_FIELD(field)                                                                  \
  [](const Scan& s) { return static_cast<double>(s.field); },                                   \
      [](Scan& s, double v) { s.field = static_cast<decltype(s.field)>(v); }, nullptr, nullptr, \
      nullptr

// A row of a key whose value the program chooses unless the file sets it (per protocol, box,
// Bond number or height): the Scan member `field`, its flag `given` set where the file sets it,
// and stored in /settings only then (each point stores the value it used).
#define LOOSEPACK_GIVEN_FIELD(field, given)                   \
  [](const Scan& s) { return static_cast<double>(s.field); }, \
      [](Scan& s, double v) {                                 \
        s.field = static_cast<decltype(s.field)>(v);          \
        s.given = true;                                       \
      },                                                      \
      nullptr, nullptr, nullptr, nullptr, [](const Scan& s) { return s.given; }

// The upper end of a range that bounds nothing in practice.
constexpr double kLarge = 1e9;

// [solver]
std::vector<SettingKey> solver_keys() {
  return {
      {"solver", "kind", Type::Choice, 0, 0, "", "the contact solver", "solver_kind", nullptr,
       nullptr,
       [] {
         std::vector<std::string> names;
         for (SolverKind k : kSolverKinds) names.emplace_back(solver_kind_name(k));
         return names;
       },
       [](const Scan& s) { return std::string(solver_kind_name(s.solver.kind)); },
       [](Scan& s, const std::string& n) {
         s.solver_kind_given = solver_kind_from_name(n, s.solver.kind);
         return s.solver_kind_given;
       },
       nullptr, nullptr},
      {"solver", "tolerance", Type::Real, 1e-14, 1.0, "h m g",
       "largest impulse change of a converged sweep", "solver_tolerance",
       LOOSEPACK_GIVEN_FIELD(solver.tolerance, tolerance_given)},
      {"solver", "relative_tolerance", Type::Real, 0.0, 1.0, "",
       "kappa: the step's tolerance is max(tolerance, kappa v_max / (g max(h, 0.0028)))",
       "solver_relative_tolerance", LOOSEPACK_FIELD(solver.relative_tolerance), nullptr, nullptr},
      {"solver", "max_sweeps", Type::Integer, 1, 1e8, "", "sweeps per step at most",
       "solver_max_sweeps", LOOSEPACK_GIVEN_FIELD(solver.max_sweeps, max_sweeps_given)},
      {"solver", "relaxation", Type::Real, 0.01, 1.95, "", "omega: P <- P + omega (P_local - P)",
       "solver_relaxation", LOOSEPACK_FIELD(solver.relaxation), nullptr, nullptr},
      {"solver", "mass_splitting", Type::Bool, 0, 1, "", "Jacobi: mass split over contacts",
       "solver_mass_splitting", LOOSEPACK_FIELD(solver.mass_splitting), nullptr, nullptr},
      {"solver", "newton_every", Type::Integer, 0, 1e8, "iterations",
       "a Newton step after this many unconverged iterations (0: none; unset: by Bond number)",
       "solver_newton_every", LOOSEPACK_GIVEN_FIELD(solver.newton_every, newton_every_given)},
      {"solver", "team_size", Type::Integer, 0, 1024, "threads",
       "the team solver's and the fused step's threads per system (0: the backend's choice)",
       "solver_team_size", LOOSEPACK_FIELD(solver.team_size), nullptr, nullptr},
      {"solver", "sweeps_per_launch", Type::Integer, 0, 1e8, "sweeps",
       "coloured_accelerated_gauss_seidel: sweeps per launch of the solve (0: the whole solve; "
       "unset: the backend's)",
       "solver_sweeps_per_launch",
       [](const Scan& s) { return static_cast<double>(s.solver.sweeps_per_launch); },
       [](Scan& s, double v) {
         s.solver.sweeps_per_launch = static_cast<int>(v);
         s.sweeps_per_launch_given = true;
       },
       nullptr, nullptr, nullptr, nullptr, nullptr, /*changes_no_result=*/true},
      {"solver", "fused_step", Type::Bool, 0, 1, "",
       "every stage of a system's step in its own team: one launch a step (the same results; "
       "unset: the backend's)",
       "solver_fused_step", [](const Scan& s) { return s.solver.fused_step ? 1.0 : 0.0; },
       [](Scan& s, double v) {
         s.solver.fused_step = v != 0.0;
         s.fused_step_given = true;
       },
       nullptr, nullptr, nullptr, nullptr, nullptr, /*changes_no_result=*/true},
      {"solver", "overlap_correction", Type::Real, 0.0, 1.0, "",
       "beta: fraction of every overlap removed per step", "solver_overlap_correction",
       LOOSEPACK_FIELD(solver.overlap_correction), nullptr, nullptr},
  };
}

// [rest]
std::vector<SettingKey> rest_keys() {
  return {
      {"rest", "speed", Type::Real, 1e-12, 1.0, "sqrt(g R)", "at rest below this speed",
       "rest_speed", LOOSEPACK_FIELD(rest.speed), nullptr, nullptr},
      {"rest", "steps", Type::Integer, 1, 1e6, "steps", "at rest for this many steps in a row",
       "rest_steps", LOOSEPACK_FIELD(rest.steps), nullptr, nullptr},
      {"rest", "converged", Type::Bool, 0, 1, "", "rest needs converged solves", "rest_converged",
       LOOSEPACK_FIELD(rest.converged), nullptr, nullptr},
      {"rest", "average_span", Type::Real, 0.0, 1e4, "sqrt(R/g)",
       "C: at rest also when positions averaged over such spans move slower than rest.speed",
       "rest_average_span", LOOSEPACK_FIELD(rest.average_span), nullptr, nullptr},
  };
}

// [protocol]
std::vector<SettingKey> protocol_keys() {
  return {
      {"protocol", "max_relax_time", Type::Real, 1e-3, kLarge, "sqrt(R/g)",
       "A: relaxation after one disk capped here", "max_relax_time",
       LOOSEPACK_FIELD(protocol.max_relax_time), nullptr, nullptr},
      {"protocol", "max_collapse_time", Type::Real, 1e-3, kLarge, "sqrt(R/g)",
       "C: collapse capped here", "max_collapse_time", LOOSEPACK_FIELD(protocol.max_collapse_time),
       nullptr, nullptr},
      {"protocol", "max_unconverged_time", Type::Real, 1e-3, kLarge, "sqrt(R/g)",
       "a member capped this long in a row fails", "max_unconverged_time",
       LOOSEPACK_FIELD(protocol.max_unconverged_time), nullptr, nullptr},
      {"protocol", "region_radius", Type::Real, 0.0, 1e6, "R",
       "A: relaxation regions of this radius (0: none)", "region_radius",
       [](const Scan& s) { return s.protocol.region_radius; },
       [](Scan& s, double v) { s.protocol.region_radius = v; }, nullptr, nullptr, nullptr,
       [](const Scan& s) {
         const double r = s.protocol.region_radius;
         return r > 0.0 && r < 5.0
                    ? std::string(
                          "must be 0 (no regions) or at least 5 (in the file's length unit)")
                    : std::string();
       },
       nullptr},
      {"protocol", "region_check_every", Type::Integer, 1, 1e6, "disks",
       "A with regions: the whole system checked after every k-th disk", "region_check_every",
       LOOSEPACK_FIELD(protocol.region_check_every), nullptr, nullptr},
      {"protocol", "region_max_disks", Type::Integer, 10, 1e7, "disks",
       "a larger region relaxes in the whole system", "region_max_disks",
       LOOSEPACK_FIELD(protocol.region_max_disks), nullptr, nullptr},
      {"protocol", "stop_rule", Type::Choice, 0, 0, "",
       "A: deposition stops at the first drop over H, or when no drop lands below H", "stop_rule",
       nullptr, nullptr,
       [] {
         std::vector<std::string> names;
         for (StopRule r : kStopRules) names.emplace_back(stop_rule_name(r));
         return names;
       },
       [](const Scan& s) { return std::string(stop_rule_name(s.protocol.stop_rule)); },
       [](Scan& s, const std::string& n) {
         for (StopRule r : kStopRules)
           if (n == stop_rule_name(r)) {
             s.protocol.stop_rule = r;
             return true;
           }
         return false;
       },
       nullptr, nullptr},
  };
}

// [observables]
std::vector<SettingKey> observables_keys() {
  return {
      {"observables", "strip_width", Type::Real, 1e-3, 1e6, "R", "nu(y) strip width", "strip_width",
       LOOSEPACK_FIELD(observables.strip_width), nullptr, nullptr},
      {"observables", "lower_half_from", Type::Real, 0.0, kLarge, "R",
       "nu_lower_half from this height to H/2", "lower_half_from",
       LOOSEPACK_GIVEN_FIELD(observables.lower_half_from, observables.lower_half_from_given)},
      {"observables", "bin_width", Type::Real, 1e-3, 1e6, "R", "avalanche profile bins",
       "bin_width", LOOSEPACK_FIELD(observables.bin_width), nullptr, nullptr},
      {"observables", "abs_dy_bin", Type::Real, 1e-3, 1e6, "R", "|Delta y| histogram bin",
       "abs_dy_bin", LOOSEPACK_FIELD(observables.abs_dy_bin), nullptr, nullptr},
      {"observables", "cut_bottom", Type::Real, 0.0, kLarge, "R",
       "the cut histogram leaves out this much at the bottom", "cut_bottom",
       LOOSEPACK_GIVEN_FIELD(observables.cut_bottom, observables.cut_bottom_given)},
      {"observables", "cut_top", Type::Real, 0.0, kLarge, "R",
       "... and at the top of the final deposit", "cut_top",
       LOOSEPACK_GIVEN_FIELD(observables.cut_top, observables.cut_top_given)},
      {"observables", "event_threshold", Type::Real, 0.0, kLarge, "R",
       "a disk moved in an avalanche beyond this", "event_threshold",
       LOOSEPACK_FIELD(observables.event_threshold), nullptr, nullptr},
      {"observables", "trajectory_every", Type::Integer, 0, 1e6, "disks",
       "the trajectory of every k-th disk (0: none)", "trajectory_every",
       LOOSEPACK_FIELD(observables.trajectory_every), nullptr, nullptr},
      {"observables", "trajectory_interval", Type::Integer, 1, 1e8, "steps",
       "C: steps between trajectory samples", "trajectory_interval",
       LOOSEPACK_FIELD(observables.trajectory_interval), nullptr, nullptr},
  };
}

// Every row, section by section.
std::vector<SettingKey> make_table() {
  std::vector<SettingKey> table;
  for (auto section : {solver_keys(), rest_keys(), protocol_keys(), observables_keys()})
    table.insert(table.end(), section.begin(), section.end());
  return table;
}

#undef LOOSEPACK_FIELD
#undef LOOSEPACK_GIVEN_FIELD

}  // namespace

const std::vector<SettingKey>& setting_keys() {
  static const std::vector<SettingKey> table = make_table();
  return table;
}

bool is_setting_section(const std::string& section) {
  const auto& t = setting_keys();
  return std::any_of(t.begin(), t.end(), [&](const SettingKey& k) { return section == k.section; });
}

std::vector<std::string> setting_keys_of(const std::string& section) {
  std::vector<std::string> keys;
  for (const auto& k : setting_keys())
    if (section == k.section) keys.emplace_back(k.key);
  return keys;
}

}  // namespace loosepack
