// A scene's geometry: meshes, instances of them with a 4x4 transform, and a top level over the
// instances. One structure per mesh, in object space, shared by all its instances; rays are moved
// into object space. Only what changed is rebuilt: a replaced mesh rebuilds its own structure alone,
// a refitted mesh (refit_mesh) refits it, and new transforms refit the top level (a BVH over instance
// boxes) while the set of instances stays the same.
//
// Threads: changes and queries may come from any threads. Changes edit a private state; commit()
// builds from it an immutable SceneSnapshot and swaps it in under a short lock. A query takes the
// current snapshot once (a shared_ptr) and keeps it to the end, so it sees the old or the new
// committed state whole and never waits for a build; a second commit() waits for the first.
#pragma once

#include "raylab/scene_snapshot.h"
#include "raylab/structure.h"

#include <glm/mat4x4.hpp>

#include <memory>
#include <span>
#include <vector>

namespace raylab {

class Scene {
 public:
  explicit Scene(const BuildSettings& settings = {});
  ~Scene();
  Scene(Scene&&) noexcept;
  Scene& operator=(Scene&&) noexcept;

  // Smooth shading for the renderer: 3 object-space normals per triangle (its corners, in winding
  // order), kept beside the mesh so the structures never see them; empty: flat. Validated as below.
  uint32_t add_mesh(MeshPtr mesh, std::vector<glm::vec3> corner_normals = {});  // returns the mesh id
  void replace_mesh(uint32_t mesh, MeshPtr replacement, std::vector<glm::vec3> corner_normals = {});
  // New positions of mesh `mesh`'s vertices, its triangles kept (a deforming mesh): on commit() its
  // structure is refitted from the last one (refit.h; octree and grid rebuild). Throws
  // std::invalid_argument, changing nothing, unless `vertices` has the mesh's vertex count and every
  // coordinate is finite and within kMaxCoordinate. Normals as in replace_mesh.
  void refit_mesh(uint32_t mesh, std::vector<glm::vec3> vertices, std::vector<glm::vec3> corner_normals = {});
  void set_shading_normals(uint32_t mesh, std::vector<glm::vec3> corner_normals);
  // Throws std::invalid_argument on an unknown mesh id or a singular / non-finite transform.
  uint32_t add_instance(uint32_t mesh, const glm::mat4& transform, uint32_t material = 0);
  void set_transform(uint32_t instance, const glm::mat4& transform);
  // Drops every instance; the meshes and their built structures stay, so a new set of instances of
  // them (the objects now shown) costs only the top level.
  void clear_instances();
  void set_settings(const BuildSettings& settings);  // rebuilds every mesh structure on commit()

  // Builds what is missing or stale (per-mesh structures, then the top level) and publishes it. The
  // top level is kept when no instance box moved, refitted when only boxes moved (transforms, mesh
  // changes) and the refitted tree's SAH cost stays within kTopLevelRefitLimit times its cost when
  // built, else built anew.
  void commit();
  // Each instance a ray enters costs a whole structure query, so the top level's quality matters
  // more than its build, which takes microseconds for hundreds of instances: a refit that lets the
  // cost grow by half is rebuilt. Small motions (an animation step) stay refits; objects that trade
  // places rebuild.
  static constexpr double kTopLevelRefitLimit = 1.5;

  // The state of the last commit(), for as long as it is held. Throws std::logic_error before the
  // first commit() and on the thread that changed the scene since the last one: that query would
  // answer from stale data. Other threads get the last committed state.
  SceneSnapshotPtr snapshot() const;

  // Queries on snapshot(); see SceneSnapshot. Many rays: take the snapshot once.
  bool closest(const Ray& ray, Hit& hit, TraversalStats* stats = nullptr) const;
  bool any(const Ray& ray, TraversalStats* stats = nullptr) const;
  SceneStory story(const Ray& ray) const;

  // The edited state, with changes not committed yet.
  size_t mesh_count() const;
  size_t instance_count() const;
  Instance instance(uint32_t i) const;
  MeshPtr mesh(uint32_t m) const;
  std::shared_ptr<const std::vector<glm::vec3>> shading_normals(uint32_t mesh) const;  // null: flat
  // After commit(); the scene holds it until the mesh is replaced or the settings change.
  const Structure& structure(uint32_t m) const;
  Bounds bounds() const;  // world bounds of every instance
  // Of the last commit (0 before the first).
  size_t memory_bytes() const;  // structures + top level
  double build_seconds() const;
  TopLevelUpdate top_level_update() const;  // what the last commit did to the top level (Built before one)
  double top_level_sah_cost() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Throws std::invalid_argument unless `corner_normals` holds exactly 3 finite normals per triangle of `mesh`.
void validate_shading_normals(const TriangleMesh& mesh, std::span<const glm::vec3> corner_normals);

// Batch queries over one snapshot of the scene, parallel over rays (TBB) on at most `threads` threads
// (0: all cores). `stats` may be null; `per_ray` as for a Structure's.
void intersect_closest(const Scene& scene, std::span<const Ray> rays, std::span<Hit> hits, TraversalStats* stats,
                       int threads = 0, std::span<TraversalStats> per_ray = {});
void intersect_any(const Scene& scene, std::span<const Ray> rays, std::span<uint8_t> occluded, TraversalStats* stats,
                   int threads = 0, std::span<TraversalStats> per_ray = {});
void intersect_with_status(const Scene& scene, std::span<const Ray> rays, std::span<Hit> hits,
                           std::span<RayStatus> statuses, int threads = 0);

}  // namespace raylab
