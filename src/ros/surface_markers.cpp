#include "surface_markers.hpp"

#include <algorithm>
#include <cmath>

#include "tissue_cut/mesh/quality.hpp"

namespace tissue_cut {

void takeSnapshot(const Tissue& tissue, const std::optional<BladeSegment>& blade,
                  SurfaceSnapshot* s) {
  const TetMesh& mesh = tissue.mesh();
  const std::vector<unsigned char>& region = tissue.cutRegion();
  const double tau = tissue.config().collapse.tau;
  s->faces.clear();
  s->face_quality.clear();
  s->queued_edges.clear();
  s->current = mesh.currentPositions();
  s->rest = mesh.restPositions();
  s->blade = blade;
  for (int t = 0; t < mesh.tetSlots(); ++t) {
    if (!mesh.tetAlive(t)) continue;
    const TetVerts& v = mesh.tet(t);
    const bool in_region = t < static_cast<int>(region.size()) && region[t];
    double q = -1.0;
    for (int f = 0; f < 4; ++f) {
      if (mesh.neighbor(t, f) >= 0) continue;
      if (q < 0) q = restQuality(mesh, t);
      s->faces.push_back({v[kTetFace[f][0]], v[kTetFace[f][1]], v[kTetFace[f][2]]});
      s->face_quality.push_back(static_cast<float>(q));
    }
    if (!in_region) continue;
    if (q < 0) q = restQuality(mesh, t);
    if (q >= tau) continue;
    // The edge the collapse queue holds for this tet: its shortest (rest lengths).
    int best = 0;
    double shortest = INFINITY;
    for (int e = 0; e < 6; ++e) {
      const double len =
          (mesh.rest(v[kTetEdge[e][0]]) - mesh.rest(v[kTetEdge[e][1]])).squaredNorm();
      if (len < shortest) shortest = len, best = e;
    }
    s->queued_edges.emplace_back(v[kTetEdge[best][0]], v[kTetEdge[best][1]]);
  }
}

SkinClassifier::SkinClassifier(const TetMesh& uncut) {
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
  double edge_sum = 0.0;
  for (int t = 0; t < uncut.tetSlots(); ++t) {
    if (!uncut.tetAlive(t)) continue;
    for (int f = 0; f < 4; ++f) {
      if (uncut.neighbor(t, f) >= 0) continue;
      std::array<Vec3, 3> tri;
      for (int i = 0; i < 3; ++i) {
        tri[i] = uncut.rest(uncut.tet(t)[kTetFace[f][i]]);
        lo = lo.cwiseMin(tri[i]);
        hi = hi.cwiseMax(tri[i]);
      }
      edge_sum += (tri[1] - tri[0]).norm();
      triangles_.push_back(tri);
    }
  }
  if (triangles_.empty()) return;
  const double mean_edge = edge_sum / triangles_.size();
  cell_ = std::max(2.0 * mean_edge, 1e-9);
  tolerance_ = 1e-4 * mean_edge;
  origin_ = lo;
  for (std::size_t i = 0; i < triangles_.size(); ++i) {
    Vec3 a = triangles_[i][0].cwiseMin(triangles_[i][1]).cwiseMin(triangles_[i][2]);
    Vec3 b = triangles_[i][0].cwiseMax(triangles_[i][1]).cwiseMax(triangles_[i][2]);
    const Eigen::Vector3i c0 = ((a - origin_) / cell_).array().floor().cast<int>();
    const Eigen::Vector3i c1 = ((b - origin_) / cell_).array().floor().cast<int>();
    for (int x = c0.x(); x <= c1.x(); ++x)
      for (int y = c0.y(); y <= c1.y(); ++y)
        for (int z = c0.z(); z <= c1.z(); ++z) cells_[cellKey(x, y, z)].push_back(int(i));
  }
}

long long SkinClassifier::cellKey(int i, int j, int k) const {
  return (static_cast<long long>(i + (1 << 20)) << 42) ^
         (static_cast<long long>(j + (1 << 20)) << 21) ^ static_cast<long long>(k + (1 << 20));
}

bool SkinClassifier::onSkin(const Vec3& p) const {
  const Eigen::Vector3i c = ((p - origin_) / cell_).array().floor().cast<int>();
  auto it = cells_.find(cellKey(c.x(), c.y(), c.z()));
  if (it == cells_.end()) return false;
  for (int i : it->second) {
    const std::array<Vec3, 3>& tri = triangles_[i];
    const Vec3 n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
    const double area2 = n.norm();
    if (area2 <= 0) continue;
    if (std::abs(n.dot(p - tri[0])) / area2 > tolerance_) continue;
    // Barycentric coordinates of p's projection; a point on an edge counts as inside.
    const double slack = 1e-6;
    const double w0 = n.dot((tri[1] - p).cross(tri[2] - p)) / (area2 * area2);
    const double w1 = n.dot((tri[2] - p).cross(tri[0] - p)) / (area2 * area2);
    if (w0 >= -slack && w1 >= -slack && 1.0 - w0 - w1 >= -slack) return true;
  }
  return false;
}

bool SkinClassifier::isSkin(const std::array<int, 3>& face, const std::vector<Vec3>& rest) {
  const std::array<int, 3> key = sortedFace(face[0], face[1], face[2]);
  auto it = cache_.find(key);
  if (it != cache_.end()) return it->second;
  if (cache_.size() > 1000000) cache_.clear();  // bounded: faces of a long session come and go
  const bool skin = onSkin((rest[face[0]] + rest[face[1]] + rest[face[2]]) / 3.0);
  cache_.emplace(key, skin);
  return skin;
}

namespace {

std_msgs::ColorRGBA rgba(float r, float g, float b, float a = 1.0f) {
  std_msgs::ColorRGBA c;
  c.r = r, c.g = g, c.b = b, c.a = a;
  return c;
}

geometry_msgs::Point point(const Vec3& p) {
  geometry_msgs::Point q;
  q.x = p.x(), q.y = p.y(), q.z = p.z();
  return q;
}

std_msgs::ColorRGBA qualityColor(float q) {  // red (0) through yellow (0.5) to green (1)
  q = std::clamp(q, 0.0f, 1.0f);
  return q < 0.5f ? rgba(0.9f, 1.8f * q, 0.1f) : rgba(1.8f * (1.0f - q), 0.9f, 0.1f);
}

void header(visualization_msgs::Marker* m, const MarkerStyle& style, const ros::Time& stamp,
            const char* ns, int id, int type) {
  m->header.frame_id = style.frame_id;
  m->header.stamp = stamp;
  m->ns = ns;
  m->id = id;
  m->type = type;
  m->pose.orientation.w = 1.0;
  m->pose.position.x = m->pose.position.y = m->pose.position.z = 0.0;
  m->pose.orientation.x = m->pose.orientation.y = m->pose.orientation.z = 0.0;
  m->frame_locked = false;
}

}  // namespace

void buildMarkers(const SurfaceSnapshot& s, const MarkerStyle& style, SkinClassifier* skin,
                  const ros::Time& stamp, visualization_msgs::MarkerArray* out) {
  out->markers.resize(3);
  const std_msgs::ColorRGBA skin_color = rgba(0.93f, 0.67f, 0.60f);
  const std_msgs::ColorRGBA wall_color = rgba(0.62f, 0.08f, 0.12f);

  visualization_msgs::Marker& surface = out->markers[0];
  header(&surface, style, stamp, "surface", 0, visualization_msgs::Marker::TRIANGLE_LIST);
  surface.action = visualization_msgs::Marker::ADD;
  surface.scale.x = surface.scale.y = surface.scale.z = 1.0;
  surface.color = skin_color;
  surface.points.resize(3 * s.faces.size());
  surface.colors.resize(3 * s.faces.size());
  for (std::size_t f = 0; f < s.faces.size(); ++f) {
    const std_msgs::ColorRGBA c = style.color_by_quality     ? qualityColor(s.face_quality[f])
                                  : skin->isSkin(s.faces[f], s.rest) ? skin_color
                                                                     : wall_color;
    for (int i = 0; i < 3; ++i) {
      surface.points[3 * f + i] = point(s.current[s.faces[f][i]]);
      surface.colors[3 * f + i] = c;
    }
  }

  visualization_msgs::Marker& queue = out->markers[1];
  header(&queue, style, stamp, "collapse_queue", 1, visualization_msgs::Marker::LINE_LIST);
  queue.scale.x = 0.0004;
  queue.color = rgba(0.1f, 0.85f, 0.2f);
  queue.points.clear();
  queue.colors.clear();
  if (style.show_collapse_queue)
    for (const auto& e : s.queued_edges) {
      queue.points.push_back(point(s.current[e.first]));
      queue.points.push_back(point(s.current[e.second]));
    }
  queue.action = queue.points.empty() ? visualization_msgs::Marker::DELETE
                                      : visualization_msgs::Marker::ADD;

  visualization_msgs::Marker& blade = out->markers[2];
  header(&blade, style, stamp, "blade", 2, visualization_msgs::Marker::LINE_LIST);
  blade.scale.x = 0.001;
  blade.color = rgba(0.75f, 0.78f, 0.82f);
  blade.points.clear();
  if (s.blade) {
    blade.points.push_back(point(s.blade->base));
    blade.points.push_back(point(s.blade->tip));
  }
  blade.action = blade.points.empty() ? visualization_msgs::Marker::DELETE
                                      : visualization_msgs::Marker::ADD;
}

}  // namespace tissue_cut
