// cut_replay --bag: a recorded session (PoseStamped in a rosbag) replays offline exactly as the
// same poses given as a CSV path; bad bags are refused with a message and exit status 2.
#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <std_msgs/String.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "replay_runner.hpp"
#include "tissue_cut/cut/scalpel_path.hpp"

using namespace tissue_cut;
using tissue_cut::test::Outcome;
using tissue_cut::test::replay;
using tissue_cut::test::run;

namespace {

const std::string kSource = TISSUE_CUT_SOURCE_DIR;
const std::string kIncision = kSource + "/meshes/paths/incision_block.csv";

nlohmann::json stats(const std::string& file) {
  std::ifstream in(file);
  return nlohmann::json::parse(in);
}

/// Writes the rows of `path` as PoseStamped on /tissue/scalpel_pose, stamped from t0 [s].
void writeBag(const std::string& file, const ScalpelPath& path, double t0,
              const std::string& frame = "world") {
  rosbag::Bag bag(file, rosbag::bagmode::Write);
  for (const ToolPose& p : path.poses()) {
    geometry_msgs::PoseStamped m;
    m.header.stamp = ros::Time(t0 + p.t);
    m.header.frame_id = frame;
    m.pose.position.x = p.position.x();
    m.pose.position.y = p.position.y();
    m.pose.position.z = p.position.z();
    m.pose.orientation.x = p.orientation.x();
    m.pose.orientation.y = p.orientation.y();
    m.pose.orientation.z = p.orientation.z();
    m.pose.orientation.w = p.orientation.w();
    bag.write("/tissue/scalpel_pose", m.header.stamp, m);
  }
  std_msgs::String other;
  other.data = "not a pose";
  bag.write("/chatter", ros::Time(t0), other);
}

}  // namespace

TEST(CutReplayBag, ReplaysARecordedSessionLikeTheSamePathFile) {
  const std::string dir = testing::TempDir();
  const std::string bag = dir + "incision.bag";
  writeBag(bag, ScalpelPath::read(kIncision), 1000.0);
  // A collapse budget in microseconds depends on the machine's speed; unbounded is exact.
  const std::string config = dir + "unbounded.yaml";
  {
    std::ofstream yaml(config);
    yaml << "collapse:\n  budget_us: 0\n";
  }
  // The bag's poses are the CSV's to about 1e-17 m (the bag keeps stamps in nanoseconds), and the
  // cut from either is the same mesh. The collapse's greedy choices are not stable under such
  // round-off (a tie in quality goes either way, and the flips and moves after it differ), so with
  // collapse on the two replays are compared by their figures, and for sameness a bag against
  // itself.
  const std::string common = " --config " + config + " --no-physics --quiet";
  const Outcome from_csv = replay("--path " + kIncision + common + " --no-collapse --stats " + dir +
                                  "csv.json");
  ASSERT_EQ(from_csv.status, 0) << from_csv.output;
  const Outcome from_bag = replay("--bag " + bag + " --topic /tissue/scalpel_pose --check" + common +
                                  " --no-collapse --stats " + dir + "bag.json");
  ASSERT_EQ(from_bag.status, 0) << from_bag.output;
  const nlohmann::json a = stats(dir + "csv.json"), b = stats(dir + "bag.json");
  EXPECT_GT(b["cut"]["cut_tetrahedra"].get<int>(), 100);
  EXPECT_EQ(a["cut"]["cut_tetrahedra"], b["cut"]["cut_tetrahedra"]);
  EXPECT_EQ(a["cut"]["created_tetrahedra"], b["cut"]["created_tetrahedra"]);
  EXPECT_EQ(a["mesh"], b["mesh"]);
  // With collapse: the same cut, a region of about the same size and quality.
  const Outcome csv_collapsed = replay("--path " + kIncision + common + " --stats " + dir +
                                       "csv_c.json");
  ASSERT_EQ(csv_collapsed.status, 0) << csv_collapsed.output;
  const Outcome bag_collapsed = replay("--bag " + bag + " --topic /tissue/scalpel_pose --check" +
                                       common + " --stats " + dir + "bag_c.json");
  ASSERT_EQ(bag_collapsed.status, 0) << bag_collapsed.output;
  const nlohmann::json ac = stats(dir + "csv_c.json"), bc = stats(dir + "bag_c.json");
  EXPECT_EQ(ac["cut"]["cut_tetrahedra"], bc["cut"]["cut_tetrahedra"]);
  const double region_a = ac["region"]["tetrahedra"].get<double>(),
               region_b = bc["region"]["tetrahedra"].get<double>();
  EXPECT_NEAR(region_b, region_a, 0.1 * region_a);
  EXPECT_NEAR(bc["region"]["quality_mean"].get<double>(),
              ac["region"]["quality_mean"].get<double>(), 0.02);
  // Deterministic: the same bag twice gives the same mesh, collapse and all.
  const Outcome again = replay("--bag " + bag + " --topic /tissue/scalpel_pose" + common +
                               " --stats " + dir + "bag2.json");
  ASSERT_EQ(again.status, 0) << again.output;
  EXPECT_EQ(stats(dir + "bag2.json")["mesh"], bc["mesh"]);
}

TEST(CutReplayBag, RefusesBadBagsNamingTheProblem) {
  const std::string dir = testing::TempDir();
  const std::string bag = dir + "refusals.bag";
  writeBag(bag, ScalpelPath::read(kIncision), 5.0);
  const std::string elsewhere = dir + "elsewhere.bag";
  writeBag(elsewhere, ScalpelPath::read(kIncision), 5.0, "camera");
  {
    std::ofstream junk(dir + "junk.bag");
    junk << "not a bag at all";
  }
  struct Case {
    std::string args, expect;
  };
  for (const Case& c : std::vector<Case>{
           {"--bag " + dir + "missing.bag --topic /x", "missing.bag"},
           {"--bag " + dir + "junk.bag --topic /x", "junk.bag"},
           {"--bag " + bag + " --topic /nothing_here", "/nothing_here"},
           {"--bag " + bag + " --topic /chatter", "std_msgs/String"},
           {"--bag " + elsewhere + " --topic /tissue/scalpel_pose", "camera"}}) {
    const Outcome r = replay(c.args + " --no-physics --quiet");
    EXPECT_EQ(r.status, 2) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.expect), std::string::npos) << c.args << "\n" << r.output;
  }
  EXPECT_EQ(replay("--bag " + bag).status, 1);  // --topic missing: usage
}
