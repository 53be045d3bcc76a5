// Mailboxing in the octree (mailbox.h): a triangle that straddles several leaves is tested once per
// ray, the hits stay brute force's bit for bit, and the counters count only the tests made.
#include "mailbox.h"
#include "octree.h"
#include "raylab/structure.h"

#include "support.h"

#include <gtest/gtest.h>

#include <map>

using namespace raylab;
using namespace raylab::test;  // support.h

namespace {

std::unique_ptr<Structure> build(const MeshPtr& mesh, StructureKind kind, int max_depth, int leaf_size) {
  BuildSettings s;
  s.kind = kind;
  s.max_depth = max_depth;
  s.leaf_size = leaf_size;
  return build_structure(mesh, s);
}

const Octree& octree_of(const Structure& s) { return dynamic_cast<const Octree&>(s); }

// One large triangle across the unit cube, and a small one in every corner so that the octree
// splits all around the large one.
MeshPtr large_triangle_mesh() {
  std::vector<glm::vec3> v = {{0.05f, 0.05f, 0.3f}, {0.95f, 0.1f, 0.6f}, {0.2f, 0.95f, 0.7f}};
  std::vector<glm::uvec3> t = {{0, 1, 2}};
  for (int c = 0; c < 8; ++c) {
    const glm::vec3 corner(c & 1, (c >> 1) & 1, (c >> 2) & 1);
    const glm::vec3 inward = glm::vec3(1.0f) - 2.0f * corner;
    const uint32_t base = uint32_t(v.size());
    v.push_back(corner);
    v.push_back(corner + 0.01f * glm::vec3(inward.x, 0, 0));
    v.push_back(corner + 0.01f * glm::vec3(0, inward.y, 0));
    t.push_back({base, base + 1, base + 2});
  }
  return mesh_of(std::move(v), std::move(t));
}

// How many of the leaves a story visited hold `triangle`.
int visited_leaves_holding(const Octree& octree, const RayStory& story, uint32_t triangle) {
  int count = 0;
  for (const StoryNode& n : story.nodes) {
    if (!octree.nodes()[n.node].leaf()) continue;
    for (uint32_t t : octree.leaf_triangles(n.node)) count += t == triangle;
  }
  return count;
}

}  // namespace

TEST(Mailbox, SkipsARepeatUntilASameSlotTriangleEvictsIt) {
  Mailbox box;
  EXPECT_TRUE(box.first_test(7));
  EXPECT_FALSE(box.first_test(7));
  EXPECT_TRUE(box.first_test(8));  // another slot: 7 is still remembered
  EXPECT_FALSE(box.first_test(7));
  EXPECT_TRUE(box.first_test(7 + Mailbox::kSlots));  // the same slot: 7 is evicted
  EXPECT_TRUE(box.first_test(7));
  EXPECT_TRUE(Mailbox().first_test(0));  // a fresh mailbox (one per query) remembers nothing
}

// A ray that skims the large triangle from one side of the cube to the other, a little above it,
// and comes down onto it at the far end: it passes through many leaves holding the triangle, and
// its hit lies beyond the first of them. That first test already finds the hit; the walk must keep
// it, test the triangle no more, and stop after the leaf that holds the hit.
TEST(OctreeMailbox, ATriangleStraddlingManyLeavesIsTestedOnceAndItsFarHitIsKept) {
  const MeshPtr mesh = large_triangle_mesh();
  const auto reference = build(mesh, StructureKind::None, 0, 1);
  const glm::vec3 a = mesh->vertex(0, 0), b = mesh->vertex(0, 1), c = mesh->vertex(0, 2);
  const glm::vec3 normal = glm::normalize(glm::cross(b - a, c - a));
  const glm::vec3 start = 0.8f * a + 0.1f * b + 0.1f * c, end = 0.1f * a + 0.45f * b + 0.45f * c;
  for (int depth : {4, 6, 8}) {
    SCOPED_TRACE("max_depth " + std::to_string(depth));
    const auto s = build(mesh, StructureKind::Octree, depth, 1);
    const Octree& octree = octree_of(*s);
    for (float height : {0.004f, 0.01f, 0.02f}) {
      const Ray ray = ray_of(start + height * normal, end - (start + height * normal));
      expect_same_closest(*reference, *s, ray);
      const RayStory story = s->story(ray);
      ASSERT_EQ(story.status, RayStatus::HitObject);
      EXPECT_EQ(story.hit.triangle, 0u);
      EXPECT_GT(visited_leaves_holding(octree, story, 0), 2) << "height " << height;
      int tests_of_large = 0;
      for (const StoryTriangle& t : story.triangles) tests_of_large += t.triangle == 0;
      EXPECT_EQ(tests_of_large, 1) << "height " << height;
      // The counters tell the same story: a skipped repeat is no test.
      EXPECT_EQ(story.stats.triangle_tests, story.triangles.size());
      TraversalStats stats;
      Hit h;
      ASSERT_TRUE(s->closest(ray, h, stats));
      EXPECT_EQ(stats.triangle_tests, story.triangles.size());
      EXPECT_TRUE(s->any(ray));
    }
  }
}

// Deep trees with leaves of one triangle: nearly every triangle sits in several leaves. Every hit is
// brute force's, and a story repeats a triangle only after a triangle of the same mailbox slot.
TEST(OctreeMailbox, DeepTreesEqualBruteForceAndRepeatOnlyEvictedTriangles) {
  for (const char* name : {"bunny.obj", "plane_holes.obj", "spot_low_resolution.obj"}) {
    SCOPED_TRACE(name);
    const MeshPtr mesh = shipped(name);
    const auto reference = build(mesh, StructureKind::None, 0, 1);
    const auto s = build(mesh, StructureKind::Octree, 9, 1);
    int rays_with_straddlers = 0;
    for (const Ray& ray : random_rays(*mesh, 1500, 13)) {
      expect_same_closest(*reference, *s, ray);
      ASSERT_EQ(reference->any(ray), s->any(ray));
      const RayStory story = s->story(ray);
      std::map<uint32_t, size_t> last_test;  // triangle -> position of its last test in the story
      for (size_t i = 0; i < story.triangles.size(); ++i) {
        const uint32_t t = story.triangles[i].triangle;
        const auto seen = last_test.find(t);
        if (seen != last_test.end()) {
          bool evicted = false;
          for (size_t j = seen->second + 1; j < i; ++j)
            evicted |= story.triangles[j].triangle % Mailbox::kSlots == t % Mailbox::kSlots;
          ASSERT_TRUE(evicted) << "triangle " << t << " tested again without being evicted";
        }
        last_test[t] = i;
      }
      const Octree& octree = octree_of(*s);
      for (const auto& [t, at] : last_test)
        if (visited_leaves_holding(octree, story, t) > 1) {
          ++rays_with_straddlers;
          break;
        }
    }
    EXPECT_GT(rays_with_straddlers, 100);  // the rays really meet triangles in several leaves
  }
}
