#include "raylab/structure.h"

#include "raylab/aabb_structure.h"
#include "raylab/batch.h"
#include "raylab/brute_force.h"
#include "raylab/bvh.h"
#include "raylab/grid.h"
#include "raylab/octree.h"

#include <chrono>

namespace raylab {

namespace {

template <class T>
std::unique_ptr<Structure> make(MeshPtr mesh, const BuildSettings& settings) {
  return std::make_unique<T>(std::move(mesh), settings);
}

// The refit of a structure without topology (brute force, one box): the same structure made anew.
template <class T>
std::unique_ptr<Structure> remake(const Structure& source, MeshPtr moved) {
  return std::make_unique<T>(std::move(moved), source.settings());
}

// VRT's levels in order, then what raylab adds. `none` and `aabb` are VRT's models: every object meets
// every ray and its own structure decides, so a Scene gives them no top level.
constexpr StructureInfo kStructures[] = {
    {StructureKind::None, "none", "None", "Every ray tests every triangle (brute force)", "the object", false,
     false, false, false, &make<BruteForce>, &remake<BruteForce>},
    {StructureKind::Aabb, "aabb", "AABB",
     "One axis-aligned bounding box per object; rays that miss it are ignored", "the AABB", false, false, false,
     true, &make<AabbStructure>, &remake<AabbStructure>},
    {StructureKind::Octree, "octree", "Octree",
     "A cube split into octants while a node holds more than leaf size triangles, down to the maximum depth "
     "(auto: derived from the triangle count and the memory budget)",
     "the octree root", true, true, true, true, &build_octree, nullptr},
    {StructureKind::Bvh, "bvh", "BVH", "A bounding volume hierarchy built with the binned surface area heuristic",
     "the BVH root", false, true, true, true, &build_bvh, &refit_bvh},
    {StructureKind::Grid, "grid", "Uniform grid",
     "Equal cells over the mesh's box, about 3 times the cube root of the triangle count along the longest "
     "side, walked front to back (3D-DDA)",
     "the grid's box", false, false, true, true, &build_grid, nullptr},
};

}  // namespace

std::span<const StructureInfo> structure_kinds() { return kStructures; }

const StructureInfo& structure_info(StructureKind kind) {
  for (const StructureInfo& info : kStructures)
    if (info.kind == kind) return info;
  throw std::logic_error("structure kind " + std::to_string(int(kind)) + " has no row in kStructures");
}

const StructureInfo& structure_info(const std::string& name) {
  std::string names;
  for (const StructureInfo& info : kStructures) {
    if (name == info.name) return info;
    names += (names.empty() ? "" : ", ") + std::string(info.name);
  }
  throw std::invalid_argument("unknown structure '" + name + "': expected one of " + names);
}

void BuildSettings::refuse_negative_depth(int depth) {
  throw std::invalid_argument("max_depth must be >= 0 or '" + std::string(kAutoDepthName) + "', got " +
                              std::to_string(depth));
}

void BuildSettings::validate() const {
  if (max_depth < 0 && max_depth != kAutoDepth) refuse_negative_depth(max_depth);
  if (max_depth > kMaxDepthLimit)
    throw std::invalid_argument("max_depth must be <= " + std::to_string(kMaxDepthLimit) + ", got " +
                                std::to_string(max_depth));
  if (leaf_size < 1) throw std::invalid_argument("leaf_size must be >= 1, got " + std::to_string(leaf_size));
  if (memory_budget == 0) throw std::invalid_argument("memory_budget must be positive");
}

std::unique_ptr<Structure> build_structure(MeshPtr mesh, const BuildSettings& settings) {
  if (!mesh) throw std::invalid_argument("mesh is null");
  settings.validate();
  mesh->validate();
  const auto start = std::chrono::steady_clock::now();
  std::unique_ptr<Structure> s = structure_info(settings.kind).build(mesh, settings);
  s->build_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return s;
}

void intersect_closest(const Structure& s, std::span<const Ray> rays, std::span<Hit> hits,
                       TraversalStats* stats, int threads, std::span<TraversalStats> per_ray) {
  if (hits.size() != rays.size()) throw std::invalid_argument("hits and rays differ in length");
  for_each_ray(
      rays.size(), threads, stats,
      [&](size_t i, TraversalStats* st) {
        Hit h;
        if (st) s.closest(rays[i], h, *st);
        else s.closest(rays[i], h);
        hits[i] = h;
      },
      per_ray);
}

void intersect_any(const Structure& s, std::span<const Ray> rays, std::span<uint8_t> occluded,
                   TraversalStats* stats, int threads, std::span<TraversalStats> per_ray) {
  if (occluded.size() != rays.size()) throw std::invalid_argument("occluded and rays differ in length");
  for_each_ray(
      rays.size(), threads, stats,
      [&](size_t i, TraversalStats* st) { occluded[i] = st ? s.any(rays[i], *st) : s.any(rays[i]); }, per_ray);
}

void intersect_with_status(const Structure& s, std::span<const Ray> rays, std::span<Hit> hits,
                           std::span<RayStatus> statuses, int threads) {
  statuses_of_rays(rays, hits, statuses, threads,
                   [&](const Ray& ray, Hit& hit, TraversalStats& own) { return s.closest(ray, hit, own); });
}

}  // namespace raylab
