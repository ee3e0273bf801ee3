// What the node's rostests share: a listener for ~stats and ~markers, waiting, and an incision
// played in real time from the project's path file.
#pragma once

#include <gtest/gtest.h>
#include <ros/ros.h>
#include <visualization_msgs/MarkerArray.h>

#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "tissue_cut/TissueStats.h"
#include "tissue_cut/cut/scalpel_path.hpp"

namespace tissue_cut::test {

/// Polls `done` every 10 ms for up to `timeout` [s] (callbacks run on an AsyncSpinner).
inline bool waitFor(const std::function<bool()>& done, double timeout) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
  while (ros::ok() && ros::WallTime::now() < end) {
    if (done()) return true;
    ros::WallDuration(0.01).sleep();
  }
  return done();
}

/// Keeps every ~stats message and the last ~markers message of node `node`.
class NodeListener {
 public:
  explicit NodeListener(const std::string& node) {
    ros::NodeHandle nh;
    stats_sub_ = nh.subscribe<TissueStats>(node + "/stats", 100, [this](const TissueStats::ConstPtr& m) {
      std::lock_guard<std::mutex> lock(mutex_);
      stats_.push_back(*m);
    });
    markers_sub_ = nh.subscribe<visualization_msgs::MarkerArray>(
        node + "/markers", 10, [this](const visualization_msgs::MarkerArray::ConstPtr& m) {
          std::lock_guard<std::mutex> lock(mutex_);
          markers_ = *m;
          ++marker_count_;
        });
  }
  std::size_t statsCount() {
    std::lock_guard<std::mutex> lock(mutex_);
    return stats_.size();
  }
  /// The next stats message after this call.
  std::optional<TissueStats> nextStats(double timeout = 5.0) {
    const std::size_t n = statsCount();
    if (!waitFor([&] { return statsCount() > n; }, timeout)) return std::nullopt;
    std::lock_guard<std::mutex> lock(mutex_);
    return stats_.back();
  }
  std::vector<TissueStats> statsSince(std::size_t first) {
    std::lock_guard<std::mutex> lock(mutex_);
    return std::vector<TissueStats>(stats_.begin() + std::min(first, stats_.size()), stats_.end());
  }
  /// The next markers message after this call.
  std::optional<visualization_msgs::MarkerArray> nextMarkers(double timeout = 5.0) {
    std::size_t n;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      n = marker_count_;
    }
    if (!waitFor(
            [&] {
              std::lock_guard<std::mutex> lock(mutex_);
              return marker_count_ > n;
            },
            timeout))
      return std::nullopt;
    std::lock_guard<std::mutex> lock(mutex_);
    return markers_;
  }
  /// Waits until the topology has settled: two stats messages 0.5 s apart (500 ticks, each with
  /// at least one collapse attempt when any is queued) with the same counts. Edges next to cut
  /// faces that have not opened stay queued (they wait for the cut to go on), so pending need
  /// not reach 0. Returns the later one.
  std::optional<TissueStats> settled(double timeout = 15.0) {
    std::optional<TissueStats> result;
    waitFor(
        [&] {
          auto a = nextStats();
          ros::WallDuration(0.5).sleep();
          auto b = nextStats();
          if (!a || !b) return false;
          if (a->tetrahedra == b->tetrahedra && a->surface_triangles == b->surface_triangles &&
              a->cut_tetrahedra == b->cut_tetrahedra && a->collapsed_edges == b->collapsed_edges) {
            result = b;
            return true;
          }
          return false;
        },
        timeout);
    return result;
  }

 private:
  std::mutex mutex_;
  std::vector<TissueStats> stats_;
  visualization_msgs::MarkerArray markers_;
  std::size_t marker_count_ = 0;
  ros::Subscriber stats_sub_, markers_sub_;
};

/// The project's incision across the block (tool poses in the mesh frame).
inline ScalpelPath blockIncision() {
  return ScalpelPath::read(std::string(TISSUE_CUT_SOURCE_DIR) + "/meshes/paths/incision_block.csv");
}

/// Plays `path` in real time at `rate` [Hz], calling `send(pose)` for each message.
inline void playPath(const ScalpelPath& path, double rate,
                     const std::function<void(const ToolPose&)>& send) {
  const ros::WallTime start = ros::WallTime::now();
  ros::WallRate loop(rate);
  for (;;) {
    const double s = (ros::WallTime::now() - start).toSec();
    send(path.at(path.startTime() + std::min(s, path.endTime() - path.startTime())));
    if (s >= path.endTime() - path.startTime() || !ros::ok()) break;
    loop.sleep();
  }
}

}  // namespace tissue_cut::test
