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

namespace {

// Q from the four faces' squared doubled areas (bc x bd, ac x ad, ab x ad, ab x ac: opposite
// a, b, c and d), the squared edge lengths and D = 6 V (see tetQuality).
inline double qualityOfFaces(Eigen::Array4d faces, double ab2, double ac2, double ad2, double bc2,
                             double bd2, double cd2, double det) {
  Eigen::Array4d lengths;
  lengths << ab2 * cd2, ac2 * bd2, ad2 * bc2, 0.0;
  faces = faces.sqrt();
  lengths = lengths.sqrt();
  const double area2 = faces.sum();
  const double p = lengths[0], q = lengths[1], r = lengths[2];
  const double s = 0.5 * (p + q + r);
  const double heron = s * (s - p) * (s - q) * (s - r);
  const double det2 = det * det;
  if (!(area2 > 0) || !(det2 > 0) || !(heron > 0)) return 0.0;
  const double quality = 3.0 * det2 / (area2 * std::sqrt(heron));
  if (!std::isfinite(quality)) return 0.0;
  return std::min(1.0, quality);
}

// The same from a tet's edge vectors (ab = b - a, ...; cd only through its length).
inline double qualityOf(const Vec3& ab, const Vec3& ac, const Vec3& ad, const Vec3& bc,
                        const Vec3& bd, double ab2, double ac2, double ad2, double bc2, double bd2,
                        double cd2, double det) {
  Eigen::Array4d faces;
  faces << bc.cross(bd).squaredNorm(), ac.cross(ad).squaredNorm(), ab.cross(ad).squaredNorm(),
      ab.cross(ac).squaredNorm();
  return qualityOfFaces(faces, ab2, ac2, ad2, bc2, bd2, cd2, det);
}

}  // namespace

double tetQuality(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  // Q = 3 r_in / r_circ with r_in = 3 V / A and r_circ = sqrt(H) / (6 V) (A: the faces' total
  // area, H: Heron's product over the three products of opposite edge lengths) is
  // 54 V^2 / (A sqrt(H)) = 3 D^2 / (2A sqrt(H)) with D = 6 V. The remeshers ask for a few million
  // of these a second: the four doubled face areas and the three length products are taken as
  // square roots of squares, four at a time (Eigen's packet sqrt), and there is one division.
  const Vec3 ab = b - a, ac = c - a, ad = d - a, bc = c - b, bd = d - b, cd = d - c;
  return qualityOf(ab, ac, ad, bc, bd, ab.squaredNorm(), ac.squaredNorm(), ad.squaredNorm(),
                   bc.squaredNorm(), bd.squaredNorm(), cd.squaredNorm(), ab.dot(ac.cross(ad)));
}

double soundTetQuality(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                       double min_relative_volume) {
  // The edge vectors, their lengths and the volume serve both questions (the same operations
  // as signedVolume() and tetQuality(): the same values).
  const Vec3 ab = b - a, ac = c - a, ad = d - a, bc = c - b, bd = d - b, cd = d - c;
  const double ab2 = ab.squaredNorm(), ac2 = ac.squaredNorm(), ad2 = ad.squaredNorm();
  const double bc2 = bc.squaredNorm(), bd2 = bd.squaredNorm(), cd2 = cd.squaredNorm();
  const double det = ab.dot(ac.cross(ad));
  const double vol = det / 6.0;
  if (!soundVolume(vol, std::max({ab2, ac2, ad2, bc2, bd2, cd2}), min_relative_volume))
    return -1.0;
  return qualityOf(ab, ac, ad, bc, bd, ab2, ac2, ad2, bc2, bd2, cd2, det);
}

MovingCornerTet::MovingCornerTet(const std::array<Vec3, 4>& corners, int moving)
    : corner_(corners), moving_(moving) {
  const Vec3 &a = corners[0], &b = corners[1], &c = corners[2], &d = corners[3];
  // The face opposite the moving corner: bc x bd, ac x ad, ab x ad or ab x ac.
  switch (moving) {
    case 0:
      edge_[3] = c - b, edge_[4] = d - b, edge_[5] = d - c;
      face_ = edge_[3].cross(edge_[4]);
      break;
    case 1:
      edge_[1] = c - a, edge_[2] = d - a, edge_[5] = d - c;
      face_ = edge_[1].cross(edge_[2]);
      break;
    case 2:
      edge_[0] = b - a, edge_[2] = d - a, edge_[4] = d - b;
      face_ = edge_[0].cross(edge_[2]);
      break;
    default:
      edge_[0] = b - a, edge_[1] = c - a, edge_[3] = c - b;
      face_ = edge_[0].cross(edge_[1]);
      break;
  }
  for (int e = 0; e < 6; ++e) len2_[e] = edge_[e].squaredNorm();  // the moving ones not read
  face2_ = face_.squaredNorm();
}

template <int kMoving>
double MovingCornerTet::soundQualityAt(const Vec3& p, double min_relative_volume) const {
  // The moving corner's three edges (as soundTetQuality() takes them from the corners), the
  // others kept.
  const Vec3 &a = corner_[0], &b = corner_[1], &c = corner_[2], &d = corner_[3];
  const Vec3 ab = kMoving == 0 ? Vec3(b - p) : kMoving == 1 ? Vec3(p - a) : edge_[0];
  const Vec3 ac = kMoving == 0 ? Vec3(c - p) : kMoving == 2 ? Vec3(p - a) : edge_[1];
  const Vec3 ad = kMoving == 0 ? Vec3(d - p) : kMoving == 3 ? Vec3(p - a) : edge_[2];
  const Vec3 bc = kMoving == 1 ? Vec3(c - p) : kMoving == 2 ? Vec3(p - b) : edge_[3];
  const Vec3 bd = kMoving == 1 ? Vec3(d - p) : kMoving == 3 ? Vec3(p - b) : edge_[4];
  const Vec3 cd = kMoving == 2 ? Vec3(d - p) : kMoving == 3 ? Vec3(p - c) : edge_[5];
  const double ab2 = kMoving <= 1 ? ab.squaredNorm() : len2_[0];
  const double ac2 = kMoving == 0 || kMoving == 2 ? ac.squaredNorm() : len2_[1];
  const double ad2 = kMoving == 0 || kMoving == 3 ? ad.squaredNorm() : len2_[2];
  const double bc2 = kMoving == 1 || kMoving == 2 ? bc.squaredNorm() : len2_[3];
  const double bd2 = kMoving == 1 || kMoving == 3 ? bd.squaredNorm() : len2_[4];
  const double cd2 = kMoving >= 2 ? cd.squaredNorm() : len2_[5];
  const Vec3 acad = kMoving == 1 ? face_ : Vec3(ac.cross(ad));
  const double det = ab.dot(acad);
  if (!soundVolume(det / 6.0, std::max({ab2, ac2, ad2, bc2, bd2, cd2}), min_relative_volume))
    return -1.0;
  Eigen::Array4d faces;
  faces << (kMoving == 0 ? face2_ : bc.cross(bd).squaredNorm()),
      (kMoving == 1 ? face2_ : acad.squaredNorm()),
      (kMoving == 2 ? face2_ : ab.cross(ad).squaredNorm()),
      (kMoving == 3 ? face2_ : ab.cross(ac).squaredNorm());
  return qualityOfFaces(faces, ab2, ac2, ad2, bc2, bd2, cd2, det);
}

double MovingCornerTet::soundQuality(const Vec3& p, double min_relative_volume) const {
  switch (moving_) {
    case 0:
      return soundQualityAt<0>(p, min_relative_volume);
    case 1:
      return soundQualityAt<1>(p, min_relative_volume);
    case 2:
      return soundQualityAt<2>(p, min_relative_volume);
    default:
      return soundQualityAt<3>(p, min_relative_volume);
  }
}

double restQuality(const TetMesh& mesh, int t) { return mesh.restQuality(t); }

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
