// Random scalpel paths for property tests, seeded and reproducible: one seed gives one path on
// one mesh, bit for bit, on any platform (own uniform and normal draws from a 64-bit SplitMix
// stream, not the standard library's distributions, whose output is implementation-defined).
//
// A path enters through any side of the mesh's bounding box and leaves through any side (or
// stops inside, or starts inside), riding one point of the blade along a straight line, a curve,
// through mesh vertices, along a mesh edge (blade in the plane of a face), in an axis-aligned
// grid plane, or after a stab along the blade's own axis; on top of that come tilt, twist,
// speed, pauses, reversals, tremble and an occasional jump that lifts the blade.
// Shared by test/unit/test_property.cpp (CI and the long run) and random_incision (writes CSVs).
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "tissue_cut/cut/scalpel_path.hpp"
#include "tissue_cut/mesh/mesh_io.hpp"

namespace tissue_cut::property {

/// A SplitMix64 stream with uniform and normal draws of its own.
class Random {
 public:
  explicit Random(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  /// Uniform on [0, 1).
  double uniform() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  /// Uniform on {0, ..., n-1}.
  int index(int n) { return static_cast<int>(uniform() * n); }
  bool chance(double p) { return uniform() < p; }
  /// Standard normal (Box-Muller).
  double normal() {
    const double u = 1.0 - uniform();  // (0, 1]
    const double v = uniform();
    return std::sqrt(-2.0 * std::log(u)) * std::cos(2.0 * M_PI * v);
  }
  Vec3 unitVector() {
    Vec3 d(normal(), normal(), normal());
    while (d.norm() < 1e-9) d = Vec3(normal(), normal(), normal());
    return d.normalized();
  }

 private:
  std::uint64_t state_;
};

/// What to replay: poses (mesh frame [m], seconds), the blade's length [m] and the tick rate
/// [Hz] to replay at, and a one-line description of what was drawn.
struct RandomIncision {
  std::vector<ToolPose> poses;
  double blade_length = 0.03;
  double rate = 1000.0;
  std::string description;
};

namespace detail {

inline Vec3 anyPerpendicular(const Vec3& m, Random& rng) {
  Vec3 d = rng.unitVector();
  d -= d.dot(m) * m;
  while (d.norm() < 1e-6) {
    d = rng.unitVector();
    d -= d.dot(m) * m;
  }
  return d.normalized();
}

/// A point just outside face `side` (0..5 = -x, +x, -y, +y, -z, +z) of the box, `margin` out.
inline Vec3 outsidePoint(const Eigen::AlignedBox3d& box, int side, double margin, Random& rng) {
  Vec3 p;
  for (int k = 0; k < 3; ++k) p[k] = rng.uniform(box.min()[k], box.max()[k]);
  const int axis = side / 2;
  p[axis] = side % 2 ? box.max()[axis] + margin : box.min()[axis] - margin;
  return p;
}

inline Vec3 insidePoint(const Eigen::AlignedBox3d& box, Random& rng, double shrink = 0.15) {
  Vec3 p;
  for (int k = 0; k < 3; ++k) {
    const double a = box.min()[k], b = box.max()[k], s = shrink * (b - a);
    p[k] = rng.uniform(a + s, b - s);
  }
  return p;
}

inline Vec3 vertex(const MeshData& mesh, int v) { return mesh.V.row(v).transpose(); }

/// Extends the line through a and b to `reach` beyond the box on both sides.
inline std::pair<Vec3, Vec3> lineThrough(const Vec3& a, const Vec3& b,
                                         const Eigen::AlignedBox3d& box, double reach) {
  const Vec3 m = (b - a).normalized();
  const double span = box.diagonal().norm() + reach;
  return {a - span * m, a + span * m};
}

}  // namespace detail

/// Inputs: mesh (V #V by 3 rest positions [m], T #T by 4), seed. Output: a random incision over
/// the mesh (see the file comment); the same seed and mesh give the same incision.
inline RandomIncision randomIncision(const MeshData& mesh, std::uint64_t seed) {
  using detail::vertex;
  Random rng(seed * 0x2545f4914f6cdd1dULL + 0x1234567ULL);
  Eigen::AlignedBox3d box;
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v) box.extend(vertex(mesh, v));
  const double diag = box.diagonal().norm();
  double edge = 0.0;  // mean edge length over a sample of tets
  const int sample = std::min<int>(200, static_cast<int>(mesh.T.rows()));
  for (int i = 0; i < sample; ++i) {
    const int t = static_cast<int>(i * (mesh.T.rows() / std::max(sample, 1)));
    edge += (vertex(mesh, mesh.T(t, 0)) - vertex(mesh, mesh.T(t, 1))).norm() / sample;
  }
  const double margin = rng.uniform(0.3, 2.0) * edge;
  std::ostringstream what;

  // 1. The ride: key points of the blade point that follows the path, the blade's direction d
  //    (unit, from the tool origin to the tip) at the start and at the end.
  std::vector<Vec3> keys;
  Vec3 d0 = Vec3::Zero(), d1 = Vec3::Zero();  // zero: drawn below from the motion
  double ride = rng.uniform();  // where along the blade the path point sits (0 base, 1 tip)
  const char* kinds[] = {"through", "stop-inside", "start-inside", "vertices",
                         "edge",    "grid-plane",  "stab",         "u-turn"};
  const int kind = rng.index(8);
  what << kinds[kind];
  const int entry = rng.index(6);
  int exit = rng.index(6);
  switch (kind) {
    case 0:  // through: in one side, out any other
      if (exit == entry) exit = entry ^ 1;
      keys = {detail::outsidePoint(box, entry, margin, rng),
              detail::outsidePoint(box, exit, margin, rng)};
      break;
    case 1:  // stops inside: the final tick lifts the blade out
      keys = {detail::outsidePoint(box, entry, margin, rng), detail::insidePoint(box, rng)};
      break;
    case 2:  // the blade appears inside the tissue and leaves
      keys = {detail::insidePoint(box, rng), detail::outsidePoint(box, exit, margin, rng)};
      break;
    case 3: {  // exactly through 1-3 mesh vertices (the riding point hits each one)
      keys.push_back(detail::outsidePoint(box, entry, margin, rng));
      const int n = 1 + rng.index(3);
      for (int i = 0; i < n; ++i) keys.push_back(vertex(mesh, rng.index(mesh.V.rows())));
      keys.push_back(detail::outsidePoint(box, exit == entry ? entry ^ 1 : exit, margin, rng));
      ride = rng.chance(0.5) ? 1.0 : ride;
      break;
    }
    case 4: {  // along a mesh edge, the blade in the plane of one of its faces
      const int t = rng.index(mesh.T.rows());
      const int i = rng.index(4), j = (i + 1 + rng.index(3)) % 4;
      int third = 0;
      while (third == i || third == j) ++third;
      const Vec3 a = vertex(mesh, mesh.T(t, i)), b = vertex(mesh, mesh.T(t, j));
      const auto [p, q] = detail::lineThrough(a, b, box, margin);
      keys = {p, a, b, q};
      if (rng.chance(0.5)) std::swap(keys.front(), keys.back()), std::swap(keys[1], keys[2]);
      const Vec3 m = (b - a).normalized();
      Vec3 c = vertex(mesh, mesh.T(t, third)) - a;
      c -= c.dot(m) * m;
      d0 = rng.chance(0.5) ? c.normalized() : -c.normalized();
      d1 = d0;
      ride = rng.chance(0.5) ? 1.0 : rng.chance(0.5) ? 0.0 : ride;
      break;
    }
    case 5: {  // axis-aligned motion and blade through a vertex: on a block, a grid plane
      const Vec3 v = vertex(mesh, rng.index(mesh.V.rows()));
      const int axis = rng.index(3);
      const int blade_axis = (axis + 1 + rng.index(2)) % 3;
      const auto [p, q] = detail::lineThrough(v, v + Vec3::Unit(axis), box, margin);
      keys = {p, v, q};
      if (rng.chance(0.5)) std::swap(keys.front(), keys.back());
      d0 = (rng.chance(0.5) ? 1.0 : -1.0) * Vec3::Unit(blade_axis);
      d1 = d0;
      break;
    }
    case 6: {  // a stab along the blade from outside, then a drag
      const Vec3 target = detail::insidePoint(box, rng);
      d0 = (target - detail::outsidePoint(box, entry, margin, rng)).normalized();
      d1 = d0;
      ride = 1.0;
      keys = {target - d0 * (0.6 * diag), target,
              rng.chance(0.5) ? detail::outsidePoint(box, exit, margin, rng)
                              : detail::insidePoint(box, rng)};
      break;
    }
    default:  // u-turn: in and out through the same side
      keys = {detail::outsidePoint(box, entry, margin, rng), detail::insidePoint(box, rng),
              detail::outsidePoint(box, entry, margin, rng)};
      break;
  }
  // Curves: up to two extra points inside, between the first two keys.
  if (kind <= 2 || kind == 7) {
    const int curves = rng.index(3);
    for (int i = 0; i < curves; ++i) keys.insert(keys.begin() + 1, detail::insidePoint(box, rng));
    if (curves) what << " curve" << curves;
  }
  const Vec3 m = (keys.back() - keys.front()).norm() > 1e-9
                     ? Vec3((keys.back() - keys.front()).normalized())
                     : Vec3((keys[1] - keys.front()).normalized());
  if (d0.norm() < 0.5) {
    d0 = detail::anyPerpendicular(m, rng);
    if (rng.chance(0.4)) d0 = Vec3(0, 0, -1) - Vec3(0, 0, -1).dot(m) * m;  // roughly downwards
    if (d0.norm() < 1e-6) d0 = detail::anyPerpendicular(m, rng);
    d0.normalize();
    if (rng.chance(0.6)) {  // tilt (rake) towards or away from the motion
      const double tilt = rng.uniform(-50.0, 50.0) * M_PI / 180.0;
      d0 = (Eigen::AngleAxisd(tilt, d0.cross(m).normalized()) * d0).normalized();
      what << " tilt" << std::lround(tilt * 180.0 / M_PI);
    }
    d1 = d0;
    if (rng.chance(0.3)) {  // the blade turns during the stroke
      const double twist = rng.uniform(-40.0, 40.0) * M_PI / 180.0;
      d1 = (Eigen::AngleAxisd(twist, m) * d0).normalized();
      what << " twist" << std::lround(twist * 180.0 / M_PI);
    }
  }
  // Blade: from a short one (partial cuts) to one longer than the body along d (severing).
  double reach = 0.0;
  for (int k = 0; k < 3; ++k) reach += std::abs(d0[k]) * box.diagonal()[k];
  const double blade = std::max(rng.uniform(0.2, 1.3) * reach, 2.0 * edge);
  what << " blade" << std::lround(blade * 1000.0) << "mm ride" << std::lround(ride * 100) << "%";

  // 2. Rows: the polyline sampled, every few edge lengths, with the blade direction blended.
  struct Row {
    Vec3 point, d;
  };
  std::vector<Row> rows;
  double total = 0.0;
  for (std::size_t i = 1; i < keys.size(); ++i) total += (keys[i] - keys[i - 1]).norm();
  double run = 0.0;
  const double spacing = rng.uniform(0.5, 4.0) * edge;
  for (std::size_t i = 1; i < keys.size(); ++i) {
    const double len = (keys[i] - keys[i - 1]).norm();
    const int n = std::max(1, static_cast<int>(std::ceil(len / spacing)));
    for (int s = (i == 1 ? 0 : 1); s <= n; ++s) {
      const double f = double(s) / n;
      const double along = total > 0 ? (run + f * len) / total : 0.0;
      const Vec3 d = ((1.0 - along) * d0 + along * d1).normalized();
      rows.push_back({keys[i - 1] + f * (keys[i] - keys[i - 1]), d});
    }
    run += len;
  }
  // Reversals: back over a few rows, then forward again.
  const int reversals = rng.chance(0.35) ? 1 + rng.index(2) : 0;
  for (int r = 0; r < reversals && rows.size() > 4; ++r) {
    const int at = 2 + rng.index(static_cast<int>(rows.size()) - 3);
    const int back = 1 + rng.index(std::min(at - 1, 4));
    std::vector<Row> detour;
    for (int s = 1; s <= back; ++s) detour.push_back(rows[at - s]);
    for (int s = back - 1; s >= 0; --s) detour.push_back(rows[at - s]);
    rows.insert(rows.begin() + at + 1, detour.begin(), detour.end());
  }
  if (reversals) what << " reversals" << reversals;
  // Tremble: noise on position and blade direction (not on the first and last rows).
  if (rng.chance(kind >= 3 && kind <= 5 ? 0.15 : 0.4)) {
    const double sigma = rng.uniform(0.02, 0.6) * edge;
    for (std::size_t i = 1; i + 1 < rows.size(); ++i) {
      rows[i].point += sigma * Vec3(rng.normal(), rng.normal(), rng.normal());
      rows[i].d = (rows[i].d + (sigma / (0.3 * blade)) * rng.unitVector()).normalized();
    }
    what << " tremble" << std::lround(sigma * 1e6) << "um";
  }

  // 3. Times: a per-tick step between 0.03 and 1 edge length at one of three rates, pauses.
  RandomIncision out;
  const double rates[] = {250.0, 500.0, 1000.0};
  out.rate = rates[rng.index(3)];
  out.blade_length = blade;
  // Capped well under cut/max_jump (20 mm by default), so only a drawn jump lifts the blade.
  const double step =
      std::min(edge * std::exp(rng.uniform(std::log(0.03), std::log(1.0))), 0.008);
  const double speed = step * out.rate;
  what << " rate" << out.rate << " step" << std::lround(step * 1e6) << "um";
  const int pauses = rng.chance(0.3) ? 1 + rng.index(2) : 0;
  std::vector<int> pause_at;
  for (int p = 0; p < pauses; ++p) pause_at.push_back(1 + rng.index(std::max<int>(1, rows.size() - 1)));
  if (pauses) what << " pauses" << pauses;
  const bool jump = rng.chance(0.08) && rows.size() > 3;
  const int jump_at = jump ? 1 + rng.index(static_cast<int>(rows.size()) - 2) : -1;
  if (jump) what << " jump";
  double t = 0.0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (i > 0) {
      const double dist = (rows[i].point - rows[i - 1].point).norm();
      // A jump: this row comes within a fraction of a tick, so the blade moves further than
      // cut/max_jump in one tick and is lifted.
      t += static_cast<int>(i) == jump_at ? 0.2 / out.rate : dist / speed;
    }
    if (std::count(pause_at.begin(), pause_at.end(), static_cast<int>(i))) {
      ToolPose hold;
      hold.t = t;
      hold.position = rows[i].point - rows[i].d * (ride * blade);
      hold.orientation = Eigen::Quaterniond::FromTwoVectors(Vec3(0, 0, -1), rows[i].d);
      out.poses.push_back(hold);
      t += rng.uniform(2.0, 40.0) / out.rate;  // 2 to 40 ticks standing still
    }
    ToolPose pose;
    pose.t = t;
    pose.position = rows[i].point - rows[i].d * (ride * blade);
    pose.orientation = Eigen::Quaterniond::FromTwoVectors(Vec3(0, 0, -1), rows[i].d);
    out.poses.push_back(pose);
  }
  out.description = what.str();
  return out;
}

/// The incision as a cut_replay path CSV (header t,x,y,z,qx,qy,qz,qw), numbers in full
/// precision so that a replay of the file sees the same poses.
inline std::string incisionCsv(const RandomIncision& incision) {
  std::string out = "t,x,y,z,qx,qy,qz,qw\n";
  char buf[512];
  for (const ToolPose& p : incision.poses) {
    const Eigen::Quaterniond& q = p.orientation;
    std::snprintf(buf, sizeof buf, "%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", p.t,
                  p.position.x(), p.position.y(), p.position.z(), q.x(), q.y(), q.z(), q.w());
    out += buf;
  }
  return out;
}

}  // namespace tissue_cut::property
