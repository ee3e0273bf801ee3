// WorkerTeam: every part of every job runs once, and the caller sees what the parts wrote; the
// helpers take parts; helpers that went to sleep between jobs wake for the next one.
#include <gtest/gtest.h>

#include <chrono>
#include <set>
#include <thread>
#include <vector>

#include "tissue_cut/physics/worker_team.hpp"

using namespace tissue_cut;

TEST(WorkerTeam, RunsEveryPartOnceAndTheHelpersTakeParts) {
  WorkerTeam team(3);
  ASSERT_EQ(team.size(), 3);
  std::vector<long long> sums(3, 0);
  std::vector<int> runs(3, 0);
  long long expected = 0;
  std::set<std::thread::id> threads;
  std::vector<std::thread::id> ids(3);
  // Tiny jobs (the caller often runs a part a helper has not taken yet) and jobs of a few
  // microseconds, as a step's loops take (time for the helpers to take theirs).
  for (int job = 1; job <= 22000; ++job) {
    const int work = job <= 20000 ? 0 : 2000;
    // Each part reads what the caller wrote last (its own sum) and writes it back grown.
    team.run([&](int part) {
      volatile double x = 0.0;
      for (int k = 0; k < work; ++k) x = x + 1e-3 * k;
      ids[part] = std::this_thread::get_id();
      sums[part] += job * (part + 1);
      ++runs[part];
    });
    expected += job;
    ASSERT_EQ(sums[0], expected) << "job " << job;
    ASSERT_EQ(sums[1], 2 * expected) << "job " << job;
    ASSERT_EQ(sums[2], 3 * expected) << "job " << job;
    if (work > 0) threads.insert(ids.begin(), ids.end());
  }
  EXPECT_EQ(runs, std::vector<int>(3, 22000));
  EXPECT_GT(threads.size(), 1u);  // the helpers did take parts
}

TEST(WorkerTeam, SleepingHelpersWakeForTheNextJob) {
  WorkerTeam team(2);
  for (int job = 0; job < 5; ++job) {
    // Far longer than the helpers look for work before they sleep.
    std::this_thread::sleep_for(std::chrono::milliseconds(3));
    std::vector<int> runs(2, 0);
    team.run([&](int part) { ++runs[part]; });
    EXPECT_EQ(runs, std::vector<int>({1, 1})) << "job " << job;  // each part once, then back
  }
}

// expectJob(): a sleeping helper wakes and keeps looking (it does not go back to sleep after
// its usual spin) until the job comes or the time given has passed; then it sleeps again.
TEST(WorkerTeam, AnExpectedJobKeepsTheHelpersAwakeUntilItComes) {
  using namespace std::chrono_literals;
  WorkerTeam team(2);
  auto waitFor = [&](int sleeping, std::chrono::milliseconds within) {
    const auto end = std::chrono::steady_clock::now() + within;
    while (team.sleepingHelpers() != sleeping && std::chrono::steady_clock::now() < end)
      std::this_thread::sleep_for(100us);
    return team.sleepingHelpers() == sleeping;
  };
  ASSERT_TRUE(waitFor(1, 2000ms)) << "an idle helper sleeps";
  team.expectJob(std::chrono::microseconds(400000));
  ASSERT_TRUE(waitFor(0, 2000ms)) << "the expectation wakes it";
  // Far longer than a helper looks before it sleeps, well within the expectation.
  std::this_thread::sleep_for(20ms);
  EXPECT_EQ(team.sleepingHelpers(), 0) << "it stays awake while the job is expected";
  std::vector<int> runs(2, 0);
  team.run([&](int part) { ++runs[part]; });
  EXPECT_EQ(runs, std::vector<int>({1, 1}));
  EXPECT_TRUE(waitFor(1, 2000ms)) << "the job came: it sleeps again";
  // An expectation that passes without a job ends too.
  team.expectJob(std::chrono::microseconds(50000));
  EXPECT_TRUE(waitFor(0, 2000ms));
  EXPECT_TRUE(waitFor(1, 2000ms)) << "the expectation passed: it sleeps again";
}

TEST(WorkerTeam, OneThreadRunsOnTheCaller) {
  WorkerTeam team(1);
  EXPECT_EQ(team.size(), 1);
  std::thread::id id;
  team.run([&](int part) {
    EXPECT_EQ(part, 0);
    id = std::this_thread::get_id();
  });
  EXPECT_EQ(id, std::this_thread::get_id());
  EXPECT_EQ(WorkerTeam::usable(1), 1);
  EXPECT_GE(WorkerTeam::usable(2), 1);
  EXPECT_LE(WorkerTeam::usable(2), 2);
}
