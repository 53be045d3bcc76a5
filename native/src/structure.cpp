#include "raylab/structure.h"

#include "batch.h"

#include <chrono>

namespace raylab {

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
  if (builder != BuildSettings().builder && !structure_info(kind).uses_builder) {
    std::string takers;
    for (const StructureInfo& info : structure_kinds())
      if (info.uses_builder) takers += (takers.empty() ? "" : ", ") + std::string(info.name);
    throw std::invalid_argument("builder '" + std::string(bvh_builder_name(builder)) +
                                "' is not available for structure '" + std::string(structure_info(kind).name) +
                                "': it has one way to build (" + takers + " take a builder)");
  }
  if (contract == Contract::Fast) {
    if (!structure_info(kind).uses_contract) {
      std::string takers;
      for (const StructureInfo& info : structure_kinds())
        if (info.uses_contract) takers += (takers.empty() ? "" : ", ") + std::string(info.name);
      throw std::invalid_argument("contract 'fast' is not available for structure '" +
                                  std::string(structure_info(kind).name) + "': it has the exact contract only (" +
                                  takers + " take the fast one)");
    }
    if (triangle_test != TriangleTest::Watertight)
      throw std::invalid_argument("triangle_test '" + std::string(triangle_test_name(triangle_test)) +
                                  "' is a test of the exact contract; the fast contract has its own "
                                  "(Möller–Trumbore on precomputed edges)");
  }
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

void Structure::closest_batch(std::span<const Ray> rays, std::span<Hit> hits) const {
  for (size_t i = 0; i < rays.size(); ++i) {
    Hit h;
    closest(rays[i], h);
    hits[i] = h;
  }
}

void Structure::any_batch(std::span<const Ray> rays, std::span<uint8_t> occluded) const {
  for (size_t i = 0; i < rays.size(); ++i) occluded[i] = any(rays[i]);
}

void Structure::closest_batch_counted(std::span<const Ray> rays, std::span<Hit> hits,
                                      std::span<TraversalStats> per_ray) const {
  for (size_t i = 0; i < rays.size(); ++i) {
    Hit h;
    closest(rays[i], h, per_ray[i]);
    hits[i] = h;
  }
}

void Structure::any_batch_counted(std::span<const Ray> rays, std::span<uint8_t> occluded,
                                  std::span<TraversalStats> per_ray) const {
  for (size_t i = 0; i < rays.size(); ++i) occluded[i] = any(rays[i], per_ray[i]);
}

// Uncounted, a chunk of rays goes to the structure's batch query (the BVH's packets); counted, every
// ray walks alone, so that each ray's counters are its own walk's.
void intersect_closest(const Structure& s, std::span<const Ray> rays, std::span<Hit> hits, TraversalStats* stats,
                       int threads, std::span<TraversalStats> per_ray) {
  if (hits.size() != rays.size()) throw std::invalid_argument("hits and rays differ in length");
  if (!stats && per_ray.empty()) {
    for_each_ray_range(rays.size(), threads, [&](size_t begin, size_t end) {
      s.closest_batch(rays.subspan(begin, end - begin), hits.subspan(begin, end - begin));
    });
    return;
  }
  for_each_ray(
      rays.size(), threads, stats,
      [&](size_t i, TraversalStats* st) {  // counted: st is never null here
        Hit h;
        s.closest(rays[i], h, *st);
        hits[i] = h;
      },
      per_ray);
}

void intersect_any(const Structure& s, std::span<const Ray> rays, std::span<uint8_t> occluded, TraversalStats* stats,
                   int threads, std::span<TraversalStats> per_ray) {
  if (occluded.size() != rays.size()) throw std::invalid_argument("occluded and rays differ in length");
  if (!stats && per_ray.empty()) {
    for_each_ray_range(rays.size(), threads, [&](size_t begin, size_t end) {
      s.any_batch(rays.subspan(begin, end - begin), occluded.subspan(begin, end - begin));
    });
    return;
  }
  for_each_ray(
      rays.size(), threads, stats, [&](size_t i, TraversalStats* st) { occluded[i] = s.any(rays[i], *st); },
      per_ray);  // counted: st set
}

void intersect_with_status(const Structure& s, std::span<const Ray> rays, std::span<Hit> hits,
                           std::span<RayStatus> statuses, int threads) {
  statuses_of_rays(rays, hits, statuses, threads,
                   [&](const Ray& ray, Hit& hit, TraversalStats& own) { return s.closest(ray, hit, own); });
}

}  // namespace raylab
