#include "octree.h"
#include "raylab/mesh_io.h"
#include "raylab/structure.h"
#include "triangle_box_overlap.h"

#include "support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cstdio>
#include <limits>
#include <random>
#include <set>

using namespace raylab;
using namespace raylab::test;  // support.h

namespace {

std::unique_ptr<Structure> build(const MeshPtr& mesh, StructureKind kind, int max_depth = 6, int leaf_size = 8,
                                 size_t memory_budget = BuildSettings{}.memory_budget) {
  BuildSettings s;
  s.kind = kind;
  s.max_depth = max_depth;
  s.leaf_size = leaf_size;
  s.memory_budget = memory_budget;
  return build_structure(mesh, s);
}

const Octree& octree_of(const Structure& s) { return dynamic_cast<const Octree&>(s); }

// A tiny triangle near `corner` of the unit cube, pointing inwards.
void add_corner_triangle(std::vector<glm::vec3>& v, std::vector<glm::uvec3>& t, glm::vec3 corner) {
  const glm::vec3 inward = glm::vec3(1.0f) - 2.0f * corner;  // +1 at a 0 coordinate, -1 at a 1
  const uint32_t base = uint32_t(v.size());
  v.push_back(corner);
  v.push_back(corner + 0.01f * glm::vec3(inward.x, 0, 0));
  v.push_back(corner + 0.01f * glm::vec3(0, inward.y, 0));
  t.push_back({base, base + 1, base + 2});
}

// One large tilted triangle across the unit cube plus a tiny triangle in every corner, so the octree
// splits all around the large one while its three vertices sit in only three octants.
MeshPtr large_triangle_mesh() {
  std::vector<glm::vec3> v = {{0.05f, 0.05f, 0.3f}, {0.95f, 0.1f, 0.6f}, {0.2f, 0.95f, 0.7f}};
  std::vector<glm::uvec3> t = {{0, 1, 2}};
  for (int c = 0; c < 8; ++c) add_corner_triangle(v, t, glm::vec3(c & 1, (c >> 1) & 1, (c >> 2) & 1));
  return mesh_of(std::move(v), std::move(t));
}

TraversalStats count_closest(const Structure& s, const std::vector<Ray>& rays) {
  std::vector<Hit> hits(rays.size());
  TraversalStats stats;
  intersect_closest(s, rays, hits, &stats);
  return stats;
}

}  // namespace

TEST(OctreeTriangleBoxOverlap, DecidesBySeparatingAxesNotByVertices) {
  const Bounds box({0, 0, 0}, {1, 1, 1});
  // A large triangle through the box with every vertex outside it.
  EXPECT_TRUE(triangle_box_overlap(box, {-5, -5, 0.5f}, {5, -5, 0.5f}, {0, 10, 0.5f}));
  // Touching counts: a vertex on a face, an edge along an edge of the box.
  EXPECT_TRUE(triangle_box_overlap(box, {1, 0.5f, 0.5f}, {2, 0.5f, 0.5f}, {2, 1, 0.5f}));
  EXPECT_TRUE(triangle_box_overlap(box, {1, 1, -1}, {1, 1, 2}, {3, 3, 0}));
  // The triangle's bounds overlap the box in both cases below. A vertical triangle in the plane
  // x + y = 2.2 passes beside the corner (1, 1) (its normal separates) ...
  EXPECT_FALSE(triangle_box_overlap(box, {0.5f, 1.7f, -1}, {0.5f, 1.7f, 2}, {1.7f, 0.5f, 0.5f}));
  // ... and a triangle in the plane z = 0.5, which cuts the box, has its edge x + y = 2.1 beside the
  // corner (an edge axis separates).
  EXPECT_FALSE(triangle_box_overlap(box, {0.5f, 1.6f, 0.5f}, {1.6f, 0.5f, 0.5f}, {3, 3, 0.5f}));
  EXPECT_TRUE(triangle_box_overlap(box, {0.5f, 1.4f, 0.5f}, {1.4f, 0.5f, 0.5f}, {3, 3, 0.5f}));
}

TEST(OctreeTriangleBoxOverlap, OctantsAgreeWithTheSingleBoxTest) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> coordinate(-0.5f, 1.5f), size(0.0f, 0.6f);
  const Bounds box({0, 0, 0}, {1, 1, 1});
  int checked = 0;
  for (int i = 0; i < 20000; ++i) {
    const glm::vec3 a(coordinate(rng), coordinate(rng), coordinate(rng));
    const glm::vec3 b = a + size(rng) * glm::vec3(coordinate(rng), coordinate(rng), coordinate(rng));
    const glm::vec3 c = a + size(rng) * glm::vec3(coordinate(rng), coordinate(rng), coordinate(rng));
    if (!triangle_box_overlap(box, a, b, c)) continue;  // the octant test requires an overlap
    ++checked;
    const uint32_t octants = triangle_octant_overlaps(box, box.center(), a, b, c);
    for (int o = 0; o < 8; ++o)
      ASSERT_EQ(((octants >> o) & 1u) != 0, triangle_box_overlap(octant_bounds(box, o), a, b, c)) << "octant " << o;
  }
  EXPECT_GT(checked, 2000);
}

TEST(Octree, LargeTriangleIsHitWhereverBruteForceHitsItAtEveryDepth) {
  const MeshPtr mesh = large_triangle_mesh();
  const auto reference = build(mesh, StructureKind::None);
  for (int depth = 0; depth <= 8; ++depth) {
    SCOPED_TRACE("max_depth " + std::to_string(depth));
    const auto octree = build(mesh, StructureKind::Octree, depth, 1);
    int large_hits = 0;
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 48; ++x) {
        Ray ray;
        ray.origin = {(x + 0.5f) / 48.0f, (y + 0.5f) / 48.0f, 2.0f};
        ray.direction = {0.05f, -0.03f, -1.0f};
        Hit h;
        large_hits += reference->closest(ray, h) && h.triangle == 0;
        expect_same_closest(*reference, *octree, ray);
        EXPECT_EQ(reference->any(ray), octree->any(ray));
      }
    EXPECT_GT(large_hits, 500);  // the grid really crosses the large triangle
  }
}

TEST(Octree, EveryLeafHoldsExactlyTheTrianglesThatOverlapIt) {
  for (const MeshPtr& mesh : {large_triangle_mesh(), shipped("spot_low_resolution.obj")}) {
    const auto s = build(mesh, StructureKind::Octree, 5, 1);
    const Octree& octree = octree_of(*s);
    const std::vector<BoxInfo> boxes = octree.boxes();
    const float tolerance = 1e-6f * glm::length(octree.root_bounds().extent());
    int leaves = 0;
    for (uint32_t node = 0; node < boxes.size(); ++node) {
      if (!boxes[node].leaf) continue;
      ++leaves;
      const Bounds& box = boxes[node].bounds;
      std::vector<bool> held(mesh->triangle_count(), false);
      for (uint32_t t : octree.leaf_triangles(node)) {
        held[t] = true;
        // No triangle merely near the box (bounds overlap is not enough).
        EXPECT_FALSE(clip_to_box(*mesh, t, box, tolerance).empty()) << "leaf " << node << " holds triangle " << t;
      }
      for (uint32_t t = 0; t < mesh->triangle_count(); ++t) {
        const Bounds tb = mesh->triangle_bounds(t);
        if (glm::any(glm::greaterThan(tb.lo, box.hi)) || glm::any(glm::lessThan(tb.hi, box.lo))) continue;
        if (!clip_to_box(*mesh, t, box, 0.0).empty())
          EXPECT_TRUE(held[t]) << "leaf " << node << " misses overlapping triangle " << t;
      }
    }
    EXPECT_GT(leaves, 20);
  }
}

TEST(Octree, DepthLeafSizeAndEmptyOctantsShapeTheTree) {
  const MeshPtr bunny = shipped("bunny.obj");
  const uint32_t n = uint32_t(bunny->triangle_count());

  const auto root_only = build(bunny, StructureKind::Octree, 0, 1);
  const std::vector<BoxInfo> root = root_only->boxes();
  ASSERT_EQ(root.size(), 1u);
  EXPECT_TRUE(root[0].leaf);
  EXPECT_EQ(root[0].triangle_count, n);
  const glm::vec3 side = root[0].bounds.extent();
  EXPECT_FLOAT_EQ(side.x, side.y);
  EXPECT_FLOAT_EQ(side.y, side.z);
  EXPECT_TRUE(root[0].bounds.contains(bunny->bounds().lo) && root[0].bounds.contains(bunny->bounds().hi));

  for (int max_depth : {3, 6}) {
    const int leaf_size = 4;
    const auto s = build(bunny, StructureKind::Octree, max_depth, leaf_size);
    const std::vector<BoxInfo> boxes = s->boxes();
    const auto nodes = octree_of(*s).nodes();
    int deepest = 0;
    for (uint32_t i = 0; i < boxes.size(); ++i) {
      const BoxInfo& b = boxes[i];
      deepest = std::max(deepest, b.depth);
      EXPECT_LE(b.depth, max_depth);
      EXPECT_GT(b.triangle_count, 0u) << "an empty octant was allocated";
      if (b.leaf && b.depth < max_depth) EXPECT_LE(b.triangle_count, uint32_t(leaf_size));
      if (!b.leaf) {
        EXPECT_GT(b.triangle_count, uint32_t(leaf_size));
        for (int octant = 0; octant < 8; ++octant)
          if ((nodes[i].child_mask() >> octant) & 1u) {
            const BoxInfo& child = boxes[nodes[i].child(octant)];
            EXPECT_EQ(child.depth, b.depth + 1);
            EXPECT_EQ(child.bounds.lo, octant_bounds(b.bounds, octant).lo);
            EXPECT_EQ(child.bounds.hi, octant_bounds(b.bounds, octant).hi);
          }
      }
    }
    EXPECT_EQ(deepest, max_depth);
  }

  // Two corner triangles: the root gets exactly the two octants that hold them.
  std::vector<glm::vec3> v;
  std::vector<glm::uvec3> t;
  add_corner_triangle(v, t, {0, 0, 0});
  add_corner_triangle(v, t, {1, 1, 1});
  const auto corners = build(mesh_of(v, t), StructureKind::Octree, 6, 1);
  const auto nodes = octree_of(*corners).nodes();
  ASSERT_EQ(nodes.size(), 3u);
  EXPECT_EQ(nodes[0].child_mask(), 0x81u);
  EXPECT_TRUE(nodes[1].leaf() && nodes[2].leaf());
}

// An inner box counts each triangle of its subtree once, however many of its leaves hold it.
TEST(Octree, BoxTriangleCountsAreTheSubtreesDistinctTriangles) {
  const MeshPtr bunny = shipped("bunny.obj");
  for (int max_depth : {2, 5, 8}) {
    const auto s = build(bunny, StructureKind::Octree, max_depth, 4);
    const Octree& octree = octree_of(*s);
    const std::vector<BoxInfo> boxes = s->boxes();
    const auto nodes = octree.nodes();
    for (uint32_t i = 0; i < boxes.size(); ++i) {
      std::set<uint32_t> below;
      std::vector<uint32_t> stack{i};
      while (!stack.empty()) {
        const uint32_t n = stack.back();
        stack.pop_back();
        if (nodes[n].leaf()) {
          for (uint32_t t : octree.leaf_triangles(n)) below.insert(t);
          continue;
        }
        for (int octant = 0; octant < 8; ++octant)
          if ((nodes[n].child_mask() >> octant) & 1u) stack.push_back(nodes[n].child(octant));
      }
      ASSERT_EQ(boxes[i].triangle_count, below.size()) << "box " << i << " at depth " << boxes[i].depth;
    }
  }
}

TEST(Octree, BuildIsDeterministic) {
  const MeshPtr mesh = shipped("bunny_hr.obj");
  const auto a = build(mesh, StructureKind::Octree, 7, 4);
  const auto b = build(mesh, StructureKind::Octree, 7, 4);
  const auto na = octree_of(*a).nodes(), nb = octree_of(*b).nodes();
  ASSERT_EQ(na.size(), nb.size());
  for (uint32_t i = 0; i < na.size(); ++i) {
    ASSERT_EQ(na[i].first, nb[i].first);
    ASSERT_EQ(na[i].bits, nb[i].bits);
    if (na[i].leaf()) ASSERT_TRUE(std::ranges::equal(octree_of(*a).leaf_triangles(i), octree_of(*b).leaf_triangles(i)));
  }
}

TEST(Octree, EqualsBruteForceOnShippedMeshes) {
  for (const char* name : {"bunny.obj", "plane_holes.obj"}) {
    SCOPED_TRACE(name);
    const MeshPtr mesh = shipped(name);
    const auto reference = build(mesh, StructureKind::None);
    const auto octree = build(mesh, StructureKind::Octree);
    for (const Ray& ray : random_rays(*mesh, 1500, 7)) {
      expect_same_closest(*reference, *octree, ray);
      EXPECT_EQ(reference->any(ray), octree->any(ray));
    }
  }
}

// The watertight leaf test takes 8 triangles at once with AVX2 and 4 with SSE: both give brute
// force's hits, and the same counts (every triangle of a leaf the ray has not tested is tested,
// whatever the packets' size), with mailboxing at work (leaves of one triangle, deep).
TEST(Octree, FourAndEightLeafLanesEqualBruteForceAndCountAlike) {
  std::vector<int> widths{4};
  if (cpu_has_avx2()) widths.push_back(8);
  for (const char* name : {"bunny.obj", "plane_holes.obj", "spot_low_resolution.obj"}) {
    SCOPED_TRACE(name);
    const MeshPtr mesh = shipped(name);
    const auto reference = build(mesh, StructureKind::None);
    for (const auto& [depth, leaf_size] : {std::pair{BuildSettings::kAutoDepth, 8}, std::pair{9, 1}}) {
      BuildSettings settings;
      settings.kind = StructureKind::Octree;
      settings.max_depth = depth;
      settings.leaf_size = leaf_size;
      std::vector<std::unique_ptr<Octree>> octrees;
      for (int lanes : widths) octrees.push_back(std::make_unique<Octree>(mesh, settings, lanes));
      for (const Ray& ray : random_rays(*mesh, 800, 21)) {
        TraversalStats first_closest, first_any;
        for (size_t i = 0; i < octrees.size(); ++i) {
          const Octree& octree = *octrees[i];
          expect_same_closest(*reference, octree, ray);
          TraversalStats closest, any;
          Hit h;
          octree.closest(ray, h, closest);
          EXPECT_EQ(reference->any(ray), octree.any(ray, any));
          const RayStory story = octree.story(ray);
          EXPECT_EQ(story.stats.triangle_tests, story.triangles.size());
          EXPECT_EQ(story.stats.triangle_tests, closest.triangle_tests);
          if (i == 0) {
            first_closest = closest, first_any = any;
            continue;
          }
          EXPECT_EQ(closest.triangle_tests, first_closest.triangle_tests);
          EXPECT_EQ(closest.box_tests, first_closest.box_tests);
          EXPECT_EQ(closest.nodes_visited, first_closest.nodes_visited);
          EXPECT_EQ(any.triangle_tests, first_any.triangle_tests);
          EXPECT_EQ(any.nodes_visited, first_any.nodes_visited);
        }
      }
    }
  }
  EXPECT_THROW(Octree(shipped("bunny.obj"), BuildSettings{}, 5), std::invalid_argument);
}

// Axis-parallel rays lying exactly in the splitting planes of the octree: the slab test meets
// 0 * inf there, and the hits sit on shared box faces.
TEST(Octree, AxisRaysInSplittingPlanesEqualBruteForce) {
  const MeshPtr mesh = shipped("bunny.obj");
  const auto reference = build(mesh, StructureKind::None);
  const auto octree = build(mesh, StructureKind::Octree);
  const std::vector<BoxInfo> boxes = octree->boxes();
  const Bounds root = octree_of(*octree).root_bounds();
  std::mt19937 rng(11);
  std::uniform_int_distribution<size_t> pick(0, boxes.size() - 1);
  int hits = 0;
  for (int i = 0; i < 3000; ++i) {
    const Bounds& box = boxes[pick(rng)].bounds;
    const int axis = i % 3;
    const bool forward = (i / 3) % 2 == 0;
    Ray ray;
    ray.origin = (i / 6) % 2 ? box.lo : box.hi;  // a corner: on three splitting planes
    ray.origin[axis] = forward ? root.lo[axis] - 1.0f : root.hi[axis] + 1.0f;
    ray.direction = glm::vec3(0.0f);
    ray.direction[axis] = forward ? 1.0f : -1.0f;
    Hit h;
    hits += reference->closest(ray, h);
    expect_same_closest(*reference, *octree, ray);
    EXPECT_EQ(reference->any(ray), octree->any(ray));
  }
  EXPECT_GT(hits, 300);
}

TEST(Octree, DegenerateMeshesGetAValidRootOrNone) {
  const MeshPtr flat = mesh_of({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}}, {{0, 1, 2}, {1, 3, 2}});
  const MeshPtr point = mesh_of({{2, 3, 4}}, {{0, 0, 0}, {0, 0, 0}});
  for (const MeshPtr& mesh : {flat, point}) {
    const auto s = build(mesh, StructureKind::Octree, 4, 1);
    for (const BoxInfo& b : s->boxes()) EXPECT_FALSE(b.bounds.empty());
    const Bounds root = octree_of(*s).root_bounds();
    EXPECT_GT(root.hi.z, root.lo.z);
  }
  Ray down;
  down.origin = {0.6f, 0.7f, 1.0f};
  down.direction = {0, 0, -1};
  Hit h;
  EXPECT_TRUE(build(flat, StructureKind::Octree, 4, 1)->closest(down, h));
  EXPECT_EQ(h.triangle, 1u);

  const auto empty = build(mesh_of({}, {}), StructureKind::Octree);
  EXPECT_TRUE(empty->boxes().empty());
  EXPECT_EQ(empty->story(down).status, RayStatus::MissedRoot);
  EXPECT_FALSE(empty->any(down));
}

TEST(Octree, TinyMemoryBudgetThrowsBuildError) {
  const MeshPtr bunny = shipped("bunny.obj");
  EXPECT_THROW(build(bunny, StructureKind::Octree, 6, 8, 4096), BuildError);
  // A budget that holds the root level but not the splits stops inside the build.
  EXPECT_THROW(build(bunny, StructureKind::Octree, 6, 8, 64 * 1024), BuildError);
  try {
    build(bunny, StructureKind::Octree, 6, 8, 4096);
  } catch (const BuildError& e) {
    EXPECT_NE(std::string(e.what()).find("memory budget"), std::string::npos);
  }
  const auto fits = build(bunny, StructureKind::Octree, 6, 8);
  EXPECT_GT(fits->memory_bytes(), 0u);
}

TEST(Octree, DeepTinyLeafBuildOnDragonFitsTheBudgetOrStops) {
  const MeshPtr dragon = shipped("dragon.obj");
  try {
    const auto s = build(dragon, StructureKind::Octree, 16, 1);
    EXPECT_LE(s->memory_bytes(), BuildSettings{}.memory_budget);
  } catch (const BuildError& e) {
    EXPECT_NE(std::string(e.what()).find("memory budget"), std::string::npos);
  }
}

TEST(Octree, StoryOfOneRayShowsTheFourStatuses) {
  std::vector<glm::vec3> v;
  std::vector<glm::uvec3> t;
  add_corner_triangle(v, t, {0, 0, 0});
  add_corner_triangle(v, t, {1, 1, 1});
  const auto s = build(mesh_of(v, t), StructureKind::Octree, 6, 1);
  auto story = [&](glm::vec3 origin, glm::vec3 direction) {
    Ray r;
    r.origin = origin;
    r.direction = direction;
    return s->story(r);
  };
  const glm::vec3 down(0, 0, -1);

  const RayStory outside = story({2, 2, 2}, down);
  EXPECT_EQ(outside.status, RayStatus::MissedRoot);
  EXPECT_EQ(outside.stats.rays_ignored, 1u);
  EXPECT_TRUE(outside.nodes.empty());

  // Through the octants x > 0.5, y < 0.5, which hold nothing: only the root is entered.
  const RayStory empty_space = story({0.75f, 0.25f, 2}, down);
  EXPECT_EQ(empty_space.status, RayStatus::MissedNodes);
  EXPECT_EQ(empty_space.stats.rays_ignored, 0u);
  ASSERT_EQ(empty_space.nodes.size(), 1u);
  EXPECT_TRUE(empty_space.boxes[0].hit);
  EXPECT_TRUE(empty_space.triangles.empty());

  // Through the leaf of the lower corner, beside its triangle.
  const RayStory beside = story({0.1f, 0.1f, 2}, down);
  EXPECT_EQ(beside.status, RayStatus::MissedTriangles);
  ASSERT_EQ(beside.triangles.size(), 1u);
  EXPECT_EQ(beside.triangles[0].triangle, 0u);
  EXPECT_FALSE(beside.triangles[0].hit);

  // From above the upper corner's octant down to the lower corner's triangle: both leaves are
  // entered, front to back, and the first one's triangle is tested and missed on the way.
  const RayStory hit = story({0.9f, 0.9f, 1.5f}, glm::vec3(0.002f, 0.002f, 0.0f) - glm::vec3(0.9f, 0.9f, 1.5f));
  EXPECT_EQ(hit.status, RayStatus::HitObject);
  EXPECT_EQ(hit.hit.triangle, 0u);
  ASSERT_EQ(hit.boxes.size(), 3u);
  EXPECT_EQ(hit.boxes[1].node, 2u);
  EXPECT_EQ(hit.boxes[2].node, 1u);
  EXPECT_TRUE(hit.boxes[1].hit && hit.boxes[2].hit);
  EXPECT_LT(hit.boxes[1].t_entry, hit.boxes[2].t_entry);
  ASSERT_EQ(hit.nodes.size(), 3u);
  EXPECT_EQ(hit.nodes[1].node, 2u);
  EXPECT_EQ(hit.nodes[2].node, 1u);
  ASSERT_EQ(hit.triangles.size(), 2u);
  EXPECT_FALSE(hit.triangles[0].hit);
  EXPECT_TRUE(hit.triangles[1].hit);
}

TEST(Octree, TestsFarFewerTrianglesThanAabb) {
  const MeshPtr bunny = shipped("bunny.obj");
  const std::vector<Ray> rays = camera_rays(*bunny, 64, 64, glm::vec3(0, 0, 1));
  const TraversalStats aabb = count_closest(*build(bunny, StructureKind::Aabb), rays);
  const TraversalStats octree = count_closest(*build(bunny, StructureKind::Octree, 6, 8), rays);
  const double per_ray_aabb = double(aabb.triangle_tests) / rays.size();
  const double per_ray_octree = double(octree.triangle_tests) / rays.size();
  std::printf("bunny.obj camera rays: triangle tests per ray: aabb %.1f, octree %.1f; box tests per ray: octree %.1f\n",
              per_ray_aabb, per_ray_octree, double(octree.box_tests) / rays.size());
  EXPECT_GT(aabb.triangle_tests, 0u);
  EXPECT_LT(per_ray_octree, 0.1 * per_ray_aabb);
}

// Issue 10, finding 5: a tiny negative direction component (here below float's smallest normal)
// with the origin on the octree's split planes. It behaves exactly like zero, in every structure.
TEST(OctreeExactness, TinyDirectionComponentsOnASplitPlaneBehaveLikeZero) {
  const MeshPtr sphere = shipped("sphere.obj");
  const auto reference = build(sphere, StructureKind::None);
  Ray zero;
  zero.origin = {-5, 0, 0};
  zero.direction = {1, 0, 0};
  Hit expected;
  ASSERT_TRUE(reference->closest(zero, expected));
  EXPECT_NEAR(expected.t, 4.0f, 1e-5f);
  for (float z : {-1e-39f, -2.8e-39f, -1e-45f, -0.0f, 1e-39f, -1e-30f, -1e-20f}) {
    Ray tiny = zero;
    tiny.direction.z = z;
    for (StructureKind kind : {StructureKind::None, StructureKind::Aabb, StructureKind::Octree, StructureKind::Bvh}) {
      const auto s = build(sphere, kind, 8, 1);
      Hit h;
      ASSERT_TRUE(s->closest(tiny, h)) << structure_kind_name(kind) << " z = " << z;
      EXPECT_EQ(h.t, expected.t) << structure_kind_name(kind) << " z = " << z;
      EXPECT_EQ(h.triangle, expected.triangle) << structure_kind_name(kind) << " z = " << z;
      EXPECT_TRUE(s->any(tiny)) << structure_kind_name(kind) << " z = " << z;
    }
  }
}

// The SIMD test of a node's eight octants is the scalar box test of each octant's own box, bit for bit:
// random boxes and rays, axis-parallel rays, origins exactly on the node's faces and mid-planes (the
// NaN of 0 * inf), -0 and tiny direction components, and every far limit.
TEST(OctreeExactness, OctantTestEqualsTheBoxTestOfEachOctant) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  std::uniform_int_distribution<int> pick(0, 5);
  int hits = 0, misses = 0;
  for (int i = 0; i < 200000; ++i) {
    const glm::vec3 lo(unit(rng), unit(rng), unit(rng));
    const Bounds box(lo, lo + glm::vec3(0.01f + std::abs(unit(rng))));
    const glm::vec3 mid = box.center();
    glm::vec3 origin(3 * unit(rng), 3 * unit(rng), 3 * unit(rng)), direction(unit(rng), unit(rng), unit(rng));
    for (int axis = 0; axis < 3; ++axis) {
      switch (pick(rng)) {
        case 0: direction[axis] = 0.0f; break;
        case 1: direction[axis] = -0.0f; break;
        case 2:
          origin[axis] = mid[axis];
          direction[axis] = 0.0f;
          break;
        case 3:
          origin[axis] = box.lo[axis];
          direction[axis] = i % 2 ? 0.0f : -1e-39f;
          break;
        default: break;
      }
    }
    Ray ray = ray_of(origin, direction, i % 3 ? 0.0f : 0.5f * std::abs(unit(rng)));
    // The root the pad is measured from: a larger box around this one, or the box itself.
    const Bounds root = i % 2 ? box : Bounds(box.lo - glm::vec3(2.0f), box.hi + glm::vec3(2.0f));
    const BoxRay r(ray, root);
    const OctantRay octant_ray(r);
    for (float tmax : {kInfinity, 1.0f, 3.0f, ray.tmin, std::numeric_limits<float>::quiet_NaN()}) {
      float got[8];
      const uint32_t mask = intersect_octants(OctantBox::load(box.lo, box.hi), octant_ray, tmax, got);
      for (int octant = 0; octant < 8; ++octant) {
        float expected = -7.0f;
        const bool a = intersect_box(octant_bounds(box, octant), r, tmax, expected);
        ASSERT_EQ(a, ((mask >> octant) & 1u) != 0) << "ray " << i << " octant " << octant;
        if (a) ASSERT_EQ(std::bit_cast<uint32_t>(expected), std::bit_cast<uint32_t>(got[octant])) << "ray " << i;
        (a ? hits : misses)++;
      }
    }
  }
  EXPECT_GT(hits, 100000);
  EXPECT_GT(misses, 100000);
}

// The walk's front-to-back order: bit k of the permuted mask is the octant k ^ flip.
TEST(OctreeExactness, OctantMaskPermutationPutsOctantKXorFlipAtBitK) {
  for (uint32_t mask = 0; mask < 256; ++mask)
    for (int flip = 0; flip < 8; ++flip) {
      const uint32_t permuted = xor_permute_octants(mask, flip);
      ASSERT_EQ(permuted & ~0xffu, 0u);
      for (int k = 0; k < 8; ++k) ASSERT_EQ((permuted >> k) & 1u, (mask >> (k ^ flip)) & 1u) << mask << " " << flip;
    }
}
