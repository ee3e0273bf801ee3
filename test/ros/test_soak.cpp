// Soak: the scripted scalpel cuts back and forth over the block for ~passes (test/ros/soak.test);
// the node must keep a valid mesh of bounded size, flat memory and its rate. Figures are printed
// and recorded in the test's XML; the size bound and validity are asserted.
#include <std_srvs/Trigger.h>

#include <algorithm>
#include <cstdio>

#include "node_test_util.hpp"

namespace tissue_cut::test {
namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

TEST(Soak, BackAndForthPassesKeepAValidBoundedMeshAndFlatMemory) {
  ros::NodeHandle pnh("~");
  int passes = 6;
  double pass_seconds = 2.0;
  pnh.getParam("passes", passes);
  pnh.getParam("pass_seconds", pass_seconds);
  NodeListener listener("/tissue");
  auto first = listener.nextStats(30.0);
  ASSERT_TRUE(first) << "no ~stats";
  const unsigned initial_tets = first->tetrahedra;

  // Watch the whole session: the player starts when it sees the node and plays passes in turn.
  const double session = passes * pass_seconds + 10.0;
  std::vector<double> rates, rss;
  unsigned max_tets = 0;
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(session);
  double rss_after_first_pass = 0.0;
  const ros::WallTime start = ros::WallTime::now();
  while (ros::WallTime::now() < end && ros::ok()) {
    auto s = listener.nextStats();
    ASSERT_TRUE(s) << "the node stopped publishing";
    max_tets = std::max(max_tets, s->tetrahedra);
    if (s->cut_tetrahedra > 0) rates.push_back(s->rate_hz);
    rss.push_back(s->memory_rss_mb);
    if (rss_after_first_pass == 0.0 && (ros::WallTime::now() - start).toSec() > pass_seconds + 5.0)
      rss_after_first_pass = s->memory_rss_mb;
  }
  auto last = listener.settled();
  ASSERT_TRUE(last) << "the mesh never settled";
  std_srvs::Trigger validate;
  ASSERT_TRUE(ros::service::call("/tissue/validate", validate));
  EXPECT_TRUE(validate.response.success) << validate.response.message;
  EXPECT_GT(last->cut_tetrahedra, 100u);
  EXPECT_LE(max_tets, 3u * initial_tets) << "collapse did not keep the mesh bounded";
  EXPECT_NEAR(last->volume_rest, first->volume_rest, 1e-3 * first->volume_rest);

  const double rate = median(rates);
  std::printf("soak: %d passes, %u -> max %u -> %u tets (%u cut, %u created, %u removed), "
              "memory %.1f MiB after pass 1 -> %.1f MiB at the end, median rate while cutting "
              "%.0f Hz, %u deadline misses, %s\n",
              passes, initial_tets, max_tets, last->tetrahedra, last->cut_tetrahedra,
              last->created_tetrahedra, last->removed_tetrahedra, rss_after_first_pass,
              last->memory_rss_mb, rate, last->deadline_misses, validate.response.message.c_str());
  ::testing::Test::RecordProperty("max_tetrahedra", std::to_string(max_tets));
  ::testing::Test::RecordProperty("memory_mib_first_pass", std::to_string(rss_after_first_pass));
  ::testing::Test::RecordProperty("memory_mib_end", std::to_string(last->memory_rss_mb));
  ::testing::Test::RecordProperty("median_rate_hz", std::to_string(rate));
  // Memory follows the mesh, which collapse keeps bounded: no growth beyond the mesh's own.
  EXPECT_LE(last->memory_rss_mb,
            rss_after_first_pass * (1.0 + double(last->tetrahedra) / initial_tets) + 16.0);
}

}  // namespace
}  // namespace tissue_cut::test

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_soak");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
