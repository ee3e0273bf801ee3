// scalpel_player: plays a scalpel path file (CSV t,x,y,z,qx,qy,qz,qw) as PoseStamped messages on
// `scalpel_pose`, in real time. Parameters (private):
//   path           the CSV file (required)
//   frame_id       frame of the poses (default "world")
//   rate           messages per second [Hz] (default 200)
//   start_delay    seconds to wait after a subscriber appears (default 0.5)
//   passes         times the path is played (default 1; 0 = until shutdown)
//   back_and_forth every second pass plays the path backwards (default false)
//   pass_offset    [x, y, z] added to the positions on each further pass [m] (default 0 0 0)
// It exits when done; the tissue lifts the blade once poses stop coming.
#include <optional>

#include <geometry_msgs/PoseStamped.h>
#include <ros/ros.h>

#include "tissue_cut/cut/scalpel_path.hpp"

int main(int argc, char** argv) {
  ros::init(argc, argv, "scalpel_player");
  ros::NodeHandle nh, pnh("~");
  std::string path_file, frame_id = "world";
  double rate = 200.0, start_delay = 0.5;
  int passes = 1;
  bool back_and_forth = false;
  std::vector<double> offset{0.0, 0.0, 0.0};
  if (!pnh.getParam("path", path_file)) {
    ROS_FATAL("scalpel_player: parameter ~path (a CSV path file) is required");
    return 1;
  }
  pnh.getParam("frame_id", frame_id);
  pnh.getParam("rate", rate);
  pnh.getParam("start_delay", start_delay);
  pnh.getParam("passes", passes);
  pnh.getParam("back_and_forth", back_and_forth);
  pnh.getParam("pass_offset", offset);
  if (!(rate > 0 && rate <= 100000) || passes < 0 || offset.size() != 3 || !(start_delay >= 0)) {
    ROS_FATAL("scalpel_player: rate must be in (0, 100000] Hz, passes >= 0, start_delay >= 0, "
              "pass_offset 3 numbers");
    return 1;
  }
  std::optional<tissue_cut::ScalpelPath> path;
  try {
    path = tissue_cut::ScalpelPath::read(path_file);
  } catch (const std::exception& e) {
    ROS_FATAL("scalpel_player: %s", e.what());
    return 1;
  }
  ros::Publisher pub = nh.advertise<geometry_msgs::PoseStamped>("scalpel_pose", 100);
  const ros::WallTime wait_until = ros::WallTime::now() + ros::WallDuration(30.0);
  while (ros::ok() && pub.getNumSubscribers() == 0 && ros::WallTime::now() < wait_until)
    ros::WallDuration(0.05).sleep();
  ros::WallDuration(start_delay).sleep();

  const double t0 = path->startTime(), duration = path->endTime() - t0;
  ros::WallRate loop(rate);
  long sent = 0;
  for (int pass = 0; ros::ok() && (passes == 0 || pass < passes); ++pass) {
    const bool backwards = back_and_forth && pass % 2 == 1;
    const tissue_cut::Vec3 shift =
        static_cast<double>(pass) * tissue_cut::Vec3(offset[0], offset[1], offset[2]);
    const ros::WallTime start = ros::WallTime::now();
    for (double s = 0.0; ros::ok(); s = (ros::WallTime::now() - start).toSec()) {
      const double u = std::min(s, duration);
      const tissue_cut::ToolPose p = path->at(backwards ? path->endTime() - u : t0 + u);
      geometry_msgs::PoseStamped msg;
      msg.header.stamp = ros::Time::now();
      msg.header.frame_id = frame_id;
      msg.pose.position.x = p.position.x() + shift.x();
      msg.pose.position.y = p.position.y() + shift.y();
      msg.pose.position.z = p.position.z() + shift.z();
      msg.pose.orientation.x = p.orientation.x();
      msg.pose.orientation.y = p.orientation.y();
      msg.pose.orientation.z = p.orientation.z();
      msg.pose.orientation.w = p.orientation.w();
      pub.publish(msg);
      ++sent;
      if (s >= duration) break;
      loop.sleep();
    }
  }
  ROS_INFO("scalpel_player: played %s, %ld poses", path_file.c_str(), sent);
  ros::WallDuration(0.2).sleep();  // let the last messages leave
  return 0;
}
