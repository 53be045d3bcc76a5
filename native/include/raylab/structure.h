// The one interface behind which the acceleration structures live, and the table that names them.
#pragma once

#include "raylab/bvh_builder.h"
#include "raylab/contract.h"
#include "raylab/geometry.h"
#include "raylab/traversal_record.h"
#include "raylab/triangle_intersection.h"

#include <cstddef>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace raylab {

enum class StructureKind { None, Aabb, Octree, Bvh, Grid };

// The memory a structure's build, or a render's buffers, may take unless told otherwise.
inline constexpr size_t kDefaultMemoryBudget = size_t(4) << 30;

struct BuildSettings {
  // The deepest octree the traversal's stack is sized for.
  static constexpr int kMaxDepthLimit = 16;
  // max_depth "auto" (Python's name for it): the octree picks its depth from the triangle count and
  // the memory budget (Octree::auto_max_depth).
  static constexpr int kAutoDepth = -1;
  static constexpr const char* kAutoDepthName = "auto";

  StructureKind kind = StructureKind::Bvh;
  int max_depth = kAutoDepth;  // octree: depth 0 is the root alone, or kAutoDepth
  int leaf_size = 8;           // octree: split while a node holds more triangles than this; bvh: max per leaf
  TriangleTest triangle_test = TriangleTest::Watertight;  // the exact contract's triangle test
  Contract contract = Contract::Exact;                    // fast: only where StructureInfo::uses_contract
  BvhBuilder builder = BvhBuilder::Sah;                   // others: only where StructureInfo::uses_builder
  size_t memory_budget = kDefaultMemoryBudget;            // a build that would need more stops with BuildError

  // The one place that decides whether settings are acceptable (the depth limit, leaf size, memory
  // budget, the contract, the builder): build_structure and the Scene call it where settings enter the core, the
  // bindings only convert types. Throws std::invalid_argument naming the bad setting.
  void validate() const;
  // validate()'s refusal of a negative max_depth. The bindings give it for -1 as well: from Python only
  // the name kAutoDepthName means auto.
  [[noreturn]] static void refuse_negative_depth(int depth);
};

class Structure;

// One row per structure kind: everything the bindings, the add-on and the benchmark need to know about
// it, read from here (the Python module exports the table as _raylab.STRUCTURES). Adding a structure
// is its own header and source, an enum value above, and a row in kStructures (structure_table.cpp).
struct StructureInfo {
  StructureKind kind;
  const char* name;         // the API's name, e.g. "bvh"
  const char* label;        // for menus and tables, e.g. "BVH"
  const char* description;  // one sentence, for tooltips
  const char* root_name;    // what a ray that misses everything missed, e.g. "the BVH root"
  bool uses_max_depth;      // whether BuildSettings::max_depth changes the build
  bool uses_leaf_size;      // whether BuildSettings::leaf_size changes the build
  bool uses_contract;       // whether it has the fast contract (BuildSettings::contract); else only exact
  bool uses_builder;        // whether BuildSettings::builder chooses how it is built; else only the default
  bool uses_top_level;      // in a Scene: a BVH over the instances' world boxes decides which to visit
  bool has_boxes;           // whether it has boxes to draw
  std::unique_ptr<Structure> (*build)(MeshPtr mesh, const BuildSettings& settings);
  // Refit (refit.h): a new structure over moved vertices of the same triangles that keeps the
  // source's topology. Null where the topology depends on the positions (octree, grid): refit
  // rebuilds those, and the result says so (Structure::refitted()).
  std::unique_ptr<Structure> (*refit)(const Structure& source, MeshPtr moved);
};

std::span<const StructureInfo> structure_kinds();
const StructureInfo& structure_info(StructureKind kind);
// Throws std::invalid_argument listing the known names.
const StructureInfo& structure_info(const std::string& name);
inline StructureKind structure_kind_from_name(const std::string& name) { return structure_info(name).kind; }
inline const char* structure_kind_name(StructureKind kind) { return structure_info(kind).name; }

// A build that cannot be done within the settings (e.g. over the memory budget).
struct BuildError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// One box of a structure, for drawing and teaching.
struct BoxInfo {
  Bounds bounds;
  int depth;
  bool leaf;
  uint32_t triangle_count;  // triangles referenced by the node's subtree leaves (leaf: its own)
};

class Structure {
 public:
  virtual ~Structure() = default;

  // Closest hit in (ray.tmin, ray.tmax]; false and `hit` untouched when nothing is hit.
  virtual bool closest(const Ray& ray, Hit& hit) const = 0;
  virtual bool closest(const Ray& ray, Hit& hit, TraversalStats& stats) const = 0;
  // Any hit in (ray.tmin, ray.tmax]: the shadow-ray query.
  virtual bool any(const Ray& ray) const = 0;
  virtual bool any(const Ray& ray, TraversalStats& stats) const = 0;
  // The whole story of one closest-hit query, recorded by the same traversal code.
  virtual RayStory story(const Ray& ray) const = 0;

  // The uncounted batch queries over a run of rays, on the calling thread (intersect_closest and
  // intersect_any hand each of for_each_ray's chunks to them when nothing is counted): hits[i] is what
  // closest(rays[i], ...) finds (a default Hit on a miss), occluded[i] what any(rays[i]) says, bit for
  // bit. The default is that loop, one ray at a time; the BVH traces coherent groups as packets.
  virtual void closest_batch(std::span<const Ray> rays, std::span<Hit> hits) const;
  virtual void any_batch(std::span<const Ray> rays, std::span<uint8_t> occluded) const;
  // The counted batch queries (the renderer's): the same answers, and each ray's counters added to
  // per_ray[i] (one per ray), exactly what closest(rays[i], hits[i], per_ray[i]) or any(rays[i],
  // per_ray[i]) counts. The default is that loop; the BVH traces coherent groups as packets that count
  // every ray's own work.
  virtual void closest_batch_counted(std::span<const Ray> rays, std::span<Hit> hits,
                                     std::span<TraversalStats> per_ray) const;
  virtual void any_batch_counted(std::span<const Ray> rays, std::span<uint8_t> occluded,
                                 std::span<TraversalStats> per_ray) const;

  virtual std::vector<BoxInfo> boxes() const = 0;
  virtual size_t memory_bytes() const = 0;  // the structure's own memory, without the mesh

  StructureKind kind() const { return settings_.kind; }
  const BuildSettings& settings() const { return settings_; }
  const TriangleMesh& mesh() const { return *mesh_; }
  const MeshPtr& mesh_ptr() const { return mesh_; }
  double build_seconds() const { return build_seconds_; }  // of the build, or of the refit that made it
  // Made by refit_structure keeping its source's topology (false for a build, and for a refit that
  // had to rebuild).
  bool refitted() const { return refitted_; }

 protected:
  Structure(MeshPtr mesh, const BuildSettings& settings) : mesh_(std::move(mesh)), settings_(settings) {}
  MeshPtr mesh_;
  BuildSettings settings_;
  double build_seconds_ = 0.0;
  bool refitted_ = false;
  friend std::unique_ptr<Structure> build_structure(MeshPtr, const BuildSettings&);
  friend std::unique_ptr<Structure> refit_structure(const Structure&, MeshPtr);
};

// Implements the virtual queries once for each recorder by calling the derived class's templates:
//   template <class Recorder> bool traverse_closest(const Ray&, Hit&, Recorder&) const;
//   template <class Recorder> bool traverse_any(const Ray&, Recorder&) const;
template <class Derived>
class StructureBase : public Structure {
 public:
  bool closest(const Ray& ray, Hit& hit) const final {
    NoRecord r;
    return self().traverse_closest(ray, hit, r);
  }
  bool closest(const Ray& ray, Hit& hit, TraversalStats& stats) const final {
    StatsRecord r{stats};
    return self().traverse_closest(ray, hit, r);
  }
  bool any(const Ray& ray) const final {
    NoRecord r;
    return self().traverse_any(ray, r);
  }
  bool any(const Ray& ray, TraversalStats& stats) const final {
    StatsRecord r{stats};
    return self().traverse_any(ray, r);
  }
  RayStory story(const Ray& ray) const final {
    RayStory s;
    s.ray = ray;
    StoryRecord r{s};
    self().traverse_closest(ray, s.hit, r);
    s.finish();
    return s;
  }

 protected:
  using Structure::Structure;

 private:
  const Derived& self() const { return static_cast<const Derived&>(*this); }
};

// Builds the structure named by settings.kind over `mesh` (validated first) and times the build.
std::unique_ptr<Structure> build_structure(MeshPtr mesh, const BuildSettings& settings);

// Batch queries, parallel over rays (TBB) on at most `threads` threads (0: all cores). `stats` may be
// null: then nothing is counted. `per_ray`, one per ray or empty, gets each ray's own counters (and
// `stats` their sum).
void intersect_closest(const Structure& s, std::span<const Ray> rays, std::span<Hit> hits, TraversalStats* stats,
                       int threads = 0, std::span<TraversalStats> per_ray = {});
void intersect_any(const Structure& s, std::span<const Ray> rays, std::span<uint8_t> occluded, TraversalStats* stats,
                   int threads = 0, std::span<TraversalStats> per_ray = {});
// Closest hits and each ray's status (what its story would say, without recording the story): the
// probe's fan of thousands of rays.
void intersect_with_status(const Structure& s, std::span<const Ray> rays, std::span<Hit> hits,
                           std::span<RayStatus> statuses, int threads = 0);

}  // namespace raylab
