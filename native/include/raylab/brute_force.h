// `none`: every ray tests every triangle. The reference every other structure must equal.
#pragma once

#include "raylab/structure.h"
#include "raylab/triangle_loop.h"

namespace raylab {

class BruteForce final : public StructureBase<BruteForce> {
 public:
  BruteForce(MeshPtr mesh, const BuildSettings& settings) : StructureBase(std::move(mesh), settings) {}

  template <class Recorder>
  bool traverse_closest(const Ray& ray, Hit& hit, Recorder& record) const {
    record.ray();
    const TriangleTester tester(ray, settings_.triangle_test);
    Hit best = initial_hit(ray);
    if (!closest_in_triangles(*mesh_, tester, uint32_t(mesh_->triangle_count()),
                              [](uint32_t i) { return i; }, best, record))
      return false;
    hit = best;
    return true;
  }

  template <class Recorder>
  bool traverse_any(const Ray& ray, Recorder& record) const {
    record.ray();
    const TriangleTester tester(ray, settings_.triangle_test);
    return any_in_triangles(*mesh_, tester, uint32_t(mesh_->triangle_count()),
                            [](uint32_t i) { return i; }, ray.tmax, record);
  }

  std::vector<BoxInfo> boxes() const override { return {}; }
  size_t memory_bytes() const override { return 0; }
};

}  // namespace raylab
