// Scan files the validator must refuse, with the message each must give.
#pragma once
#include <gtest/gtest.h>

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

// Every case is refused with a message containing its expected part.
inline void expect_refused(const std::vector<Case>& cases) {
  for (const auto& c : cases) {
    const std::string msg = error_of(c.text);
    EXPECT_NE(msg.find(c.expect), std::string::npos)
        << "input:\n"
        << c.text << "message: " << msg << "\nexpected to contain: " << c.expect;
  }
}

}  // namespace loosepack::scan_errors
