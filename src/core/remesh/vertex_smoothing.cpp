#include "tissue_cut/remesh/vertex_smoothing.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include "tissue_cut/mesh/inline_vector.hpp"
#include "tissue_cut/mesh/quality.hpp"
#include "tissue_cut/remesh/edge_collapse.hpp"

namespace tissue_cut {

namespace {

constexpr double kSameNormal = 1e-9;  // 1 - cos of the largest angle between "parallel" faces

// The tet of `star` with v at `p` (rest positions).
std::array<Vec3, 4> restCorners(const TetMesh& mesh, int t, int v, const Vec3& p) {
  const TetVerts& tv = mesh.tet(t);
  std::array<Vec3, 4> c;
  for (int k = 0; k < 4; ++k) c[k] = tv[k] == v ? p : mesh.rest(tv[k]);
  return c;
}

// Worst rest Q of v's star with v at p; -1 when a tet is not sound. Stops at the first tet no
// better than `floor` (its Q is returned): the caller only wants to know whether p beats it.
// The tets are looked at in *order, the caller's guess of the likeliest to stop it first; the
// tet it stops at moves to the front (the trial positions lie close together, and the same tet
// tends to stop the next one). The order changes how soon a call stops, never what it answers.
// When it looks at every tet, (*q)[i] is the Q of star[i] and *worst_at the place in the star
// of the worst (the first of equals).
// Each star tet's fixed corners are prepared (`tets`) when it is first looked at (most tries
// look at a few tets once; a move looks at each ~5 times).
double worstWith(const TetMesh& mesh, const std::vector<int>& star, int v, const Vec3& p,
                 double floor, std::vector<int>* order, std::vector<double>* q, int* worst_at,
                 std::vector<MovingCornerTet>* tets, std::vector<char>* prepared) {
  double worst = 1.0;  // Q is at most 1: after the first look, the lowest Q seen
  for (auto it = order->begin(); it != order->end(); ++it) {
    const int i = *it;
    if (!(*prepared)[i]) {
      (*prepared)[i] = 1;
      (*tets)[i] =
          MovingCornerTet(restCorners(mesh, star[i], v, p), localIndex(mesh.tet(star[i]), v));
    }
    const double qi = (*tets)[i].soundQuality(p, kMinCollapseRelativeVolume);
    if (qi < 0.0) {
      worst = -1.0;  // not sound
    } else {
      (*q)[i] = qi;
      if (qi < worst || (qi == worst && i < *worst_at)) *worst_at = i;
      worst = std::min(worst, qi);
    }
    if (worst <= floor) {
      std::rotate(order->begin(), it, it + 1);
      return worst;
    }
  }
  return worst;
}

// smoothVertex()'s lists, one a thread, kept for their room. Not inlined: its caller then holds
// a plain pointer (each lookup of a thread_local in a shared library is a call).
struct SmoothingScratch {
  std::vector<double> q;              // per place in the star
  std::vector<int> order;             // the star's places in the order worstWith() looks at them
  std::vector<MovingCornerTet> tets;  // per place, prepared when first looked at
  std::vector<char> prepared;         // per place, whether tets[place] is prepared
};
[[gnu::noinline]] SmoothingScratch& smoothingScratch() {
  thread_local SmoothingScratch scratch;
  return scratch;
}

// The star's three worst places by their Q in q first, worst first (the first of equals first);
// the others after them in no particular order. The order is only the trials' guess of the tets
// likeliest to stop them (see worstWith()): the three worst served as well as the whole star
// sorted (79.49 M instructions on the 20k replay against 79.52 M; the worst alone 80.78 M, two
// 79.75 M, four 79.51 M, six 79.62 M), and their selection mispredicts fewer branches than the
// sort's (the queue 1.5% faster, 24 pinned pairs).
void putWorstFirst(const std::vector<double>& q, std::vector<int>* order) {
  const auto k = std::min<std::ptrdiff_t>(3, static_cast<std::ptrdiff_t>(order->size()));
  std::partial_sort(order->begin(), order->begin() + k, order->end(), [&](int a, int b) {
    return q[a] < q[b] || (q[a] == q[b] && a < b);
  });
}

// The point that makes tet t regular-looking over the face opposite v: above the face's centroid
// at the height of a regular tet with the face's mean edge.
Vec3 idealApex(const TetMesh& mesh, int t, int v) {
  const TetVerts& tv = mesh.tet(t);
  const int i = localIndex(tv, v);
  const Vec3& a = mesh.rest(tv[kTetFace[i][0]]);
  const Vec3& b = mesh.rest(tv[kTetFace[i][1]]);
  const Vec3& c = mesh.rest(tv[kTetFace[i][2]]);
  const Vec3 outward = (b - a).cross(c - a);  // out of the tet, so v lies on the other side
  const double edge = ((a - b).norm() + (b - c).norm() + (c - a).norm()) / 3.0;
  const double n = outward.norm();
  if (!(n > 0)) return mesh.rest(v);
  return (a + b + c) / 3.0 - outward / n * (std::sqrt(2.0 / 3.0) * edge);
}

Vec3 project(VertexFreedom freedom, const Vec3& dir, const Vec3& from, const Vec3& p) {
  switch (freedom) {
    case VertexFreedom::kInterior:
      return p;
    case VertexFreedom::kPlane:
      return p - dir * dir.dot(p - from);
    case VertexFreedom::kLine:
      return from + dir * dir.dot(p - from);
    case VertexFreedom::kPinned:
      break;
  }
  return from;
}

}  // namespace

VertexFreedom vertexFreedom(const TetMesh& mesh, int v, Vec3* direction) {
  if (mesh.boundaryFacesAt(v) == 0) return VertexFreedom::kInterior;  // (no face to look at)
  InlineVector<Vec3, 3> planes;  // a third one pins v
  for (int t : mesh.vertexTets(v)) {
    const TetVerts& tv = mesh.tet(t);
    const int i = localIndex(tv, v);
    for (int f = 0; f < 4; ++f) {
      if ((f == i) | (mesh.neighbor(t, f) >= 0)) continue;  // (one branch, mostly taken)
      const Vec3& a = mesh.rest(tv[kTetFace[f][0]]);
      const Vec3 n = (mesh.rest(tv[kTetFace[f][1]]) - a).cross(mesh.rest(tv[kTetFace[f][2]]) - a);
      if (!(n.norm() > 0)) return VertexFreedom::kPinned;
      const Vec3 u = n.normalized();
      bool known = false;
      for (const Vec3& w : planes) known = known || u.dot(w) >= 1.0 - kSameNormal;
      if (!known) planes.push_back(u);
      if (planes.size() > 2) return VertexFreedom::kPinned;
    }
  }
  if (planes.empty()) return VertexFreedom::kInterior;
  if (planes.size() == 1) {
    if (direction) *direction = planes[0];
    return VertexFreedom::kPlane;
  }
  const Vec3 line = planes[0].cross(planes[1]);
  // Nearly opposite normals: both faces of a cut meet at v (a crack front), which must stay.
  if (line.norm() < 1e-3) return VertexFreedom::kPinned;
  if (direction) *direction = line.normalized();
  return VertexFreedom::kLine;
}

bool smoothVertex(TetMesh* mesh, int v, double min_gain, ChangeRecord* record,
                  SmoothingCheck* check) {
  SmoothingCheck out;
  // The mesh's own list (nothing below changes it before moveVertex(), the last use).
  const std::vector<int>& star = mesh->vertexTets(v);
  // The star's qualities where v is: the worst, and the first tet that has it.
  double lowest = 2.0;
  int worst_at = 0;
  SmoothingScratch& scratch = smoothingScratch();
  std::vector<double>& star_q = scratch.q;
  star_q.resize(star.size());
  for (int i = 0; i < static_cast<int>(star.size()); ++i) {
    const double q = restQuality(*mesh, star[i]);
    star_q[i] = q;
    if (q < lowest) lowest = q, worst_at = i;
  }
  out.worst_before = std::min(1.0, lowest);
  out.worst_after = out.worst_before;
  Vec3 dir = Vec3::Zero();
  out.freedom = vertexFreedom(*mesh, v, &dir);
  if (check) *check = out;
  if (out.freedom == VertexFreedom::kPinned || star.empty()) return false;

  const Vec3 origin = mesh->rest(v);
  Vec3 mean_link = Vec3::Zero(), mean_ideal = Vec3::Zero();
  int links = 0;
  for (int t : star) {
    for (int u : mesh->tet(t))
      if (u != v) {
        mean_link += mesh->rest(u);
        ++links;
      }
    mean_ideal += idealApex(*mesh, t, v);
  }
  mean_link /= links;
  mean_ideal /= static_cast<double>(star.size());

  Vec3 best = origin;
  double best_q = out.worst_before;
  // The trial positions lie close together: the tets worst at the best position so far are the
  // likeliest to stop a trial that does not beat it. Looked at from the worst where the vertex
  // is; each new best position's worst tet then goes to the front (sorting the star again at
  // each one looked at no fewer tets and cost 0.4 M instructions on the 20k replay).
  std::vector<int>& order = scratch.order;
  order.resize(star.size());
  std::iota(order.begin(), order.end(), 0);
  putWorstFirst(star_q, &order);
  scratch.tets.resize(star.size());
  scratch.prepared.assign(star.size(), 0);
  for (int round = 0; round < 4; ++round) {
    // The worst tet at the best position so far (known from the look that made it the best).
    const int worst_t = worst_at;
    // The worst tet's ideal apex as seen from the current best position's opposite face.
    const Vec3 targets[3] = {mean_ideal, mean_link, idealApex(*mesh, star[worst_t], v)};
    const Vec3 from = best;
    bool improved = false;
    for (const Vec3& target : targets)
      for (double step : {1.0, 0.5, 0.25, 0.125}) {
        const Vec3 p = project(out.freedom, dir, origin, from + step * (target - from));
        int at = static_cast<int>(star.size());
        const double q = worstWith(*mesh, star, v, p, best_q + 1e-12, &order, &star_q, &at,
                                   &scratch.tets, &scratch.prepared);
        if (q > best_q + 1e-12) {  // every tet was looked at: `at` is the worst's place
          best_q = q;
          best = p;
          worst_at = at;
          improved = true;
          // The worst tet at the new best position first; the others keep their order.
          const auto worst = std::find(order.begin(), order.end(), worst_at);
          std::rotate(order.begin(), worst, worst + 1);
        }
      }
    if (!improved) break;
  }
  if (!(best_q >= out.worst_before + min_gain)) return false;

  // Rest volume: exact for an interior vertex; a boundary vertex must have stayed on its patch.
  if (out.freedom != VertexFreedom::kInterior) {
    double before = 0.0, after = 0.0;
    for (int t : star) {
      before += mesh->restVolume(t);
      const auto c = restCorners(*mesh, t, v, best);
      after += signedVolume(c[0], c[1], c[2], c[3]);
    }
    if (std::abs(after - before) > 1e-9 * before) return false;
  }

  // The material point at `best`: barycentric weights in the old star tet holding it.
  VertexParents parents;
  double best_min = -1e300;
  for (int t : star) {
    const TetVerts& tv = mesh->tet(t);
    const Vec3 &a = mesh->rest(tv[0]), &b = mesh->rest(tv[1]), &c = mesh->rest(tv[2]),
               &d = mesh->rest(tv[3]);
    const double vol = signedVolume(a, b, c, d);
    const double w[4] = {signedVolume(best, b, c, d) / vol, signedVolume(a, best, c, d) / vol,
                         signedVolume(a, b, best, d) / vol, signedVolume(a, b, c, best) / vol};
    const double m = std::min(std::min(w[0], w[1]), std::min(w[2], w[3]));
    if (m > best_min) {
      best_min = m;
      parents = {{tv[0], w[0]}, {tv[1], w[1]}, {tv[2], w[2]}, {tv[3], w[3]}};
    }
  }
  if (best_min < -1e-9) return false;  // outside the star: cannot be (sound tets cover it)
  Vec3 current = Vec3::Zero();
  for (const VertexParent& p : parents) current += p.weight * mesh->current(p.vertex);
  for (int t : star) {
    const TetVerts& tv = mesh->tet(t);
    Vec3 c[4];
    for (int k = 0; k < 4; ++k) c[k] = tv[k] == v ? current : mesh->current(tv[k]);
    if (!isSoundTet(c[0], c[1], c[2], c[3])) return false;
  }
  mesh->moveVertex(v, parents, record);
  out.moved = true;
  out.worst_after = best_q;
  out.target = mesh->rest(v);
  if (check) *check = out;
  return true;
}

}  // namespace tissue_cut
