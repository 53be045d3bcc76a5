// The BVH's builders (bvh_builder.h): every one exact, and the tree and split decisions that
// Structure.tree() and split_costs show are the build's own.
#include "bvh.h"
#include "raylab/tree.h"
#include "support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <string>
#include <vector>

using namespace raylab;
using namespace raylab::test;

namespace {

BuildSettings bvh_settings(BvhBuilder builder, int leaf_size = 8) {
  BuildSettings s;
  s.kind = StructureKind::Bvh;
  s.builder = builder;
  s.leaf_size = leaf_size;
  return s;
}

std::vector<uint32_t> sorted(std::vector<uint32_t> v) {
  std::sort(v.begin(), v.end());
  return v;
}

MeshPtr identical_triangles() {
  auto mesh = std::make_shared<TriangleMesh>();
  mesh->vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh->triangles.assign(3000, glm::uvec3(0, 1, 2));
  return mesh;
}

}  // namespace

TEST(BvhBuilders, EveryBuilderMatchesBruteForceWithConservativeLeaves) {
  const MeshPtr meshes[] = {shipped("bunny.obj"), shipped("teapot.obj"), flat_grid(40), identical_triangles()};
  for (const BvhBuilderInfo& info : kBvhBuilders) {
    SCOPED_TRACE(info.name);
    for (const MeshPtr& mesh : meshes) {
      for (int leaf_size : {1, 8}) {
        const auto s = build_structure(mesh, bvh_settings(info.builder, leaf_size));
        EXPECT_EQ(s->settings().builder, info.builder);
        const Bvh& bvh = dynamic_cast<const Bvh&>(*s);
        const StructureTree tree = bvh.tree();
        // Every triangle once, and every leaf's box holds its triangles' boxes.
        std::vector<int> seen(mesh->triangle_count(), 0);
        for (size_t id = 0; id < tree.leaf.size(); ++id) {
          if (!tree.leaf[id]) continue;
          EXPECT_LE(tree.triangle_count[id], uint32_t(leaf_size));
          for (uint32_t t : bvh.triangles_of(uint32_t(id))) {
            ++seen[t];
            const Bounds b = mesh->triangle_bounds(t);
            for (int a = 0; a < 3; ++a) {
              ASSERT_LE(tree.bounds[id].lo[a], b.lo[a]);
              ASSERT_GE(tree.bounds[id].hi[a], b.hi[a]);
            }
          }
        }
        for (size_t t = 0; t < seen.size(); ++t) ASSERT_EQ(seen[t], 1) << "triangle " << t;
        const BuildSettings brute{.kind = StructureKind::None};
        const auto reference = build_structure(mesh, brute);
        for (const Ray& ray : random_rays(*mesh, 600, 31 + leaf_size)) expect_same_closest(*reference, *s, ray);
      }
    }
  }
}

TEST(BvhBuilders, OtherKindsRefuseABuilderByName) {
  for (const StructureInfo& info : structure_kinds()) {
    BuildSettings s;
    s.kind = info.kind;
    s.builder = BvhBuilder::Lbvh;
    if (info.uses_builder) {
      EXPECT_NO_THROW(s.validate());
      continue;
    }
    try {
      s.validate();
      ADD_FAILURE() << info.name << " took a builder";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("builder 'lbvh'"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(bvh_builder_from_name("best"), std::invalid_argument);
}

TEST(BvhBuilders, TheTreeIsTheBoxesAndItsSahCostsSumToSahCost) {
  for (const BvhBuilderInfo& info : kBvhBuilders) {
    SCOPED_TRACE(info.name);
    const auto s = build_structure(shipped("bunny.obj"), bvh_settings(info.builder));
    const Bvh& bvh = dynamic_cast<const Bvh&>(*s);
    const StructureTree tree = *structure_tree(*s);
    const std::vector<BoxInfo> boxes = s->boxes();
    ASSERT_EQ(tree.parent.size(), boxes.size());
    EXPECT_EQ(tree.width, bvh.width());
    double sum = 0.0;
    for (size_t i = 0; i < boxes.size(); ++i) {
      EXPECT_EQ(tree.depth[i], boxes[i].depth);
      EXPECT_EQ(tree.bounds[i].lo, boxes[i].bounds.lo);
      EXPECT_EQ(tree.bounds[i].hi, boxes[i].bounds.hi);
      EXPECT_EQ(bool(tree.leaf[i]), boxes[i].leaf);
      EXPECT_EQ(tree.triangle_count[i], boxes[i].triangle_count);
      EXPECT_EQ(tree.parent[i] < 0, i == 0);
      if (i != 0) EXPECT_EQ(tree.depth[size_t(tree.parent[i])] + 1, tree.depth[i]);
      sum += tree.sah_cost[i];
    }
    EXPECT_NEAR(sum, bvh.sah_cost(), 1e-9 * bvh.sah_cost());
    // Each child row lists exactly the nodes whose parent it is.
    size_t listed = 0;
    for (size_t p = 0; p * size_t(tree.width) < tree.children.size(); ++p)
      for (int k = 0; k < tree.width; ++k)
        if (const int32_t c = tree.children[p * size_t(tree.width) + size_t(k)]; c >= 0) {
          EXPECT_EQ(tree.parent[size_t(c)], int32_t(p));
          ++listed;
        }
    EXPECT_EQ(listed, boxes.size() - 1);
  }
  EXPECT_FALSE(structure_tree(*build_structure(shipped("bunny.obj"), BuildSettings{.kind = StructureKind::Grid})));
  const auto octree = build_structure(shipped("bunny.obj"), BuildSettings{.kind = StructureKind::Octree});
  const StructureTree t = *structure_tree(*octree);
  EXPECT_EQ(t.parent.size(), octree->boxes().size());
  EXPECT_TRUE(t.sah_cost.empty());
  EXPECT_THROW(structure_split_costs(*octree, 0), std::invalid_argument);
}

// The explorer's decision is the build's at every node: the triangles it puts left are a prefix of the
// wide node's children (the collapse keeps the left subtree's children first), a leaf is a leaf, and
// the SAH's chosen candidate is the cheapest one it lists.
void expect_explained(const Structure& s) {
  const Bvh& bvh = dynamic_cast<const Bvh&>(s);
  const StructureTree tree = bvh.tree();
  const size_t nodes = tree.children.size() / size_t(tree.width);
  for (size_t id = 0; id < tree.parent.size(); ++id) {
    const SplitCosts c = bvh.split_costs(uint32_t(id));
    ASSERT_EQ(c.count, tree.triangle_count[id]);
    if (id >= nodes) {  // a leaf of the wide tree is a leaf of the build
      ASSERT_EQ(c.method, SplitMethod::Leaf) << "leaf " << id;
      continue;
    }
    if (c.method == SplitMethod::Leaf) {  // only a root that is a leaf: one child
      ASSERT_EQ(id, 0u);
      ASSERT_EQ(tree.children[1], -1);
      continue;
    }
    std::vector<uint32_t> prefix;
    bool found = false;
    for (int k = 0; k < tree.width && !found; ++k) {
      const int32_t child = tree.children[id * size_t(tree.width) + size_t(k)];
      if (child < 0) break;
      const std::vector<uint32_t> own = bvh.triangles_of(uint32_t(child));
      prefix.insert(prefix.end(), own.begin(), own.end());
      found =
          c.method == SplitMethod::IndexMedian ? prefix.size() == c.left_prims.size() : sorted(prefix) == c.left_prims;
    }
    ASSERT_TRUE(found) << "node " << id << " (" << split_method_name(c.method) << ", " << c.count << " triangles)";
    if (c.method == SplitMethod::SahBinned || c.method == SplitMethod::SahSorted) {
      const std::vector<float>& costs = c.cost[c.axis];
      ASSERT_GE(c.candidate, 0);
      EXPECT_EQ(c.sorted, c.method == SplitMethod::SahSorted);
      EXPECT_FLOAT_EQ(costs[size_t(c.candidate)], c.cost_chosen);
      EXPECT_EQ(c.left_count[c.axis][size_t(c.candidate)], c.left_prims.size());
      for (int a = 0; a < 3; ++a)
        for (float other : c.cost[a]) EXPECT_GE(other, costs[size_t(c.candidate)]);
    }
  }
}

TEST(BvhBuilders, SplitCostsReproduceTheSahBuildAtEveryNodeOfTheBenchmarkMeshes) {
  for (const char* name : {"goathead.obj", "bunny.obj", "dragon.obj"}) {
    SCOPED_TRACE(name);
    expect_explained(*build_structure(shipped(name), bvh_settings(BvhBuilder::Sah)));
  }
}

TEST(BvhBuilders, SplitCostsReproduceEveryBuildersDecisions) {
  for (const BvhBuilderInfo& info : kBvhBuilders) {
    SCOPED_TRACE(info.name);
    expect_explained(*build_structure(shipped("bunny.obj"), bvh_settings(info.builder)));
    expect_explained(*build_structure(flat_grid(20), bvh_settings(info.builder, 1)));
  }
}

TEST(BvhBuilders, ARootLeafAndBadIdsAreExplained) {
  auto one = std::make_shared<TriangleMesh>();
  one->vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  one->triangles = {{0, 1, 2}};
  const auto s = build_structure(one, bvh_settings(BvhBuilder::Sah));
  const SplitCosts c = structure_split_costs(*s, 0);
  EXPECT_EQ(c.method, SplitMethod::Leaf);
  EXPECT_EQ(c.count, 1u);
  EXPECT_EQ(c.cost_chosen, c.leaf_cost);
  EXPECT_THROW(structure_split_costs(*s, 2), std::invalid_argument);
}
