// A scalpel path from a rosbag: the geometry_msgs/PoseStamped messages of one topic.
#pragma once

#include <string>

#include "tissue_cut/cut/scalpel_path.hpp"

namespace tissue_cut {

/// Reads every PoseStamped on `topic` of `bag_file` into a path; t is the header stamp (the
/// recording time when a stamp is zero) relative to the first message [s]. Poses must be in
/// `frame_id` (or have no frame): no tf2 offline. Throws PathError naming the file, topic or
/// message: unreadable bag, no such topic, another message type, a frame other than frame_id,
/// time going backwards, a non-finite value or a zero quaternion.
ScalpelPath readBagPath(const std::string& bag_file, const std::string& topic,
                        const std::string& frame_id);

}  // namespace tissue_cut
