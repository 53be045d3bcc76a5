#include "raylab/refit.h"

#include <chrono>
#include <stdexcept>
#include <string>

namespace raylab {

MeshPtr moved_mesh(const TriangleMesh& source, std::vector<glm::vec3> vertices) {
  if (vertices.size() != source.vertices.size())
    throw std::invalid_argument("vertices: expected " + std::to_string(source.vertices.size()) +
                                " rows (the mesh's vertex count: a refit keeps the triangles), got " +
                                std::to_string(vertices.size()));
  auto moved = std::make_shared<TriangleMesh>();
  moved->vertices = std::move(vertices);
  moved->triangles = source.triangles;
  try {
    moved->validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("vertices: ") + e.what());
  }
  return moved;
}

std::unique_ptr<Structure> refit_structure(const Structure& source, MeshPtr moved) {
  if (!moved) throw std::invalid_argument("mesh is null");
  if (moved->triangles != source.mesh().triangles || moved->vertices.size() != source.mesh().vertices.size())
    throw std::invalid_argument("refit: the moved mesh must have the source's triangles and vertex count");
  moved->validate();
  const auto start = std::chrono::steady_clock::now();
  const StructureInfo& info = structure_info(source.kind());
  std::unique_ptr<Structure> s = info.refit ? info.refit(source, moved) : info.build(moved, source.settings());
  s->build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  s->refitted_ = info.refit != nullptr;
  return s;
}

std::unique_ptr<Structure> refit_structure(const Structure& source, std::vector<glm::vec3> vertices) {
  return refit_structure(source, moved_mesh(source.mesh(), std::move(vertices)));
}

namespace {

// Post-order from node n (whatever order the build stored the nodes in); the depth is the builder's,
// below 48 + log2(n). Returns the node's new box.
Bounds refit_subtree(BinaryBvh& bvh, std::span<const Bounds> prim_bounds, uint32_t n) {
  Bounds b;
  if (bvh.nodes[n].leaf()) {
    for (uint32_t k = 0; k < bvh.nodes[n].count; ++k) b.extend(prim_bounds[bvh.prims[bvh.nodes[n].index + k]]);
  } else {
    const uint32_t first = bvh.nodes[n].index;
    b.extend(refit_subtree(bvh, prim_bounds, first));
    b.extend(refit_subtree(bvh, prim_bounds, first + 1));
  }
  bvh.nodes[n].lo = b.lo;
  bvh.nodes[n].hi = b.hi;
  return b;
}

}  // namespace

bool refit_binary_bvh(BinaryBvh& bvh, std::span<const Bounds> prim_bounds) {
  size_t taken = 0;
  for (const Bounds& b : prim_bounds) taken += !b.empty();
  if (taken != bvh.prims.size()) return false;
  for (uint32_t p : bvh.prims)
    if (p >= prim_bounds.size() || prim_bounds[p].empty()) return false;
  if (!bvh.nodes.empty()) refit_subtree(bvh, prim_bounds, 0);
  return true;
}

double sah_cost(const BinaryBvh& bvh, uint32_t leaf_block) {
  if (bvh.nodes.empty()) return 0.0;
  const double root = bvh.nodes[0].bounds().surface_area();
  double sum = 0.0;
  for (const BvhNode& node : bvh.nodes) {
    const double weight = root > 0.0 ? node.bounds().surface_area() / root : 1.0;
    sum += weight * (node.leaf() ? double((node.count + leaf_block - 1) / leaf_block) : double(kSahTraversalCost));
  }
  return sum;
}

}  // namespace raylab
