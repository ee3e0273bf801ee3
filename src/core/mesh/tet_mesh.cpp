#include "tissue_cut/mesh/tet_mesh.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "tissue_cut/mesh/quality.hpp"
#include "tissue_cut/mesh/stamped_table.hpp"

namespace tissue_cut {

namespace {

using FaceKey = std::array<int, 3>;

// The room a new vertex's list of tets starts with.
constexpr std::size_t kNewStarRoom = 16;

// Local face of tet t made of vertices {a, b, c}: the one opposite the fourth vertex (the first
// place holding none of them; -1 when there is none). Found as localIndex() finds its place.
int localFace(const TetVerts& t, int a, int b, int c) {
  unsigned other = 0;
  for (int i = 0; i < 4; ++i)
    other |= static_cast<unsigned>((t[i] != a) & (t[i] != b) & (t[i] != c)) << i;
  return other != 0 ? __builtin_ctz(other) : -1;
}

}  // namespace

double distanceToSegment(const Vec3& x, const Vec3& a, const Vec3& b) {
  const Vec3 d = b - a;
  return std::sqrt(squaredDistanceToSegment(x, a, d, d.squaredNorm()));
}

double pointTriangleDistance(const Vec3& x, const Vec3& a, const Vec3& b, const Vec3& c) {
  // The closest point by the Voronoi regions of the corners, edges and face (Ericson, Real-Time
  // Collision Detection, 5.1.5).
  const Vec3 ab = b - a, ac = c - a, ax = x - a;
  const double d1 = ab.dot(ax), d2 = ac.dot(ax);
  if (d1 <= 0 && d2 <= 0) return ax.norm();
  const Vec3 bx = x - b;
  const double d3 = ab.dot(bx), d4 = ac.dot(bx);
  if (d3 >= 0 && d4 <= d3) return bx.norm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return (x - (a + d1 / (d1 - d3) * ab)).norm();
  const Vec3 cx = x - c;
  const double d5 = ab.dot(cx), d6 = ac.dot(cx);
  if (d6 >= 0 && d5 <= d6) return cx.norm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return (x - (a + d2 / (d2 - d6) * ac)).norm();
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0)
    return (x - (b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b))).norm();
  const double sum = va + vb + vc;
  if (!(sum > 0)) return std::min({ax.norm(), bx.norm(), cx.norm()});  // degenerate triangle
  return (x - (a + ab * (vb / sum) + ac * (vc / sum))).norm();
}

bool ChangeRecord::empty() const {
  return removed_tets.empty() && added_tets.empty() && added_vertices.empty() &&
         removed_vertices.empty();
}

void ChangeRecord::clear() {
  removed_tets.clear();
  added_tets.clear();
  added_from.clear();
  added_vertices.clear();
  vertex_parents.clear();
  removed_vertices.clear();
  merged_vertices.clear();
}

void ChangeRecord::append(const ChangeRecord& later) { append(later, 256); }

namespace {

// A tet slot as a key of append()'s notes.
std::uint64_t slotKey(int t) { return static_cast<std::uint32_t>(t); }

// append()'s scratch, one a thread, kept between calls so that their room is: the notes (a
// table over every tet slot, as these notes were, cost its thread's first long record 0.6-0.7 ms
// of page faults in the middle of a tick on the 20k organ), later's removed slots with their
// origins, and which of the added ones they cancel.
struct AppendScratch {
  StampedTable<long long> notes;
  std::vector<std::pair<int, int>> origin;
  std::vector<char> cancelled;
};

// Not inlined: the reference it returns is then a plain pointer. Inlined, the compiler looked the
// thread_local up again (a call, in a shared library) at each use in append()'s loops.
[[gnu::noinline]] AppendScratch& appendScratch() {
  thread_local AppendScratch scratch;
  return scratch;
}

}  // namespace

void ChangeRecord::append(const ChangeRecord& later, std::size_t scan_limit) {
  // Compose into one net change: a tet or vertex added here and removed later never existed for
  // the consumers, and a tet continuing one of those continues what that one continued. Most
  // records composed are small next to a tick's (one collapse, flip or move appended to what the
  // tick did so far): short lists are scanned; for longer ones (a tick's record of hundreds of
  // tets against a collapse's dozen removed, most of them not added here) later's slots are
  // noted first in a table (appendScratch()) and found by one look along this record's list.
  AppendScratch& scratch = appendScratch();
  StampedTable<long long>* notes = nullptr;  // begun when first needed
  const std::size_t n_added = added_tets.size();
  const bool scan_added = later.removed_tets.size() * n_added <= scan_limit;
  if (!scan_added) {
    // later's removed slots noted (-1: not added here), each given its last place in added_tets
    // by one look along the list from its end. Most of the list is none of them: a filter of 512
    // bits answers that before the table is asked.
    notes = &scratch.notes;
    notes->begin(later.removed_tets.size());
    std::array<std::uint64_t, 8> filter{};
    auto bit = [](int t) { return (static_cast<std::uint32_t>(t) * 0x9E3779B1u) >> 23; };
    for (int t : later.removed_tets) {
      notes->put(slotKey(t), -1);
      filter[bit(t) >> 6] |= std::uint64_t{1} << (bit(t) & 63);
    }
    for (std::size_t i = n_added; i-- > 0;) {
      const int t = added_tets[i];
      if (!((filter[bit(t) >> 6] >> (bit(t) & 63)) & 1)) continue;
      if (notes->contains(slotKey(t)) && notes->at(slotKey(t)) < 0)
        notes->put(slotKey(t), static_cast<long long>(i));  // the last, as scanned
    }
  }
  // later's removed slots and what each continued, in later.removed_tets' order
  std::vector<std::pair<int, int>>& origin = scratch.origin;
  origin.clear();
  std::vector<char>& cancelled = scratch.cancelled;
  cancelled.clear();
  for (int t : later.removed_tets) {
    std::size_t i = n_added;
    if (scan_added) {
      for (std::size_t k = n_added; k-- > 0;)
        if (added_tets[k] == t) {
          i = k;
          break;
        }
    } else if (notes->at(slotKey(t)) >= 0) {
      i = static_cast<std::size_t>(notes->at(slotKey(t)));
    }
    if (i < n_added && (cancelled.empty() || !cancelled[i])) {
      if (cancelled.empty()) cancelled.assign(n_added, 0);
      cancelled[i] = 1;
      origin.emplace_back(t, added_from[i]);
    } else {
      removed_tets.push_back(t);
      origin.emplace_back(t, t);
    }
  }
  if (!cancelled.empty()) {
    std::size_t kept = 0;
    for (std::size_t i = 0; i < n_added; ++i)
      if (!cancelled[i]) {
        added_tets[kept] = added_tets[i];
        added_from[kept] = added_from[i];
        ++kept;
      }
    added_tets.resize(kept);
    added_from.resize(kept);
  }
  const bool scan_origin = later.added_tets.size() * origin.size() <= scan_limit;
  if (!scan_origin) {
    notes = &scratch.notes;
    notes->begin(origin.size());
    for (const auto& [t, o] : origin)
      if (!notes->contains(slotKey(t))) notes->put(slotKey(t), o);  // the first, as scanned
  }
  for (std::size_t i = 0; i < later.added_tets.size(); ++i) {
    int from = later.added_from[i];
    if (from >= 0) {
      if (scan_origin) {
        for (const auto& [t, o] : origin)
          if (t == from) {
            from = o;
            break;
          }
      } else if (notes->contains(slotKey(from))) {
        from = static_cast<int>(notes->at(slotKey(from)));
      }
    }
    added_tets.push_back(later.added_tets[i]);
    added_from.push_back(from);
  }
  for (int v : later.removed_vertices) {
    auto it = std::find(added_vertices.begin(), added_vertices.end(), v);
    if (it != added_vertices.end()) {
      vertex_parents.erase(vertex_parents.begin() + (it - added_vertices.begin()));
      added_vertices.erase(it);
    } else {
      removed_vertices.push_back(v);
    }
  }
  added_vertices.insert(added_vertices.end(), later.added_vertices.begin(),
                        later.added_vertices.end());
  vertex_parents.insert(vertex_parents.end(), later.vertex_parents.begin(),
                        later.vertex_parents.end());
  merged_vertices.insert(merged_vertices.end(), later.merged_vertices.begin(),
                         later.merged_vertices.end());
}

TetMesh::TetMesh(const Eigen::MatrixXd& V, const Eigen::MatrixXi& T) {
  if (V.cols() != 3) throw std::invalid_argument("TetMesh: V must have 3 columns");
  if (T.size() > 0 && T.cols() != 4) throw std::invalid_argument("TetMesh: T must have 4 columns");
  // Slots to spare (see slotCapacity()): cutting adds vertices and tets without reallocating.
  const int nv = static_cast<int>(V.rows());
  assignSlots(&rest_, nv, Vec3::Zero());
  for (int i = 0; i < nv; ++i) rest_[i] = V.row(i).transpose();
  current_.reserve(rest_.capacity());
  current_ = rest_;
  assignSlots(&velocity_, nv, Vec3::Zero());
  assignSlots(&vertex_alive_, nv, static_cast<unsigned char>(1));
  assignSlots(&vertex_tets_, nv);
  assignSlots(&boundary_faces_, nv, 0);
  num_vertices_ = nv;

  const int nt = static_cast<int>(T.rows());
  assignSlots(&tets_, nt);
  assignSlots(&rest_quality_, nt, 0.0);
  assignSlots(&rest_volume_, nt, 0.0);
  assignSlots(&neighbors_, nt, {-1, -1, -1, -1});
  assignSlots(&tet_alive_, nt, static_cast<unsigned char>(1));
  num_tets_ = nt;
  for (int t = 0; t < nt; ++t) {
    TetVerts tv{T(t, 0), T(t, 1), T(t, 2), T(t, 3)};
    for (int i = 0; i < 4; ++i) {
      if (tv[i] < 0 || tv[i] >= nv) {
        std::ostringstream msg;
        msg << "TetMesh: tet " << t << " names vertex " << tv[i] << " of " << nv;
        throw std::invalid_argument(msg.str());
      }
      for (int j = 0; j < i; ++j)
        if (tv[i] == tv[j])
          throw std::invalid_argument("TetMesh: tet " + std::to_string(t) + " repeats a vertex");
    }
    if (signedVolume(rest_[tv[0]], rest_[tv[1]], rest_[tv[2]], rest_[tv[3]]) < 0) {
      std::swap(tv[2], tv[3]);
      ++reoriented_;
    }
    tets_[t] = tv;
    measureTet(t);
    for (int v : tv) vertex_tets_[v].push_back(t);
  }
  // Match faces globally once; later changes match locally.
  std::unordered_map<FaceKey, std::pair<int, int>, FaceHash> open;
  open.reserve(static_cast<std::size_t>(nt) * 2);
  for (int t = 0; t < nt; ++t) {
    for (int f = 0; f < 4; ++f) {
      const TetVerts& tv = tets_[t];
      FaceKey k = sortedFace(tv[kTetFace[f][0]], tv[kTetFace[f][1]], tv[kTetFace[f][2]]);
      auto it = open.find(k);
      if (it == open.end()) {
        open.emplace(k, std::make_pair(t, f));
        continue;
      }
      auto [u, g] = it->second;
      if (u < 0)
        throw std::invalid_argument("TetMesh: a face of tet " + std::to_string(t) +
                                    " is shared by more than two tets");
      neighbors_[t][f] = u;
      neighbors_[u][g] = t;
      it->second = {-1, -1};
    }
  }
  for (const auto& kv : open)
    if (kv.second.first >= 0) {
      ++num_boundary_faces_;
      countBoundaryFace(kv.first[0], kv.first[1], kv.first[2], 1);
    }
}

std::vector<int> TetMesh::edgeTets(int a, int b) const {
  std::vector<int> out(vertex_tets_[a].size());  // the star is among a's tets
  out.resize(edgeTets(a, b, out.data(), static_cast<int>(out.size())));
  return out;
}

int TetMesh::edgeTets(int a, int b, int* out, int capacity) const {
  int count = 0;
  for (int t : vertex_tets_[a])
    if (contains(tets_[t], b)) {
      if (count < capacity) out[count] = t;
      ++count;
    }
  return count;
}

bool TetMesh::hasEdge(int a, int b) const {
  for (int t : vertex_tets_[a])
    if (contains(tets_[t], b)) return true;
  return false;
}

int TetMesh::faceTet(int a, int b, int c, int except) const {
  // The face's tets are in each of its vertices' stars: the smallest is searched (a point a cut
  // made has a handful of tets, an original vertex tens). At most two tets hold a face, so the
  // answer does not depend on which.
  smallestStarFirst(&a, &b, &c);
  for (int t : vertex_tets_[a]) {
    if (t == except) continue;
    const TetVerts& tv = tets_[t];
    if (contains(tv, b) && contains(tv, c)) return t;
  }
  return -1;
}

void TetMesh::smallestStarFirst(int* a, int* b, int* c) const {
  if (vertex_tets_[*b].size() < vertex_tets_[*a].size()) std::swap(*a, *b);
  if (vertex_tets_[*c].size() < vertex_tets_[*a].size()) std::swap(*a, *c);
}

std::vector<std::pair<int, int>> TetMesh::edges() const {
  std::vector<std::pair<int, int>> out;
  out.reserve(static_cast<std::size_t>(num_tets_) * 2);
  for (int t = 0; t < tetSlots(); ++t) {
    if (!tet_alive_[t]) continue;
    for (const auto& e : kTetEdge) {
      int a = tets_[t][e[0]], b = tets_[t][e[1]];
      out.emplace_back(std::min(a, b), std::max(a, b));
    }
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

Eigen::MatrixXi TetMesh::liveTets(std::vector<int>* slots) const {
  Eigen::MatrixXi T(num_tets_, 4);
  if (slots) slots->clear();
  int row = 0;
  for (int t = 0; t < tetSlots(); ++t) {
    if (!tet_alive_[t]) continue;
    for (int i = 0; i < 4; ++i) T(row, i) = tets_[t][i];
    if (slots) slots->push_back(t);
    ++row;
  }
  return T;
}

double TetMesh::currentVolume(int t) const {
  const TetVerts& v = tets_[t];
  return signedVolume(current_[v[0]], current_[v[1]], current_[v[2]], current_[v[3]]);
}

double TetMesh::restVolume() const {
  double sum = 0;
  for (int t = 0; t < tetSlots(); ++t)
    if (tet_alive_[t]) sum += restVolume(t);
  return sum;
}

double TetMesh::currentVolume() const {
  double sum = 0;
  for (int t = 0; t < tetSlots(); ++t)
    if (tet_alive_[t]) sum += currentVolume(t);
  return sum;
}

int TetMesh::allocateVertex() {
  // Vertex slots are never reused: ids then grow with creation, and "smaller id" means "older",
  // which the cut's face rule relies on (a dead slot costs a few bytes).
  rest_.emplace_back();
  current_.emplace_back();
  velocity_.emplace_back();
  vertex_alive_.push_back(0);
  vertex_tets_.emplace_back();
  boundary_faces_.push_back(0);
  return vertexSlots() - 1;
}

int TetMesh::allocateTet() {
  if (!free_tets_.empty()) {
    int t = free_tets_.back();
    free_tets_.pop_back();
    return t;
  }
  tets_.emplace_back();
  rest_quality_.push_back(0.0);
  rest_volume_.push_back(0.0);
  neighbors_.push_back({-1, -1, -1, -1});
  tet_alive_.push_back(0);
  return tetSlots() - 1;
}

int TetMesh::addVertex(const VertexParents& parents, ChangeRecord* record) {
  Vec3 r = Vec3::Zero(), c = Vec3::Zero(), u = Vec3::Zero();
  for (const VertexParent& p : parents) {
    if (p.vertex < 0 || p.vertex >= vertexSlots() || !vertex_alive_[p.vertex])
      throw std::logic_error("TetMesh::addVertex: dead parent vertex " + std::to_string(p.vertex));
    r += p.weight * rest_[p.vertex];
    c += p.weight * current_[p.vertex];
    u += p.weight * velocity_[p.vertex];
  }
  const int v = allocateVertex();
  rest_[v] = r;
  current_[v] = c;
  velocity_[v] = u;
  vertex_alive_[v] = 1;
  vertex_tets_[v].clear();
  // Room for a cut vertex's star at once (10-20 tets), not grown by doubling from one.
  vertex_tets_[v].reserve(kNewStarRoom);
  ++num_vertices_;
  if (record) {
    record->added_vertices.push_back(v);
    record->vertex_parents.push_back(parents);
  }
  return v;
}

void TetMesh::removeVertex(int v, ChangeRecord* record) {
  if (!vertex_alive_[v]) throw std::logic_error("TetMesh::removeVertex: vertex already dead");
  if (!vertex_tets_[v].empty())
    throw std::logic_error("TetMesh::removeVertex: vertex " + std::to_string(v) + " still in use");
  vertex_alive_[v] = 0;
  --num_vertices_;
  if (record) record->removed_vertices.push_back(v);
}

void TetMesh::measureTet(int t) {
  const TetVerts& tv = tets_[t];
  rest_quality_[t] = tetQuality(rest_[tv[0]], rest_[tv[1]], rest_[tv[2]], rest_[tv[3]]);
  rest_volume_[t] = signedVolume(rest_[tv[0]], rest_[tv[1]], rest_[tv[2]], rest_[tv[3]]);
}

void TetMesh::linkTet(int t) {
  const TetVerts& tv = tets_[t];
  for (int v : tv) vertex_tets_[v].push_back(t);
  for (int f = 0; f < 4; ++f) {
    int a = tv[kTetFace[f][0]], b = tv[kTetFace[f][1]], c = tv[kTetFace[f][2]];
    int u = faceTet(a, b, c, t);
    if (u < 0) {
      neighbors_[t][f] = -1;
      ++num_boundary_faces_;
      countBoundaryFace(a, b, c, 1);
    } else {
      int g = localFace(tets_[u], a, b, c);
      neighbors_[t][f] = u;
      neighbors_[u][g] = t;
      --num_boundary_faces_;
      countBoundaryFace(a, b, c, -1);
    }
  }
}

void TetMesh::unlinkTets(const std::vector<int>& remove) {
  // The tets to remove carry this call's stamp (replaceTets()). A face between two of them
  // neither opens nor closes; one to a kept tet opens on its side; one on the boundary goes.
  auto removed = [this](int t) { return removing_[t] == removing_stamp_; };
  std::vector<int>& verts = unlink_vertices_;
  verts.clear();
  nextStamp(&vertex_mark_, &vertex_mark_call_, vertex_tets_.size());
  for (int t : remove) {
    const TetVerts& tv = tets_[t];
    for (int f = 0; f < 4; ++f) {
      const int u = neighbors_[t][f];
      if (u < 0) {
        --num_boundary_faces_;
        countBoundaryFace(tv[kTetFace[f][0]], tv[kTetFace[f][1]], tv[kTetFace[f][2]], -1);
      } else if (!removed(u)) {
        for (int g = 0; g < 4; ++g)
          if (neighbors_[u][g] == t) neighbors_[u][g] = -1;
        ++num_boundary_faces_;
        countBoundaryFace(tv[kTetFace[f][0]], tv[kTetFace[f][1]], tv[kTetFace[f][2]], 1);
      }
      neighbors_[t][f] = -1;
    }
    for (int v : tets_[t])
      if (vertex_mark_[v] != vertex_mark_call_) {
        vertex_mark_[v] = vertex_mark_call_;
        verts.push_back(v);
      }
  }
  // Each vertex's list loses them in one pass, its other tets in order (as erasing them one by
  // one left it).
  for (int v : verts) {
    std::vector<int>& list = vertex_tets_[v];
    list.erase(std::remove_if(list.begin(), list.end(), removed), list.end());
  }
}

std::vector<int> TetMesh::replaceTets(const std::vector<int>& remove,
                                      const std::vector<TetVerts>& add, ChangeRecord* record,
                                      const std::vector<int>* from) {
  std::vector<int> ids;
  replaceTets(remove, add, record, from, &ids);
  return ids;
}

void TetMesh::replaceTets(const std::vector<int>& remove, const std::vector<TetVerts>& add,
                          ChangeRecord* record, const std::vector<int>* from,
                          std::vector<int>* ids_out) {
  if (from && from->size() != add.size())
    throw std::logic_error("TetMesh::replaceTets: `from` must be parallel to `add`");
  // Check everything first, so a refused change leaves the mesh as it was. The tets removed are
  // marked with this call's stamp, the new faces sorted and counted (no set or hash map: a move
  // of one vertex replaces its star through here).
  nextStamp(&removing_, &removing_stamp_, tets_.size());
  for (int t : remove)
    if (t < 0 || t >= tetSlots() || !tet_alive_[t])
      throw std::logic_error("TetMesh::replaceTets: removing dead tet " + std::to_string(t));
  for (int t : remove) {
    if (removing_[t] == removing_stamp_)
      throw std::logic_error("TetMesh::replaceTets: a tet is removed twice");
    removing_[t] = removing_stamp_;
  }
  auto removed = [this](int t) { return removing_[t] == removing_stamp_; };
  // The new faces, each at its place (4 x the tet's place in `add` + the face), grouped by a
  // hash table of places (open addressing, at most half full): each face's first place holds
  // how many places name it and the second one's place. (A sort of the faces had cost more,
  // mostly in mispredicted comparisons.)
  const std::size_t faces = 4 * add.size();
  std::vector<FaceKey>& keys = face_keys_;
  keys.resize(faces);
  for (std::size_t place = 0; place < add.size(); ++place) {
    const TetVerts& tv = add[place];
    for (int i = 0; i < 4; ++i) {
      if (tv[i] < 0 || tv[i] >= vertexSlots() || !vertex_alive_[tv[i]])
        throw std::logic_error("TetMesh::replaceTets: dead vertex " + std::to_string(tv[i]));
      for (int j = 0; j < i; ++j)
        if (tv[i] == tv[j]) throw std::logic_error("TetMesh::replaceTets: repeated vertex");
    }
    // validate()'s own test: a flat or inverted tet would make the mesh invalid.
    if (!(signedVolume(rest_[tv[0]], rest_[tv[1]], rest_[tv[2]], rest_[tv[3]]) > 0.0))
      throw std::logic_error("TetMesh::replaceTets: tet (" + std::to_string(tv[0]) + ", " +
                             std::to_string(tv[1]) + ", " + std::to_string(tv[2]) + ", " +
                             std::to_string(tv[3]) + ") has no positive rest volume");
    for (int f = 0; f < 4; ++f)
      keys[4 * place + f] = sortedFace(tv[kTetFace[f][0]], tv[kTetFace[f][1]], tv[kTetFace[f][2]]);
  }
  std::size_t bits = 4;
  while ((std::size_t{1} << bits) < 2 * faces) ++bits;
  const std::size_t mask = (std::size_t{1} << bits) - 1;
  std::vector<int>& table = face_table_;
  table.assign(mask + 1, -1);
  std::vector<int>& count = face_count_;    // per first place: the places naming its face
  std::vector<int>& second = face_second_;  // per first place: the second one
  count.assign(faces, 0);
  second.resize(faces);
  for (std::size_t p = 0; p < faces; ++p) {
    const FaceKey& k = keys[p];
    std::size_t h = (FaceHash()(k) * 0x9E3779B97F4A7C15ull) >> (64 - bits);
    while (table[h] >= 0 && !sameVertices(keys[table[h]], k)) h = (h + 1) & mask;
    if (table[h] < 0) {
      table[h] = static_cast<int>(p);
      count[p] = 1;
    } else {
      if (++count[table[h]] == 2) second[table[h]] = static_cast<int>(p);
    }
  }
  // Each face once, at its first place: how many tets would share it, and what each new tet
  // will find across it (linkTet()'s search, done here once: the tet the count finds kept, or
  // the other new one).
  face_across_.assign(faces, -1);
  for (std::size_t p = 0; p < faces; ++p) {
    if (count[p] == 0) continue;  // a face met at an earlier place
    const FaceKey& key = keys[p];
    int a = key[0], b = key[1], c = key[2];
    smallestStarFirst(&a, &b, &c);
    int kept = 0, across = -1;
    for (int t : vertex_tets_[a])
      // One branch (taken at most twice a face), not three that go either way.
      if (!removed(t) & contains(tets_[t], b) & contains(tets_[t], c)) {
        ++kept;
        across = t;
      }
    if (count[p] + kept > 2)
      throw std::logic_error("TetMesh::replaceTets: face (" + std::to_string(key[0]) + ", " +
                             std::to_string(key[1]) + ", " + std::to_string(key[2]) +
                             ") would be shared by " + std::to_string(count[p] + kept) + " tets");
    const int place0 = static_cast<int>(p);
    if (count[p] == 2) {
      const int place1 = second[p];
      face_across_[place0] = -2 - place1;
      face_across_[place1] = -2 - place0;
    } else {
      face_across_[place0] = across;
    }
  }

  unlinkTets(remove);
  for (int t : remove) {
    tet_alive_[t] = 0;
    free_tets_.push_back(t);
    --num_tets_;
  }
  std::vector<int>& ids = *ids_out;
  ids.clear();
  ids.reserve(add.size());
  for (std::size_t place = 0; place < add.size(); ++place) {
    const TetVerts& tv = add[place];
    int t = allocateTet();
    tets_[t] = tv;
    measureTet(t);
    tet_alive_[t] = 1;
    ++num_tets_;
    // As linkTet(t) would link it, with what lies across each face known: a new tet made
    // earlier is linked to it, one made later will be.
    for (int v : tv) vertex_tets_[v].push_back(t);
    for (int f = 0; f < 4; ++f) {
      const int across = face_across_[4 * place + f];
      const int other = across <= -2 ? (-2 - across) / 4 : -1;  // a new tet's place
      if (across == -1 || (other >= 0 && other > static_cast<int>(place))) {
        neighbors_[t][f] = -1;
        ++num_boundary_faces_;
        countBoundaryFace(tv[kTetFace[f][0]], tv[kTetFace[f][1]], tv[kTetFace[f][2]], 1);
        continue;
      }
      const int u = other >= 0 ? ids[other] : across;
      const int g = other >= 0 ? (-2 - across) % 4
                               : localFace(tets_[u], tv[kTetFace[f][0]], tv[kTetFace[f][1]],
                                           tv[kTetFace[f][2]]);
      neighbors_[t][f] = u;
      neighbors_[u][g] = t;
      --num_boundary_faces_;
      countBoundaryFace(tv[kTetFace[f][0]], tv[kTetFace[f][1]], tv[kTetFace[f][2]], -1);
    }
    ids.push_back(t);
  }
  if (record) {
    record->removed_tets.insert(record->removed_tets.end(), remove.begin(), remove.end());
    record->added_tets.insert(record->added_tets.end(), ids.begin(), ids.end());
    for (std::size_t i = 0; i < ids.size(); ++i)
      record->added_from.push_back(from ? (*from)[i] : -1);
  }
}

void TetMesh::moveVertex(int v, const VertexParents& parents, ChangeRecord* record) {
  if (v < 0 || v >= vertexSlots() || !vertex_alive_[v])
    throw std::logic_error("TetMesh::moveVertex: dead vertex " + std::to_string(v));
  Vec3 r = Vec3::Zero(), c = Vec3::Zero(), u = Vec3::Zero();
  for (const VertexParent& p : parents) {
    if (p.vertex < 0 || p.vertex >= vertexSlots() || !vertex_alive_[p.vertex])
      throw std::logic_error("TetMesh::moveVertex: dead parent vertex " + std::to_string(p.vertex));
    r += p.weight * rest_[p.vertex];
    c += p.weight * current_[p.vertex];
    u += p.weight * velocity_[p.vertex];
  }
  // The star is announced as replaced by the same tets, exactly as replaceTets(star, star's tets,
  // record, &star) would leave it (that is what this did), without its checks and searches:
  // nothing but the numbering changes (a smoothing move costs a tenth of what it did).
  std::vector<int>& star = move_star_;  // a copy: restack() changes the star
  star = vertex_tets_[v];
  const Vec3 old_rest = rest_[v];
  rest_[v] = r;
  for (int t : star) {
    const TetVerts& tv = tets_[t];
    if (!(signedVolume(rest_[tv[0]], rest_[tv[1]], rest_[tv[2]], rest_[tv[3]]) > 0.0)) {
      rest_[v] = old_rest;
      throw std::logic_error("TetMesh::moveVertex: tet (" + std::to_string(tv[0]) + ", " +
                             std::to_string(tv[1]) + ", " + std::to_string(tv[2]) + ", " +
                             std::to_string(tv[3]) + ") would have no positive rest volume");
    }
  }
  current_[v] = c;
  velocity_[v] = u;
  restack(star, v, v, record);
}

std::vector<int> TetMesh::renameVertex(const std::vector<int>& tets, int v, int copy,
                                       ChangeRecord* record) {
  std::vector<int> ids;
  renameVertex(tets, v, copy, record, &ids);
  return ids;
}

void TetMesh::renameVertex(const std::vector<int>& tets, int v, int copy, ChangeRecord* record,
                           std::vector<int>* ids) {
  auto refuse = [](const std::string& why) {
    throw std::logic_error("TetMesh::renameVertex: " + why);
  };
  if (v < 0 || v >= vertexSlots() || !vertex_alive_[v]) refuse("dead vertex " + std::to_string(v));
  if (copy < 0 || copy >= vertexSlots() || !vertex_alive_[copy] || copy == v)
    refuse("the copy " + std::to_string(copy) + " is not a live vertex other than " +
           std::to_string(v));
  // A copy without tets is in no face yet: the renamed faces through it are those of `tets`,
  // each shared as before or by one of them alone. (Otherwise replaceTets checks it all.)
  if (!vertex_tets_[copy].empty()) refuse("the copy " + std::to_string(copy) + " already has tets");
  nextStamp(&removing_, &removing_stamp_, tets_.size());
  for (int t : tets) {
    if (t < 0 || t >= tetSlots() || !tet_alive_[t]) refuse("dead tet " + std::to_string(t));
    if (removing_[t] == removing_stamp_) refuse("a tet is named twice");
    removing_[t] = removing_stamp_;
    const int i = localIndex(tets_[t], v);
    if (i < 0) refuse("tet " + std::to_string(t) + " does not hold vertex " + std::to_string(v));
    TetVerts tv = tets_[t];
    tv[i] = copy;
    if (!(signedVolume(rest_[tv[0]], rest_[tv[1]], rest_[tv[2]], rest_[tv[3]]) > 0.0))
      refuse("tet " + std::to_string(t) + " would have no positive rest volume");
  }
  restack(tets, v, copy, record);
  ids->assign(tets.rbegin(), tets.rend());
}

void TetMesh::restack(const std::vector<int>& star, int v, int copy, ChangeRecord* record) {
  // As replaceTets(star, renamed, record, &star) leaves it: the slots taken back in reverse
  // order (the free list is a stack), so the tet of star[i] moves to slot star[n - 1 - i]; each
  // vertex's list keeps its other tets in order and gets the star's new slots at its end;
  // adjacency follows the slots, and a face through v to a tet outside the star opens when v is
  // renamed (only the star's tets hold the copy).
  const int n = static_cast<int>(star.size());
  // The star's slots marked in replaceTets' scratch (this call's stamp), with their places.
  nextStamp(&removing_, &removing_stamp_, tets_.size());
  std::vector<int>& place = move_place_;
  growSlots(&place, tets_.size(), 0);
  for (int i = 0; i < n; ++i) {
    removing_[star[i]] = removing_stamp_;
    place[star[i]] = i;
  }
  // (Without a branch on the boundary's -1: slot 0 read in its place.)
  auto inStar = [&](int t) {
    return (t >= 0) & (removing_[t >= 0 ? t : 0] == removing_stamp_);
  };
  auto slotOf = [&](int t) { return star[n - 1 - place[t]]; };  // where t's tet goes
  move_tets_.assign(n, TetVerts{});
  move_neighbors_.assign(n, std::array<int, 4>{});
  for (int i = 0; i < n; ++i) {
    move_tets_[i] = tets_[star[i]];
    for (int f = 0; f < 4; ++f) {
      const int w = neighbors_[star[i]][f];
      move_neighbors_[i][f] = inStar(w) ? slotOf(w) : w;
    }
  }
  // Neighbours outside the star point at the new slots (their face found by its vertices), or
  // no longer meet it where the face holds a renamed v.
  for (int i = 0; i < n; ++i) {
    const TetVerts& tv = move_tets_[i];
    for (int f = 0; f < 4; ++f) {
      const int w = move_neighbors_[i][f];
      if (w < 0 || inStar(neighbors_[star[i]][f])) continue;
      const int a = tv[kTetFace[f][0]], b = tv[kTetFace[f][1]], c = tv[kTetFace[f][2]];
      const bool opens = copy != v && (a == v || b == v || c == v);
      neighbors_[w][localFace(tets_[w], a, b, c)] = opens ? -1 : star[n - 1 - i];
      if (opens) {
        move_neighbors_[i][f] = -1;
        num_boundary_faces_ += 2;
        countBoundaryFace(a, b, c, 2);  // both sides, v's until the rename below
      }
    }
  }
  // The star's boundary faces through v (those just opened on its side too) hold the copy
  // after the rename.
  if (copy != v)
    for (int i = 0; i < n; ++i)
      for (int f = 0; f < 4; ++f)
        if (move_neighbors_[i][f] < 0 && move_tets_[i][f] != v) {
          --boundary_faces_[v];
          ++boundary_faces_[copy];
        }
  // The star's vertices (and the copy) once each, found by a mark: each one's list is mended on
  // its own, so their order does not matter (a sort had cost more than the mending).
  std::vector<int>& verts = move_vertices_;
  verts.clear();
  nextStamp(&vertex_mark_, &vertex_mark_call_, vertex_tets_.size());
  auto note = [&](int w) {
    if (vertex_mark_[w] == vertex_mark_call_) return;
    vertex_mark_[w] = vertex_mark_call_;
    verts.push_back(w);
  };
  for (TetVerts& tv : move_tets_) {
    for (int& x : tv) {
      note(x);
      if (x == v) x = copy;
    }
  }
  if (copy != v) note(copy);
  // A moved v moves its star (moveVertex): measured anew. A copy where v is (a rename at the
  // same place) leaves each tet's corners where they were, in the same order: its measures are
  // the ones it had, and go with it.
  const bool same_place = copy != v && rest_[copy] == rest_[v];
  if (same_place) {
    move_measures_.resize(n);
    for (int i = 0; i < n; ++i) move_measures_[i] = {rest_quality_[star[i]], rest_volume_[star[i]]};
  }
  for (int i = 0; i < n; ++i) {
    const int slot = star[n - 1 - i];
    tets_[slot] = move_tets_[i];
    if (same_place) {
      rest_quality_[slot] = move_measures_[i][0];
      rest_volume_[slot] = move_measures_[i][1];
    } else {
      measureTet(slot);
    }
    neighbors_[slot] = move_neighbors_[i];
  }
  // Each vertex of the star: its other tets in order, then the star's slots in the order taken.
  for (int w : verts) {
    std::vector<int>& list = vertex_tets_[w];
    list.erase(std::remove_if(list.begin(), list.end(), inStar), list.end());
  }
  // In the order taken: each list gets its slots in increasing i, as a scan per vertex would.
  for (int i = 0; i < n; ++i)
    for (int w : move_tets_[i]) vertex_tets_[w].push_back(star[n - 1 - i]);
  if (record) {
    record->removed_tets.insert(record->removed_tets.end(), star.begin(), star.end());
    for (int i = 0; i < n; ++i) {
      record->added_tets.push_back(star[n - 1 - i]);
      record->added_from.push_back(star[i]);
    }
  }
}

void TetMesh::mergeVertices(int removed, int survivor, ChangeRecord* record) {
  if (removed == survivor || !vertex_alive_[removed] || !vertex_alive_[survivor])
    throw std::logic_error("TetMesh::mergeVertices: needs two distinct live vertices");
  // (member lists, kept for their room: a collapse queue merges vertices by the hundred)
  std::vector<int>& old = merge_old_;
  old = vertex_tets_[removed];  // a copy: replaceTets() changes the star
  std::vector<TetVerts>& moved = merge_moved_;
  moved.clear();
  std::vector<int>& from = merge_from_;
  from.clear();
  for (int t : old) {
    TetVerts tv = tets_[t];
    if (contains(tv, survivor)) continue;
    tv[localIndex(tv, removed)] = survivor;
    moved.push_back(tv);
    from.push_back(t);
  }
  replaceTets(old, moved, record, &from, &merge_ids_);
  removeVertex(removed, record);
  if (record) record->merged_vertices.emplace_back(removed, survivor);
}

std::string TetMesh::validate() const {
  std::ostringstream err;
  auto tetName = [&](int t) {
    const TetVerts& v = tets_[t];
    return "tet " + std::to_string(t) + " (" + std::to_string(v[0]) + " " + std::to_string(v[1]) +
           " " + std::to_string(v[2]) + " " + std::to_string(v[3]) + ")";
  };
  int live_tets = 0;
  for (int t = 0; t < tetSlots(); ++t) {
    if (!tet_alive_[t]) continue;
    ++live_tets;
    const TetVerts& tv = tets_[t];
    for (int i = 0; i < 4; ++i) {
      if (tv[i] < 0 || tv[i] >= vertexSlots() || !vertex_alive_[tv[i]])
        return tetName(t) + " names dead vertex " + std::to_string(tv[i]);
      for (int j = 0; j < i; ++j)
        if (tv[i] == tv[j]) return tetName(t) + " repeats a vertex";
      const auto& inc = vertex_tets_[tv[i]];
      if (std::find(inc.begin(), inc.end(), t) == inc.end())
        return tetName(t) + " is missing from the incidence list of vertex " +
               std::to_string(tv[i]);
    }
    const double vol = signedVolume(rest_[tv[0]], rest_[tv[1]], rest_[tv[2]], rest_[tv[3]]);
    if (!(vol > 0)) {
      err << tetName(t) << " has non-positive rest volume " << vol;
      return err.str();
    }
    if (rest_volume_[t] != vol) {
      err << tetName(t) << " keeps rest volume " << rest_volume_[t] << " where it has " << vol;
      return err.str();
    }
    const double q = tetQuality(rest_[tv[0]], rest_[tv[1]], rest_[tv[2]], rest_[tv[3]]);
    if (rest_quality_[t] != q) {
      err << tetName(t) << " keeps rest quality " << rest_quality_[t] << " where it has " << q;
      return err.str();
    }
    for (int f = 0; f < 4; ++f) {
      const int a = tv[kTetFace[f][0]], b = tv[kTetFace[f][1]], c = tv[kTetFace[f][2]];
      int sharing = 0;
      for (int u : vertex_tets_[a])
        if (u != t && contains(tets_[u], b) && contains(tets_[u], c)) ++sharing;
      if (sharing > 1)
        return "face " + std::to_string(f) + " of " + tetName(t) +
               " is shared by more than two tets";
      const int u = neighbors_[t][f];
      if (u < 0) {
        if (sharing != 0)
          return "face " + std::to_string(f) + " of " + tetName(t) +
                 " has a tet beyond it but no neighbour";
        continue;
      }
      if (u >= tetSlots() || !tet_alive_[u])
        return "face " + std::to_string(f) + " of " + tetName(t) + " points at a dead tet";
      const TetVerts& uv = tets_[u];
      if (!contains(uv, a) || !contains(uv, b) || !contains(uv, c))
        return "neighbour " + tetName(u) + " across face " + std::to_string(f) + " of " +
               tetName(t) + " does not hold that face";
      const int g = localFace(uv, a, b, c);
      if (neighbors_[u][g] != t)
        return "adjacency of " + tetName(t) + " and " + tetName(u) + " is not symmetric";
      // Opposite orientation: the face as seen from u must be an odd permutation of (a, b, c).
      const int* gf = kTetFace[g];
      std::array<int, 3> seen{uv[gf[0]], uv[gf[1]], uv[gf[2]]};
      std::array<int, 3> same0{a, b, c}, same1{b, c, a}, same2{c, a, b};
      if (seen == same0 || seen == same1 || seen == same2)
        return "face shared by " + tetName(t) + " and " + tetName(u) + " has the same orientation";
    }
  }
  if (live_tets != num_tets_) return "live tet count is out of date";
  int live_vertices = 0;
  for (int v = 0; v < vertexSlots(); ++v) {
    if (!vertex_alive_[v]) {
      if (!vertex_tets_[v].empty()) return "dead vertex " + std::to_string(v) + " has tets";
      continue;
    }
    ++live_vertices;
    if (vertex_tets_[v].empty()) return "vertex " + std::to_string(v) + " has no tetrahedron";
    for (int t : vertex_tets_[v])
      if (t < 0 || t >= tetSlots() || !tet_alive_[t] || !contains(tets_[t], v))
        return "incidence list of vertex " + std::to_string(v) + " names tet " + std::to_string(t) +
               " that does not hold it";
  }
  if (live_vertices != num_vertices_) return "live vertex count is out of date";

  // Boundary: each directed edge once and its reverse once (closed, consistently oriented), and
  // around each boundary vertex a single fan of triangles (a 2-manifold, no pinched vertex).
  // Hash maps: validate() runs after every tick under cut_replay --check.
  auto edgeKey = [](int a, int b) { return (static_cast<long long>(a) << 32) | unsigned(b); };
  std::unordered_map<long long, int> directed;
  std::unordered_map<int, std::vector<std::pair<int, int>>> fans;  // vertex -> (next, prev)
  directed.reserve(3 * static_cast<std::size_t>(num_boundary_faces_) + 1);
  fans.reserve(static_cast<std::size_t>(num_boundary_faces_) + 1);
  int boundary = 0;
  for (int t = 0; t < tetSlots(); ++t) {
    if (!tet_alive_[t]) continue;
    for (int f = 0; f < 4; ++f) {
      if (neighbors_[t][f] >= 0) continue;
      ++boundary;
      const TetVerts& tv = tets_[t];
      const int a = tv[kTetFace[f][0]], b = tv[kTetFace[f][1]], c = tv[kTetFace[f][2]];
      ++directed[edgeKey(a, b)];
      ++directed[edgeKey(b, c)];
      ++directed[edgeKey(c, a)];
      fans[a].emplace_back(b, c);
      fans[b].emplace_back(c, a);
      fans[c].emplace_back(a, b);
    }
  }
  if (boundary != num_boundary_faces_) return "boundary face count is out of date";
  for (int v = 0; v < vertexSlots(); ++v) {
    const auto fan = fans.find(v);
    const int through = fan == fans.end() ? 0 : static_cast<int>(fan->second.size());
    if (boundary_faces_[v] != through)
      return "vertex " + std::to_string(v) + " keeps " + std::to_string(boundary_faces_[v]) +
             " boundary faces through it where it has " + std::to_string(through);
  }
  for (const auto& [e, n] : directed) {
    const int a = static_cast<int>(e >> 32), b = static_cast<int>(e & 0xffffffff);
    if (n != 1)
      return "boundary edge (" + std::to_string(a) + ", " + std::to_string(b) + ") appears in " +
             std::to_string(n) + " boundary triangles with one orientation";
    if (!directed.count(edgeKey(b, a)))
      return "boundary is open at edge (" + std::to_string(a) + ", " + std::to_string(b) + ")";
  }
  for (const auto& [v, ring] : fans) {
    // Follow next -> prev links around v: one cycle must cover all its boundary triangles.
    int start = ring.front().second, cur = start, steps = 0;
    do {
      auto it =
          std::find_if(ring.begin(), ring.end(), [&](const auto& np) { return np.second == cur; });
      if (it == ring.end()) break;
      cur = it->first;
      ++steps;
    } while (cur != start && steps <= static_cast<int>(ring.size()));
    if (steps != static_cast<int>(ring.size()))
      return "boundary is pinched at vertex " + std::to_string(v) + " (" +
             std::to_string(ring.size()) + " triangles in more than one fan)";
  }
  return "";
}

}  // namespace tissue_cut
