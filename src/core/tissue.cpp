#include "tissue_cut/tissue.hpp"

#include <algorithm>
#include <chrono>

#include "tissue_cut/mesh/block.hpp"
#include "tissue_cut/mesh/quality.hpp"

namespace tissue_cut {

namespace {
// Boundary collapses may tilt a boundary face by 8% of its size (the cutter's own snapping
// tolerance), and change the rest volume by 0.05% net in all (half the 0.1%). Faces
// smaller than the mean edge count as that large: the surface then moves by at most 8% of the
// mean edge, as far as the cutter's snapping moves it, so the sub-millimetre facets a cut leaves
// at its rim may be evened out (measured by their own size they bent the rim by 40% and stayed).
constexpr double kShapeTolerance = 0.08;
constexpr double kShapeLengthFloor = 1.0;
constexpr double kVolumeBudget = 5e-4;
// Under a deadline the queue starts only with this much time left (or its budget, if less): a
// tet's collapse checks take ~50-100 us, and each tick whose collapses or moves change the
// springs costs the next physics steps CG iterations.
constexpr double kMinChunkUs = 100.0;

}  // namespace

MeshData loadTissueMesh(const Config& config) {
  if (config.mesh.empty()) {
    BlockSpec spec;
    spec.cell_size = config.block_cell_size;
    return makeBlock(spec);
  }
  MeshReadOptions options;
  options.max_tets = config.mesh_max_tets;
  MeshData mesh = readMesh(config.mesh, options);
  if (config.mesh_order == "spatial") return spatiallyOrdered(mesh);
  return mesh;
}

BladeFilterParams bladeFilterParams(const Config& config) {
  BladeFilterParams p;
  p.min_cutoff = config.cut.filter_min_cutoff;
  p.beta = config.cut.filter_beta;
  p.max_jump = config.cut.max_jump;
  return p;
}

MassSpringParams massSpringParams(const Config& config) {
  MassSpringParams p;
  p.density = config.physics.density;
  p.young_modulus = config.physics.young_modulus;
  p.damping = config.physics.damping;
  p.gravity = config.physics.gravity;
  p.implicit = config.physics.integrator == "implicit";
  p.fixed_axis = config.fixedAxisIndex();
  p.fixed_max_side = config.physics.fixed_side == "max";
  p.fixed_band = config.physics.fixed_band;
  p.threads = config.physics.threads;
  p.cluster_preconditioner = config.physics.cluster_preconditioner;
  p.local_presolve = config.physics.local_presolve;
  p.local_presolve_neighbours = config.physics.local_presolve_neighbours;
  p.quadratic_warm_start = config.physics.quadratic_warm_start;
  return p;
}

Tissue::Tissue(const Config& config, const MeshData& mesh) : config_(config), initial_(mesh) {
  const std::string bad = config_.check();
  if (!bad.empty()) throw ConfigError(bad);
  if (initial_.V.rows() == 0 || initial_.T.rows() == 0)
    throw std::invalid_argument("the tissue mesh has no tetrahedra");
  if (!initial_.V.allFinite())
    throw std::invalid_argument("the tissue mesh has non-finite vertices");
  reset();
  // A file can hold tets that each look fine but do not form a closed, consistently oriented
  // complex (a corrupted index makes two tets overlap); cutting it would go wrong later.
  const std::string invalid = mesh_.validate();
  if (!invalid.empty())
    throw std::invalid_argument("the tissue mesh is not a valid tetrahedral mesh: " + invalid);
}

Tissue::~Tissue() = default;

void Tissue::reset() {
  mesh_ = TetMesh(initial_.V, initial_.T);
  CutterOptions cut;
  cut.max_jump = config_.cut.max_jump;
  cutter_ = std::make_unique<Cutter>(&mesh_, cut);
  // Its tet index was just built where the vertices are, and nothing moves them before the
  // first step's physics, which tells it how far: the first tick need not scan every vertex for
  // drift, as a cutter never told does (tick 1 on the 20k organ 0.35-0.40 -> 0.24-0.30 ms).
  cutter_->tissueMoved(0.0);
  blade_filter_ = BladeFilter(bladeFilterParams(config_));
  physics_ = std::make_unique<MassSpring>(&mesh_, massSpringParams(config_));
  if (config_.physics.enabled) physics_->prepare(1.0 / config_.rate);
  collapse_ =
      std::make_unique<CollapseQueue>(&mesh_, config_.collapse.tau, config_.collapse.budget_us);
  if (config_.collapse.enabled) collapse_->prepare();
  if (clock_) collapse_->setBudgetClock(clock_);
  collapse_->setShapeTolerance(kShapeTolerance, kVolumeBudget * mesh_.restVolume(),
                               kShapeLengthFloor * cutter_->meanEdge());
  setCollapseExtensions(config_);
  assignSlots(&cut_region_, mesh_.tetSlots(), {});
  busy_epoch_ = -1;
  physics_steps_ = 0;
  physics_slow_us_ = 0.0;
  starved_ticks_ = 0;
  follows_ = 0;  // the new queue starts with no follow cost
  tick_times_.clear();
  initial_volume_ = mesh_.restVolume();
}

void Tissue::setCollapseExtensions(const Config& c) {
  // Vertices the physics holds still keep their place.
  collapse_->setSmoothing(c.collapse.smoothing, [this](int v) { return physics_->fixed(v); });
  // The cutter knows a blade coming back along a wound by the wound vertices at the ends of the
  // edges it crosses; flips make only edges it would know so (without this rule, 20 passes
  // back and forth with physics re-cut 5,100 tets instead of about 400).
  collapse_->setFlips(c.collapse.flips, [this](int u, int v) { return cutter_->mayJoin(u, v); });
}

std::string Tissue::reconfigure(const Config& c) {
  const std::string bad = c.check();
  if (!bad.empty()) return bad;
  if (c.mesh != config_.mesh) return "mesh: changes only by loading a mesh";
  if (c.mesh_max_tets != config_.mesh_max_tets) return "mesh_max_tets: cannot change live";
  if (c.mesh_order != config_.mesh_order) return "mesh_order: changes only by loading a mesh";
  if (c.block_cell_size != config_.block_cell_size) return "block_cell_size: cannot change live";
  if (c.physics.fixed_axis != config_.physics.fixed_axis ||
      c.physics.fixed_side != config_.physics.fixed_side ||
      c.physics.fixed_band != config_.physics.fixed_band)
    return "physics/fixed_axis, fixed_side, fixed_band: cannot change live";
  if (c.cut.max_jump != config_.cut.max_jump) cutter_->setMaxJump(c.cut.max_jump);
  blade_filter_.setParams(bladeFilterParams(c));
  collapse_->setTau(c.collapse.tau);
  collapse_->setBudget(c.collapse.budget_us);
  setCollapseExtensions(c);
  physics_->setParams(massSpringParams(c));
  if (c.physics.enabled) physics_->prepare(1.0 / c.rate);
  config_ = c;
  return "";
}

void Tissue::applyChange(const ChangeRecord& change) {
  // A renamed tet keeps its flag; a tet a cut made gets 1. Slots may be reused within a record,
  // so read the removed flags first (by slot, stamped for this record: no map, no allocation
  // once grown; a slot removed twice keeps the 0 its first removal left, as a map did).
  nextStamp(&removed_seen_, &removed_stamp_, mesh_.tetSlots());
  growSlots(&removed_flag_, removed_seen_.size(), {});
  for (int t : change.removed_tets) {
    removed_seen_[t] = removed_stamp_;
    removed_flag_[t] = cut_region_[t];
    cut_region_[t] = 0;
  }
  growSlots(&cut_region_, mesh_.tetSlots(), {});
  for (std::size_t i = 0; i < change.added_tets.size(); ++i) {
    const int from = change.added_from[i];
    const bool known = from >= 0 && from < static_cast<int>(removed_seen_.size()) &&
                       removed_seen_[from] == removed_stamp_;
    cut_region_[change.added_tets[i]] = from < 0 ? 1 : known ? removed_flag_[from] : 0;
  }
}

double Tissue::nowUs() const {
  if (clock_) return clock_();
  return std::chrono::duration<double, std::micro>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

void Tissue::setClock(std::function<double()> now_us) {
  clock_ = std::move(now_us);
  collapse_->setBudgetClock(clock_);
}

bool Tissue::keepsDeadline() const {
  return config_.collapse.enabled && config_.collapse.budget_us > 0.0 &&
         config_.collapse.deadline > 0.0;
}

void Tissue::recordPhysicsTime(double us) {
  recent_physics_us_[physics_steps_++ % kRecentSteps] = us;
  if (physics_steps_ % kSlowEvery != 0 && physics_steps_ >= kSlowEvery) return;
  physics_slow_us_ = ringPercentile(recent_physics_us_, physics_steps_, kSlowPercent);
}

void Tissue::workCollapseQueueByDeadline(double tick_start_us) {
  const double deadline_us = 1e6 * config_.collapse.deadline / config_.rate;
  const double left = deadline_us - (nowUs() - tick_start_us);
  const double chunk = std::min(kMinChunkUs, config_.collapse.budget_us);
  if (left >= chunk) {
    starved_ticks_ = 0;
    workCollapseQueue(left);
    return;
  }
  // Where the physics step alone, as its slower steps take (the 75th percentile of the last
  // 128), leaves no chunk before the deadline, waiting for a tick with time to spare would starve
  // the queue: it gets a chunk of budget every kStarvedEvery-th such tick (its first tet worked
  // whole, as under any budget), or its whole budget every tick where the physics alone takes the
  // period (no tick keeps pace). A chunk on every such tick made each of them late (on the 20k
  // organ on one core, runs of 6-10 ticks at 1.0-1.1 ms after the cut opened: most of the ticks
  // over the 99th percentile); one in kStarvedEvery is late instead, and the queue still moves.
  const double physics_us = config_.physics.enabled ? physics_slow_us_ : 0.0;
  if (physics_us * config_.rate >= 1e6) {
    starved_ticks_ = 0;
    workCollapseQueue(-1.0);
  } else if (physics_us + chunk >= deadline_us && ++starved_ticks_ >= kStarvedEvery) {
    starved_ticks_ = 0;
    workCollapseQueue(-1.0, chunk);
  } else {
    collapse_->deferred();
  }
}

void Tissue::workCollapseQueue(double limit_us, double budget_us) {
  ChangeRecord& collapsed = collapsed_;
  collapsed.clear();
  // Tets waiting for the cutter are looked at again only when its state changed.
  const long long epoch = cutter_->stateEpoch();
  collapse_->process([this](int v) { return cutter_->isBusy(v); },
                     [this](int t) { return createdByCut(t); }, &collapsed, epoch != busy_epoch_,
                     limit_us, budget_us);
  busy_epoch_ = epoch;
  if (collapsed.empty()) return;
  const double start = limit_us >= 0.0 ? nowUs() : 0.0;
  applyChange(collapsed);
  cutter_->follow(collapsed);
  physics_->follow(collapsed);
  // Under a deadline, what following cost joins the queue's time (see setFollowCost()): on the
  // 20k organ 0.1-0.2 ms after the queue's last tet had taken collapse ticks past the period.
  const std::size_t changed = collapsed.added_tets.size() + collapsed.removed_tets.size();
  if (limit_us < 0.0 || changed < kMinFollowSample) return;
  recent_follow_[follows_++ % kRecentFollows] = (nowUs() - start) / static_cast<double>(changed);
  collapse_->setFollowCost(ringPercentile(recent_follow_, follows_, kSlowPercent));
}

std::string Tissue::step(const std::optional<BladeSegment>& blade, double dt) {
  const double tick_start = nowUs();
  // The physics step's helper thread would fall asleep during a long cut and cost its first job
  // the time to wake it (20-40 us, and as much again before it helps: measured on the 20k
  // organ's cut ticks); it stays up for this tick instead.
  if (config_.physics.enabled) physics_->expectStep(1e6 / config_.rate);
  ChangeRecord& change = tick_change_;
  change.clear();
  std::string warning;
  if (blade && !(blade->base.allFinite() && blade->tip.allFinite())) {
    // A broken pose must not reach the geometry; the cut waits for the next good one.
    warning = "blade position is not finite: ignored this tick";
  } else {
    warning = cutter_->step(blade_filter_(blade, dt), &change);
  }
  applyChange(change);
  physics_->follow(change);
  collapse_->queueFrom(change, [this](int t) { return createdByCut(t); });
  // Under a deadline the queue works after the physics step, in the time the tick has left
  // (measured: the physics step's own time varies with the changes it follows); without one,
  // before it, within its budget alone, as the deterministic replays (budget 0) always do.
  const bool deadline = keepsDeadline();
  if (config_.collapse.enabled && !deadline) workCollapseQueue(-1.0);
  if (config_.physics.enabled) {
    const double physics_start = nowUs();
    const std::string unstable = physics_->step(dt);
    if (!unstable.empty()) warning += (warning.empty() ? "" : "; ") + unstable;
    recordPhysicsTime(nowUs() - physics_start);
    // The cutter's tet index looks for drift only once the moves could add up to enough.
    cutter_->tissueMoved(physics_->lastMaxDisplacement());
  } else {
    cutter_->tissueMoved(0.0);
  }
  if (deadline) workCollapseQueueByDeadline(tick_start);
  return warning;
}

std::string Tissue::validate() const {
  std::string err = mesh_.validate();
  if (err.empty()) err = cutter_->validate();
  return err;
}

Statistics Tissue::statistics() const {
  Statistics s;  // every figure comes from the parts that own it
  s.cut.cut_tetrahedra = cutter_->counts().cut_tetrahedra;
  s.cut.created_tetrahedra = cutter_->counts().created_tetrahedra;
  s.cut.time_ms = cutter_->counts().time_ms;
  s.cut.refused = cutter_->counts().refused;
  s.cut.quiet_ticks = cutter_->counts().quiet_ticks;
  s.cut.quiet_refreshes = cutter_->counts().quiet_refreshes;
  s.cut.feature_ticks = cutter_->counts().feature_ticks;
  const CollapseCounts& c = collapse_->counts();
  s.collapse.collapsed_edges = c.collapsed_edges;
  s.collapse.removed_tetrahedra = c.removed_tetrahedra;
  s.collapse.pending = collapse_->pending();
  s.collapse.rejected_link = c.rejected_link;
  s.collapse.rejected_inversion = c.rejected_inversion;
  s.collapse.rejected_quality = c.rejected_quality;
  s.collapse.rejected_boundary = c.rejected_boundary;
  s.collapse.smoothed_vertices = c.smoothed_vertices;
  s.collapse.flips = c.flips;
  s.collapse.deferred_ticks = c.deferred_ticks;
  s.collapse.time_ms = c.time_ms;
  s.physics.mass_total = physics_->totalMass();
  s.physics.kinetic_energy = physics_->kineticEnergy();
  s.physics.instabilities = physics_->instabilities();
  s.physics.springs = physics_->numSprings();
  s.physics.steps = physics_->steps();
  s.physics.time_ms = physics_->timeMs();
  s.physics.inertia_added = physics_->addedInertia();
  s.physics.threads = physics_->numThreads();
  s.physics.clusters = physics_->numClusters();
  if (physics_->steps() > 0)
    s.physics.cg_iterations_mean =
        static_cast<double>(physics_->totalIterations()) / physics_->steps();
  if (physics_->totalIterations() > 0 && physics_->numSprings() > 0)
    s.physics.ns_per_spring_iteration =
        1e6 * physics_->timeMs() /
        (static_cast<double>(physics_->totalIterations()) * physics_->numSprings());
  s.vertices = mesh_.numVertices();
  s.tetrahedra = mesh_.numTets();
  s.surface_triangles = mesh_.numBoundaryFaces();
  s.initial_vertices = static_cast<int>(initial_.V.rows());
  s.initial_tetrahedra = static_cast<int>(initial_.T.rows());
  s.initial_volume_rest = initial_volume_;
  s.volume_rest = mesh_.restVolume();
  s.volume_current = mesh_.currentVolume();
  s.quality = summarizeQuality(mesh_, config_.collapse.tau);
  const QualitySummary region = summarizeQuality(mesh_, config_.collapse.tau, &cut_region_);
  s.region.tetrahedra = region.count;
  s.region.quality_mean = region.mean;
  s.region.quality_min = region.min;
  s.region.below_tau = region.below_tau;
  s.ticks.count = tick_times_.count();
  s.ticks.p50_ms = tick_times_.percentile(50);
  s.ticks.p99_ms = tick_times_.percentile(99);
  s.ticks.max_ms = tick_times_.max();
  s.ticks.deadline_misses = tick_times_.deadlineMisses();
  return s;
}

MeshWriteData Tissue::exportMesh() const {
  MeshWriteData out;
  std::vector<int> slots;
  Eigen::MatrixXi T = mesh_.liveTets(&slots);
  // Compact vertex ids: files have no dead slots.
  std::vector<int> remap(mesh_.vertexSlots(), -1);
  int nv = 0;
  for (int v = 0; v < mesh_.vertexSlots(); ++v)
    if (mesh_.vertexAlive(v)) remap[v] = nv++;
  out.V.resize(nv, 3);
  out.rest.resize(nv, 3);
  for (int v = 0; v < mesh_.vertexSlots(); ++v) {
    if (remap[v] < 0) continue;
    out.V.row(remap[v]) = mesh_.current(v).transpose();
    out.rest.row(remap[v]) = mesh_.rest(v).transpose();
  }
  for (int i = 0; i < T.rows(); ++i)
    for (int k = 0; k < 4; ++k) T(i, k) = remap[T(i, k)];
  out.T = T;
  out.quality.resize(T.rows());
  out.cut_region.resize(T.rows());
  for (int i = 0; i < T.rows(); ++i) {
    out.quality[i] = restQuality(mesh_, slots[i]);
    out.cut_region[i] = cut_region_[slots[i]];
  }
  return out;
}

}  // namespace tissue_cut
