// The tissue's surface as RViz markers: a snapshot taken between ticks, and the MarkerArray built
// from it outside the model's lock.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include <visualization_msgs/MarkerArray.h>

#include "tissue_cut/tissue.hpp"

namespace tissue_cut {

/// What the markers need from the model at one instant (copied under the model's lock).
struct SurfaceSnapshot {
  std::vector<std::array<int, 3>> faces;  ///< boundary triangles, outward, vertex ids
  std::vector<float> face_quality;        ///< rest Q of the tet each face belongs to
  std::vector<Vec3> current;              ///< current positions by vertex slot [m]
  std::vector<Vec3> rest;                 ///< rest positions by vertex slot [m]
  std::vector<std::pair<int, int>> queued_edges;  ///< shortest edges of cut tets below tau
  std::optional<BladeSegment> blade;              ///< the blade this tick [m], if down
};

/// Copies what the markers show. Cost: one pass over the live tets.
void takeSnapshot(const Tissue& tissue, const std::optional<BladeSegment>& blade,
                  SurfaceSnapshot* snapshot);

/// Tells the original skin from cut walls: a boundary face whose rest centroid lies on the
/// loaded mesh's boundary is skin, any other boundary face was made by a cut. Answers are cached
/// per face (faces outlive many publications).
class SkinClassifier {
 public:
  /// Indexes the boundary triangles of the uncut mesh (rest positions [m]).
  explicit SkinClassifier(const TetMesh& uncut);
  bool isSkin(const std::array<int, 3>& face, const std::vector<Vec3>& rest);

 private:
  long long cellKey(int i, int j, int k) const;
  bool onSkin(const Vec3& p) const;

  std::vector<std::array<Vec3, 3>> triangles_;
  std::unordered_map<long long, std::vector<int>> cells_;
  Vec3 origin_ = Vec3::Zero();
  double cell_ = 1.0, tolerance_ = 0.0;
  std::unordered_map<std::array<int, 3>, bool, FaceHash> cache_;  // by sortedFace()
};

/// How the markers look.
struct MarkerStyle {
  std::string frame_id = "world";
  bool color_by_quality = false;    ///< colour every face by its tet's Q (red 0 .. green 1)
  bool show_collapse_queue = true;  ///< the queued edges as a green line list (paper's Fig. 9)
};

/// Fills `out` (reused between calls): marker 0 the surface (TRIANGLE_LIST, 3 points and colours
/// per boundary face), 1 the queued edges (LINE_LIST), 2 the blade (LINE_LIST). Empty lists are
/// sent as DELETE so RViz never gets an empty line list.
void buildMarkers(const SurfaceSnapshot& snapshot, const MarkerStyle& style,
                  SkinClassifier* skin, const ros::Time& stamp,
                  visualization_msgs::MarkerArray* out);

}  // namespace tissue_cut
