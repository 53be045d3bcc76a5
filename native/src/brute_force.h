// `none`: every ray tests every triangle. The reference every other structure must equal.
#pragma once

#include "raylab/structure.h"
#include "triangle_loop.h"

namespace raylab {

class BruteForce final : public StructureBase<BruteForce> {
 public:
  BruteForce(MeshPtr mesh, const BuildSettings& settings) : StructureBase(std::move(mesh), settings) {}

  template <class Recorder>
  bool traverse_closest(const Ray& ray, Hit& hit, Recorder& record) const {
    record.ray();
    return closest_in_mesh(*mesh_, settings_.triangle_test, ray, hit, record);
  }

  template <class Recorder>
  bool traverse_any(const Ray& ray, Recorder& record) const {
    record.ray();
    return any_in_mesh(*mesh_, settings_.triangle_test, ray, record);
  }

  std::vector<BoxInfo> boxes() const override { return {}; }
  size_t memory_bytes() const override { return 0; }
};

}  // namespace raylab
