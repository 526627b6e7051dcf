// MPI ranks of one run (OpenMPI; without MPI a run is one rank). Members are sharded over the
// ranks by what the cost model leaves of each (share_over_ranks), each rank runs its share, and
// rank 0 gathers the results and writes the output file; progress from every rank reaches rank
// 0, which alone talks to the user.
#pragma once
#include <csignal>
#include <memory>
#include <string>
#include <vector>

#include "loosepack/protocols.hpp"

namespace loosepack {

class Ranks {
 public:
  // Initialises MPI (when built with it) for the lifetime of the object.
  Ranks(int& argc, char**& argv);
  ~Ranks();
  Ranks(const Ranks&) = delete;
  Ranks& operator=(const Ranks&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }
  bool root() const { return rank_ == 0; }

  // Rank 0 receives every rank's bytes, in rank order (its own first); the others get nothing
  // back. Sent point to point in chunks, so shares beyond 2 GiB travel too.
  std::vector<std::string> gather(const std::string& mine) const;
  void barrier() const;
  // Rank 0's value, on every rank.
  int broadcast(int value) const;
  // Ends every rank at once (MPI_Abort) when there are several; nothing with one rank.
  void abort(int code) const;

  // Not rank 0: tells rank 0 how far this rank got. A progress message still in flight makes
  // this one be dropped, except the final one, which is always delivered; the final one carries
  // the signal that stopped this rank (`stopped`, 0 when it finished its share).
  void send_progress(const Progress& p, bool final, int stopped = 0);
  // Rank 0: takes the progress messages that have arrived (waiting for one when `wait`);
  // latest[r] holds rank r's latest, final[r] whether rank r is done (finished or stopped).
  // Returns the signal that stopped a rank whose final message arrived, else 0.
  int receive_progress(std::vector<Progress>& latest, std::vector<char>& final, bool wait) const;
  // A stop of the whole run, whichever rank the signal reached: rank 0 tells each rank not yet
  // done to stop (`signal`); the others poll for that notice (the signal, or 0).
  void send_stop(int signal, const std::vector<char>& final) const;
  int poll_stop() const;
  // The end of the wait for the ranks, once each has sent its final message. Rank 0 (`decide`)
  // sends every rank the run's verdict (the signal that stops it, or 0) and then takes all
  // that rank sent before it learnt the verdict, so no message is left unreceived. The others
  // (`await_verdict`) wait for it; a signal that reaches such a rank meanwhile goes to rank 0
  // in a final message again (`own`, with the signal), where it stops the run like a signal to
  // rank 0 while ranks still compute. Both return the verdict.
  int decide(int stop) const;
  int await_verdict(const Progress& own, const volatile std::sig_atomic_t& signal);

 private:
  int rank_ = 0, size_ = 1;
  struct Pending;  // the progress message in flight and the messages counted (MPI only)
  std::unique_ptr<Pending> pending_;
};

}  // namespace loosepack
