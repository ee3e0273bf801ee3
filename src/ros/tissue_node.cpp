#include "tissue_node.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <unistd.h>

#include <tf2_geometry_msgs/tf2_geometry_msgs.h>
#include <yaml-cpp/yaml.h>

#include "tissue_cut/mesh/mesh_io.hpp"

namespace tissue_cut {
namespace {

constexpr double kWarnPeriod = 1.0;  // [s] between repeats of one kind of warning
constexpr double kMaxCatchUp = 4.0;  // a late tick simulates at most this many periods

YAML::Node toYaml(const XmlRpc::XmlRpcValue& v, const std::string& name) {
  XmlRpc::XmlRpcValue value = v;  // XmlRpc's conversions are not const
  switch (value.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean: return YAML::Node(static_cast<bool>(value));
    case XmlRpc::XmlRpcValue::TypeInt: return YAML::Node(static_cast<int>(value));
    case XmlRpc::XmlRpcValue::TypeDouble: return YAML::Node(static_cast<double>(value));
    case XmlRpc::XmlRpcValue::TypeString: return YAML::Node(static_cast<std::string>(value));
    case XmlRpc::XmlRpcValue::TypeArray: {
      YAML::Node seq(YAML::NodeType::Sequence);
      for (int i = 0; i < value.size(); ++i) seq.push_back(toYaml(value[i], name));
      return seq;
    }
    default: throw ConfigError("parameter " + name + ": a value of an unusable type");
  }
}

template <typename T>
T optionalParameter(const ros::NodeHandle& pnh, const std::string& key, const T& fallback) {
  if (!pnh.hasParam(key)) return fallback;
  T value;
  if (!pnh.getParam(key, value))
    throw ConfigError("parameter " + pnh.resolveName(key) + ": a value of the wrong type");
  return value;
}

// This process's resident memory [MiB] from /proc, or 0 where there is none.
double residentMegabytes() {
  FILE* f = std::fopen("/proc/self/statm", "r");
  if (!f) return 0.0;
  long pages = 0, resident = 0;
  const int n = std::fscanf(f, "%ld %ld", &pages, &resident);
  std::fclose(f);
  return n == 2 ? resident * (sysconf(_SC_PAGESIZE) / 1048576.0) : 0.0;
}

double seconds(std::chrono::steady_clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

// The model's live settings as dynamic_reconfigure shows them (the view settings are apart), and
// back.
void putModelValues(const Config& c, TissueConfig* r) {
  r->collapse_enabled = c.collapse.enabled;
  r->collapse_tau = c.collapse.tau;
  r->collapse_budget_us = c.collapse.budget_us;
  r->collapse_deadline = c.collapse.deadline;
  r->collapse_flips = c.collapse.flips;
  r->collapse_smoothing = c.collapse.smoothing;
  r->blade_length = c.cut.blade_length;
  r->blade_filter_min_cutoff = c.cut.filter_min_cutoff;
  r->blade_filter_beta = c.cut.filter_beta;
  r->physics_enabled = c.physics.enabled;
  r->young_modulus = c.physics.young_modulus;
  r->damping = c.physics.damping;
  r->gravity_x = c.physics.gravity.x();
  r->gravity_y = c.physics.gravity.y();
  r->gravity_z = c.physics.gravity.z();
}

Config withReconfigureValues(Config c, const TissueConfig& r) {
  c.collapse.enabled = r.collapse_enabled;
  c.collapse.tau = r.collapse_tau;
  c.collapse.budget_us = r.collapse_budget_us;
  c.collapse.deadline = r.collapse_deadline;
  c.collapse.flips = r.collapse_flips;
  c.collapse.smoothing = r.collapse_smoothing;
  c.cut.blade_length = r.blade_length;
  c.cut.filter_min_cutoff = r.blade_filter_min_cutoff;
  c.cut.filter_beta = r.blade_filter_beta;
  c.physics.enabled = r.physics_enabled;
  c.physics.young_modulus = r.young_modulus;
  c.physics.damping = r.damping;
  c.physics.gravity = Vec3(r.gravity_x, r.gravity_y, r.gravity_z);
  return c;
}

}  // namespace

Config configFromParameters(const ros::NodeHandle& pnh) {
  Config config;
  for (const std::string& key : configKeys()) {
    if (!pnh.hasParam(key)) continue;
    XmlRpc::XmlRpcValue value;
    pnh.getParam(key, value);
    const std::string name = pnh.resolveName(key);
    setConfigValue(key, toYaml(value, name), "parameter " + name, &config);
  }
  const std::string bad = config.check();
  if (!bad.empty()) throw ConfigError("parameter " + pnh.resolveName("") + "/" + bad);
  return config;
}

NodeSettings nodeSettingsFromParameters(const ros::NodeHandle& pnh, const Config& config) {
  NodeSettings s;
  s.scalpel_frame = optionalParameter<std::string>(pnh, "scalpel_frame", "");
  s.pose_timeout = optionalParameter<double>(pnh, "pose_timeout", s.pose_timeout);
  if (!std::isfinite(s.pose_timeout) || s.pose_timeout <= 0 || s.pose_timeout > 3600)
    throw ConfigError("parameter " + pnh.resolveName("pose_timeout") + ": must be in (0, 3600] s");
  s.interactive_scalpel = optionalParameter<bool>(pnh, "interactive_scalpel", true);
  s.style.frame_id = config.frame_id;
  s.style.color_by_quality = optionalParameter<bool>(pnh, "color_by_quality", false);
  s.style.show_collapse_queue = optionalParameter<bool>(pnh, "show_collapse_queue", true);
  return s;
}

TissueNode::TissueNode(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), diagnostics_(nh, pnh) {
  // The same order as robot_localization: parameters, model, diagnostics, I/O, then the loop.
  config_ = configFromParameters(pnh_);
  settings_ = nodeSettingsFromParameters(pnh_, config_);
  blade_length_ = config_.cut.blade_length;
  frame_id_ = config_.frame_id;
  const MeshData mesh = loadTissueMesh(config_);
  tissue_ = std::make_unique<Tissue>(config_, mesh);
  skin_ = std::make_unique<SkinClassifier>(tissue_->mesh());
  window_.setWindow(static_cast<std::size_t>(std::ceil(config_.rate)));
  ROS_INFO("tissue: %s, %d vertices, %d tetrahedra, %.0f Hz, frame '%s'",
           config_.mesh.empty() ? "built-in block" : config_.mesh.c_str(),
           tissue_->mesh().numVertices(), tissue_->mesh().numTets(), config_.rate,
           config_.frame_id.c_str());

  diagnostics_.setHardwareID("tissue_cut");
  diagnostics_.add("tick loop", this, &TissueNode::diagnose);

  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(tf_buffer_, nh_);
  markers_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>("markers", 1, /*latch=*/true);
  stats_pub_ = pnh_.advertise<TissueStats>("stats", 10);
  if (settings_.scalpel_frame.empty())
    pose_sub_ = pnh_.subscribe("scalpel_pose", 100, &TissueNode::poseCallback, this,
                               ros::TransportHints().tcpNoDelay());
  else
    ROS_INFO("tissue: the scalpel is tf2 frame '%s'", settings_.scalpel_frame.c_str());
  reset_srv_ = pnh_.advertiseService("reset", &TissueNode::resetService, this);
  load_srv_ = pnh_.advertiseService("load_mesh", &TissueNode::loadMeshService, this);
  save_srv_ = pnh_.advertiseService("save_mesh", &TissueNode::saveMeshService, this);
  validate_srv_ = pnh_.advertiseService("validate", &TissueNode::validateService, this);

  reconfigure_server_ =
      std::make_unique<dynamic_reconfigure::Server<TissueConfig>>(reconfigure_mutex_, pnh_);
  TissueConfig initial;
  putModelValues(config_, &initial);
  initial.color_by_quality = settings_.style.color_by_quality;
  initial.show_collapse_queue = settings_.style.show_collapse_queue;
  reconfigure_server_->updateConfig(initial);
  reconfigure_server_->setCallback(
      [this](TissueConfig& cfg, uint32_t level) { reconfigure(cfg, level); });

  if (settings_.interactive_scalpel) makeInteractiveScalpel();

  publish_timer_ = nh_.createSteadyTimer(ros::WallDuration(1.0 / config_.publish_rate),
                                         &TissueNode::publishTimer, this);
  tick_thread_ = std::thread(&TissueNode::tickLoop, this);
}

TissueNode::~TissueNode() {
  running_ = false;
  if (tick_thread_.joinable()) tick_thread_.join();
}

// --- input

std::string TissueNode::acceptPose(const geometry_msgs::PoseStamped& msg) {
  const auto& p = msg.pose.position;
  const auto& o = msg.pose.orientation;
  const std::string bad = checkPose(Vec3(p.x, p.y, p.z), Eigen::Quaterniond(o.w, o.x, o.y, o.z));
  if (!bad.empty()) return bad;
  if (!msg.header.stamp.isZero() &&
      (ros::Time::now() - msg.header.stamp).toSec() > settings_.pose_timeout)
    return "pose is stale (stamped " +
           std::to_string((ros::Time::now() - msg.header.stamp).toSec()) + " s ago)";
  geometry_msgs::PoseStamped in_frame = msg;
  const std::string& frame = frame_id_;
  if (!msg.header.frame_id.empty() && msg.header.frame_id != frame) {
    try {
      const geometry_msgs::TransformStamped tf =
          tf_buffer_.lookupTransform(frame, msg.header.frame_id, ros::Time(0));
      tf2::doTransform(msg, in_frame, tf);
    } catch (const tf2::TransformException& e) {
      return "cannot transform frame '" + msg.header.frame_id + "' to '" + frame + "': " +
             e.what();
    }
  }
  const auto& q = in_frame.pose.position;
  const auto& r = in_frame.pose.orientation;
  std::lock_guard<std::mutex> lock(input_mutex_);
  input_.blade = bladeFromPose(Vec3(q.x, q.y, q.z), Eigen::Quaterniond(r.w, r.x, r.y, r.z),
                               blade_length_);
  input_.received = SteadyClock::now();
  input_.stale_reported = false;
  return "";
}

void TissueNode::poseCallback(const geometry_msgs::PoseStamped::ConstPtr& msg) {
  const std::string why = acceptPose(*msg);
  if (!why.empty()) ROS_WARN_THROTTLE(kWarnPeriod, "tissue: scalpel pose ignored: %s", why.c_str());
}

void TissueNode::markerFeedback(
    const visualization_msgs::InteractiveMarkerFeedbackConstPtr& feedback) {
  if (feedback->event_type != visualization_msgs::InteractiveMarkerFeedback::POSE_UPDATE) return;
  geometry_msgs::PoseStamped pose;
  pose.header.frame_id = feedback->header.frame_id;
  pose.pose = feedback->pose;
  const std::string why = acceptPose(pose);
  if (!why.empty()) ROS_WARN_THROTTLE(kWarnPeriod, "tissue: marker pose ignored: %s", why.c_str());
}

std::optional<BladeSegment> TissueNode::bladeThisTick() {
  if (!settings_.scalpel_frame.empty()) {
    try {
      const geometry_msgs::TransformStamped tf =
          tf_buffer_.lookupTransform(frame_id_, settings_.scalpel_frame, ros::Time(0));
      if (!tf.header.stamp.isZero() &&
          (ros::Time::now() - tf.header.stamp).toSec() > settings_.pose_timeout) {
        ROS_WARN_THROTTLE(kWarnPeriod, "tissue: scalpel frame '%s' is stale: blade lifted",
                          settings_.scalpel_frame.c_str());
        return std::nullopt;
      }
      const auto& t = tf.transform.translation;
      const auto& r = tf.transform.rotation;
      const Vec3 origin(t.x, t.y, t.z);
      const Eigen::Quaterniond q(r.w, r.x, r.y, r.z);
      const std::string bad = checkPose(origin, q);
      if (!bad.empty()) {
        ROS_WARN_THROTTLE(kWarnPeriod, "tissue: scalpel frame ignored: %s", bad.c_str());
        return std::nullopt;
      }
      std::lock_guard<std::mutex> lock(input_mutex_);
      return bladeFromPose(origin, q, blade_length_);
    } catch (const tf2::TransformException& e) {
      ROS_WARN_THROTTLE(kWarnPeriod, "tissue: no transform from '%s' to '%s': %s",
                        settings_.scalpel_frame.c_str(), frame_id_.c_str(), e.what());
      return std::nullopt;
    }
  }
  std::lock_guard<std::mutex> lock(input_mutex_);
  if (!input_.blade) return std::nullopt;
  if (seconds(SteadyClock::now() - input_.received) > settings_.pose_timeout) {
    if (!input_.stale_reported)
      ROS_INFO("tissue: no scalpel pose for %.2f s: blade lifted", settings_.pose_timeout);
    input_.stale_reported = true;
    input_.blade.reset();
    return std::nullopt;
  }
  return input_.blade;
}

void TissueNode::clearInput() {
  std::lock_guard<std::mutex> lock(input_mutex_);
  input_ = Input{};
}

// --- the loop

std::unique_lock<std::mutex> TissueNode::lockModel() {
  ++model_waiting_;
  std::unique_lock<std::mutex> lock(model_mutex_);
  --model_waiting_;
  return lock;
}

void TissueNode::tickLoop() {
  const double dt = 1.0 / config_.rate;
  const auto period = std::chrono::duration_cast<SteadyClock::duration>(
      std::chrono::duration<double>(dt));
  const double period_ms = 1e3 * dt;
  auto next = SteadyClock::now();
  std::optional<SteadyClock::time_point> last_start;
  while (running_ && ros::ok()) {
    next += period;
    std::this_thread::sleep_until(next);
    const std::optional<BladeSegment> blade = bladeThisTick();
    std::string warning;
    {
      std::lock_guard<std::mutex> lock(model_mutex_);
      const auto t0 = SteadyClock::now();
      // A tick that starts late steps the simulation by the time that passed (at most
      // kMaxCatchUp periods), so the tissue keeps pace with the scalpel, which moves in real
      // time. Stepping one period while the scalpel moved several let later strokes meet the
      // tissue where it had not moved yet: a 20-pass soak behind schedule re-cut its way to
      // 55,680 tets.
      const double step_dt =
          last_start ? std::clamp(seconds(t0 - *last_start), dt, kMaxCatchUp * dt) : dt;
      last_start = t0;
      warning = tissue_->step(blade, step_dt);
      const auto t1 = SteadyClock::now();
      last_blade_ = blade;
      window_.record(1e3 * seconds(t1 - t0), period_ms);
      ++ticks_;
      if (t1 > next + period) ++deadline_misses_;
      tick_starts_.push_back(t0);
      while (!tick_starts_.empty() && t1 - tick_starts_.front() > std::chrono::seconds(1))
        tick_starts_.pop_front();
    }
    // Behind schedule the next tick would take the mutex again at once, and std::mutex is not
    // fair: callbacks, services and the marker timer waiting for the model starved (no pose for
    // 0.5 s, no ~stats for 5 s in a 20-pass soak). They go first.
    while (model_waiting_.load() > 0 && running_) std::this_thread::yield();
    if (!warning.empty()) ROS_WARN_THROTTLE(kWarnPeriod, "tissue: %s", warning.c_str());
    // Far behind (a long service, a stalled machine): start the schedule again from now.
    if (SteadyClock::now() - next > 100 * period) next = SteadyClock::now();
  }
}

// --- outputs

void TissueNode::fillStats(const Statistics& s, TissueStats* m) {
  m->header.stamp = ros::Time::now();
  m->header.frame_id = frame_id_;
  m->vertices = s.vertices;
  m->tetrahedra = s.tetrahedra;
  m->surface_triangles = s.surface_triangles;
  m->cut_tetrahedra = s.cut.cut_tetrahedra;
  m->created_tetrahedra = s.cut.created_tetrahedra;
  m->removed_tetrahedra = s.collapse.removed_tetrahedra;
  m->collapsed_edges = s.collapse.collapsed_edges;
  m->pending_collapses = s.collapse.pending;
  m->quality_min = s.quality.min;
  m->quality_mean = s.quality.mean;
  m->region_quality_min = s.region.quality_min;
  m->region_quality_mean = s.region.quality_mean;
  m->quality_histogram.assign(s.quality.histogram.begin(), s.quality.histogram.end());
  m->volume_rest = s.volume_rest;
  m->volume_current = s.volume_current;
  m->region_tetrahedra = s.region.tetrahedra;
  m->region_below_tau = s.region.below_tau;
  m->cut_time_ms = s.cut.time_ms;
  m->collapse_time_ms = s.collapse.time_ms;
}

void TissueNode::publishTimer(const ros::SteadyTimerEvent&) {
  const bool want_markers = markers_pub_.getNumSubscribers() > 0;
  const bool want_stats = stats_pub_.getNumSubscribers() > 0;
  TissueStats stats;
  if (want_stats || want_markers) {
    const auto lock = lockModel();
    if (want_stats) {
      fillStats(tissue_->statistics(), &stats);
      stats.tick_p50_ms = window_.percentile(50);
      stats.tick_p99_ms = window_.percentile(99);
      stats.tick_max_ms = window_.max();
      stats.rate_hz = static_cast<double>(tick_starts_.size());
      stats.deadline_misses = static_cast<std::uint32_t>(deadline_misses_);
      stats.ticks = ticks_;
      stats.memory_rss_mb = residentMegabytes();
    }
    if (want_markers) {
      std::lock_guard<std::mutex> marker_lock(marker_mutex_);
      takeSnapshot(*tissue_, last_blade_, &snapshot_);
    }
  }
  if (want_markers) {
    std::lock_guard<std::mutex> marker_lock(marker_mutex_);
    buildMarkers(snapshot_, settings_.style, skin_.get(), ros::Time::now(), &markers_);
    markers_pub_.publish(markers_);
  }
  if (want_stats) stats_pub_.publish(stats);
  diagnostics_.update();
}

void TissueNode::diagnose(diagnostic_updater::DiagnosticStatusWrapper& status) {
  const auto lock = lockModel();
  const double rate = static_cast<double>(tick_starts_.size());
  if (rate >= 0.9 * config_.rate)
    status.summary(diagnostic_msgs::DiagnosticStatus::OK, "ticking at rate");
  else
    status.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "ticking at %.0f of %.0f Hz", rate,
                    config_.rate);
  status.add("rate_hz", rate);
  status.add("target_rate_hz", config_.rate);
  status.add("tick_p50_ms", window_.percentile(50));
  status.add("tick_p99_ms", window_.percentile(99));
  status.add("tick_max_ms", window_.max());
  status.add("deadline_misses", deadline_misses_);
  status.add("tetrahedra", tissue_->mesh().numTets());
}

// --- services

bool TissueNode::resetService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  {
    const auto lock = lockModel();
    tissue_->reset();
    res.message = "reset to the uncut mesh: " + std::to_string(tissue_->mesh().numVertices()) +
                  " vertices, " + std::to_string(tissue_->mesh().numTets()) + " tetrahedra";
  }
  clearInput();
  res.success = true;
  return true;
}

bool TissueNode::loadMeshService(LoadMesh::Request& req, LoadMesh::Response& res) {
  res.success = false;
  if (req.path.empty()) {
    res.message = "load_mesh: the path is empty";
    return true;
  }
  Config config;
  {
    const auto lock = lockModel();
    config = config_;
  }
  config.mesh = req.path;
  try {
    // Read and build outside the lock: the ticks go on with the old mesh meanwhile.
    const MeshData mesh = loadTissueMesh(config);
    auto tissue = std::make_unique<Tissue>(config, mesh);
    auto skin = std::make_unique<SkinClassifier>(tissue->mesh());
    res.vertices = tissue->mesh().numVertices();
    res.tetrahedra = tissue->mesh().numTets();
    {
      const auto lock = lockModel();
      std::lock_guard<std::mutex> marker_lock(marker_mutex_);
      tissue_.swap(tissue);
      skin_.swap(skin);
      config_.mesh = config.mesh;
      last_blade_.reset();
    }
    clearInput();
  } catch (const std::exception& e) {
    char cwd[4096];
    const bool relative = req.path[0] != '/' && getcwd(cwd, sizeof cwd);
    res.message = std::string("load_mesh refused '") + req.path + "'" +
                  (relative ? std::string(" (relative to ") + cwd + ")" : "") + ": " + e.what() +
                  "; the current mesh is kept";
    ROS_WARN("tissue: %s", res.message.c_str());
    return true;
  }
  res.success = true;
  res.message = "loaded " + req.path + ": " + std::to_string(res.vertices) + " vertices, " +
                std::to_string(res.tetrahedra) + " tetrahedra";
  ROS_INFO("tissue: %s", res.message.c_str());
  return true;
}

bool TissueNode::saveMeshService(SaveMesh::Request& req, SaveMesh::Response& res) {
  res.success = false;
  if (req.path.empty()) {
    res.message = "save_mesh: the path is empty";
    return true;
  }
  MeshWriteData data;
  {
    const auto lock = lockModel();
    data = tissue_->exportMesh();
  }
  // The file is the cut material: rest positions as its points, so that load_mesh reads it back
  // as a valid model (the deformed shape may hold tets inverted by the simulation).
  data.V = data.rest;
  data.rest.resize(0, 3);
  try {
    writeMesh(req.path, data);
  } catch (const std::exception& e) {
    res.message = std::string("save_mesh failed for '") + req.path + "': " + e.what();
    return true;
  }
  res.success = true;
  res.message = "wrote " + req.path + ": " + std::to_string(data.V.rows()) + " vertices, " +
                std::to_string(data.T.rows()) + " tetrahedra";
  return true;
}

bool TissueNode::validateService(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  const auto lock = lockModel();
  const std::string err = tissue_->validate();
  res.success = err.empty();
  res.message = err.empty() ? "valid: " + std::to_string(tissue_->mesh().numTets()) +
                                  " tetrahedra, closed 2-manifold boundary"
                            : err;
  return true;
}

void TissueNode::reconfigure(TissueConfig& cfg, uint32_t) {
  const auto lock = lockModel();
  const Config c = withReconfigureValues(config_, cfg);
  const std::string bad = tissue_->reconfigure(c);
  if (!bad.empty()) {
    ROS_ERROR("tissue: reconfigure refused: %s; the settings are kept", bad.c_str());
    putModelValues(config_, &cfg);
  } else {
    config_ = c;
    std::lock_guard<std::mutex> input_lock(input_mutex_);
    blade_length_ = c.cut.blade_length;
  }
  std::lock_guard<std::mutex> marker_lock(marker_mutex_);
  settings_.style.color_by_quality = cfg.color_by_quality;
  settings_.style.show_collapse_queue = cfg.show_collapse_queue;
}

// --- the RViz scalpel

void TissueNode::makeInteractiveScalpel() {
  marker_server_ = std::make_unique<interactive_markers::InteractiveMarkerServer>(
      pnh_.resolveName("scalpel_marker"), "", false);
  const TetMesh& mesh = tissue_->mesh();
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
  for (int v = 0; v < mesh.vertexSlots(); ++v)
    if (mesh.vertexAlive(v)) lo = lo.cwiseMin(mesh.rest(v)), hi = hi.cwiseMax(mesh.rest(v));
  const double length = config_.cut.blade_length;

  visualization_msgs::InteractiveMarker im;
  im.header.frame_id = config_.frame_id;
  im.name = "scalpel";
  im.description = "scalpel (blade along -z)";
  im.scale = static_cast<float>(std::max(0.02, 0.5 * length));
  im.pose.position.x = lo.x() - 0.01;  // beside the tissue: dragging it in starts a cut
  im.pose.position.y = 0.5 * (lo.y() + hi.y());
  im.pose.position.z = hi.z() + 0.5 * length;
  im.pose.orientation.w = 1.0;

  visualization_msgs::Marker blade;
  blade.type = visualization_msgs::Marker::CYLINDER;
  blade.scale.x = blade.scale.y = 0.0015;
  blade.scale.z = length;
  blade.pose.position.z = -0.5 * length;
  blade.pose.orientation.w = 1.0;
  blade.color.r = 0.75f, blade.color.g = 0.78f, blade.color.b = 0.82f, blade.color.a = 1.0f;
  visualization_msgs::InteractiveMarkerControl body;
  body.always_visible = true;
  body.interaction_mode = visualization_msgs::InteractiveMarkerControl::MOVE_3D;
  body.markers.push_back(blade);
  im.controls.push_back(body);

  const double h = std::sqrt(0.5);  // control frames: x, then z (the y-up of RViz's), then y
  const double axes[3][4] = {{h, h, 0, 0}, {h, 0, h, 0}, {h, 0, 0, h}};  // w, x, y, z
  const char* names[3] = {"x", "z", "y"};
  for (int i = 0; i < 3; ++i) {
    visualization_msgs::InteractiveMarkerControl c;
    c.orientation.w = axes[i][0], c.orientation.x = axes[i][1];
    c.orientation.y = axes[i][2], c.orientation.z = axes[i][3];
    c.name = std::string("move_") + names[i];
    c.interaction_mode = visualization_msgs::InteractiveMarkerControl::MOVE_AXIS;
    im.controls.push_back(c);
    c.name = std::string("rotate_") + names[i];
    c.interaction_mode = visualization_msgs::InteractiveMarkerControl::ROTATE_AXIS;
    im.controls.push_back(c);
  }
  marker_server_->insert(im, [this](const visualization_msgs::InteractiveMarkerFeedbackConstPtr& f) {
    markerFeedback(f);
  });
  marker_server_->applyChanges();
}

}  // namespace tissue_cut
