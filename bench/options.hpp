// Small helpers shared by the study programs: command lines and the scan defaults they record.
#pragma once
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "loosepack/scan.hpp"

namespace loosepack::bench {

// The sweep cap a scan gives a member of `protocol` ("A", "B" or "C") in a width x height box
// when the file sets none (default_max_sweeps).
inline int default_cap(const std::string& protocol, double width, double height) {
  Protocol p = Protocol::A;
  protocol_from_name(protocol, p);  // the programs' own names, always valid
  SystemParams box;
  box.width = width;
  box.height = height;
  return default_max_sweeps(p, box);
}

// "250,500,1000" -> {250, 500, 1000}
inline std::vector<int> parse_list(const char* s) {
  std::vector<int> v;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) v.push_back(std::atoi(item.c_str()));
  return v;
}

}  // namespace loosepack::bench
