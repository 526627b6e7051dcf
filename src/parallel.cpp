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
constexpr int kTagProgress = 1, kTagSize = 2, kTagChunk = 3, kTagStop = 4, kTagVerdict = 5,
              kTagSent = 6;
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
  // Messages counted so that the verdict's exchange (decide, await_verdict) leaves none behind:
  // progress messages this rank sent, and on rank 0 those received from each rank; stop
  // notices rank 0 sent to each rank, and on the others those received.
  long long progress_sent = 0;
  std::vector<long long> progress_received, stops_sent;
  int stops_received = 0;
};

Ranks::Ranks(int& argc, char**& argv) {
  MPI_Init(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  pending_ = std::make_unique<Pending>();
  pending_->progress_received.assign(static_cast<std::size_t>(size_), 0);
  pending_->stops_sent.assign(static_cast<std::size_t>(size_), 0);
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
  ++pending_->progress_sent;
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
    ++pending_->progress_received.at(static_cast<std::size_t>(st.MPI_SOURCE));
    latest.at(static_cast<std::size_t>(st.MPI_SOURCE)) = m.progress;
    if (m.final) final.at(static_cast<std::size_t>(st.MPI_SOURCE)) = 1;
    if (m.stopped && !stopped) stopped = m.stopped;
    wait = false;  // something arrived: drain the rest without waiting
  }
}

void Ranks::send_stop(int signal, const std::vector<char>& final) const {
  for (int r = 1; r < size_; ++r)
    if (!final.at(static_cast<std::size_t>(r))) {
      MPI_Send(&signal, 1, MPI_INT, r, kTagStop, MPI_COMM_WORLD);
      ++pending_->stops_sent[static_cast<std::size_t>(r)];
    }
}

int Ranks::poll_stop() const {
  if (root()) return 0;
  int signal = 0;
  for (;;) {  // every stop notice that has arrived (one at most, by send_stop)
    int flag = 0;
    MPI_Iprobe(0, kTagStop, MPI_COMM_WORLD, &flag, MPI_STATUS_IGNORE);
    if (!flag) return signal;
    MPI_Recv(&signal, 1, MPI_INT, 0, kTagStop, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    ++pending_->stops_received;
  }
}

int Ranks::decide(int stop) const {
  for (int r = 1; r < size_; ++r) {
    const int verdict[2] = {stop,
                            static_cast<int>(pending_->stops_sent[static_cast<std::size_t>(r)])};
    MPI_Send(verdict, 2, MPI_INT, r, kTagVerdict, MPI_COMM_WORLD);
  }
  for (int r = 1; r < size_; ++r) {
    long long sent = 0;
    MPI_Recv(&sent, 1, MPI_LONG_LONG, r, kTagSent, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    for (auto& got = pending_->progress_received[static_cast<std::size_t>(r)]; got < sent; ++got) {
      ProgressMessage late;  // a signal's, sent as the verdict went out: the run has ended
      MPI_Recv(&late, sizeof late, MPI_BYTE, r, kTagProgress, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    }
  }
  return stop;
}

int Ranks::await_verdict(const Progress& own, const volatile std::sig_atomic_t& signal) {
  int verdict[2] = {0, 0};
  bool passed_on = pending_->message.stopped != 0;  // the final message carried a signal
  for (;;) {
    poll_stop();  // a stop notice that crossed this rank's final message
    int flag = 0;
    MPI_Iprobe(0, kTagVerdict, MPI_COMM_WORLD, &flag, MPI_STATUS_IGNORE);
    if (flag) break;
    if (signal && !passed_on) {
      send_progress(own, true, signal);
      passed_on = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  MPI_Recv(verdict, 2, MPI_INT, 0, kTagVerdict, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  for (; pending_->stops_received < verdict[1]; ++pending_->stops_received) {
    int notice = 0;
    MPI_Recv(&notice, 1, MPI_INT, 0, kTagStop, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  }
  MPI_Send(&pending_->progress_sent, 1, MPI_LONG_LONG, 0, kTagSent, MPI_COMM_WORLD);
  return verdict[0];
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
int Ranks::decide(int stop) const { return stop; }
int Ranks::await_verdict(const Progress&, const volatile std::sig_atomic_t&) { return 0; }

#endif

}  // namespace loosepack
