// Small helpers shared by the study programs' command lines.
#pragma once
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

namespace loosepack::bench {

// "250,500,1000" -> {250, 500, 1000}
inline std::vector<int> parse_list(const char* s) {
  std::vector<int> v;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) v.push_back(std::atoi(item.c_str()));
  return v;
}

}  // namespace loosepack::bench
