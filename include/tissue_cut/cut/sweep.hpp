// Geometry of the blade's sweep: the bilinear quad between two blade positions as two triangles,
// and the intersection tests the cutter needs.
#pragma once

#include <array>
#include <cmath>
#include <limits>

#include "tissue_cut/cut/blade.hpp"
#include "tissue_cut/mesh/tet_mesh.hpp"

namespace tissue_cut {

using Triangle = std::array<Vec3, 3>;

/// The quad swept from `from` to `to` as two triangles (base0, tip0, tip1) and (base0, tip1,
/// base1).
std::array<Triangle, 2> sweptTriangles(const BladeSegment& from, const BladeSegment& to);

/// Area of a triangle [m^2].
double triangleArea(const Triangle& t);

/// A triangle with its normal n = (t[1] - t[0]) x (t[2] - t[0]), |n|, |n|^2 and the edges the
/// barycentric coordinates take (t[2] - t[1], t[0] - t[2]), for many tests against one triangle
/// (a tick's swept triangles): the tests below take the same values either way.
struct PreparedTriangle {
  explicit PreparedTriangle(const Triangle& triangle)
      : t(triangle),
        n((t[1] - t[0]).cross(t[2] - t[0])),
        len(n.norm()),
        nn(n.squaredNorm()),
        e12(t[2] - t[1]),
        e20(t[0] - t[2]) {}
  Triangle t;
  Vec3 n;
  double len;
  double nn;
  Vec3 e12, e20;
};

/// Where segment p->q crosses triangle t: true with the segment parameter s in [0, 1] and the
/// barycentric coordinates of the crossing, when p and q lie strictly on opposite sides of the
/// triangle's plane and the crossing is inside the triangle grown by `margin` (barycentric).
bool segmentCrossesTriangle(const Vec3& p, const Vec3& q, const PreparedTriangle& t, double margin,
                            double* s, Vec3* barycentric);
inline bool segmentCrossesTriangle(const Vec3& p, const Vec3& q, const Triangle& t, double margin,
                                   double* s, Vec3* barycentric) {
  return segmentCrossesTriangle(p, q, PreparedTriangle(t), margin, s, barycentric);
}

/// True when x is within `distance` [m] of the triangle's plane and projects inside it.
bool pointNearTriangle(const Vec3& x, const PreparedTriangle& t, double distance);
inline bool pointNearTriangle(const Vec3& x, const Triangle& t, double distance) {
  return pointNearTriangle(x, PreparedTriangle(t), distance);
}

/// Whether x, `d` [m] from the triangle's plane along n / |n|, projects inside the triangle.
bool projectsInside(const Vec3& x, double d, const PreparedTriangle& t);

/// pointNearTriangle() of one point and one triangle at several distances: the distance from
/// the plane and where the point projects are found once, when first needed (the same values).
/// Holds x and t by reference: they must outlive it.
class PointOverTriangle {
 public:
  PointOverTriangle(const Vec3& x, const PreparedTriangle& t) : x_(x), t_(t) {}
  /// pointNearTriangle(x, t, distance).
  bool near(double distance) const {
    if (!measured_) {
      measured_ = true;
      if (t_.len > 0) d_ = t_.n.dot(x_ - t_.t[0]) / t_.len;  // else NaN: near nothing
    }
    if (!(std::abs(d_) <= distance)) return false;
    if (inside_ < 0) inside_ = projectsInside(x_, d_, t_) ? 1 : 0;
    return inside_ == 1;
  }

 private:
  const Vec3& x_;
  const PreparedTriangle& t_;
  mutable bool measured_ = false;
  mutable double d_ = std::numeric_limits<double>::quiet_NaN();
  mutable signed char inside_ = -1;  // not known yet
};

/// A lower bound of the distance [m] between segment base->tip and the tet with these corners
/// (separating axes: coordinate axes, the segment's, towards the tet, the tet's face normals);
/// 0 when they may meet or a corner is not finite. Once an axis gives a bound above `enough`
/// [m], that bound is returned without trying the others (it may then be lower than with
/// `enough` infinite, never lower than `enough`).
double segmentTetGap(const Vec3& base, const Vec3& tip, const std::array<Vec3, 4>& corners,
                     double enough = HUGE_VAL);

/// A segment base->tip prepared for many segmentTetGap() calls and point distances (a blade
/// against each tet or vertex near it): what depends on the segment alone is computed once (the
/// same values as the calls on its two ends).
struct PreparedSegment {
  PreparedSegment() = default;
  PreparedSegment(const Vec3& from, const Vec3& to);  // base, tip
  /// distanceToSegment(x, base, tip).
  double distanceTo(const Vec3& x) const {
    return std::sqrt(squaredDistanceToSegment(x, base, d, len2));
  }
  Vec3 base = Vec3::Zero(), tip = Vec3::Zero();
  Vec3 d = Vec3::Zero();                      // tip - base
  Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();  // its box, from base
  double len2 = 0.0;                          // |d|^2
  double len = 0.0;                           // |d|
  Vec3 u = Vec3::Zero();                      // d / len, where len > 0
  bool finite = true;
};
/// segmentTetGap(s.base, s.tip, corners, enough).
double segmentTetGap(const PreparedSegment& s, const std::array<Vec3, 4>& corners,
                     double enough = HUGE_VAL);

/// The distance [m] between segments p0-p1 and q0-q1.
double segmentSegmentDistance(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1);

/// True when segment p->q meets the tet (a, b, c, d) grown by `tolerance` [m].
bool segmentMeetsTet(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c,
                     const Vec3& d, double tolerance);

/// segmentMeetsTet() for a tet asked again and again (a tet the blade is inside, each tick): its
/// face planes are kept while its corners stay where they were (segmentMeetsTet() makes them for
/// one question), and the answer is the same to the bit.
class TetPlanes {
 public:
  bool meets(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c,
             const Vec3& d, double tolerance);

 private:
  std::array<Vec3, 4> corner_;  // the corners the planes were made from
  std::array<Vec3, 4> normal_;  // each face's outward unit normal (zero: a flat face)
  bool valid_ = false;
  // The last segment found to meet the tet, and how far (less a margin for rounding) the point
  // in the middle of its part inside lies within every plane: a segment whose ends are each
  // closer than that to its ends meets the tet too, while the corners and the tolerance stay.
  Vec3 met_p_ = Vec3::Zero(), met_q_ = Vec3::Zero();
  double met_depth2_ = -1.0, met_tolerance_ = 0.0;  // the depth squared (-1: none kept)
};

}  // namespace tissue_cut
