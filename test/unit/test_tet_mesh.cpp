// TetMesh: incidence, adjacency, boundary and validate() under the changes cuts and collapses use.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "tissue_cut/mesh/block.hpp"
#include "tissue_cut/mesh/inline_vector.hpp"
#include "tissue_cut/mesh/quality.hpp"
#include "tissue_cut/mesh/sorted_search.hpp"
#include "tissue_cut/mesh/stamped_table.hpp"
#include "tissue_cut/mesh/tet_mesh.hpp"

using namespace tissue_cut;

namespace {

// Two tets glued on face (1, 2, 3).
TetMesh twoTets() {
  Eigen::MatrixXd V(5, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1;
  Eigen::MatrixXi T(2, 4);
  T << 0, 1, 2, 3, 4, 1, 3, 2;
  return TetMesh(V, T);
}

// Splits every tet around edge ab at its midpoint; returns the new vertex.
int bisectEdge(TetMesh& mesh, int a, int b, ChangeRecord* record) {
  const int m = mesh.addVertex({{a, 0.5}, {b, 0.5}}, record);
  std::vector<int> star = mesh.edgeTets(a, b);
  std::vector<TetVerts> add;
  for (int t : star) {
    for (int end : {a, b}) {
      TetVerts tv = mesh.tet(t);
      *std::find(tv.begin(), tv.end(), end) = m;
      add.push_back(tv);
    }
  }
  mesh.replaceTets(star, add, record);
  return m;
}

// The built-in block after bisecting six edges drawn by rng: slots freed and reused, as cuts
// leave them.
TetMesh bisectedBlock(std::mt19937* rng) {
  const MeshData b = makeBlock();
  TetMesh mesh(b.V, b.T);
  for (int k = 0; k < 6; ++k) {
    const auto edges = mesh.edges();
    const auto [a, c] = edges[(*rng)() % edges.size()];
    bisectEdge(mesh, a, c, nullptr);
  }
  return mesh;
}

// Every slot, tet, adjacency, star order and the boundary count agree (ASSERTs: the first
// difference stops the test, named with `what`).
// The boundary faces through u, counted from the adjacency.
int boundaryFacesThrough(const TetMesh& mesh, int u) {
  int through = 0;
  for (int t : mesh.vertexTets(u))
    for (int f = 0; f < 4; ++f) through += mesh.tet(t)[f] != u && mesh.neighbor(t, f) < 0;
  return through;
}

void expectSameMesh(const TetMesh& a, const TetMesh& b, const std::string& what) {
  ASSERT_EQ(a.tetSlots(), b.tetSlots()) << what;
  for (int t = 0; t < a.tetSlots(); ++t) {
    ASSERT_EQ(a.tetAlive(t), b.tetAlive(t)) << what << ", tet " << t;
    if (!a.tetAlive(t)) continue;
    ASSERT_EQ(a.tet(t), b.tet(t)) << what << ", tet " << t;
    for (int f = 0; f < 4; ++f)
      ASSERT_EQ(a.neighbor(t, f), b.neighbor(t, f)) << what << ", tet " << t;
  }
  ASSERT_EQ(a.vertexSlots(), b.vertexSlots()) << what;
  for (int u = 0; u < a.vertexSlots(); ++u) {
    ASSERT_EQ(a.vertexTets(u), b.vertexTets(u)) << what << ", vertex " << u;
    // Each one's kept count of boundary faces, as counted from its tets.
    ASSERT_EQ(a.boundaryFacesAt(u), boundaryFacesThrough(a, u)) << what << ", vertex " << u;
    ASSERT_EQ(b.boundaryFacesAt(u), boundaryFacesThrough(b, u)) << what << ", vertex " << u;
  }
  ASSERT_EQ(a.numBoundaryFaces(), b.numBoundaryFaces()) << what;
}

// Every live tet's kept rest Q and rest volume are the ones measured now, to the bit.
void expectKeptQuality(const TetMesh& mesh, const std::string& what) {
  int wrong = 0;
  for (int t = 0; t < mesh.tetSlots(); ++t) {
    if (!mesh.tetAlive(t)) continue;
    const TetVerts& tv = mesh.tet(t);
    const double q =
        tetQuality(mesh.rest(tv[0]), mesh.rest(tv[1]), mesh.rest(tv[2]), mesh.rest(tv[3]));
    if (mesh.restQuality(t) != q && ++wrong <= 3)
      ADD_FAILURE() << what << ": tet " << t << " keeps " << mesh.restQuality(t) << ", has " << q;
    const double volume =
        signedVolume(mesh.rest(tv[0]), mesh.rest(tv[1]), mesh.rest(tv[2]), mesh.rest(tv[3]));
    if (mesh.restVolume(t) != volume && ++wrong <= 3)
      ADD_FAILURE() << what << ": tet " << t << " keeps volume " << mesh.restVolume(t) << ", has "
                    << volume;
  }
  EXPECT_EQ(wrong, 0) << what;
}

}  // namespace

// The table that notes a few keys out of many (append()'s slots, the quiet reach's edges): the
// same answers as a map, through passes of different sizes, growth past the size it was given,
// keys that collide (consecutive ids, multiples of its size) and values replaced.
TEST(StampedTable, AnswersAsAMapThroughPassesAndGrowth) {
  std::mt19937 rng(3);
  StampedTable<long long> table;
  EXPECT_FALSE(table.contains(7));  // never begun: empty
  std::unordered_map<std::uint64_t, long long> last;
  for (int pass = 0; pass < 300; ++pass) {
    const std::size_t expected = pass % 3 == 0 ? 0 : rng() % 200;
    table.begin(expected);
    std::unordered_map<std::uint64_t, long long> map;
    const int puts = static_cast<int>(rng() % 600);
    for (int k = 0; k < puts; ++k) {
      // Consecutive keys, keys of one residue, and keys anywhere.
      const std::uint64_t key = k % 3 == 0   ? static_cast<std::uint64_t>(pass * 1000 + k)
                                : k % 3 == 1 ? static_cast<std::uint64_t>(rng() % 64) * 1024
                                             : (std::uint64_t{rng()} << 32) | rng();
      const long long value = static_cast<long long>(rng());
      EXPECT_EQ(table.put(key, value), map.count(key) == 0) << "pass " << pass;
      map[key] = value;
    }
    for (const auto& [key, value] : map) {
      ASSERT_TRUE(table.contains(key)) << "pass " << pass;
      ASSERT_EQ(table.at(key), value) << "pass " << pass;
    }
    for (int k = 0; k < 200; ++k) {  // keys never put
      const std::uint64_t key = static_cast<std::uint64_t>(rng() % 2000) * 7 + 1'000'000'000ull;
      ASSERT_FALSE(table.contains(key)) << "pass " << pass;
    }
    for (const auto& [key, value] : last) {  // the last pass's keys are gone unless put again
      if (!map.count(key)) {
        ASSERT_FALSE(table.contains(key)) << "pass " << pass;
      }
    }
    last = map;
  }
}

// The in-place lists of a split: filled to their capacity, and never past it (a list that grew
// past its room would write over whatever follows it).
TEST(SortedSearch, LowerBoundIndexAnswersAsStdLowerBound) {
  // Every key from below the first to past the last, in lists of every length up to 70 (the
  // halvings' odd and even lengths), with runs of equal ids and gaps, and an empty list.
  std::mt19937 rng(7);
  for (int n = 0; n <= 70; ++n) {
    for (int trial = 0; trial < 4; ++trial) {
      std::vector<int> list;
      int id = static_cast<int>(rng() % 5) - 2;
      for (int i = 0; i < n; ++i) {
        id += static_cast<int>(rng() % 3);  // steps of 0 (a repeat), 1 or 2
        list.push_back(id);
      }
      const int lo = list.empty() ? -3 : list.front() - 2, hi = list.empty() ? 3 : list.back() + 2;
      for (int key = lo; key <= hi; ++key) {
        const auto expected = std::lower_bound(list.begin(), list.end(), key) - list.begin();
        ASSERT_EQ(lowerBoundIndex(list, key), static_cast<std::size_t>(expected))
            << "length " << n << ", key " << key;
      }
    }
  }
}

TEST(TetMesh, LocalIndexIsTheFirstPlaceHoldingTheVertex) {
  // Each place, ids of either sign and far apart, a vertex not held, and (in no tet, but the
  // answer is defined) a repeated one: the first place, as a search from the front finds it.
  const TetVerts tv{7, -3, 1 << 30, 0};
  EXPECT_EQ(localIndex(tv, 7), 0);
  EXPECT_EQ(localIndex(tv, -3), 1);
  EXPECT_EQ(localIndex(tv, 1 << 30), 2);
  EXPECT_EQ(localIndex(tv, 0), 3);
  EXPECT_EQ(localIndex(tv, 8), -1);
  EXPECT_EQ(localIndex(tv, -1), -1);
  EXPECT_EQ(localIndex(TetVerts{4, 5, 5, 4}, 5), 1);
  EXPECT_EQ(localIndex(TetVerts{4, 5, 5, 4}, 4), 0);
  EXPECT_EQ(localIndex(TetVerts{1, 2, 3, 9}, 9), 3);
}

TEST(InlineVector, HoldsUpToItsCapacityAndRefusesMore) {
  InlineVector<int, 3> v{4, 5};
  EXPECT_EQ(v.size(), 2u);
  v.push_back(6);
  EXPECT_EQ(std::vector<int>(v.begin(), v.end()), (std::vector<int>{4, 5, 6}));
  EXPECT_THROW(v.push_back(7), std::length_error);
  EXPECT_EQ(v.size(), 3u);
  EXPECT_EQ(v.back(), 6);
  const InlineVector<int, 3> copy = v;  // a copy holds its own items
  v[0] = 9;
  EXPECT_EQ(copy[0], 4);
  v.clear();
  EXPECT_TRUE(v.empty());
  EXPECT_EQ(copy.size(), 3u);
  EXPECT_THROW((InlineVector<int, 1>{1, 2}), std::length_error);
}

// A new vertex's parents are a tet's corners at most, kept in the change record in place: a
// fifth is refused before the mesh is touched.
TEST(TetMesh, AVertexHasAtMostFourParentsKeptInPlace) {
  TetMesh mesh = twoTets();
  ChangeRecord record;
  const int m = mesh.addVertex({{0, 0.25}, {1, 0.25}, {2, 0.25}, {3, 0.25}}, &record);
  ASSERT_EQ(record.vertex_parents.size(), 1u);
  EXPECT_EQ(record.vertex_parents[0].size(), 4u);
  EXPECT_EQ(record.vertex_parents[0][3].vertex, 3);
  EXPECT_EQ(mesh.rest(m), 0.25 * (mesh.rest(0) + mesh.rest(1) + mesh.rest(2) + mesh.rest(3)));
  const int slots = mesh.vertexSlots();
  EXPECT_THROW(mesh.addVertex({{0, 0.2}, {1, 0.2}, {2, 0.2}, {3, 0.2}, {4, 0.2}}, &record),
               std::length_error);
  EXPECT_EQ(mesh.vertexSlots(), slots);
  EXPECT_EQ(record.vertex_parents.size(), 1u);
}

TEST(TetMesh, AdjacencyAndBoundaryOfTwoGluedTets) {
  TetMesh mesh = twoTets();
  EXPECT_EQ(mesh.numTets(), 2);
  EXPECT_EQ(mesh.numBoundaryFaces(), 6);
  EXPECT_EQ(mesh.neighbor(0, 0), 1);  // face opposite vertex 0 is (1, 2, 3)
  EXPECT_EQ(mesh.neighbor(1, 0), 0);
  EXPECT_EQ(mesh.neighbor(0, 1), -1);
  EXPECT_EQ(mesh.edges().size(), 9u);
  EXPECT_EQ(mesh.validate(), "");
}

TEST(TetMesh, FlipsNegativelyOrientedTetsAndCountsThem) {
  Eigen::MatrixXd V(4, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  Eigen::MatrixXi T(1, 4);
  T << 0, 1, 3, 2;
  TetMesh mesh(V, T);
  EXPECT_EQ(mesh.reoriented(), 1);
  EXPECT_GT(mesh.restVolume(0), 0);
  EXPECT_EQ(mesh.validate(), "");
}

TEST(TetMesh, RefusesOutOfRangeIndexAndRepeatedVertex) {
  Eigen::MatrixXd V(4, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  Eigen::MatrixXi T(1, 4);
  T << 0, 1, 2, 4;
  EXPECT_THROW(TetMesh(V, T), std::invalid_argument);
  T << 0, 1, 2, 2;
  EXPECT_THROW(TetMesh(V, T), std::invalid_argument);
}

TEST(TetMesh, EdgeBisectionKeepsVolumeAndValidity) {
  const MeshData b = makeBlock();
  TetMesh mesh(b.V, b.T);
  const double volume = mesh.restVolume();
  auto edges = mesh.edges();
  const auto [a, c] = edges[edges.size() / 2];
  const int star = static_cast<int>(mesh.edgeTets(a, c).size());
  ChangeRecord record;
  const int m = bisectEdge(mesh, a, c, &record);
  EXPECT_EQ(mesh.validate(), "");
  EXPECT_NEAR(mesh.restVolume(), volume, 1e-15);
  EXPECT_EQ(static_cast<int>(record.removed_tets.size()), star);
  EXPECT_EQ(static_cast<int>(record.added_tets.size()), 2 * star);
  ASSERT_EQ(record.added_vertices.size(), 1u);
  EXPECT_EQ(record.added_vertices[0], m);
  EXPECT_TRUE(mesh.current(m).isApprox(0.5 * (mesh.current(a) + mesh.current(c))));
}

TEST(TetMesh, CuttingATenthMoreSlotsMovesNoVertexOrTetArray) {
  // The arrays keep slots to spare (slotCapacity()): the cuts of a session add a few percent of
  // vertices and tets, and a mesh-sized array copied within a tick cost the 20k organ's ticks
  // 0.5-0.8 ms. Bisecting edges adds a tenth more of both.
  const MeshData b = makeBlock();
  TetMesh mesh(b.V, b.T);
  const int vertices = mesh.vertexSlots(), tets = mesh.tetSlots();
  const Vec3* rest = mesh.restPositions().data();
  const Vec3* current = mesh.currentPositions().data();
  const Vec3* velocity = mesh.velocities().data();
  const TetVerts* tet0 = &mesh.tet(0);
  const auto edges = mesh.edges();
  for (std::size_t i = 0;
       mesh.vertexSlots() < vertices + vertices / 10 || mesh.tetSlots() < tets + tets / 10;
       i += 7) {
    ASSERT_LT(i, edges.size());
    bisectEdge(mesh, edges[i].first, edges[i].second, nullptr);
  }
  EXPECT_EQ(mesh.validate(), "");
  EXPECT_EQ(mesh.restPositions().data(), rest);
  EXPECT_EQ(mesh.currentPositions().data(), current);
  EXPECT_EQ(mesh.velocities().data(), velocity);
  EXPECT_EQ(&mesh.tet(0), tet0);
  // The helpers themselves: a quarter (and a little) to spare, then no move until it is used.
  std::vector<int> slots;
  assignSlots(&slots, 1000, 7);
  EXPECT_EQ(slots.size(), 1000u);
  EXPECT_GE(slots.capacity(), 1250u);
  const int* data = slots.data();
  growSlots(&slots, 1200, -1);
  EXPECT_EQ(slots.data(), data);
  EXPECT_EQ(slots[999], 7);
  EXPECT_EQ(slots[1199], -1);
  growSlots(&slots, 10, -1);  // never shrinks
  EXPECT_EQ(slots.size(), 1200u);
  resizeSlots(&slots, 10, -1);  // sizes exactly
  EXPECT_EQ(slots.size(), 10u);
}

TEST(TetMesh, MergingTheBisectionPointBackRestoresTheMesh) {
  const MeshData b = makeBlock();
  TetMesh mesh(b.V, b.T);
  auto edges = mesh.edges();
  const auto [a, c] = edges[edges.size() / 3];
  const int m = bisectEdge(mesh, a, c, nullptr);
  ChangeRecord record;
  mesh.mergeVertices(m, a, &record);
  EXPECT_EQ(mesh.validate(), "");
  EXPECT_EQ(mesh.numTets(), b.T.rows());
  EXPECT_EQ(mesh.numVertices(), b.V.rows());
  ASSERT_EQ(record.merged_vertices.size(), 1u);
  EXPECT_EQ(record.merged_vertices[0], std::make_pair(m, a));
  EXPECT_FALSE(mesh.vertexAlive(m));
}

// ChangeRecord::append composes records into the net change: what was added and removed again
// vanishes, what stays removed was there at the start, every live tet is either added or there
// unchanged since the start, and an added tet continues a removed tet of the start or is new.
// Bisections, their undoing and vertex moves (whose tets continue the ones they replace), a few
// or a couple of hundred, appended one by one, or in two halves composed apart and then
// appended; by noting the slots' places first, by scanning the short lists and noting for the
// long ones, or by scanning them all (append's scan limit 0, 256 or none): all give the same
// record.
TEST(TetMesh, AppendedRecordsGiveTheNetChange) {
  for (const int operations : {7, 200}) {
    const MeshData b = makeBlock();
    TetMesh mesh(b.V, b.T);
    const int slots = mesh.tetSlots();
    std::vector<TetVerts> start(slots);
    for (int t = 0; t < slots; ++t) start[t] = mesh.tet(t);
    std::mt19937 rng(operations);
    std::vector<ChangeRecord> steps;
    int last_mid = -1, last_end = -1;
    for (int k = 0; k < operations; ++k) {
      ChangeRecord step;
      if (k % 4 == 2) {
        mesh.mergeVertices(last_mid, last_end, &step);  // the bisection just made, undone
      } else if (k % 4 == 3) {
        const int v = static_cast<int>(rng() % b.V.rows());  // its star announced as replaced
        mesh.moveVertex(v, {{v, 1.0}}, &step);
      } else {
        const auto edges = mesh.edges();
        const auto [a, c] = edges[rng() % edges.size()];
        last_mid = bisectEdge(mesh, a, c, &step);
        last_end = a;
      }
      steps.push_back(step);
    }
    ASSERT_EQ(mesh.validate(), "");
    std::vector<ChangeRecord> composed;
    for (const std::size_t limit : {std::size_t{0}, std::size_t{256}, ~std::size_t{0}}) {
      ChangeRecord first, second;
      for (int k = 0; k < operations; ++k)
        (operations > 100 && k >= operations / 2 ? second : first).append(steps[k], limit);
      first.append(second, limit);
      composed.push_back(first);
    }
    for (int way = 1; way < 3; ++way) {
      EXPECT_EQ(composed[0].removed_tets, composed[way].removed_tets) << operations << " " << way;
      EXPECT_EQ(composed[0].added_tets, composed[way].added_tets) << operations << " " << way;
      EXPECT_EQ(composed[0].added_from, composed[way].added_from) << operations << " " << way;
      EXPECT_EQ(composed[0].added_vertices, composed[way].added_vertices) << operations;
      EXPECT_EQ(composed[0].removed_vertices, composed[way].removed_vertices) << operations;
    }
    const ChangeRecord& total = composed[0];
    const std::set<int> removed(total.removed_tets.begin(), total.removed_tets.end());
    const std::set<int> added(total.added_tets.begin(), total.added_tets.end());
    EXPECT_EQ(removed.size(), total.removed_tets.size()) << operations << ": each once";
    EXPECT_EQ(added.size(), total.added_tets.size()) << operations << ": each once";
    EXPECT_GT(removed.size(), 0u);
    for (int t : removed) EXPECT_LT(t, slots) << "removed tet " << t << " was not there";
    for (int t = 0; t < mesh.tetSlots(); ++t) {
      const bool unchanged = t < slots && !removed.count(t);
      if (!mesh.tetAlive(t)) {
        EXPECT_FALSE(unchanged) << operations << ": tet " << t << " went unannounced";
        EXPECT_FALSE(added.count(t)) << operations << ": dead tet " << t << " is added";
        continue;
      }
      EXPECT_NE(unchanged, added.count(t) == 1) << operations << ": tet " << t;
      if (unchanged) {
        EXPECT_EQ(mesh.tet(t), start[t]) << operations << ": tet " << t;
      }
    }
    ASSERT_EQ(total.added_from.size(), total.added_tets.size());
    // A tet only moved continues its tet of the start: same corners, `from` that slot.
    int continued = 0;
    for (std::size_t i = 0; i < total.added_tets.size(); ++i) {
      const int from = total.added_from[i];
      if (from < 0) continue;
      ++continued;
      EXPECT_TRUE(removed.count(from)) << operations << ": continues " << from;
      EXPECT_EQ(mesh.tet(total.added_tets[i]), start[from]) << operations << ": continues " << from;
    }
    EXPECT_GT(continued, 0) << operations;
    for (int v : total.added_vertices) EXPECT_TRUE(mesh.vertexAlive(v)) << operations;
  }
}

// moveVertex announces the moved vertex's star as replaced by the same tets; it must leave the
// mesh exactly as that replacement does: slots, adjacency and each vertex's list of tets in the
// same order (the remeshers and the cutter walk them in that order), and the same record. Moves
// of interior and boundary vertices, each after some cuts left free slots, on two copies of a
// block: one moved, the other replaced. A move that would flatten a tet is refused with the
// mesh unchanged.
TEST(TetMesh, MovingAVertexEqualsReplacingItsStarByTheSameTets) {
  std::mt19937 rng(3);
  TetMesh moved = bisectedBlock(&rng);
  TetMesh replaced = moved;
  for (int k = 0; k < 40; ++k) {
    const int v = static_cast<int>(rng() % moved.vertexSlots());
    if (!moved.vertexAlive(v)) continue;
    ChangeRecord by_move, by_replace;
    moved.moveVertex(v, {{v, 1.0}}, &by_move);
    const std::vector<int> star = replaced.vertexTets(v);
    std::vector<TetVerts> same;
    for (int t : star) same.push_back(replaced.tet(t));
    replaced.replaceTets(star, same, &by_replace, &star);
    EXPECT_EQ(by_move.removed_tets, by_replace.removed_tets) << "vertex " << v;
    EXPECT_EQ(by_move.added_tets, by_replace.added_tets) << "vertex " << v;
    EXPECT_EQ(by_move.added_from, by_replace.added_from) << "vertex " << v;
    expectSameMesh(moved, replaced, "moving vertex " + std::to_string(v));
    if (HasFatalFailure()) return;
  }
  EXPECT_EQ(moved.validate(), "");
  EXPECT_EQ(moved.numBoundaryFaces(), replaced.numBoundaryFaces());
  // Onto a neighbour's far side: some tet of the star turns inside out. Refused, nothing moved.
  const int v = moved.tet(0)[0];
  const int w = moved.tet(0)[1];
  const Vec3 rest = moved.rest(v), current = moved.current(v);
  const std::vector<int> star = moved.vertexTets(v);
  EXPECT_THROW(moved.moveVertex(v, {{v, -1.0}, {w, 2.0}}, nullptr), std::logic_error);
  EXPECT_EQ(moved.rest(v), rest);
  EXPECT_EQ(moved.current(v), current);
  EXPECT_EQ(moved.vertexTets(v), star);
  EXPECT_EQ(moved.validate(), "");
}

// A cut opens a vertex by giving a group of its tets a copy of it; renameVertex must leave the
// mesh and the record exactly as replacing the group by its renamed tets does (slots, adjacency,
// the order of every star: later choices depend on them).
TEST(TetMesh, RenamingAVertexEqualsReplacingItsTetsByTheRenamedTets) {
  std::mt19937 rng(5);
  TetMesh renamed = bisectedBlock(&rng);
  TetMesh replaced = renamed;
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int splits = 0, opened = 0;
  for (int k = 0; k < 200 && splits < 40; ++k) {
    const int v = static_cast<int>(rng() % renamed.vertexSlots());
    if (!renamed.vertexAlive(v) || renamed.vertexTets(v).size() < 2) continue;
    // The tets on one side of a plane through v, as a cut through it would group them.
    const Vec3 n(unit(rng), unit(rng), unit(rng));
    std::vector<int> group;
    for (int t : renamed.vertexTets(v)) {
      Vec3 centre = Vec3::Zero();
      for (int x : renamed.tet(t)) centre += 0.25 * renamed.rest(x);
      if (n.dot(centre - renamed.rest(v)) > 0) group.push_back(t);
    }
    if (group.empty() || group.size() == renamed.vertexTets(v).size()) continue;
    const std::string what = "split " + std::to_string(splits) + " of vertex " + std::to_string(v);
    ChangeRecord by_rename, by_replace;
    const int boundary = renamed.numBoundaryFaces();
    const int copy = renamed.addVertex({{v, 1.0}}, &by_rename);
    const std::vector<int> ids = renamed.renameVertex(group, v, copy, &by_rename);
    ASSERT_EQ(replaced.addVertex({{v, 1.0}}, &by_replace), copy);
    std::vector<TetVerts> tets;
    for (int t : group) {
      TetVerts tv = replaced.tet(t);
      *std::find(tv.begin(), tv.end(), v) = copy;
      tets.push_back(tv);
    }
    EXPECT_EQ(ids, replaced.replaceTets(group, tets, &by_replace, &group)) << what;
    EXPECT_EQ(by_rename.removed_tets, by_replace.removed_tets) << what;
    EXPECT_EQ(by_rename.added_tets, by_replace.added_tets) << what;
    EXPECT_EQ(by_rename.added_from, by_replace.added_from) << what;
    EXPECT_EQ(by_rename.added_vertices, by_replace.added_vertices) << what;
    expectSameMesh(renamed, replaced, what);
    if (HasFatalFailure()) return;
    EXPECT_TRUE(renamed.vertexTets(copy).size() == group.size()) << what;
    opened += renamed.numBoundaryFaces() > boundary;
    ++splits;
  }
  EXPECT_EQ(splits, 40);
  EXPECT_GT(opened, 20);  // most splits open faces (the case that differs from moveVertex)
}

// renameVertex checks before it changes anything: a copy with tets, a tet without v, a dead or
// repeated tet, v as its own copy; each refused with the mesh as it was.
TEST(TetMesh, RefusedRenameLeavesTheMeshUnchanged) {
  TetMesh mesh = twoTets();
  const TetMesh before = mesh;
  const int copy = mesh.addVertex({{1, 1.0}}, nullptr);
  const TetMesh with_copy = mesh;
  EXPECT_THROW(mesh.renameVertex({0}, 1, 4, nullptr), std::logic_error);        // 4 has a tet
  EXPECT_THROW(mesh.renameVertex({0, 1}, 0, copy, nullptr), std::logic_error);  // 1 lacks 0
  EXPECT_THROW(mesh.renameVertex({0, 0}, 1, copy, nullptr), std::logic_error);
  EXPECT_THROW(mesh.renameVertex({7}, 1, copy, nullptr), std::logic_error);
  EXPECT_THROW(mesh.renameVertex({0}, 1, 1, nullptr), std::logic_error);
  expectSameMesh(mesh, with_copy, "after the refusals");
  // And one that goes through: tet 0 takes the copy of 1, and face (1, 2, 3) opens on both sides.
  const std::vector<int> ids = mesh.renameVertex({0}, 1, copy, nullptr);
  EXPECT_EQ(ids, std::vector<int>{0});
  EXPECT_EQ(mesh.tet(0), (TetVerts{0, copy, 2, 3}));
  EXPECT_EQ(mesh.neighbor(0, 0), -1);
  EXPECT_EQ(mesh.neighbor(1, 0), -1);
  EXPECT_EQ(mesh.numBoundaryFaces(), before.numBoundaryFaces() + 2);
  EXPECT_EQ(mesh.vertexTets(1), std::vector<int>{1});
  EXPECT_EQ(mesh.vertexTets(copy), std::vector<int>{0});
}

TEST(TetMesh, RemovedSlotsAreReusedAndAnnounced) {
  TetMesh mesh = twoTets();
  ChangeRecord record;
  const TetVerts t1 = mesh.tet(1);
  auto ids = mesh.replaceTets({1}, {t1}, &record);
  ASSERT_EQ(ids.size(), 1u);
  EXPECT_EQ(ids[0], 1);
  EXPECT_EQ(record.removed_tets, std::vector<int>{1});
  EXPECT_EQ(record.added_tets, std::vector<int>{1});
  EXPECT_EQ(mesh.tetSlots(), 2);
  EXPECT_EQ(mesh.validate(), "");
}

TEST(TetMesh, RefusedReplacementLeavesTheMeshUnchanged) {
  TetMesh mesh = twoTets();
  // A third tet on face (1, 2, 3) would make it shared by three tets.
  const int v = mesh.addVertex({{4, 1.0}}, nullptr);
  EXPECT_THROW(mesh.replaceTets({}, {{v, 1, 2, 3}}, nullptr), std::logic_error);
  EXPECT_EQ(mesh.numTets(), 2);
  EXPECT_EQ(mesh.neighbor(0, 0), 1);
  mesh.removeVertex(v, nullptr);
  EXPECT_EQ(mesh.validate(), "");
}

// The checks before a replacement: a tet removed twice, a dead tet, a face the added tets would
// share three ways among themselves; each refused with the mesh unchanged, and a removed tet's
// faces count as free for the ones added (so the next call, after the refusals, goes through).
TEST(TetMesh, ReplacementChecksRemovedTetsAndNewFaces) {
  TetMesh mesh = twoTets();
  const TetVerts t0 = mesh.tet(0), t1 = mesh.tet(1);
  auto unchanged = [&] {
    EXPECT_EQ(mesh.numTets(), 2);
    EXPECT_EQ(mesh.tet(0), t0);
    EXPECT_EQ(mesh.tet(1), t1);
    EXPECT_EQ(mesh.neighbor(0, 0), 1);
  };
  EXPECT_THROW(mesh.replaceTets({1, 1}, {t1}, nullptr), std::logic_error);
  unchanged();
  EXPECT_THROW(mesh.replaceTets({2}, {}, nullptr), std::logic_error);
  EXPECT_THROW(mesh.replaceTets({-1}, {}, nullptr), std::logic_error);
  unchanged();
  // Tet 1 out, two tets on face (1, 2, 3) beyond it: with tet 0 that face is shared three ways.
  const int v = mesh.addVertex({{4, 0.5}, {0, -0.5}, {1, 1.0}}, nullptr);
  EXPECT_THROW(mesh.replaceTets({1}, {t1, {v, 1, 3, 2}}, nullptr), std::logic_error);
  unchanged();
  // Both out, and three new tets on that face: shared three ways among the new tets alone.
  EXPECT_THROW(mesh.replaceTets({0, 1}, {t0, t1, {v, 1, 3, 2}}, nullptr), std::logic_error);
  unchanged();
  // Tet 1 out and a tet on its face in: the face is tet 1's no more, so it may be taken.
  ChangeRecord record;
  const auto ids = mesh.replaceTets({1}, {{v, 1, 3, 2}}, &record);
  ASSERT_EQ(ids.size(), 1u);
  EXPECT_EQ(mesh.neighbor(0, 0), ids[0]);
  mesh.removeVertex(4, nullptr);
  EXPECT_EQ(mesh.validate(), "");
}

TEST(TetMesh, ReplacementRefusesAFlatTet) {
  // A split whose piece is flat (a point on an edge of its own base) must not reach the mesh:
  // validate() would call it invalid. Refused before anything changes.
  TetMesh mesh = twoTets();
  const TetVerts t0 = mesh.tet(0);
  const int mid = mesh.addVertex({{t0[0], 0.5}, {t0[1], 0.5}}, nullptr);
  EXPECT_THROW(mesh.replaceTets({0}, {{t0[0], t0[1], t0[2], mid}}, nullptr), std::logic_error);
  EXPECT_EQ(mesh.numTets(), 2);
  EXPECT_EQ(mesh.tet(0), t0);
  mesh.removeVertex(mid, nullptr);
  EXPECT_EQ(mesh.validate(), "");
}

TEST(TetMesh, ValidateNamesAZeroVolumeTet) {
  Eigen::MatrixXd V(4, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0;
  Eigen::MatrixXi T(1, 4);
  T << 0, 1, 2, 3;
  TetMesh mesh(V, T);
  EXPECT_NE(mesh.validate().find("non-positive rest volume"), std::string::npos);
}

TEST(TetMesh, ValidateNamesTetsSharingOnlyAnEdge) {
  Eigen::MatrixXd V(6, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, -1, 0.5, -1, -1;
  Eigen::MatrixXi T(2, 4);
  T << 0, 1, 2, 3, 0, 1, 4, 5;
  TetMesh mesh(V, T);
  // The edge shared by the two tets is named, in either of its orientations.
  const std::string err = mesh.validate();
  EXPECT_TRUE(err.find("boundary edge (0, 1) appears in 2") != std::string::npos ||
              err.find("boundary edge (1, 0) appears in 2") != std::string::npos)
      << err;
}

TEST(TetMesh, ValidateNamesAPinchedVertex) {
  Eigen::MatrixXd V(7, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, -1, 0, 0, 0, -1, 0, 0, 0, -1;
  Eigen::MatrixXi T(2, 4);
  T << 0, 1, 2, 3, 0, 4, 6, 5;
  TetMesh mesh(V, T);
  EXPECT_NE(mesh.validate().find("pinched at vertex 0"), std::string::npos) << mesh.validate();
}

TEST(TetMesh, ValidateNamesAnIsolatedVertex) {
  TetMesh mesh = twoTets();
  mesh.addVertex({{0, 1.0}}, nullptr);
  EXPECT_NE(mesh.validate().find("has no tetrahedron"), std::string::npos);
}

TEST(TetMesh, HasEdgeAnswersAsTheEdgesStar) {
  // Every pair of vertices of a block with a bisected edge: an edge exactly when its star is not
  // empty, and the bounded star as the star (the remeshers ask these without allocating).
  BlockSpec spec;
  spec.cell_size = 0.02;
  const MeshData b = makeBlock(spec);
  TetMesh mesh(b.V, b.T);
  const auto [a0, b0] = mesh.edges().front();
  ChangeRecord record;
  bisectEdge(mesh, a0, b0, &record);
  int edges = 0, pairs = 0;
  for (int u = 0; u < mesh.vertexSlots(); ++u)
    for (int v = 0; v < mesh.vertexSlots(); ++v) {
      if (u == v || !mesh.vertexAlive(u) || !mesh.vertexAlive(v)) continue;
      ++pairs;
      // The star from its definition: u's tets that hold v, in u's order.
      std::vector<int> star;
      for (int t : mesh.vertexTets(u))
        if (localIndex(mesh.tet(t), v) >= 0) star.push_back(t);
      ASSERT_EQ(mesh.edgeTets(u, v), star) << u << "-" << v;
      const bool edge = !star.empty();
      ASSERT_EQ(mesh.hasEdge(u, v), edge) << u << "-" << v;
      // The bounded form: the whole count, the first two written in the same order.
      int first[2] = {-1, -1};
      ASSERT_EQ(mesh.edgeTets(u, v, first, 2), static_cast<int>(star.size())) << u << "-" << v;
      for (int k = 0; k < std::min<int>(2, star.size()); ++k) ASSERT_EQ(first[k], star[k]);
      edges += edge;
    }
  EXPECT_EQ(edges, 2 * static_cast<int>(mesh.edges().size()));
  EXPECT_LT(edges, pairs);
  EXPECT_FALSE(mesh.hasEdge(a0, b0));  // bisected: gone
}

// The remeshers read a tet's rest Q from the mesh, which measures it when the tet is made and
// when a vertex of it moves: every kind of change must leave it right.
TEST(TetMesh, KeepsEachTetsRestQualityThroughEveryChange) {
  std::mt19937 rng(5);
  TetMesh mesh = bisectedBlock(&rng);  // replacements into freed and new slots
  expectKeptQuality(mesh, "bisected");
  int moves = 0, renames = 0, merges = 0, renames_in_place = 0;
  // v's tets handed to a new vertex made of `parents`, v removed (the new one, if refused).
  auto renameAll = [&](int v, const VertexParents& parents, int* count) {
    const int copy = mesh.addVertex(parents, nullptr);
    try {
      mesh.renameVertex(mesh.vertexTets(v), v, copy, nullptr);
      mesh.removeVertex(v, nullptr);
      ++*count;
    } catch (const std::logic_error&) {
      mesh.removeVertex(copy, nullptr);
    }
  };
  for (int k = 0; k < 80; ++k) {
    const auto edges = mesh.edges();
    const auto [v, w] = edges[rng() % edges.size()];
    switch (k % 4) {
      case 0:  // a smoothing move of v a fifth of the way to w (refused where a tet would flip)
        try {
          mesh.moveVertex(v, {{v, 0.8}, {w, 0.2}}, nullptr);
          ++moves;
        } catch (const std::logic_error&) {
        }
        expectKeptQuality(mesh, "moving " + std::to_string(v));
        break;
      case 1:  // v's tets handed to a copy a tenth of the way to w: the copy's rest differs
        renameAll(v, {{v, 0.9}, {w, 0.1}}, &renames);
        expectKeptQuality(mesh, "renaming " + std::to_string(v));
        break;
      case 3:  // v's tets handed to a copy where v is (the cutter's copies are): the tets keep
               // what they had, in their new slots
        renameAll(v, {{v, 1.0}}, &renames_in_place);
        expectKeptQuality(mesh, "renaming in place " + std::to_string(v));
        break;
      default:  // a collapse of v onto w
        try {
          mesh.mergeVertices(v, w, nullptr);
          ++merges;
        } catch (const std::logic_error&) {
        }
        expectKeptQuality(mesh, "merging " + std::to_string(v));
    }
    if (HasFailure()) return;
  }
  // Each kind of change happened (the seed is fixed; the counts only guard the test's reach).
  EXPECT_GT(moves, 5);
  EXPECT_GT(renames, 5);
  EXPECT_GT(merges, 5);
  EXPECT_GT(renames_in_place, 5);
  EXPECT_EQ(mesh.validate(), "");
}
