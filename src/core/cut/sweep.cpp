#include "tissue_cut/cut/sweep.hpp"

#include <algorithm>
#include <cmath>

namespace tissue_cut {

std::array<Triangle, 2> sweptTriangles(const BladeSegment& from, const BladeSegment& to) {
  return {Triangle{from.base, from.tip, to.tip}, Triangle{from.base, to.tip, to.base}};
}

double triangleArea(const Triangle& t) { return 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).norm(); }

namespace {

// Barycentric coordinates of x (assumed in the plane) in the prepared triangle.
Vec3 barycentric(const Vec3& x, const PreparedTriangle& p) {
  const double u = p.n.dot(p.e12.cross(x - p.t[1])) / p.nn;
  const double v = p.n.dot(p.e20.cross(x - p.t[2])) / p.nn;
  return Vec3(u, v, 1.0 - u - v);
}

}  // namespace

bool segmentCrossesTriangle(const Vec3& p, const Vec3& q, const PreparedTriangle& prepared,
                            double margin, double* s, Vec3* bary) {
  const Triangle& t = prepared.t;
  const Vec3& n = prepared.n;
  const double len = prepared.len;
  if (!(len > 0)) return false;
  const double dp = n.dot(p - t[0]) / len, dq = n.dot(q - t[0]) / len;
  if (!((dp > 0 && dq < 0) || (dp < 0 && dq > 0))) return false;
  const double param = dp / (dp - dq);
  const Vec3 x = p + param * (q - p);
  const Vec3 b = barycentric(x, prepared);
  if (b.minCoeff() < -margin) return false;
  *s = param;
  *bary = b;
  return true;
}

double segmentSegmentDistance(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1) {
  // The squared distance between the points at parameters s and t is convex in (s, t): where the
  // lines' nearest points lie inside both segments they are the segments' too; else the nearest
  // points lie at an end of one segment. Nearly parallel segments, whose lines' nearest points
  // are ill-defined, take the ends.
  const Vec3 u = p1 - p0, v = q1 - q0, w = p0 - q0;
  const Vec3 n = u.cross(v);
  const double nn = n.squaredNorm();
  if (nn > 1e-24 * u.squaredNorm() * v.squaredNorm()) {
    // Line parameters of the nearest points (Cramer's rule on the normal equations).
    const double s = v.cross(w).dot(n) / nn, t = u.cross(w).dot(n) / nn;
    if (s > 0.0 && s < 1.0 && t > 0.0 && t < 1.0) return std::abs(w.dot(n)) / std::sqrt(nn);
  }
  // The nearest of the four ends' distances to the other segment: the least square, then its
  // root (the root is monotone: the same value as the least of the roots).
  const double uu = u.squaredNorm(), vv = v.squaredNorm();
  return std::sqrt(std::min({squaredDistanceToSegment(p0, q0, v, vv),
                             squaredDistanceToSegment(p1, q0, v, vv),
                             squaredDistanceToSegment(q0, p0, u, uu),
                             squaredDistanceToSegment(q1, p0, u, uu)}));
}

bool projectsInside(const Vec3& x, double d, const PreparedTriangle& prepared) {
  const Vec3 projected = x - d * prepared.n / prepared.len;
  return barycentric(projected, prepared).minCoeff() >= 0.0;
}

bool pointNearTriangle(const Vec3& x, const PreparedTriangle& prepared, double distance) {
  return PointOverTriangle(x, prepared).near(distance);
}

PreparedSegment::PreparedSegment(const Vec3& from, const Vec3& to)
    : base(from), tip(to), d(to - from) {
  finite = d.allFinite();
  lo = d.cwiseMin(Vec3::Zero());
  hi = d.cwiseMax(Vec3::Zero());
  len2 = d.squaredNorm();
  len = std::sqrt(len2);  // d.norm()
  if (len > 0) u = d / len;
}

double segmentTetGap(const Vec3& base, const Vec3& tip, const std::array<Vec3, 4>& corners,
                     double enough) {
  return segmentTetGap(PreparedSegment(base, tip), corners, enough);
}

double segmentTetGap(const PreparedSegment& s, const std::array<Vec3, 4>& corners,
                     double enough) {
  // Separating axes between the tet and the segment: the three coordinate axes, the segment's
  // own, the direction from its line to the tet's centroid and the tet's four face normals.
  // Along any unit axis, the gap between the two projections is at most the distance. The
  // cheaper axes first: a gap past `enough` ends the search.
  enough = std::max(enough, 0.0);  // (the answer is never below 0)
  std::array<Vec3, 4> p;
  for (int i = 0; i < 4; ++i) {
    p[i] = corners[i] - s.base;
    if (!p[i].allFinite()) return 0.0;  // a corner anywhere: no bound
  }
  const Vec3& d = s.d;
  if (!s.finite) return 0.0;
  Vec3 lo = p[0], hi = p[0];
  for (int i = 1; i < 4; ++i) {
    lo = lo.cwiseMin(p[i]);
    hi = hi.cwiseMax(p[i]);
  }
  double gap = std::max((lo - s.hi).maxCoeff(), (s.lo - hi).maxCoeff());
  if (gap > enough) return gap;
  const double len = s.len;
  if (len > 0) {
    const Vec3& u = s.u;
    double a = HUGE_VAL, z = -HUGE_VAL;
    for (const Vec3& q : p) {
      a = std::min(a, u.dot(q));
      z = std::max(z, u.dot(q));
    }
    gap = std::max({gap, a - len, -z});
    if (gap > enough) return gap;
    // Perpendicular to the segment, which projects to the single value 0 there. Only a positive
    // gap counts (the answer is never below 0): an axis is scaled to unit length only when its
    // gap is.
    const Vec3 c = 0.25 * (p[0] + p[1] + p[2] + p[3]);
    const Vec3 w = c - u.dot(c) * u;
    double m = HUGE_VAL;
    for (const Vec3& q : p) m = std::min(m, w.dot(q));
    if (m > 0) gap = std::max(gap, m / w.norm());
    if (gap > enough) return gap;
  }
  // Each face's outward normal: the segment's nearer end beyond the face's plane.
  for (int f = 0; f < 4; ++f) {
    const Vec3& a = p[kTetFace[f][0]];
    Vec3 n = (p[kTetFace[f][1]] - a).cross(p[kTetFace[f][2]] - a);
    if (n.dot(p[f] - a) > 0) n = -n;  // face f is the one opposite corner f
    const double g = std::min(n.dot(-a), n.dot(d - a));
    if (g > 0) gap = std::max(gap, g / n.norm());  // a flat face (n = 0) gives no gap
  }
  return gap > 0 ? gap : 0.0;
}

bool segmentMeetsTet(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c,
                     const Vec3& d, double tolerance) {
  TetPlanes planes;  // made for this one question
  return planes.meets(p, q, a, b, c, d, tolerance);
}

bool TetPlanes::meets(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c,
                      const Vec3& d, double tolerance) {
  // Clip the segment's parameter range against the four face planes (outward unit normals),
  // made only when the corners moved.
  const Vec3* const v[4] = {&a, &b, &c, &d};  // (not copied: most calls find the planes made)
  if (!valid_ || corner_[0] != a || corner_[1] != b || corner_[2] != c || corner_[3] != d) {
    const double orientation = signedVolume(a, b, c, d) >= 0 ? 1.0 : -1.0;
    for (int k = 0; k < 4; ++k) {
      const auto& f = kTetFace[k];
      Vec3 n = orientation * (*v[f[1]] - *v[f[0]]).cross(*v[f[2]] - *v[f[0]]);
      const double len = n.norm();
      normal_[k] = len > 0 ? Vec3(n / len) : Vec3::Zero();
      corner_[k] = *v[k];
    }
    valid_ = true;
    met_depth2_ = -1.0;
  } else if (met_depth2_ > 0.0 && tolerance == met_tolerance_ &&
             (p - met_p_).squaredNorm() < met_depth2_ && (q - met_q_).squaredNorm() < met_depth2_) {
    // The point at the same parameter moved less than its depth: inside still (most ticks).
    return true;
  }
  double lo = 0.0, hi = 1.0;
  for (int k = 0; k < 4; ++k) {
    if (normal_[k] == Vec3::Zero()) continue;  // a flat face (len not > 0)
    const Vec3& n = normal_[k];
    const Vec3& origin = *v[kTetFace[k][0]];
    const double dp = n.dot(p - origin) - tolerance;  // inside when <= 0
    const double dq = n.dot(q - origin) - tolerance;
    if (dp > 0 && dq > 0) return false;
    if (dp > 0) lo = std::max(lo, dp / (dp - dq));
    if (dq > 0) hi = std::min(hi, dp / (dp - dq));
    if (lo > hi) return false;
  }
  // Kept for the next call: the depth of the middle of the part inside, less a margin far above
  // the rounding of these sums (coordinates of up to `scale`).
  const Vec3 x = p + 0.5 * (lo + hi) * (q - p);
  double depth = HUGE_VAL, scale = std::max(p.cwiseAbs().maxCoeff(), q.cwiseAbs().maxCoeff());
  for (int k = 0; k < 4; ++k) {
    scale = std::max(scale, v[k]->cwiseAbs().maxCoeff());
    if (normal_[k] != Vec3::Zero())
      depth = std::min(depth, tolerance - normal_[k].dot(x - *v[kTetFace[k][0]]));
  }
  depth -= 1e-9 * scale;
  met_depth2_ = depth > 0.0 ? depth * depth : -1.0;
  met_tolerance_ = tolerance;
  met_p_ = p;
  met_q_ = q;
  return true;
}

}  // namespace tissue_cut
