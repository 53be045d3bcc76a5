#include "bvh.h"
#include "raylab/mesh_io.h"
#include "support.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <utility>

using namespace raylab;
using raylab::test::flat_grid;

namespace {

MeshPtr load(const char* name) {
  return std::make_shared<const TriangleMesh>(load_mesh(std::string(RAYLAB_MESH_DIR) + "/" + name));
}

BuildSettings settings_for(StructureKind kind, int leaf_size = 8, TriangleTest test = TriangleTest::Watertight) {
  BuildSettings s;
  s.kind = kind;
  s.leaf_size = leaf_size;
  s.triangle_test = test;
  return s;
}

// Rays from around the mesh aimed at points inside its box (mostly hits), and some in any direction.
// Flat boxes are thickened for the origins so the rays stay clear of grazing the flat mesh.
std::vector<Ray> random_rays(const Bounds& box, size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  const float largest = glm::max(glm::max(box.extent().x, box.extent().y), box.extent().z);
  const glm::vec3 extent = glm::max(box.extent(), glm::vec3(0.25f * largest));
  auto point_in = [&](glm::vec3 lo, glm::vec3 size) {
    return lo + raylab::test::draw_vec3([&] { return unit(rng); }) * size;
  };
  std::vector<Ray> rays(n);
  for (size_t i = 0; i < n; ++i) {
    Ray& r = rays[i];
    r.origin = point_in(box.lo - extent, 3.0f * extent);
    const glm::vec3 target =
        (i % 4 == 3) ? point_in(glm::vec3(-1.0f), glm::vec3(2.0f)) + r.origin : point_in(box.lo, extent);
    r.direction = target - r.origin;
    if (glm::length(r.direction) == 0.0f) r.direction = {0, 0, 1};
  }
  return rays;
}

// Closest and any hit of `s` equal brute force exactly (same triangle, t, u, v) on every ray.
void expect_same_as_brute_force(const Structure& s, const std::vector<Ray>& rays) {
  const auto brute = build_structure(s.mesh_ptr(), settings_for(StructureKind::None, 8, s.settings().triangle_test));
  size_t hits = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    Hit expected, got;
    const bool e = brute->closest(rays[i], expected);
    const bool g = s.closest(rays[i], got);
    ASSERT_EQ(e, g) << "ray " << i;
    ASSERT_EQ(brute->any(rays[i]), s.any(rays[i])) << "ray " << i;
    if (!e) continue;
    ++hits;
    ASSERT_EQ(expected.triangle, got.triangle) << "ray " << i;
    ASSERT_EQ(expected.t, got.t) << "ray " << i;
    ASSERT_EQ(expected.u, got.u) << "ray " << i;
    ASSERT_EQ(expected.v, got.v) << "ray " << i;
  }
  EXPECT_GT(hits, rays.size() / 8);  // the rays really exercise the traversal
}

// Checks the tree's invariants: each triangle exactly once, with its own vertices, leaf sizes, and
// boxes enclosing their content.
template <int W>
void expect_well_formed(const Bvh& bvh, const std::vector<BvhWideNode<W>>& nodes, uint32_t leaf_size) {
  const TriangleMesh& mesh = bvh.mesh();
  ASSERT_EQ(bvh.width(), W);
  std::vector<int> seen(mesh.triangle_count(), 0);
  for (size_t n = 0; n < nodes.size(); ++n) {
    for (int i = 0; i < W; ++i) {
      if (!nodes[n].used(i)) continue;
      const Bounds box = nodes[n].bounds(i);
      if (!nodes[n].leaf(i)) {
        const uint32_t c = nodes[n].child[i];
        ASSERT_GT(c, n);
        ASSERT_LT(c, nodes.size());
        for (int j = 0; j < W; ++j)
          if (nodes[c].used(j)) EXPECT_TRUE(box.contains(nodes[c].bounds(j).lo) && box.contains(nodes[c].bounds(j).hi));
        continue;
      }
      const uint32_t count = nodes[n].count[i];
      EXPECT_LE(count, leaf_size);
      for (uint32_t k = 0; k < count; ++k) {
        const TrianglePacket& packet = bvh.packets()[nodes[n].child[i] + k / 4];
        const uint32_t t = packet.triangle[k % 4];
        ASSERT_LT(t, mesh.triangle_count());
        ++seen[t];
        for (int c = 0; c < 3; ++c) {
          const glm::vec3 p(packet.p[c][0][k % 4], packet.p[c][1][k % 4], packet.p[c][2][k % 4]);
          EXPECT_EQ(p, mesh.vertex(t, c));
          EXPECT_TRUE(box.contains(p));
        }
      }
    }
  }
  for (size_t t = 0; t < seen.size(); ++t) ASSERT_EQ(seen[t], 1) << "triangle " << t;
}

void expect_well_formed(const Bvh& bvh, uint32_t leaf_size) {
  if (bvh.width() == 8) {
    EXPECT_TRUE(bvh.nodes().empty());
    expect_well_formed(bvh, bvh.nodes8(), leaf_size);
  } else {
    EXPECT_TRUE(bvh.nodes8().empty());
    expect_well_formed(bvh, bvh.nodes(), leaf_size);
  }
}

// The node widths this CPU runs: the SSE path always, the AVX2 path where the CPU has it.
std::vector<int> widths() { return cpu_has_avx2() ? std::vector<int>{4, 8} : std::vector<int>{4}; }

const Bvh& as_bvh(const Structure& s) { return dynamic_cast<const Bvh&>(s); }

}  // namespace

TEST(BvhBuild, EveryTriangleAppearsExactlyOnceInTheLeaves) {
  for (int leaf_size : {1, 4, 8}) {
    const auto s = build_structure(load("bunny.obj"), settings_for(StructureKind::Bvh, leaf_size));
    expect_well_formed(as_bvh(*s), uint32_t(leaf_size));
  }
}

TEST(BvhBuild, IsTheSameOnOneThreadAsOnAll) {
  const MeshPtr mesh = load("dragon.obj");  // large enough for parallel binning and subtree tasks
  const auto a = [&] {
    tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
    return build_structure(mesh, settings_for(StructureKind::Bvh));
  }();
  const auto b = build_structure(mesh, settings_for(StructureKind::Bvh));
  const Bvh& ta = as_bvh(*a);
  const Bvh& tb = as_bvh(*b);
  ASSERT_EQ(ta.nodes().size(), tb.nodes().size());
  ASSERT_EQ(ta.nodes8().size(), tb.nodes8().size());
  ASSERT_EQ(ta.packets().size(), tb.packets().size());
  // One of the two node vectors is empty (its data() may be null: no memcmp on it).
  if (!ta.nodes().empty())
    EXPECT_EQ(0, std::memcmp(ta.nodes().data(), tb.nodes().data(), ta.nodes().size() * sizeof(Bvh4Node)));
  if (!ta.nodes8().empty())
    EXPECT_EQ(0, std::memcmp(ta.nodes8().data(), tb.nodes8().data(), ta.nodes8().size() * sizeof(Bvh8Node)));
  EXPECT_EQ(0, std::memcmp(ta.packets().data(), tb.packets().data(), ta.packets().size() * sizeof(TrianglePacket)));
}

TEST(BvhBuild, RefusesALeafBlockThatIsNotAPowerOfTwo) {
  const std::vector<Bounds> prims{{glm::vec3(0.0f), glm::vec3(1.0f)}, {glm::vec3(2.0f), glm::vec3(3.0f)}};
  EXPECT_THROW(build_binary_bvh(prims, 8, 3), std::invalid_argument);
  EXPECT_THROW(build_binary_bvh(prims, 8, 0), std::invalid_argument);
  EXPECT_EQ(build_binary_bvh(prims, 8, 4).prims.size(), 2u);
}

// Enough boxes for several reference tasks and for subtrees built as local trees and placed in
// parallel; every seventh box is empty.
TEST(BvhBuild, LeavesOutEmptyBoxesAsIfTheyWereNeverGiven) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> coord(-10.0f, 10.0f), size(0.0f, 0.5f);
  std::vector<Bounds> all, kept;
  std::vector<uint32_t> kept_index;
  for (uint32_t i = 0; i < 20000; ++i) {
    if (i % 7 == 3) {
      all.push_back(Bounds());
      continue;
    }
    const glm::vec3 lo(coord(rng), coord(rng), coord(rng));
    all.push_back({lo, lo + glm::vec3(size(rng), size(rng), size(rng))});
    kept.push_back(all.back());
    kept_index.push_back(i);
  }
  const BinaryBvh with_empty = build_binary_bvh(all, 4, 4);
  const BinaryBvh without = build_binary_bvh(kept, 4, 4);
  ASSERT_EQ(with_empty.nodes.size(), without.nodes.size());
  EXPECT_EQ(0, std::memcmp(with_empty.nodes.data(), without.nodes.data(), without.nodes.size() * sizeof(BvhNode)));
  ASSERT_EQ(with_empty.prims.size(), kept.size());
  for (size_t i = 0; i < kept.size(); ++i) EXPECT_EQ(with_empty.prims[i], kept_index[without.prims[i]]);
  // The callback form builds the same tree.
  const BinaryBvh from_callback = build_binary_bvh(
      uint32_t(all.size()), [&](uint32_t b, uint32_t e, Bounds* out) { std::copy(&all[b], &all[e], out); }, 4, 4);
  ASSERT_EQ(from_callback.nodes.size(), with_empty.nodes.size());
  EXPECT_EQ(
      0, std::memcmp(from_callback.nodes.data(), with_empty.nodes.data(), with_empty.nodes.size() * sizeof(BvhNode)));
  EXPECT_EQ(from_callback.prims, with_empty.prims);
}

TEST(BvhBuild, BoxesReportDepthsLeavesAndSubtreeCounts) {
  const auto s = build_structure(load("sphere.obj"), settings_for(StructureKind::Bvh, 4));
  const std::vector<BoxInfo> boxes = s->boxes();
  ASSERT_FALSE(boxes.empty());
  EXPECT_EQ(boxes[0].depth, 0);
  EXPECT_EQ(boxes[0].triangle_count, s->mesh().triangle_count());
  uint32_t in_leaves = 0;
  int max_depth = 0;
  for (const BoxInfo& b : boxes) {
    if (b.leaf) in_leaves += b.triangle_count;
    max_depth = std::max(max_depth, b.depth);
  }
  EXPECT_EQ(in_leaves, s->mesh().triangle_count());
  EXPECT_GE(max_depth, 3);  // 1280 triangles in leaves of at most 4: more than log8(320) levels
  EXPECT_GT(s->memory_bytes(), 0u);
}

TEST(BvhBuild, OverTheMemoryBudgetIsABuildError) {
  BuildSettings settings = settings_for(StructureKind::Bvh);
  settings.memory_budget = 1000;
  EXPECT_THROW(build_structure(load("bunny.obj"), settings), BuildError);
}

TEST(BvhBuild, EmptyMeshMissesEverything) {
  auto mesh = std::make_shared<TriangleMesh>();
  const auto s = build_structure(mesh, settings_for(StructureKind::Bvh));
  Hit h;
  EXPECT_FALSE(s->closest(Ray{}, h));
  EXPECT_FALSE(s->any(Ray{}));
  EXPECT_EQ(s->story(Ray{}).status, RayStatus::MissedRoot);
}

TEST(BvhDegenerate, IdenticalTrianglesTerminateAndKeepTheLowestIndex) {
  auto mesh = std::make_shared<TriangleMesh>();
  mesh->vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh->triangles.assign(5000, glm::uvec3(0, 1, 2));
  const auto s = build_structure(mesh, settings_for(StructureKind::Bvh, 4));
  expect_well_formed(as_bvh(*s), 4);
  Ray ray;
  ray.origin = {0.25f, 0.25f, 1.0f};
  ray.direction = {0, 0, -1};
  Hit h;
  ASSERT_TRUE(s->closest(ray, h));
  EXPECT_EQ(h.triangle, 0u);
  EXPECT_EQ(h.t, 1.0f);
  expect_same_as_brute_force(*s, random_rays(mesh->bounds(), 300, 7));
}

TEST(BvhDegenerate, FlatGridMatchesBruteForce) {
  const int n = 40;
  const MeshPtr mesh = flat_grid(n);
  const auto s = build_structure(mesh, settings_for(StructureKind::Bvh));
  expect_well_formed(as_bvh(*s), 8);
  expect_same_as_brute_force(*s, random_rays(mesh->bounds(), 3000, 11));
  // Straight down through grid vertices and edges: the ties the index tie-break settles.
  std::vector<Ray> axis_rays;
  for (int i = 0; i <= 2 * n; ++i) {
    Ray r;
    r.origin = {float(i) / (2 * n), float(i % 7) / 7, 1.0f};
    r.direction = {0, 0, -1};
    axis_rays.push_back(r);
  }
  expect_same_as_brute_force(*s, axis_rays);
}

TEST(BvhDegenerate, CoordinatesNearAMillionMatchBruteForce) {
  auto mesh = std::make_shared<TriangleMesh>(load_mesh(std::string(RAYLAB_MESH_DIR) + "/bunny.obj"));
  for (glm::vec3& v : mesh->vertices) v = v * 10.0f + glm::vec3(1e6f, -1e6f, 1e6f);
  const auto s = build_structure(mesh, settings_for(StructureKind::Bvh));
  expect_well_formed(as_bvh(*s), 8);
  expect_same_as_brute_force(*s, random_rays(mesh->bounds(), 2000, 3));
}

TEST(BvhTraversal, MatchesBruteForceOnShippedMeshes) {
  for (const char* name : {"bunny.obj", "teapot.obj", "spot_low_resolution.obj"}) {
    SCOPED_TRACE(name);
    for (int leaf_size : {1, 8}) {
      const auto s = build_structure(load(name), settings_for(StructureKind::Bvh, leaf_size));
      expect_same_as_brute_force(*s, random_rays(s->mesh().bounds(), 2000, 42 + leaf_size));
    }
  }
}

TEST(BvhTraversal, MollerTrumboreMatchesItsBruteForce) {
  const auto s = build_structure(load("teapot.obj"), settings_for(StructureKind::Bvh, 8, TriangleTest::MollerTrumbore));
  expect_same_as_brute_force(*s, random_rays(s->mesh().bounds(), 2000, 5));
}

TEST(BvhTraversal, CountsAndStoryFollowTheSameTraversal) {
  const auto s = build_structure(load("bunny.obj"), settings_for(StructureKind::Bvh));
  const Bounds box = s->mesh().bounds();
  Ray ray;
  ray.origin = box.center() - glm::vec3(0, 0, 2.0f * box.extent().z);
  ray.direction = {0, 0, 1};
  const RayStory story = s->story(ray);
  ASSERT_EQ(story.status, RayStatus::HitObject);
  Hit h;
  ASSERT_TRUE(s->closest(ray, h));
  EXPECT_EQ(story.hit.triangle, h.triangle);
  EXPECT_EQ(story.hit.t, h.t);
  TraversalStats stats;
  s->closest(ray, h, stats);
  EXPECT_EQ(stats.rays, 1u);
  EXPECT_EQ(stats.box_tests, story.boxes.size());
  EXPECT_EQ(stats.nodes_visited, story.nodes.size());
  EXPECT_EQ(stats.triangle_tests, story.triangles.size());
  EXPECT_LT(stats.triangle_tests, s->mesh().triangle_count() / 10);  // the hierarchy prunes
  EXPECT_EQ(story.boxes.front().node, 0u);
  EXPECT_EQ(story.nodes.front().node, 0u);
  // The story's node ids index boxes(): same box, same depth.
  const std::vector<BoxInfo> boxes = s->boxes();
  for (const StoryBox& b : story.boxes) {
    ASSERT_LT(b.node, boxes.size());
    EXPECT_EQ(boxes[b.node].bounds.lo, b.bounds.lo);
    EXPECT_EQ(boxes[b.node].bounds.hi, b.bounds.hi);
    EXPECT_EQ(boxes[b.node].depth, b.depth);
  }
  for (const StoryNode& n : story.nodes) {
    // Every entered node had its box tested and hit first.
    EXPECT_TRUE(std::any_of(story.boxes.begin(), story.boxes.end(),
                            [&](const StoryBox& b) { return b.node == n.node && b.hit; }));
  }

  Ray away = ray;
  away.direction = {0, 0, -1};
  const RayStory missed = s->story(away);
  EXPECT_EQ(missed.status, RayStatus::MissedRoot);
  EXPECT_EQ(missed.stats.rays_ignored, 1u);
  EXPECT_TRUE(missed.triangles.empty());
}

// Issue 10, finding 2: origins 1e-7 above a flat mesh (a sphere flattened to z = 0), rays in every
// direction. The triangle test's error there is many times the distance to the surface; the padded
// boxes must still contain every hit it reports.
TEST(BvhExactness, OriginsJustAboveAFlatMeshMatchBruteForce) {
  auto mesh = std::make_shared<TriangleMesh>(load_mesh(std::string(RAYLAB_MESH_DIR) + "/sphere.obj"));
  for (glm::vec3& v : mesh->vertices) v.z = 0.0f;
  const float radius = mesh->bounds().hi.x;
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  std::normal_distribution<float> normal;
  std::vector<Ray> rays;
  while (rays.size() < 20000) {
    Ray r;
    r.origin = {0.9f * radius * unit(rng), 0.9f * radius * unit(rng), 1e-7f};
    r.direction = {normal(rng), normal(rng), normal(rng)};
    if (glm::length(glm::vec2(r.origin)) < 0.9f * radius) rays.push_back(r);
  }
  for (StructureKind kind : {StructureKind::Aabb, StructureKind::Octree, StructureKind::Bvh}) {
    SCOPED_TRACE(structure_kind_name(kind));
    expect_same_as_brute_force(*build_structure(mesh, settings_for(kind)), rays);
  }
}

// Finding 3: a shadow ray whose tmax lies a hair (1e-6 relative) past the surface it ends on.
TEST(BvhExactness, TmaxJustPastAHitStillSeesIt) {
  auto mesh = std::make_shared<TriangleMesh>();
  mesh->vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  mesh->triangles = {{0, 1, 2}, {0, 2, 3}};
  const auto brute = build_structure(mesh, settings_for(StructureKind::None));
  std::vector<std::unique_ptr<Structure>> structures;
  for (StructureKind kind : {StructureKind::Aabb, StructureKind::Octree, StructureKind::Bvh})
    structures.push_back(build_structure(mesh, settings_for(kind)));
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  for (int i = 0; i < 2000; ++i) {
    Ray r;
    r.origin = {3 * unit(rng) - 1, 3 * unit(rng) - 1, 0.1f + 3 * unit(rng)};
    r.direction = glm::vec3(unit(rng), unit(rng), 0.0f) - r.origin;
    Hit expected;
    ASSERT_TRUE(brute->closest(r, expected)) << "ray " << i;
    r.tmax = expected.t * 1.000001f;
    for (const auto& s : structures) {
      Hit got;
      ASSERT_TRUE(s->closest(r, got)) << structure_kind_name(s->kind()) << " ray " << i;
      ASSERT_EQ(got.t, expected.t) << structure_kind_name(s->kind()) << " ray " << i;
      ASSERT_TRUE(s->any(r)) << structure_kind_name(s->kind()) << " ray " << i;
    }
  }
}

// Finding 4: a negative tmin means the same to every structure (the hit behind the origin).
TEST(BvhExactness, NegativeTminIsTheSameForEveryStructure) {
  auto mesh = std::make_shared<TriangleMesh>();
  mesh->vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  mesh->triangles = {{0, 1, 2}, {0, 2, 3}};
  Ray r;
  r.origin = {0.2f, 0.3f, 0.5f};
  r.direction = {0, 0, 1};
  r.tmin = -1.0f;
  for (StructureKind kind : {StructureKind::None, StructureKind::Aabb, StructureKind::Octree, StructureKind::Bvh}) {
    const auto s = build_structure(mesh, settings_for(kind));
    Hit h;
    ASSERT_TRUE(s->closest(r, h)) << structure_kind_name(kind);
    EXPECT_EQ(h.t, -0.5f) << structure_kind_name(kind);
    EXPECT_TRUE(s->any(r)) << structure_kind_name(kind);
  }
}

// Finding 7's other side: coordinates up to the limit are hit by every structure, exactly as brute force.
TEST(BvhExactness, CoordinatesUpToTheLimitMatchBruteForce) {
  for (float scale : {1e-15f, 1e18f, kMaxCoordinate / 2}) {  // random_rays squares lengths: not 1e-30
    auto mesh = std::make_shared<TriangleMesh>(load_mesh(std::string(RAYLAB_MESH_DIR) + "/bunny.obj"));
    const float extent = glm::length(mesh->bounds().extent());
    for (glm::vec3& v : mesh->vertices) v *= scale / extent;
    SCOPED_TRACE(scale);
    for (StructureKind kind : {StructureKind::Aabb, StructureKind::Octree, StructureKind::Bvh})
      expect_same_as_brute_force(*build_structure(mesh, settings_for(kind)), random_rays(mesh->bounds(), 1000, 5));
  }
}

// The widest nodes this CPU runs are the default; RAYLAB_BVH_WIDTH=4 (for measuring) is the one way
// to the SSE path on an AVX2 CPU, and an 8-wide tree without AVX2 is refused, not run.
TEST(BvhWidths, TheDefaultIsTheWidestThisCpuRuns) {
  const MeshPtr mesh = load("sphere.obj");
  const char* forced = std::getenv("RAYLAB_BVH_WIDTH");
  const int expected = (cpu_has_avx2() && !(forced && std::string(forced) == "4")) ? 8 : 4;
  EXPECT_EQ(Bvh(mesh, settings_for(StructureKind::Bvh)).width(), expected);
  EXPECT_THROW(Bvh(mesh, settings_for(StructureKind::Bvh), 6), std::invalid_argument);
  if (!cpu_has_avx2()) EXPECT_THROW(Bvh(mesh, settings_for(StructureKind::Bvh), 8), std::invalid_argument);
}

// Each width, forced, against brute force on the hard cases above (flat grid ties, coordinates near
// a million, tiny leaves, Möller–Trumbore), and with the counters, the story and boxes() agreeing.
TEST(BvhWidths, EveryWidthMatchesBruteForceAndTellsTheTruth) {
  auto grid = std::make_shared<TriangleMesh>();
  const int n = 40;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) grid->vertices.push_back({float(x) / n, float(y) / n, 0.0f});
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const uint32_t a = y * (n + 1) + x, b = a + 1, c = a + n + 1, d = c + 1;
      grid->triangles.push_back({a, b, d});
      grid->triangles.push_back({a, d, c});
    }
  auto far = std::make_shared<TriangleMesh>(load_mesh(std::string(RAYLAB_MESH_DIR) + "/bunny.obj"));
  for (glm::vec3& v : far->vertices) v = v * 10.0f + glm::vec3(1e6f, -1e6f, 1e6f);
  const std::pair<MeshPtr, int> cases[] = {{load("bunny.obj"), 8}, {load("teapot.obj"), 1}, {grid, 8}, {far, 4}};
  for (int width : widths()) {
    SCOPED_TRACE("width " + std::to_string(width));
    for (const auto& [mesh, leaf_size] : cases) {
      const Bvh bvh(mesh, settings_for(StructureKind::Bvh, leaf_size), width);
      expect_well_formed(bvh, uint32_t(leaf_size));
      const std::vector<Ray> rays = random_rays(mesh->bounds(), 1500, 17 + width);
      expect_same_as_brute_force(bvh, rays);
      const std::vector<BoxInfo> boxes = bvh.boxes();
      EXPECT_EQ(boxes[0].triangle_count, mesh->triangle_count());
      for (size_t i = 0; i < 200; ++i) {
        const RayStory story = bvh.story(rays[i]);
        TraversalStats stats;
        Hit h;
        bvh.closest(rays[i], h, stats);
        ASSERT_EQ(stats.box_tests, story.boxes.size());
        ASSERT_EQ(stats.nodes_visited, story.nodes.size());
        ASSERT_EQ(stats.triangle_tests, story.triangles.size());
        for (const StoryBox& b : story.boxes) {
          ASSERT_LT(b.node, boxes.size());
          ASSERT_EQ(boxes[b.node].bounds.lo, b.bounds.lo);
          ASSERT_EQ(boxes[b.node].bounds.hi, b.bounds.hi);
          ASSERT_EQ(boxes[b.node].depth, b.depth);
        }
      }
    }
    const Bvh mt(load("teapot.obj"), settings_for(StructureKind::Bvh, 8, TriangleTest::MollerTrumbore), width);
    expect_same_as_brute_force(mt, random_rays(mt.mesh().bounds(), 1500, 5));
  }
}
