// An advisory lock on an output path, held for a whole run: a second run writing the same `-o`
// (or its checkpoint) is refused before any work, with the holder's pid. The lock is
// `<path>.lock` (flock, LOCK_EX); the kernel releases it when the holder dies, so a run killed
// by SIGKILL leaves a file that the next run simply locks again. A file at that path that is not
// such a lock (a user's file named so) is left as it is and the run refused.
#pragma once
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>

namespace loosepack {

class OutputLock {
 public:
  OutputLock() = default;
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;
  ~OutputLock() { release(); }

  // Takes the lock on `path`: "" when held now, else why not (another run holds it). On a file
  // system without locks (NFS without lockd, some Lustre mounts: flock fails with another error
  // than EWOULDBLOCK) the run goes on unlocked, and `warning()` says so.
  std::string acquire(const std::string& path) {
    lock_path_ = path + ".lock";
    warning_.clear();
    if (!lock_file_or_none(lock_path_))
      return lock_path_ + " is there and is not a lock of this program's (which holds a pid at " +
             "most), so it would be overwritten and removed: move it away or give another -o";
    for (int attempt = 0; attempt < 10; ++attempt) {
      fd_ = ::open(lock_path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
      if (fd_ < 0) return "cannot create the lock file " + lock_path_ + ": " + std::strerror(errno);
      const int refused = ::flock(fd_, LOCK_EX | LOCK_NB) == 0 ? 0 : errno;
      if (refused != 0 && refused != EWOULDBLOCK) {
        warning_ = "cannot lock " + lock_path_ + " (" + std::strerror(refused) +
                   "): a second run writing the same output at the same time would not be refused";
        return "";
      }
      if (refused == EWOULDBLOCK) {
        std::string pid;
        std::ifstream(lock_path_) >> pid;
        ::close(fd_);
        fd_ = -1;
        return path + " is being written by another run (pid " + (pid.empty() ? "?" : pid) +
               ", lock " + lock_path_ + "); wait for it to end or give another -o";
      }
      // The holder before us may have removed the file after we opened it: lock the file that
      // is at the path now.
      struct stat held {}, at_path {};
      if (::fstat(fd_, &held) == 0 && ::stat(lock_path_.c_str(), &at_path) == 0 &&
          held.st_ino == at_path.st_ino && held.st_dev == at_path.st_dev) {
        const std::string pid = std::to_string(::getpid()) + "\n";
        if (::ftruncate(fd_, 0) != 0 || ::write(fd_, pid.data(), pid.size()) < 0) {
        }  // the pid is for messages only
        return "";
      }
      ::close(fd_);
      fd_ = -1;
    }
    return "cannot lock " + lock_path_ + " (it keeps changing)";
  }

  // Why the lock taken is none (a file system without locks), or "".
  const std::string& warning() const { return warning_; }

  // Removes the lock file (while holding it) and releases the lock.
  void release() {
    if (fd_ < 0) return;
    ::unlink(lock_path_.c_str());
    ::close(fd_);
    fd_ = -1;
  }

 private:
  // Whether `p` is free to take as a lock: nothing there, or a regular file holding at most a
  // pid (a run that died left it, or another is taking its lock now). Where it cannot be looked
  // at, opening it says why.
  static bool lock_file_or_none(const std::string& p) {
    struct stat st {};
    if (::lstat(p.c_str(), &st) != 0) return true;
    if (!S_ISREG(st.st_mode) || st.st_size > 32) return false;
    std::ifstream in(p);
    const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    return text.find_first_not_of("0123456789\n") == std::string::npos;
  }

  std::string lock_path_, warning_;
  int fd_ = -1;
};

}  // namespace loosepack
