// `octree`: the root is the mesh's bounding box grown to a cube (depth 0 = the root alone). A node
// splits into its 8 octants while depth < max_depth and it holds more than leaf_size triangles; a
// triangle goes to every octant it truly overlaps (separating-axis test, triangle_box_overlap.h),
// never by "a vertex lies inside", so a large triangle is found in every leaf it crosses. Empty
// octants are not allocated. max_depth auto (the default) derives the depth from the triangle count
// and the memory budget (auto_max_depth). Traversal visits children front to back, stops as soon as
// the closest hit lies before the next child's entry, and tests a triangle met in several leaves once
// per ray (mailbox.h). Built in src/octree.cpp.
#pragma once

#include "raylab/box_intersection.h"
#include "raylab/structure.h"
#include "raylab/triangle_loop.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <span>
#include <type_traits>

namespace raylab {

// One node in 8 bytes. The children of a node are stored next to each other in octant order, so an
// inner node needs only the index of its first child and a mask of the octants that exist; a leaf
// references a run of the octree's one triangle-index array.
struct OctreeNode {
  static constexpr uint32_t kLeaf = 0x80000000u;
  uint32_t first = 0;     // inner: index of the first child; leaf: first entry in the index array
  uint32_t bits = kLeaf;  // leaf: kLeaf | triangle count; inner: child mask (bit i: octant i exists)

  bool leaf() const { return (bits & kLeaf) != 0; }
  uint32_t triangle_count() const { return bits & ~kLeaf; }
  uint32_t child_mask() const { return bits & 0xffu; }
  // The node index of the child in `octant`, which must exist.
  uint32_t child(int octant) const {
    return first + uint32_t(std::popcount(child_mask() & ((1u << octant) - 1u)));
  }
};

// Octant i of a box: bit 0 selects the upper half in x, bit 1 in y, bit 2 in z. Build and traversal
// both derive boxes with this one function, so octants share their splitting planes bit for bit and
// tile their parent exactly. Always inlined: GCC kept it a call inside the walk, about 5% of an
// octree's camera-ray time on dragon.obj.
[[gnu::always_inline]] inline Bounds octant_bounds(const Bounds& box, int octant) {
  const glm::vec3 mid = box.center();
  Bounds b;
  for (int axis = 0; axis < 3; ++axis) {
    const bool upper = (octant >> axis) & 1;
    b.lo[axis] = upper ? mid[axis] : box.lo[axis];
    b.hi[axis] = upper ? box.hi[axis] : mid[axis];
  }
  return b;
}

// The ray against all eight octants of a node at once: the parametric idea of Revelles, Ureña and
// Lastra (2000), where the distances to a node's planes are computed once and every child's interval
// is assembled from them. Per axis there are four planes (the node's two faces and, padded both
// ways, its mid-plane), so building this costs about what one box test costs, and each octant's test
// after it is six comparisons. Each octant's result is intersect_box(octant_bounds(box, octant))
// bit for bit, from the same expressions in the same order (box_intersection.h), so the exactness
// pad, the NaN rules and the story's boxes are unchanged: the children are still box-tested, only
// without repeating the work they share. (Revelles' successor table, which enters only the children
// the ray pierces, would visit fewer than the padded boxes the exactness contract requires.)
// Measured on one core under load, octree / BVH camera rays, median of 9 interleaved pairs: bunny.obj
// 0.19 -> 0.25, dragon.obj 0.18 -> 0.23, koala.obj 0.15 -> 0.17 (max_depth auto).
class OctantSlabs {
 public:
  [[gnu::always_inline]] OctantSlabs(const Bounds& box, const BoxRay& r) {
    const glm::vec3 mid = box.center();  // octant_bounds' own mid-planes
    for (int axis = 0; axis < 3; ++axis) {
      const float o = r.origin[axis], inv = r.inv_dir[axis];
      set(axis, 0, ((box.lo[axis] - o) - r.pad) * inv, ((mid[axis] - o) + r.pad) * inv);
      set(axis, 1, ((mid[axis] - o) - r.pad) * inv, ((box.hi[axis] - o) + r.pad) * inv);
    }
  }

  // intersect_box(octant_bounds(box, octant), r, tmax, t_entry), bit for bit.
  bool intersect(int octant, const BoxRay& r, float tmax, float& t_entry) const {
    float t_near = r.tmin, t_far = tmax;
    for (int axis = 0; axis < 3; ++axis) {
      const int half = (octant >> axis) & 1;
      const float t0 = near_[axis][half], t1 = far_[axis][half];
      t_near = t0 > t_near ? t0 : t_near;
      t_far = t1 < t_far ? t1 : t_far;
    }
    // Neither is ever NaN (the comparisons above keep the old value), and t_near only grows while
    // t_far only shrinks, so testing once at the end decides as intersect_box's test per axis does.
    if (t_near > t_far) return false;
    t_entry = t_near;
    return true;
  }

 private:
  void set(int axis, int half, float t0, float t1) {
    if (t0 > t1) std::swap(t0, t1);
    near_[axis][half] = t0;
    far_[axis][half] = t1 * kBoxFarScale;
  }
  float near_[3][2], far_[3][2];
};

class Octree final : public StructureBase<Octree> {
 public:
  // BuildSettings::validate's limit on max_depth; it sizes the traversal stack.
  static constexpr int kMaxDepth = BuildSettings::kMaxDepthLimit;

  // Levels added to log4(triangles / leaf_size) by max_depth auto (auto_max_depth).
  static constexpr int kAutoDepthMargin = 2;

  // Throws BuildError as soon as the build would need more than settings.memory_budget bytes; with
  // max_depth auto (BuildSettings::kAutoDepth) it ends the tree at the last level that fits instead.
  Octree(MeshPtr mesh, const BuildSettings& settings);

  // The depth max_depth auto allows a mesh of `triangle_count` triangles before the budget is
  // counted: log4(triangle_count / leaf_size), rounded up, plus kAutoDepthMargin, at most kMaxDepth.
  static int auto_max_depth(size_t triangle_count, int leaf_size);
  // The depth limit the tree was built with: settings().max_depth, or what auto chose (lowered to
  // the last level that fitted the memory budget, where that stopped the build).
  int max_depth() const { return max_depth_; }

  template <class Recorder>
  bool traverse_closest(const Ray& ray, Hit& hit, Recorder& record) const {
    return closest_over_leaves(*mesh_, settings_.triangle_test, ray, hit, record, [&](auto limit, auto visit) {
      walk(ray, record, limit, [&](const OctreeNode& leaf) { return visit(triangles_of(leaf)); });
    }, Mailbox{});
  }

  template <class Recorder>
  bool traverse_any(const Ray& ray, Recorder& record) const {
    return any_over_leaves(*mesh_, settings_.triangle_test, ray, record, [&](auto limit, auto visit) {
      walk(ray, record, limit, [&](const OctreeNode& leaf) { return visit(triangles_of(leaf)); });
    }, Mailbox{});
  }

  // Every node in index order (parents before children). A leaf's triangle_count is its own; an
  // inner node's is the number of distinct triangles referenced by the leaves below it.
  std::vector<BoxInfo> boxes() const override;
  // The nodes and the triangle-index array.
  size_t memory_bytes() const override;

  const Bounds& root_bounds() const { return root_; }
  std::span<const OctreeNode> nodes() const { return nodes_; }
  // The triangles of a leaf, in ascending index order.
  std::span<const uint32_t> leaf_triangles(uint32_t node) const { return triangles_of(nodes_[node]); }

 private:
  std::span<const uint32_t> triangles_of(const OctreeNode& leaf) const {
    return {triangles_.data() + leaf.first, leaf.triangle_count()};
  }

  // Trivially constructible (glm vectors, not a Bounds with its empty-box initialiser): the walk's
  // stack of 129 entries was filled with empty boxes on every query, about a tenth of an octree's
  // camera-ray time on dragon.obj.
  struct StackEntry {
    glm::vec3 lo, hi;
    uint32_t node;
    int depth;
    float t_entry;

    Bounds box() const { return {lo, hi}; }
  };
  static_assert(std::is_trivially_default_constructible_v<StackEntry>);

  // The front-to-back walk both queries share. `limit()` is the far end of the search (the closest
  // hit so far, or ray.tmax); `visit_leaf(node)` tests a leaf's triangles and returns true to stop.
  template <class Recorder, class Limit, class VisitLeaf>
  void walk(const Ray& ray, Recorder& record, Limit limit, VisitLeaf visit_leaf) const {
    // Padded boxes (box_intersection.h): a box holding a triangle the triangle test hits at t is
    // entered at or before t, so the walk needs no slack of its own.
    const BoxRay box_ray(ray, root_);

    float t_root;
    if (!enter_root(root_, !nodes_.empty(), box_ray, limit(), record, t_root)) return;
    // Visiting octants in the order k ^ near_octant is front to back: along a ray each octant bit
    // can only turn on, so the octants a ray passes come in increasing order of k. The signs are the
    // box test's (effective_direction): a tiny or -0 component counts as +0 in both.
    const int near_octant =
        (box_ray.inv_dir.x < 0.0f ? 1 : 0) | (box_ray.inv_dir.y < 0.0f ? 2 : 0) | (box_ray.inv_dir.z < 0.0f ? 4 : 0);

    // DFS keeps at most the 8 children of one node per depth on the stack.
    StackEntry stack[8 * kMaxDepth + 1];
    int top = 0;
    stack[top++] = {root_.lo, root_.hi, 0, 0, t_root};
    while (top > 0) {
      const StackEntry entry = stack[--top];
      const float far = limit();
      if (entry.t_entry > far) continue;  // the closest hit so far lies before this box
      record.node(entry.node, entry.depth);
      const OctreeNode node = nodes_[entry.node];
      if (node.leaf()) {
        if (visit_leaf(node)) return;
        continue;
      }
      StackEntry entered[8];
      int count = 0;
      const Bounds box = entry.box();
      const OctantSlabs octants(box, box_ray);
      for (int k = 0; k < 8; ++k) {
        const int octant = k ^ near_octant;
        if (!((node.child_mask() >> octant) & 1u)) continue;
        const uint32_t child = node.child(octant);
        float t = ray.tmin;
        const bool hit = octants.intersect(octant, box_ray, far, t);
        // The octant's box is made only where it is needed (a recorder that draws boxes, a child to
        // enter): with NoRecord the call is empty and the box is never computed for a miss.
        record.box(child, octant_bounds(box, octant), entry.depth + 1, hit, t);
        if (hit) {
          const Bounds b = octant_bounds(box, octant);
          entered[count++] = {b.lo, b.hi, child, entry.depth + 1, t};
        }
      }
      while (count > 0) stack[top++] = entered[--count];  // the nearest child on top
    }
  }

  void build();

  Bounds root_;
  bool automatic_depth_ = false;
  int max_depth_ = 0;
  std::vector<OctreeNode> nodes_;     // breadth first: node 0 is the root
  std::vector<uint32_t> triangles_;   // the leaves' runs, one after another
};

std::unique_ptr<Structure> build_octree(MeshPtr mesh, const BuildSettings& settings);

}  // namespace raylab
