// Writing a file so that nothing half-written is ever left at its path: `write(tmp)` fills a
// temporary file beside it (`<path>.tmp.<host>.<pid>`), which is flushed to the disk, renamed
// over the path, and the directory flushed, so that after a crash the path holds the old file or
// the new one, whole. On any error the temporary is removed, the path is left as it was, and the
// error propagates. The host in the name keeps apart the temporaries of processes on different
// nodes of a shared file system whose pids are equal (MPI ranks that each write a checkpoint's
// `selection`). A temporary of a run that died on this host (kill -9 during a write) is removed
// by the next run that writes the same path (remove_stale_temporaries).
#pragma once
#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace loosepack {

// fsync of a file or a directory (the directory holds the new name after a rename).
inline void sync_path(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) throw std::runtime_error("cannot open " + path + " to flush it");
  const int rc = ::fsync(fd);
  const int error = errno;
  ::close(fd);
  if (rc != 0)
    throw std::runtime_error("cannot flush " + path + " to the disk: " + std::strerror(error));
}

// Writes `bytes` to the file `path` (created or truncated); an error names the file and its
// reason (a full disk: "No space left on device").
inline void write_bytes(const std::string& path, const std::string& bytes) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0666);
  if (fd < 0) throw std::runtime_error("cannot create " + path + ": " + std::strerror(errno));
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int error = n < 0 ? errno : ENOSPC;
      ::close(fd);
      throw std::runtime_error("cannot write " + path + ": " + std::strerror(error));
    }
    done += static_cast<std::size_t>(n);
  }
  if (::close(fd) != 0)
    throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
}

// The bytes of the file `path`; an error names the file and its reason.
inline std::string read_bytes(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) throw std::runtime_error("cannot open " + path + ": " + std::strerror(errno));
  std::string bytes;
  char buffer[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int error = errno;
      ::close(fd);
      throw std::runtime_error("cannot read " + path + ": " + std::strerror(error));
    }
    if (n == 0) break;
    bytes.append(buffer, static_cast<std::size_t>(n));
  }
  ::close(fd);
  return bytes;
}

inline std::string directory_of_path(const std::string& path) {
  const std::string dir = std::filesystem::path(path).parent_path().string();
  return dir.empty() ? "." : dir;
}

// This host's name as a temporary's name holds it: characters other than letters, digits, '-'
// and '_' replaced by '_' (so that the pid after the last '.' is found again).
inline std::string host_tag() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0 || name[0] == '\0') return "host";
  std::string tag(name);
  for (char& c : tag)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_')) c = '_';
  return tag;
}

// The temporary that replace_file writes `path` through, for this process (or process `pid`).
inline std::string temporary_of(const std::string& path, long pid = ::getpid()) {
  return path + ".tmp." + host_tag() + "." + std::to_string(pid);
}
// Linux's largest process id (pid_max's bound): a temporary's longest name, for any process that
// may write one.
constexpr long kLargestPid = 4194304;

template <class Write>
void replace_file(const std::string& path, Write write) {
  const std::string tmp = temporary_of(path);
  try {
    write(tmp);
    sync_path(tmp);
    if (std::rename(tmp.c_str(), path.c_str()) != 0)
      throw std::runtime_error("cannot rename " + tmp + " to " + path + ": " +
                               std::strerror(errno));
    sync_path(directory_of_path(path));
  } catch (...) {
    std::remove(tmp.c_str());
    throw;
  }
}

// Whether `tail`, what follows ".tmp." in a temporary's name (`<host>.<pid>`, or `<pid>` as
// programs before the host was in the name wrote them), names a process of this host that no
// longer runs. Another host's are never stale: whether their process runs cannot be told here.
inline bool stale_temporary(const std::string& tail) {
  const std::size_t dot = tail.rfind('.');
  if (dot != std::string::npos && tail.substr(0, dot) != host_tag()) return false;
  const std::string pid = dot == std::string::npos ? tail : tail.substr(dot + 1);
  if (pid.empty() || pid.find_first_not_of("0123456789") != std::string::npos) return false;
  return ::kill(static_cast<pid_t>(std::stol(pid)), 0) != 0 && errno == ESRCH;
}

// The stale temporaries in `directory` whose names begin with `prefix` followed by ".tmp.", or
// of any name when `prefix` is empty: removed; returns their names (for a message). Files only,
// unless `directories`: then a directory too, where its name holds this host (as the program
// names a checkpoint on its way out), with everything in it. A user's file or directory that
// merely looks like one is left alone where it can be told apart.
inline std::vector<std::string> remove_stale_temporaries_in(const std::string& directory,
                                                            const std::string& prefix,
                                                            bool directories = false) {
  namespace fs = std::filesystem;
  std::vector<std::string> removed;
  std::error_code ec;
  const std::string mark = prefix + ".tmp.";
  for (const auto& e : fs::directory_iterator(directory, ec)) {
    const std::string name = e.path().filename().string();
    const std::size_t at =
        prefix.empty() ? name.rfind(mark) : (name.rfind(mark, 0) == 0 ? 0 : std::string::npos);
    if (at == std::string::npos) continue;
    const std::string tail = name.substr(at + mark.size());
    if (!stale_temporary(tail)) continue;
    std::error_code kind;
    if (e.is_directory(kind)) {
      if (!directories || tail.rfind(host_tag() + ".", 0) != 0) continue;
      if (fs::remove_all(e.path(), ec) > 0 && !ec) removed.push_back(e.path().string());
    } else if (e.is_regular_file(kind) && fs::remove(e.path(), ec)) {
      removed.push_back(e.path().string());
    }
  }
  return removed;
}

// The stale temporaries of `path` (`<path>.tmp.<host>.<pid>`): replace_file's files, and with
// `directories` a directory of that name (a checkpoint on its way out); returns their names.
inline std::vector<std::string> remove_stale_temporaries(const std::string& path,
                                                         bool directories = false) {
  return remove_stale_temporaries_in(directory_of_path(path),
                                     std::filesystem::path(path).filename().string(), directories);
}

}  // namespace loosepack
