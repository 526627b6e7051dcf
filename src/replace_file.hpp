// Writing a file so that nothing half-written is ever left at its path: `write(tmp)` fills a
// temporary file beside it, which is then renamed over the path. On any error the temporary is
// removed, the path is left as it was, and the error propagates.
#pragma once
#include <unistd.h>

#include <cstdio>
#include <stdexcept>
#include <string>

namespace loosepack {

template <class Write>
void replace_file(const std::string& path, Write write) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  try {
    write(tmp);
    if (std::rename(tmp.c_str(), path.c_str()) != 0)
      throw std::runtime_error("cannot rename " + tmp + " to " + path);
  } catch (...) {
    std::remove(tmp.c_str());
    throw;
  }
}

}  // namespace loosepack
