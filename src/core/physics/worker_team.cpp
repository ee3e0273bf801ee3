#include "tissue_cut/physics/worker_team.hpp"

#include <algorithm>
#include <chrono>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace tissue_cut {

namespace {

// A helper keeps looking for the next job this long before it sleeps: longer than the gaps
// between the jobs of one step (microseconds), shorter than a tick's idle time. Past the first
// few microseconds it yields between looks, so that a machine with more runnable threads than
// cores (tests side by side) still gets on.
constexpr std::chrono::microseconds kSpinFor(100);
constexpr int kPauseLooks = 2000;

void relax(int looks) {
  if (looks < kPauseLooks) {
#if defined(__x86_64__) || defined(__i386__)
    _mm_pause();
#endif
  } else {
    std::this_thread::yield();
  }
}

}  // namespace

WorkerTeam::WorkerTeam(int size) {
  for (int i = 1; i < std::max(size, 1); ++i) helpers_.emplace_back([this, i] { helperLoop(i); });
}

WorkerTeam::~WorkerTeam() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_.store(true, std::memory_order_relaxed);
    generation_.fetch_add(1, std::memory_order_release);
  }
  wake_.notify_all();
  for (std::thread& t : helpers_) t.join();
}

int WorkerTeam::usable(int wanted) {
  const int cores = static_cast<int>(std::thread::hardware_concurrency());
  return std::max(1, cores > 0 ? std::min(wanted, cores) : wanted);
}

void WorkerTeam::run(const std::function<void(int)>& part) {
  if (helpers_.empty()) {
    part(0);
    return;
  }
  job_ = &part;
  remaining_.store(static_cast<int>(helpers_.size()), std::memory_order_relaxed);
  {
    // Under the mutex, so that a helper about to sleep either sees the new generation or is
    // already waiting when the notification comes.
    std::lock_guard<std::mutex> lock(mutex_);
    generation_.fetch_add(1, std::memory_order_release);
  }
  wake_.notify_all();
  part(0);
  for (int looks = 0; remaining_.load(std::memory_order_acquire) > 0; ++looks) relax(looks);
}

void WorkerTeam::helperLoop(int index) {
  std::uint64_t seen = 0;
  for (;;) {
    const auto since = std::chrono::steady_clock::now();
    std::uint64_t now = generation_.load(std::memory_order_acquire);
    for (int looks = 0; now == seen; ++looks) {
      if ((looks & 63) == 63 && std::chrono::steady_clock::now() - since > kSpinFor) {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return generation_.load(std::memory_order_acquire) != seen; });
      } else {
        relax(looks);
      }
      now = generation_.load(std::memory_order_acquire);
    }
    seen = now;
    if (stop_.load(std::memory_order_relaxed)) return;  // set before the generation changed
    (*job_)(index);
    remaining_.fetch_sub(1, std::memory_order_release);
  }
}

}  // namespace tissue_cut
