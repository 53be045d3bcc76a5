#include "raylab/bvh.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <string>

namespace raylab {

namespace {

BinaryBvh build_over_triangles(const TriangleMesh& mesh, const BuildSettings& settings) {
  const size_t n = mesh.triangle_count();
  const size_t needed = n * sizeof(Bounds) + binary_bvh_build_bytes(n);
  if (needed > settings.memory_budget)
    throw BuildError("bvh: building over " + std::to_string(n) + " triangles needs about " +
                     std::to_string(needed) + " bytes, over the memory budget of " +
                     std::to_string(settings.memory_budget));
  std::vector<Bounds> bounds(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) bounds[i] = mesh.triangle_bounds(uint32_t(i));
  });
  return build_binary_bvh(bounds, uint32_t(settings.leaf_size));
}

}  // namespace

Bvh::Bvh(MeshPtr mesh, const BuildSettings& settings)
    : StructureBase(std::move(mesh), settings), bvh_(build_over_triangles(*mesh_, settings_)) {}

std::vector<BoxInfo> Bvh::boxes() const {
  std::vector<BoxInfo> out(bvh_.nodes.size());
  if (bvh_.nodes.empty()) return out;
  // Children always follow their parent in the array, so a backward pass sums subtree counts
  // after a forward pass has set depths.
  out[0].depth = 0;
  for (size_t i = 0; i < bvh_.nodes.size(); ++i) {
    const BvhNode& node = bvh_.nodes[i];
    out[i].bounds = node.bounds();
    out[i].leaf = node.leaf();
    out[i].triangle_count = node.count;
    if (!node.leaf()) out[node.index].depth = out[node.index + 1].depth = out[i].depth + 1;
  }
  for (size_t i = bvh_.nodes.size(); i-- > 0;) {
    const BvhNode& node = bvh_.nodes[i];
    if (!node.leaf()) out[i].triangle_count = out[node.index].triangle_count + out[node.index + 1].triangle_count;
  }
  return out;
}

size_t Bvh::memory_bytes() const {
  return bvh_.nodes.capacity() * sizeof(BvhNode) + bvh_.prims.capacity() * sizeof(uint32_t);
}

std::unique_ptr<Structure> build_bvh(MeshPtr mesh, const BuildSettings& settings) {
  return std::make_unique<Bvh>(std::move(mesh), settings);
}

}  // namespace raylab
