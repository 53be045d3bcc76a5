// `bvh`: a binned SAH bounding volume hierarchy (bvh_build.h) with compact 32-byte nodes and ordered
// traversal: the nearer child first, and a node is skipped once the closest hit lies before it.
#pragma once

#include "raylab/box_intersection.h"
#include "raylab/bvh_build.h"
#include "raylab/structure.h"
#include "raylab/triangle_loop.h"

namespace raylab {

// The far limit for box tests while a hit at `best_t` is known. A box entered exactly at best_t
// must still be opened, since a triangle there may win the index tie-break; the slack of a few ulp
// also covers the box and triangle tests rounding the same point differently.
inline float box_limit(float best_t) { return best_t + std::abs(best_t) * 0x1p-20f; }

class Bvh final : public StructureBase<Bvh> {
 public:
  // The traversal stack bound: the builder keeps the depth below 48 + log2(n).
  static constexpr int kStackSize = 128;

  Bvh(MeshPtr mesh, const BuildSettings& settings);

  template <class Recorder>
  bool traverse_closest(const Ray& ray, Hit& hit, Recorder& record) const {
    record.ray();
    const BoxRay box_ray(ray);
    Entry stack[kStackSize];
    int size = 0;
    if (!enter_root(box_ray, record, stack, size)) return false;
    const TriangleTester tester(ray, settings_.triangle_test);
    Hit best = initial_hit(ray);
    bool found = false;
    while (size > 0) {
      const Entry e = stack[--size];
      if (e.t_entry > box_limit(best.t)) continue;
      const BvhNode& node = bvh_.nodes[e.node];
      record.node(e.node, e.depth);
      if (node.leaf()) {
        found |= closest_in_triangles(*mesh_, tester, node.count,
                                      [&](uint32_t i) { return bvh_.prims[node.index + i]; }, best, record);
        continue;
      }
      push_children(node, e.depth, box_ray, box_limit(best.t), record, stack, size);
    }
    if (found) hit = best;
    return found;
  }

  template <class Recorder>
  bool traverse_any(const Ray& ray, Recorder& record) const {
    record.ray();
    const BoxRay box_ray(ray);
    Entry stack[kStackSize];
    int size = 0;
    if (!enter_root(box_ray, record, stack, size)) return false;
    const TriangleTester tester(ray, settings_.triangle_test);
    while (size > 0) {
      const Entry e = stack[--size];
      const BvhNode& node = bvh_.nodes[e.node];
      record.node(e.node, e.depth);
      if (node.leaf()) {
        if (any_in_triangles(*mesh_, tester, node.count, [&](uint32_t i) { return bvh_.prims[node.index + i]; },
                             ray.tmax, record))
          return true;
        continue;
      }
      push_children(node, e.depth, box_ray, ray.tmax, record, stack, size);
    }
    return false;
  }

  std::vector<BoxInfo> boxes() const override;
  size_t memory_bytes() const override;

  const BinaryBvh& tree() const { return bvh_; }

 private:
  struct Entry {
    uint32_t node;
    int depth;
    float t_entry;
  };

  template <class Recorder>
  bool enter_root(const BoxRay& box_ray, Recorder& record, Entry* stack, int& size) const {
    float t_entry = box_ray.tmin;
    const bool hit = !bvh_.nodes.empty() && intersect_box(bvh_.nodes[0].bounds(), box_ray, box_ray.tmax, t_entry);
    record.box(0, bvh_.nodes.empty() ? Bounds() : bvh_.nodes[0].bounds(), 0, hit, t_entry);
    if (!hit) {
      record.ignored();
      return false;
    }
    stack[size++] = {0, 0, t_entry};
    return true;
  }

  // Tests both children and pushes the ones hit, the nearer last so that it is visited first.
  template <class Recorder>
  void push_children(const BvhNode& node, int depth, const BoxRay& box_ray, float tmax, Recorder& record,
                     Entry* stack, int& size) const {
    const uint32_t c = node.index;
    float t0 = box_ray.tmin, t1 = box_ray.tmin;
    const bool h0 = intersect_box(bvh_.nodes[c].bounds(), box_ray, tmax, t0);
    record.box(c, bvh_.nodes[c].bounds(), depth + 1, h0, t0);
    const bool h1 = intersect_box(bvh_.nodes[c + 1].bounds(), box_ray, tmax, t1);
    record.box(c + 1, bvh_.nodes[c + 1].bounds(), depth + 1, h1, t1);
    if (h0 && h1) {
      if (t1 < t0) {
        stack[size++] = {c, depth + 1, t0};
        stack[size++] = {c + 1, depth + 1, t1};
      } else {
        stack[size++] = {c + 1, depth + 1, t1};
        stack[size++] = {c, depth + 1, t0};
      }
    } else if (h0) {
      stack[size++] = {c, depth + 1, t0};
    } else if (h1) {
      stack[size++] = {c + 1, depth + 1, t1};
    }
  }

  BinaryBvh bvh_;
};

std::unique_ptr<Structure> build_bvh(MeshPtr mesh, const BuildSettings& settings);

}  // namespace raylab
