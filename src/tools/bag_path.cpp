#include "bag_path.hpp"

#include <geometry_msgs/PoseStamped.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>

#include "tissue_cut/cut/blade.hpp"

namespace tissue_cut {

ScalpelPath readBagPath(const std::string& bag_file, const std::string& topic,
                        const std::string& frame_id) {
  rosbag::Bag bag;
  try {
    bag.open(bag_file, rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    throw PathError(bag_file + ": cannot read the bag: " + e.what());
  }
  std::vector<ToolPose> poses;
  double first = 0.0;
  try {
    rosbag::View view(bag, rosbag::TopicQuery(topic));
    if (view.size() == 0) throw PathError(bag_file + ": no messages on topic '" + topic + "'");
    int index = 0;
    for (const rosbag::MessageInstance& m : view) {
      ++index;
      const std::string where = bag_file + ": message " + std::to_string(index) + " on '" + topic + "'";
      auto msg = m.instantiate<geometry_msgs::PoseStamped>();
      if (!msg)
        throw PathError(where + " is a " + m.getDataType() + ", not a geometry_msgs/PoseStamped");
      if (!msg->header.frame_id.empty() && msg->header.frame_id != frame_id)
        throw PathError(where + " is in frame '" + msg->header.frame_id + "', not in '" +
                        frame_id + "' (the replay has no tf2)");
      const double stamp = msg->header.stamp.isZero() ? m.getTime().toSec() : msg->header.stamp.toSec();
      if (poses.empty()) first = stamp;
      ToolPose p;
      p.t = stamp - first;
      const auto& x = msg->pose.position;
      const auto& q = msg->pose.orientation;
      p.position = Vec3(x.x, x.y, x.z);
      p.orientation = Eigen::Quaterniond(q.w, q.x, q.y, q.z);
      const std::string bad = checkPose(p.position, p.orientation);
      if (!bad.empty()) throw PathError(where + ": " + bad);
      if (!poses.empty() && p.t < poses.back().t)
        throw PathError(where + ": time goes backwards");
      p.orientation.normalize();
      poses.push_back(p);
    }
  } catch (const rosbag::BagException& e) {
    throw PathError(bag_file + ": " + e.what());
  }
  return ScalpelPath(std::move(poses));
}

}  // namespace tissue_cut
