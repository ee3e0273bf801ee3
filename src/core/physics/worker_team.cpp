#include "tissue_cut/physics/worker_team.hpp"

#include <algorithm>
#include <chrono>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace tissue_cut {

namespace {

// A helper keeps looking for the next job this long before it sleeps: longer than the gaps
// between the jobs of one step (microseconds), short against a tick's idle time. Past the first
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

WorkerTeam::WorkerTeam(int size) : taken_(new std::atomic<std::uint64_t>[std::max(size, 1)]) {
  for (int i = 0; i < std::max(size, 1); ++i) taken_[i].store(0, std::memory_order_relaxed);
  for (int i = 1; i < std::max(size, 1); ++i) helpers_.emplace_back([this, i] { helperLoop(i); });
}

WorkerTeam::~WorkerTeam() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_.store(true, std::memory_order_relaxed);
    job_number_.fetch_add(1, std::memory_order_release);
  }
  wake_.notify_all();
  for (std::thread& t : helpers_) t.join();
}

int WorkerTeam::usable(int wanted) {
  const int cores = static_cast<int>(std::thread::hardware_concurrency());
  return std::max(1, cores > 0 ? std::min(wanted, cores) : wanted);
}

void WorkerTeam::runPart(int index, std::uint64_t job) {
  // Taken for this job already, or for a later one (a helper that saw this job too late: the
  // job is over, so job_ may be another's by now).
  std::uint64_t taken = taken_[index].load(std::memory_order_acquire);
  while (taken < job)
    if (taken_[index].compare_exchange_weak(taken, job, std::memory_order_acq_rel,
                                            std::memory_order_acquire)) {
      (*job_)(index);
      done_.fetch_add(1, std::memory_order_release);
      return;
    }
}

void WorkerTeam::expectJob(std::chrono::microseconds within) {
  if (helpers_.empty()) return;
  const auto until = std::chrono::steady_clock::now() + within;
  awake_until_.store(until.time_since_epoch().count());
  if (sleeping_.load() == 0) return;  // seq_cst with the helpers' count and look (see helperLoop)
  { std::lock_guard<std::mutex> lock(mutex_); }
  wake_.notify_all();
}

void WorkerTeam::run(const std::function<void(int)>& part) {
  if (helpers_.empty()) {
    part(0);
    return;
  }
  awake_until_.store(0, std::memory_order_relaxed);  // the expected job came
  job_ = &part;
  done_.store(0, std::memory_order_relaxed);
  std::uint64_t job;
  {
    // Under the mutex, so that a helper about to sleep either sees the new job or is already
    // waiting when the notification comes.
    std::lock_guard<std::mutex> lock(mutex_);
    job = job_number_.load(std::memory_order_relaxed) + 1;
    job_number_.store(job, std::memory_order_release);
  }
  wake_.notify_all();
  runPart(0, job);
  // The parts no helper has taken yet are the caller's.
  for (int i = 1; i < size(); ++i)
    if (taken_[i].load(std::memory_order_relaxed) < job) runPart(i, job);
  for (int looks = 0; done_.load(std::memory_order_acquire) < size(); ++looks) relax(looks);
}

void WorkerTeam::helperLoop(int index) {
  std::uint64_t seen = 0;
  for (;;) {
    const auto since = std::chrono::steady_clock::now();
    std::uint64_t now = job_number_.load(std::memory_order_acquire);
    // Sleeps once it has looked kSpinFor and no job is expected (see expectJob()). A helper
    // counts itself asleep before it looks at the expectation, and expectJob() sets that before
    // it looks at the count (both sequentially consistent): either the helper sees the
    // expectation and stays up, or expectJob() sees it asleep and wakes it.
    auto expected = [&] {
      return std::chrono::steady_clock::now().time_since_epoch().count() < awake_until_.load();
    };
    for (int looks = 0; now == seen; ++looks) {
      if ((looks & 63) == 63 && std::chrono::steady_clock::now() - since > kSpinFor &&
          !expected()) {
        std::unique_lock<std::mutex> lock(mutex_);
        sleeping_.fetch_add(1);
        wake_.wait(lock, [&] {
          return job_number_.load(std::memory_order_acquire) != seen || expected();
        });
        sleeping_.fetch_sub(1);
      } else {
        relax(looks);
      }
      now = job_number_.load(std::memory_order_acquire);
    }
    seen = now;
    if (stop_.load(std::memory_order_relaxed)) return;  // set before the job number changed
    runPart(index, now);
  }
}

}  // namespace tissue_cut
