// rostest of the tissue node driven through ~scalpel_pose (test/ros/tissue_node.test starts it on
// the built-in block). Cases run in order; each starts from ~reset, the mesh-loading ones last.
#include <dynamic_reconfigure/Reconfigure.h>
#include <geometry_msgs/PoseStamped.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "node_test_util.hpp"
#include "tissue_cut/LoadMesh.h"
#include "tissue_cut/SaveMesh.h"

namespace tissue_cut::test {
namespace {

constexpr const char* kNode = "/tissue";
constexpr unsigned kBlockTets = 5100;

// Sets the node's dynamic_reconfigure parameters that `request` holds; returns what it took.
dynamic_reconfigure::Config reconfigureNode(const dynamic_reconfigure::Config& request) {
  dynamic_reconfigure::Reconfigure srv;
  srv.request.config = request;
  EXPECT_TRUE(ros::service::call(std::string(kNode) + "/set_parameters", srv));
  return srv.response.config;
}

class TissueNodeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ros::NodeHandle nh;
    pose_pub_ = nh.advertise<geometry_msgs::PoseStamped>(std::string(kNode) + "/scalpel_pose", 100);
    ASSERT_TRUE(waitFor([&] { return pose_pub_.getNumSubscribers() > 0; }, 20.0))
        << "the node never subscribed to ~scalpel_pose";
    ASSERT_TRUE(ros::service::waitForService(std::string(kNode) + "/reset", ros::Duration(20)));
    std_srvs::Trigger reset;
    ASSERT_TRUE(ros::service::call(std::string(kNode) + "/reset", reset));
    ASSERT_TRUE(reset.response.success) << reset.response.message;
  }

  void send(const ToolPose& p, const std::string& frame = "world", const Vec3& shift = Vec3::Zero()) {
    geometry_msgs::PoseStamped msg;
    msg.header.stamp = ros::Time::now();
    msg.header.frame_id = frame;
    msg.pose.position.x = p.position.x() + shift.x();
    msg.pose.position.y = p.position.y() + shift.y();
    msg.pose.position.z = p.position.z() + shift.z();
    msg.pose.orientation.x = p.orientation.x();
    msg.pose.orientation.y = p.orientation.y();
    msg.pose.orientation.z = p.orientation.z();
    msg.pose.orientation.w = p.orientation.w();
    pose_pub_.publish(msg);
  }

  LoadMesh load(const std::string& path) {
    LoadMesh srv;
    srv.request.path = path;
    EXPECT_TRUE(ros::service::call(std::string(kNode) + "/load_mesh", srv));
    return srv;
  }

  NodeListener listener_{kNode};
  ros::Publisher pose_pub_;
};

TEST_F(TissueNodeTest, PublishesStatisticsOfTheUncutBlock) {
  auto s = listener_.nextStats(10.0);
  ASSERT_TRUE(s) << "no ~stats message";
  EXPECT_EQ(s->tetrahedra, kBlockTets);
  EXPECT_EQ(s->cut_tetrahedra, 0u);
  EXPECT_EQ(s->quality_histogram.size(), 10u);
  EXPECT_NEAR(s->volume_rest, 0.1 * 0.06 * 0.03, 1e-9);
  EXPECT_GT(s->quality_min, 0.7);
  EXPECT_GT(s->rate_hz, 0.0);
}

TEST_F(TissueNodeTest, IncisionOnTheTopicCutsAndMarkersMatchTheSurface) {
  const std::size_t first = listener_.statsCount();
  playPath(blockIncision(), 200.0, [&](const ToolPose& p) { send(p); });
  const std::vector<TissueStats> during = listener_.statsSince(first);
  auto s = listener_.settled();
  ASSERT_TRUE(s) << "the cut never settled";
  EXPECT_GT(s->cut_tetrahedra, 100u);
  EXPECT_GT(s->created_tetrahedra, s->cut_tetrahedra);
  EXPECT_GT(s->tetrahedra, kBlockTets);
  EXPECT_NEAR(s->volume_rest, 0.1 * 0.06 * 0.03, 1e-3 * 0.1 * 0.06 * 0.03);

  // The achieved tick rate while cutting is a figure, not a pass/fail (a loaded machine would
  // fail it): recorded in the test's XML and printed; scripts/node_rate measures it on purpose.
  ASSERT_GE(during.size(), 10u) << "stats stopped while cutting";
  std::vector<double> rates;
  for (const TissueStats& m : during) rates.push_back(m.rate_hz);
  std::nth_element(rates.begin(), rates.begin() + rates.size() / 2, rates.end());
  ::testing::Test::RecordProperty("median_rate_hz_while_cutting",
                                  std::to_string(rates[rates.size() / 2]));
  std::printf("median achieved rate while cutting: %.0f Hz\n", rates[rates.size() / 2]);

  auto m = listener_.nextMarkers();
  ASSERT_TRUE(m) << "no ~markers message";
  ASSERT_GE(m->markers.size(), 1u);
  const visualization_msgs::Marker& surface = m->markers[0];
  EXPECT_EQ(surface.type, visualization_msgs::Marker::TRIANGLE_LIST);
  EXPECT_EQ(surface.points.size(), 3u * s->surface_triangles);
  EXPECT_EQ(surface.colors.size(), surface.points.size());
  // Cut walls are coloured apart from the skin: two colours on the surface after a cut.
  const auto differs = [&](const std_msgs::ColorRGBA& c) {
    return std::abs(c.r - surface.colors[0].r) + std::abs(c.g - surface.colors[0].g) > 0.1;
  };
  EXPECT_TRUE(std::any_of(surface.colors.begin(), surface.colors.end(), differs));
}

TEST_F(TissueNodeTest, PoseInAnotherFrameIsTransformedByTf2) {
  // "table" sits 0.1 m above "world": the same incision given in "table" must cut the same way.
  tf2_ros::StaticTransformBroadcaster broadcaster;
  geometry_msgs::TransformStamped tf;
  tf.header.stamp = ros::Time::now();
  tf.header.frame_id = "world";
  tf.child_frame_id = "table";
  tf.transform.translation.z = 0.1;
  tf.transform.rotation.w = 1.0;
  broadcaster.sendTransform(tf);
  ros::WallDuration(0.5).sleep();
  playPath(blockIncision(), 200.0,
           [&](const ToolPose& p) { send(p, "table", Vec3(0.0, 0.0, -0.1)); });
  auto s = listener_.settled();
  ASSERT_TRUE(s);
  EXPECT_GT(s->cut_tetrahedra, 100u);
}

TEST_F(TissueNodeTest, InvalidPosesAreIgnoredAndTheNodeRunsOn) {
  const ScalpelPath path = blockIncision();
  ToolPose p = path.at(0.5 * (path.startTime() + path.endTime()));  // blade inside the block
  auto before = listener_.nextStats();
  ASSERT_TRUE(before);
  for (int i = 0; i < 50; ++i) {
    ToolPose nan_pose = p;
    nan_pose.position.x() = std::nan("");
    send(nan_pose);
    ToolPose zero_q = p;
    zero_q.orientation = Eigen::Quaterniond(0, 0, 0, 0);
    send(zero_q);
    ToolPose inf_pose = p;
    inf_pose.position.z() = INFINITY;
    send(inf_pose);
    send(p, "no_such_frame");
    ros::WallDuration(0.005).sleep();
  }
  ros::WallDuration(0.5).sleep();
  auto after = listener_.nextStats();
  ASSERT_TRUE(after) << "the node stopped publishing";
  EXPECT_GT(after->ticks, before->ticks);
  EXPECT_EQ(after->cut_tetrahedra, 0u) << "an invalid pose reached the cut";
  EXPECT_EQ(after->tetrahedra, kBlockTets);
  // And a valid incision still cuts afterwards.
  playPath(path, 200.0, [&](const ToolPose& q) { send(q); });
  auto s = listener_.settled();
  ASSERT_TRUE(s);
  EXPECT_GT(s->cut_tetrahedra, 100u);
}

TEST_F(TissueNodeTest, ResetRestoresTheUncutMesh) {
  auto uncut = listener_.nextStats();
  ASSERT_TRUE(uncut);
  playPath(blockIncision(), 200.0, [&](const ToolPose& p) { send(p); });
  auto cut = listener_.settled();
  ASSERT_TRUE(cut);
  ASSERT_GT(cut->cut_tetrahedra, 0u);
  std_srvs::Trigger reset;
  ASSERT_TRUE(ros::service::call(std::string(kNode) + "/reset", reset));
  EXPECT_TRUE(reset.response.success);
  auto s = listener_.nextStats();
  ASSERT_TRUE(s);
  EXPECT_EQ(s->tetrahedra, kBlockTets);
  EXPECT_EQ(s->cut_tetrahedra, 0u);
  EXPECT_EQ(s->created_tetrahedra, 0u);
  EXPECT_EQ(s->surface_triangles, uncut->surface_triangles);
  EXPECT_EQ(s->vertices, uncut->vertices);
  EXPECT_GT(cut->surface_triangles, uncut->surface_triangles);
}

// dynamic_reconfigure sets the blade filter live, and the model takes it: held at a still
// blade's cutoff of 0.01 Hz with no rise for speed, the blade stays where it was put down until
// the tool is cut/max_jump (20 mm) from it, then jumps there (lifted across the gap), so the
// incision cuts a small part of what it cuts unfiltered. Turned off again for the cases after.
TEST_F(TissueNodeTest, ReconfigureSetsTheBladeFilterLive) {
  auto set = [](double min_cutoff, double beta) {
    dynamic_reconfigure::Config request;
    dynamic_reconfigure::DoubleParameter p;
    p.name = "blade_filter_min_cutoff";
    p.value = min_cutoff;
    request.doubles.push_back(p);
    p.name = "blade_filter_beta";
    p.value = beta;
    request.doubles.push_back(p);
    std::map<std::string, double> got;
    for (const auto& d : reconfigureNode(request).doubles) got[d.name] = d.value;
    return got;
  };
  playPath(blockIncision(), 200.0, [&](const ToolPose& p) { send(p); });
  auto unfiltered = listener_.settled();
  ASSERT_TRUE(unfiltered);
  std_srvs::Trigger reset;
  ASSERT_TRUE(ros::service::call(std::string(kNode) + "/reset", reset));
  auto got = set(0.01, 0.0);
  EXPECT_EQ(got["blade_filter_min_cutoff"], 0.01);
  EXPECT_EQ(got["blade_filter_beta"], 0.0);
  playPath(blockIncision(), 200.0, [&](const ToolPose& p) { send(p); });
  auto held = listener_.settled();
  got = set(0.0, 20.0);
  EXPECT_EQ(got["blade_filter_min_cutoff"], 0.0);
  ASSERT_TRUE(held);
  std::printf("cut tets: %u unfiltered, %u held back\n", unfiltered->cut_tetrahedra,
              held->cut_tetrahedra);
  EXPECT_GT(unfiltered->cut_tetrahedra, 50u);
  EXPECT_LT(held->cut_tetrahedra, unfiltered->cut_tetrahedra / 3);
}

// The collapse queue's flips and smoothing (collapse/flips, collapse/smoothing) are live settings
// too: turned off and on again through dynamic_reconfigure, the node answers with what it took
// and goes on publishing.
TEST_F(TissueNodeTest, ReconfigureTurnsTheCollapseExtensionsOffAndOn) {
  auto set = [](bool on) {
    dynamic_reconfigure::Config request;
    dynamic_reconfigure::BoolParameter p;
    p.value = on;
    for (const char* name : {"collapse_flips", "collapse_smoothing"}) {
      p.name = name;
      request.bools.push_back(p);
    }
    std::map<std::string, bool> got;
    for (const auto& b : reconfigureNode(request).bools) got[b.name] = b.value;
    return got;
  };
  auto got = set(false);
  EXPECT_EQ(got.count("collapse_flips"), 1u);
  EXPECT_FALSE(got["collapse_flips"]);
  EXPECT_FALSE(got["collapse_smoothing"]);
  EXPECT_TRUE(listener_.nextStats().has_value());
  got = set(true);
  EXPECT_TRUE(got["collapse_flips"]);
  EXPECT_TRUE(got["collapse_smoothing"]);
}

TEST_F(TissueNodeTest, SaveMeshWritesAFileThatLoadMeshReadsBack) {
  playPath(blockIncision(), 200.0, [&](const ToolPose& p) { send(p); });
  auto cut = listener_.settled();
  ASSERT_TRUE(cut);
  const std::string file = "/tmp/tissue_cut_rostest_" + std::to_string(::getpid()) + ".vtk";
  SaveMesh save;
  save.request.path = file;
  ASSERT_TRUE(ros::service::call(std::string(kNode) + "/save_mesh", save));
  ASSERT_TRUE(save.response.success) << save.response.message;
  LoadMesh loaded = load(file);
  EXPECT_TRUE(loaded.response.success) << loaded.response.message;
  EXPECT_EQ(loaded.response.tetrahedra, cut->tetrahedra);
  auto s = listener_.nextStats();
  ASSERT_TRUE(s);
  EXPECT_EQ(s->tetrahedra, cut->tetrahedra);
  EXPECT_EQ(s->cut_tetrahedra, 0u);  // counts start again with the loaded mesh
  std::remove(file.c_str());

  SaveMesh bad;
  bad.request.path = "/nonexistent_dir/x.vtk";
  ASSERT_TRUE(ros::service::call(std::string(kNode) + "/save_mesh", bad));
  EXPECT_FALSE(bad.response.success);
  EXPECT_NE(bad.response.message.find("/nonexistent_dir/x.vtk"), std::string::npos)
      << bad.response.message;
}

TEST_F(TissueNodeTest, LoadMeshLoadsAGmshFile) {
  LoadMesh srv = load(std::string(TISSUE_CUT_SOURCE_DIR) + "/meshes/ellipsoid_v22.msh");
  ASSERT_TRUE(srv.response.success) << srv.response.message;
  EXPECT_EQ(srv.response.tetrahedra, 1622u);
  auto s = listener_.nextStats();
  ASSERT_TRUE(s);
  EXPECT_EQ(s->tetrahedra, 1622u);
}

TEST_F(TissueNodeTest, LoadMeshRefusesBadMissingAndEmptyPathsAndKeepsTheMesh) {
  auto before = listener_.nextStats();
  ASSERT_TRUE(before);
  const std::string src = TISSUE_CUT_SOURCE_DIR;
  for (const std::string& path :
       {src + "/test/data/no_such_mesh.msh", src + "/test/data", std::string(""),
        src + "/test/data/bad/msh22_truncated.msh", src + "/README.md"}) {
    LoadMesh srv = load(path);
    EXPECT_FALSE(srv.response.success) << path;
    EXPECT_FALSE(srv.response.message.empty()) << path;
    if (!path.empty()) {
      EXPECT_NE(srv.response.message.find(path), std::string::npos) << srv.response.message;
    }
  }
  auto after = listener_.nextStats();
  ASSERT_TRUE(after);
  EXPECT_EQ(after->tetrahedra, before->tetrahedra);
  EXPECT_EQ(after->vertices, before->vertices);
}

}  // namespace
}  // namespace tissue_cut::test

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_tissue_node");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  return RUN_ALL_TESTS();
}
