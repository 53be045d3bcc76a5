#include "raylab/structure.h"

#include "raylab/aabb_structure.h"
#include "raylab/batch.h"
#include "raylab/brute_force.h"
#include "raylab/bvh.h"
#include "raylab/grid.h"
#include "raylab/octree.h"


#include <chrono>

namespace raylab {

StructureKind structure_kind_from_name(const std::string& name) {
  if (name == "none") return StructureKind::None;
  if (name == "aabb") return StructureKind::Aabb;
  if (name == "octree") return StructureKind::Octree;
  if (name == "bvh") return StructureKind::Bvh;
  if (name == "grid") return StructureKind::Grid;
  throw std::invalid_argument("unknown structure '" + name + "': expected none, aabb, octree, bvh or grid");
}

const char* structure_kind_name(StructureKind kind) {
  switch (kind) {
    case StructureKind::None: return "none";
    case StructureKind::Aabb: return "aabb";
    case StructureKind::Octree: return "octree";
    case StructureKind::Bvh: return "bvh";
    case StructureKind::Grid: return "grid";
  }
  return "?";
}

const char* ray_status_name(RayStatus status) {
  switch (status) {
    case RayStatus::MissedRoot: return "missed_root";
    case RayStatus::MissedNodes: return "missed_nodes";
    case RayStatus::MissedTriangles: return "missed_triangles";
    case RayStatus::HitObject: return "hit_object";
  }
  return "?";
}

void BuildSettings::validate() const {
  if (max_depth < 0) throw std::invalid_argument("max_depth must be >= 0, got " + std::to_string(max_depth));
  if (max_depth > 16) throw std::invalid_argument("max_depth must be <= 16, got " + std::to_string(max_depth));
  if (leaf_size < 1) throw std::invalid_argument("leaf_size must be >= 1, got " + std::to_string(leaf_size));
  if (memory_budget == 0) throw std::invalid_argument("memory_budget must be positive");
}

std::unique_ptr<Structure> build_structure(MeshPtr mesh, const BuildSettings& settings) {
  if (!mesh) throw std::invalid_argument("mesh is null");
  settings.validate();
  mesh->validate();
  const auto start = std::chrono::steady_clock::now();
  std::unique_ptr<Structure> s;
  switch (settings.kind) {
    case StructureKind::None: s = std::make_unique<BruteForce>(mesh, settings); break;
    case StructureKind::Aabb: s = std::make_unique<AabbStructure>(mesh, settings); break;
    case StructureKind::Octree: s = build_octree(mesh, settings); break;
    case StructureKind::Bvh: s = build_bvh(mesh, settings); break;
    case StructureKind::Grid: s = build_grid(mesh, settings); break;
  }
  s->build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return s;
}

void intersect_closest(const Structure& s, std::span<const Ray> rays, std::span<Hit> hits,
                       TraversalStats* stats) {
  if (hits.size() != rays.size()) throw std::invalid_argument("hits and rays differ in length");
  for_each_ray(rays.size(), stats, [&](size_t i, TraversalStats* st) {
    Hit h;
    if (st) s.closest(rays[i], h, *st);
    else s.closest(rays[i], h);
    hits[i] = h;
  });
}

void intersect_any(const Structure& s, std::span<const Ray> rays, std::span<uint8_t> occluded,
                   TraversalStats* stats) {
  if (occluded.size() != rays.size()) throw std::invalid_argument("occluded and rays differ in length");
  for_each_ray(rays.size(), stats, [&](size_t i, TraversalStats* st) {
    occluded[i] = st ? s.any(rays[i], *st) : s.any(rays[i]);
  });
}

}  // namespace raylab
