// WorkerTeam: every part of every job runs once, on its own thread, and the caller sees what the
// parts wrote; helpers that went to sleep between jobs wake for the next one.
#include <gtest/gtest.h>

#include <chrono>
#include <set>
#include <thread>
#include <vector>

#include "tissue_cut/physics/worker_team.hpp"

using namespace tissue_cut;

TEST(WorkerTeam, RunsEveryPartOnceOnItsOwnThread) {
  WorkerTeam team(3);
  ASSERT_EQ(team.size(), 3);
  std::vector<std::thread::id> ids(3);
  std::vector<long long> sums(3, 0);
  long long expected = 0;
  for (int job = 1; job <= 20000; ++job) {
    // Each part reads what the caller wrote last (its own sum) and writes it back grown.
    team.run([&](int part) {
      ids[part] = std::this_thread::get_id();
      sums[part] += job * (part + 1);
    });
    expected += job;
    ASSERT_EQ(sums[0], expected) << "job " << job;
    ASSERT_EQ(sums[1], 2 * expected) << "job " << job;
    ASSERT_EQ(sums[2], 3 * expected) << "job " << job;
  }
  EXPECT_EQ(ids[0], std::this_thread::get_id());  // part 0 runs on the caller
  EXPECT_EQ(std::set<std::thread::id>(ids.begin(), ids.end()).size(), 3u);
}

TEST(WorkerTeam, SleepingHelpersWakeForTheNextJob) {
  WorkerTeam team(2);
  int done = 0;
  for (int job = 0; job < 5; ++job) {
    // Far longer than the helpers look for work before they sleep.
    std::this_thread::sleep_for(std::chrono::milliseconds(3));
    int parts = 0;
    std::vector<int> seen(2, 0);
    team.run([&](int part) { seen[part] = 1; });
    for (int s : seen) parts += s;
    EXPECT_EQ(parts, 2) << "job " << job;
    ++done;
  }
  EXPECT_EQ(done, 5);
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
