// The tissue model: owns the mesh, the cutter, the collapse queue and the physics; one step()
// per tick. The node and cut_replay both drive this class, so both give the same mesh and figures.
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <optional>

#include "tissue_cut/config.hpp"
#include "tissue_cut/cut/blade.hpp"
#include "tissue_cut/cut/blade_filter.hpp"
#include "tissue_cut/cut/cutter.hpp"
#include "tissue_cut/mesh/mesh_io.hpp"
#include "tissue_cut/mesh/tet_mesh.hpp"
#include "tissue_cut/physics/mass_spring.hpp"
#include "tissue_cut/remesh/collapse_queue.hpp"
#include "tissue_cut/statistics.hpp"

namespace tissue_cut {

/// The mesh the configuration names: config.mesh read from file (limited to
/// config.mesh_max_tets; renumbered by spatiallyOrdered() when config.mesh_order is "spatial"),
/// or the built-in block (numbered row by row already). Throws MeshIOError or
/// std::invalid_argument.
MeshData loadTissueMesh(const Config& config);

/// The physics parameters a configuration gives.
MassSpringParams massSpringParams(const Config& config);

/// The blade filter's parameters a configuration gives (cut/filter_*, cut/max_jump).
BladeFilterParams bladeFilterParams(const Config& config);

class Tissue {
 public:
  /// Builds the model on `mesh` (#V by 3 rest positions [m], #T by 4 tets).
  /// Throws ConfigError for an invalid config, std::invalid_argument for an unusable mesh
  /// (empty, non-finite, or failing TetMesh::validate(), e.g. a pinched or overlapping boundary).
  Tissue(const Config& config, const MeshData& mesh);
  ~Tissue();
  Tissue(const Tissue&) = delete;
  Tissue& operator=(const Tissue&) = delete;

  /// One tick of `dt` [s]: cut with the blade (none = the blade is away), remesh, simulate.
  /// With cut/filter_min_cutoff > 0 the cutter gets the blade smoothed by a BladeFilter.
  /// Returns a warning for the caller to log (the blade was lifted), or "".
  std::string step(const std::optional<BladeSegment>& blade, double dt);

  /// TetMesh::validate() plus the cutter's pending state; "" when valid.
  std::string validate() const;
  const Cutter& cutter() const { return *cutter_; }
  const MassSpring& physics() const { return *physics_; }
  const CollapseQueue& collapse() const { return *collapse_; }

  /// Back to the mesh given at construction, uncut and at rest.
  void reset();

  /// Applies a changed configuration between ticks: collapse (enabled, tau, budget, deadline,
  /// flips, smoothing), the cut's blade length, max jump and blade filter, and the physics
  /// material (enabled, integrator, density, Young's modulus, damping, gravity). Keys that need
  /// the model rebuilt (mesh, mesh_max_tets, block_cell_size, physics/fixed_*) must be unchanged.
  /// Returns "" when applied, else the first key that is invalid or cannot change live; the model
  /// is then left as it was.
  std::string reconfigure(const Config& config);

  const TetMesh& mesh() const { return mesh_; }
  const Config& config() const { return config_; }
  /// 1 for live tets made by cuts (indexed by tet slot).
  const std::vector<unsigned char>& cutRegion() const { return cut_region_; }
  /// Current figures; `ticks` holds what the caller recorded in tickTimes().
  Statistics statistics() const;
  TickTimes& tickTimes() { return tick_times_; }
  /// The clock step() measures the tick's deadline on (see Config::Collapse::deadline), the
  /// physics step's time and the collapse budget [us, any origin]; null (the default): the
  /// steady clock. A test gives one that advances a fixed step a reading.
  void setClock(std::function<double()> now_us);
  /// The live mesh as arrays for writeMesh (current positions, rest, quality, cut_region).
  MeshWriteData exportMesh() const;

 private:
  void applyChange(const ChangeRecord& change);
  // The collapse queue's flips and smoothing as the config says (Config::Collapse).
  void setCollapseExtensions(const Config& c);
  bool createdByCut(int t) const {
    return t < static_cast<int>(cut_region_.size()) && cut_region_[t];
  }
  // A physics step's time [us] into the ring below; its percentile every kSlowEvery steps.
  void recordPhysicsTime(double us);
  // Whether the collapse queue keeps the tick's deadline (Config::Collapse::deadline).
  bool keepsDeadline() const;
  // After the physics step: the collapse queue within the time the tick has left (see
  // Config::Collapse::deadline).
  void workCollapseQueueByDeadline(double tick_start_us);
  // Works the collapse queue, within `limit_us` [us] (-1: none) and `budget_us` (0: its own),
  // and follows its changes.
  void workCollapseQueue(double limit_us, double budget_us = 0.0);
  double nowUs() const;

  Config config_;
  MeshData initial_;
  TetMesh mesh_;
  std::unique_ptr<Cutter> cutter_;
  BladeFilter blade_filter_;
  std::unique_ptr<MassSpring> physics_;
  std::unique_ptr<CollapseQueue> collapse_;
  long long busy_epoch_ = -1;  // the cutter's state epoch when the queue last looked at it
  // The last physics steps' times [us] (a ring) and their kSlowPercent-th percentile, taken every
  // kSlowEvery steps.
  static constexpr std::size_t kRecentSteps = 128;
  static constexpr long long kSlowEvery = 16;
  static constexpr int kSlowPercent = 75;
  std::array<double, kRecentSteps> recent_physics_us_{};
  long long physics_steps_ = 0;
  double physics_slow_us_ = 0.0;
  // Ticks since the queue last worked, counted while the physics alone leaves it no chunk
  // before the deadline: it gets one every kStarvedEvery-th of them.
  static constexpr int kStarvedEvery = 4;
  int starved_ticks_ = 0;
  // The last collapse batches' cost to follow [us per tet changed] (a ring), and its
  // kSlowPercent-th percentile: the queue keeps that time for it under a deadline.
  static constexpr std::size_t kRecentFollows = 32;
  static constexpr std::size_t kMinFollowSample = 16;  // tets a batch changes to be measured
  std::array<double, kRecentFollows> recent_follow_{};
  long long follows_ = 0;
  std::function<double()> clock_;  // null: the steady clock
  // The tick's change and the collapse queue's, emptied before each use (their lists keep their
  // room: a tick takes nothing from the heap for them once they have grown).
  ChangeRecord tick_change_, collapsed_;
  std::vector<unsigned char> cut_region_;
  std::vector<unsigned char> removed_flag_;  // applyChange()'s scratch: removed tets' flags
  std::vector<unsigned> removed_seen_;       // and the record they belong to
  unsigned removed_stamp_ = 0;
  TickTimes tick_times_;
  double initial_volume_ = 0.0;
};

}  // namespace tissue_cut
