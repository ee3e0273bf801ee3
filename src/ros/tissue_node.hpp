// TissueNode: the ROS face of one Tissue. Owns the node handles, the scalpel input (topic, tf2 or
// an interactive marker), the fixed-rate tick thread, the publishers, services and reconfigure.
#pragma once

#include <atomic>
#include <chrono>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <geometry_msgs/PoseStamped.h>
#include <interactive_markers/interactive_marker_server.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "surface_markers.hpp"
#include "tissue_cut/LoadMesh.h"
#include "tissue_cut/SaveMesh.h"
#include "tissue_cut/TissueConfig.h"
#include "tissue_cut/TissueStats.h"
#include "tissue_cut/tissue.hpp"

namespace tissue_cut {

/// Reads every Config key present in `pnh` (private namespace, keys as in config/tissue.yaml).
/// Throws ConfigError naming the parameter for a wrong type or an unusable value.
Config configFromParameters(const ros::NodeHandle& pnh);

/// Settings of the node itself (not of the model).
struct NodeSettings {
  std::string scalpel_frame;     ///< tf2 frame of the tool read each tick; "" = use the topic
  double pose_timeout = 0.5;     ///< a pose older than this lifts the blade [s]
  bool interactive_scalpel = true;
  MarkerStyle style;
};
NodeSettings nodeSettingsFromParameters(const ros::NodeHandle& pnh, const Config& config);

class TissueNode {
 public:
  /// Loads parameters and the mesh, advertises everything, starts the tick thread.
  /// Throws ConfigError / MeshIOError / std::invalid_argument naming what is wrong.
  TissueNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~TissueNode();
  TissueNode(const TissueNode&) = delete;
  TissueNode& operator=(const TissueNode&) = delete;

  /// Gives a tool pose to the cut; returns why it was refused, or "".
  std::string acceptPose(const geometry_msgs::PoseStamped& pose);

 private:
  using SteadyClock = std::chrono::steady_clock;
  struct Input {
    std::optional<BladeSegment> blade;
    SteadyClock::time_point received{};
    bool stale_reported = false;
  };

  void poseCallback(const geometry_msgs::PoseStamped::ConstPtr& msg);
  void markerFeedback(const visualization_msgs::InteractiveMarkerFeedbackConstPtr& feedback);
  std::optional<BladeSegment> bladeThisTick();
  void tickLoop();
  void publishTimer(const ros::SteadyTimerEvent& event);
  void fillStats(const Statistics& s, TissueStats* msg);
  bool resetService(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
  bool loadMeshService(LoadMesh::Request& req, LoadMesh::Response& res);
  bool saveMeshService(SaveMesh::Request& req, SaveMesh::Response& res);
  bool validateService(std_srvs::Trigger::Request& req, std_srvs::Trigger::Response& res);
  void reconfigure(TissueConfig& cfg, uint32_t level);
  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& status);
  void makeInteractiveScalpel();
  void clearInput();

  ros::NodeHandle nh_, pnh_;
  Config config_;  // guarded by model_mutex_
  NodeSettings settings_;
  std::string frame_id_;  // the mesh frame, fixed at start-up (read by every thread)
  double blade_length_ = 0.03;  // guarded by input_mutex_

  std::mutex model_mutex_;  // the Tissue, config_, snapshot-taking; never held by two ticks
  std::atomic<int> model_waiting_{0};  // threads other than the tick's waiting for model_mutex_
  /// model_mutex_ for anyone but the tick thread, which lets such waiters go first.
  std::unique_lock<std::mutex> lockModel();
  std::unique_ptr<Tissue> tissue_;
  std::unique_ptr<SkinClassifier> skin_;  // guarded by marker_mutex_
  std::mutex marker_mutex_;
  SurfaceSnapshot snapshot_;
  visualization_msgs::MarkerArray markers_;

  std::mutex input_mutex_;
  Input input_;
  std::optional<BladeSegment> last_blade_;  // guarded by model_mutex_ (for the blade marker)

  // Tick timing, guarded by model_mutex_.
  TickTimes window_;                        // last second of ticks
  std::deque<SteadyClock::time_point> tick_starts_;
  std::uint64_t deadline_misses_ = 0, ticks_ = 0;

  tf2_ros::Buffer tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  ros::Subscriber pose_sub_;
  ros::Publisher markers_pub_, stats_pub_;
  ros::ServiceServer reset_srv_, load_srv_, save_srv_, validate_srv_;
  ros::SteadyTimer publish_timer_;
  diagnostic_updater::Updater diagnostics_;
  std::unique_ptr<dynamic_reconfigure::Server<TissueConfig>> reconfigure_server_;
  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<interactive_markers::InteractiveMarkerServer> marker_server_;

  std::atomic<bool> running_{true};
  std::thread tick_thread_;
};

}  // namespace tissue_cut
