#include "tissue_cut/physics/mass_spring.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <limits>
#include <sstream>

#include "tissue_cut/physics/lane_inverse.hpp"

namespace tissue_cut {

namespace {

// The room a new vertex's lists of springs start with.
constexpr std::size_t kNewListRoom = 8;

// k x for a symmetric block k = (xx, xy, xz, yy, yz, zz).
template <class Sym>
Vec3 apply(const Sym& k, const Vec3& x) {
  return Vec3(k.xx * x.x() + k.xy * x.y() + k.xz * x.z(),
              k.xy * x.x() + k.yy * x.y() + k.yz * x.z(),
              k.xz * x.x() + k.yz * x.y() + k.zz * x.z());
}

template <class Sym>
void addTo(Sym* m, const Sym& k) {
  m->xx += k.xx;
  m->xy += k.xy;
  m->xz += k.xz;
  m->yy += k.yy;
  m->yz += k.yz;
  m->zz += k.zz;
}

// The warm start's guesses from the last three answers (newest first): the linear extrapolation,
// and what the quadratic one adds to it.
// For 3-vectors and for finishStep()'s padded ones (through a pointer: see applyBlock()).
template <class V>
inline void linearGuess(const V& w, const V& w_prev, V* out) {
  *out = 2.0 * w - w_prev;
}
template <class V>
inline void curvature(const V& w, const V& w_prev, const V& w_prev2, V* out) {
  *out = (w - 2.0 * w_prev) + w_prev2;
}

// The inverse of a symmetric block by cofactors; false when it is not positive definite. Always
// inlined: called from setupVertices()' AVX2 copy, it had been a call that spilled the vectors.
template <class Sym>
inline __attribute__((always_inline)) bool invert(Sym* m) {
  const double a = m->xx, b = m->xy, c = m->xz, d = m->yy, e = m->yz, f = m->zz;
  const double A = d * f - e * e, B = c * e - b * f, C = b * e - c * d;
  const double det = a * A + b * B + c * C;
  if (!(det > 0) || !(a > 0)) return false;
  const double s = 1.0 / det;
  *m = {A * s, B * s, C * s, (a * f - c * c) * s, (b * c - a * e) * s, (a * d - b * b) * s};
  return true;
}

// x = a r for the symmetric M x M matrix a (row-major).
template <int M>
void multiply(const double* a, const double* r, double* x) {
  for (int i = 0; i < M; ++i) {
    double s = 0.0;
    for (int j = 0; j < M; ++j) s += a[i * M + j] * r[j];
    x[i] = s;
  }
}

}  // namespace

MassSpring::MassSpring(TetMesh* mesh, const MassSpringParams& params)
    : mesh_(mesh), params_(params) {
  makeTeam();
  resize();
  assignSlots(&tet_copy_, mesh_->tetSlots(), {-1, -1, -1, -1});
  assignSlots(&tet_volume_, mesh_->tetSlots(), 0.0);
  for (int t = 0; t < mesh_->tetSlots(); ++t)
    if (mesh_->tetAlive(t)) {
      tet_copy_[t] = mesh_->tet(t);
      tet_volume_[t] = mesh_->restVolume(t);
    }
  const auto edges = mesh_->edges();
  double sum = 0.0;
  for (const auto& [a, b] : edges) sum += (mesh_->rest(a) - mesh_->rest(b)).norm();
  reference_length_ = edges.empty() ? 0.0 : sum / edges.size();
  springs_.reserve(slotCapacity(edges.size()));
  updateMassesAndSprings(liveVertices(), edges);
  // The loaded mesh's 99th percentile of k / (lighter end's mass), per unit of E / density (see
  // strongThreshold()).
  std::vector<double> couplings;
  couplings.reserve(springs_.size());
  for (const Spring& s : springs_) {
    const double lighter = std::min(mass_[s.a], mass_[s.b]);
    if (lighter > 0) couplings.push_back(s.stiffness / lighter);
  }
  if (!couplings.empty()) {
    const auto at = couplings.begin() + couplings.size() * 99 / 100;
    std::nth_element(couplings.begin(), at, couplings.end());
    loaded_coupling_ = *at * params_.density / params_.young_modulus;
  }
  if (params_.fixed_band >= 0) {
    double side = params_.fixed_max_side ? -1e300 : 1e300;
    for (int v = 0; v < mesh_->vertexSlots(); ++v) {
      if (!mesh_->vertexAlive(v)) continue;
      const double x = mesh_->rest(v)[params_.fixed_axis];
      side = params_.fixed_max_side ? std::max(side, x) : std::min(side, x);
    }
    for (int v = 0; v < mesh_->vertexSlots(); ++v)
      if (mesh_->vertexAlive(v) &&
          std::abs(mesh_->rest(v)[params_.fixed_axis] - side) <= params_.fixed_band)
        fixed_[v] = 1;
  }
}

void MassSpring::setParams(const MassSpringParams& params) {
  const bool stiffness_changed = params.young_modulus != params_.young_modulus;
  const bool mass_changed = params.density != params_.density;
  if (params.implicit != params_.implicit) warm_history_ = 0;  // semi-implicit steps keep none
  params_ = params;
  strong_dt_ = 0.0;  // found again at the next step
  makeTeam();
  if (!mass_changed && !stiffness_changed) return;
  // Every spring is there already: each is updated in its place.
  std::vector<std::pair<int, int>> edges;
  edges.reserve(springs_.size());
  for (const Spring& s : springs_) edges.emplace_back(s.a, s.b);
  std::sort(edges.begin(), edges.end());
  updateMassesAndSprings(liveVertices(), edges);
}

std::vector<int> MassSpring::liveVertices() const {
  std::vector<int> out;
  for (int v = 0; v < mesh_->vertexSlots(); ++v)
    if (mesh_->vertexAlive(v)) out.push_back(v);
  return out;
}

void MassSpring::makeTeam() {
  const int threads = WorkerTeam::usable(params_.threads);
  if (threads == numThreads()) return;
  repack_all_ = true;      // the parts' ranges change
  inertia_valid_ = false;  // and the parts' sums of the mass
  team_.reset();
  if (threads > 1) team_ = std::make_unique<WorkerTeam>(threads);
}

void MassSpring::resize() {
  const std::size_t n = mesh_->vertexSlots();
  resizeSlots(&mass_, n, 0.0);
  resizeSlots(&fixed_, n, static_cast<unsigned char>(0));
  resizeSlots(&warm_, n, Vec3::Zero());
  // The same slots: every step extrapolates (see follow()).
  resizeSlots(&warm_prev_, n, Vec3::Zero());
  resizeSlots(&warm_prev2_, n, Vec3::Zero());
  resizeSlots(&quadratic_at_, n, static_cast<unsigned char>(0));
  // The spring lists by end too, with the slots to spare (slotCapacity()) that the mesh keeps:
  // grown one spring end at a time, they were moved to a new block in the middle of a cut when a
  // new vertex's id passed their capacity (0.45-0.55 ms on one tick of the 20k organ's replay).
  growSlots(&springs_from_, n);
  growSlots(&springs_to_, n);
}

void MassSpring::setFixed(const std::vector<int>& vertices, bool fixed) {
  strong_dt_ = 0.0;  // found again at the next step
  repack_all_ = true;
  for (int v : vertices)
    if (v >= 0 && v < static_cast<int>(fixed_.size())) fixed_[v] = fixed ? 1 : 0;
}

void MassSpring::forgetKept() {
  repack_all_ = true;
  inertia_valid_ = false;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::fill(ends_.begin(), ends_.end(), std::array<int, 2>{-1, -1});
  std::fill(packed_at_.begin(), packed_at_.end(), -2);
  for (SpringConsts& c : consts_) {
    std::fill(std::begin(c.stiffness), std::end(c.stiffness), nan);
    std::fill(std::begin(c.rest), std::end(c.rest), nan);
  }
  std::fill(inertia_.begin(), inertia_.end(), nan);
}

int MassSpring::findSpring(int a, int b) const {
  const int lo = std::min(a, b), hi = std::max(a, b);
  if (lo >= static_cast<int>(springs_from_.size())) return -1;
  for (const SpringRef& r : springs_from_[lo])
    if (r.other == hi) return r.index;
  return -1;
}

void MassSpring::noteChangedInPlace(int spring) {
  // Without implicit steps (physics off, or semi-implicit) nothing reads the notes: past one a
  // spring, packing everything is as cheap.
  if (repack_all_) return;
  if (respring_.size() >= springs_.size()) {
    repack_all_ = true;
    respring_.clear();
    return;
  }
  respring_.push_back(spring);
}

void MassSpring::setSpring(int a, int b, double volume) {
  const int found = findSpring(a, b);
  if (volume <= 0.0) {
    if (found < 0) return;
    // Swap-remove: the last spring takes the slot (and its place in its first end's list).
    const int last = static_cast<int>(springs_.size()) - 1;
    auto at_index = [](int i) { return [i](const SpringRef& r) { return r.index == i; }; };
    for (auto* lists : {&springs_from_, &springs_to_}) {
      std::vector<SpringRef>& at =
          (*lists)[lists == &springs_from_ ? springs_[found].a : springs_[found].b];
      at.erase(std::find_if(at.begin(), at.end(), at_index(found)));
    }
    repack_from_ = std::min(repack_from_, last);  // the packing's end moves
    if (found != last) {
      noteChangedInPlace(found);
      springs_[found] = springs_[last];
      for (auto* lists : {&springs_from_, &springs_to_}) {
        std::vector<SpringRef>& moved =
            (*lists)[lists == &springs_from_ ? springs_[found].a : springs_[found].b];
        std::find_if(moved.begin(), moved.end(), at_index(last))->index = found;
      }
    }
    springs_.pop_back();
    return;
  }
  const double length = (mesh_->rest(a) - mesh_->rest(b)).norm();
  // Van Gelder: k = E * (volume of the tets on the edge) / length^2, so that stiffness follows
  // the material, not the mesh. Kept within [kMinStiffness, kMaxStiffness] x E x the loaded
  // mesh's mean edge (a regular mesh's springs are about 0.6 of it): repeated cuts can leave
  // nanometre edges (k 1e4 N/m) next to micrometre tets hanging on by 1e-8 N/m, and such rows
  // leave the implicit solve's CG unconverged (speeds of 50-130 m/s, rolled back tick after tick).
  const double scale = params_.young_modulus * reference_length_;
  double k = params_.young_modulus * volume / (length * length);
  if (scale > 0) k = std::clamp(k, kMinStiffness * scale, kMaxStiffness * scale);
  const Spring s{std::min(a, b), std::max(a, b), length, k};
  if (found < 0) {
    repack_from_ = std::min(repack_from_, static_cast<int>(springs_.size()));
    growSlots(&springs_from_, s.a + 1);
    growSlots(&springs_to_, s.b + 1);
    // A new vertex's lists start with room for its springs (7 each way on average), not grown
    // by doubling from one.
    for (std::vector<SpringRef>* list : {&springs_from_[s.a], &springs_to_[s.b]})
      if (list->capacity() == 0) list->reserve(kNewListRoom);
    springs_from_[s.a].push_back({s.b, static_cast<int>(springs_.size())});
    springs_to_[s.b].push_back({s.a, static_cast<int>(springs_.size())});
    springs_.push_back(s);
  } else {
    noteChangedInPlace(found);
    springs_[found] = s;
  }
}

void MassSpring::updateMassesAndSprings(const std::vector<int>& vertices,
                                        const std::vector<std::pair<int, int>>& edges) {
  // Each vertex's tets once: its mass, and the volume of the tets on each of its edges to a higher
  // vertex, summed in the order of its tets (reading the lower end's tets again for every edge,
  // and each tet's rest volume again for every edge and vertex on it, had cost follow() more than
  // its records' work).
  // v's edges are found through their far ends, each noted with its place by a stamp (a scan of
  // v's edges for every vertex of every tet had cost as much again).
  if (!vertices.empty()) inertia_valid_ = false;  // their masses change
  // Four more places than edges, one a corner of the tets: where a tet's vertex that is not the
  // far end of one of v's edges adds its volume, so that the loop below takes no branch on it
  // (never read; one a corner, so that those adds do not wait on each other).
  std::vector<double>& volume = edge_volumes_;
  const std::size_t sink = edges.size();
  volume.assign(edges.size() + 4, 0.0);
  const std::size_t slots = mesh_->vertexSlots();
  growSlots(&edge_at_, slots, std::size_t{0});
  std::size_t first = 0;  // the first of v's edges in `edges`
  for (int v : vertices) {
    std::size_t last = first;
    while (last < edges.size() && edges[last].first == v) ++last;
    nextStamp(&edge_seen_, &edge_stamp_, slots);
    for (std::size_t e = first; e < last; ++e) {
      edge_seen_[edges[e].second] = edge_stamp_;
      edge_at_[edges[e].second] = e;
    }
    double m = 0.0;
    if (mesh_->vertexAlive(v))
      for (int t : mesh_->vertexTets(v)) {
        const double tet_volume = tet_volume_[t];
        m += params_.density * tet_volume / 4.0;
        const TetVerts& tv = mesh_->tet(t);
        for (int k = 0; k < 4; ++k) {
          const int u = tv[k];
          const bool edge = (u > v) & (edge_seen_[u] == edge_stamp_);
          volume[edge ? edge_at_[u] : sink + k] += tet_volume;
        }
      }
    mass_[v] = m;
    first = last;
  }
  // A dead end has no tets: its spring goes (volume 0).
  for (std::size_t e = 0; e < edges.size(); ++e)
    setSpring(edges[e].first, edges[e].second, volume[e]);
}

void MassSpring::follow(const ChangeRecord& change) {
  // Vertices came or went (their springs change through setSpring(), which notes the packing's
  // changes). Most ticks follow an empty record.
  if (!change.empty()) inertia_valid_ = false;
  resize();
  growSlots(&tet_copy_, mesh_->tetSlots(), {-1, -1, -1, -1});
  // The vertices and edges of the tets that went or came, each once, in increasing order. A
  // tick's record of collapses and smoothing moves lists each edge about ten times (the tets
  // around it, removed and added again): sorting them all took a third of the follow. The
  // vertices are taken once each by a stamp and sorted; their edges are marked in a matrix over
  // their places in that order and read out row by row, sorted as they come.
  std::vector<int>& vertices = follow_vertices_;
  std::vector<std::pair<int, int>>& edges = follow_edges_;
  vertices.clear();
  edges.clear();
  auto forEachTet = [&](auto&& f) {
    for (int t : change.removed_tets)
      if (tet_copy_[t][0] >= 0) f(tet_copy_[t]);
    for (int t : change.added_tets) f(mesh_->tet(t));
  };
  nextStamp(&follow_seen_, &follow_stamp_, mesh_->vertexSlots());
  forEachTet([&](const TetVerts& tv) {
    for (int v : tv)
      if (follow_seen_[v] != follow_stamp_) {
        follow_seen_[v] = follow_stamp_;
        vertices.push_back(v);
      }
  });
  std::sort(vertices.begin(), vertices.end());
  const int n = static_cast<int>(vertices.size());
  if (n <= kEdgeMatrixMax) {
    growSlots(&follow_place_, follow_seen_.size());
    for (int i = 0; i < n; ++i) follow_place_[vertices[i]] = i;
    follow_matrix_.assign(static_cast<std::size_t>(n) * n, 0);
    forEachTet([&](const TetVerts& tv) {
      for (const auto& e : kTetEdge) {
        const int i = follow_place_[tv[e[0]]], j = follow_place_[tv[e[1]]];
        follow_matrix_[static_cast<std::size_t>(std::min(i, j)) * n + std::max(i, j)] = 1;
      }
    });
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j)
        if (follow_matrix_[static_cast<std::size_t>(i) * n + j])
          edges.emplace_back(vertices[i], vertices[j]);
  } else {
    forEachTet([&](const TetVerts& tv) {
      for (const auto& e : kTetEdge)
        edges.emplace_back(std::min(tv[e[0]], tv[e[1]]), std::max(tv[e[0]], tv[e[1]]));
    });
    std::sort(edges.begin(), edges.end());
    edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  }
  growSlots(&tet_volume_, mesh_->tetSlots(), 0.0);
  for (int t : change.removed_tets) tet_copy_[t] = {-1, -1, -1, -1};
  for (int t : change.added_tets) {
    tet_copy_[t] = mesh_->tet(t);
    tet_volume_[t] = mesh_->restVolume(t);
  }
  for (int v : change.removed_vertices) {
    mass_[v] = 0.0;
    fixed_[v] = 0;
    warm_[v] = Vec3::Zero();
    warm_prev_[v] = Vec3::Zero();
    warm_prev2_[v] = Vec3::Zero();
    quadratic_at_[v] = 0;
  }
  for (std::size_t i = 0; i < change.added_vertices.size(); ++i) {
    const int v = change.added_vertices[i];
    bool all_fixed = !change.vertex_parents[i].empty();
    for (const VertexParent& p : change.vertex_parents[i])
      all_fixed = all_fixed && p.vertex < static_cast<int>(fixed_.size()) && fixed_[p.vertex];
    fixed_[v] = all_fixed ? 1 : 0;
    warm_[v] = Vec3::Zero();
    warm_prev_[v] = Vec3::Zero();
    warm_prev2_[v] = Vec3::Zero();
    quadratic_at_[v] = 0;
  }
  updateMassesAndSprings(vertices, edges);
  if (strong_dt_ > 0 && !vertices.empty()) updateStrong(vertices);
}

double MassSpring::totalMass() const {
  double m = 0.0;
  for (int v = 0; v < mesh_->vertexSlots(); ++v)
    if (mesh_->vertexAlive(v)) m += mass_[v];
  return m;
}

double MassSpring::kineticEnergy() const {
  double e = 0.0;
  for (int v = 0; v < mesh_->vertexSlots(); ++v)
    if (mesh_->vertexAlive(v)) e += 0.5 * mass_[v] * mesh_->velocity(v).squaredNorm();
  return e;
}

void MassSpring::forces(std::vector<Vec3>* f) const {
  const int n = mesh_->vertexSlots();
  f->resize(n);
  for (int v = 0; v < n; ++v)
    (*f)[v] = mesh_->vertexAlive(v)
                  ? Vec3(mass_[v] * (params_.gravity - params_.damping * mesh_->velocity(v)))
                  : Vec3::Zero();
  for (const Spring& s : springs_) {
    const Vec3 d = mesh_->current(s.b) - mesh_->current(s.a);
    const double len = d.norm();
    if (!(len > 0)) continue;
    const Vec3 fa = s.stiffness * (len - s.rest_length) / len * d;
    (*f)[s.a] += fa;
    (*f)[s.b] -= fa;
  }
}

int MassSpring::numThreads() const { return team_ ? team_->size() : 1; }

std::pair<int, int> MassSpring::rangeOf(int count, int part) const {
  const long long parts = numThreads();
  return {static_cast<int>(count * part / parts), static_cast<int>(count * (part + 1) / parts)};
}

int MassSpring::packedBegin(int part) const {
  // Part p's range starts at first_p; its slots at first_p rounded up to a batch, plus kSize p.
  // It packs at most first_{p+1} - first_p springs, so its slots, and the lanes of its last
  // batch, end before first_{p+1} + kSize (p + 1), and so before part p + 1's first slot.
  constexpr int kSize = SpringBatch::kSize;
  const int first = rangeOf(static_cast<int>(springs_.size()), part).first;
  return (first + kSize - 1) / kSize * kSize + kSize * part;
}

double MassSpring::partialSum(int k) const {
  double sum = 0.0;
  for (const Partial& p : partial_) sum += p.sum[k];
  return sum;
}

namespace {

// Four doubles as one vector (GCC's vector extensions: one AVX register where the CPU has AVX2,
// two SSE2 registers otherwise), read and written in place of a Padded3.
typedef double V4 __attribute__((vector_size(32), may_alias));
typedef long long I4 __attribute__((vector_size(32)));
// Two doubles, read where only 8 bytes are sure to be aligned.
typedef double V2 __attribute__((vector_size(16), aligned(8), may_alias));

// The vector (x, y, z, 0) from three doubles: two halves joined (built in a stack slot, such a
// vector waited for the stores before it; through a pointer, as applyBlock() returns).
inline void join3(double x, double y, double z, V4* out) {
  const V2 lo = {x, y};
  const V2 hi = {z, 0.0};
  *out = __builtin_shufflevector(lo, hi, 0, 1, 2, 3);
}

// *out = k d in the lanes of d (the fourth lane zero): three columns times three broadcasts,
// each lane ((k.xx d.x + k.xy d.y) + k.xz d.z) and so on, as apply() does. Inlined into each copy
// of its callers (a V4 returned by value would change the ABI between them).
template <class Sym>
inline void applyBlock(const Sym& k, const V4& d, V4* out) {
  const V4 dx = __builtin_shuffle(d, I4{0, 0, 0, 0});
  const V4 dy = __builtin_shuffle(d, I4{1, 1, 1, 1});
  const V4 dz = __builtin_shuffle(d, I4{2, 2, 2, 2});
  *out = (V4{k.xx, k.xy, k.xz, 0.0} * dx + V4{k.xy, k.yy, k.yz, 0.0} * dy) +
         V4{k.xz, k.yz, k.zz, 0.0} * dz;
}

// A dot product's lanes added as Eigen adds a 3-vector's, (x + y) + z.
inline double sum3(const V4& m) { return (m[0] + m[1]) + m[2]; }

}  // namespace

// Compiled twice, the AVX2 copy chosen where the CPU has it: a vertex's p and sum are one
// register each (one load or store, not three), and a block's product is applyBlock(). On the
// 20k organ a CG iteration took 11% fewer cycles (209 -> 186 k, medians of 10 alternating
// replays); this loop alone, on made-up springs, 68 -> 53 us for 28,700. Each lane does the
// scalar code's operations in its order (the fourth lane is zero): both copies give the bits of
// apply().
__attribute__((target_clones("avx2", "default"))) void MassSpring::springProducts(
    int part, const Padded3* pv) {
  // h^2 K (p_a - p_b) of this part's springs, added at a and taken at b. Springs are kept sorted
  // by their first end (mostly: new ones go last), so the first end's sum stays in registers along
  // a run and only the second end is scattered; that breaks the chain of dependent loads and
  // stores through out[a].
  // The part's own buffer, zero on entry: massProducts(), which reads it, zeroes each row.
  Padded3* out = product_acc_[part].data();
  // The part's springs as assembleSprings() packed them (none whose ends are both held).
  const int begin = packedBegin(part);
  const int end = packed_end_[part];
  const std::array<int, 2>* ends = ends_.data();  // 8 bytes a spring read, not 24
  const BlockBatch* blocks = blocks_.data();
  static_assert(sizeof(Padded3) == sizeof(V4) && alignof(Padded3) >= alignof(V4),
                "a padded vector is four doubles");
  const V4* p4 = reinterpret_cast<const V4*>(pv);
  V4* out4 = reinterpret_cast<V4*>(out);
  int run = -1;
  V4 pa = {0, 0, 0, 0}, sum = {0, 0, 0, 0};
  // A batch's blocks at a time (the part's slots start at a batch's first): a lane's index, not
  // a slot's batch and lane, a spring.
  constexpr int kSize = SpringBatch::kSize;
  for (int first = begin; first < end; first += kSize) {
    const BlockBatch& kb = blocks[first / kSize];
    const int count = std::min(kSize, end - first);
    const std::array<int, 2>* batch_ends = ends + first;
    for (int j = 0; j < count; ++j) {
      const int a = batch_ends[j][0], b = batch_ends[j][1];
      if (a != run) {
        if (run >= 0) out4[run] += sum;
        run = a;
        pa = p4[a];
        sum = V4{0, 0, 0, 0};
      }
      V4 r;
      applyBlock(kb.at(j), pa - p4[b], &r);
      sum += r;
      out4[b] -= r;
    }
  }
  if (run >= 0) out4[run] += sum;
}

void MassSpring::updatePacking() {
  // The packing that packing every spring anew would give (each part's springs with a free end,
  // in order, from the part's first slot), made from the last one: a spring changed in place
  // (respring_) whose end is as held as before keeps its slot, which takes its ends and
  // constants; the springs from repack_from_ on (the end of springs_ moved), or from a spring
  // that is now held at both ends or no longer, are packed again. Everything is packed again
  // after a fixed vertex or the number of parts changed, and with more than one part after any
  // change (the parts' ranges follow the number of springs). A cut changes a few dozen springs
  // of 28,000 on the 20k organ: packing them all on its tick had cost more than the rest of the
  // set-up's gather.
  constexpr int kSize = SpringBatch::kSize;
  const int n = static_cast<int>(springs_.size());
  const unsigned char* held = held_.data();
  auto packs = [&](const Spring& sp) { return !(held[sp.a] && held[sp.b]); };
  auto put = [&](int slot, const Spring& sp) {
    ends_[slot] = {sp.a, sp.b};
    SpringConsts& c = consts_[slot / kSize];
    c.stiffness[slot % kSize] = sp.stiffness;
    c.rest[slot % kSize] = sp.rest_length;
  };
  // Part `part`'s springs from `from` on, packed from `slot` on; the lanes past its last slot in
  // that batch zero.
  auto packFrom = [&](int part, int from, int slot) {
    const int end = rangeOf(n, part).second;
    for (int i = from; i < end; ++i) {
      if (!packs(springs_[i])) {
        packed_at_[i] = -1;
        continue;
      }
      packed_at_[i] = slot;
      put(slot++, springs_[i]);
    }
    packed_end_[part] = slot;
    for (; slot % kSize != 0; ++slot) {
      consts_[slot / kSize].stiffness[slot % kSize] = 0.0;
      consts_[slot / kSize].rest[slot % kSize] = 0.0;
    }
  };
  if (numThreads() > 1 && (repack_from_ < std::numeric_limits<int>::max() || !respring_.empty()))
    repack_all_ = true;
  if (repack_all_) {
    parallel([&](int part) { packFrom(part, rangeOf(n, part).first, packedBegin(part)); });
  } else {
    int from = std::min(repack_from_, n);
    for (int i : respring_) {
      if (i >= from) continue;  // packed again below
      const int slot = packed_at_[i];
      if ((slot >= 0) != packs(springs_[i])) {
        from = i;
      } else if (slot >= 0) {
        put(slot, springs_[i]);
      }
    }
    if (from < n || repack_from_ < std::numeric_limits<int>::max()) {
      int slot = 0;  // after the last packed spring before `from` (one part: its slots start at 0)
      for (int i = from - 1; i >= 0; --i)
        if (packed_at_[i] >= 0) {
          slot = packed_at_[i] + 1;
          break;
        }
      packFrom(0, from, slot);
    }
  }
  repack_all_ = false;
  repack_from_ = std::numeric_limits<int>::max();
  respring_.clear();
}

// Compiled as springTerms() is (each copy calls springTerms()' copy of its own kind): the
// scatter adds each spring's terms to a vertex's padded rows as whole vectors, each lane doing
// the scalar code's operations in its order.
__attribute__((target_clones("avx512f", "avx2", "default"))) void MassSpring::assembleSprings(
    int part, double dt) {
  // A part's springs: their forces, their stiffness blocks (kept scaled by h^2 for the CG
  // products), and their terms of the right-hand side, of the diagonal blocks and of A dv for
  // the warm start dv (so that CG's first residual needs no pass of its own), summed into the
  // part's own buffers (zero on entry: the set-up's vertex loop zeroes each row it has read).
  // A spring both of whose ends are held (fixed, as a tray holds the bottom of an organ) adds
  // only to rows that are zero: updatePacking() leaves it out of ends_, so it is left out here and
  // from every CG product. The part's other springs are packed, in order, into ends_ (and their
  // blocks into blocks_) from the part's first slot (packedBegin()): no free vertex's sums see
  // another term. (Where removals
  // left a vertex's springs in two runs with only such springs between, the two runs are now one:
  // the same terms, added in another grouping. Keeping the old grouping with a flag a spring cost
  // 6% of a step.)
  const double h2 = dt * dt, inv_dt = 1.0 / dt;
  const Vec3* x = mesh_->currentPositions().data();
  const Vec3* u = mesh_->velocities().data();
  const Vec3* w = dv_.data();
  V4* acc = reinterpret_cast<V4*>(acc_[part].data());
  V4* start = reinterpret_cast<V4*>(start_acc_[part].data());
  PaddedBlock* diag = diag_acc_[part].data();  // (xx, xy, xz, yy) and (yz, zz) as vectors
  // As in springProducts(): the first end's sums stay in registers along a run of its springs.
  int run = -1;
  V4 run_b = {0, 0, 0, 0}, run_w = {0, 0, 0, 0}, run_k = {0, 0, 0, 0};
  V2 run_k2 = {0, 0};
  auto flush = [&] {
    if (run < 0) return;
    acc[run] += run_b;
    start[run] += run_w;
    *reinterpret_cast<V4*>(&diag[run]) += run_k;
    *reinterpret_cast<V2*>(&diag[run].k.yz) += run_k2;
  };
  // A batch at a time in three loops: the springs' ends gathered into arrays of one coordinate
  // each, the arithmetic over those arrays (no loads from the mesh, no stores into it: it runs
  // on the vector unit, square roots and divisions included), then the sums scattered.
  SpringBatch s;
  const std::array<int, 2>* ends = ends_.data();
  // The springs as updatePacking() packed them, a batch at a time.
  const int packed_end = packed_end_[part];
  for (int batch = packedBegin(part); batch < packed_end; batch += SpringBatch::kSize) {
    const SpringConsts& c = consts_[batch / SpringBatch::kSize];
    const int count = std::min(SpringBatch::kSize, packed_end - batch);
    for (int j = 0; j < count; ++j) {
      const int a = ends[batch + j][0], b = ends[batch + j][1];
      const Vec3 d = x[b] - x[a];
      const Vec3 dvel = u[b] - u[a];
      const Vec3 dw = w[a] - w[b];
      s.dx[j] = d.x(), s.dy[j] = d.y(), s.dz[j] = d.z();
      s.ux[j] = dvel.x(), s.uy[j] = dvel.y(), s.uz[j] = dvel.z();
      s.wx[j] = dw.x(), s.wy[j] = dw.y(), s.wz[j] = dw.z();
    }
    for (int j = count; j < SpringBatch::kSize; ++j) {  // a full batch: a fixed count vectorizes
      s.dx[j] = s.dy[j] = s.dz[j] = 0.0;
      s.ux[j] = s.uy[j] = s.uz[j] = s.wx[j] = s.wy[j] = s.wz[j] = 0.0;
    }
    BlockBatch& kb = blocks_[batch / SpringBatch::kSize];  // batch is a batch's first slot
    springTerms(&s, &c, &kb, h2, inv_dt);
    for (int j = 0; j < count; ++j) {
      const int i = batch + j;
      const int a = ends[i][0], b = ends[i][1];
      if (a != run) {
        flush();
        run = a;
        run_b = run_w = run_k = V4{0, 0, 0, 0};
        run_k2 = V2{0, 0};
      }
      V4 fb, kw, k;
      join3(s.fx[j], s.fy[j], s.fz[j], &fb);
      run_b += fb;
      acc[b] -= fb;
      join3(s.wx[j], s.wy[j], s.wz[j], &kw);  // as springProducts() adds for dv
      run_w += kw;
      start[b] -= kw;
      const V2 k01 = {kb.xx[j], kb.xy[j]}, k23 = {kb.xz[j], kb.yy[j]};
      const V2 k45 = {kb.yz[j], kb.zz[j]};
      k = __builtin_shufflevector(k01, k23, 0, 1, 2, 3);
      run_k += k;
      run_k2 += k45;
      *reinterpret_cast<V4*>(&diag[b]) += k;
      *reinterpret_cast<V2*>(&diag[b].k.yz) += k45;
    }
  }
  flush();
}

// Compiled three times, the widest copy the CPU has chosen when the library is loaded: AVX-512
// (eight springs an instruction; on the 20k organ's machine 4.1 -> 2.2 ns a spring, where the
// multiplications had kept both vector multipliers busy), AVX2 (four) or SSE2 (two). None uses
// fused multiply-adds (-ffp-contract=off for this file: AVX-512 has them): the same bits each way.
__attribute__((target_clones("avx512f", "avx2", "default"))) void MassSpring::springTerms(
    SpringBatch* __restrict s, const SpringConsts* __restrict c, BlockBatch* __restrict k,
    double h2, double inv_dt) {
  // Per spring of the batch, from its end-to-end vector d = x_b - x_a, velocity difference
  // u_b - u_a and warm-start difference w_a - w_b: its stiffness block K (into *k, the batch's
  // place in blocks_), f + K (u_b - u_a) / h (into f*) and K (w_a - w_b) (over w*). The force on a
  // is f = k (|d| - L) d / |d|, and to first order +K (x_b - x_a) with K = k (n n^T + max(0, 1 -
  // L/|d|) (I - n n^T)): the transverse part clamped at 0 keeps the block positive semi-definite
  // (Choi and Ko 2002), so that A stays symmetric positive definite. A spring of length 0 has f = 0
  // and K = k I.
  for (int j = 0; j < SpringBatch::kSize; ++j) {
    const double dx = s->dx[j], dy = s->dy[j], dz = s->dz[j];
    const double len = std::sqrt(dx * dx + dy * dy + dz * dz);
    // Arithmetic, not branches, so that the loop vectorizes: 1 / |d|, or 0 where |d| = 0.
    const double some = len > 0 ? 1.0 : 0.0;
    const double inv = some / (len + (1.0 - some));
    const double stiffness = c->stiffness[j];
    const double f = stiffness * (len - c->rest[j]) * inv;
    const double nx = dx * inv, ny = dy * inv, nz = dz * inv;
    const double transverse = std::max(0.0, 1.0 - c->rest[j] * inv);
    const double kt = h2 * stiffness * transverse, kn = h2 * stiffness - kt;
    const double xx = kt + kn * nx * nx, xy = kn * nx * ny, xz = kn * nx * nz;
    const double yy = kt + kn * ny * ny, yz = kn * ny * nz, zz = kt + kn * nz * nz;
    k->xx[j] = xx, k->xy[j] = xy, k->xz[j] = xz, k->yy[j] = yy, k->yz[j] = yz, k->zz[j] = zz;
    const double ux = s->ux[j], uy = s->uy[j], uz = s->uz[j];
    s->fx[j] = f * dx + inv_dt * (xx * ux + xy * uy + xz * uz);
    s->fy[j] = f * dy + inv_dt * (xy * ux + yy * uy + yz * uz);
    s->fz[j] = f * dz + inv_dt * (xz * ux + yz * uy + zz * uz);
    const double wx = s->wx[j], wy = s->wy[j], wz = s->wz[j];
    s->wx[j] = xx * wx + xy * wy + xz * wz;
    s->wy[j] = xy * wx + yy * wy + yz * wz;
    s->wz[j] = xz * wx + yz * wy + zz * wz;
  }
}

std::vector<std::vector<int>> MassSpring::clusters() const {
  std::vector<std::vector<int>> out;
  for (const Cluster& c : clusters_) {
    out.emplace_back(c.vertices.begin(), c.vertices.begin() + c.size);
    std::sort(out.back().begin(), out.back().end());
  }
  std::sort(out.begin(), out.end());
  return out;
}

double MassSpring::strongThreshold(double dt) const {
  if (!params_.cluster_preconditioner) return HUGE_VAL;  // no spring is strong enough
  const double loaded = dt * dt * loaded_coupling_ * params_.young_modulus / params_.density;
  return std::max(kStrongCoupling, loaded);
}

double MassSpring::strongRatio(int spring, double dt) const {
  const Spring& s = springs_[spring];
  const int a = s.a, b = s.b;
  if (!mesh_->vertexAlive(a) || !mesh_->vertexAlive(b) || fixed_[a] || fixed_[b]) return 0.0;
  const double lighter = std::min(mass_[a], mass_[b]);
  if (!(lighter > 0)) return 0.0;
  const double ratio = dt * dt * s.stiffness / lighter;
  return ratio >= strongThreshold(dt) ? ratio : 0.0;
}

void MassSpring::rescanStrong(double dt) {
  strong_dt_ = dt;
  strong_.clear();
  for (int i = 0; i < static_cast<int>(springs_.size()); ++i) {
    const double ratio = strongRatio(i, dt);
    if (ratio > 0) strong_.push_back({{springs_[i].a, springs_[i].b}, ratio});
  }
  std::sort(strong_.begin(), strong_.end());
  clusters_stale_ = true;
}

template <typename F>
void MassSpring::forEachSpring(int v, F&& f) const {
  if (v < static_cast<int>(springs_from_.size()))
    for (const SpringRef& r : springs_from_[v]) f(r.other, r.index);
  if (v < static_cast<int>(springs_to_.size()))
    for (const SpringRef& r : springs_to_[v]) f(r.other, r.index);
}

void MassSpring::updateStrong(const std::vector<int>& vertices) {
  // A spring's strength changes with its stiffness and its ends' masses: those of the changed
  // tets' edges and vertices, so every spring that can change has an end among `vertices`
  // (sorted). Those are taken out and tested again; the rest stand.
  nextStamp(&changed_seen_, &changed_stamp_, mesh_->vertexSlots());
  for (int v : vertices) changed_seen_[v] = changed_stamp_;
  auto changed = [&](int v) { return changed_seen_[v] == changed_stamp_; };
  strong_.erase(std::remove_if(strong_.begin(), strong_.end(),
                               [&](const StrongSpring& e) {
                                 return changed(e.ends[0]) || changed(e.ends[1]);
                               }),
                strong_.end());
  // The rest stays sorted: the springs found again are sorted apart and merged in (these calls
  // come on the ticks that cut or collapse, the slowest; sorting the whole list and testing each
  // neighbour once per tet around it had made this 64% of follow()'s instructions).
  const auto kept = static_cast<std::ptrdiff_t>(strong_.size());
  // Each spring at a changed vertex once: from its lower end's list where that end changed, else
  // from the higher end's (walking each changed vertex's neighbours and looking each one's spring
  // up had been half of this).
  auto test = [&](int spring) {
    const double ratio = strongRatio(spring, strong_dt_);
    if (ratio > 0) strong_.push_back({{springs_[spring].a, springs_[spring].b}, ratio});
  };
  for (int v : vertices) {
    if (!mesh_->vertexAlive(v) || fixed_[v]) continue;  // none of its springs is strong
    if (v < static_cast<int>(springs_from_.size()))
      for (const SpringRef& r : springs_from_[v]) test(r.index);
    if (v < static_cast<int>(springs_to_.size()))
      for (const SpringRef& r : springs_to_[v])
        if (!changed(r.other)) test(r.index);  // else taken from that end's list
  }
  std::sort(strong_.begin() + kept, strong_.end());
  // Merged into a kept list, as std::inplace_merge would (stable: the same order), without the
  // buffer it takes from the heap on every call; the two lists swap their room.
  std::vector<StrongSpring>& merged = strong_merged_;
  merged.clear();
  std::merge(strong_.begin(), strong_.begin() + kept, strong_.begin() + kept, strong_.end(),
             std::back_inserter(merged));
  strong_.swap(merged);
  clusters_stale_ = true;
}

void MassSpring::buildClusters() {
  // Strong springs, strongest first, join their ends' clusters while the union stays within
  // kMaxCluster vertices (greedy: the strongest ties are the ones a 3x3 block misses most).
  // strong_ is kept in that order (updateStrong() merges the springs it finds again): sorting a
  // copy of it here had been 80% of the instructions of this rebuild, which every cut or collapse
  // tick makes.
  clusters_stale_ = false;
  for (const Cluster& c : clusters_)
    for (int k = 0; k < c.size; ++k) cluster_of_[c.vertices[k]] = -1;
  resizeSlots(&cluster_of_, mesh_->vertexSlots(), -1);
  resizeSlots(&cluster_diag_, mesh_->vertexSlots());
  std::vector<ClusterSet>& sets = cluster_sets_;
  sets.clear();
  auto add = [&](int c, int v) {
    sets[c].vertices[sets[c].size++] = v;
    cluster_of_[v] = c;
  };
  for (const StrongSpring& e : strong_) {
    const int a = e.ends[0], b = e.ends[1];
    int ca = cluster_of_[a];
    const int cb = cluster_of_[b];
    if (ca >= 0 && ca == cb) continue;
    const int together = (ca >= 0 ? sets[ca].size : 1) + (cb >= 0 ? sets[cb].size : 1);
    if (together > kMaxCluster) continue;
    if (ca < 0) {
      ca = static_cast<int>(sets.size());
      sets.emplace_back();
      add(ca, a);
    }
    if (cb < 0) {
      add(ca, b);
    } else {
      ClusterSet& from = sets[cb];
      for (int k = 0; k < from.size; ++k) add(ca, from.vertices[k]);
      from.size = 0;  // dropped below
    }
  }
  // The non-empty ones in order, renumbered, each with its inner springs.
  int kept = 0;
  for (const ClusterSet& set : sets) kept += set.size > 0 ? 1 : 0;
  clusters_.resize(kept);
  kept = 0;
  for (const ClusterSet& set : sets) {
    if (set.size == 0) continue;
    Cluster& cl = clusters_[kept];
    cl.size = set.size;
    cl.vertices = set.vertices;
    cl.num_springs = 0;
    for (int i = 0; i < cl.size; ++i) {
      cluster_of_[cl.vertices[i]] = kept;
      for (int j = i + 1; j < cl.size; ++j) {
        const int s = findSpring(cl.vertices[i], cl.vertices[j]);
        if (s >= 0) cl.springs[cl.num_springs++] = {s, i, j};
      }
    }
    ++kept;
  }
}

void MassSpring::factorClusters() {
  static_assert(kMaxCluster == 4, "the inversions below take 2 to 4 vertices");
  // The clusters are independent: split over the parts (their inverses do not depend on it).
  parallel([&](int part) {
    const auto [begin, end] = rangeOf(static_cast<int>(clusters_.size()), part);
    for (int k = begin; k < end; ++k) fillCluster(&clusters_[k]);
    // Inverted once a step: CG applies it 4-10 times, as a plain product (Eigen's Cholesky
    // solve, its size known only at run time, took 0.2 us a cluster). kInverseLanes clusters of
    // a size at a time: one alone was a chain of square roots and divisions (about 40 us a step
    // for the 20k organ's 66 clusters; 28 -> 14 us side by side).
    constexpr int kLanes = kInverseLanes;
    double lanes[9 * kMaxCluster * kMaxCluster * kLanes];
    unsigned char ok[kLanes];
    int group[kLanes];
    for (int size = 2; size <= kMaxCluster; ++size) {
      const int m = 3 * size, mm = m * m;
      int count = 0;
      auto invert = [&] {
        for (int x = 0; x < kLanes; ++x) {
          if (x < count) {
            const double* a = clusters_[group[x]].inverse.data();
            for (int e = 0; e < mm; ++e) lanes[e * kLanes + x] = a[e];
          } else {  // an empty lane: the identity
            for (int e = 0; e < mm; ++e) lanes[e * kLanes + x] = e % (m + 1) == 0 ? 1.0 : 0.0;
          }
        }
        invertSymmetricLanes(m, lanes, ok);
        for (int x = 0; x < count; ++x) {
          Cluster& c = clusters_[group[x]];
          c.usable = ok[x] != 0;
          if (!c.usable) continue;  // its block left as it was
          for (int e = 0; e < mm; ++e) c.inverse[e] = lanes[e * kLanes + x];
        }
        count = 0;
      };
      for (int k = begin; k < end; ++k) {
        if (clusters_[k].size != size) continue;
        group[count++] = k;
        if (count == kLanes) invert();
      }
      if (count > 0) invert();
    }
  });
}

void MassSpring::fillCluster(Cluster* cluster) {
  Cluster& c = *cluster;
  const int m = 3 * c.size;
  double* a = c.inverse.data();  // the block first, then inverted in place (factorClusters())
  std::fill(a, a + m * m, 0.0);
  auto put = [&](int i, int j, const Block& k, double sign) {
    const double e[3][3] = {{k.xx, k.xy, k.xz}, {k.xy, k.yy, k.yz}, {k.xz, k.yz, k.zz}};
    for (int r = 0; r < 3; ++r)
      for (int q = 0; q < 3; ++q) a[(3 * i + r) * m + 3 * j + q] = sign * e[r][q];
  };
  for (int i = 0; i < c.size; ++i) put(i, i, cluster_diag_[c.vertices[i]], 1.0);
  for (int s = 0; s < c.num_springs; ++s) {
    const auto& [spring, i, j] = c.springs[s];
    // A cluster's vertices are free: its springs are packed (see assembleSprings()).
    const Block k = blockAt(packed_at_[spring]);
    put(i, j, k, -1.0);  // A p at a has -h^2 K p_b
    put(j, i, k, -1.0);
  }
}

double MassSpring::applyClusters(const Padded3* r, Padded3* z, Padded3* p) {
  double change = 0.0;
  for (const Cluster& c : clusters_) {
    if (!c.usable) continue;  // its vertices keep their own blocks
    const int m = 3 * c.size;
    double rhs[3 * kMaxCluster], x[3 * kMaxCluster];
    for (int i = 0; i < c.size; ++i)
      for (int k = 0; k < 3; ++k) rhs[3 * i + k] = r[c.vertices[i]].v[k];
    const double* inverse = c.inverse.data();
    if (m == 6) {
      multiply<6>(inverse, rhs, x);
    } else if (m == 9) {
      multiply<9>(inverse, rhs, x);
    } else {
      multiply<12>(inverse, rhs, x);
    }
    for (int i = 0; i < c.size; ++i) {
      const int v = c.vertices[i];
      const Vec3 zv(x[3 * i], x[3 * i + 1], x[3 * i + 2]);
      change += r[v].v.dot(zv - z[v].v);
      z[v].v = zv;
      if (p) p[v].v = zv;
    }
  }
  return change;
}

// The local pre-solve's PCG, compiled twice as CG's vertex loops are (its vectors in padded rows,
// each lane doing the scalar code's operations in its order).
__attribute__((target_clones("avx2", "default"))) void MassSpring::localIterations(
    int m, int total, double tolerance2, double rr) {
  // PCG on the first m of local_vertices_ (the rest, their neighbours, held fixed: their residuals
  // follow each step, A dx there); local_r_ and the rest zero on entry.
  const double md = mass_damping_;
  const int* vertices = local_vertices_.data();
  const Block* inv_diag = inv_diag_.data();
  const double* inertia = inertia_.data();
  const unsigned char* held = held_.data();
  V4* r_all = reinterpret_cast<V4*>(r_.data());
  V4* lr = reinterpret_cast<V4*>(local_r_.data());
  V4* lz = reinterpret_cast<V4*>(local_z_.data());
  V4* lp = reinterpret_cast<V4*>(local_p_.data());
  V4* lq = reinterpret_cast<V4*>(local_q_.data());
  V4* lx = reinterpret_cast<V4*>(local_x_.data());
  double rz = 0.0, rr_local = 0.0;
  for (int i = 0; i < m; ++i) {
    const int v = vertices[i];
    lr[i] = r_all[v];
    applyBlock(inv_diag[v], lr[i], &lz[i]);
    lp[i] = lz[i];
    rz += sum3(lr[i] * lz[i]);
    rr_local += sum3(lr[i] * lr[i]);
  }
  const double goal = kLocalGoal * std::max(rr - rr_local, tolerance2);
  int it = 0;
  for (; it < kLocalIterations && rr_local > goal && rz > 0; ++it) {
    for (int i = 0; i < m; ++i) lq[i] = (md * inertia[vertices[i]]) * lp[i];
    for (int i = m; i < total; ++i) lq[i] = V4{0, 0, 0, 0};
    for (const LocalSpring& s : local_springs_) {
      const V4 d = s.b < m ? lp[s.a] - lp[s.b] : lp[s.a];
      V4 r;
      applyBlock(blockAt(s.block), d, &r);
      lq[s.a] += r;
      lq[s.b] -= r;
    }
    double pq = 0.0;
    for (int i = 0; i < m; ++i) pq += sum3(lp[i] * lq[i]);
    if (!(pq > 0)) break;
    const double alpha = rz / pq;
    double rz_next = 0.0;
    rr_local = 0.0;
    for (int i = 0; i < m; ++i) {
      lx[i] += alpha * lp[i];
      lr[i] -= alpha * lq[i];
      applyBlock(inv_diag[vertices[i]], lr[i], &lz[i]);
      rz_next += sum3(lr[i] * lz[i]);
      rr_local += sum3(lr[i] * lr[i]);
    }
    for (int i = m; i < total; ++i) {
      const int v = vertices[i];
      if (!held[v]) r_all[v] -= alpha * lq[i];  // held rows stay zero
    }
    const double beta = rz_next / rz;
    rz = rz_next;
    for (int i = 0; i < m; ++i) lp[i] = lz[i] + beta * lp[i];
  }
}

void MassSpring::presolveLocally(double tolerance2, double* rz_total, double* rr_total) {
  const double rr = *rr_total;
  if (!params_.local_presolve || !(rr > kLocalTrigger * tolerance2)) return;
  const int n = mesh_->vertexSlots();
  // The vertices that hold the residual: each at least kLocalPick of it, the kMaxLocal largest.
  auto& pick = local_pick_;
  pick.clear();
  const double least = kLocalPick * rr;
  for (int v = 0; v < n; ++v) {
    const double e = r_[v].v.squaredNorm();
    if (e >= least) pick.push_back({e, v});
  }
  // More vertices than that each hold kLocalPick of it: the residual is spread out (the organ
  // settling under its weight, not a cut's few vertices), CG's own work. The largest kMaxLocal
  // of such a residual held 50-91% of it on the 20k organ, and their local solve took the
  // residual down 1.9-8.5x (median 2.8x, less than a CG iteration does) for ~100 us a step on
  // the calling thread alone (15% of a two-thread step; the vertices of a cut's step: 4.8-1,600x).
  if (static_cast<int>(pick.size()) > kMaxLocal) return;
  double picked = 0.0;
  for (const auto& e : pick) picked += e.first;
  if (pick.empty() || picked < kLocalShare * rr) return;  // spread out: CG's own work
  std::sort(pick.begin(), pick.end(),
            [](const auto& x, const auto& y) { return x.second < y.second; });
  // Their springs, each once, and their neighbours.
  nextStamp(&local_seen_, &local_stamp_, n);
  growSlots(&local_index_, local_seen_.size());
  local_vertices_.clear();
  auto place = [&](int v) {
    local_seen_[v] = local_stamp_;
    local_index_[v] = static_cast<int>(local_vertices_.size());
    local_vertices_.push_back(v);
  };
  for (const auto& e : pick) place(e.second);
  // Solved for alone, they leave most of what remains of the residual on their neighbours (in
  // the 20k organ's replay: 45 times the tolerance after the local solve at the median, against
  // 12 with the neighbours; 108 steps of 5 CG iterations or more against 33). The neighbours of
  // the vertices holding the most come first, up to kMaxLocalRows rows and a kLocalRowsPer-th of
  // the mesh's vertices: on the 5k organ 128 rows cost more than the iterations they saved.
  const int max_rows = std::min(kMaxLocalRows, mesh_->numVertices() / kLocalRowsPer);
  if (params_.local_presolve_neighbours) {
    std::sort(pick.begin(), pick.end(), [](const auto& x, const auto& y) {
      return x.first > y.first || (x.first == y.first && x.second < y.second);
    });
    for (const auto& e : pick) {
      if (static_cast<int>(local_vertices_.size()) >= max_rows) break;
      forEachSpring(e.second, [&](int u, int) {
        if (local_seen_[u] == local_stamp_ || held_[u] ||
            static_cast<int>(local_vertices_.size()) >= max_rows)
          return;
        place(u);
      });
    }
  }
  const int m = static_cast<int>(local_vertices_.size());  // the rows solved for
  local_springs_.clear();
  for (int i = 0; i < m; ++i) {
    const int v = local_vertices_[i];
    forEachSpring(v, [&](int u, int k) {
      const bool known = local_seen_[u] == local_stamp_;
      if (known && local_index_[u] < m && u < v) return;  // listed from u
      if (packed_at_[k] < 0) return;
      if (!known) place(u);
      local_springs_.push_back({i, local_index_[u], packed_at_[k]});
    });
  }
  const int total = static_cast<int>(local_vertices_.size());
  // Their terms of r.z and r.r before (z = P r, as the set-up left it).
  double rz_before = 0.0, rr_before = 0.0;
  for (int v : local_vertices_) {
    rz_before += r_[v].v.dot(z_[v].v);
    rr_before += r_[v].v.squaredNorm();
  }
  for (auto* x : {&local_r_, &local_z_, &local_p_, &local_q_, &local_x_}) x->assign(total, {});
  localIterations(m, total, tolerance2, rr);
  for (int i = 0; i < m; ++i) {
    const int v = local_vertices_[i];
    dv_[v] += local_x_[i].v;
    r_[v].v = local_r_[i].v;
  }
  // CG's start there again: z = P r, p = z; the sums changed by the difference.
  double rz_after = 0.0, rr_after = 0.0;
  for (int v : local_vertices_) {
    z_[v].v = apply(inv_diag_[v], r_[v].v);
    p_[v].v = z_[v].v;
    rz_after += r_[v].v.dot(z_[v].v);
    rr_after += r_[v].v.squaredNorm();
  }
  *rz_total = std::max(0.0, *rz_total + (rz_after - rz_before));
  *rr_total = std::max(0.0, *rr_total + (rr_after - rr_before));
  ++local_presolves_;
}

void MassSpring::prepare(double dt) {
  resize();
  sizeStepBuffers();
  // What the first step would make for itself and later steps keep until a change (the inertia,
  // the held rows and the springs' packing), made now: the first tick after a load or a reset
  // does not pay for it.
  if (!inertia_valid_) updateInertia();
  if (!params_.implicit || !(dt > 0)) return;
  refreshClusters(dt);
  const int n = mesh_->vertexSlots();
  const unsigned char* alive = mesh_->vertexAliveFlags().data();
  for (int v = 0; v < n; ++v) held_[v] = fixed_[v] || !alive[v];  // as the warm start marks them
  updatePacking();
}

void MassSpring::refreshClusters(double dt) {
  if (dt != strong_dt_) rescanStrong(dt);
  if (clusters_stale_ || static_cast<int>(cluster_of_.size()) != mesh_->vertexSlots())
    buildClusters();
}

void MassSpring::sizeStepBuffers() {
  // Sized with slots to spare (see slotCapacity()): cuts add vertices and springs.
  const int n = mesh_->vertexSlots();
  const int parts = numThreads();
  resizeSlots(&x0_, n, Vec3::Zero());
  resizeSlots(&inertia_, n, 0.0);
  partial_.resize(parts);
  if (!params_.implicit) return;
  for (auto* v : {&b_, &dv_}) resizeSlots(v, n, Vec3::Zero());
  for (auto* v : {&r_, &z_, &p_, &ap_}) resizeSlots(v, n, Padded3{});
  resizeSlots(&inv_diag_, n);
  resizeSlots(&held_, n);
  // Each part's slots start at a batch's first, after the part before's last (see packedBegin()).
  const int slots = packedBegin(parts - 1) + static_cast<int>(springs_.size()) -
                    rangeOf(static_cast<int>(springs_.size()), parts - 1).first;
  resizeSlots(&blocks_, slots / SpringBatch::kSize + 1);
  resizeSlots(&consts_, slots / SpringBatch::kSize + 1);
  resizeSlots(&ends_, slots);
  resizeSlots(&packed_at_, springs_.size());
  packed_end_.resize(parts);
  acc_.resize(parts);
  start_acc_.resize(parts);
  diag_acc_.resize(parts);
  for (auto& e : acc_) resizeSlots(&e, n, Padded3{});
  product_acc_.resize(parts);
  for (auto& e : product_acc_) resizeSlots(&e, n, Padded3{});
  for (auto& e : start_acc_) resizeSlots(&e, n, Padded3{});
  for (auto& e : diag_acc_) resizeSlots(&e, n, PaddedBlock{});
}

// CG's vertex loops, compiled twice as springProducts() (padded rows, a vertex's vector one
// load or store). Each lane does the scalar code's operations in its order, and a dot product
// adds its lanes as Eigen's does for a 3-vector, (x + y) + z: the same bits.
namespace {
// A 3-vector's row as a vector, the fourth lane zero: its first two doubles in one load (through
// a pointer, as applyBlock() returns: see there).
inline void load3(const Vec3& x, V4* out) {
  const V2 lo = *reinterpret_cast<const V2*>(x.data());
  const V2 hi = {x.z(), 0.0};
  *out = __builtin_shufflevector(lo, hi, 0, 1, 2, 3);
}
}  // namespace

__attribute__((target_clones("avx2", "default"))) double MassSpring::massProducts(int part) {
  // A p = (1 + h alpha) M p + h^2 sum_springs K (p_a - p_b), the springs' terms summed part by
  // part (each part's buffer zeroed as it is read). Held rows (fixed vertices) are zero; dead
  // vertices have no mass and no springs. Returns this part's share of p.Ap.
  const auto [begin, end] = rangeOf(mesh_->vertexSlots(), part);
  const int parts = numThreads();
  const V4* p = reinterpret_cast<const V4*>(p_.data());
  V4* ap = reinterpret_cast<V4*>(ap_.data());
  V4* acc0 = reinterpret_cast<V4*>(product_acc_[0].data());
  const double* inertia = inertia_.data();
  const unsigned char* held = held_.data();
  const double mass_damping = mass_damping_;
  double pap = 0.0;
  for (int v = begin; v < end; ++v) {
    V4 sum = (mass_damping * inertia[v]) * p[v];
    sum += acc0[v];  // the first part's sums through a pointer of their own
    acc0[v] = V4{0, 0, 0, 0};
    for (int q = 1; q < parts; ++q) {
      V4* acc = reinterpret_cast<V4*>(product_acc_[q].data());
      sum += acc[v];
      acc[v] = V4{0, 0, 0, 0};
    }
    const V4 apv = held[v] ? V4{0, 0, 0, 0} : sum;
    ap[v] = apv;
    pap += sum3(p[v] * apv);
  }
  return pap;
}

__attribute__((target_clones("avx2", "default"))) void MassSpring::updateResidual(int part,
                                                                                  double alpha) {
  // dv += alpha p, r -= alpha A p, z = P r (block-Jacobi; the clusters after), and this part's
  // shares of r.z and r.r into partial_[part].
  const auto [begin, end] = rangeOf(mesh_->vertexSlots(), part);
  Vec3* dv = dv_.data();
  V4* r = reinterpret_cast<V4*>(r_.data());
  V4* z = reinterpret_cast<V4*>(z_.data());
  const Padded3* p = p_.data();
  const V4* ap = reinterpret_cast<const V4*>(ap_.data());
  const Block* inv_diag = inv_diag_.data();
  double rz_next = 0.0, rr_next = 0.0;
  for (int v = begin; v < end; ++v) {
    dv[v] += alpha * p[v].v;
    const V4 rv = r[v] - alpha * ap[v];
    V4 zv;
    applyBlock(inv_diag[v], rv, &zv);
    r[v] = rv;
    z[v] = zv;
    rz_next += sum3(rv * zv);
    rr_next += sum3(rv * rv);
  }
  partial_[part].sum[0] = rz_next;
  partial_[part].sum[1] = rr_next;
}

__attribute__((target_clones("avx2", "default"))) void MassSpring::updateDirection(int part,
                                                                                   double beta) {
  const auto [begin, end] = rangeOf(mesh_->vertexSlots(), part);
  V4* p = reinterpret_cast<V4*>(p_.data());
  const V4* z = reinterpret_cast<const V4*>(z_.data());
  for (int v = begin; v < end; ++v) p[v] = z[v] + beta * p[v];
}

// The set-up's vertex loop, compiled twice as CG's vertex loops are: each vertex's b, A dv, r, z
// and p one register each (its diagonal block stays scalar), each lane doing the scalar code's
// operations in its order (a 3-vector's row read in two halves: built in a stack slot, each row
// had waited for the store before it). BM_PhysicsStep/20000/1: 578 -> 554 us (22 interleaved
// pairs, faster in all).
__attribute__((target_clones("avx2", "default"))) void MassSpring::setupVertices(int part,
                                                                                 double dt) {
  // Each vertex's own terms (inertia, gravity, damping) and its springs' terms summed part by
  // part (each part's buffers zeroed as they are read): b, the vertex's block of A (kept whole
  // for its cluster, inverted for block-Jacobi) and CG's start r = b - A dv, z = P r, p = z.
  // This part's sums of the weight's impulse squared, |b|^2, r.z and r.r go to partial_[part].
  const auto [begin, end] = rangeOf(mesh_->vertexSlots(), part);
  const int parts = numThreads();
  const V4 gravity{params_.gravity.x(), params_.gravity.y(), params_.gravity.z(), 0.0};
  const double damping = params_.damping, mass_damping = mass_damping_;
  const Vec3* velocity = mesh_->velocities().data();
  const double* mass = mass_.data();
  const double* inertia = inertia_.data();
  const unsigned char* held = held_.data();
  const int* cluster_of = cluster_of_.data();
  Block* cluster_diag = cluster_diag_.data();
  const unsigned char* alive_at = mesh_->vertexAliveFlags().data();
  const Vec3* dv = dv_.data();
  Vec3* b_out = b_.data();
  Block* inv_diag = inv_diag_.data();
  V4* r = reinterpret_cast<V4*>(r_.data());
  V4* z = reinterpret_cast<V4*>(z_.data());
  V4* p = reinterpret_cast<V4*>(p_.data());
  // The first part's sums through pointers of their own (the others' are added after, in the
  // same order): through acc_[q] each row reloaded the buffers' addresses after every store.
  V4* acc0 = reinterpret_cast<V4*>(acc_[0].data());
  V4* start0 = reinterpret_cast<V4*>(start_acc_[0].data());
  PaddedBlock* diag0 = diag_acc_[0].data();
  // The sums of the weight's impulse squared, |b|^2, r.z and r.r, one in each lane (each lane
  // adds as a scalar sum would; a held row adds zero to the first).
  V4 sums{0, 0, 0, 0};
  for (int v = begin; v < end; ++v) {
    const bool alive = alive_at[v] != 0;
    V4 b{0, 0, 0, 0}, a, row;
    if (alive) {
      load3(velocity[v], &row);
      b = mass[v] * (gravity - damping * row);
    }
    const double md = mass_damping * inertia[v];
    Block diag{md, 0.0, 0.0, md, 0.0, md};
    load3(dv[v], &row);
    a = md * row;
    b += acc0[v];
    a += start0[v];
    addTo(&diag, diag0[v].k);
    acc0[v] = start0[v] = V4{0, 0, 0, 0};
    diag0[v].k = {0, 0, 0, 0, 0, 0};
    for (int q = 1; q < parts; ++q) {
      V4* acc = reinterpret_cast<V4*>(acc_[q].data());
      V4* start = reinterpret_cast<V4*>(start_acc_[q].data());
      b += acc[v];
      a += start[v];
      addTo(&diag, diag_acc_[q][v].k);
      acc[v] = start[v] = V4{0, 0, 0, 0};
      diag_acc_[q][v].k = {0, 0, 0, 0, 0, 0};
    }
    const bool held_v = held[v] != 0;
    const V4 bv = held_v ? V4{0, 0, 0, 0} : dt * b;
    if (cluster_of[v] >= 0) cluster_diag[v] = diag;  // see factorClusters()
    // Block-Jacobi: the vertex's own 3x3 block of A, inverted; zero where the row is held.
    if (held_v || !invert(&diag)) diag = {0, 0, 0, 0, 0, 0};
    const V4 rv = held_v ? V4{0, 0, 0, 0} : bv - a;
    V4 zv;
    applyBlock(diag, rv, &zv);
    b_out[v] = Vec3(bv[0], bv[1], bv[2]);
    inv_diag[v] = diag;
    r[v] = rv;
    z[v] = zv;
    p[v] = zv;
    const double weight = held_v ? 0.0 : (mass[v] * dt) * (mass[v] * dt);
    sums += V4{weight, sum3(bv * bv), sum3(rv * zv), sum3(rv * rv)};
  }
  for (int k = 0; k < 4; ++k) partial_[part].sum[k] = sums[k];
}

// The step's last pass over the vertices, compiled twice as the set-up's vertex loop is, each
// lane doing the scalar code's operations in its order.
__attribute__((target_clones("avx2", "default"))) void MassSpring::finishStep(int part, double dt,
                                                                              bool compare) {
  // The new velocities and positions; each extrapolation's miss of this step's answer (summed,
  // and which was clearly the closer at each vertex: see stepImplicit()); the fastest speed and
  // whether every position and speed is finite. The sums go to partial_[part]: the linear and
  // quadratic misses, the fastest speed, 1 where all were finite (else 0). The misses compare
  // extrapolations from three past answers only where there were three (`compare`).
  const auto [begin, end] = rangeOf(mesh_->vertexSlots(), part);
  const Vec3* warm = warm_.data();
  const Vec3* warm_prev = warm_prev_.data();
  const Vec3* warm_prev2 = warm_prev2_.data();
  unsigned char* quadratic_at = quadratic_at_.data();
  const unsigned char* alive = mesh_->vertexAliveFlags().data();
  const unsigned char* fixed = fixed_.data();
  const Vec3* dv = dv_.data();
  Vec3* velocity = mesh_->velocities().data();
  Vec3* current = mesh_->currentPositions().data();
  double linear_miss = 0.0, quadratic_miss = 0.0;
  double worst2 = 0.0, finite = 1.0;  // as scanSpeeds() finds them, in the same pass
  for (int v = begin; v < end; ++v) {
    if (!alive[v]) continue;
    if (fixed[v]) {
      velocity[v].setZero();
      if (!current[v].allFinite()) finite = 0.0;
      continue;
    }
    V4 w, wp, wpp, d, u, x;
    load3(warm[v], &w);
    load3(warm_prev[v], &wp);
    load3(warm_prev2[v], &wpp);
    load3(dv[v], &d);
    load3(velocity[v], &u);
    load3(current[v], &x);
    V4 linear, curve;
    linearGuess(w, wp, &linear);
    curvature(w, wp, wpp, &curve);
    const V4 miss = d - linear;
    const V4 off = miss - curve;
    const double qm = sum3(off * off), lm = sum3(miss * miss);
    quadratic_at[v] = !compare                    ? kLinearCloser
                      : qm * kClearlyCloser2 < lm ? kQuadraticCloser
                      : lm * kClearlyCloser2 < qm ? kLinearCloser
                                                  : kEitherCloser;
    linear_miss += lm;
    quadratic_miss += qm;
    u += d;
    x += dt * u;
    velocity[v] = Vec3(u[0], u[1], u[2]);
    current[v] = Vec3(x[0], x[1], x[2]);
    // Any infinity or NaN among them makes this NaN (x - x): one test for both vectors.
    const V4 nan_if_not_finite = (x - x) + (u - u);
    if (!(sum3(nan_if_not_finite) == 0.0)) finite = 0.0;
    worst2 = std::max(worst2, sum3(u * u));
  }
  partial_[part].sum[0] = linear_miss;
  partial_[part].sum[1] = quadratic_miss;
  partial_[part].sum[2] = std::sqrt(worst2);
  partial_[part].sum[3] = finite;
}

bool MassSpring::stepImplicit(double dt) {
  // Linearly-implicit backward Euler: (M (1 + h alpha) + h^2 K) dv = h (f0 + h K v0), solved by
  // CG preconditioned by block-Jacobi, with the clusters' whole blocks on their vertices (see
  // buildClusters()). Every loop runs in numThreads() parts: vertex loops over
  // ranges of vertices, spring loops over ranges of springs, each part summing into its own
  // buffer (the parts' buffers are added in a fixed order, so a step's result does not depend on
  // timing). The vertex loops work through local pointers and copies of the scalars: through the
  // members and the captured references the compiler reloaded them after every store.
  const int n = mesh_->vertexSlots();
  mass_damping_ = 1.0 + dt * params_.damping;

  // The warm start: the last steps' answers extrapolated (the velocity change varies smoothly
  // from step to step; 16.2 -> 13.1 CG iterations a step on the 20k organ while it is cut),
  // linearly, or quadratically where that predicted the last step better (see the end of this
  // function; 4.0 -> 3.5 iterations a step on the 20k organ with one choice for all vertices,
  // 3.20 -> 3.05 with each vertex's own); zero where the row is held (fixed or dead vertices).
  // Each extrapolation needs as many past answers: with fewer (the first steps, the step after
  // a roll-back), fewer are used. With one, that answer as it is (a linear guess from it and a
  // zero would double it: free fall under gravity changes the velocity by the same g h each
  // step). With none, each vertex's answer were its springs' stiffness left out: its force over
  // its inertia (at rest on the springs' rest lengths, g h / (1 + h alpha), the answer of every
  // vertex whose neighbours move alike). The 20k organ's first two steps took 9 CG iterations
  // each from zero and from twice the first answer.
  const int history = warm_history_;
  const bool quadratic = params_.quadratic_warm_start && history >= 3;
  const bool per_vertex = params_.per_vertex_warm_start;
  const bool quadratic_next = quadratic_next_;
  if (history == 0) forces(&b_);  // set again below, before it is read as b
  parallel([&](int part) {
    const auto [begin, end] = rangeOf(n, part);
    unsigned char* held = held_.data();
    Vec3* dv = dv_.data();
    const Vec3* warm = warm_.data();
    const Vec3* warm_prev = warm_prev_.data();
    const Vec3* warm_prev2 = warm_prev2_.data();
    const unsigned char* quadratic_at = quadratic_at_.data();
    const Vec3* force = b_.data();
    const double* inertia = inertia_.data();
    const double impulse = dt / mass_damping_;
    const unsigned char* fixed = fixed_.data();
    const unsigned char* alive = mesh_->vertexAliveFlags().data();
    for (int v = begin; v < end; ++v) {
      held[v] = fixed[v] || !alive[v];
      if (held[v]) {
        dv[v].setZero();
      } else if (history == 0) {
        dv[v] = inertia[v] > 0 ? Vec3(impulse / inertia[v] * force[v]) : Vec3::Zero();
      } else if (history == 1) {
        dv[v] = warm[v];
      } else {
        linearGuess(warm[v], warm_prev[v], &dv[v]);
        const unsigned char closer = per_vertex ? quadratic_at[v] : kEitherCloser;
        if (quadratic && (closer == kEitherCloser ? quadratic_next : closer == kQuadraticCloser)) {
          Vec3 curve;
          curvature(warm[v], warm_prev[v], warm_prev2[v], &curve);
          dv[v] += curve;
        }
      }
    }
  });
  refreshClusters(dt);
  // b = h (f0 + h K v0), with K v0 at a = K (v_b - v_a). One pass over the springs gives their
  // forces, their stiffness blocks (kept scaled by h^2 for the CG products), the diagonal blocks
  // of A for the preconditioner and the springs' part of A dv.
  updatePacking();
  parallel([&](int part) { assembleSprings(part, dt); });
  // The vertices' own terms and the parts' sums together, and CG's start: r = b - A dv, z = P r,
  // p = z.
  parallel([&](int part) { setupVertices(part, dt); });
  // Converged when the residual is cg_tolerance of the right-hand side, or of the weight's impulse
  // over the step where that is larger: near equilibrium the right-hand side is small and a
  // relative tolerance alone would chase a velocity error far below 1e-6 g dt (13.1 -> 9.5 CG
  // iterations a step on the 20k organ while it is cut; positions at the end agree to 14 nm).
  const double weight2 = partialSum(0) * params_.gravity.squaredNorm();
  const double b_norm = partialSum(1);
  double rz = partialSum(2), rr = partialSum(3);
  const double tolerance2 =
      params_.cg_tolerance * params_.cg_tolerance * std::max({b_norm, weight2, 1e-300});
  presolveLocally(tolerance2, &rz, &rr);
  // The clusters' vertices: z (and p) from their clusters' blocks instead of their own.
  factorClusters();
  rz += applyClusters(r_.data(), z_.data(), p_.data());
  int it = 0;
  for (; it < params_.cg_max_iterations; ++it) {
    if (rr <= tolerance2) break;
    parallel([&](int part) { springProducts(part, p_.data()); });
    parallel([&](int part) { partial_[part].sum[0] = massProducts(part); });
    const double pap = partialSum(0);
    if (!(pap > 0)) break;  // massProducts() has left the products' buffers zero
    const double alpha = rz / pap;
    parallel([&, alpha](int part) { updateResidual(part, alpha); });
    const double rz_next = partialSum(0) + applyClusters(r_.data(), z_.data(), nullptr);
    rr = partialSum(1);
    const double beta = rz_next / rz;
    rz = rz_next;
    parallel([&, beta](int part) { updateDirection(part, beta); });
  }
  last_iterations_ = it;
  total_iterations_ += it;
  // The new state; and how far each extrapolation was from the answer, which chooses the next
  // warm start. Quadratic extrapolation follows smooth motion closer, and overshoots more where
  // it turns (near a cut on the steps after it, a vibration of a few steps' period): mostly in
  // one place, not everywhere at once. So each vertex takes the one that was clearly the closer
  // for it (its miss at most half the other's), and where neither was, the one whose misses
  // summed over the mesh were the smaller. The deterministic replays of the bench organ (one
  // thread, collapse unbudgeted) took 1,772 -> 1,703 CG iterations at 5k tets, 3,202 -> 3,048 at
  // 20k and 6,211 -> 6,039 at 80k against one choice for the whole mesh; a choice by every
  // vertex's own misses alone (any ratio) had cost the cut block of the tests 1%. The misses
  // compare extrapolations from three past answers only where there were three.
  parallel([&](int part) { finishStep(part, dt, history >= 3); });
  quadratic_next_ = history >= 3 && partialSum(1) < partialSum(0);
  warm_history_ = std::min(history + 1, 3);
  warm_prev2_.swap(warm_prev_);
  warm_prev_.swap(warm_);
  warm_.swap(dv_);
  return true;
}

void MassSpring::stepSemiImplicit(double dt) {
  forces(&b_);
  const std::vector<Vec3>& f = b_;
  for (int v = 0; v < mesh_->vertexSlots(); ++v) {
    if (!mesh_->vertexAlive(v)) continue;
    if (fixed_[v] || !(inertia_[v] > 0)) {
      mesh_->velocity(v).setZero();
      continue;
    }
    mesh_->velocity(v) += dt * f[v] / inertia_[v];
    mesh_->current(v) += dt * mesh_->velocity(v);
  }
}

void MassSpring::expectStep(double within_us) {
  if (team_ && within_us > 0)
    team_->expectJob(std::chrono::microseconds(static_cast<long long>(std::min(within_us, 1e6))));
}

std::string MassSpring::step(double dt) {
  const auto start = std::chrono::steady_clock::now();
  struct Timer {  // counts the step's time on every way out
    const std::chrono::steady_clock::time_point& start;
    double* total;
    ~Timer() {
      *total += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                    .count();
    }
  } timer{start, &time_ms_};
  ++steps_;
  resize();
  sizeStepBuffers();  // capacity kept: no allocation once grown
  const int n = mesh_->vertexSlots();
  // The positions to roll back to.
  parallel([&](int part) {
    const auto [begin, end] = rangeOf(n, part);
    const Vec3* x = mesh_->currentPositions().data();
    std::copy(x + begin, x + end, x0_.data() + begin);
  });
  // The inertia depends on the masses and the live vertices only: made again only when they, or
  // the parts that sum the mass, changed (inertia_valid_).
  if (!inertia_valid_) updateInertia();
  if (params_.implicit) {
    stepImplicit(dt);  // its last pass scans the speeds too
  } else {
    stepSemiImplicit(dt);
    scanSpeeds();
  }
  double worst = 0.0;
  bool finite = true;
  for (const Partial& p : partial_) {
    worst = std::max(worst, p.sum[2]);
    finite = finite && p.sum[3] > 0.0;
  }
  if (finite && worst <= params_.max_speed) {
    last_max_displacement_ = dt * worst;
    return "";
  }
  last_max_displacement_ = HUGE_VAL;
  // Roll back and damp: the tissue keeps its last good shape, at rest.
  mesh_->currentPositions() = x0_;
  for (Vec3& u : mesh_->velocities()) u.setZero();
  warm_history_ = 0;  // the next steps read none of the answers before (see stepImplicit())
  ++instabilities_;
  std::ostringstream msg;
  msg << "physics step unstable (" << (finite ? "speed " : "non-finite state, speed ") << worst
      << " m/s): rolled back and damped";
  return msg.str();
}

void MassSpring::updateInertia() {
  const int n = mesh_->vertexSlots();
  // The mass and the live vertices, for the inertia floor.
  parallel([&](int part) {
    const auto [begin, end] = rangeOf(n, part);
    const unsigned char* alive_at = mesh_->vertexAliveFlags().data();
    const double* vertex_mass = mass_.data();
    double mass = 0.0, alive = 0.0;
    for (int v = begin; v < end; ++v) {
      if (!alive_at[v]) continue;
      mass += vertex_mass[v];
      alive += 1.0;
    }
    partial_[part].sum[0] = mass;
    partial_[part].sum[1] = alive;
  });
  const double total = partialSum(0), alive = partialSum(1);
  // Inertia: the mass, but at least kMinInertia of the mean vertex mass (mass scaling, as explicit
  // codes do for small elements). Repeated cuts leave micrometre tets whose corners weigh 1e-12
  // of the rest while their springs stay stiff; such rows make the system ill-conditioned: at a
  // floor of 1e-9 CG returned speeds of 50-130 m/s, at 1e-3 the 20k organ needed up to 25 CG
  // iterations on the ticks after a cut, at 3e-2 up to 15 (99th percentiles, tolerance 1e-6;
  // 12 at 1e-5). The floor adds 0.04% of the mass there as inertia, on 3% of the vertices (the
  // mass statistics and gravity keep the true mass; addedInertia() reports it).
  const double floor = alive > 0 ? kMinInertia * total / alive : 0.0;
  parallel([&](int part) {
    const auto [begin, end] = rangeOf(n, part);
    const unsigned char* alive_at = mesh_->vertexAliveFlags().data();
    const double* mass = mass_.data();
    double* inertia = inertia_.data();
    double added = 0.0;
    for (int v = begin; v < end; ++v) {
      inertia[v] = alive_at[v] ? std::max(mass[v], floor) : 0.0;
      added += inertia[v] - mass[v];  // dead vertices have no mass
    }
    partial_[part].sum[0] = added;
  });
  added_inertia_ = total > 0 ? partialSum(0) / total : 0.0;
  inertia_valid_ = true;
}

void MassSpring::scanSpeeds() {
  const int n = mesh_->vertexSlots();
  parallel([&](int part) {
    const auto [begin, end] = rangeOf(n, part);
    const Vec3* x = mesh_->currentPositions().data();
    const Vec3* u = mesh_->velocities().data();
    const unsigned char* alive_at = mesh_->vertexAliveFlags().data();
    double worst2 = 0.0, finite = 1.0;  // the largest squared speed: one square root a part
    for (int v = begin; v < end; ++v) {
      if (!alive_at[v]) continue;
      if (!(x[v].allFinite() && u[v].allFinite())) finite = 0.0;
      worst2 = std::max(worst2, u[v].squaredNorm());
    }
    partial_[part].sum[2] = std::sqrt(worst2);
    partial_[part].sum[3] = finite;
  });
}

}  // namespace tissue_cut
