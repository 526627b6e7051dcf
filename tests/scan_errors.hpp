// Scan files the validator must refuse, with the message each must give.
#pragma once
#include <gtest/gtest.h>

#include <regex>
#include <string>
#include <vector>

#include "loosepack/scan.hpp"

namespace loosepack::scan_errors {

// The ScanError message for the scan text (as file "bad.toml"), or "" when it is accepted.
inline std::string error_of(const std::string& text) {
  try {
    parse_scan(text, "bad.toml");
  } catch (const ScanError& e) {
    return e.what();
  }
  return "";
}

struct Case {
  std::string text;
  std::string expect;  // part of the message
};

// Every case is refused with a message containing its expected part, which begins at the
// file's line and column ("bad.toml:L:C: ") unless it is about the whole file ("bad.toml: ").
inline void expect_refused(const std::vector<Case>& cases) {
  const std::regex at_a_place(R"(^bad\.toml:[0-9]+:[0-9]+: )");
  for (const auto& c : cases) {
    const std::string msg = error_of(c.text);
    EXPECT_NE(msg.find(c.expect), std::string::npos)
        << "input:\n"
        << c.text << "message: " << msg << "\nexpected to contain: " << c.expect;
    if (c.expect.rfind("bad.toml: ", 0) != 0) {
      EXPECT_TRUE(std::regex_search(msg, at_a_place)) << "input:\n" << c.text << "message: " << msg;
    }
  }
}

}  // namespace loosepack::scan_errors
