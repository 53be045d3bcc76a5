// A scene's geometry: meshes, instances of them with a 4x4 transform, and a top level over the
// instances. One structure per mesh, in object space, shared by all its instances; rays are moved
// into object space. Only what changed is rebuilt: a new transform rebuilds the top level alone (a
// BVH over instance boxes, cheap), a replaced mesh rebuilds its own structure alone.
#pragma once

#include "raylab/structure.h"

#include <glm/mat4x4.hpp>

#include <memory>
#include <vector>

namespace raylab {

struct Instance {
  uint32_t mesh = 0;
  glm::mat4 transform{1.0f};  // object to world
  uint32_t material = 0;      // an index the renderer interprets
};

class Scene {
 public:
  explicit Scene(const BuildSettings& settings = {});
  ~Scene();
  Scene(Scene&&) noexcept;
  Scene& operator=(Scene&&) noexcept;

  uint32_t add_mesh(MeshPtr mesh);  // validates; returns the mesh id
  void replace_mesh(uint32_t mesh, MeshPtr replacement);  // drops the mesh's shading normals
  // Smooth shading for the renderer: 3 object-space normals per triangle (its corners, in winding
  // order), kept beside the mesh so the structures never see them. Validated as below.
  void set_shading_normals(uint32_t mesh, std::vector<glm::vec3> corner_normals);
  const std::vector<glm::vec3>* shading_normals(uint32_t mesh) const;  // null: flat (face normals)
  // Throws std::invalid_argument on an unknown mesh id or a singular / non-finite transform.
  uint32_t add_instance(uint32_t mesh, const glm::mat4& transform, uint32_t material = 0);
  void set_transform(uint32_t instance, const glm::mat4& transform);
  void set_settings(const BuildSettings& settings);  // rebuilds every mesh structure on commit()

  // Builds what is missing or stale: per-mesh structures, then the top level. A query on a scene
  // changed since the last commit() throws std::logic_error rather than answer from stale data.
  void commit();

  // World-space queries. hit.instance is set; hit.t is in the world ray's parameter.
  // stats.rays_ignored counts rays that entered no object (every object's box missed). With `none`
  // and `aabb` every object meets every ray, as in VRT; octree and bvh scenes add a top level.
  bool closest(const Ray& ray, Hit& hit, TraversalStats* stats = nullptr) const;
  bool any(const Ray& ray, TraversalStats* stats = nullptr) const;

  size_t mesh_count() const;
  size_t instance_count() const;
  const Instance& instance(uint32_t i) const;
  const TriangleMesh& mesh(uint32_t m) const;
  const Structure& structure(uint32_t m) const;  // after commit()
  Bounds bounds() const;                          // world bounds of every instance
  size_t memory_bytes() const;                    // structures + top level
  double build_seconds() const;                   // of the last commit

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Throws std::invalid_argument unless `corner_normals` holds exactly 3 finite normals per triangle of `mesh`.
void validate_shading_normals(const TriangleMesh& mesh, std::span<const glm::vec3> corner_normals);

// Batch queries over a committed scene, parallel over rays (TBB). `stats` may be null.
void intersect_closest(const Scene& scene, std::span<const Ray> rays, std::span<Hit> hits, TraversalStats* stats);
void intersect_any(const Scene& scene, std::span<const Ray> rays, std::span<uint8_t> occluded,
                   TraversalStats* stats);

}  // namespace raylab
