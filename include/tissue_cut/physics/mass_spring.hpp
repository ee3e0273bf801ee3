// MassSpring: lumped masses and edge springs on the live tets, integrated by linearly-implicit
// backward Euler (matrix-free conjugate gradients, preconditioned by 3x3 vertex blocks and by
// whole blocks of the cut's stiff, light vertex clusters; warm-started;
// its loops split over MassSpringParams::threads threads) or by semi-implicit Euler. Follows
// every cut and collapse through TetMesh change records.
#pragma once

#include <array>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "tissue_cut/mesh/tet_mesh.hpp"
#include "tissue_cut/physics/worker_team.hpp"

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
  /// CG stops at this residual relative to the right-hand side or to the weight's impulse over
  /// the step (m g dt of the free vertices), whichever is larger. At 1e-5 a cantilever's motion
  /// over 0.5 s stays within 0.06 um of a solve at 1e-12 (test_physics), with a third fewer
  /// iterations than at 1e-6.
  double cg_tolerance = 1e-5;
  double max_speed = 50.0;     ///< a faster vertex means the step blew up [m/s]
  /// Vertices tied by springs far stiffer than their mass over a step (the corners of a cut's
  /// slivers) are preconditioned as clusters, each cluster's whole block of the system inverted
  /// (see MassSpring::clusters()); false: each vertex's own 3x3 block only (block-Jacobi).
  bool cluster_preconditioner = true;
  /// CG's warm start: each vertex's velocity change extrapolated from the last steps' answers,
  /// quadratically where that was the closer guess at the last step (false: linearly).
  bool quadratic_warm_start = true;
  /// That choice made for each vertex: quadratic where it was clearly the closer for the vertex,
  /// linear where that was, and where neither was, the one closer over the whole mesh (false:
  /// the whole mesh's choice for every vertex, as until session 31; for comparison).
  bool per_vertex_warm_start = true;
  /// Before CG, where a few vertices hold most of the first residual (the vertices whose springs
  /// a cut or a collapse just changed, and the steps after), the system is solved for those
  /// vertices alone (the rest held at the warm start) and CG starts from there: the same
  /// tolerance, in fewer whole-mesh iterations (see MassSpring::presolveLocally()).
  bool local_presolve = true;
  /// The local solve takes those vertices' neighbours as unknowns too (up to 128 rows and a 40th
  /// of the mesh's vertices): solved for alone, the few vertices leave the rest of the residual
  /// around them (false: the few alone, as until session 31).
  bool local_presolve_neighbours = true;
  /// Threads the implicit step's loops run on (at most the machine's hardware threads). The
  /// result depends on the count (sums are split), never on timing.
  int threads = 1;
};

class MassSpring {
 public:
  /// Builds masses and springs on the mesh's live tets (rest positions) and fixes the vertices
  /// within params.fixed_band of the chosen side (rest positions).
  MassSpring(TetMesh* mesh, const MassSpringParams& params);

  /// Updates masses, springs and fixed flags for a topology change that already happened: new
  /// vertices are fixed when all their parents are; removed vertices' mass goes with their tets.
  void follow(const ChangeRecord& change);

  /// A step is coming within `within_us` (after other work, such as a cut): a second thread's
  /// helper stays awake for it (see WorkerTeam::expectJob()).
  void expectStep(double within_us);

  /// One step of dt [s]. Returns a warning when the step was unstable (rolled back and damped).
  std::string step(double dt);
  /// Does now what the first step of dt [s] would do before it solves: sizes the step's buffers,
  /// finds the strong springs and their clusters, and makes the inertia, the held rows and the
  /// springs' packing that steps keep until a change (the first step of the 20k organ took 1.8
  /// ms longer than the next, most of it first touching 3 MB of buffers). Optional: the steps
  /// after it are the same, to the bit, as without it; only when that work is done changes.
  void prepare(double dt);

  double totalMass() const;      ///< [kg]
  double kineticEnergy() const;  ///< [J]
  int instabilities() const { return instabilities_; }
  int lastIterations() const { return last_iterations_; }
  /// Steps that solved locally before CG (see MassSpringParams::local_presolve).
  long long localPresolves() const { return local_presolves_; }
  /// Inertia the floor of the last step added (see step()), as a fraction of the total mass.
  double addedInertia() const { return added_inertia_; }
  /// How far the last step moved any vertex [m] (dt times the fastest speed; infinity when it was
  /// rolled back; 0 before the first step).
  double lastMaxDisplacement() const { return last_max_displacement_; }
  /// Steps taken, their CG iterations in total, and the time spent in step() [ms].
  long long steps() const { return steps_; }
  long long totalIterations() const { return total_iterations_; }
  double timeMs() const { return time_ms_; }
  int numSprings() const { return static_cast<int>(springs_.size()); }
  /// The vertex clusters the last implicit step preconditioned whole, each sorted; in order.
  std::vector<std::vector<int>> clusters() const;
  int numClusters() const { return static_cast<int>(clusters_.size()); }
  /// Threads the implicit step runs on: params().threads, at most the hardware threads.
  int numThreads() const;
  double mass(int v) const { return mass_[v]; }
  /// The stiffness of the spring between vertices a and b [N/m]; 0 when there is none.
  double stiffness(int a, int b) const {
    const int i = findSpring(a, b);
    return i < 0 ? 0.0 : springs_[i].stiffness;
  }
  bool fixed(int v) const { return fixed_[v] != 0; }
  /// Fixes (or frees) vertices by id, on top of the band.
  void setFixed(const std::vector<int>& vertices, bool fixed = true);
  /// Makes the next step pack the springs and take the inertia anew, as a change to the springs
  /// and masses would, from a packing whose every entry is wrong (the tests compare steps that
  /// keep them with steps that make them every time from nothing).
  void forgetKept();
  void setParams(const MassSpringParams& params);
  const MassSpringParams& params() const { return params_; }

 private:
  struct Spring {
    int a, b;
    double rest_length;
    double stiffness;  ///< [N/m]
  };
  void resize();
  void sizeStepBuffers();  // the step's buffers for the vertex and spring slots now
  void makeTeam();  // team_ for params_.threads
  /// The masses of `vertices` (sorted) and the springs on `edges` (sorted, lower end first, each
  /// lower end among `vertices`) from the tets now on them: added, updated in place, or removed
  /// where no tet is left.
  void updateMassesAndSprings(const std::vector<int>& vertices,
                              const std::vector<std::pair<int, int>>& edges);
  std::vector<int> liveVertices() const;  // in increasing order
  /// Spring a-b for `volume` of tets on it: added, updated, or removed when there is none.
  void setSpring(int a, int b, double volume);
  int findSpring(int a, int b) const;  // index in springs_, -1: none
  /// Symmetric 3x3 block (xx, xy, xz, yy, yz, zz); a spring's is kept scaled by h^2.
  struct Block {
    double xx, xy, xz, yy, yz, zz;
  };
  void forces(std::vector<Vec3>* f) const;
  /// Runs part(0) .. part(numThreads() - 1) at once (see WorkerTeam). The callable reaches the
  /// team by reference: a std::function made from a lambda that captures more than two pointers'
  /// worth allocates it on the heap, which two of the step's loops did on every step.
  template <class Part>
  void parallel(const Part& part) {
    if (team_) {
      team_->run(std::cref(part));
    } else {
      part(0);
    }
  }
  /// The part'th of numThreads() nearly equal ranges of [0, count).
  std::pair<int, int> rangeOf(int count, int part) const;
  // A vertex's vector in 32 bytes, the fourth double zero: CG's products and vertex loops read
  // and write a vertex's vector with one vector load or store (see springProducts()).
  struct alignas(32) Padded3 {
    Vec3 v = Vec3::Zero();
    double pad = 0.0;
  };
  /// A p with A = (1 + h alpha) M + h^2 K, in two steps: springProducts() for every part (its
  /// springs' terms into its own buffer, product_acc_[part]), then massProducts() (the mass
  /// term and the parts' sums into ap_, held rows zero).
  void springProducts(int part, const Padded3* p);
  /// The springs' part of the implicit step's set-up (see stepImplicit()).
  void assembleSprings(int part, double dt);
  /// A batch of springs, one array per coordinate: what assembleSprings() gathers from the mesh
  /// for springTerms(), and what that makes of it (its blocks go to a BlockBatch).
  struct SpringBatch {
    static constexpr int kSize = 32;
    alignas(64) double dx[kSize], dy[kSize], dz[kSize];  // x_b - x_a
    alignas(64) double ux[kSize], uy[kSize], uz[kSize];  // u_b - u_a
    alignas(64) double wx[kSize], wy[kSize], wz[kSize];  // w_a - w_b, then K (w_a - w_b)
    alignas(64) double fx[kSize], fy[kSize], fz[kSize];  // f + K (u_b - u_a) / h
  };
  /// A packed batch's springs' constants (zero in the lanes past its last spring), kept with the
  /// packing (see updatePacking()).
  struct SpringConsts {
    alignas(64) double stiffness[SpringBatch::kSize], rest[SpringBatch::kSize];
  };
  /// A batch's stiffness blocks, one array per entry: springTerms() writes them where the CG
  /// products read them (blocks_), so the set-up's scatter does not copy them.
  struct BlockBatch {
    alignas(64) double xx[SpringBatch::kSize], xy[SpringBatch::kSize], xz[SpringBatch::kSize];
    alignas(64) double yy[SpringBatch::kSize], yz[SpringBatch::kSize], zz[SpringBatch::kSize];
    Block at(int j) const { return {xx[j], xy[j], xz[j], yy[j], yz[j], zz[j]}; }
  };
  /// Brings ends_, packed_at_, packed_end_ and consts_ up to date with springs_ and the held
  /// vertices (see there).
  void updatePacking();
  /// Notes for updatePacking() that springs_[spring] changed in place.
  void noteChangedInPlace(int spring);
  static void springTerms(SpringBatch* s, const SpringConsts* c, BlockBatch* k, double h2,
                          double inv_dt);
  /// A packed spring's block (see blocks_).
  Block blockAt(int slot) const {
    const unsigned at = static_cast<unsigned>(slot);
    return blocks_[at / SpringBatch::kSize].at(at % SpringBatch::kSize);
  }
  /// The first slot of a part's packed springs in ends_ and blocks_: a batch's first, and past
  /// every slot the part before can fill.
  int packedBegin(int part) const;
  // Cluster preconditioning. Block-Jacobi inverts each vertex's own 3x3 block of A; where a
  // spring is far stiffer than its lighter end's inertia over a step (the corners of a cut's
  // slivers: h^2 k of kStrongCoupling m and more), the ends' motion together, which only their
  // small inertia and weak ties to the rest resist, then takes CG many iterations. Such vertices
  // are grouped in clusters of up to kMaxCluster, and the preconditioner inverts each cluster's
  // whole block of A instead (still a block-diagonal, symmetric positive definite P: CG's answer
  // is the same to its tolerance).
  static constexpr int kMaxCluster = 4;
  static constexpr double kStrongCoupling = 2.0;
  struct Cluster {
    int size = 0;
    std::array<int, kMaxCluster> vertices{};
    int num_springs = 0;
    /// The springs between its vertices: index in springs_, and the two ends' places in vertices.
    std::array<std::array<int, 3>, kMaxCluster*(kMaxCluster - 1) / 2> springs{};
    /// The inverse of its block of A this step (3 size x 3 size, row-major, by Cholesky).
    std::array<double, 9 * kMaxCluster * kMaxCluster> inverse{};
    bool usable = false;  // the block was positive definite
  };
  /// h^2 k / m of springs_[spring] (m its lighter end's mass) when that is at least
  /// strongThreshold(), neither end fixed nor dead; 0 otherwise.
  double strongRatio(int spring, double dt) const;
  /// kStrongCoupling, or the loaded mesh's 99th percentile of h^2 k / m where that is more (a
  /// stiff material or a long step): clusters are for what cuts make, not for a whole mesh.
  double strongThreshold(double dt) const;
  void rescanStrong(double dt);                         // strong_ from every spring
  void updateStrong(const std::vector<int>& vertices);  // strong_ at these vertices again
  /// f(u, spring) for each spring of v: its other end and its index in springs_.
  template <typename F>
  void forEachSpring(int v, F&& f) const;
  void buildClusters();                                 // clusters_ from strong_
  /// strong_ found again when dt changed, clusters_ built again when stale or sized for fewer
  /// vertex slots: what a step needs before its set-up (and prepare() does ahead).
  void refreshClusters(double dt);
  /// Inverts each cluster's block of A, from cluster_diag_ and the springs' blocks.
  void factorClusters();
  /// A cluster's block of A into its inverse's place, to be inverted there.
  void fillCluster(Cluster* cluster);
  /// z = the clusters' blocks' inverses times r on the clusters' vertices (also into *p when
  /// given); returns the change this makes to sum r.z.
  double applyClusters(const Padded3* r, Padded3* z, Padded3* p);
  /// The implicit step's vertex passes, a part of the vertices each (see stepImplicit()): after
  /// the springs' set-up, b, the diagonal blocks and CG's start; the last, the new state.
  void setupVertices(int part, double dt);
  void finishStep(int part, double dt, bool compare);
  /// CG's vertex loops (see stepImplicit()): A p from the products' buffers (returns this
  /// part's share of p.Ap); the updates of dv, r and z (shares of r.z and r.r into partial_);
  /// p = z + beta p.
  double massProducts(int part);
  void updateResidual(int part, double alpha);
  void updateDirection(int part, double beta);
  // The local pre-solve. On the step a cut or a collapse changes some vertices' springs and
  // masses, 96-99% of CG's first residual sits on those few vertices (the 20k organ: 6-12 of
  // 5,000; the steps after: the same few, through the warm start's extrapolation): 1,000-10,000
  // times the tolerance against about 30 on other steps, i.e. 6-9 whole-mesh CG iterations
  // instead of 3-4. The vertices that hold the residual (up to kMaxLocal, together at least
  // kLocalShare of it) and their neighbours (up to kMaxLocalRows rows in all and a
  // kLocalRowsPer-th of the mesh's vertices, the neighbours of the vertices holding the most
  // first) are solved for by CG on their rows of A (block-Jacobi, the other vertices held at the
  // warm start), and the residual kept exact (r = b - A dv) on them and on their neighbours: CG
  // then starts from a better dv, and ends at the same tolerance.
  static constexpr int kMaxLocal = 96;
  static constexpr int kMaxLocalRows = 128;
  static constexpr int kLocalRowsPer = 40;  // vertices of the mesh per row solved for, at least
  static constexpr double kLocalTrigger = 1e4;  // first residual over tolerance, squared
  static constexpr double kLocalPick = 1e-3;    // of the residual squared, a vertex's least
  static constexpr double kLocalShare = 0.5;    // of the residual squared, the picked ones' least
  static constexpr double kLocalGoal = 0.1;     // local residual over the rest's, squared
  static constexpr int kLocalIterations = 40;
  /// Solves locally (see above) when r_ (its sums *rz, *rr) calls for it: dv_, r_, z_ and p_
  /// changed there, and the sums with them.
  void presolveLocally(double tolerance2, double* rz, double* rr);
  struct LocalSpring {
    int a, b;   // local indices: a among the rows solved for, b one of them or a neighbour
    int block;  // in blocks_
  };
  std::vector<std::pair<double, int>> local_pick_;
  std::vector<int> local_vertices_;  // the picked vertices, then their neighbours
  std::vector<int> local_index_;     // a vertex's place in local_vertices_ (where stamped)
  std::vector<unsigned> local_seen_;
  unsigned local_stamp_ = 0;
  std::vector<LocalSpring> local_springs_;
  std::vector<Padded3> local_r_, local_z_, local_p_, local_q_, local_x_;  // padded rows
  /// The local PCG on the first m rows of local_vertices_ (see presolveLocally()).
  void localIterations(int m, int total, double tolerance2, double rr);
  long long local_presolves_ = 0;
  /// The parts' shares of sum k of the last parallel loop, added in part order.
  double partialSum(int k) const;
  /// Leaves each part's fastest live vertex's speed in partial_[part].sum[2] and whether all its
  /// live vertices' positions and velocities are finite (1 or 0) in sum[3], as scanSpeeds() does.
  bool stepImplicit(double dt);
  void stepSemiImplicit(double dt);
  /// The fastest speed and finiteness of each part's live vertices, into partial_ (see above).
  void scanSpeeds();
  /// inertia_ (the masses with the floor of step()) and added_inertia_ from the masses and the
  /// live vertices.
  void updateInertia();

  TetMesh* mesh_;
  MassSpringParams params_;
  std::vector<double> mass_;
  std::vector<double> inertia_;  // mass_, floored (see step())
  static constexpr double kMinInertia = 3e-2;
  static constexpr double kMinStiffness = 1e-3, kMaxStiffness = 20.0;  // see setSpring()
  double reference_length_ = 0.0;  // mean rest edge of the mesh at construction [m]
  std::vector<unsigned char> fixed_;
  std::vector<Spring> springs_;
  // Per vertex, the springs whose first (lower) end it is, with their other ends: finding a
  // spring by its ends costs a short list, not a hash table (whose growth and misses had cost up
  // to 120 us a tick of collapses), and no read of the springs themselves (scattered in springs_).
  struct SpringRef {
    int other;  // the other end: the higher in springs_from_, the lower in springs_to_
    int index;  // in springs_
  };
  std::vector<std::vector<SpringRef>> springs_from_;
  // Per vertex, its springs to lower vertices (other: the lower end), so that a vertex's
  // springs are listed without a search (the local solve's set-up).
  std::vector<std::vector<SpringRef>> springs_to_;
  std::vector<Vec3> warm_;                        // last velocity change, per vertex
  std::vector<Vec3> warm_prev_;                   // the one before (warm start by extrapolation)
  std::vector<Vec3> warm_prev2_;                  // and the one before that
  // Per vertex, which extrapolation was the closer at the last step (see stepImplicit()).
  static constexpr unsigned char kLinearCloser = 0, kQuadraticCloser = 1, kEitherCloser = 2;
  static constexpr double kClearlyCloser2 = 4.0;  // a miss this much smaller, squared
  std::vector<unsigned char> quadratic_at_;
  bool quadratic_next_ = false;  // the quadratic misses summed over the mesh were the smaller
  /// Steps whose answers warm_, warm_prev_ and warm_prev2_ hold, up to 3 (0 after a roll-back):
  /// what the warm start may extrapolate from (see stepImplicit()).
  int warm_history_ = 0;
  std::vector<TetVerts> tet_copy_;                // each live tet's vertices, from the records
  std::vector<double> tet_volume_;                // each live tet's rest volume, from the records
  std::vector<int> follow_vertices_;              // follow()'s scratch, kept for its capacity
  std::vector<std::pair<int, int>> follow_edges_;
  std::vector<double> edge_volumes_;  // updateMassesAndSprings()' scratch
  std::vector<unsigned> edge_seen_;   // its stamps: the far ends of one vertex's edges
  unsigned edge_stamp_ = 0;
  std::vector<std::size_t> edge_at_;   // the place in its edges of each far end stamped
  std::vector<unsigned> follow_seen_;  // follow()'s stamps: each vertex once
  unsigned follow_stamp_ = 0;
  std::vector<int> follow_place_;             // a vertex's place among follow()'s vertices
  std::vector<unsigned char> follow_matrix_;  // follow()'s edges among them (n x n, upper)
  static constexpr int kEdgeMatrixMax = 256;  // more vertices: the edges are sorted instead
  // The implicit step's work space, kept between steps so that a tick allocates nothing.
  // h^2-scaled stiffness blocks of this step, packed as ends_: a slot's in its batch's lane.
  std::vector<BlockBatch> blocks_;
  // The springs with a free end, packed in order within each part's range of springs_ (see
  // assembleSprings()): their ends and blocks, where each part's ends, and each spring's place.
  std::vector<std::array<int, 2>> ends_;
  std::vector<int> packed_end_;  // per part
  std::vector<int> packed_at_;   // per spring: its index in ends_ and blocks_, -1 when left out
  std::vector<SpringConsts> consts_;  // per batch of blocks_: its springs' stiffness and length
  // What changed since the packing was made (updatePacking() makes it before each implicit
  // step's set-up): everything (a fixed vertex, the number of parts), the springs from
  // repack_from_ on (springs_ grew or shrank there), the springs at the places in respring_
  // (changed in place).
  bool repack_all_ = true;
  int repack_from_ = std::numeric_limits<int>::max();
  std::vector<int> respring_;
  // Whether inertia_ and added_inertia_ still hold what the masses and the live vertices give
  // (see updateInertia()): false once a mass, a vertex's life or the number of parts changed.
  bool inertia_valid_ = false;
  std::vector<Vec3> b_, dv_, x0_;
  std::vector<Padded3> r_, z_, p_, ap_;  // CG's residual, its preconditioned, direction, A p
  std::vector<Block> inv_diag_;  // block-Jacobi preconditioner (unscaled), zero for fixed/dead
  std::vector<unsigned char> held_;  // rows held at zero this step: fixed or dead vertices
  // Each part sums its springs' terms here (per part, per vertex). Zero between uses: the
  // vertex loop that reads a row (of every part's buffer) zeroes it, so no pass of its own clears
  // them. (Each part cleared its whole buffer before: with two threads both cleared all rows.)
  // All in padded rows, so that the scatters add whole vectors (see assembleSprings()).
  std::vector<std::vector<Padded3>> acc_;          // the set-up's (assembleSprings())
  std::vector<std::vector<Padded3>> product_acc_;  // the CG products' (springProducts())
  std::vector<std::vector<Padded3>> start_acc_;    // the springs' part of A dv for the warm start
  // A vertex's block in a cache line: (xx, xy, xz, yy) and (yz, zz) each one vector.
  struct alignas(64) PaddedBlock {
    Block k{0, 0, 0, 0, 0, 0};
    double pad[2] = {0, 0};
  };
  std::vector<std::vector<PaddedBlock>> diag_acc_;
  struct alignas(64) Partial {  // one part's shares of dot products, a cache line of its own
    double sum[4];
  };
  std::vector<Partial> partial_;
  struct StrongSpring {
    std::array<int, 2> ends;  // lower first
    double ratio;             // strongRatio() when found (it changes only where follow() looks)
    // The order buildClusters() takes them in: strongest first, ties by their ends.
    bool operator<(const StrongSpring& o) const {
      return ratio != o.ratio ? ratio > o.ratio : ends < o.ends;
    }
  };
  std::vector<StrongSpring> strong_;         // the strong springs, in that order
  std::vector<StrongSpring> strong_merged_;  // updateStrong()'s merge, kept for its room
  double strong_dt_ = 0.0;                 // the step size of strong_; 0: find them all again
  std::vector<Cluster> clusters_;
  std::vector<int> cluster_of_;      // per vertex: its cluster's index in clusters_, or -1
  std::vector<Block> cluster_diag_;  // a cluster vertex's own block of A, this step
  // buildClusters()' scratch: the clusters as they grow (a Cluster with its inverse is 1.2 kB:
  // made and moved while merging, they had been half of the rebuild that every cut or collapse
  // tick makes).
  struct ClusterSet {
    int size = 0;
    std::array<int, kMaxCluster> vertices;
  };
  std::vector<ClusterSet> cluster_sets_;
  std::vector<unsigned> changed_seen_;  // updateStrong()'s scratch: the changed vertices
  unsigned changed_stamp_ = 0;
  double loaded_coupling_ = 0.0;  // the loaded mesh's p99 k / lighter mass, per E / density
  bool clusters_stale_ = true;    // strong_ changed since clusters_ were built
  std::unique_ptr<WorkerTeam> team_;  // none: one thread
  double mass_damping_ = 1.0;    // 1 + h alpha of this step
  int instabilities_ = 0, last_iterations_ = 0;
  long long steps_ = 0, total_iterations_ = 0;
  double time_ms_ = 0.0;
  double added_inertia_ = 0.0;
  double last_max_displacement_ = 0.0;
};

}  // namespace tissue_cut
