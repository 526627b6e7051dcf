// libFuzzer target for the checkpoint reader (src/checkpoint.cpp; docs/OUTPUT.md,
// "Checkpoints"). The input is the body of a part file, after a valid header (magic, byte order,
// the scan's fingerprint) and before a valid checksum, so that the fuzzer reaches the decoding
// of finished members and of running members' snapshots rather than stopping at the checksum;
// the same bytes also go to decode_members (the MPI messages' decoder). Each must return or
// throw CheckpointError; any other exception, crash, sanitizer report or huge allocation is a
// bug.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "loosepack/checkpoint.hpp"
#include "loosepack/scan.hpp"

namespace {

const loosepack::Scan& fuzz_scan() {
  static const loosepack::Scan scan = loosepack::parse_scan(
      "[scan]\nseeds = 3\nprotocol = [\"A\", \"C\"]\n[system]\nwidth = 12\nheight = 12\n"
      "bond_number = [0, 100]\n",
      "fuzz.toml");
  return scan;
}

std::uint64_t fnv1a(const std::string& s) {  // the part files' checksum (src/checkpoint.cpp)
  std::uint64_t h = 14695981039346656037ull;
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

template <class T>
void put(std::string& out, T v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof v);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const loosepack::Scan& scan = fuzz_scan();
  const std::string body(reinterpret_cast<const char*>(data), size);
  try {
    loosepack::decode_members(body, scan, "fuzz message");
  } catch (const loosepack::CheckpointError&) {
  }
  static const std::string dir =
      (std::filesystem::temp_directory_path() / ("loosepack-fuzz-" + std::to_string(getpid())))
          .string();
  std::filesystem::create_directories(dir);
  std::string part = "LPCKPT02";
  put<std::uint32_t>(part, 0x01020304u);
  put<std::uint64_t>(part, loosepack::scan_fingerprint(scan));
  part += body;
  put<std::uint64_t>(part, fnv1a(part));
  std::ofstream(dir + "/part-1-0.bin", std::ios::binary | std::ios::trunc) << part;
  try {
    loosepack::read_checkpoint(dir, scan);
  } catch (const loosepack::CheckpointError&) {
  }
  return 0;
}
