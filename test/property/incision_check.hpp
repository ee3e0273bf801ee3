// Replays a random incision through Tissue::step and checks the properties every cut must keep:
// validate() after every tick, and at the end a valid mesh with a closed boundary, the rest
// volume conserved (cutting and collapse move no material), nothing left pending, finite
// positions, and a bounded mesh size. Shared by test_property (CI and the long run).
#pragma once

#include <chrono>
#include <cmath>
#include <exception>
#include <sstream>
#include <string>

#include "random_incision.hpp"
#include "tissue_cut/mesh/topology.hpp"
#include "tissue_cut/tissue.hpp"

namespace tissue_cut::property {

/// Limits of the end checks.
struct IncisionLimits {
  double volume_tolerance = 1e-3;  ///< relative change of the rest volume allowed
  /// Most tets one replaced tet may become (the widest split, the centroid fallback, is well
  /// under this) [count].
  double max_created_per_cut = 24.0;
  /// The final mesh may hold at most this many times the initial tets [ratio].
  double max_growth = 8.0;
};

struct IncisionOutcome {
  std::string failure;  ///< "" when every property held
  int ticks = 0;
  int cut_tetrahedra = 0;
  int created_tetrahedra = 0;
  int collapsed_edges = 0;
  int pieces = 0;
  double volume_error = 0.0;  ///< relative change of the rest volume
  double growth = 0.0;        ///< final tets / initial tets
  double seconds = 0.0;
};

/// Inputs: config (physics, collapse...; cut.blade_length and rate are taken from the incision),
/// mesh (#V by 3, #T by 4), the incision. Output: the figures, and the first property broken.
inline IncisionOutcome checkIncision(Config config, const MeshData& mesh,
                                     const RandomIncision& incision,
                                     const IncisionLimits& limits = {}) {
  IncisionOutcome out;
  const auto start = std::chrono::steady_clock::now();
  config.cut.blade_length = incision.blade_length;
  config.rate = incision.rate;
  const double dt = 1.0 / incision.rate;
  try {
    Tissue tissue(config, mesh);
    const double volume0 = tissue.mesh().restVolume();
    const int tets0 = tissue.mesh().numTets();
    const ScalpelPath path(incision.poses);
    const double t0 = path.startTime(), t1 = path.endTime();
    const long long ticks = static_cast<long long>(std::ceil((t1 - t0) / dt - 1e-9));
    // As cut_replay does it: ticks over the path, then one tick with the blade lifted out.
    for (long long k = 1; k <= ticks + 1; ++k) {
      std::optional<BladeSegment> blade;
      if (k <= ticks) {
        const ToolPose pose = path.at(std::min(t0 + k * dt, t1));
        blade = bladeFromPose(pose.position, pose.orientation, incision.blade_length);
      }
      tissue.step(blade, dt);
      ++out.ticks;
      const std::string err = tissue.validate();
      if (!err.empty()) {
        out.failure = "tick " + std::to_string(k) + (k > ticks ? " (blade lifted)" : "") +
                      ": invalid mesh: " + err;
        return out;
      }
    }
    const TetMesh& m = tissue.mesh();
    const Statistics s = tissue.statistics();
    out.cut_tetrahedra = s.cut.cut_tetrahedra;
    out.created_tetrahedra = s.cut.created_tetrahedra;
    out.collapsed_edges = s.collapse.collapsed_edges;
    out.pieces = countPieces(m);
    out.volume_error = std::abs(m.restVolume() - volume0) / volume0;
    out.growth = double(m.numTets()) / tets0;
    std::ostringstream why;
    if (tissue.cutter().hasPending()) {
      why << "tets still pending after the blade was lifted: " << tissue.cutter().numPending();
    } else if (!(out.volume_error <= limits.volume_tolerance)) {
      why << "rest volume changed by " << out.volume_error * 100 << "% (" << volume0 << " -> "
          << m.restVolume() << " m^3)";
    } else if (boundaryEulerCharacteristic(m) % 2 != 0) {
      why << "boundary Euler characteristic " << boundaryEulerCharacteristic(m)
          << " is odd: not a union of closed surfaces";
    } else if (out.cut_tetrahedra > 0 &&
               out.created_tetrahedra > limits.max_created_per_cut * out.cut_tetrahedra) {
      why << out.created_tetrahedra << " tets created for " << out.cut_tetrahedra
          << " cut: more than " << limits.max_created_per_cut << " per cut tet";
    } else if (out.growth > limits.max_growth) {
      why << "mesh grew from " << tets0 << " to " << m.numTets() << " tets";
    } else {
      for (int v = 0; v < m.vertexSlots(); ++v) {
        if (m.vertexAlive(v) && !m.current(v).allFinite()) {
          why << "vertex " << v << " has a non-finite current position";
          break;
        }
      }
    }
    out.failure = why.str();
  } catch (const std::exception& e) {
    out.failure = std::string("exception: ") + e.what();
  }
  out.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace tissue_cut::property
