// MPI ranks: start-up, result gathering and progress messages (or one rank without MPI).
#include "loosepack/parallel.hpp"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <thread>

#ifdef LOOSEPACK_WITH_MPI
#include <mpi.h>
#endif

namespace loosepack {

#ifdef LOOSEPACK_WITH_MPI

namespace {
constexpr int kTagProgress = 1, kTagSize = 2, kTagChunk = 3, kTagStop = 4;
constexpr std::uint64_t kChunk = 1ull << 30;

struct ProgressMessage {
  Progress progress;
  int final = 0;
  int stopped = 0;  // the signal that stopped the rank, with its final message
};
}  // namespace

struct Ranks::Pending {
  MPI_Request request = MPI_REQUEST_NULL;
  ProgressMessage message;
};

Ranks::Ranks(int& argc, char**& argv) {
  MPI_Init(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  pending_ = std::make_unique<Pending>();
}

Ranks::~Ranks() {
  if (pending_->request != MPI_REQUEST_NULL) MPI_Wait(&pending_->request, MPI_STATUS_IGNORE);
  MPI_Finalize();
}

std::vector<std::string> Ranks::gather(const std::string& mine) const {
  std::vector<std::string> out;
  if (!root()) {
    std::uint64_t n = mine.size();
    MPI_Send(&n, 1, MPI_UINT64_T, 0, kTagSize, MPI_COMM_WORLD);
    for (std::uint64_t at = 0; at < n; at += kChunk)
      MPI_Send(mine.data() + at, static_cast<int>(std::min(kChunk, n - at)), MPI_BYTE, 0, kTagChunk,
               MPI_COMM_WORLD);
    return out;
  }
  out.push_back(mine);
  for (int r = 1; r < size_; ++r) {
    std::uint64_t n = 0;
    MPI_Recv(&n, 1, MPI_UINT64_T, r, kTagSize, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    std::string bytes(n, '\0');
    for (std::uint64_t at = 0; at < n; at += kChunk)
      MPI_Recv(&bytes[at], static_cast<int>(std::min(kChunk, n - at)), MPI_BYTE, r, kTagChunk,
               MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    out.push_back(std::move(bytes));
  }
  return out;
}

void Ranks::barrier() const { MPI_Barrier(MPI_COMM_WORLD); }

int Ranks::broadcast(int value) const {
  MPI_Bcast(&value, 1, MPI_INT, 0, MPI_COMM_WORLD);
  return value;
}

void Ranks::abort(int code) const {
  if (size_ > 1) MPI_Abort(MPI_COMM_WORLD, code);
}

void Ranks::send_progress(const Progress& p, bool final, int stopped) {
  if (root()) return;
  if (pending_->request != MPI_REQUEST_NULL) {
    int done = 0;
    MPI_Test(&pending_->request, &done, MPI_STATUS_IGNORE);
    if (!done && !final) return;
    if (!done) MPI_Wait(&pending_->request, MPI_STATUS_IGNORE);
  }
  pending_->message.progress = p;
  pending_->message.final = final ? 1 : 0;
  pending_->message.stopped = stopped;
  MPI_Isend(&pending_->message, sizeof(ProgressMessage), MPI_BYTE, 0, kTagProgress, MPI_COMM_WORLD,
            &pending_->request);
}

int Ranks::receive_progress(std::vector<Progress>& latest, std::vector<char>& final,
                            bool wait) const {
  int stopped = 0;
  for (;;) {
    int flag = 0;
    MPI_Status st;
    MPI_Iprobe(MPI_ANY_SOURCE, kTagProgress, MPI_COMM_WORLD, &flag, &st);
    if (!flag) {
      // Poll rather than block, so that the caller's timer and stop flag stay live.
      if (wait) std::this_thread::sleep_for(std::chrono::milliseconds(20));
      return stopped;
    }
    ProgressMessage m;
    MPI_Recv(&m, sizeof m, MPI_BYTE, st.MPI_SOURCE, kTagProgress, MPI_COMM_WORLD,
             MPI_STATUS_IGNORE);
    latest.at(static_cast<std::size_t>(st.MPI_SOURCE)) = m.progress;
    if (m.final) final.at(static_cast<std::size_t>(st.MPI_SOURCE)) = 1;
    if (m.stopped && !stopped) stopped = m.stopped;
    wait = false;  // something arrived: drain the rest without waiting
  }
}

void Ranks::send_stop(int signal, const std::vector<char>& final) const {
  for (int r = 1; r < size_; ++r)
    if (!final.at(static_cast<std::size_t>(r)))
      MPI_Send(&signal, 1, MPI_INT, r, kTagStop, MPI_COMM_WORLD);
}

int Ranks::poll_stop() const {
  if (root()) return 0;
  int signal = 0;
  for (;;) {  // every stop notice that has arrived (one at most, by send_stop)
    int flag = 0;
    MPI_Iprobe(0, kTagStop, MPI_COMM_WORLD, &flag, MPI_STATUS_IGNORE);
    if (!flag) return signal;
    MPI_Recv(&signal, 1, MPI_INT, 0, kTagStop, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  }
}

#else  // one rank

struct Ranks::Pending {};
Ranks::Ranks(int&, char**&) {}
Ranks::~Ranks() = default;
std::vector<std::string> Ranks::gather(const std::string& mine) const { return {mine}; }
void Ranks::barrier() const {}
int Ranks::broadcast(int value) const { return value; }
void Ranks::abort(int) const {}
void Ranks::send_progress(const Progress&, bool, int) {}
int Ranks::receive_progress(std::vector<Progress>&, std::vector<char>&, bool) const { return 0; }
void Ranks::send_stop(int, const std::vector<char>&) const {}
int Ranks::poll_stop() const { return 0; }

#endif

}  // namespace loosepack
