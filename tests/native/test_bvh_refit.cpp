// Refit (refit.h): on every frame of an animated mesh the refitted BVH (both widths) gives brute
// force's and a rebuild's hits bit for bit, with counters and stories that agree; its boxes contain
// their triangles; its topology is its source's; bad vertices change nothing.
#include "support.h"

#include "bvh.h"
#include "raylab/refit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

using namespace raylab;
using namespace raylab::test;

namespace {

constexpr int kFrames = 24;

MeshPtr moved(const TriangleMesh& rest, int f) {
  auto m = std::make_shared<TriangleMesh>(rest);
  m->vertices = animated_vertices(rest, f, kFrames);
  return m;
}

BuildSettings bvh_settings(int leaf_size = 8) {
  BuildSettings s;
  s.kind = StructureKind::Bvh;
  s.leaf_size = leaf_size;
  return s;
}

std::vector<int> widths() { return cpu_has_avx2() ? std::vector<int>{4, 8} : std::vector<int>{4}; }

// The same closest hit (bit for bit), the same any hit, and a story that is closest()'s with the
// counters closest() counts.
void expect_exact(const Structure& reference, const Structure& s, const std::vector<Ray>& rays) {
  for (const Ray& ray : rays) {
    expect_same_closest(reference, s, ray);
    EXPECT_EQ(reference.any(ray), s.any(ray));
    Hit h;
    TraversalStats stats;
    const bool found = s.closest(ray, h, stats);
    const RayStory story = s.story(ray);
    EXPECT_EQ(story.hit.valid(), found);
    if (found) {
      EXPECT_EQ(story.hit.triangle, h.triangle);
      EXPECT_EQ(story.hit.t, h.t);
    }
    for (const CounterInfo& c : kCounters) EXPECT_EQ(story.stats.*c.field, stats.*c.field) << c.name;
  }
}

// Every triangle lies in the box of the leaf that holds it, every box in its parent's (boxes()'s ids
// and depths), and the root is the mesh's box.
void expect_boxes_contain(const Bvh& bvh) {
  const TriangleMesh& mesh = bvh.mesh();
  const std::vector<BoxInfo> boxes = bvh.boxes();
  ASSERT_FALSE(boxes.empty());
  EXPECT_EQ(boxes[0].bounds.lo, mesh.bounds().lo);
  EXPECT_EQ(boxes[0].bounds.hi, mesh.bounds().hi);
  const auto inside = [](const Bounds& inner, const Bounds& outer) {
    return glm::all(glm::greaterThanEqual(inner.lo, outer.lo)) && glm::all(glm::lessThanEqual(inner.hi, outer.hi));
  };
  for (const BoxInfo& b : boxes) EXPECT_TRUE(inside(b.bounds, boxes[0].bounds));
  const size_t nodes = bvh.width() == 8 ? bvh.nodes8().size() : bvh.nodes().size();
  size_t leaf = 0;
  const auto check_leaves = [&](const auto& wide) {
    for (const auto& node : wide)
      for (int i = 0; i < std::decay_t<decltype(node)>::kWidth; ++i) {
        if (!node.leaf(i)) continue;
        ++leaf;
        for (uint32_t k = 0; k < node.count[i]; ++k) {
          const uint32_t t = bvh.packets()[node.child[i] + k / 4].triangle[k % 4];
          EXPECT_TRUE(inside(mesh.triangle_bounds(t), node.bounds(i))) << "triangle " << t;
          for (int c = 0; c < 3; ++c)
            for (int a = 0; a < 3; ++a)
              EXPECT_EQ(bvh.packets()[node.child[i] + k / 4].p[c][a][k % 4], mesh.vertex(t, c)[a]);
        }
      }
  };
  if (bvh.width() == 8) check_leaves(bvh.nodes8());
  else check_leaves(bvh.nodes());
  EXPECT_EQ(boxes.size(), nodes + leaf);
}

// The same tree shape: node count, and each box's depth, leaf flag and triangle count.
void expect_same_topology(const Structure& a, const Structure& b) {
  const std::vector<BoxInfo> x = a.boxes(), y = b.boxes();
  ASSERT_EQ(x.size(), y.size());
  for (size_t i = 0; i < x.size(); ++i) {
    EXPECT_EQ(x[i].depth, y[i].depth);
    EXPECT_EQ(x[i].leaf, y[i].leaf);
    EXPECT_EQ(x[i].triangle_count, y[i].triangle_count);
  }
}

}  // namespace

TEST(BvhRefit, EveryFrameGivesBruteForceAndRebuildHitsBitForBit) {
  for (const char* name : {"sphere.obj", "spot_low_resolution.obj"})
    for (const int width : widths()) {
      SCOPED_TRACE(std::string(name) + " width " + std::to_string(width));
      const MeshPtr rest = shipped(name);
      const auto first = std::make_unique<Bvh>(rest, bvh_settings(), width);
      std::unique_ptr<Structure> chained = std::make_unique<Bvh>(rest, bvh_settings(), width);
      BuildSettings brute;
      brute.kind = StructureKind::None;
      for (int f = 0; f < kFrames; ++f) {
        SCOPED_TRACE("frame " + std::to_string(f));
        const MeshPtr mesh = moved(*rest, f);
        // From the previous frame's refit (as an animation plays) and from the rest pose's build.
        chained = refit_structure(*chained, mesh);
        const std::unique_ptr<Structure> from_rest = refit_structure(*first, animated_vertices(*rest, f, kFrames));
        ASSERT_TRUE(chained->refitted());
        ASSERT_EQ(static_cast<const Bvh&>(*chained).width(), width);
        const Bvh rebuilt(mesh, bvh_settings(), width);
        const std::unique_ptr<Structure> brute_force = build_structure(mesh, brute);
        const std::vector<Ray> rays = random_rays(*mesh, 400, uint32_t(f + 1));
        expect_exact(*brute_force, *chained, rays);
        expect_exact(*brute_force, *from_rest, rays);
        expect_exact(rebuilt, *chained, rays);
        expect_boxes_contain(static_cast<const Bvh&>(*chained));
        expect_same_topology(*first, *chained);
      }
    }
}

TEST(BvhRefit, RefitToTheSameVerticesIsTheBuildBoxForBox) {
  const MeshPtr mesh = shipped("bunny.obj");
  for (const int width : widths()) {
    const Bvh built(mesh, bvh_settings(), width);
    const std::unique_ptr<Structure> refitted = refit_structure(built, mesh->vertices);
    const std::vector<BoxInfo> a = built.boxes(), b = refitted->boxes();
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].bounds.lo, b[i].bounds.lo) << i;
      EXPECT_EQ(a[i].bounds.hi, b[i].bounds.hi) << i;
    }
    EXPECT_EQ(built.sah_cost(), static_cast<const Bvh&>(*refitted).sah_cost());
  }
}

TEST(BvhRefit, SahCostDegradesWhenTheVerticesScramble) {
  // The same positions, dealt to other vertices at random: a tree built for the old positions groups
  // triangles that are now far apart, and its cost rises above a rebuild's (1373 against 908 for the
  // bunny: every triangle now spans the mesh, so a rebuild is poor too).
  const MeshPtr mesh = shipped("bunny.obj");
  std::vector<glm::vec3> scrambled = mesh->vertices;
  std::shuffle(scrambled.begin(), scrambled.end(), std::mt19937(7));
  const Bvh built(mesh, bvh_settings());
  const std::unique_ptr<Structure> refitted = refit_structure(built, scrambled);
  const Bvh rebuilt(refitted->mesh_ptr(), bvh_settings());
  const double refit_cost = static_cast<const Bvh&>(*refitted).sah_cost();
  EXPECT_GT(built.sah_cost(), kSahTraversalCost);  // the root visit and at least one leaf block
  EXPECT_GT(refit_cost, 1.25 * rebuilt.sah_cost());
  expect_exact(*build_structure(refitted->mesh_ptr(),
                                [] {
                                  BuildSettings s;
                                  s.kind = StructureKind::None;
                                  return s;
                                }()),
               *refitted, random_rays(refitted->mesh(), 200, 3));
}

TEST(BvhRefit, KindsWithoutTopologyRefitAndTheOthersRebuild) {
  const MeshPtr rest = shipped("sphere.obj");
  const MeshPtr mesh = moved(*rest, 5);
  BuildSettings brute;
  brute.kind = StructureKind::None;
  const std::unique_ptr<Structure> reference = build_structure(mesh, brute);
  for (const StructureInfo& info : structure_kinds()) {
    SCOPED_TRACE(info.name);
    BuildSettings s;
    s.kind = info.kind;
    const std::unique_ptr<Structure> built = build_structure(rest, s);
    const std::unique_ptr<Structure> refitted = refit_structure(*built, mesh->vertices);
    EXPECT_EQ(refitted->refitted(), info.refit != nullptr);
    EXPECT_FALSE(built->refitted());
    EXPECT_EQ(refitted->kind(), info.kind);
    EXPECT_EQ(refitted->mesh().vertices, mesh->vertices);
    expect_exact(*reference, *refitted, random_rays(*mesh, 300, 11));
  }
}

TEST(BvhRefit, BadVerticesAreRefusedAndChangeNothing) {
  const MeshPtr mesh = shipped("sphere.obj");
  const Bvh built(mesh, bvh_settings());
  const std::vector<BoxInfo> before = built.boxes();
  std::vector<glm::vec3> fewer(mesh->vertices.begin(), mesh->vertices.end() - 1);
  std::vector<glm::vec3> nan = mesh->vertices, huge = mesh->vertices;
  nan[3].y = std::nanf("");
  huge[5].x = 1e30f;
  for (const auto& bad : {fewer, nan, huge}) {
    try {
      refit_structure(built, bad);
      ADD_FAILURE() << "accepted bad vertices";
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind("vertices: ", 0), 0u) << e.what();
    }
  }
  // A mesh with other triangles is not a refit.
  auto other = std::make_shared<TriangleMesh>(*mesh);
  std::swap(other->triangles[0], other->triangles[1]);
  EXPECT_THROW(refit_structure(built, MeshPtr(other)), std::invalid_argument);
  EXPECT_EQ(built.mesh_ptr(), mesh);
  const std::vector<BoxInfo> after = built.boxes();
  ASSERT_EQ(before.size(), after.size());
  for (size_t i = 0; i < before.size(); ++i) EXPECT_EQ(before[i].bounds.lo, after[i].bounds.lo);
}

TEST(BvhRefit, EmptyMeshRefitsToAnEmptyTree) {
  const MeshPtr empty = mesh_of({{0, 0, 0}}, {});
  const Bvh built(empty, bvh_settings());
  const std::unique_ptr<Structure> refitted = refit_structure(built, std::vector<glm::vec3>{{1, 2, 3}});
  Hit h;
  EXPECT_FALSE(refitted->closest(ray_of({0, 0, -1}, {0, 0, 1}), h));
  EXPECT_EQ(static_cast<const Bvh&>(*refitted).sah_cost(), 0.0);
}

TEST(BinaryBvhRefit, RefitsInPlaceAndRefusesAnotherPrimitiveSet) {
  std::vector<Bounds> prims;
  for (int i = 0; i < 50; ++i) prims.push_back({glm::vec3(float(i)), glm::vec3(float(i) + 1.0f)});
  BinaryBvh bvh = build_binary_bvh(prims, 1);
  const double built_cost = sah_cost(bvh, 1);
  for (Bounds& b : prims) b = {b.lo + glm::vec3(0, 3, 0), b.hi + glm::vec3(0, 3, 0)};
  ASSERT_TRUE(refit_binary_bvh(bvh, prims));
  EXPECT_EQ(bvh.nodes[0].lo, glm::vec3(0, 3, 0));
  EXPECT_EQ(bvh.nodes[0].hi, glm::vec3(50, 53, 50));
  EXPECT_DOUBLE_EQ(sah_cost(bvh, 1), built_cost);  // a translation keeps every area
  // Every inner node's box is its children's union; every leaf's its primitive's.
  for (const BvhNode& n : bvh.nodes) {
    Bounds u;
    if (n.leaf()) u = prims[bvh.prims[n.index]];
    else {
      u.extend(bvh.nodes[n.index].bounds());
      u.extend(bvh.nodes[n.index + 1].bounds());
    }
    EXPECT_EQ(n.lo, u.lo);
    EXPECT_EQ(n.hi, u.hi);
  }
  prims.pop_back();
  EXPECT_FALSE(refit_binary_bvh(bvh, prims));
  prims.push_back(Bounds());  // an empty box: build_binary_bvh would leave it out
  EXPECT_FALSE(refit_binary_bvh(bvh, prims));
}
