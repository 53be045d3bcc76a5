// max_depth auto, the octree's default: the depth follows the triangle count and stays within the
// memory budget.
#include "octree.h"
#include "raylab/structure.h"

#include "support.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace raylab;
using namespace raylab::test;  // support.h

namespace {

BuildSettings octree_settings(int max_depth, int leaf_size, size_t memory_budget = BuildSettings{}.memory_budget) {
  BuildSettings s;
  s.kind = StructureKind::Octree;
  s.max_depth = max_depth;
  s.leaf_size = leaf_size;
  s.memory_budget = memory_budget;
  return s;
}

const Octree& octree_of(const Structure& s) { return dynamic_cast<const Octree&>(s); }

int deepest_box(const Structure& s) {
  int deepest = 0;
  for (const BoxInfo& b : s.boxes()) deepest = std::max(deepest, b.depth);
  return deepest;
}

void expect_brute_force_hits(const Structure& s, size_t rays) {
  BuildSettings none;
  none.kind = StructureKind::None;
  const auto reference = build_structure(s.mesh_ptr(), none);
  for (const Ray& ray : random_rays(s.mesh(), rays, 5)) {
    Hit expected, got;
    const bool a = reference->closest(ray, expected);
    ASSERT_EQ(a, s.closest(ray, got));
    ASSERT_EQ(reference->any(ray), s.any(ray));
    if (!a) continue;
    EXPECT_EQ(expected.triangle, got.triangle);
    EXPECT_EQ(expected.t, got.t);
    EXPECT_EQ(expected.u, got.u);
    EXPECT_EQ(expected.v, got.v);
  }
}

}  // namespace

TEST(OctreeAutoDepth, IsTheDefault) {
  EXPECT_EQ(BuildSettings{}.max_depth, BuildSettings::kAutoDepth);
  EXPECT_NO_THROW(BuildSettings{}.validate());
  BuildSettings below = BuildSettings{};
  below.max_depth = BuildSettings::kAutoDepth - 1;
  EXPECT_THROW(below.validate(), std::invalid_argument);
}

TEST(OctreeAutoDepth, GrowsWithTheTriangleCountAsLog4OfTrianglesPerLeaf) {
  for (int leaf_size : {1, 8, 32}) {
    SCOPED_TRACE("leaf_size " + std::to_string(leaf_size));
    const size_t leaf = size_t(leaf_size);
    EXPECT_EQ(Octree::auto_max_depth(0, leaf_size), Octree::kAutoDepthMargin);
    EXPECT_EQ(Octree::auto_max_depth(leaf, leaf_size), Octree::kAutoDepthMargin);
    EXPECT_EQ(Octree::auto_max_depth(leaf + 1, leaf_size), 1 + Octree::kAutoDepthMargin);
    EXPECT_EQ(Octree::auto_max_depth(16 * leaf, leaf_size), 2 + Octree::kAutoDepthMargin);
    EXPECT_EQ(Octree::auto_max_depth(16 * leaf + 1, leaf_size), 3 + Octree::kAutoDepthMargin);
    int previous = 0;
    for (double n = 1; n < 1e12; n *= 1.7) {
      const int depth = Octree::auto_max_depth(size_t(n), leaf_size);
      EXPECT_GE(depth, previous);
      EXPECT_LE(depth, Octree::kMaxDepth);
      // Below the cap: the fewest levels d with leaf_size * 4^d >= n, plus the margin.
      const int levels = depth - Octree::kAutoDepthMargin;
      if (depth < Octree::kMaxDepth && levels > 0) {
        EXPECT_GE(double(leaf) * std::pow(4.0, levels), double(size_t(n)));
        EXPECT_LT(double(leaf) * std::pow(4.0, levels - 1), double(size_t(n)));
      }
      previous = depth;
    }
    EXPECT_EQ(previous, Octree::kMaxDepth);
  }
}

// Meshes of increasing size (spot, bunny, bunny_hr): the default tree deepens with each,
// splits wherever a node holds more than leaf_size triangles above that depth, and stays exact.
TEST(OctreeAutoDepth, TheDefaultTreeDeepensWithTheMesh) {
  int previous_depth = -1;
  size_t previous_count = 0;
  for (const char* name : {"spot_low_resolution.obj", "bunny.obj", "bunny_hr.obj"}) {
    SCOPED_TRACE(name);
    const MeshPtr mesh = shipped(name);
    ASSERT_GT(mesh->triangle_count(), previous_count);
    BuildSettings settings;
    settings.kind = StructureKind::Octree;
    const auto s = build_structure(mesh, settings);
    const Octree& octree = octree_of(*s);
    EXPECT_EQ(s->settings().max_depth, BuildSettings::kAutoDepth);
    EXPECT_EQ(octree.max_depth(), Octree::auto_max_depth(mesh->triangle_count(), settings.leaf_size));
    EXPECT_GT(octree.max_depth(), previous_depth);
    EXPECT_LE(deepest_box(*s), octree.max_depth());
    for (const BoxInfo& b : s->boxes())
      if (b.leaf && b.depth < octree.max_depth()) EXPECT_LE(b.triangle_count, uint32_t(settings.leaf_size));
    expect_brute_force_hits(*s, 300);
    previous_depth = octree.max_depth();
    previous_count = mesh->triangle_count();
  }
}

// Where the tree the triangle count allows would pass the memory budget, auto ends it at the last
// level that fits (a fixed depth refuses instead).
TEST(OctreeAutoDepth, StaysWithinTheMemoryBudget) {
  const MeshPtr mesh = shipped("bunny_hr.obj");
  const auto free = build_structure(mesh, octree_settings(BuildSettings::kAutoDepth, 1));
  const int full_depth = octree_of(*free).max_depth();
  ASSERT_EQ(deepest_box(*free), full_depth);
  // The finished tree alone: the build needs more than this while it works.
  const size_t budget = free->memory_bytes();
  const auto limited = build_structure(mesh, octree_settings(BuildSettings::kAutoDepth, 1, budget));
  EXPECT_LT(octree_of(*limited).max_depth(), full_depth);
  EXPECT_EQ(deepest_box(*limited), octree_of(*limited).max_depth());
  EXPECT_LE(limited->memory_bytes(), budget);
  expect_brute_force_hits(*limited, 300);
  EXPECT_THROW(build_structure(mesh, octree_settings(full_depth, 1, budget)), BuildError);
  // Not even the root fits: auto refuses too.
  EXPECT_THROW(build_structure(mesh, octree_settings(BuildSettings::kAutoDepth, 1, 1000)), BuildError);
}

// Triangles crowding one point (a fan around a vertex) go to the same octant level after level:
// the depth cap, not leaf_size, ends the tree there.
TEST(OctreeAutoDepth, AFanAroundOneVertexStopsAtTheCap) {
  std::vector<glm::vec3> v = {{0.3f, 0.4f, 0.5f}};
  std::vector<glm::uvec3> t;
  const int n = 300;
  for (int i = 0; i < n; ++i) {
    const float a = 6.2831853f * float(i) / n, b = 6.2831853f * float(i + 1) / n;
    v.push_back({0.3f + std::cos(a), 0.4f + std::sin(a), 0.5f + 0.1f * std::sin(3 * a)});
    v.push_back({0.3f + std::cos(b), 0.4f + std::sin(b), 0.5f + 0.1f * std::sin(3 * b)});
    t.push_back({0, uint32_t(v.size() - 2), uint32_t(v.size() - 1)});
  }
  const auto s = build_structure(mesh_of(v, t), octree_settings(BuildSettings::kAutoDepth, 8));
  EXPECT_EQ(octree_of(*s).max_depth(), Octree::auto_max_depth(n, 8));
  EXPECT_EQ(deepest_box(*s), octree_of(*s).max_depth());
  expect_brute_force_hits(*s, 500);
}
