#include "grid.h"
#include "raylab/mesh_io.h"
#include "raylab/structure.h"
#include "triangle_box_overlap.h"

#include "support.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <random>

using namespace raylab;
using namespace raylab::test;  // support.h

namespace {

std::unique_ptr<Structure> build(const MeshPtr& mesh, StructureKind kind,
                                 size_t memory_budget = BuildSettings{}.memory_budget) {
  BuildSettings s;
  s.kind = kind;
  s.memory_budget = memory_budget;
  return build_structure(mesh, s);
}

const Grid& grid_of(const Structure& s) { return dynamic_cast<const Grid&>(s); }

// Closest hit bit for bit and the any-hit answer of brute force.
void expect_same(const Structure& reference, const Structure& s, const Ray& ray, const std::string& what) {
  Hit expected, got;
  const bool a = reference.closest(ray, expected);
  const bool b = s.closest(ray, got);
  ASSERT_EQ(a, b) << what;
  ASSERT_EQ(reference.any(ray), s.any(ray)) << what;
  if (!a) return;
  ASSERT_EQ(expected.triangle, got.triangle) << what;
  ASSERT_EQ(expected.t, got.t) << what;
  ASSERT_EQ(expected.u, got.u) << what;
  ASSERT_EQ(expected.v, got.v) << what;
}

glm::ivec3 cell_of_index(const Grid& g, uint32_t cell) {
  const glm::ivec3 r = g.resolution();
  return {int(cell % uint32_t(r.x)), int(cell / uint32_t(r.x) % uint32_t(r.y)), int(cell / uint32_t(r.x * r.y))};
}

}  // namespace

TEST(GridBuild, ResolutionFollowsPbrtsRule) {
  const MeshPtr bunny = shipped("bunny.obj");
  const auto structure = build(bunny, StructureKind::Grid);  // outlives the reference below
  const Grid& g = grid_of(*structure);
  const glm::vec3 e = bunny->bounds().extent();
  const float longest = std::max({e.x, e.y, e.z});
  const double per_unit = 3.0 * std::cbrt(double(bunny->triangle_count())) / longest;
  for (int a = 0; a < 3; ++a) EXPECT_EQ(g.resolution()[a], std::max(1, int(std::lround(e[a] * per_unit)))) << a;
  EXPECT_EQ(g.bounds().lo, bunny->bounds().lo);
  EXPECT_EQ(g.bounds().hi, bunny->bounds().hi);
  // The planes tile the bounds exactly.
  for (int a = 0; a < 3; ++a) {
    EXPECT_EQ(g.plane(a, 0), g.bounds().lo[a]);
    EXPECT_EQ(g.plane(a, g.resolution()[a]), g.bounds().hi[a]);
    for (int i = 0; i < g.resolution()[a]; ++i) EXPECT_LT(g.plane(a, i), g.plane(a, i + 1));
  }
}

TEST(GridBuild, EveryCellHoldsExactlyTheTrianglesThatOverlapIt) {
  // A large triangle across many cells, plus the cow.
  std::vector<glm::vec3> v = {
      {0.05f, 0.05f, 0.3f}, {0.95f, 0.1f, 0.6f}, {0.2f, 0.95f, 0.7f}, {0, 0, 0}, {1, 1, 1}, {1, 0, 1}};
  const MeshPtr large = mesh_of(v, {{0, 1, 2}, {3, 4, 5}});
  for (const MeshPtr& mesh : {large, shipped("spot_low_resolution.obj")}) {
    const auto s = build(mesh, StructureKind::Grid);
    const Grid& g = grid_of(*s);
    const float tolerance = 1e-6f * glm::length(g.bounds().extent());
    std::vector<int> cells_of_triangle(mesh->triangle_count(), 0);
    std::vector<Bounds> triangle_bounds;
    for (uint32_t t = 0; t < mesh->triangle_count(); ++t) triangle_bounds.push_back(mesh->triangle_bounds(t));
    for (uint32_t cell = 0; cell < g.cell_count(); ++cell) {
      const Bounds box = g.cell_bounds(cell_of_index(g, cell));
      const auto held = g.cell_triangles(cell);
      EXPECT_TRUE(std::is_sorted(held.begin(), held.end()));
      std::vector<bool> in_cell(mesh->triangle_count(), false);
      for (uint32_t t : held) {
        in_cell[t] = true;
        ++cells_of_triangle[t];
        EXPECT_TRUE(!clip_to_box(*mesh, t, box, tolerance).empty()) << "cell " << cell << " holds triangle " << t;
      }
      for (uint32_t t = 0; t < mesh->triangle_count(); ++t) {
        const Bounds& tb = triangle_bounds[t];
        if (in_cell[t] || glm::any(glm::greaterThan(tb.lo, box.hi)) || glm::any(glm::lessThan(tb.hi, box.lo))) continue;
        if (!clip_to_box(*mesh, t, box, 0.0).empty())
          ADD_FAILURE() << "cell " << cell << " misses overlapping triangle " << t;
      }
    }
    for (uint32_t t = 0; t < mesh->triangle_count(); ++t) EXPECT_GE(cells_of_triangle[t], 1) << t;
  }
}

TEST(GridBuild, BoxesAreTheBoundsAndTheNonEmptyCells) {
  const MeshPtr cow = shipped("spot_low_resolution.obj");
  const auto s = build(cow, StructureKind::Grid);
  const Grid& g = grid_of(*s);
  const std::vector<BoxInfo> boxes = s->boxes();
  ASSERT_FALSE(boxes.empty());
  EXPECT_EQ(boxes[0].depth, 0);
  EXPECT_FALSE(boxes[0].leaf);
  EXPECT_EQ(boxes[0].triangle_count, cow->triangle_count());
  EXPECT_EQ(boxes[0].bounds.lo, g.bounds().lo);
  size_t non_empty = 0, references = 0;
  for (uint32_t cell = 0; cell < g.cell_count(); ++cell) {
    non_empty += !g.cell_triangles(cell).empty();
    references += g.cell_triangles(cell).size();
  }
  ASSERT_EQ(boxes.size(), 1 + non_empty);
  size_t counted = 0;
  for (size_t i = 1; i < boxes.size(); ++i) {
    EXPECT_EQ(boxes[i].depth, 1);
    EXPECT_TRUE(boxes[i].leaf);
    EXPECT_GT(boxes[i].triangle_count, 0u);
    counted += boxes[i].triangle_count;
  }
  EXPECT_EQ(counted, references);
  EXPECT_EQ(s->memory_bytes(), (g.cell_count() + 1 + references) * sizeof(uint32_t) + (g.cell_count() + 63) / 64 * 8);
  for (uint32_t cell = 0; cell < g.cell_count(); ++cell)
    EXPECT_EQ(g.occupied(cell), !g.cell_triangles(cell).empty()) << cell;
}

TEST(GridBuild, IsTheSameOnOneThreadAsOnAllAndIgnoresDepthAndLeafSize) {
  const MeshPtr mesh = shipped("bunny.obj");
  const auto a = [&] {
    tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
    return build(mesh, StructureKind::Grid);
  }();
  BuildSettings other;
  other.kind = StructureKind::Grid;
  other.max_depth = 0;
  other.leaf_size = 1000;
  const auto b = build_structure(mesh, other);
  const Grid &ga = grid_of(*a), &gb = grid_of(*b);
  ASSERT_EQ(ga.resolution(), gb.resolution());
  for (uint32_t cell = 0; cell < ga.cell_count(); ++cell)
    ASSERT_TRUE(std::ranges::equal(ga.cell_triangles(cell), gb.cell_triangles(cell))) << cell;
}

TEST(GridBuild, MemoryBudget) {
  const MeshPtr bunny = shipped("bunny.obj");
  // Not even one reference per triangle fits: refused, naming the budget.
  try {
    build(bunny, StructureKind::Grid, 4096);
    ADD_FAILURE() << "no BuildError";
  } catch (const BuildError& e) {
    EXPECT_NE(std::string(e.what()).find("memory budget"), std::string::npos) << e.what();
  }
  // A budget below the full grid's size gives a coarser grid within it, still exact.
  const auto full = build(bunny, StructureKind::Grid);
  const size_t budget = full->memory_bytes() / 4;
  const auto coarse = build(bunny, StructureKind::Grid, budget);
  EXPECT_LE(coarse->memory_bytes(), budget);
  const glm::ivec3 rf = grid_of(*full).resolution(), rc = grid_of(*coarse).resolution();
  EXPECT_LT(size_t(rc.x) * rc.y * rc.z, size_t(rf.x) * rf.y * rf.z);
  const auto reference = build(bunny, StructureKind::None);
  for (const Ray& ray : random_rays(*bunny, 300, 4)) expect_same(*reference, *coarse, ray, "coarse");
}

TEST(GridDegenerate, EmptyMeshHasNoCellsAndMissesEverything) {
  const auto empty = build(mesh_of({}, {}), StructureKind::Grid);
  EXPECT_TRUE(empty->boxes().empty());
  EXPECT_EQ(empty->memory_bytes(), 0u);
  const Ray down = ray_of({0, 0, 1}, {0, 0, -1});
  Hit h;
  EXPECT_FALSE(empty->closest(down, h));
  EXPECT_FALSE(empty->any(down));
  const RayStory story = empty->story(down);
  EXPECT_EQ(story.status, RayStatus::MissedRoot);
  EXPECT_EQ(story.stats.box_tests, 1u);
}

TEST(GridDegenerate, SingleTriangle) {
  const MeshPtr one = mesh_of({{0, 0, 0}, {2, 0, 0}, {0, 1, 0.5f}}, {{0, 1, 2}});
  const auto s = build(one, StructureKind::Grid);
  const Grid& g = grid_of(*s);
  EXPECT_EQ(g.resolution(), glm::ivec3(3, 2, 1));  // 3 * cbrt(1) along x, in proportion along y and z
  const auto reference = build(one, StructureKind::None);
  int hits = 0;
  for (int y = -2; y <= 22; ++y)
    for (int x = -2; x <= 42; ++x) {
      const Ray ray = ray_of({x / 20.0f, y / 20.0f, 3.0f}, {0.01f, 0.02f, -1.0f});
      Hit h;
      hits += reference->closest(ray, h);
      expect_same(*reference, *s, ray, "x " + std::to_string(x) + " y " + std::to_string(y));
    }
  EXPECT_GT(hits, 300);
}

TEST(GridDegenerate, FlatAndPointMeshes) {
  const MeshPtr flat = mesh_of({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}}, {{0, 1, 2}, {1, 3, 2}});
  const auto s = build(flat, StructureKind::Grid);
  EXPECT_EQ(grid_of(*s).resolution().z, 1);
  Hit h;
  ASSERT_TRUE(s->closest(ray_of({0.6f, 0.7f, 1.0f}, {0, 0, -1}), h));
  EXPECT_EQ(h.triangle, 1u);
  EXPECT_EQ(h.t, 1.0f);
  // Upwards from below, and rays lying in the plane (which count as missing it), as brute force says.
  const auto reference = build(flat, StructureKind::None);
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> unit(-0.5f, 1.5f);
  for (int i = 0; i < 2000; ++i) {
    const glm::vec3 o(unit(rng), unit(rng), i % 2 ? 0.0f : -unit(rng));
    const glm::vec3 d(unit(rng) - 0.5f, unit(rng) - 0.5f, i % 2 ? 0.0f : 1.0f);
    expect_same(*reference, *s, ray_of(o, d), "ray " + std::to_string(i));
  }
  const MeshPtr point = mesh_of({{2, 3, 4}}, {{0, 0, 0}, {0, 0, 0}});
  const auto p = build(point, StructureKind::Grid);
  EXPECT_EQ(grid_of(*p).resolution(), glm::ivec3(1));
  EXPECT_FALSE(p->any(ray_of({2, 3, 0}, {0, 0, 1})));
  EXPECT_FALSE(p->any(ray_of({2, 3, 4}, {0, 0, 1})));
}

// Axis-parallel rays along cell planes and cell corners: the slab test meets 0 * inf there, and the
// hits sit on faces shared by neighbouring cells.
TEST(GridTraversal, AxisRaysOnCellPlanesEqualBruteForce) {
  const MeshPtr mesh = shipped("bunny.obj");
  const auto reference = build(mesh, StructureKind::None);
  const auto s = build(mesh, StructureKind::Grid);
  const Grid& g = grid_of(*s);
  std::mt19937 rng(11);
  int hits = 0;
  for (int i = 0; i < 3000; ++i) {
    const glm::ivec3 r = g.resolution();
    const glm::ivec3 corner(int(rng() % uint32_t(r.x + 1)), int(rng() % uint32_t(r.y + 1)),
                            int(rng() % uint32_t(r.z + 1)));
    const int axis = i % 3;
    const bool forward = (i / 3) % 2 == 0;
    glm::vec3 origin(g.plane(0, corner.x), g.plane(1, corner.y), g.plane(2, corner.z));
    // Outside the bounds, on a cell plane, or inside the grid (starting on a corner of cells).
    if (i % 4 != 3) origin[axis] = forward ? g.bounds().lo[axis] - 1.0f : g.bounds().hi[axis] + 1.0f;
    glm::vec3 direction(0.0f);
    direction[axis] = forward ? 1.0f : -1.0f;
    const Ray ray = ray_of(origin, direction);
    Hit h;
    hits += reference->closest(ray, h);
    expect_same(*reference, *s, ray, "ray " + std::to_string(i));
  }
  EXPECT_GT(hits, 300);
}

TEST(GridTraversal, RaysStartingInsideAndFromOutsideEqualBruteForce) {
  for (const char* name : {"bunny.obj", "plane_holes.obj", "sphere.obj"}) {
    SCOPED_TRACE(name);
    const MeshPtr mesh = shipped(name);
    const auto reference = build(mesh, StructureKind::None);
    const auto s = build(mesh, StructureKind::Grid);
    const auto rays = random_rays(*mesh, 1500, 7);
    for (size_t i = 0; i < rays.size(); ++i) expect_same(*reference, *s, rays[i], "ray " + std::to_string(i));
  }
}

// tmax exactly at the hit (inclusive), one float before it, tmin one float before it and at it.
TEST(GridTraversal, TminAndTmaxAtTheHit) {
  const MeshPtr mesh = shipped("spot_low_resolution.obj");
  const auto reference = build(mesh, StructureKind::None);
  const auto s = build(mesh, StructureKind::Grid);
  int checked = 0;
  for (const Ray& base : random_rays(*mesh, 2000, 9)) {
    Hit h;
    if (!reference->closest(base, h)) continue;
    ++checked;
    Ray r = base;
    r.tmax = h.t;
    expect_same(*reference, *s, r, "tmax = t");
    Hit exact;
    ASSERT_TRUE(s->closest(r, exact));
    r.tmax = std::nextafter(h.t, 0.0f);
    expect_same(*reference, *s, r, "tmax before t");
    r = base;
    r.tmin = std::nextafter(h.t, 0.0f);
    expect_same(*reference, *s, r, "tmin before t");
    r.tmin = h.t;
    expect_same(*reference, *s, r, "tmin = t");
  }
  EXPECT_GT(checked, 500);
}

// The walk visits exactly the non-empty cells whose padded box the ray enters at or before the
// closest hit (or tmax), front to back, and the counters count what the story shows.
TEST(GridTraversal, VisitsExactlyTheCellsEnteredBeforeTheHitFrontToBack) {
  const MeshPtr mesh = shipped("bunny.obj");
  const auto s = build(mesh, StructureKind::Grid);
  const Grid& g = grid_of(*s);
  std::vector<uint32_t> occupied;
  for (uint32_t cell = 0; cell < g.cell_count(); ++cell)
    if (!g.cell_triangles(cell).empty()) occupied.push_back(cell);
  int visited_rays = 0;
  for (const Ray& ray : random_rays(*mesh, 400, 13)) {
    const RayStory story = s->story(ray);
    Hit h;
    TraversalStats stats;
    const bool hit = s->closest(ray, h, stats);
    ASSERT_EQ(hit, story.hit.valid());
    EXPECT_EQ(stats.box_tests, story.stats.box_tests);
    EXPECT_EQ(stats.nodes_visited, story.stats.nodes_visited);
    EXPECT_EQ(stats.triangle_tests, story.stats.triangle_tests);
    EXPECT_EQ(story.nodes.size(), stats.nodes_visited);
    EXPECT_EQ(story.triangles.size(), stats.triangle_tests);
    ASSERT_FALSE(story.boxes.empty());
    EXPECT_EQ(story.boxes[0].node, 0u);
    if (!story.boxes[0].hit) {
      EXPECT_EQ(story.status, RayStatus::MissedRoot);
      continue;
    }
    // Every non-empty cell the padded ray enters within (tmin, limit]: by brute force over the cells.
    const BoxRay box_ray(ray, g.bounds());
    const float limit = hit ? h.t : ray.tmax;
    std::vector<uint32_t> expected;
    for (uint32_t cell : occupied) {
      float t = ray.tmin;
      if (intersect_box(g.cell_bounds(cell_of_index(g, cell)), box_ray, limit, t)) expected.push_back(cell + 1);
    }
    std::vector<uint32_t> visited;
    for (const StoryNode& n : story.nodes) visited.push_back(n.node);
    std::vector<uint32_t> sorted = visited;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_TRUE(std::adjacent_find(sorted.begin(), sorted.end()) == sorted.end()) << "a cell visited twice";
    ASSERT_EQ(sorted, expected);
    visited_rays += !visited.empty();
    // Front to back: after the cells present at the bounds' entry, entries never decrease.
    const float t_root = story.boxes[0].t_entry;
    float last = t_root;
    for (size_t i = 1; i < story.boxes.size(); ++i) {
      const StoryBox& b = story.boxes[i];
      EXPECT_EQ(b.depth, 1);
      if (!b.hit || b.t_entry <= t_root) continue;
      EXPECT_GE(b.t_entry, last);
      last = b.t_entry;
    }
  }
  EXPECT_GT(visited_rays, 200);
}

TEST(GridTraversal, StoryShowsTheFourStatuses) {
  // Two small triangles in opposite corners of the unit cube: a 4 x 4 x 4 grid (3 * cbrt(2) = 3.8).
  const MeshPtr corners =
      mesh_of({{0, 0, 0}, {0.1f, 0, 0}, {0, 0.1f, 0}, {1, 1, 1}, {0.9f, 1, 1}, {1, 0.9f, 1}}, {{0, 1, 2}, {3, 4, 5}});
  const auto s = build(corners, StructureKind::Grid);
  ASSERT_EQ(grid_of(*s).resolution(), glm::ivec3(4));
  const glm::vec3 down(0, 0, -1);
  EXPECT_EQ(s->story(ray_of({2, 2, 2}, down)).status, RayStatus::MissedRoot);
  const RayStory empty_space = s->story(ray_of({0.5f, 0.5f, 2}, down));
  EXPECT_EQ(empty_space.status, RayStatus::MissedNodes);
  EXPECT_TRUE(empty_space.nodes.empty());
  const RayStory beside = s->story(ray_of({0.08f, 0.08f, 2}, down));
  EXPECT_EQ(beside.status, RayStatus::MissedTriangles);
  ASSERT_EQ(beside.triangles.size(), 1u);
  const RayStory hit = s->story(ray_of({0.02f, 0.02f, 2}, down));
  EXPECT_EQ(hit.status, RayStatus::HitObject);
  EXPECT_EQ(hit.hit.triangle, 0u);
  EXPECT_EQ(hit.stats.nodes_visited, 1u);
  EXPECT_EQ(hit.stats.box_tests, 2u);  // the bounds and the one non-empty cell on the way
}

TEST(GridTraversal, TestsFarFewerTrianglesThanAabb) {
  const MeshPtr bunny = shipped("bunny.obj");
  const auto rays = random_rays(*bunny, 2000, 21);
  std::vector<Hit> hits(rays.size());
  TraversalStats aabb, grid;
  intersect_closest(*build(bunny, StructureKind::Aabb), rays, hits, &aabb);
  intersect_closest(*build(bunny, StructureKind::Grid), rays, hits, &grid);
  EXPECT_LT(grid.triangle_tests, aabb.triangle_tests / 20);
}
