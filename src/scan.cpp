// Scan files: parsing with toml++, validation of every key before any work, expansion of the
// axes into scan points.
#include "loosepack/scan.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#define TOML_EXCEPTIONS 1
#include <toml++/toml.h>

#include "loosepack/geometry.hpp"
#include "loosepack/settings.hpp"

namespace loosepack {

std::string protocol_name(Protocol p) {
  switch (p) {
    case Protocol::A:
      return "A";
    case Protocol::B:
      return "B";
    case Protocol::C:
      return "C";
  }
  return "?";
}

bool protocol_from_name(const std::string& name, Protocol& p) {
  for (Protocol q : {Protocol::A, Protocol::B, Protocol::C})
    if (name == protocol_name(q)) {
      p = q;
      return true;
    }
  return false;
}

namespace {

// Bounds that keep a valid scan's first consumers (members_of, member_capacity, the batch
// allocation) within int and memory; far beyond any useful scan (fuzz/, docs/SCAN.md).
constexpr long kMaxPoints = 100000;    // scan points of a scan (grid or [[point]] tables)
constexpr long kMaxMembers = 1000000;  // scan points x seeds
constexpr double kMaxArea = 1e7;       // L_x H / R^2 of one system (about 3e6 disks)

std::string where(const std::string& file, const toml::source_region& src) {
  std::ostringstream o;
  o << file << ":" << src.begin.line << ":" << src.begin.column;
  return o.str();
}

[[noreturn]] void fail(const std::string& file, const toml::node& node, const std::string& key,
                       const std::string& what) {
  throw ScanError(where(file, node.source()) + ": key '" + key + "': " + what);
}

// C0 and DEL, and the C1 controls U+0080 to U+009F (in UTF-8 0xC2 0x80 to 0xC2 0x9F), which a
// terminal may take as commands.
bool has_control_character(const std::string& s) {
  for (std::size_t k = 0; k < s.size(); ++k) {
    const auto u = static_cast<unsigned char>(s[k]);
    if (u < 0x20 || u == 0x7f) return true;
    if (u == 0xc2 && k + 1 < s.size() && static_cast<unsigned char>(s[k + 1]) < 0xa0 &&
        static_cast<unsigned char>(s[k + 1]) >= 0x80)
      return true;
  }
  return false;
}

std::string format_number(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

// Whether a node holds a value anywhere: a section or [[point]] header alone sets nothing (an empty
// list is a value, which its key's check refuses).
bool sets_a_value(const toml::node& node) {
  if (auto t = node.as_table())
    return std::any_of(t->begin(), t->end(),
                       [](const auto& kv) { return sets_a_value(kv.second); });
  if (auto a = node.as_array())
    return a->empty() ||
           std::any_of(a->begin(), a->end(), [](const toml::node& e) { return sets_a_value(e); });
  return true;
}

// A number: integer, float, or the strings "inf" / "infinity" (which the key's own check refuses
// where it must be finite); nan is none. `must`: what the key's values must be (a system key's
// range, which says where "inf" is one), told with the type error.
double as_number(const std::string& file, const toml::node& node, const std::string& key,
                 const std::string& must = "") {
  if (auto v = node.as_floating_point()) {
    if (std::isnan(v->get())) fail(file, node, key, "nan is not a value");
    return v->get();
  }
  if (auto v = node.as_integer()) return static_cast<double>(v->get());
  if (auto v = node.as_string()) {
    if (v->get() == "inf" || v->get() == "infinity") return INFINITY;
  }
  fail(file, node, key, "expected a number" + (must.empty() ? "" : ": " + must));
}

bool as_bool(const std::string& file, const toml::node& node, const std::string& key) {
  if (auto v = node.as_boolean()) return v->get();
  fail(file, node, key, "expected true or false");
}

// The value at fraction f of a logarithmic range: spaced evenly in log10, and exactly a power
// of ten where the exponent is a whole number (1e2 is 100, not 100.00000000000004), so that
// `bond_number == 100` finds it and each decade of a scan is exact.
double log_range_value(double from, double to, double f) {
  const double e = std::log10(from) + f * (std::log10(to) - std::log10(from));
  const double whole = std::round(e);
  return std::abs(e - whole) < 1e-9 ? std::pow(10.0, whole) : std::pow(10.0, e);
}

// A scalar, an array of values, or a range table {from, to, points[, log]} (+ also = [...]);
// `must` as as_number's.
std::vector<double> as_axis(const std::string& file, const toml::node& node, const std::string& key,
                            const std::string& must) {
  std::vector<double> out;
  if (auto arr = node.as_array()) {
    if (arr->empty()) fail(file, node, key, "an axis needs at least one value");
    std::set<double> seen;
    for (const auto& e : *arr) {
      const double v = as_number(file, e, key, must);
      // The same value twice would make two scan points of one set of parameters.
      if (!seen.insert(v).second)
        fail(file, e, key, "the value " + format_number(v) + " is already in this axis");
      out.push_back(v);
    }
    return out;
  }
  if (auto tbl = node.as_table()) {
    double from = NAN, to = NAN;
    int points = 0;
    bool log = false;
    for (const auto& [k, v] : *tbl) {
      const std::string kk(k.str());
      if (kk == "from") {
        from = as_number(file, v, key + ".from", must);
      } else if (kk == "to") {
        to = as_number(file, v, key + ".to", must);
      } else if (kk == "points") {
        auto i = v.as_integer();
        if (!i || i->get() < 1 || i->get() > kMaxPoints)
          fail(file, v, key + ".points",
               "expected an integer in [1, " + std::to_string(kMaxPoints) + "]");
        points = static_cast<int>(i->get());
      } else if (kk == "log") {
        log = as_bool(file, v, key + ".log");
      } else if (kk == "also") {
        auto arr = v.as_array();
        if (!arr) fail(file, v, key + ".also", "expected an array of values");
        for (const auto& e : *arr) out.push_back(as_number(file, e, key + ".also", must));
      } else {
        fail(file, v, key + "." + kk,
             "unknown key in a range (allowed: from, to, points, log, also)");
      }
    }
    if (std::isnan(from) || std::isnan(to) || points == 0)
      fail(file, node, key, "a range needs from, to and points");
    if (log && !(from > 0.0 && to > 0.0 && std::isfinite(from) && std::isfinite(to)))
      fail(file, node, key, "a logarithmic range needs finite positive from and to");
    // Ranges that would silently give fewer values than they say.
    if (points == 1 && from != to)
      fail(file, node, key, "points = 1 gives `from` alone: set points >= 2 to reach `to`");
    if (points > 1 && from == to)
      fail(file, node, key,
           "from equals to: the range is one value, not " + std::to_string(points));
    if (!log && !(std::isfinite(from) && std::isfinite(to)))
      fail(file, node, key,
           "a linear range needs finite from and to (list \"inf\" in `also` to add it)");
    std::set<double> range;
    for (int k = 0; k < points; ++k) {
      const double f = points == 1 ? 0.0 : static_cast<double>(k) / (points - 1);
      range.insert(log ? log_range_value(from, to, f) : from + f * (to - from));
    }
    if (static_cast<int>(range.size()) < points)
      fail(file, node, key,
           "from and to lie too close for " + std::to_string(points) +
               " distinct points (they give " + std::to_string(range.size()) + ")");
    out.insert(out.end(), range.begin(), range.end());
    // The `also` values merged in order, each value once.
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }
  return {as_number(file, node, key, must)};
}

struct SystemKey {
  const char* name;
  std::function<void(SystemParams&, double)> set;
  std::function<std::string(const SystemParams&)> check;  // empty when valid
};

const std::vector<SystemKey>& system_keys() {
  static const std::vector<SystemKey> keys = {
      {"width", [](SystemParams& p, double v) { p.width = v; },
       // No pair of disks may reach round the periodic box both ways: a contact is kept with
       // the nearest image alone (kernels/contacts.hpp).
       [](const SystemParams& p) {
         const bool ok = p.width >= smallest_width(p) && std::isfinite(p.width);
         return ok ? ""
                   : "L_x must be finite and >= 2 (2 R_max + d_c), here " +
                         format_number(smallest_width(p));
       }},
      {"height", [](SystemParams& p, double v) { p.height = v; },
       [](const SystemParams& p) {
         const bool ok = p.height >= 4.0 * p.radius && std::isfinite(p.height);
         return ok ? "" : "H must be finite and >= 4 R";
       }},
      {"radius", [](SystemParams& p, double v) { p.radius = v; },
       [](const SystemParams& p) {
         return p.radius >= 1e-6 && p.radius <= 1e6 ? "" : "R must be in [1e-6, 1e6]";
       }},
      {"polydispersity", [](SystemParams& p, double v) { p.polydispersity = v; },
       [](const SystemParams& p) {
         return p.polydispersity >= 0.0 && p.polydispersity <= 0.3
                    ? ""
                    : "sigma_R/R must be in [0, 0.3] (radii stay positive and contacts per "
                      "disk bounded)";
       }},
      {"bond_number", [](SystemParams& p, double v) { p.bond_number = v; },
       [](const SystemParams& p) {
         return (p.bond_number >= 0.0 && p.bond_number <= 1e8) ||
                        (std::isinf(p.bond_number) && p.bond_number > 0.0)
                    ? ""
                    : "Bo must be 0, in (0, 1e8], or \"inf\" (the solver's tolerance, in units of "
                      "the weight m g, must stay far above the rounding of cohesive impulses, "
                      "Bo x 2.2e-16; docs/MODEL.md, supported ranges)";
       }},
      {"cohesion_range", [](SystemParams& p, double v) { p.cohesion_range = v; },
       [](const SystemParams& p) {
         return p.cohesion_range > 0.0 && p.cohesion_range <= 0.5 * p.radius
                    ? ""
                    : "d_c must be in (0, R/2]";
       }},
      {"friction", [](SystemParams& p, double v) { p.friction = v; },
       [](const SystemParams& p) {
         return p.friction >= 0.0 && std::isfinite(p.friction) ? "" : "mu must be finite and >= 0";
       }},
      {"rolling_friction", [](SystemParams& p, double v) { p.rolling_friction = v; },
       [](const SystemParams& p) {
         return p.rolling_friction >= 0.0 && std::isfinite(p.rolling_friction)
                    ? ""
                    : "mu_r must be finite and >= 0";
       }},
      {"time_step", [](SystemParams& p, double v) { p.time_step = v; },
       [](const SystemParams& p) {
         return p.time_step > 0.0 && p.time_step <= 0.1
                    ? ""
                    : "h must be in (0, 0.1] sqrt(R/g) (and small enough for the height: "
                      "docs/MODEL.md, supported ranges)";
       }},
      {"capture_radius", [](SystemParams& p, double v) { p.capture_radius = v; },
       [](const SystemParams& p) {
         return p.capture_radius >= 1.0 && p.capture_radius <= 10.0 ? ""
                                                                    : "r_capt must be in [1, 10]";
       }},
      {"floor_cohesion", [](SystemParams& p, double v) { p.floor_cohesion = v != 0.0; },
       [](const SystemParams&) { return std::string(); }},
  };
  return keys;
}

// What a system key's values must be: its check's message for a value that is none (nan).
std::string value_range(const SystemKey& sk) {
  SystemParams p;
  sk.set(p, NAN);
  return sk.check(p);
}

// The system key `name`, or nullptr.
const SystemKey* system_key(const std::string& name) {
  for (const auto& sk : system_keys())
    if (name == sk.name) return &sk;
  return nullptr;
}

template <class F>
void for_each_key(const toml::table& tbl, F f) {
  for (const auto& [k, v] : tbl) f(std::string(k.str()), v);
}

// toml++ 3.3.0 (Debian's) reaches TOML_UNREACHABLE, undefined behaviour, when it asks whether
// a character of kUnsafe is whitespace (marzer/tomlplusplus#190, #295; the ranges are the blocks
// of its is_non_ascii_horizontal_whitespace() without a case, less U+00A0, U+3000, U+FEFF),
// which it does anywhere outside a comment or a string value: in keys, after values, between
// tokens, after a line-ending backslash. Refuse them there before parsing. Comments and
// strings are tracked as TOML lexes them; a string counts as a value only when it follows '='
// and is not a multi-line basic string (whose line-ending backslash is one of those places).
// A bare token (a key, a number, a date, a boolean) is read as toml++ reads a value: up to
// whitespace, ']', '}', ',' or '#', quotes included (those strings are not values); only a key
// at the start of a line outside an array also ends at '='. Where this lexer and toml++ could
// disagree (invalid TOML) it errs towards refusing, and UTF-8 is decoded leniently (overlong
// forms too), again refusing a superset.
constexpr char32_t kUnsafe[][2] = {
    {0xA1, 0x499}, {0x2C5E, 0x2FFF}, {0x3001, 0x3057}, {0xFB26, 0xFEFE}};

// The UTF-8 character of `text` at byte i: its code point and bytes, or malformed (a byte that
// starts no sequence, or a sequence cut short).
struct Utf8Char {
  char32_t c;
  std::size_t bytes;
  bool malformed;
};
Utf8Char utf8_at(const std::string& text, std::size_t i) {
  const auto b = static_cast<unsigned char>(text[i]);
  const std::size_t n = b < 0x80 ? 1 : b >= 0xF0 ? 4 : b >= 0xE0 ? 3 : b >= 0xC0 ? 2 : 1;
  char32_t c = n == 1 ? b : n == 2 ? b & 0x1F : n == 3 ? b & 0x0F : b & 0x07;
  bool malformed = b >= 0x80 && (b < 0xC0 || b >= 0xF8);
  for (std::size_t k = 1; k < n && !malformed; ++k) {
    malformed = i + k >= text.size() || (static_cast<unsigned char>(text[i + k]) & 0xC0) != 0x80;
    if (!malformed) c = (c << 6) | (static_cast<unsigned char>(text[i + k]) & 0x3F);
  }
  return {c, n, malformed};
}

// Where in TOML's lexical structure a scan file's characters fall, as far as the check of kUnsafe
// needs (the rules above): end_bare_token() before a character is judged, safe() whether any
// character may stand there, advance() past it (it returns the bytes taken: 3 for a triple quote).
class TomlPlaces {
 public:
  enum State { Outside, Bare, Comment, Basic, Literal, MultiBasic, MultiLiteral };
  State state = Outside;

  void end_bare_token(char32_t c) {
    if (state == Bare && (c == ' ' || c == '\t' || c == '\n' || c == ']' || c == '}' || c == ',' ||
                          c == '#' || (key_ && c == '=')))
      state = Outside;
  }
  bool safe() const {
    return state == Comment || (value_ && state != Outside && state != Bare && state != MultiBasic);
  }
  std::size_t advance(char32_t c, std::size_t bytes, const std::string& text, std::size_t i) {
    auto at = [&](const char* q) { return text.compare(i, std::strlen(q), q) == 0; };
    const bool was_escaped = escaped_;
    escaped_ = false;
    if (c == '\n') {
      if (state == Comment || state == Basic || state == Literal) state = Outside;
      if (state == Outside) last_ = '\n';
    } else if (state == Outside || state == Bare) {
      return advance_outside_strings(c, at("\"\"\""), at("'''"), bytes);
    } else if ((state == Basic || state == MultiBasic) && !was_escaped) {
      if (c == '\\') {
        escaped_ = true;
      } else if (state == MultiBasic && at("\"\"\"")) {
        state = resumed();
        return 3;
      } else if (state == Basic && c == '"') {
        state = resumed();
      }
    } else if (state == Literal && c == '\'') {
      state = resumed();
    } else if (state == MultiLiteral && at("'''")) {
      state = resumed();
      return 3;
    }
    return bytes;
  }

 private:
  bool escaped_ = false;  // the previous character was a backslash in a basic string
  bool value_ = false;    // the string being read follows '='
  bool in_bare_ = false;  // the string being read is inside a bare token, which resumes after it
  bool key_ = false;      // the bare token being read is a key at the start of a line
  int arrays_ = 0;        // arrays open (not table headers)
  char last_ = '\n';      // the last character outside strings and comments, not space or tab

  State resumed() const { return in_bare_ ? Bare : Outside; }

  std::size_t advance_outside_strings(char32_t c, bool three_double, bool three_single,
                                      std::size_t bytes) {
    in_bare_ = state == Bare;
    value_ = !in_bare_ && last_ == '=';
    const char before = last_;
    if (c != ' ' && c != '\t') last_ = static_cast<char>(c < 0x80 ? c : 0x7F);
    // (Inside a bare token brackets are the token's, and a quote starts a string that is no
    // value.)
    if (!in_bare_ && c == '[' && (arrays_ > 0 || before == '=')) ++arrays_;  // else a header
    if (!in_bare_ && c == ']' && arrays_ > 0) --arrays_;
    if (c == '#') {
      state = Comment;
    } else if (three_double) {
      state = MultiBasic;
      return 3;
    } else if (c == '"') {
      state = Basic;
    } else if (three_single) {
      state = MultiLiteral;
      return 3;
    } else if (c == '\'') {
      state = Literal;
    } else if (!in_bare_ && c != ' ' && c != '\t' && c != '\r' && c != '=' && c != '[' &&
               c != ']' && c != '{' && c != '}' && c != ',') {
      state = Bare;
      key_ = before == '\n' && arrays_ == 0;
    }
    return bytes;
  }
};

void refuse_unsafe_characters(const std::string& text, const std::string& file) {
  TomlPlaces places;
  long line = 1, column = 0;
  for (std::size_t i = 0; i < text.size();) {
    const Utf8Char u = utf8_at(text, i);
    ++column;
    // A malformed byte is refused here, where its line and column are known (toml++ places it at
    // the end of the token before).
    if (u.malformed) {
      std::ostringstream o;
      o << file << ":" << line << ":" << column << ": byte 0x" << std::hex << std::uppercase
        << static_cast<unsigned>(static_cast<unsigned char>(text[i]))
        << " is not UTF-8 text (a scan file is UTF-8)";
      throw ScanError(o.str());
    }
    places.end_bare_token(u.c);
    bool unsafe = false;
    for (const auto& r : kUnsafe) unsafe = unsafe || (u.c >= r[0] && u.c <= r[1]);
    if (u.bytes > 1 && unsafe && !places.safe()) {
      std::ostringstream o;
      o << file << ":" << line << ":" << column << ": character U+" << std::hex << std::uppercase
        << static_cast<unsigned long>(u.c)
        << " is only allowed in comments and string values (toml++ 3.3.0 mishandles "
           "U+00A1..U+0499, U+2C5E..U+2FFF, U+3001..U+3057 and U+FB26..U+FEFE elsewhere"
        << (places.state == TomlPlaces::MultiBasic
                ? R"(; a multi-line """ string is no such value, ''' is)"
                : "")
        << ")";
      throw ScanError(o.str());
    }
    const std::size_t advance = places.advance(u.c, u.bytes, text, i);
    if (u.c == '\n') {
      ++line;
      column = 0;
    }
    if (advance == 3) column += 2;  // the two further quotes of a """ or '''
    i += advance;
  }
}

// Names joined by commas, each between `open` and its match: "[" closes with "]", a quote (or
// nothing) with itself.
std::string joined(const std::vector<std::string>& names, const std::string& open = "") {
  const std::string close = open == "[" ? "]" : open;
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + (open + n + close);
  return out;
}

// The tables of a scan file besides [[point]]: [scan], [system] and the settings' sections.
std::vector<std::string> section_names() {
  std::vector<std::string> names = {"scan", "system"};
  for (const auto& k : setting_keys())
    if (std::find(names.begin(), names.end(), k.section) == names.end())
      names.emplace_back(k.section);
  return names;
}

// Key `k` of the settings section `section` (include/loosepack/settings.hpp), parsed into the
// scan and checked against its row.
void parse_setting(const std::string& file, const std::string& section, const std::string& k,
                   const toml::node& v, Scan& scan) {
  const std::string key = section + "." + k;
  const auto& table = setting_keys();
  const auto row = std::find_if(table.begin(), table.end(), [&](const SettingKey& r) {
    return section == r.section && k == r.key;
  });
  if (row == table.end())
    fail(file, v, key, "unknown key (allowed: " + joined(setting_keys_of(section)) + ")");
  // After a range: its unit, and what the key means.
  const std::string unit_and_meaning =
      std::string(*row->unit ? " " : "") + row->unit + " (" + row->meaning + ")";
  switch (row->type) {
    case SettingKey::Type::Real: {
      const double x = as_number(file, v, key);
      if (!(x >= row->lo && x <= row->hi)) {
        std::ostringstream o;
        o << "value " << x << " outside the allowed range [" << row->lo << ", " << row->hi << "]"
          << unit_and_meaning;
        fail(file, v, key, o.str());
      }
      row->set(scan, x);
      break;
    }
    case SettingKey::Type::Integer: {
      auto i = v.as_integer();
      if (!i || static_cast<double>(i->get()) < row->lo ||
          static_cast<double>(i->get()) > row->hi) {
        std::ostringstream o;
        o << "expected an integer in [" << static_cast<long>(row->lo) << ", "
          << static_cast<long>(row->hi) << "]" << unit_and_meaning;
        fail(file, v, key, o.str());
      }
      row->set(scan, static_cast<double>(i->get()));
      break;
    }
    case SettingKey::Type::Bool:
      row->set(scan, as_bool(file, v, key) ? 1.0 : 0.0);
      break;
    case SettingKey::Type::Choice: {
      auto str = v.as_string();
      if (!str || !row->set_name(scan, str->get())) {
        auto names = row->choices();
        const std::string last = "\"" + names.back() + "\"";
        names.pop_back();
        fail(file, v, key, "expected " + joined(names, "\"") + " or " + last);
      }
      break;
    }
  }
  if (row->check) {
    const std::string why = row->check(scan);
    if (!why.empty()) fail(file, v, key, why);
  }
}

// An integer that a double holds exactly, as that double.
std::optional<double> exact_real(const toml::node* v) {
  constexpr std::int64_t kExact = std::int64_t{1} << 53;
  const auto* i = v ? v->as_integer() : nullptr;
  if (!i || i->get() <= -kExact || i->get() >= kExact) return std::nullopt;
  return static_cast<double>(i->get());
}

// Whether `section.key` takes a real: every system key (in [system] and [[point]]) and the
// settings of Type::Real.
bool real_valued(const std::string& section, const std::string& key) {
  if (section == "system" || section == "point") return true;
  for (const auto& k : setting_keys())
    if (section == k.section && key == k.key) return k.type == SettingKey::Type::Real;
  return false;
}

// An array's integers written as reals.
void reals_in(toml::array& values) {
  for (std::size_t k = 0; k < values.size(); ++k)
    if (const auto r = exact_real(values.get(k)))
      values.replace(values.cbegin() + static_cast<std::ptrdiff_t>(k), *r);
}

// The integers of a table's real-valued keys written as reals, so that `24` and `24.0`, `100`
// and `1e2` are one setting: a value, an axis's values, a range's `from`, `to` and `also`.
// Integer-valued keys (seeds, a range's `points`, the integer settings) keep theirs, so that the
// identity still parses as a scan.
void reals_in(toml::table& table, const std::string& section) {
  std::vector<std::string> keys;
  for (auto&& [key, value] : table)
    if (real_valued(section, std::string(key.str()))) keys.emplace_back(key.str());
  for (const auto& key : keys) {
    toml::node* value = table.get(key);
    if (const auto real = exact_real(value)) {
      table.insert_or_assign(key, *real);
    } else if (auto* axis = value->as_array()) {
      reals_in(*axis);
    } else if (auto* range = value->as_table()) {
      for (const char* end : {"from", "to"})
        if (const auto r = exact_real(range->get(end))) range->insert_or_assign(end, *r);
      if (auto* also = range->get_as<toml::array>("also")) reals_in(*also);
    }
  }
}

void integers_as_reals(toml::table& identity) {
  for (auto&& [section, node] : identity) {
    const std::string name(section.str());
    if (auto* table = node.as_table()) reals_in(*table, name);
    if (auto* points = node.as_array())
      for (auto& point : *points)
        if (auto* table = point.as_table()) reals_in(*table, name);
  }
}

// The settings a scan's identity (Scan::content) is made of: the parsed file less what no
// member's result depends on, [scan] batch_size (a run may resume with another --batch-size) and
// the table's keys that say so (SettingKey::changes_no_result), the integers of real-valued keys
// as reals. A table left empty is left out, as in a file without it. `for_resume`: less
// protocol.max_collapse_time too (Scan::resume_identity).
toml::table identity_of(const toml::table& root, bool for_resume) {
  toml::table identity = root;
  auto drop = [&](const char* section, const char* key) {
    auto* table = identity[section].as_table();
    if (!table) return;
    table->erase(key);
    if (table->empty()) identity.erase(section);
  };
  drop("scan", "batch_size");
  for (const auto& k : setting_keys())
    if (k.changes_no_result) drop(k.section, k.key);
  if (for_resume) drop("protocol", "max_collapse_time");
  integers_as_reals(identity);
  return identity;
}

// The dotted key that `line` (1-based) of a scan file's text sets, "section.key", where that line
// is a plain `key = value` (else ""): toml++'s syntax errors name the bare key only ("cannot
// redefine existing floating-point 'width'"), and the same key is in several sections. A plain
// reading of the lines (no std::regex, whose recursion a long line can overflow).
std::string key_on_line(const std::string& text, long line) {
  auto name_at = [](const std::string& row, std::size_t& i) {  // a bare name from row[i] on
    const std::size_t from = i;
    while (i < row.size() && (std::isalnum(static_cast<unsigned char>(row[i])) || row[i] == '_' ||
                              row[i] == '-' || row[i] == '.'))
      ++i;
    return row.substr(from, i - from);
  };
  auto quoted_at = [](const std::string& row, std::size_t& i) {  // "name" or 'name', no escapes
    const std::size_t end = row.find(row[i], i + 1);
    if (end == std::string::npos || row.find('\\', i + 1) < end) return std::string();
    const std::string name = row.substr(i + 1, end - i - 1);
    i = end + 1;
    return name;
  };
  auto skip_blanks = [](const std::string& row, std::size_t& i) {
    while (i < row.size() && (row[i] == ' ' || row[i] == '\t')) ++i;
  };
  std::istringstream in(text);
  std::string row;
  std::optional<std::string> section = "";  // none where a header could not be read
  for (long k = 1; k <= line && std::getline(in, row); ++k) {
    std::size_t i = 0;
    skip_blanks(row, i);
    if (k < line) {  // a table header [name] or [[name]] sets the section of the lines below
      if (i >= row.size() || row[i] != '[') continue;
      while (i < row.size() && row[i] == '[') ++i;
      skip_blanks(row, i);
      const bool quoted = i < row.size() && (row[i] == '"' || row[i] == '\'');
      const std::string name = quoted ? quoted_at(row, i) : name_at(row, i);
      skip_blanks(row, i);
      // A quoted header this reading cannot name (a dot inside the quotes, an escape) leaves the
      // section unknown; a line that is no header (inside a multi-line array) leaves it as it is.
      if (!name.empty() && i < row.size() && row[i] == ']')
        section =
            quoted && name.find('.') != std::string::npos ? std::nullopt : std::optional(name);
      else if (quoted)
        section = std::nullopt;
      continue;
    }
    const std::string key = name_at(row, i);
    skip_blanks(row, i);
    if (!section || key.empty() || key.find('.') != std::string::npos || i >= row.size() ||
        row[i] != '=')
      return "";
    return section->empty() ? key : *section + "." + key;
  }
  return "";
}

}  // namespace

Scan load_scan(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ScanError(path + ": cannot open the scan file: " + std::strerror(errno));
  std::stringstream ss;
  ss << in.rdbuf();
  // A result file or another binary given by mistake: said so, not a TOML syntax error deep in it.
  if (ss.str().find('\0') != std::string::npos)
    throw ScanError(path +
                    ": not a text file (a scan file is TOML; a result file is read by "
                    "loosepack summary)");
  return parse_scan(ss.str(), path);
}

namespace {

// The parse of one scan file: its sections read into the scan and the axes, then the points
// expanded, checked and counted.
class ScanParser {
 public:
  ScanParser(const std::string& text, const std::string& file) : file(file) {
    scan.file = file;
    scan.text = text;
  }
  Scan parse();
  // The keys of [scan], each with the reader that parses it.
  using KeyReader = void (ScanParser::*)(const toml::node& v, const std::string& key);
  static const std::vector<std::pair<std::string, KeyReader>>& scan_keys();

 private:
  void read_sections(const toml::table& root);
  void read_point_tables(const toml::node& node);
  void read_scan_section(const toml::table& tbl);
  void read_name(const toml::node& v, const std::string& key);
  void read_seed(const toml::node& v, const std::string& key);
  void read_seeds(const toml::node& v, const std::string& key);
  void read_batch_size(const toml::node& v, const std::string& key);
  void read_protocol(const toml::node& v, const std::string& key);
  void read_system_section(const toml::table& tbl);
  std::vector<ScanPoint> expand_grid();
  std::vector<ScanPoint> explicit_points_on(const ScanPoint& base, bool system_sets_time_step);
  void validate_point(const ScanPoint& sp);
  const toml::node& failing_value(const toml::node& axis, const SystemKey& sk,
                                  SystemParams p) const;
  std::pair<const toml::node*, std::string> where_set(const std::string& key) const;
  void check_rest_window(const ScanPoint& sp);
  void check_counts(const std::vector<ScanPoint>& points);
  void warn_unresolved_barrier(const std::vector<ScanPoint>& points);
  void warn_diverging_jacobi();
  void reset_unused_capture_radius(std::vector<ScanPoint>& points);
  void check_bands(double height) const;
  [[noreturn]] void fail_setting(const std::string& key, const std::string& reason) const;
  void check_sweeps_per_launch();
  void check_fused_step();
  int positive_int(const toml::node& v, const std::string& key, int lo, int hi) const {
    auto i = v.as_integer();
    if (!i || i->get() < lo || i->get() > hi)
      fail(file, v, key,
           "expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return static_cast<int>(i->get());
  }

  const std::string file;
  Scan scan;
  std::vector<Protocol> protocols = {Protocol::A};
  // Axis values of the system keys, in the order of system_keys(); scalars are one-value axes.
  std::map<std::string, std::pair<std::vector<double>, const toml::node*>> axes;
  std::map<std::string, bool> bool_keys;
  // Explicit points ([[point]] tables): each one system-key override set, plus its protocol.
  struct Explicit {
    const toml::node* node;
    std::vector<std::pair<std::string, const toml::node*>> keys;
  };
  std::vector<Explicit> explicit_points;
  // The [[point]] table of the point being built or validated (nullptr: a point of the grid):
  // its own keys are where that point's errors lie.
  const Explicit* point_table = nullptr;
  const toml::node* protocol_node = nullptr;
  const toml::node* seeds_node = nullptr;
  std::map<std::string, const toml::node*> setting_nodes;  // where the file sets each setting
};

Scan ScanParser::parse() {
  refuse_unsafe_characters(scan.text, file);
  toml::table root;
  try {
    root = toml::parse(scan.text, file);
  } catch (const toml::parse_error& e) {
    std::ostringstream o;
    const long line = static_cast<long>(e.source().begin.line);
    o << file << ":" << line << ":" << e.source().begin.column << ": ";
    const std::string key = key_on_line(scan.text, line);
    if (!key.empty()) o << "key '" << key << "': ";
    o << e.description();
    throw ScanError(o.str());
  }
  if (!sets_a_value(root))
    throw ScanError(file +
                    ": the scan file sets nothing; every default together is a 200 R x 150 R "
                    "deposit of hours (docs/SCAN.md): set at least [system] width and height");
  read_sections(root);
  if (!explicit_points.empty()) {
    if (protocols.size() > 1)
      fail(file, *protocol_node, "scan.protocol",
           "axes and [[point]] tables do not mix: list the points, or the axes");
    for (const auto& [k, ax] : axes)
      if (ax.first.size() > 1)
        fail(file, *ax.second, "system." + k,
             "axes and [[point]] tables do not mix: list the points, or the axes");
  }
  const bool system_sets_time_step = axes.count("time_step") > 0;
  std::vector<ScanPoint> points = expand_grid();
  if (!explicit_points.empty()) points = explicit_points_on(points.front(), system_sets_time_step);
  // Validate every point; report the first offending key with its location (in the point's
  // own [[point]] table where it has one).
  for (std::size_t k = 0; k < points.size(); ++k) {
    point_table = explicit_points.empty() ? nullptr : &explicit_points[k];
    validate_point(points[k]);
  }
  for (std::size_t k = 0; k < points.size(); ++k) {  // a band refused at the point's height
    point_table = explicit_points.empty() ? nullptr : &explicit_points[k];
    check_bands(points[k].params.height);
  }
  point_table = nullptr;
  reset_unused_capture_radius(points);
  check_counts(points);
  for (std::size_t k = 0; k < points.size(); ++k) points[k].index = static_cast<int>(k);
  warn_unresolved_barrier(points);
  warn_diverging_jacobi();
  check_sweeps_per_launch();
  check_fused_step();
  // The identity is written once every value is valid: toml++ 3.3's writer converts an inf or
  // a nan in an array to an integer (undefined behaviour), and every key refuses them.
  const auto written = [&](bool for_resume) {
    std::ostringstream content;
    content << "# written by toml++ " << TOML_LIB_MAJOR << "." << TOML_LIB_MINOR << "."
            << TOML_LIB_PATCH << "\n"
            << identity_of(root, for_resume);
    return content.str();
  };
  scan.content = written(false);
  scan.resume_identity = written(true);
  scan.points = std::move(points);
  return scan;
}

// The observables' bands within a point of height H: nu_lower_half from lower_half_from to H/2,
// the cut histogram and profile fits between the bottom and the top cut, and at least one strip
// of nu(y) below H (a strip reaching over H would count the empty space above the box).
void ScanParser::check_bands(double height) const {
  const auto& obs = scan.observables;
  // A band the file leaves at its default is refused where the file sets the height.
  const auto fail_band = [&](const std::string& key, const std::string& reason) {
    if (!setting_nodes.count(key))
      if (const auto [node, name] = where_set("height"); node)
        fail(file, *node, name, key + " (its default, not set in the file) " + reason);
    fail_setting(key, reason);
  };
  if (!(obs.strip_width <= height)) {
    std::ostringstream o;
    o << obs.strip_width << " must be at most H = " << height
      << " of every point (nu(y) is measured in the strips that fit below H)";
    fail_band("observables.strip_width", o.str());
  }
  if (!(obs.lower_half_from_at(height) < 0.5 * height)) {
    std::ostringstream o;
    o << obs.lower_half_from << " must lie below H/2 = " << 0.5 * height
      << " of every point (nu_lower_half is the band from it to H/2)";
    fail_band("observables.lower_half_from", o.str());
  }
  const double bottom = obs.cut_bottom_at(height), top = obs.cut_top_at(height);
  if (!(bottom + top < height)) {
    std::ostringstream o;
    o << "cut_bottom + cut_top = " << bottom + top << " must lie below H = " << height
      << " of every point (the cut histogram and the profile fits use the band between them)";
    fail_band(obs.cut_top_given ? "observables.cut_top" : "observables.cut_bottom", o.str());
  }
}

// Refuses the setting `key` with `reason`, at its place in the file where the file sets it.
void ScanParser::fail_setting(const std::string& key, const std::string& reason) const {
  const auto at = setting_nodes.find(key);
  if (at != setting_nodes.end()) fail(file, *at->second, key, reason);
  throw ScanError(file + ": key '" + key + "': " + reason);
}

void ScanParser::read_sections(const toml::table& root) {
  for_each_key(root, [&](const std::string& section, const toml::node& node) {
    if (section == "point") return read_point_tables(node);
    auto tbl = node.as_table();
    if (!tbl)
      fail(file, node, section,
           "expected a table (" + joined(section_names(), "[") + ") or [[point]] tables");
    if (section == "scan") {
      read_scan_section(*tbl);
    } else if (section == "system") {
      read_system_section(*tbl);
    } else if (is_setting_section(section)) {
      for_each_key(*tbl, [&](const std::string& k, const toml::node& v) {
        parse_setting(file, section, k, v, scan);
        setting_nodes[section + "." + k] = &v;
      });
    } else {
      fail(file, node, section, "unknown section (allowed: " + joined(section_names()) + ")");
    }
  });
}

void ScanParser::read_point_tables(const toml::node& node) {
  const std::string section = "point";
  auto arr = node.as_array();
  if (!arr || arr->empty() || !arr->is_array_of_tables())
    fail(file, node, section, "expected [[point]] tables");
  for (const auto& e : *arr) {
    Explicit ex{&e, {}};
    for_each_key(*e.as_table(), [&](const std::string& k, const toml::node& v) {
      if (k != "protocol" && !system_key(k))
        fail(file, v, "point." + k, "unknown key (allowed: protocol and the [system] keys)");
      if (v.is_array() || v.is_table())
        fail(file, v, "point." + k, "a point takes single values, not axes");
      ex.keys.emplace_back(k, &v);
    });
    explicit_points.push_back(ex);
  }
}

const std::vector<std::pair<std::string, ScanParser::KeyReader>>& ScanParser::scan_keys() {
  static const std::vector<std::pair<std::string, KeyReader>> keys = {
      {"name", &ScanParser::read_name},
      {"seed", &ScanParser::read_seed},
      {"seeds", &ScanParser::read_seeds},
      {"batch_size", &ScanParser::read_batch_size},
      {"protocol", &ScanParser::read_protocol}};
  return keys;
}

// The keys of [scan], in the order of scan_keys().
std::vector<std::string> scan_section_keys() {
  std::vector<std::string> names;
  for (const auto& key : ScanParser::scan_keys()) names.push_back(key.first);
  return names;
}

void ScanParser::read_scan_section(const toml::table& tbl) {
  for_each_key(tbl, [&](const std::string& k, const toml::node& v) {
    const std::string key = "scan." + k;
    const auto& keys = scan_keys();
    const auto known =
        std::find_if(keys.begin(), keys.end(), [&](const auto& entry) { return entry.first == k; });
    if (known == keys.end())
      fail(file, v, key, "unknown key (allowed: " + joined(scan_section_keys()) + ")");
    (this->*known->second)(v, key);
  });
}

void ScanParser::read_name(const toml::node& v, const std::string& key) {
  auto s = v.as_string();
  if (!s || s->get().empty() || has_control_character(s->get()))
    fail(file, v, key,
         "expected a non-empty string without control characters (it labels "
         "the output's lines)");
  scan.name = s->get();
}

void ScanParser::read_seed(const toml::node& v, const std::string& key) {
  auto i = v.as_integer();
  if (!i || i->get() < 0) fail(file, v, key, "expected an integer >= 0");
  scan.seed = static_cast<std::uint64_t>(i->get());
}

void ScanParser::read_seeds(const toml::node& v, const std::string& key) {
  scan.seeds = positive_int(v, key, 1, 1000000);
  seeds_node = &v;
}

void ScanParser::read_batch_size(const toml::node& v, const std::string& key) {
  scan.batch_size = positive_int(v, key, 1, 1000000);
}

void ScanParser::read_protocol(const toml::node& v, const std::string& key) {
  protocol_node = &v;
  protocols.clear();
  auto one = [&](const toml::node& e) {
    auto s = e.as_string();
    Protocol p;
    if (!s || !protocol_from_name(s->get(), p))
      fail(file, e, key, "expected \"A\", \"B\" or \"C\"");
    // As a number axis: the same protocol twice would make two points of one system.
    if (std::find(protocols.begin(), protocols.end(), p) != protocols.end())
      fail(file, e, key, "the value \"" + s->get() + "\" is already in this axis");
    protocols.push_back(p);
  };
  if (auto arr = v.as_array()) {
    if (arr->empty()) fail(file, v, key, "an axis needs at least one value");
    for (const auto& e : *arr) one(e);
  } else {
    one(v);
  }
}

void ScanParser::read_system_section(const toml::table& tbl) {
  for_each_key(tbl, [&](const std::string& k, const toml::node& v) {
    const std::string key = "system." + k;
    const SystemKey* sk = system_key(k);
    if (!sk) {
      std::vector<std::string> allowed;
      for (const auto& known : system_keys()) allowed.emplace_back(known.name);
      fail(file, v, key, "unknown key (allowed: " + joined(allowed) + ")");
    }
    if (k == "floor_cohesion") {
      bool_keys[k] = as_bool(file, v, key);
      return;
    }
    axes[k] = {as_axis(file, v, key, value_range(*sk)), &v};
  });
}

// The grid of the axes: protocol slowest, then the system keys in their fixed order.
std::vector<ScanPoint> ScanParser::expand_grid() {
  std::vector<ScanPoint> points;
  for (Protocol pr : protocols) {
    ScanPoint sp;
    sp.protocol = pr;
    for (const auto& [k, b] : bool_keys)
      if (k == "floor_cohesion") sp.params.floor_cohesion = b;
    points.push_back(sp);
  }
  for (const auto& sk : system_keys()) {
    auto it = axes.find(sk.name);
    if (it == axes.end()) continue;
    const std::size_t n = points.size() * it->second.first.size();
    if (n > static_cast<std::size_t>(kMaxPoints))
      fail(file, *it->second.second, std::string("system.") + sk.name,
           "this axis makes the grid " + std::to_string(n) + " scan points; at most " +
               std::to_string(kMaxPoints));
    std::vector<ScanPoint> next;
    for (const auto& base : points)
      for (double v : it->second.first) {
        ScanPoint sp = base;
        sk.set(sp.params, v);
        next.push_back(sp);
      }
    points = std::move(next);
  }
  if (!axes.count("time_step"))
    for (auto& sp : points) sp.params.time_step = sp.params.default_time_step();
  return points;
}

// Explicit points: the [system] values (now all scalars) overridden by each point's keys; a
// point whose time step neither it nor [system] sets gets the default at its own Bond number.
std::vector<ScanPoint> ScanParser::explicit_points_on(const ScanPoint& base,
                                                      bool system_sets_time_step) {
  std::vector<ScanPoint> points;
  for (const auto& ex : explicit_points) {
    point_table = &ex;
    ScanPoint sp = base;
    bool sets_time_step = system_sets_time_step;
    for (const auto& [k, v] : ex.keys) {
      sets_time_step = sets_time_step || k == "time_step";
      if (k == "protocol") {
        auto str = v->as_string();
        if (!str || !protocol_from_name(str->get(), sp.protocol))
          fail(file, *v, "point.protocol", "expected \"A\", \"B\" or \"C\"");
      } else if (k == "floor_cohesion") {
        sp.params.floor_cohesion = as_bool(file, *v, "point." + k);
      } else {
        const SystemKey* sk = system_key(k);
        const double x = as_number(file, *v, "point." + k, sk ? value_range(*sk) : "");
        if (sk) sk->set(sp.params, x);
      }
    }
    if (!sets_time_step) sp.params.time_step = sp.params.default_time_step();
    for (const auto& sk : system_keys()) {
      const std::string why = sk.check(sp.params);
      if (why.empty()) continue;
      const auto [node, key] = where_set(sk.name);
      fail(file, node ? *node : *ex.node, node ? key : "point." + std::string(sk.name), why);
    }
    points.push_back(sp);
  }
  point_table = nullptr;
  return points;
}

// Where the file sets system key `key` for the point at hand, and the key's name there: its
// [[point]] table's own key (point.KEY), else [system]'s (system.KEY); nullptr where neither
// sets it (its default).
std::pair<const toml::node*, std::string> ScanParser::where_set(const std::string& key) const {
  if (point_table)
    for (const auto& [k, node] : point_table->keys)
      if (k == key) return {node, "point." + key};
  const auto it = axes.find(key);
  if (it != axes.end()) return {it->second.second, "system." + key};
  return {nullptr, "system." + key};
}

// The value of an array axis that fails key sk's check with the other parameters of p (the
// first such): where an invalid point's error is located. The axis itself for a scalar or a
// range.
const toml::node& ScanParser::failing_value(const toml::node& axis, const SystemKey& sk,
                                            SystemParams p) const {
  if (const auto* values = axis.as_array())
    for (const auto& e : *values) {
      sk.set(p, as_number(file, e, sk.name));  // parsed once already: valid
      if (!sk.check(p).empty()) return e;
    }
  return axis;
}

void ScanParser::validate_point(const ScanPoint& sp) {
  for (const auto& sk : system_keys()) {
    const std::string why = sk.check(sp.params);
    if (why.empty()) continue;
    const auto [node, key] = where_set(sk.name);
    if (node) fail(file, failing_value(*node, sk, sp.params), key, why);
    throw ScanError(file + ": default of key '" + key + "' invalid here: " + why);
  }
  // The system size: member_capacity and the neighbour grid scale with it.
  const double area = (sp.params.width / sp.params.radius) * (sp.params.height / sp.params.radius);
  if (!(area <= kMaxArea)) {
    std::ostringstream why;
    why << "the system is L_x H / R^2 = " << area << " > " << kMaxArea
        << " (about 3e6 disks per member at most)";
    // Blame the key the file sets that grows the area most beyond its default (the area is
    // counted in R^2, so a small radius weighs twice).
    const SystemParams d;
    std::vector<std::pair<double, std::string>> growth = {
        {std::log(sp.params.width / d.width), "width"},
        {std::log(sp.params.height / d.height), "height"},
        {2.0 * std::log(d.radius / sp.params.radius), "radius"}};
    std::sort(growth.rbegin(), growth.rend());
    for (const auto& [factor, key] : growth)
      if (const auto [node, name] = where_set(key); node) fail(file, *node, name, why.str());
    throw ScanError(file + ": " + why.str());
  }
  // Contacts are detected up to 2 h (v + h g) ahead (src/batch.cpp); a disk falling through
  // the whole box must stay within the bound the contact capacity allows. (Ballistic
  // deposition, B and A at Bo = inf, has no dynamics.)
  if (sp.protocol == Protocol::C ||
      (sp.protocol == Protocol::A && !std::isinf(sp.params.bond_number))) {
    const auto& p = sp.params;
    const double g = std::abs(p.gravity), h = p.time_step;
    const double v = fall_speed(g, box_top(p, largest_radius(p)));
    const double reach = detection_margin(h, v, g);
    if (reach > kMaxDetectionMargin * p.radius) {
      const double h_max =
          g > 0.0 ? (-2.0 * v + std::sqrt(4.0 * v * v + 8.0 * g * kMaxDetectionMargin * p.radius)) /
                        (4.0 * g)
                  : h;
      std::ostringstream why;
      why << "h = " << h << " is too large for H = " << p.height << ": a disk falling through "
          << "the box moves 2 h v = " << reach << " R in two steps, beyond the "
          << kMaxDetectionMargin << " R the contact detection covers; use h <= " << h_max
          << " (docs/MODEL.md, supported ranges)";
      for (const char* k : {"time_step", "height"})
        if (const auto [node, name] = where_set(k); node) fail(file, *node, name, why.str());
      throw ScanError(file + ": key 'system.time_step': " + why.str());
    }
  }
  if (sp.protocol == Protocol::C && std::isinf(sp.params.bond_number)) {
    const std::string why = "protocol C with Bo = inf has no collapse; use protocol B";
    if (const auto [node, name] = where_set("bond_number"); node) fail(file, *node, name, why);
    throw ScanError(file + ": " + why);
  }
  check_rest_window(sp);
}

// A disk set free reaches g h rest.steps within the rest window; below kRestWindowSpeeds rest
// speeds a falling disk cannot be told from one at rest, and rest would be declared before
// anything moved (docs/SCAN.md, [rest]).
void ScanParser::check_rest_window(const ScanPoint& sp) {
  constexpr double kRestWindowSpeeds = 2.0;
  const bool dynamics = sp.protocol == Protocol::C ||
                        (sp.protocol == Protocol::A && !std::isinf(sp.params.bond_number));
  const double g = std::abs(sp.params.gravity), h = sp.params.time_step;
  const double reach = g * h * scan.rest.steps;
  if (!dynamics || !(g > 0.0) || reach >= kRestWindowSpeeds * scan.rest.speed) return;
  const auto& keys = setting_keys();
  const double most_rest_steps = std::find_if(keys.begin(), keys.end(), [](const SettingKey& k) {
                                   return std::string(k.section) + "." + k.key == "rest.steps";
                                 })->hi;
  const double need = std::ceil(kRestWindowSpeeds * scan.rest.speed / (g * h) - 1e-9);
  std::ostringstream why;
  why << "h = " << h << " with rest.steps = " << scan.rest.steps
      << ": a disk set free falls only g h rest.steps = " << reach
      << " sqrt(gR) fast within the rest window, below " << kRestWindowSpeeds << " rest speeds ("
      << kRestWindowSpeeds * scan.rest.speed
      << "), so rest would be declared before anything moved; ";
  if (need <= most_rest_steps)
    why << "set [rest] steps >= " << static_cast<long>(need)
        << ", or a smaller rest.speed (docs/SCAN.md, [rest])";
  else
    why << "[rest] steps would need " << need << ", beyond its bound of "
        << format_number(most_rest_steps)
        << ": take a larger time_step or a smaller rest.speed (docs/SCAN.md, [rest])";
  if (const auto [node, name] = where_set("time_step"); node) fail(file, *node, name, why.str());
  for (const char* setting : {"rest.steps", "rest.speed"})
    if (const auto node = setting_nodes.find(setting); node != setting_nodes.end())
      fail(file, *node->second, setting, why.str());
  // None of them is set: h is the default time step of the point's Bond number.
  why << "; h is the default time step at Bo = " << sp.params.bond_number
      << " (or set system.time_step)";
  if (const auto [node, name] = where_set("bond_number"); node) fail(file, *node, name, why.str());
  throw ScanError(file + ": key 'system.time_step': " + why.str());
}

void ScanParser::check_counts(const std::vector<ScanPoint>& points) {
  if (points.size() > static_cast<std::size_t>(kMaxPoints))
    fail(file, *explicit_points[kMaxPoints].node, "point",
         "more than " + std::to_string(kMaxPoints) + " [[point]] tables");
  if (points.size() * static_cast<std::size_t>(scan.seeds) > static_cast<std::size_t>(kMaxMembers))
    fail(file, *seeds_node, "scan.seeds",
         std::to_string(points.size()) + " scan points x " + std::to_string(scan.seeds) +
             " seeds make more than " + std::to_string(kMaxMembers) + " members");
}

// Only the team solver splits a step's solve over launches.
void ScanParser::check_sweeps_per_launch() {
  if (scan.solver.sweeps_per_launch == 0 ||
      (scan.solver_kind_given && scan.solver.kind == SolverKind::ColouredAcceleratedGaussSeidel))
    return;
  fail(file, *setting_nodes.at("solver.sweeps_per_launch"), "solver.sweeps_per_launch",
       "only the solver kind coloured_accelerated_gauss_seidel splits a step's solve over "
       "launches; set solver.kind to it, or leave sweeps_per_launch at 0");
}

// A fused step needs a solver that sweeps each system in its own team (fused_step_solver), as
// every backend's default does.
void ScanParser::check_fused_step() {
  if (!scan.solver.fused_step || !scan.solver_kind_given || fused_step_solver(scan.solver.kind))
    return;
  fail(file, *setting_nodes.at("solver.fused_step"), "solver.fused_step",
       "a step runs in one launch only with a solver that sweeps each system in its own team: "
       "accelerated_gauss_seidel, coloured_accelerated_gauss_seidel or sequential_gauss_seidel, "
       "not " +
           std::string(solver_kind_name(scan.solver.kind)));
}

// Without mass splitting each of a disk's k contacts applies its whole impulse change at once,
// k times too much: the iteration diverges unless the relaxation is small (12 R x 12 R deposits
// converge at 0.5; at Bo = 1e2 they blow up at the default 0.8, at Bo = 0 at 1.0, and their
// members fail).
void ScanParser::warn_diverging_jacobi() {
  const bool jacobi = scan.solver_kind_given && scan.solver.kind == SolverKind::Jacobi;
  if (!scan.solver.mass_splitting && !jacobi)  // the other solvers update one contact at a time
    scan.warnings.push_back(file +
                            ": solver.mass_splitting acts in the Jacobi solver only "
                            "(solver.kind = \"jacobi\"); this scan's solver ignores it");
  if (jacobi && !scan.solver.mass_splitting && scan.solver.relaxation > 0.5)
    scan.warnings.push_back(file +
                            ": the Jacobi solver without mass splitting diverges at "
                            "relaxation > 0.5 (its members fail, their disks thrown "
                            "about); set solver.relaxation <= 0.5 or mass_splitting = true");
}

// The capture radius shapes the ballistic deposits of protocols B and C; protocol A drops each
// disk with its dynamics. So an A point runs with capture_radius = 1 and says so in the output,
// and an A point that the reset makes a repeat of another (a grid of protocols and capture
// radii) is left out: it would compute the same members again under another label.
void ScanParser::reset_unused_capture_radius(std::vector<ScanPoint>& points) {
  std::vector<ScanPoint> kept;
  int reset = 0, repeats = 0;
  for (auto sp : points) {
    if (sp.protocol == Protocol::A && sp.params.capture_radius != 1.0) {
      sp.params.capture_radius = 1.0;
      ++reset;
      const auto same = [&](const ScanPoint& o) {
        return o.protocol == sp.protocol && o.params == sp.params;
      };
      if (std::any_of(kept.begin(), kept.end(), same)) {
        ++repeats;
        continue;
      }
    }
    kept.push_back(sp);
  }
  if (reset == 0) return;
  std::ostringstream o;
  o << file << ": capture_radius acts in protocols B and C only; protocol A runs with "
    << "capture_radius = 1";
  if (repeats > 0)
    o << ", and " << repeats << " protocol-A point" << (repeats > 1 ? "s" : "")
      << (explicit_points.empty() ? " of the grid" : " ([[point]] table)")
      << " that differed from another only in it " << (repeats > 1 ? "are" : "is")
      << " left out (the points are numbered without " << (repeats > 1 ? "them" : "it") << ")";
  scan.warnings.push_back(o.str());
  points = std::move(kept);
}

// The discrete pull-off barrier matches F_c d_c only for h well below sqrt(2 m_n d_c / F_c),
// m_n = m/2 (docs/MODEL.md; the pull-off test shows it).
void ScanParser::warn_unresolved_barrier(const std::vector<ScanPoint>& points) {
  for (const auto& sp : points) {
    const auto& p = sp.params;
    const double scale = p.cohesive_barrier_time();
    if (sp.protocol == Protocol::B) continue;
    if (p.time_step > scale) {
      std::ostringstream o;
      o << file << ": point " << sp.index << " (Bo = " << p.bond_number << "): time_step "
        << p.time_step << " exceeds sqrt(2 m_n d_c / F_c) = " << scale
        << "; the cohesive barrier F_c d_c is not resolved (see docs/MODEL.md)";
      scan.warnings.push_back(o.str());
    }
  }
}

}  // namespace

namespace {
// Every leaf of a parsed identity as (key, value as toml++ writes it), in the table's order:
// `section.key`, `point[k].key` for the k-th [[point]], a range's `system.height.from`.
void leaves(const toml::node& node, const std::string& key,
            std::vector<std::pair<std::string, std::string>>& out) {
  if (const auto* table = node.as_table()) {
    for (auto&& [k, v] : *table)
      leaves(v, key.empty() ? std::string(k.str()) : key + "." + std::string(k.str()), out);
  } else if (const auto* array = node.as_array(); array && array->is_array_of_tables()) {
    for (std::size_t i = 0; i < array->size(); ++i)
      leaves(*array->get(i), key + "[" + std::to_string(i) + "]", out);
  } else {
    std::ostringstream value;
    if (const auto* a = node.as_array())
      value << *a;
    else
      node.visit([&](auto&& v) { value << v; });
    out.emplace_back(key, value.str());
  }
}
}  // namespace

std::string first_difference(const std::string& a, const std::string& b, const std::string& a_name,
                             const std::string& b_name) {
  std::vector<std::pair<std::string, std::string>> in_a, in_b;
  try {
    leaves(toml::parse(a), "", in_a);
    leaves(toml::parse(b), "", in_b);
  } catch (const toml::parse_error&) {
    return a == b ? "" : "the settings of " + a_name + " and " + b_name + " differ";
  }
  const auto value_in = [](const auto& leaves_of, const std::string& key) {
    for (const auto& [k, v] : leaves_of)
      if (k == key) return v;
    return std::string("(none)");
  };
  for (const auto* side : {&in_b, &in_a})
    for (const auto& leaf : *side) {
      const std::string& key = leaf.first;
      const std::string va = value_in(in_a, key), vb = value_in(in_b, key);
      if (va != vb)
        return "key '" + key + "' is `" + va + "` in " + a_name + " and `" + vb + "` in " + b_name;
    }
  return "";
}

std::vector<std::string> scan_file_keys() {
  std::vector<std::string> keys;
  for (const auto& k : scan_section_keys()) keys.push_back("scan." + k);
  for (const auto& k : system_keys()) keys.push_back(std::string("system.") + k.name);
  for (const auto& k : setting_keys()) keys.push_back(std::string(k.section) + "." + k.key);
  return keys;
}

Scan parse_scan(const std::string& text, const std::string& file) {
  return ScanParser(text, file).parse();
}

}  // namespace loosepack
