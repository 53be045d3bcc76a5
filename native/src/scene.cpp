#include "raylab/scene.h"

#include "raylab/batch.h"
#include "raylab/box_intersection.h"
#include "raylab/bvh.h"
#include "raylab/bvh_build.h"

#include <glm/gtc/matrix_access.hpp>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

namespace raylab {

namespace {

bool finite(const glm::mat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r])) return false;
  return true;
}

// Object -> world transforms must be affine and invertible; returns the inverse (world -> object).
glm::mat4 checked_inverse(const glm::mat4& m) {
  if (!finite(m)) throw std::invalid_argument("instance transform has a NaN or infinite entry");
  if (glm::row(m, 3) != glm::vec4(0, 0, 0, 1))
    throw std::invalid_argument("instance transform must be affine: its last row must be (0, 0, 0, 1)");
  const glm::mat4 inverse = glm::inverse(m);
  if (glm::determinant(glm::mat3(m)) == 0.0f || !finite(inverse))
    throw std::invalid_argument("instance transform is singular (not invertible)");
  return inverse;
}

// The world box of an object box under an affine transform, from its eight corners, widened by a
// few ulp of its coordinates so that rounding never lets the top level cull a true hit.
Bounds transform_bounds(const Bounds& b, const glm::mat4& m) {
  Bounds out;
  if (b.empty()) return out;
  for (int corner = 0; corner < 8; ++corner) {
    const glm::vec3 p((corner & 1) ? b.hi.x : b.lo.x, (corner & 2) ? b.hi.y : b.lo.y, (corner & 4) ? b.hi.z : b.lo.z);
    out.extend(glm::vec3(m * glm::vec4(p, 1.0f)));
  }
  const glm::vec3 pad = (glm::max(glm::abs(out.lo), glm::abs(out.hi)) + out.extent()) * 0x1p-18f;
  return {out.lo - pad, out.hi + pad};
}

}  // namespace

struct Scene::Impl {
  struct MeshSlot {
    MeshPtr mesh;
    Bounds bounds;  // object space
    std::unique_ptr<Structure> structure;  // null while stale
    std::vector<glm::vec3> shading_normals;  // 3 per triangle, or empty: flat
  };
  struct InstanceSlot {
    Instance instance;
    glm::mat4 world_to_object;
  };

  BuildSettings settings;
  std::vector<MeshSlot> meshes;
  std::vector<InstanceSlot> instances;
  std::vector<Bounds> world_bounds;  // per instance, as of the last top-level build
  BinaryBvh top;
  bool top_stale = true;
  double build_seconds = 0.0;

  MeshSlot& mesh_slot(uint32_t m) {
    if (m >= meshes.size())
      throw std::invalid_argument("unknown mesh id " + std::to_string(m) + ": the scene has " +
                                  std::to_string(meshes.size()) + " meshes");
    return meshes[m];
  }
  const MeshSlot& mesh_slot(uint32_t m) const { return const_cast<Impl*>(this)->mesh_slot(m); }
  InstanceSlot& instance_slot(uint32_t i) {
    if (i >= instances.size())
      throw std::invalid_argument("unknown instance id " + std::to_string(i) + ": the scene has " +
                                  std::to_string(instances.size()) + " instances");
    return instances[i];
  }

  bool stale() const {
    if (top_stale) return true;
    for (const MeshSlot& m : meshes)
      if (!m.structure) return true;
    return false;
  }
  void require_committed() const {
    if (stale()) throw std::logic_error("scene changed since the last commit(): call commit() before querying");
  }

  Ray to_object(const InstanceSlot& inst, const Ray& ray, float tmax) const {
    Ray r;
    r.origin = glm::vec3(inst.world_to_object * glm::vec4(ray.origin, 1.0f));
    // Not normalised: the object-space ray keeps the world ray's parameter t.
    r.direction = glm::mat3(inst.world_to_object) * ray.direction;
    r.tmin = ray.tmin;
    r.tmax = tmax;
    return r;
  }

  // `none` and `aabb` are VRT's models: every object meets every ray and its own structure decides
  // (brute force tests every triangle of every object; the AABB ignores the ray or not). A top level
  // over the instances would be acceleration those two do not have.
  bool uses_top_level() const {
    return settings.kind == StructureKind::Octree || settings.kind == StructureKind::Bvh;
  }

  // One traversal of the top level for both queries. `visit(instance, tmax)` queries one instance
  // and returns the new far limit (any-hit returns -inf to stop).
  template <class Recorder, class Visit>
  void traverse(const Ray& ray, Recorder& record, float& tmax, Visit visit) const {
    struct Entry {
      uint32_t node;
      int depth;
      float t_entry;
    };
    record.ray();
    if (!uses_top_level()) {
      for (uint32_t k = 0; k < instances.size() && tmax >= ray.tmin; ++k) tmax = visit(k, tmax);
      return;
    }
    if (top.nodes.empty()) return;
    const BoxRay box_ray(ray);
    float t_root = ray.tmin;
    const bool root_hit = intersect_box(top.nodes[0].bounds(), box_ray, ray.tmax, t_root);
    record.box(0, top.nodes[0].bounds(), 0, root_hit, t_root);
    if (!root_hit) return;
    Entry stack[Bvh::kStackSize];
    int size = 0;
    stack[size++] = {0, 0, t_root};
    while (size > 0) {
      const Entry e = stack[--size];
      if (e.t_entry > box_limit(tmax)) continue;
      const BvhNode& node = top.nodes[e.node];
      record.node(e.node, e.depth);
      if (node.leaf()) {
        for (uint32_t k = 0; k < node.count && tmax >= ray.tmin; ++k) tmax = visit(top.prims[node.index + k], tmax);
        if (tmax < ray.tmin) return;
        continue;
      }
      float t[2] = {ray.tmin, ray.tmin};
      bool h[2];
      for (uint32_t c = 0; c < 2; ++c) {
        const BvhNode& child = top.nodes[node.index + c];
        h[c] = intersect_box(child.bounds(), box_ray, box_limit(tmax), t[c]);
        record.box(node.index + c, child.bounds(), e.depth + 1, h[c], t[c]);
      }
      const uint32_t near = (h[0] && h[1] && t[1] < t[0]) ? 1 : 0;
      for (uint32_t c : {1 - near, near})
        if (h[c]) stack[size++] = {node.index + c, e.depth + 1, t[c]};
    }
  }

  // Runs a query on one instance's structure, adding its work (not its ray count) to the record;
  // `entered` becomes true when the object's structure did not ignore the ray.
  template <class Recorder, class Query>
  static auto counted(Recorder& record, bool& entered, Query query) {
    if constexpr (Recorder::kActive) {
      TraversalStats s;
      const auto result = query(&s);
      if (s.rays_ignored == 0) entered = true;
      record.stats.box_tests += s.box_tests;
      record.stats.triangle_tests += s.triangle_tests;
      record.stats.nodes_visited += s.nodes_visited;
      return result;
    } else {
      return query(nullptr);
    }
  }

  template <class Recorder>
  bool closest(const Ray& ray, Hit& hit, Recorder& record) const {
    Hit best = initial_hit(ray);
    float tmax = ray.tmax;
    bool entered = false;
    traverse(ray, record, tmax, [&](uint32_t k, float limit) {
      const InstanceSlot& inst = instances[k];
      const Structure& s = *meshes[inst.instance.mesh].structure;
      const Ray r = to_object(inst, ray, limit);
      Hit h;
      const bool found = counted(record, entered, [&](TraversalStats* st) { return st ? s.closest(r, h, *st) : s.closest(r, h); });
      // Equal t across instances: the lower instance index wins, whatever the visiting order.
      if (found && (h.t < best.t || (h.t == best.t && k < best.instance))) {
        best = h;
        best.instance = k;
      }
      return best.t;
    });
    if (!entered) record.ignored();
    if (!best.valid()) return false;
    hit = best;
    return true;
  }

  template <class Recorder>
  bool any(const Ray& ray, Recorder& record) const {
    bool found = false;
    float tmax = ray.tmax;
    bool entered = false;
    traverse(ray, record, tmax, [&](uint32_t k, float limit) {
      const InstanceSlot& inst = instances[k];
      const Structure& s = *meshes[inst.instance.mesh].structure;
      const Ray r = to_object(inst, ray, limit);
      found = counted(record, entered, [&](TraversalStats* st) { return st ? s.any(r, *st) : s.any(r); });
      return found ? -kInfinity : limit;
    });
    if (!entered) record.ignored();
    return found;
  }
};

Scene::Scene(const BuildSettings& settings) : impl_(std::make_unique<Impl>()) {
  settings.validate();
  impl_->settings = settings;
}
Scene::~Scene() = default;
Scene::Scene(Scene&&) noexcept = default;
Scene& Scene::operator=(Scene&&) noexcept = default;

uint32_t Scene::add_mesh(MeshPtr mesh) {
  if (!mesh) throw std::invalid_argument("mesh is null");
  mesh->validate();
  const Bounds bounds = mesh->bounds();
  impl_->meshes.push_back({std::move(mesh), bounds, nullptr, {}});
  return uint32_t(impl_->meshes.size() - 1);
}

void Scene::replace_mesh(uint32_t mesh, MeshPtr replacement) {
  Impl::MeshSlot& slot = impl_->mesh_slot(mesh);
  if (!replacement) throw std::invalid_argument("mesh is null");
  replacement->validate();
  slot.bounds = replacement->bounds();
  slot.mesh = std::move(replacement);
  slot.structure.reset();
  slot.shading_normals.clear();  // they belonged to the old triangles
  impl_->top_stale = true;  // its instances' world boxes changed
}

void validate_shading_normals(const TriangleMesh& mesh, std::span<const glm::vec3> corner_normals) {
  const size_t expected = 3 * mesh.triangles.size();
  if (corner_normals.size() != expected)
    throw std::invalid_argument("shading normals: expected 3 per triangle (" + std::to_string(expected) + "), got " +
                                std::to_string(corner_normals.size()));
  for (const glm::vec3& n : corner_normals)
    if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z))
      throw std::invalid_argument("shading normals have a NaN or infinite entry");
}

void Scene::set_shading_normals(uint32_t mesh, std::vector<glm::vec3> corner_normals) {
  Impl::MeshSlot& slot = impl_->mesh_slot(mesh);
  validate_shading_normals(*slot.mesh, corner_normals);
  slot.shading_normals = std::move(corner_normals);
}

const std::vector<glm::vec3>* Scene::shading_normals(uint32_t mesh) const {
  const Impl::MeshSlot& slot = impl_->mesh_slot(mesh);
  return slot.shading_normals.empty() ? nullptr : &slot.shading_normals;
}

uint32_t Scene::add_instance(uint32_t mesh, const glm::mat4& transform, uint32_t material) {
  impl_->mesh_slot(mesh);
  const glm::mat4 inverse = checked_inverse(transform);
  impl_->instances.push_back({Instance{mesh, transform, material}, inverse});
  impl_->top_stale = true;
  return uint32_t(impl_->instances.size() - 1);
}

void Scene::set_transform(uint32_t instance, const glm::mat4& transform) {
  Impl::InstanceSlot& slot = impl_->instance_slot(instance);
  const glm::mat4 inverse = checked_inverse(transform);
  slot.instance.transform = transform;
  slot.world_to_object = inverse;
  impl_->top_stale = true;
}

void Scene::set_settings(const BuildSettings& settings) {
  settings.validate();
  impl_->settings = settings;
  for (Impl::MeshSlot& m : impl_->meshes) m.structure.reset();
  impl_->top_stale = true;
}

void Scene::commit() {
  const auto start = std::chrono::steady_clock::now();
  // Stale meshes build side by side (each build is parallel inside too): many small meshes would
  // otherwise leave cores idle.
  tbb::parallel_for(size_t(0), impl_->meshes.size(), [&](size_t i) {
    Impl::MeshSlot& m = impl_->meshes[i];
    if (!m.structure) m.structure = build_structure(m.mesh, impl_->settings);
  });
  if (impl_->top_stale) {
    impl_->world_bounds.resize(impl_->instances.size());
    for (size_t i = 0; i < impl_->instances.size(); ++i) {
      const Impl::InstanceSlot& inst = impl_->instances[i];
      impl_->world_bounds[i] = transform_bounds(impl_->meshes[inst.instance.mesh].bounds, inst.instance.transform);
    }
    // One instance per leaf: entering an instance costs a whole structure query.
    impl_->top = build_binary_bvh(impl_->world_bounds, 1);
    impl_->top_stale = false;
  }
  impl_->build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

bool Scene::closest(const Ray& ray, Hit& hit, TraversalStats* stats) const {
  impl_->require_committed();
  if (stats) {
    StatsRecord record{*stats};
    return impl_->closest(ray, hit, record);
  }
  NoRecord record;
  return impl_->closest(ray, hit, record);
}

bool Scene::any(const Ray& ray, TraversalStats* stats) const {
  impl_->require_committed();
  if (stats) {
    StatsRecord record{*stats};
    return impl_->any(ray, record);
  }
  NoRecord record;
  return impl_->any(ray, record);
}

size_t Scene::mesh_count() const { return impl_->meshes.size(); }
size_t Scene::instance_count() const { return impl_->instances.size(); }
const Instance& Scene::instance(uint32_t i) const { return impl_->instance_slot(i).instance; }
const TriangleMesh& Scene::mesh(uint32_t m) const { return *impl_->mesh_slot(m).mesh; }

const Structure& Scene::structure(uint32_t m) const {
  const Impl::MeshSlot& slot = impl_->mesh_slot(m);
  if (!slot.structure) throw std::logic_error("mesh " + std::to_string(m) + " has no structure before commit()");
  return *slot.structure;
}

Bounds Scene::bounds() const {
  Bounds b;
  for (const Impl::InstanceSlot& inst : impl_->instances)
    b.extend(transform_bounds(impl_->meshes[inst.instance.mesh].bounds, inst.instance.transform));
  return b;
}

size_t Scene::memory_bytes() const {
  size_t bytes = impl_->top.nodes.capacity() * sizeof(BvhNode) + impl_->top.prims.capacity() * sizeof(uint32_t);
  for (const Impl::MeshSlot& m : impl_->meshes)
    if (m.structure) bytes += m.structure->memory_bytes();
  return bytes;
}

double Scene::build_seconds() const { return impl_->build_seconds; }

void intersect_closest(const Scene& scene, std::span<const Ray> rays, std::span<Hit> hits, TraversalStats* stats) {
  if (hits.size() != rays.size()) throw std::invalid_argument("hits and rays differ in length");
  for_each_ray(rays.size(), stats, [&](size_t i, TraversalStats* st) { scene.closest(rays[i], hits[i], st); });
}

void intersect_any(const Scene& scene, std::span<const Ray> rays, std::span<uint8_t> occluded,
                   TraversalStats* stats) {
  if (occluded.size() != rays.size()) throw std::invalid_argument("occluded and rays differ in length");
  for_each_ray(rays.size(), stats, [&](size_t i, TraversalStats* st) { occluded[i] = scene.any(rays[i], st); });
}

}  // namespace raylab
