// WorkerTeam: a fixed team of threads that run the parts of one job together and return when
// every part is done. Made for the implicit step's loops: a job lasts tens of microseconds and a
// step runs a few dozen of them back to back, so helpers wait for the next job spinning (then
// yielding) for a while before they sleep. Part i goes to thread i (part 0 to the caller), so
// that each thread keeps working on the same data from job to job (its own cache); a part whose
// helper has not taken it by the time the caller is done with its own is run by the caller: a
// helper that is late (asleep, or its core busy with something else) costs the job its
// parallelism, not a wait.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
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
  /// Runs part(0) .. part(size() - 1), each once, on the calling thread and the helpers; returns
  /// when all have returned. Everything the caller wrote before is visible to the parts, and
  /// everything the parts wrote is visible to the caller after. Which thread runs a part may
  /// depend on timing: a part's work must depend on its index only. Not reentrant; parts must
  /// not throw.
  void run(const std::function<void(int)>& part);

  /// A job is coming within `within`: the helpers keep looking for it until it comes or that
  /// time has passed, instead of going to sleep (those asleep are woken now). Waking a sleeping
  /// helper costs the thread that wakes it 20-40 us on these machines, and the helper as much
  /// again before it takes a part: a caller that knows a job is coming after a stretch of work
  /// of its own (longer than helpers look before they sleep) calls this before that stretch.
  void expectJob(std::chrono::microseconds within);

  /// Helpers asleep now (waiting for a job or an expectJob()).
  int sleepingHelpers() const { return sleeping_.load(); }

  /// The threads a team of `wanted` gets on this machine: at most its hardware threads.
  static int usable(int wanted);

 private:
  void helperLoop(int index);
  /// Runs part `index` of job `job` unless another thread has taken it (or the job is over).
  void runPart(int index, std::uint64_t job);

  std::vector<std::thread> helpers_;
  const std::function<void(int)>* job_ = nullptr;
  std::atomic<std::uint64_t> job_number_{0};
  // Per part, the number of the last job it was taken for (only grows).
  std::unique_ptr<std::atomic<std::uint64_t>[]> taken_;
  std::atomic<int> done_{0};        // parts of this job finished
  std::atomic<bool> stop_{false};   // published by the job number change after it
  // expectJob(): until when (steady clock, its ticks) helpers look instead of sleeping; 0 once
  // a job came. Helpers sleeping now.
  std::atomic<std::int64_t> awake_until_{0};
  std::atomic<int> sleeping_{0};
  std::mutex mutex_;
  std::condition_variable wake_;
};

}  // namespace tissue_cut
