#include "tissue_cut/mesh/quality.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace tissue_cut {

namespace {

inline double faceArea(const Vec3& a, const Vec3& b, const Vec3& c) {
  return 0.5 * (b - a).cross(c - a).norm();
}

}  // namespace

double tetInradius(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const double area = faceArea(b, c, d) + faceArea(a, c, d) + faceArea(a, b, d) + faceArea(a, b, c);
  if (!(area > 0)) return 0.0;
  return 3.0 * std::abs(signedVolume(a, b, c, d)) / area;
}

double tetCircumradius(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  // 24 V R = sqrt of Heron's product over the three products of opposite edge lengths.
  const double p = (b - a).norm() * (d - c).norm();
  const double q = (c - a).norm() * (d - b).norm();
  const double r = (d - a).norm() * (c - b).norm();
  const double s = 0.5 * (p + q + r);
  const double heron = std::max(0.0, s * (s - p) * (s - q) * (s - r));
  const double vol = std::abs(signedVolume(a, b, c, d));
  if (!(vol > 0)) return std::numeric_limits<double>::infinity();
  return std::sqrt(heron) / (6.0 * vol);
}

double tetQuality(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  // tetInradius and tetCircumradius written out with the volume taken once (the same operations:
  // the same value); the remeshers ask for a few million of these a second.
  const double vol = std::abs(signedVolume(a, b, c, d));
  const double area = faceArea(b, c, d) + faceArea(a, c, d) + faceArea(a, b, d) + faceArea(a, b, c);
  if (!(area > 0)) return 0.0;
  const double r_in = 3.0 * vol / area;
  if (!(r_in > 0) || !(vol > 0)) return 0.0;
  const double p = (b - a).norm() * (d - c).norm();
  const double q = (c - a).norm() * (d - b).norm();
  const double r = (d - a).norm() * (c - b).norm();
  const double s = 0.5 * (p + q + r);
  const double heron = std::max(0.0, s * (s - p) * (s - q) * (s - r));
  const double r_circ = std::sqrt(heron) / (6.0 * vol);
  if (!std::isfinite(r_circ) || !(r_circ > 0)) return 0.0;
  return std::min(1.0, 3.0 * r_in / r_circ);
}

double restQuality(const TetMesh& mesh, int t) {
  const TetVerts& v = mesh.tet(t);
  return tetQuality(mesh.rest(v[0]), mesh.rest(v[1]), mesh.rest(v[2]), mesh.rest(v[3]));
}

double currentQuality(const TetMesh& mesh, int t) {
  const TetVerts& v = mesh.tet(t);
  return tetQuality(mesh.current(v[0]), mesh.current(v[1]), mesh.current(v[2]), mesh.current(v[3]));
}

std::array<int, 2> shortestRestEdge(const TetMesh& mesh, int t) {
  const TetVerts& v = mesh.tet(t);
  std::array<int, 2> best{v[0], v[1]};
  double best_len = std::numeric_limits<double>::infinity();
  for (const auto& e : kTetEdge) {
    const double len = (mesh.rest(v[e[0]]) - mesh.rest(v[e[1]])).squaredNorm();
    if (len < best_len) {
      best_len = len;
      best = {v[e[0]], v[e[1]]};
    }
  }
  return best;
}

QualitySummary summarizeQuality(const TetMesh& mesh, double tau,
                                const std::vector<unsigned char>* flag) {
  QualitySummary s;
  double sum = 0.0;
  s.min = std::numeric_limits<double>::infinity();
  for (int t = 0; t < mesh.tetSlots(); ++t) {
    if (!mesh.tetAlive(t)) continue;
    if (flag && (t >= static_cast<int>(flag->size()) || !(*flag)[t])) continue;
    const double q = restQuality(mesh, t);
    s.min = std::min(s.min, q);
    sum += q;
    ++s.count;
    if (q < tau) ++s.below_tau;
    ++s.histogram[std::min(9, static_cast<int>(q * 10.0))];
  }
  if (s.count == 0) {
    s.min = 0.0;
    return s;
  }
  s.mean = sum / s.count;
  return s;
}

}  // namespace tissue_cut
