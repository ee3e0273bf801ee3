// MassSpring: lumped masses and edge springs on the live tets, integrated by linearly-implicit
// backward Euler (matrix-free, Jacobi-preconditioned conjugate gradients, warm-started) or by
// semi-implicit Euler. Follows every cut and collapse through TetMesh change records.
#pragma once

#include <string>
#include <unordered_map>
#include <vector>

#include "tissue_cut/mesh/tet_mesh.hpp"

namespace tissue_cut {

struct MassSpringParams {
  double density = 1000.0;        ///< [kg/m^3]
  double young_modulus = 5000.0;  ///< [Pa]
  double damping = 2.0;           ///< mass-proportional damping [1/s]
  Vec3 gravity{0.0, 0.0, -9.81};  ///< [m/s^2]
  bool implicit = true;           ///< backward Euler + CG; false: semi-implicit Euler
  int fixed_axis = 2;             ///< 0, 1, 2 = x, y, z
  bool fixed_max_side = false;    ///< fix the vertices near the max (true) or min side
  double fixed_band = 0.001;      ///< [m]; negative: fix nothing
  int cg_max_iterations = 100;
  double cg_tolerance = 1e-6;  ///< relative residual
  double max_speed = 50.0;     ///< a faster vertex means the step blew up [m/s]
};

class MassSpring {
 public:
  /// Builds masses and springs on the mesh's live tets (rest positions) and fixes the vertices
  /// within params.fixed_band of the chosen side (rest positions).
  MassSpring(TetMesh* mesh, const MassSpringParams& params);

  /// Updates masses, springs and fixed flags for a topology change that already happened: new
  /// vertices are fixed when all their parents are; removed vertices' mass goes with their tets.
  void follow(const ChangeRecord& change);

  /// One step of dt [s]. Returns a warning when the step was unstable (rolled back and damped).
  std::string step(double dt);

  double totalMass() const;      ///< [kg]
  double kineticEnergy() const;  ///< [J]
  int instabilities() const { return instabilities_; }
  int lastIterations() const { return last_iterations_; }
  int numSprings() const { return static_cast<int>(springs_.size()); }
  double mass(int v) const { return mass_[v]; }
  bool fixed(int v) const { return fixed_[v] != 0; }
  /// Fixes (or frees) vertices by id, on top of the band.
  void setFixed(const std::vector<int>& vertices, bool fixed = true);
  void setParams(const MassSpringParams& params);
  const MassSpringParams& params() const { return params_; }

 private:
  struct Spring {
    int a, b;
    double rest_length;
    double stiffness;  ///< [N/m]
  };
  void resize();
  void updateMass(int v);
  void updateSpring(int a, int b);
  void forces(std::vector<Vec3>* f) const;
  void multiply(double dt, const std::vector<Vec3>& p, std::vector<Vec3>* out) const;
  bool stepImplicit(double dt);
  void stepSemiImplicit(double dt);

  TetMesh* mesh_;
  MassSpringParams params_;
  std::vector<double> mass_;
  std::vector<unsigned char> fixed_;
  std::vector<Spring> springs_;
  std::unordered_map<long long, int> spring_of_;  // edge key -> index
  std::vector<Vec3> warm_;                        // last velocity change, per vertex
  std::vector<TetVerts> tet_copy_;                // each live tet's vertices, from the records
  std::vector<Eigen::Matrix3d> blocks_;           // per-spring stiffness blocks of this step
  int instabilities_ = 0, last_iterations_ = 0;
};

}  // namespace tissue_cut
