// The tissue node: see TissueNode. A bad parameter or mesh stops it with a message naming it.
#include <ros/ros.h>

#include "tissue_node.hpp"

int main(int argc, char** argv) {
  ros::init(argc, argv, "tissue");
  try {
    tissue_cut::TissueNode node(ros::NodeHandle(), ros::NodeHandle("~"));
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("tissue: %s", e.what());
    return 1;
  }
  return 0;
}
