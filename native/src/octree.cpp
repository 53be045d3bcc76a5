#include "raylab/octree.h"
namespace raylab {
// Placeholder until the octree lands; the octree issue replaces this file.
std::unique_ptr<Structure> build_octree(MeshPtr, const BuildSettings&) {
  throw std::logic_error("octree: not built yet");
}
}  // namespace raylab
