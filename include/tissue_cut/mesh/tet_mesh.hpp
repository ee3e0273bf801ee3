// TetMesh: the one owner of the tissue's topology, with rest and current geometry.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "tissue_cut/mesh/inline_vector.hpp"

namespace tissue_cut {

using Vec3 = Eigen::Vector3d;
using TetVerts = std::array<int, 4>;

/// Whether two vertex lists (a tet's, a face's, an edge's) hold the same vertices in the same
/// places. (std::array's == compiles to a call of memcmp, tens of thousands of them a cut.)
template <std::size_t N>
inline bool sameVertices(const std::array<int, N>& a, const std::array<int, N>& b) {
  int differ = 0;
  for (std::size_t i = 0; i < N; ++i) differ |= a[i] ^ b[i];
  return differ == 0;
}

/// std::array's own order (the first differing place decides), compared field by field: the
/// sorts of small vertex tuples ask it often, and std::array's < goes through a generic compare.
/// Negative when a comes first, 0 when equal, positive when b does.
template <std::size_t N>
inline int compareVertices(const std::array<int, N>& a, const std::array<int, N>& b) {
  for (std::size_t i = 0; i < N; ++i)
    if (a[i] != b[i]) return a[i] < b[i] ? -1 : 1;
  return 0;
}

/// Face f of a tet is opposite its local vertex f. The listed order makes the face normal
/// (right-hand rule) point out of a positively oriented tet.
constexpr int kTetFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
/// The six edges of a tet as pairs of local vertices.
constexpr int kTetEdge[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

/// A face named by its three vertex ids, sorted: the same name from whichever tet or corner.
inline std::array<int, 3> sortedFace(int a, int b, int c) {
  if (a > b) std::swap(a, b);
  if (b > c) std::swap(b, c);
  if (a > b) std::swap(a, b);
  return {a, b, c};
}

/// The capacity given to an array of one entry per vertex or tet slot when it must grow: a
/// quarter to spare. The mesh grows a few slots a cut (the 20k organ's incision adds 1.5% of its
/// vertices and 1.3% of its tets), and std::vector grows only when full, so an array sized
/// exactly at load was copied into fresh pages on the first tick that added a slot: 0.5-0.8 ms
/// for the physics step's arrays of the 20k organ, several times over a replay.
inline std::size_t slotCapacity(std::size_t slots) { return slots + slots / 4 + 256; }

/// v resized to `slots` entries (new ones `fill`), taking slotCapacity() when it must grow.
template <class T>
void resizeSlots(std::vector<T>* v, std::size_t slots,
                 const typename std::vector<T>::value_type& fill = T()) {
  if (slots > v->capacity()) v->reserve(slotCapacity(slots));
  v->resize(slots, fill);
}

/// v grown to at least `slots` entries (new ones `fill`), as resizeSlots().
template <class T>
void growSlots(std::vector<T>* v, std::size_t slots,
               const typename std::vector<T>::value_type& fill = T()) {
  if (v->size() < slots) resizeSlots(v, slots, fill);
}

/// v set to `slots` entries of `fill`, as resizeSlots() (what it had spare it keeps).
template <class T>
void assignSlots(std::vector<T>* v, std::size_t slots,
                 const typename std::vector<T>::value_type& fill = T()) {
  v->clear();
  resizeSlots(v, slots, fill);
}

/// A new mark for one pass over per-slot stamps (each pass marks what it has seen with *call),
/// the stamps grown to `slots` entries; when the counter wraps, all are cleared so that no old
/// mark equals the new one.
inline void nextStamp(std::vector<unsigned>* stamps, unsigned* call, std::size_t slots) {
  growSlots(stamps, slots, 0u);
  if (++*call == 0) {
    std::fill(stamps->begin(), stamps->end(), 0u);
    *call = 1;
  }
}

/// Where vertex v sits in tet t (0-3; the first place, were it in two), or -1 when t does not
/// hold it. The four places compared at once, the first found by its bit: a loop stopping at the
/// match mispredicted its exit about as often as it ran (the place is any of the four).
inline int localIndex(const TetVerts& t, int v) {
  const unsigned at = static_cast<unsigned>(t[0] == v) | static_cast<unsigned>(t[1] == v) << 1 |
                      static_cast<unsigned>(t[2] == v) << 2 | static_cast<unsigned>(t[3] == v) << 3;
  return at != 0 ? __builtin_ctz(at) : -1;
}

/// Whether tet t holds vertex v (the four places compared at once, as in localIndex()).
inline bool contains(const TetVerts& t, int v) {
  return (t[0] == v) | (t[1] == v) | (t[2] == v) | (t[3] == v);
}

/// Hash of a face named by its three vertex ids (sorted, as the maps of faces keep them).
struct FaceHash {
  std::size_t operator()(const std::array<int, 3>& k) const {
    std::size_t h = static_cast<std::size_t>(k[0]) * 73856093u;
    h ^= static_cast<std::size_t>(k[1]) * 19349663u;
    h ^= static_cast<std::size_t>(k[2]) * 83492791u;
    return h;
  }
};

/// A new vertex is an affine combination of existing ones (weights sum to 1).
struct VertexParent {
  int vertex;
  double weight;
};
/// A vertex's parents: at most a tet's four corners (kept in place: a cut makes vertices by the
/// dozen a tick). A fifth throws std::length_error.
using VertexParents = InlineVector<VertexParent, 4>;

/// What one topology change did. Everyone keeping per-vertex or per-tet data updates from it, in
/// this order: removed tets, removed vertices, added vertices, added tets. Slots in the removed
/// lists may be reused by the added lists of the same record.
struct ChangeRecord {
  std::vector<int> removed_tets;
  std::vector<int> added_tets;
  /// Parallel to added_tets: the removed tet an added one continues (the same material element
  /// with a vertex renamed or moved), or -1 for a new element made by a cut.
  std::vector<int> added_from;
  std::vector<int> added_vertices;
  std::vector<VertexParents> vertex_parents;  ///< parallel to added_vertices
  std::vector<int> removed_vertices;
  std::vector<std::pair<int, int>>
      merged_vertices;  ///< (removed, survivor), also in removed_vertices

  bool empty() const;
  /// Empties every list and keeps their room: a record reused change after change (the tick's,
  /// a collapse's) stops taking from the heap once its lists have grown to a tick's size.
  void clear();
  /// Composes `later`, which happened after this record, into one net change: what was added
  /// and removed again within the two vanishes from both lists.
  void append(const ChangeRecord& later);
  /// The same, scanning the lists while |later.removed_tets| times |added_tets| (and |later's
  /// added| times |later's removed|) stays within scan_limit, and above it noting later's
  /// removed slots (or their origins) first in a hash table: append() takes 256; both ways give
  /// the same record (a test composes with 0, 256 and no limit).
  void append(const ChangeRecord& later, std::size_t scan_limit);
};

/// A tetrahedral mesh with incidence and adjacency kept up to date under every change.
/// Tet ids are slots: a removed slot is dead until a later change reuses it, and both events are
/// announced in that change's record. Vertex ids are never reused, so they grow with creation.
class TetMesh {
 public:
  TetMesh() = default;
  /// V: #V by 3 rest positions [m] (current = rest, velocity 0); T: #T by 4 vertex ids.
  /// Negatively oriented tets are flipped (see reoriented()). Throws std::invalid_argument for an
  /// index out of range, a repeated vertex in a tet, a face shared by more than two tets.
  TetMesh(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T);

  // --- sizes and liveness
  int vertexSlots() const { return static_cast<int>(rest_.size()); }
  int tetSlots() const { return static_cast<int>(tets_.size()); }
  int numVertices() const { return num_vertices_; }
  int numTets() const { return num_tets_; }
  bool vertexAlive(int v) const { return vertex_alive_[v] != 0; }
  bool tetAlive(int t) const { return tet_alive_[t] != 0; }
  /// vertexAlive() for every vertex slot, nonzero where alive (for loops over all slots).
  const std::vector<unsigned char>& vertexAliveFlags() const { return vertex_alive_; }
  int reoriented() const { return reoriented_; }

  // --- geometry [m], [m/s]
  const Vec3& rest(int v) const { return rest_[v]; }
  const Vec3& current(int v) const { return current_[v]; }
  const Vec3& velocity(int v) const { return velocity_[v]; }
  Vec3& current(int v) { return current_[v]; }
  Vec3& velocity(int v) { return velocity_[v]; }
  std::vector<Vec3>& currentPositions() { return current_; }
  std::vector<Vec3>& velocities() { return velocity_; }
  const std::vector<Vec3>& currentPositions() const { return current_; }
  const std::vector<Vec3>& restPositions() const { return rest_; }

  // --- topology
  const TetVerts& tet(int t) const { return tets_[t]; }
  /// The tet across face f of t (face f is opposite local vertex f), or -1 on the boundary.
  int neighbor(int t, int f) const { return neighbors_[t][f]; }
  /// Live tets incident to vertex v.
  const std::vector<int>& vertexTets(int v) const { return vertex_tets_[v]; }
  /// Live tets containing both a and b (the star of edge ab), in no particular order.
  std::vector<int> edgeTets(int a, int b) const;
  /// The same into out[0 .. capacity) (no allocation); returns how many there are, which may be
  /// more than capacity (the rest not written).
  int edgeTets(int a, int b, int* out, int capacity) const;
  /// Whether some live tet holds both a and b (edgeTets() not empty), without building the list.
  bool hasEdge(int a, int b) const;
  /// The live tet having face {a, b, c} other than `except`, or -1.
  int faceTet(int a, int b, int c, int except = -1) const;
  /// Number of boundary faces (faces with no neighbour).
  int numBoundaryFaces() const { return num_boundary_faces_; }
  /// Number of boundary faces through vertex v (kept with every change: a boundary test of a
  /// vertex is one read instead of a walk over its star).
  int boundaryFacesAt(int v) const { return boundary_faces_[v]; }
  /// Unique edges of live tets as (smaller id, larger id).
  std::vector<std::pair<int, int>> edges() const;
  /// Tet 4-tuples of live tets (#T by 4) and the slot of each row; V rows are vertex slots.
  Eigen::MatrixXi liveTets(std::vector<int>* slots = nullptr) const;

  // --- measures of one tet
  /// Signed volume of tet t in rest positions, kept with the tet as its quality is.
  double restVolume(int t) const { return rest_volume_[t]; }
  double currentVolume(int t) const;
  /// Q of tet t in rest positions (tetQuality()), kept with the tet: rest positions change only
  /// through this class, and the remeshers ask for the same tets' Q tens of thousands of times.
  double restQuality(int t) const { return rest_quality_[t]; }
  /// Total rest / current volume of live tets [m^3].
  double restVolume() const;
  double currentVolume() const;

  // --- changes (each returns what it did)
  /// Adds a vertex whose rest and current position and velocity are the parents' weighted sums.
  int addVertex(const VertexParents& parents, ChangeRecord* record);
  /// Removes the tets `remove`, then adds `add` (vertex ids, positively oriented in rest
  /// positions); updates incidence and adjacency locally. `from` (optional, parallel to `add`)
  /// names the removed tet each added one continues, -1 for new ones (see ChangeRecord).
  /// Returns the new tets' ids in the order of `add`. Throws std::logic_error (mesh unchanged)
  /// when an added tet repeats a vertex, names a dead vertex, or would make a face shared by more
  /// than two tets.
  std::vector<int> replaceTets(const std::vector<int>& remove, const std::vector<TetVerts>& add,
                               ChangeRecord* record, const std::vector<int>* from = nullptr);
  /// The same with the new tets' ids into *ids (emptied first; its room reused; not `remove` or
  /// `from`).
  void replaceTets(const std::vector<int>& remove, const std::vector<TetVerts>& add,
                   ChangeRecord* record, const std::vector<int>* from, std::vector<int>* ids);
  /// Removes a vertex that no tet uses any more.
  void removeVertex(int v, ChangeRecord* record);
  /// Moves vertex v to the parents' weighted sums of rest and current positions and velocities
  /// (`parents` may name v itself; weights sum to 1), then announces its star as replaced by the
  /// same tets (added_from = themselves), so masses and springs follow. The caller makes sure no
  /// tet of the star inverts. Throws std::logic_error (mesh unchanged) for a dead vertex or
  /// parent, or when a tet of the star would have no positive rest volume.
  void moveVertex(int v, const VertexParents& parents, ChangeRecord* record);
  /// The tets `tets` (live, each holding v) take `copy` (live, in no tet yet: a vertex just
  /// added) in place of v: the faces among them stay joined, those through v to other tets open.
  /// Leaves the mesh and `record` exactly as replaceTets(tets, the renamed tets, record, &tets)
  /// would (the same slots, adjacency and star orders), without its searches. Returns the new
  /// slots in the order of `tets`. Throws std::logic_error (mesh unchanged) for a dead or repeated
  /// tet, a tet without v, a copy that is dead, v, or already in a tet, or a renamed tet without
  /// positive rest volume.
  std::vector<int> renameVertex(const std::vector<int>& tets, int v, int copy,
                                ChangeRecord* record);
  /// The same with the new slots into *ids (emptied first; its room reused; not `tets`).
  void renameVertex(const std::vector<int>& tets, int v, int copy, ChangeRecord* record,
                    std::vector<int>* ids);
  /// Moves every tet of `removed` onto `survivor`; tets holding both vanish; `removed` dies.
  /// Geometry of the survivor is unchanged.
  void mergeVertices(int removed, int survivor, ChangeRecord* record);

  /// Checks the invariants: live vertices of every tet, positive rest volume, the kept rest Q,
  /// incidence, symmetric adjacency with opposite orientation across each interior face, no face in
  /// more than two tets, a closed consistently oriented 2-manifold boundary, no isolated vertex.
  /// Returns "" when valid, else the first violation in words.
  std::string validate() const;

 private:
  void linkTet(int t);
  /// Unlinks the tets `remove` (marked with replaceTets()' stamp) from their neighbours and their
  /// vertices' lists.
  void unlinkTets(const std::vector<int>& remove);
  /// Reorders a face's vertices so that *a has the fewest tets (a face search walks its star).
  void smallestStarFirst(int* a, int* b, int* c) const;
  /// Puts the tet of slot star[i] into slot star[n - 1 - i] with v renamed `copy` (v itself:
  /// none), as replaceTets(star, those tets, record, &star) would; see renameVertex().
  void restack(const std::vector<int>& star, int v, int copy, ChangeRecord* record);
  int allocateTet();
  int allocateVertex();
  // Measures the rest Q of the tet now in slot t.
  void measureTet(int t);
  // The boundary-face counts of a face's three vertices, changed by `delta`.
  void countBoundaryFace(int a, int b, int c, int delta) {
    boundary_faces_[a] += delta;
    boundary_faces_[b] += delta;
    boundary_faces_[c] += delta;
  }

  std::vector<Vec3> rest_, current_, velocity_;
  std::vector<unsigned char> vertex_alive_;
  std::vector<std::vector<int>> vertex_tets_;
  std::vector<TetVerts> tets_;
  std::vector<double> rest_quality_;  // per tet slot; restQuality()
  std::vector<double> rest_volume_;   // per tet slot; restVolume()
  std::vector<std::array<int, 4>> neighbors_;
  std::vector<unsigned char> tet_alive_;
  std::vector<int> free_tets_;
  // replaceTets()'s scratch: per tet slot, the stamp of the call removing it; per place among
  // the new faces (4 x the new tet's place in `add` + the face), its sorted vertices, and at a
  // face's first place how many places name it and the second one; the table of first places
  // by the faces' hashes; per place, what lies across the face (a kept tet, or -2 - the place
  // of a new tet's face, or -1: nothing).
  std::vector<unsigned> removing_;
  unsigned removing_stamp_ = 0;
  std::vector<std::array<int, 3>> face_keys_;
  std::vector<int> face_count_, face_second_, face_table_;
  std::vector<int> face_across_;
  std::vector<int> merge_old_, merge_from_;  // mergeVertices()'s star and the tets moved
  std::vector<int> merge_ids_;               // and their new slots
  std::vector<int> move_star_;               // moveVertex()'s star
  std::vector<TetVerts> merge_moved_;
  // restack()'s scratch: per tet slot its place in the star; the star's tets and adjacency.
  std::vector<int> move_place_, move_vertices_;
  std::vector<int> unlink_vertices_;   // unlinkTets()' vertices, each once
  std::vector<unsigned> vertex_mark_;  // per vertex slot, the restack() or unlinkTets() call
                                       // that noted it
  unsigned vertex_mark_call_ = 0;
  std::vector<TetVerts> move_tets_;
  std::vector<std::array<int, 4>> move_neighbors_;
  std::vector<std::array<double, 2>> move_measures_;  // rest quality and volume, for a rename
  int num_vertices_ = 0, num_tets_ = 0, num_boundary_faces_ = 0, reoriented_ = 0;
  std::vector<int> boundary_faces_;  // per vertex slot: boundaryFacesAt()
};

/// Signed volume of the tet (a, b, c, d): positive when d sees (a, b, c) counter-clockwise [m^3].
/// (Inline: the quality measures and the remeshers' checks call it tens of millions of times.)
inline double signedVolume(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return (b - a).dot((c - a).cross(d - a)) / 6.0;
}

/// Squared distance [m^2] from x to the segment from a along d (= b - a, |d|^2 = len2): the
/// square of distanceToSegment(x, a, b), before its square root.
inline double squaredDistanceToSegment(const Vec3& x, const Vec3& a, const Vec3& d, double len2) {
  const double t = len2 > 0 ? std::clamp((x - a).dot(d) / len2, 0.0, 1.0) : 0.0;
  return (x - (a + t * d)).squaredNorm();
}

/// Distance [m] from x to the segment ab (to a when the segment is a point).
double distanceToSegment(const Vec3& x, const Vec3& a, const Vec3& b);

/// Distance [m] from x to the closest point of the triangle abc (its interior, an edge or a
/// corner).
double pointTriangleDistance(const Vec3& x, const Vec3& a, const Vec3& b, const Vec3& c);

}  // namespace tissue_cut
