// The settings sections of a scan file ([solver], [rest], [protocol], [observables]) as one
// table: each row is a key with its member of Scan, allowed range, unit and meaning, and drives
// the parser and its validation (src/scan.cpp; a value out of range is refused with the range,
// the unit and the meaning), the list of allowed keys in its error messages,
// the output's /settings attributes (src/output.cpp) and the check that docs/SCAN.md lists every
// key of the scan file (tests/test_scan.cpp). A new setting is one row here, plus its member
// and its line in docs/SCAN.md.
#pragma once
#include <string>
#include <vector>

#include "loosepack/scan.hpp"

namespace loosepack {

struct SettingKey {
  enum class Type { Real, Integer, Bool, Choice };
  const char* section;  // "solver"
  const char* key;      // "tolerance": the scan file's solver.tolerance
  Type type;
  double lo, hi;          // the allowed range of a Real or Integer
  const char* unit;       // "" where dimensionless or a count
  const char* meaning;    // one line
  const char* attribute;  // its attribute in the output's /settings group
  // The value on a scan (a Bool as 0 or 1; a Choice through name/set_name instead).
  double (*get)(const Scan&);
  void (*set)(Scan&, double);
  // Choice keys: the allowed names, the scan's, and setting it by name (false: no such name).
  std::vector<std::string> (*choices)();
  std::string (*name)(const Scan&);
  bool (*set_name)(Scan&, const std::string&);
  // Where not null: a check beyond the range ("" when valid), and whether the value is stored
  // (solver.tolerance, max_sweeps, newton_every and the observables' lengths only where the
  // file sets them: else each member's default holds, by protocol, box, Bond number or height,
  // and that is not one number).
  std::string (*check)(const Scan&);
  bool (*stored)(const Scan&);
  // A setting of how a run goes that no member's result depends on (solver.sweeps_per_launch):
  // left out of the scan's identity (Scan::content), so a run resumes and shards merge across it.
  bool changes_no_result = false;
};

// Every row, section by section, in the order the error messages list the keys.
const std::vector<SettingKey>& setting_keys();
// Whether `section` is one of the table's sections; the keys of one, in order.
bool is_setting_section(const std::string& section);
std::vector<std::string> setting_keys_of(const std::string& section);

// Every key a scan file may set, as "section.key" ("scan.seeds", "system.width",
// "solver.tolerance", ...), for the docs check.
std::vector<std::string> scan_file_keys();

}  // namespace loosepack
