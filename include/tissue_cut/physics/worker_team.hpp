// WorkerTeam: a fixed team of threads that run the parts of one job together (part i on thread i,
// part 0 on the caller) and return when every part is done. Made for the implicit step's loops:
// a job lasts tens of microseconds and a step runs a few dozen of them back to back, so helpers
// wait for the next job spinning (then yielding) for a while before they sleep, and a job costs
// two cache-line handoffs instead of a wake-up.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace tissue_cut {

class WorkerTeam {
 public:
  /// `size` threads in all (size - 1 helpers); at least 1.
  explicit WorkerTeam(int size);
  ~WorkerTeam();
  WorkerTeam(const WorkerTeam&) = delete;
  WorkerTeam& operator=(const WorkerTeam&) = delete;

  int size() const { return static_cast<int>(helpers_.size()) + 1; }
  /// Runs part(0) .. part(size() - 1) at once, part(0) on the calling thread; returns when all
  /// have returned. Everything the caller wrote before is visible to the parts, and everything
  /// the parts wrote is visible to the caller after. Not reentrant; parts must not throw.
  void run(const std::function<void(int)>& part);

  /// The threads a team of `wanted` gets on this machine: at most its hardware threads.
  static int usable(int wanted);

 private:
  void helperLoop(int index);

  std::vector<std::thread> helpers_;
  const std::function<void(int)>* job_ = nullptr;
  std::atomic<std::uint64_t> generation_{0};
  std::atomic<int> remaining_{0};
  std::atomic<bool> stop_{false};  // published by the generation change after it
  std::mutex mutex_;
  std::condition_variable wake_;
};

}  // namespace tissue_cut
