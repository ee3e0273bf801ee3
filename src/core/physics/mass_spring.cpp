#include "tissue_cut/physics/mass_spring.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

namespace tissue_cut {

namespace {

long long edgeKey(int a, int b) {
  if (a > b) std::swap(a, b);
  return (static_cast<long long>(a) << 32) | static_cast<unsigned>(b);
}

// The spring's stiffness block: force on a is +K (x_b - x_a) to first order. The transverse
// part (1 - L/|d|) is clamped at 0 so the block stays positive semi-definite (Choi and Ko 2002),
// which keeps the implicit system symmetric positive definite.
Eigen::Matrix3d springBlock(const Vec3& d, double rest_length, double k) {
  const double len = d.norm();
  if (!(len > 0)) return k * Eigen::Matrix3d::Identity();
  const Vec3 n = d / len;
  const Eigen::Matrix3d nn = n * n.transpose();
  const double transverse = std::max(0.0, 1.0 - rest_length / len);
  return k * (nn + transverse * (Eigen::Matrix3d::Identity() - nn));
}

}  // namespace

MassSpring::MassSpring(TetMesh* mesh, const MassSpringParams& params)
    : mesh_(mesh), params_(params) {
  resize();
  tet_copy_.assign(mesh_->tetSlots(), {-1, -1, -1, -1});
  for (int t = 0; t < mesh_->tetSlots(); ++t)
    if (mesh_->tetAlive(t)) tet_copy_[t] = mesh_->tet(t);
  for (int v = 0; v < mesh_->vertexSlots(); ++v)
    if (mesh_->vertexAlive(v)) updateMass(v);
  for (const auto& [a, b] : mesh_->edges()) updateSpring(a, b);
  if (params_.fixed_band >= 0) {
    double side = params_.fixed_max_side ? -1e300 : 1e300;
    for (int v = 0; v < mesh_->vertexSlots(); ++v) {
      if (!mesh_->vertexAlive(v)) continue;
      const double x = mesh_->rest(v)[params_.fixed_axis];
      side = params_.fixed_max_side ? std::max(side, x) : std::min(side, x);
    }
    for (int v = 0; v < mesh_->vertexSlots(); ++v)
      if (mesh_->vertexAlive(v) &&
          std::abs(mesh_->rest(v)[params_.fixed_axis] - side) <= params_.fixed_band)
        fixed_[v] = 1;
  }
}

void MassSpring::setParams(const MassSpringParams& params) {
  const bool stiffness_changed = params.young_modulus != params_.young_modulus;
  const bool mass_changed = params.density != params_.density;
  params_ = params;
  if (mass_changed)
    for (int v = 0; v < mesh_->vertexSlots(); ++v)
      if (mesh_->vertexAlive(v)) updateMass(v);
  if (stiffness_changed)
    for (const Spring& s : std::vector<Spring>(springs_)) updateSpring(s.a, s.b);
}

void MassSpring::resize() {
  const std::size_t n = mesh_->vertexSlots();
  mass_.resize(n, 0.0);
  fixed_.resize(n, 0);
  warm_.resize(n, Vec3::Zero());
}

void MassSpring::setFixed(const std::vector<int>& vertices, bool fixed) {
  for (int v : vertices)
    if (v >= 0 && v < static_cast<int>(fixed_.size())) fixed_[v] = fixed ? 1 : 0;
}

void MassSpring::updateMass(int v) {
  double m = 0.0;
  if (mesh_->vertexAlive(v))
    for (int t : mesh_->vertexTets(v)) m += params_.density * mesh_->restVolume(t) / 4.0;
  mass_[v] = m;
}

void MassSpring::updateSpring(int a, int b) {
  const long long key = edgeKey(a, b);
  double volume = 0.0;
  if (mesh_->vertexAlive(a) && mesh_->vertexAlive(b))
    for (int t : mesh_->edgeTets(a, b)) volume += mesh_->restVolume(t);
  auto it = spring_of_.find(key);
  if (volume <= 0.0) {
    if (it == spring_of_.end()) return;
    const int i = it->second;
    spring_of_.erase(it);
    if (i != static_cast<int>(springs_.size()) - 1) {
      springs_[i] = springs_.back();
      spring_of_[edgeKey(springs_[i].a, springs_[i].b)] = i;
    }
    springs_.pop_back();
    return;
  }
  const double length = (mesh_->rest(a) - mesh_->rest(b)).norm();
  // Van Gelder: k = E * (volume of the tets on the edge) / length^2, so that stiffness follows
  // the material, not the mesh.
  const Spring s{std::min(a, b), std::max(a, b), length,
                 params_.young_modulus * volume / (length * length)};
  if (it == spring_of_.end()) {
    spring_of_[key] = static_cast<int>(springs_.size());
    springs_.push_back(s);
  } else {
    springs_[it->second] = s;
  }
}

void MassSpring::follow(const ChangeRecord& change) {
  resize();
  if (tet_copy_.size() < static_cast<std::size_t>(mesh_->tetSlots()))
    tet_copy_.resize(mesh_->tetSlots(), {-1, -1, -1, -1});
  std::set<int> vertices;
  std::set<std::pair<int, int>> edges;
  auto collect = [&](const TetVerts& tv) {
    for (int v : tv) vertices.insert(v);
    for (const auto& e : kTetEdge)
      edges.insert({std::min(tv[e[0]], tv[e[1]]), std::max(tv[e[0]], tv[e[1]])});
  };
  for (int t : change.removed_tets)
    if (tet_copy_[t][0] >= 0) collect(tet_copy_[t]);
  for (int t : change.added_tets) collect(mesh_->tet(t));
  for (int t : change.removed_tets) tet_copy_[t] = {-1, -1, -1, -1};
  for (int t : change.added_tets) tet_copy_[t] = mesh_->tet(t);
  for (int v : change.removed_vertices) {
    mass_[v] = 0.0;
    fixed_[v] = 0;
    warm_[v] = Vec3::Zero();
  }
  for (std::size_t i = 0; i < change.added_vertices.size(); ++i) {
    const int v = change.added_vertices[i];
    bool all_fixed = !change.vertex_parents[i].empty();
    for (const VertexParent& p : change.vertex_parents[i])
      all_fixed = all_fixed && p.vertex < static_cast<int>(fixed_.size()) && fixed_[p.vertex];
    fixed_[v] = all_fixed ? 1 : 0;
    warm_[v] = Vec3::Zero();
  }
  for (int v : vertices) updateMass(v);
  for (const auto& [a, b] : edges) updateSpring(a, b);
}

double MassSpring::totalMass() const {
  double m = 0.0;
  for (int v = 0; v < mesh_->vertexSlots(); ++v)
    if (mesh_->vertexAlive(v)) m += mass_[v];
  return m;
}

double MassSpring::kineticEnergy() const {
  double e = 0.0;
  for (int v = 0; v < mesh_->vertexSlots(); ++v)
    if (mesh_->vertexAlive(v)) e += 0.5 * mass_[v] * mesh_->velocity(v).squaredNorm();
  return e;
}

void MassSpring::forces(std::vector<Vec3>* f) const {
  const int n = mesh_->vertexSlots();
  f->assign(n, Vec3::Zero());
  for (int v = 0; v < n; ++v)
    if (mesh_->vertexAlive(v))
      (*f)[v] = mass_[v] * (params_.gravity - params_.damping * mesh_->velocity(v));
  for (const Spring& s : springs_) {
    const Vec3 d = mesh_->current(s.b) - mesh_->current(s.a);
    const double len = d.norm();
    if (!(len > 0)) continue;
    const Vec3 fa = s.stiffness * (len - s.rest_length) / len * d;
    (*f)[s.a] += fa;
    (*f)[s.b] -= fa;
  }
}

void MassSpring::multiply(double dt, const std::vector<Vec3>& p, std::vector<Vec3>* out) const {
  // A p = (1 + h alpha) M p + h^2 sum_springs K (p_a - p_b), fixed vertices held at zero.
  const int n = mesh_->vertexSlots();
  out->assign(n, Vec3::Zero());
  const double h2 = dt * dt, md = 1.0 + dt * params_.damping;
  for (int v = 0; v < n; ++v)
    if (mesh_->vertexAlive(v)) (*out)[v] = md * mass_[v] * p[v];
  for (std::size_t i = 0; i < springs_.size(); ++i) {
    const Spring& s = springs_[i];
    const Vec3 r = h2 * (blocks_[i] * (p[s.a] - p[s.b]));
    (*out)[s.a] += r;
    (*out)[s.b] -= r;
  }
  for (int v = 0; v < n; ++v)
    if (fixed_[v]) (*out)[v].setZero();
}

bool MassSpring::stepImplicit(double dt) {
  const int n = mesh_->vertexSlots();
  blocks_.resize(springs_.size());
  for (std::size_t i = 0; i < springs_.size(); ++i) {
    const Spring& s = springs_[i];
    blocks_[i] = springBlock(mesh_->current(s.b) - mesh_->current(s.a), s.rest_length, s.stiffness);
  }
  // b = h (f0 + h K v0), with K v0 at a = K (v_b - v_a).
  std::vector<Vec3> b, r, z, p, ap, dv = warm_;
  forces(&b);
  for (std::size_t i = 0; i < springs_.size(); ++i) {
    const Spring& s = springs_[i];
    const Vec3 kv = blocks_[i] * (mesh_->velocity(s.b) - mesh_->velocity(s.a));
    b[s.a] += dt * kv;
    b[s.b] -= dt * kv;
  }
  std::vector<Vec3> diag(n, Vec3::Zero());
  for (int v = 0; v < n; ++v) {
    b[v] *= dt;
    if (mesh_->vertexAlive(v)) diag[v].setConstant((1.0 + dt * params_.damping) * mass_[v]);
    if (fixed_[v] || !mesh_->vertexAlive(v)) {
      b[v].setZero();
      dv[v].setZero();
    }
  }
  for (std::size_t i = 0; i < springs_.size(); ++i) {
    const Vec3 d = dt * dt * blocks_[i].diagonal();
    diag[springs_[i].a] += d;
    diag[springs_[i].b] += d;
  }
  // Jacobi-preconditioned conjugate gradients, warm-started from the last step's answer.
  multiply(dt, dv, &ap);
  r.resize(n);
  z.resize(n);
  double b_norm = 0.0;
  for (int v = 0; v < n; ++v) {
    r[v] = b[v] - ap[v];
    b_norm += b[v].squaredNorm();
  }
  auto precondition = [&](const std::vector<Vec3>& in, std::vector<Vec3>* out) {
    for (int v = 0; v < n; ++v)
      (*out)[v] = (diag[v].array() > 0).select(in[v].array() / diag[v].array(), 0.0).matrix();
  };
  precondition(r, &z);
  p = z;
  double rz = 0.0;
  for (int v = 0; v < n; ++v) rz += r[v].dot(z[v]);
  const double tolerance2 = params_.cg_tolerance * params_.cg_tolerance * std::max(b_norm, 1e-300);
  int it = 0;
  for (; it < params_.cg_max_iterations; ++it) {
    double rr = 0.0;
    for (int v = 0; v < n; ++v) rr += r[v].squaredNorm();
    if (rr <= tolerance2) break;
    multiply(dt, p, &ap);
    double pap = 0.0;
    for (int v = 0; v < n; ++v) pap += p[v].dot(ap[v]);
    if (!(pap > 0)) break;
    const double alpha = rz / pap;
    for (int v = 0; v < n; ++v) {
      dv[v] += alpha * p[v];
      r[v] -= alpha * ap[v];
    }
    precondition(r, &z);
    double rz_next = 0.0;
    for (int v = 0; v < n; ++v) rz_next += r[v].dot(z[v]);
    const double beta = rz_next / rz;
    rz = rz_next;
    for (int v = 0; v < n; ++v) p[v] = z[v] + beta * p[v];
  }
  last_iterations_ = it;
  for (int v = 0; v < n; ++v) {
    if (!mesh_->vertexAlive(v)) continue;
    if (fixed_[v]) {
      mesh_->velocity(v).setZero();
      continue;
    }
    mesh_->velocity(v) += dv[v];
    mesh_->current(v) += dt * mesh_->velocity(v);
  }
  warm_ = dv;
  return true;
}

void MassSpring::stepSemiImplicit(double dt) {
  std::vector<Vec3> f;
  forces(&f);
  for (int v = 0; v < mesh_->vertexSlots(); ++v) {
    if (!mesh_->vertexAlive(v)) continue;
    if (fixed_[v] || !(mass_[v] > 0)) {
      mesh_->velocity(v).setZero();
      continue;
    }
    mesh_->velocity(v) += dt * f[v] / mass_[v];
    mesh_->current(v) += dt * mesh_->velocity(v);
  }
}

std::string MassSpring::step(double dt) {
  resize();
  const std::vector<Vec3> x0 = mesh_->currentPositions();
  if (params_.implicit) {
    stepImplicit(dt);
  } else {
    stepSemiImplicit(dt);
  }
  double worst = 0.0;
  bool finite = true;
  for (int v = 0; v < mesh_->vertexSlots(); ++v) {
    if (!mesh_->vertexAlive(v)) continue;
    finite = finite && mesh_->current(v).allFinite() && mesh_->velocity(v).allFinite();
    worst = std::max(worst, mesh_->velocity(v).norm());
  }
  if (finite && worst <= params_.max_speed) return "";
  // Roll back and damp: the tissue keeps its last good shape, at rest.
  mesh_->currentPositions() = x0;
  for (Vec3& u : mesh_->velocities()) u.setZero();
  std::fill(warm_.begin(), warm_.end(), Vec3::Zero());
  ++instabilities_;
  std::ostringstream msg;
  msg << "physics step unstable (" << (finite ? "speed " : "non-finite state, speed ") << worst
      << " m/s): rolled back and damped";
  return msg.str();
}

}  // namespace tissue_cut
