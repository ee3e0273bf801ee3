// Cutter: progressive cutting by tetrahedra replacement (Ganovelli et al. 2000, 2001).
//
// Each tick the blade sweeps a quad. Mesh edges it crosses get a cut point, faces its front
// (the tip's path, the base's path, and the blade where a stroke starts or ends) crosses get a
// front point; a point belongs to its edge or face and is shared by every tet around it. A tet
// holding points is *pending* while the blade is inside it: it is kept as a temporary conforming
// subdivision (no separation) so that the mesh stays a valid complex every tick. On the tick the
// blade leaves it, it is replaced by SplitTable's split, its cut faces are marked, and every
// vertex the cut touched gets one copy per group of its tets joined across unmarked faces.
// Vertices within `snap` of the swept surface are taken as lying on it (no sliver point next to
// them), so cuts through grid vertices, along edges and along faces come out clean; one whose
// edge got a point first stays off the cut for good (a later pass would cut chips off there).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "tissue_cut/cut/blade.hpp"
#include "tissue_cut/cut/split_table.hpp"
#include "tissue_cut/cut/sweep.hpp"
#include "tissue_cut/mesh/inline_vector.hpp"
#include "tissue_cut/mesh/stamped_table.hpp"
#include "tissue_cut/mesh/tet_grid.hpp"
#include "tissue_cut/mesh/tet_mesh.hpp"

namespace tissue_cut {

struct CutterOptions {
  /// A blade end moving further than this in one tick is lifted and put down again [m].
  double max_jump = 0.02;
  /// Vertices closer to the swept surface than this fraction of the mean edge length lie on it.
  double snap = 0.08;
  /// Vertices of an earlier cut whose wall runs along the blade's sweep (within 30 degrees) lie on
  /// it within this fraction of the mean edge: a blade coming back along a wound that the tissue
  /// has moved since follows the wound instead of cutting slivers off its wall.
  double wound_snap = 0.35;
  /// separate() takes a vertex's groups as heldSplits() found them while no split since has
  /// changed its star or marks (the same answer, less work); false finds every vertex's groups
  /// afresh (for comparison).
  bool keep_groups = true;
  /// A pending tet the blade leaves on the tick it takes a new point gets its final split
  /// straight away; true first subdivides it anew with the point, as the tets the blade is still
  /// in are (the same mesh, more work: for comparison).
  bool subdivide_left = false;
  /// A tick whose blade, and the tissue as told (tissueMoved), has moved less since the last
  /// tick that swept than the distance from the blade then to anything a sweep could act on,
  /// except a few features tested on their own each tick (quietReach()), is not swept: it would
  /// make no point, snap no vertex and cross no face. A tick that reaches some of those features
  /// (at most one vertex the sweep would look at) tests those alone, as the sweep would. The same
  /// cut, less work; false sweeps every tick (for comparison), as does a cutter never told how
  /// far the tissue moves.
  bool skip_quiet = true;
  /// How far the blade may move before the features kept for the quiet ticks are taken anew
  /// (around the blade where the last tick left it; that tick is then swept only if it reaches
  /// one of them), as a fraction of the mean edge.
  double quiet_reach = 0.1;
  /// Sweeps the quiet ticks too, and the ticks that tested only the kept features they reached
  /// (after those), and throws std::logic_error where that changed the cut (for tests: the same
  /// cut either way, or a tick was wrongly left unswept).
  bool check_quiet = false;
};

/// The paper's counts and the cutter's own.
struct CutCounts {
  int cut_tetrahedra = 0;        ///< tets replaced (#CuT)
  int created_tetrahedra = 0;    ///< tets they were replaced by (#CrT)
  double time_ms = 0.0;          ///< time in cutting (t.Repl)
  int separated_vertices = 0;    ///< vertex copies made to open the cut
  long long separation_tries = 0;  ///< vertices whose split was simulated, summed over the calls
  long long groups_kept = 0;       ///< of those tried, vertices whose groups separate() kept
  long long subdivisions = 0;      ///< pending tets subdivided anew after taking points
  int lifts = 0;                 ///< jumps treated as the blade lifted
  int refused = 0;               ///< replacements TetMesh refused (the cut left closed there)
  long long quiet_ticks = 0;     ///< ticks the blade moved on that were not swept (skip_quiet)
  /// Ticks whose quiet reach had run out and was taken anew without a sweep (the tick is then
  /// quiet unless it reaches a feature kept anew).
  long long quiet_refreshes = 0;
  /// Ticks that reached at most one kept vertex and tested only the kept features they reached
  /// (that vertex, edges, front faces), not swept (skip_quiet).
  long long feature_ticks = 0;
  /// Ticks whose look for drift in the tet index scanned every vertex (the tissue's moves since
  /// the last scan could have taken one past the index's margin, or were not told).
  long long grid_scans = 0;
  std::array<int, 7> by_kind{};  ///< replacements per SplitKind
};

class Cutter {
 public:
  Cutter(TetMesh* mesh, const CutterOptions& options);

  /// One tick: `blade` is the blade now (mesh frame [m]), or none when it is away. Changes the
  /// mesh and appends what changed to `change`. Returns a warning (a lift) or "".
  std::string step(const std::optional<BladeSegment>& blade, ChangeRecord* change);

  /// Tells the cutter about topology changes made by others (collapse), after they happened.
  void follow(const ChangeRecord& change);
  /// Tells the cutter how far any vertex may have moved (physics) since it was last told; it then
  /// looks for drift in its tet index only when the moves add up to enough. A cutter never told
  /// assumes anything may have moved and looks every tick.
  void tissueMoved(double distance);

  /// The cutter's own invariants on top of TetMesh::validate(): every pending tet's children are
  /// live and fill it. "" when fine.
  std::string validate() const;

  bool hasPending() const { return !pending_.empty(); }
  int numPending() const { return static_cast<int>(pending_.size()); }
  /// Vertices on the cut whose split still waits (it would pinch the boundary for now).
  int numDeferred() const { return static_cast<int>(deferred_.size()); }
  /// True for tets that are temporary pieces of a tet the blade is still inside.
  bool isPendingPiece(int t) const {
    return static_cast<std::size_t>(t) < pending_of_.size() && pending_of_[t] >= 0;
  }
  /// True for vertices a remesher must leave alone: next to a tet still being cut, on a cut face
  /// not opened yet, or waiting to be split.
  /// (Its kept answer inline: the collapse queue asks it tens of thousands of times a second.)
  bool isBusy(int v) const {
    const std::size_t slot = static_cast<std::size_t>(v);
    const bool kept = slot < busy_known_.size() && busy_known_[slot] == busy_epoch_ + 1;
    return kept ? busy_answer_[slot] != 0 : keepBusy(v);
  }
  /// isBusy() worked out anew, without the answers it keeps while stateEpoch() stays (for
  /// tests: the two must agree).
  bool isBusyAfresh(int v) const;
  /// True for vertices on a cut: snapped onto one, made by one, or copies of those.
  bool onWound(int v) const {
    return static_cast<std::size_t>(v) < wound_flag_.size() && wound_flag_[v] != 0;
  }
  /// Whether a remesher may make the new edge uv: every point of it lies within the wound band
  /// (wound_snap times the mean edge) of one of its ends on a wound, in current positions. A
  /// blade coming back along a wound that the tissue has moved since follows it where it crosses
  /// an edge near such an end (see woundAround); a new edge far from any wound end would be cut.
  bool mayJoin(int u, int v) const;
  const CutCounts& counts() const { return counts_; }
  /// Changes whenever something isBusy() depends on may have changed (tets replaced or made
  /// pending, pending tets finished, cut faces marked or opened, vertices deferred or split):
  /// between two equal values, isBusy() answers alike. Collapses followed do not change it: they
  /// happen only where no vertex is busy, and leave every vertex's answer as it was.
  long long stateEpoch() const { return busy_epoch_; }
  /// Mean rest edge length of the mesh the cutter started on [m].
  double meanEdge() const { return mean_edge_; }
  /// Resets all cut state (after the mesh was replaced).
  void reset();
  /// See CutterOptions::max_jump [m].
  void setMaxJump(double max_jump) { options_.max_jump = max_jump; }

  /// Called with every tet replaced and how (for diagnostics and tests).
  std::function<void(const TetCut&, const TetSplit&)> on_split;

 private:
  // A pending tet's pieces: a cone from a point over its faces' triangles, rarely more than this.
  static constexpr std::size_t kPiecesRoom = 24;
  struct Pending {
    TetCut cut;
    std::vector<int> pieces;  // tet slots that stand for it now
    int steiner = -1;
    bool dirty = false;
    TetPlanes planes;  // whether the blade is still inside it, asked each tick
  };
  // A tet of the coarse mesh the blade cuts: a pending tet, or a plain live tet.
  struct Coarse {
    int pending = -1;
    int tet = -1;
  };

  /// What a tick's moves reached of the kept features and the sweep's tests would pass: the
  /// sweep and the fronts would act on no other feature (see step()).
  struct Reached {
    int vertex = -1;    // the one vertex trySnap() may snap, one the sweep looks at (-1: none)
    bool more = false;  // another vertex, or one not known to be looked at: the tick is swept
    std::vector<std::pair<int, int>> edges;  // the edges that would cross (sorted, each once)
    bool faces = false;                      // a face a front would cross
    bool none() const { return vertex < 0 && !more && edges.empty() && !faces; }
  };

  /// This tick's sweep from `from` to `to`: its vertices snapped and its edges crossed. With
  /// `only`, the features the sweep would act on are among those: they alone are tested, as
  /// the sweep tests them and in its order (see step()).
  void sweep(const BladeSegment& from, const BladeSegment& to, ChangeRecord* change,
             const Reached* only = nullptr);
  /// The swept surface's normal at this tick (unit; the first triangle's unless it has no area).
  Vec3 sweepNormal(const std::array<Triangle, 2>& tris) const;
  /// The sweep's edge crossings: of the sweep's tets (sweep_corners_), or of `only` (`normal`:
  /// sweepNormal(tris); lo, hi: the sweep's box).
  void crossEdges(const BladeSegment& from, const BladeSegment& to,
                  const std::array<Triangle, 2>& tris,
                  const std::array<PreparedTriangle, 2>& prepared, const Vec3& normal,
                  const Vec3& lo, const Vec3& hi, const std::vector<std::pair<int, int>>* only,
                  ChangeRecord* change);
  void crossFront(const std::array<Vec3, 2>& front, const Vec3& inward, ChangeRecord* change);
  /// An edge's or a face's vertices.
  using Corners = InlineVector<int, 3>;
  void coarseNear(const Vec3& lo, const Vec3& hi, std::vector<Coarse>* out);
  TetVerts cornersOf(const Coarse& c) const;
  bool coarseAround(const Corners& verts, std::vector<Coarse>* out) const;
  int makePending(int tet);
  bool faceOnBoundary(const Coarse& c, const std::array<int, 3>& face) const;
  bool conforming(const std::vector<Coarse>& around, const Corners& verts) const;
  void registerEdgePoint(int a, int b, double s, ChangeRecord* change);
  void registerFacePoint(const std::array<int, 3>& face, const Vec3& weights, ChangeRecord* change);
  void trySnap(int v, const std::array<Triangle, 2>& tris,
               const std::array<PreparedTriangle, 2>& prepared, const Vec3& normal);
  bool woundFacing(int v, const Vec3& normal) const;
  /// A crossing `distance` from v stands for v: v lies on a cut (within the wound's band).
  bool nearWound(int v, double distance, const Vec3& normal) const;
  void subdivide(int pid, ChangeRecord* change);
  void finalize(int pid, ChangeRecord* change, std::vector<int>* touched);
  /// Replaces the pending tets the blade has left, then opens the cut where it can. At the end of
  /// a stroke every waiting vertex is tried again (see separate()).
  void finalizeLeft(const std::optional<BladeSegment>& blade, ChangeRecord* change,
                    bool stroke_end = false);
  /// Splits the vertices of `touched`, and the waiting ones near a change since the last call (all
  /// of them with `all_waiting`), where the boundary stays a 2-manifold; the others wait.
  /// (`touched` is the caller's scratch: sorted here and grown by the waiting vertices tried.)
  void separate(std::vector<int>* touched, bool all_waiting, ChangeRecord* change);
  /// The groups of v's star: its tets joined through faces that are not marked, in the order of
  /// their first tets' places in the star, each in star order. Returns how many; where there are
  /// two or more (v splits), group k is group_tets_[group_start_[k] .. group_start_[k + 1])
  /// (until the next call). One group (most calls) is counted, not listed: no caller reads it.
  int groupsAround(int v) const;
  /// Of `verts`, those whose split must wait (sorted): splitting all the others, as separate()
  /// does, keeps the boundary a 2-manifold. Keeps each vertex's groups for groupsKept(). (The
  /// answer is kept until the next call.)
  const std::vector<int>& heldSplits(const std::vector<int>& verts);
  /// groupsAround(v) for verts[place] of the last heldSplits(verts): its kept answer while no split
  /// since has changed a tet of v's star or a mark on one (see keptStale()), else afresh. (Groups
  /// are kept, and listed again, only for a vertex that splits.)
  int groupsKept(int v, int place);
  /// The groups kept for these tets' vertices no longer hold: a split renames the tets (new
  /// slots, v in place of its copy) and moves or opens the marks on their faces.
  void keptStale(const std::vector<int>& tets);
  int addSteiner(const Pending& p, ChangeRecord* change);
  void dropUnusedSteiner(int* steiner, ChangeRecord* change);
  void setPieces(int pid, const std::vector<int>& pieces);
  bool replace(const std::vector<int>& remove, const std::vector<TetVerts>& add,
               ChangeRecord* change, const std::vector<int>* from, std::vector<int>* ids);
  /// replace() of `tets` by themselves with v renamed `copy` (TetMesh::renameVertex).
  bool splitOff(const std::vector<int>& tets, int v, int copy, ChangeRecord* change,
                std::vector<int>* ids);
  /// Makes a change by `make` (std::vector<int>(ChangeRecord*): fills the record it is given, or
  /// throws std::logic_error with the mesh unchanged) and follows it; false when refused. (A
  /// template: as a std::function, the callers' lambdas were too big to be held in place.)
  template <typename Make>
  bool changeMesh(const std::vector<int>& remove, const Make& make, ChangeRecord* change,
                  std::vector<int>* ids);
  void refreshGrid(const ChangeRecord& change);
  /// Tets just filed (anew) that the grid could return for a box inside the cached one join it.
  void joinNearCache(const std::vector<int>& tets);
  void rebuildGrid();
  /// Grows the per-slot scratch of the searches and of the separation to the mesh's slots (see
  /// reset()).
  void sizeScratch();
  /// The grid's query, from candidates kept while the blade stays near (see near_cache_).
  void gridQuery(const Vec3& lo, const Vec3& hi, std::vector<int>* out);
  /// Makes near_cache_ hold the grid's candidates around [lo, hi] (anew: even where it does).
  void cacheNear(const Vec3& lo, const Vec3& hi, bool anew = false);
  /// Whether near_cache_ holds the grid's candidates around [lo, hi] (cacheNear() keeps it).
  bool cacheHolds(const Vec3& lo, const Vec3& hi) const;
  /// How far the blade `at`'s box lies inside near_cache_'s on its nearest side.
  double cacheMargin(const BladeSegment& at) const;
  /// Before the quiet features are taken around the blade `at`: where the near cache's edge
  /// would cut the quiet reach short, the cache and the gaps are taken anew around it.
  void roomAround(const BladeSegment& at);
  /// gridQuery for the sweep from `from` to `to`, leaving out tets too far from the blade to
  /// take any part in it (see near_gap_).
  void sweepQuery(const BladeSegment& from, const BladeSegment& to, const Vec3& lo,
                  const Vec3& hi, std::vector<int>* out);
  /// Whether the gaps are unknown or were taken for a blade that did not go on to `from` (a new
  /// stroke), or nobody says how far the tissue moves: none of them can be carried.
  bool gapsRestart(const BladeSegment& from) const;
  /// Whether sweepQuery() of a sweep from `from` moving the blade by `step` takes the gaps anew.
  bool gapsRetaken(const BladeSegment& from, double step) const;
  /// Takes the gaps anew from the blade `from` (gap_ref_), carrying those far enough.
  void retakeGaps(const BladeSegment& from);
  /// A lower bound of tet t's distance from the blade at gap_ref_, in current positions.
  double gapOf(int t) const;
  /// The Coarse tets of `tets` (a pending tet once, at its first piece).
  void coarseOf(const std::vector<int>& tets, std::vector<Coarse>* out) const;

  TetMesh* mesh_;
  CutterOptions options_;
  double snap_distance_ = 0.0, wound_snap_distance_ = 0.0, mean_edge_ = 0.0;
  TetGrid grid_;
  // The grid's candidates around the blade (TetGrid::candidates), kept while queries stay inside
  // [near_cache_lo_, near_cache_hi_] and grown by the tets filed since; dropped on a rebuild.
  std::vector<int> near_cache_;
  Vec3 near_cache_lo_ = Vec3::Zero(), near_cache_hi_ = Vec3::Zero();
  bool near_cache_valid_ = false;
  std::vector<unsigned char> join_near_;  // joinNearCache()'s: which of its tets are filed near
  // Parallel to near_cache_: a lower bound of each tet's distance from the blade at gap_ref_
  // when it was computed, plus gap_tissue_ then. Since then the blade has moved by at most
  // gap_blade_ (each tick's sweep lies within its larger end move of the blade before it) and
  // the tissue by gap_tissue_ less that; a tet whose entry exceeds the sweep's reach plus both
  // cannot meet this tick's sweep, and the sweep leaves it alone (most ticks the blade moves
  // tens of micrometres inside tets of millimetres: only the tets it is in are looked at).
  // An entry kGapDue is not measured yet: it passes every filter (a gap of at most gap_far_),
  // and gapAt() measures it where it is first read.
  std::vector<double> near_gap_;
  static constexpr double kGapDue = -1.0;
  /// near_gap_[place], measured first where it is due.
  double gapAt(std::size_t place) {
    return near_gap_[place] != kGapDue ? near_gap_[place] : measureDue(place);
  }
  double measureDue(std::size_t place);
  /// The gap measureDue() takes, not kept.
  double dueGap(std::size_t place) const;
  /// sweepQuery()'s reach for a tet's gap, and the reach for one holding a wound vertex, when
  /// blade and tissue moved by `moved` since the gaps were taken.
  std::pair<double, double> gapReach(const BladeSegment& from, const BladeSegment& to,
                                     double step, double moved) const;
  /// Whether sweepQuery() takes tet t with this gap.
  bool gapTakes(int t, double gap, double reach, double wound_reach) const;
  /// Whether a vertex of tv is on a wound.
  bool anyOnWound(const TetVerts& tv) const;
  BladeSegment gap_ref_, gap_last_;
  PreparedSegment gap_segment_;  // gap_ref_'s blade prepared for gapOf()
  bool gap_valid_ = false;
  double gap_blade_ = 0.0, gap_tissue_ = 0.0;
  // Beyond any reach until the gaps are taken again: a gap carried over (see sweepQuery()) is
  // above it.
  double gap_far_ = 0.0;
  bool gap_retake_ = false;  // the cache changed: the next sweep's query takes the gaps again
  // The places in near_cache_ whose gap is at most gap_far_, in order: the only ones a sweep
  // looks at until the gaps are taken again, besides a pending tet's pieces (the cache holds
  // 2,000-3,000 tets around the 20k organ's blade, 5-10% of them this close). Kept while the
  // gaps are valid and not to be taken again; made anew by the query that takes them.
  std::vector<int> near_close_;
  std::vector<int> far_pieces_;  // sweepQuery()'s scratch: pieces' places beyond gap_far_
  bool closeKept() const { return near_cache_valid_ && gap_valid_ && !gap_retake_; }
  void keepClose(std::size_t place, bool inserted);  // near_close_ after joinNearCache() set it
  std::vector<int> old_cache_;  // cacheNear()'s scratch: the cache it replaces, and its gaps
  std::vector<double> old_gap_;
  std::optional<BladeSegment> previous_;
  Vec3 last_motion_ = Vec3::Zero();  // the blade's last move, to push a stroke's end ahead
  double frontShift() const { return 0.6 * snap_distance_; }
  bool stroke_start_ = false;  // no area swept yet in this stroke: the blade's line is front
  std::unordered_map<int, Pending> pending_;
  int next_pending_ = 0;
  std::vector<int> pending_of_;          // per tet slot
  // Per vertex slot: kOnCut for vertices lying on the cut surface (snapped), kWound for points
  // the cutter made on cut surfaces; copies of a vertex and the survivor of a collapse inherit.
  static constexpr unsigned char kOnCut = 1, kWound = 2;
  std::vector<unsigned char> wound_flag_;
  bool onCut(int v) const {
    return static_cast<std::size_t>(v) < wound_flag_.size() && (wound_flag_[v] & kOnCut) != 0;
  }
  void setWoundFlag(int v, unsigned char flag);
  /// A crossing at x of the edge or face `verts` lies on an earlier cut in the tets around it.
  /// *standing (if given) is the wound vertex the crossing stands for, or -1 (none, or a wound
  /// edge of a face).
  bool woundAround(const Vec3& x, const Corners& verts, const Vec3& normal,
                   int* standing = nullptr) const;
  // This stroke's edge crossings dropped because a wound vertex at one end stood for them: the
  // pairs (that vertex, the other end) as pairKey() gives them. A tent split of a tet holding both
  // may go through the vertex instead (see finalize()).
  std::unordered_set<long long> stood_for_;
  static long long pairKey(int u, int v) {
    return (static_cast<long long>(u) << 32) | static_cast<unsigned>(v);
  }
  /// x lies within the snap distance of the blade's line at the start of this tick's sweep
  /// (`tris`, as sweptTriangles() gives them), beside it and not ahead of the blade.
  bool nearTrailingLine(const Vec3& x, const std::array<Triangle, 2>& tris) const;
  // Vertices kept off the cut because a point was made on one of their edges first, with their
  // rest positions then (a slot reused or a vertex moved since no longer matches).
  std::unordered_map<int, Vec3> kept_off_;
  // Quiet ticks (CutterOptions::skip_quiet). After a tick that swept, the vertices, edges and
  // faces a sweep could act on before the blade and the tissue have moved quiet_reach_ from the
  // blade quiet_ref_ (quiet_moved_ so far) are kept, and each tick until then tests those alone
  // (watchedQuiet()). Changes to the cut's state keep them (they only make more features inert);
  // the features of tets a change adds join them (refreshGrid()).
  bool quiet_valid_ = false;
  BladeSegment quiet_ref_;
  PreparedSegment quiet_segment_;  // quiet_ref_'s blade prepared for quietTet()'s distances
  double quiet_reach_ = 0.0, quiet_moved_ = 0.0;
  // Each kept feature with how far the moves must add up before a sweep could act on it (its
  // distance from quiet_ref_ less its band), in that order: a tick tests only those its moves
  // have reached.
  struct QuietVertex {
    double at;
    int v;
    // The moves at which a tick's test of it found it clear of the blade's bands by its
    // distance then, plus that distance (less the wider band): watchedQuiet() leaves it until.
    mutable double next = 0.0;
    auto key() const { return std::tie(at, v); }
  };
  struct QuietEdge {
    double at;
    int a, b;  // a < b
    // The moves at which a tick's test of it found it clear of the blade by its distance then,
    // plus that distance: no tick's quad reaches it before the moves do (watchedQuiet()).
    mutable double next = 0.0;
    auto key() const { return std::tie(at, a, b); }
  };
  struct QuietFace {
    double at;
    std::array<int, 3> f;  // sorted
    // The moves at which a tick's test of it found it clear of the front's path by its distance
    // from the path's end then (over the turn's scale), plus that: watchedQuiet() leaves it until.
    mutable double next = 0.0;
    auto key() const { return std::tie(at, f); }
  };
  std::vector<QuietVertex> quiet_verts_;
  std::vector<QuietEdge> quiet_edges_;
  std::vector<QuietFace> quiet_faces_, quiet_base_faces_;  // near the tip's path, the base's
  // sortQuiet()'s merges, kept for their room.
  std::vector<QuietVertex> quiet_verts_merged_;
  std::vector<QuietEdge> quiet_edges_merged_;
  std::vector<QuietFace> quiet_faces_merged_;
  std::vector<std::pair<int, int>> quiet_scratch_;
  double quiet_slack_ = 0.0;     // rounding room of the distances above
  bool quiet_unsorted_ = false;  // features joined since they were sorted
  /// Sorts the kept features (and drops repeats).
  void sortQuiet();
  bool pieces_only_ = false;  // the change being made replaces a pending tet's pieces
  /// Keeps the features a sweep could act on within the quiet reach of the blade `at` (this
  /// tick's, swept), and returns that reach; 0 when it is not known (see
  /// CutterOptions::skip_quiet).
  double quietReach(const BladeSegment& at);
  /// Whether a sweep only looks at v: trySnap() returns before changing anything.
  bool snapLooksOnly(int v) const;
  /// The edges a crossing of which changes nothing (sorted, a < b; in quiet_scratch_).
  const std::vector<std::pair<int, int>>& refusedEdges();
  /// Keeps what tet tv holds within the quiet reach of quiet_ref_ (`lower`: a lower bound of its
  /// distance from it; cut_edges: the edges a crossing of which coarseAround() refuses).
  void quietTet(const TetVerts& tv, double lower,
                const std::vector<std::pair<int, int>>& cut_edges);
  /// Starts a batch of quietTet() calls (one state of the mesh and the cut): each vertex is
  /// looked at once in a batch (quiet_seen_[v] == quiet_batch_ once it was; its distance from
  /// quiet_ref_'s blade is then in quiet_dist_[v]), and each edge once (quiet_edges_met_).
  void newQuietBatch();
  std::vector<unsigned> quiet_seen_;
  std::vector<double> quiet_dist_;
  unsigned quiet_batch_ = 0;
  /// The edges (a << 32 | b, a < b) met in the batch: an edge lies in ~5 of its tets, and its
  /// distance from the blade is measured once.
  StampedTable<char> quiet_edges_met_;
  /// Whether this tick's sweep from `from` to `to` and its fronts leave alone every kept feature
  /// the moves since quiet_ref_, `moved` with this tick's, have reached.
  /// With `out`, the test goes on past the first such feature and notes them there (it stops at
  /// a second vertex), and the answer is out->none().
  bool watchedQuiet(const BladeSegment& from, const BladeSegment& to, double moved,
                    Reached* out = nullptr) const;
  /// Whether the sweep from `from` to `to` would pass vertex v to trySnap(): 1 it would, 0 it
  /// would not, -1 not known without sweeping (it would take the near cache or the gaps anew).
  int sweepLooksAt(int v, const BladeSegment& from, const BladeSegment& to,
                   const std::array<Triangle, 2>& tris) const;
  Reached reached_;
  std::set<int> deferred_;               // vertices to split once that keeps a 2-manifold
  // Vertices of the tets and marks changed since separate() last ran (by the cutter or, through
  // follow(), by collapse): a waiting vertex is tried again only within two rings of one of them,
  // since whether it can split depends on nothing farther (see separate()).
  std::vector<int> changed_near_;
  void noteChanged(const ChangeRecord& change);
  std::unordered_set<std::array<int, 3>, FaceHash> marked_;  // cut faces not opened (sorted ids)
  void mark(const std::array<int, 3>& face);
  bool unmark(const std::array<int, 3>& face);
  std::vector<int> marked_at_;  // per vertex slot: the number of marked faces holding it
  bool markedAt(int v) const {
    return v < static_cast<int>(marked_at_.size()) && marked_at_[v] > 0;
  }
  CutCounts counts_;
  long long epoch_ = 0;  // changes with anything the separation depends on (collapses too)
  long long busy_epoch_ = 0;  // see stateEpoch()
  // isBusy()'s answers by vertex slot, each for the epoch busy_known_ holds plus one (0: none).
  mutable std::vector<long long> busy_known_;
  mutable std::vector<unsigned char> busy_answer_;
  bool keepBusy(int v) const;  // isBusyAfresh(v), kept as isBusy()'s answer for this epoch
  void stateChanged() {
    ++epoch_;
    ++busy_epoch_;
  }
  long long separated_at_ = -1;  // epoch_ when separate() last started
  std::string refusal_;  // the first refused replacement of this tick
  // Scratch buffers of one tick, kept for their capacity.
  std::vector<int> near_scratch_;
  std::vector<Coarse> sweep_near_, front_near_;  // sweep()'s and crossFront()'s coarse tets
  std::vector<TetVerts> sweep_corners_;  // sweep()'s coarse tets near the swept triangles
  std::vector<Coarse> around_;  // the coarse tets around an edge or face a point is put on
  std::vector<std::array<int, 3>> front_done_;  // crossFront()'s faces tried (sorted corners)
  mutable std::vector<int> seen_scratch_;    // coarseOf()'s and coarseAround()'s pending tets
  mutable std::vector<int> points_scratch_;  // conforming()'s points
  ChangeRecord mesh_change_;                 // changeMesh()'s record, emptied before each use
  std::vector<int> change_added_;            // changeMesh()'s new tets where the caller keeps none
  // subdivide()'s and finalize()'s lists, kept for their room (finalize() calls subdivide()).
  TetSplit subdivide_split_, finalize_split_;
  std::vector<int> subdivide_ids_, subdivide_old_, finalize_ids_, finalize_from_;
  Pending finalize_pending_;
  std::vector<int> refiled_;  // tets the grid filed anew this tick (TetGrid::refresh)
  std::vector<int> update_refiled_;  // and with a change (TetGrid::update)
  double moved_ = 0.0;        // how far vertices may have moved since the grid's last refresh
  bool told_motion_ = false;  // tissueMoved() was called: moved_ is known
  std::vector<int> swept_near_;  // this tick's sweep search, while no tet has been replaced
  Vec3 swept_lo_ = Vec3::Zero(), swept_hi_ = Vec3::Zero();
  bool swept_valid_ = false;
  std::vector<std::pair<int, int>> edge_scratch_;
  // groupsAround's scratch: per tet slot, the call that last saw it in the star and its place.
  mutable std::vector<unsigned> star_stamp_;
  mutable std::vector<int> star_place_;
  mutable unsigned star_call_ = 0;
  mutable std::vector<int> star_parent_, star_group_;  // its union-find, each root's group
  mutable std::vector<int> group_tets_, group_start_;  // its answer (see groupsAround())
  // separate()'s scratch: per vertex slot, the call that put it in the rings around the changes,
  // the last waiting vertex whose rings held it; the ring being grown, and the next.
  std::vector<unsigned> ring_stamp_, wait_stamp_;
  unsigned ring_call_ = 0, wait_call_ = 0;
  std::vector<int> ring_, ring_next_;
  // heldSplits' scratch, per tet slot: the group each corner's vertex will use (-1: it does not
  // split), the faces that open (bit f), the call that put it in the region; per vertex slot: a
  // candidate that splits or is held back, the call that put it in the check.
  std::vector<std::array<int, 4>> corner_group_;
  std::vector<unsigned char> open_face_;
  // heldSplits()' lists, kept for their capacity (eight vectors grown each call had been a tenth
  // of the separation): its candidates and their stars' tets, each round's region, the faces
  // opened, the vertices to check and those held; a checked vertex's boundary links; the answer.
  std::vector<int> held_splitting_, held_stars_, held_region_, held_opened_, held_check_,
      held_back_, held_result_;
  struct FanEdge {
    std::int64_t copy, prev, next;  // around the copy of the vertex, the boundary runs prev -> next
  };
  std::vector<FanEdge> held_fan_;
  // groupsAround()'s answers for heldSplits()' vertices, kept for separate(): for verts[i],
  // g = kept_groups_[i] is its first group's place in kept_start_ (-1: none kept; kCountKept:
  // one group or none, counted only) and kept_count_[i] how many; group k of it is
  // kept_tets_[kept_start_[g + k] .. kept_start_[g + k + 1]). A vertex slot's kept_stale_ is
  // kept_call_ once a split has changed its star or marks since.
  static constexpr int kCountKept = -2;
  std::vector<int> kept_groups_, kept_count_, kept_start_, kept_tets_;
  std::vector<unsigned> kept_stale_;
  unsigned kept_call_ = 0;
  // finalizeLeft()'s lists, kept likewise: the pending tets to subdivide anew, the vertices the
  // final splits touched, the pending tets the blade left.
  std::vector<int> final_ids_, final_touched_, left_;
  std::vector<int> separate_before_, separate_after_;  // separate()'s waiting lists, likewise
  // separate()'s for one vertex split off: its groups of tets, the record of a group's split, the
  // group sorted, the cut faces it holds, the pending tets it holds and one of those's pieces.
  std::vector<std::vector<int>> separate_groups_;
  ChangeRecord separate_change_;
  std::vector<int> in_group_;
  std::vector<std::pair<std::array<int, 3>, bool>> separate_marks_;
  std::vector<int> separate_pendings_, separate_pieces_, separate_ids_;
  std::vector<unsigned> region_stamp_, check_stamp_;
  unsigned region_call_ = 0, check_call_ = 0;
  std::vector<unsigned char> split_state_;
  std::vector<unsigned> vertex_seen_;  // per vertex slot: seen_stamp_ when the sweep saw it
  unsigned seen_stamp_ = 0;
  // sweep()'s per-tick values of vertices along the swept triangles' axes and from their planes:
  // per vertex slot, the tick that took them and their place in axis_values_.
  std::vector<unsigned> axis_stamp_;
  unsigned axis_call_ = 0;
  std::vector<int> axis_slot_;
  std::vector<std::array<double, 10>> axis_values_;
  std::vector<std::array<int, 3>> face_scratch_;
};

}  // namespace tissue_cut
