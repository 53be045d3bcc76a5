#include "raylab/bvh.h"
namespace raylab {
// Placeholder until the BVH lands; the BVH work replaces this file.
std::unique_ptr<Structure> build_bvh(MeshPtr, const BuildSettings&) {
  throw std::logic_error("bvh: not built yet");
}
}  // namespace raylab
