// One committed state of a Scene: its meshes with their structures and shading normals, its
// instances and the top level over them. Immutable once Scene::commit() made it, so any number of
// threads may query it while the scene changes and commits again; whoever holds the shared_ptr keeps
// the whole state alive (a query, a batch, a render).
#pragma once

#include "raylab/bvh_build.h"
#include "raylab/structure.h"

#include <glm/mat4x4.hpp>

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace raylab {

struct Instance {
  uint32_t mesh = 0;
  glm::mat4 transform{1.0f};  // object to world
  uint32_t material = 0;      // an index the renderer interprets
};

// Its parts are shared, not copied, between the scene's edited state and the snapshots that did not
// change them: a commit costs what changed.
struct SceneMesh {
  MeshPtr mesh;
  Bounds bounds;                                                  // object space
  std::shared_ptr<const Structure> structure;                     // null while stale (only in the edited state)
  std::shared_ptr<const std::vector<glm::vec3>> shading_normals;  // 3 per triangle; null: flat
  // Only in the edited state, while stale after Scene::refit_mesh: the structure to refit (refit.h)
  // instead of building anew.
  std::shared_ptr<const Structure> refit_source;
};

// What a commit did to the top level: kept the last one (no instance box changed), built it anew,
// or refitted the last one's topology to moved instance boxes (Scene::commit says when).
enum class TopLevelUpdate { Kept, Built, Refitted };
inline constexpr const char* kTopLevelUpdateNames[] = {"kept", "built", "refitted"};
inline const char* top_level_update_name(TopLevelUpdate u) { return kTopLevelUpdateNames[int(u)]; }

struct SceneInstance {
  Instance instance;
  glm::mat4 world_to_object;
};

// What one world ray did in a scene, recorded by the same traversal as closest(): the top level's
// boxes and nodes (world space; none without a top level), then every instance it queried, in
// order, with that instance's own story (object space: its ray is the world ray carried there).
struct SceneStory {
  struct Part {
    uint32_t instance;
    RayStory story;
  };
  Ray ray;
  std::vector<StoryBox> top_boxes;   // in test order
  std::vector<StoryNode> top_nodes;  // in visit order
  std::vector<Part> instances;       // in query order
  Hit hit;                           // world t; hit.instance set
  TraversalStats stats;              // exactly what closest() counts for this ray
  RayStatus status = RayStatus::MissedRoot;
  bool ignored = false;  // no instance's structure took the ray

  void finish();
};

class SceneSnapshot {
 public:
  // Every mesh has its structure; `top` is the top level over the instances' world boxes.
  SceneSnapshot(const BuildSettings& settings, std::vector<SceneMesh> meshes, std::vector<SceneInstance> instances,
                std::shared_ptr<const BinaryBvh> top, uint64_t generation, double build_seconds);

  // World-space queries. hit.instance is set; hit.t is in the world ray's parameter.
  // stats.rays_ignored counts rays that entered no object (every object's box missed). With `none`
  // and `aabb` every object meets every ray, as in VRT; octree and bvh scenes add a top level.
  bool closest(const Ray& ray, Hit& hit, TraversalStats* stats = nullptr) const;
  bool any(const Ray& ray, TraversalStats* stats = nullptr) const;
  SceneStory story(const Ray& ray) const;
  // Many rays on the calling thread (the renderer's primary and shadow rays): hits[i] is what closest()
  // finds for rays[i] (a default Hit on a miss), occluded[i] what any() says, bit for bit; with per_ray
  // (one per ray) each ray's counters are added to per_ray[i], exactly what closest() or any() counts
  // for it. Each ray walks the top level as alone; the rays that reach the same instance go to its
  // structure's batch query together (the BVH traces coherent groups of them as packets).
  void closest_batch(std::span<const Ray> rays, std::span<Hit> hits, std::span<TraversalStats> per_ray = {}) const;
  void any_batch(std::span<const Ray> rays, std::span<uint8_t> occluded, std::span<TraversalStats> per_ray = {}) const;

  size_t mesh_count() const { return meshes_.size(); }
  size_t instance_count() const { return instances_.size(); }
  const Instance& instance(uint32_t i) const;
  const TriangleMesh& mesh(uint32_t m) const;
  const Structure& structure(uint32_t m) const;
  std::shared_ptr<const Structure> structure_ptr(uint32_t m) const;  // keeps it alive past the snapshot
  const std::vector<glm::vec3>* shading_normals(uint32_t m) const;   // null: flat (face normals)
  Bounds bounds() const;                                             // world bounds of every instance
  size_t memory_bytes() const;                                       // structures + top level
  double build_seconds() const { return build_seconds_; }            // of the commit that made it
  uint64_t generation() const { return generation_; }                // the count of scene edits it includes
  TopLevelUpdate top_level_update() const { return top_update_; }    // what the commit that made it did
  double top_level_sah_cost() const;  // sah_cost (refit.h) of the top level, one instance per leaf

 private:
  friend class Scene;  // reuses the top level of the last snapshot when no instance box changed
  // One ray's walk of the top level, suspended at each instance it visits (scene_snapshot.cpp).
  struct TopWalk;
  template <class Recorder>
  void start(TopWalk& walk, Recorder& record) const;
  template <class Recorder>
  bool next_instance(TopWalk& walk, Recorder& record, uint32_t& instance) const;
  template <class Recorder, class Visit>
  void traverse(const Ray& ray, Recorder& record, float& tmax, Visit visit) const;
  template <bool kClosest, bool kCount>
  void trace_batch(std::span<const Ray> rays, Hit* hits, uint8_t* occluded, TraversalStats* per_ray) const;
  // Runs `query(structure, object_ray, stats)` on instance k, the ray moved to its object space with
  // the far limit `limit`; its work goes into the record, and `entered` becomes true unless the
  // object's structure ignored the ray.
  template <class Recorder, class Query>
  bool query_instance(uint32_t k, const Ray& ray, float limit, Recorder& record, bool& entered, Query query) const;
  // `query(k, structure, object_ray, hit, stats_or_null)` runs instance k's closest-hit query.
  template <class Recorder, class Query>
  bool closest(const Ray& ray, Hit& hit, Recorder& record, Query query) const;
  template <class Recorder>
  bool any(const Ray& ray, Recorder& record) const;
  bool uses_top_level() const { return uses_top_level_; }

  BuildSettings settings_;
  bool uses_top_level_;  // the kind's StructureInfo::uses_top_level, read once (every walk asks)
  std::vector<SceneMesh> meshes_;
  std::vector<SceneInstance> instances_;
  std::shared_ptr<const BinaryBvh> top_;
  uint64_t generation_;
  double build_seconds_;
  // Set by Scene::commit: how the top level came about, and its SAH cost when it was last built
  // (carried through refits: the reference a refit's degradation is measured against).
  TopLevelUpdate top_update_ = TopLevelUpdate::Built;
  double top_built_sah_cost_ = 0.0;
};

using SceneSnapshotPtr = std::shared_ptr<const SceneSnapshot>;

// The world box of an object box under an affine transform, padded so that rounding never lets the
// top level cull a true hit.
Bounds transform_bounds(const Bounds& b, const glm::mat4& m);

// Batch queries over one snapshot, parallel over rays (TBB) on at most `threads` threads (0: all
// cores). `stats` may be null; `per_ray` as for a Structure's.
void intersect_closest(const SceneSnapshot& scene, std::span<const Ray> rays, std::span<Hit> hits,
                       TraversalStats* stats, int threads = 0, std::span<TraversalStats> per_ray = {});
void intersect_any(const SceneSnapshot& scene, std::span<const Ray> rays, std::span<uint8_t> occluded,
                   TraversalStats* stats, int threads = 0, std::span<TraversalStats> per_ray = {});
// Closest hits and each ray's status, what its story would say: the probe's fan.
void intersect_with_status(const SceneSnapshot& scene, std::span<const Ray> rays, std::span<Hit> hits,
                           std::span<RayStatus> statuses, int threads = 0);

}  // namespace raylab
