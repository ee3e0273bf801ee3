// Tetrahedron quality Q = 3 * inradius / circumradius, the paper's measure (VTK's radius ratio
// is its inverse).
#pragma once

#include <array>

#include "tissue_cut/mesh/tet_mesh.hpp"

namespace tissue_cut {

/// Q in [0, 1] of the tet (a, b, c, d) [m]: 1 for the regular tet, 0 for a degenerate one.
/// Orientation does not matter.
double tetQuality(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

/// Whether a tet of signed volume `vol` [m^3] whose longest edge squared is `longest2` [m^2] is
/// sound: vol > min_relative_volume * (longest edge)^3 with vol > 0, compared as squares (no
/// square root: the remeshers ask for hundreds of thousands of these a second).
inline bool soundVolume(double vol, double longest2, double min_relative_volume) {
  const double k2 = min_relative_volume * min_relative_volume;
  return vol > 0.0 && vol * vol > k2 * longest2 * longest2 * longest2;
}

/// Q of the tet (a, b, c, d) [m] as tetQuality gives it when its signed volume is positive and
/// above min_relative_volume * (longest edge)^3 (so orientation matters here); -1 otherwise. One
/// pass for what the remeshers ask of every tet they would make: is it sound, and how good.
double soundTetQuality(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d,
                       double min_relative_volume);

/// soundTetQuality() of one tet for many places of one corner, the other three fixed (a vertex
/// tried at trial positions in its star): what the fixed corners alone decide (three edges and
/// the face they bound) is computed once. The same operations on the same values as
/// soundTetQuality(): the same answers, bit for bit.
class MovingCornerTet {
 public:
  MovingCornerTet() = default;
  /// corners: the tet's corners in its order; corners[moving] is not read.
  MovingCornerTet(const std::array<Vec3, 4>& corners, int moving);
  /// soundTetQuality(..., min_relative_volume) of the tet with its moving corner at p.
  double soundQuality(const Vec3& p, double min_relative_volume) const;

 private:
  template <int kMoving>
  double soundQualityAt(const Vec3& p, double min_relative_volume) const;

  std::array<Vec3, 4> corner_{};
  // The edges ab, ac, ad, bc, bd, cd (b - a, ...) and their squared lengths: those between
  // fixed corners.
  std::array<Vec3, 6> edge_{};
  std::array<double, 6> len2_{};
  Vec3 face_ = Vec3::Zero();  // the fixed face's cross product, as soundTetQuality() takes it
  double face2_ = 0.0;        // and its squared norm
  int moving_ = 0;
};

/// Inradius and circumradius of the tet (a, b, c, d) [m]; 0 and +inf for a degenerate one.
double tetInradius(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);
double tetCircumradius(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

/// Q of tet t in rest (the material) or current positions.
double restQuality(const TetMesh& mesh, int t);
double currentQuality(const TetMesh& mesh, int t);

/// The shortest edge of tet t in rest positions, as (vertex, vertex).
std::array<int, 2> shortestRestEdge(const TetMesh& mesh, int t);

/// Summary of Q over a set of tets: min, mean and a 10-bin histogram on [0, 1].
struct QualitySummary {
  double min = 0.0;
  double mean = 0.0;
  std::array<int, 10> histogram{};
  int count = 0;
  int below_tau = 0;  ///< tets with Q < the tau given to summarizeQuality
};

/// Summarises rest Q over all live tets, or over those with flag[t] != 0 when flag is given.
QualitySummary summarizeQuality(const TetMesh& mesh, double tau = 0.0,
                                const std::vector<unsigned char>* flag = nullptr);

}  // namespace tissue_cut
