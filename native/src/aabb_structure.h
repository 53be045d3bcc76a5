// `aabb`: VRT's per-object bounding box. A ray that misses the box is ignored; otherwise every
// triangle of the object is tested.
#pragma once

#include "box_intersection.h"
#include "raylab/structure.h"
#include "triangle_loop.h"

namespace raylab {

class AabbStructure final : public StructureBase<AabbStructure> {
 public:
  AabbStructure(MeshPtr mesh, const BuildSettings& settings)
      : StructureBase(std::move(mesh), settings), box_(mesh_->bounds()) {}

  template <class Recorder>
  bool traverse_closest(const Ray& ray, Hit& hit, Recorder& record) const {
    record.ray();
    if (!enter(ray, record)) return false;
    return closest_in_mesh(*mesh_, settings_.triangle_test, ray, hit, record);
  }

  template <class Recorder>
  bool traverse_any(const Ray& ray, Recorder& record) const {
    record.ray();
    if (!enter(ray, record)) return false;
    return any_in_mesh(*mesh_, settings_.triangle_test, ray, record);
  }

  std::vector<BoxInfo> boxes() const override {
    if (box_.empty()) return {};
    return {BoxInfo{box_, 0, true, uint32_t(mesh_->triangle_count())}};
  }
  size_t memory_bytes() const override { return sizeof(Bounds); }

 private:
  template <class Recorder>
  bool enter(const Ray& ray, Recorder& record) const {
    float t_entry;
    if (!enter_root(box_, !box_.empty(), BoxRay(ray, box_), ray.tmax, record, t_entry)) return false;
    record.node(0, 0);
    return true;
  }

  Bounds box_;
};

}  // namespace raylab
