// rostest of the tissue node reading the scalpel as tf2 frame "scalpel" each tick
// (test/ros/tissue_node_tf.test starts it with ~scalpel_frame set).
#include <tf2_ros/transform_broadcaster.h>

#include "node_test_util.hpp"

namespace tissue_cut::test {
namespace {

TEST(TissueNodeTf, RunsWithoutTheFrameAndCutsWhenTheFrameMoves) {
  NodeListener listener("/tissue");
  // No "scalpel" frame yet: the node warns and keeps ticking.
  auto first = listener.nextStats(20.0);
  ASSERT_TRUE(first) << "no ~stats message";
  auto second = listener.nextStats();
  ASSERT_TRUE(second);
  EXPECT_GT(second->ticks, first->ticks);
  EXPECT_EQ(second->cut_tetrahedra, 0u);

  tf2_ros::TransformBroadcaster broadcaster;
  playPath(blockIncision(), 200.0, [&](const ToolPose& p) {
    geometry_msgs::TransformStamped tf;
    tf.header.stamp = ros::Time::now();
    tf.header.frame_id = "world";
    tf.child_frame_id = "scalpel";
    tf.transform.translation.x = p.position.x();
    tf.transform.translation.y = p.position.y();
    tf.transform.translation.z = p.position.z();
    tf.transform.rotation.x = p.orientation.x();
    tf.transform.rotation.y = p.orientation.y();
    tf.transform.rotation.z = p.orientation.z();
    tf.transform.rotation.w = p.orientation.w();
    broadcaster.sendTransform(tf);
  });
  // The frame goes stale once we stop: the blade lifts and the cut finishes.
  auto s = listener.settled();
  ASSERT_TRUE(s) << "the cut never settled";
  EXPECT_GT(s->cut_tetrahedra, 100u);
  EXPECT_GT(s->created_tetrahedra, s->cut_tetrahedra);
  auto m = listener.nextMarkers();
  ASSERT_TRUE(m);
  ASSERT_GE(m->markers.size(), 1u);
  EXPECT_EQ(m->markers[0].points.size(), 3u * s->surface_triangles);
}

}  // namespace
}  // namespace tissue_cut::test

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_tissue_node_tf");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
