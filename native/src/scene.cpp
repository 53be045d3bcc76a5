#include "raylab/scene.h"

#include "batch.h"
#include "raylab/refit.h"

#include <tbb/parallel_for.h>
#include <glm/gtc/matrix_access.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <stdexcept>
#include <string>

namespace raylab {

namespace {

// A number for the calling thread that no other thread of the process ever gets: thread ids are
// recycled once a thread ends, and a new thread must not inherit an ended one's uncommitted change.
uint64_t this_thread_serial() {
  static std::atomic<uint64_t> next{1};
  thread_local const uint64_t serial = next.fetch_add(1, std::memory_order_relaxed);
  return serial;
}

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
  // In double: a uniform scale of 1e-13 has a float determinant of about 1e-39, whose reciprocal
  // overflows, though its inverse (scale 1e13) is a fine float matrix.
  const glm::dmat4 exact(m);
  if (glm::determinant(glm::dmat3(exact)) == 0.0)
    throw std::invalid_argument("instance transform is singular (not invertible)");
  const glm::mat4 inverse(glm::inverse(exact));
  if (!finite(inverse))
    throw std::invalid_argument("instance transform is too close to singular: its inverse overflows float");
  return inverse;
}

// Validated normals, shared with the snapshots; none: flat.
std::shared_ptr<const std::vector<glm::vec3>> shared_normals(const TriangleMesh& mesh,
                                                             std::vector<glm::vec3> corner_normals) {
  if (corner_normals.empty()) return nullptr;
  validate_shading_normals(mesh, corner_normals);
  return std::make_shared<const std::vector<glm::vec3>>(std::move(corner_normals));
}

}  // namespace

struct Scene::Impl {
  // What the changes edit and commit() builds from. Copies share the meshes, structures and normals.
  struct Edited {
    BuildSettings settings;
    uint64_t settings_generation = 0;  // of the last set_settings()
    std::vector<SceneMesh> meshes;
    std::vector<SceneInstance> instances;
    uint64_t generation = 0;            // changes so far
    uint64_t top_generation = 0;        // of the last change to an instance's world box
    uint64_t instances_generation = 0;  // of the last change to the set of instances
  };
  // A thread whose changes the published snapshot does not include yet, and its last change.
  struct Editor {
    uint64_t thread;  // this_thread_serial()
    uint64_t generation;
  };

  // Guards everything below; held only to read or write them, never during a build, so a query
  // never waits for a commit().
  mutable std::mutex mutex;
  Edited edited;
  SceneSnapshotPtr committed;  // null before the first commit()
  std::vector<Editor> editors;
  // One commit() at a time: the second builds on what the first published.
  std::mutex commit_mutex;

  SceneMesh& mesh_slot(uint32_t m) {
    if (m >= edited.meshes.size())
      throw std::invalid_argument("unknown mesh id " + std::to_string(m) + ": the scene has " +
                                  std::to_string(edited.meshes.size()) + " meshes");
    return edited.meshes[m];
  }
  const SceneMesh& mesh_slot(uint32_t m) const { return const_cast<Impl*>(this)->mesh_slot(m); }
  SceneInstance& instance_slot(uint32_t i) {
    if (i >= edited.instances.size())
      throw std::invalid_argument("unknown instance id " + std::to_string(i) + ": the scene has " +
                                  std::to_string(edited.instances.size()) + " instances");
    return edited.instances[i];
  }
  const SceneInstance& instance_slot(uint32_t i) const { return const_cast<Impl*>(this)->instance_slot(i); }

  // Counts one change by the calling thread (with `mutex` held); `moves_boxes` when it changes an
  // instance's world box, so that the top level is refitted, `changes_instances` when it adds or
  // drops instances, so that it is rebuilt.
  void changed(bool moves_boxes, bool changes_instances = false) {
    const uint64_t generation = ++edited.generation;
    if (moves_boxes || changes_instances) edited.top_generation = generation;
    if (changes_instances) edited.instances_generation = generation;
    const uint64_t self = this_thread_serial();
    for (Editor& e : editors)
      if (e.thread == self) {
        e.generation = generation;
        return;
      }
    editors.push_back({self, generation});
  }
};

Scene::Scene(const BuildSettings& settings) : impl_(std::make_unique<Impl>()) {
  settings.validate();
  impl_->edited.settings = settings;
}
Scene::~Scene() = default;
Scene::Scene(Scene&&) noexcept = default;
Scene& Scene::operator=(Scene&&) noexcept = default;

uint32_t Scene::add_mesh(MeshPtr mesh, std::vector<glm::vec3> corner_normals) {
  if (!mesh) throw std::invalid_argument("mesh is null");
  mesh->validate();
  const Bounds bounds = mesh->bounds();
  auto normals = shared_normals(*mesh, std::move(corner_normals));
  std::lock_guard lock(impl_->mutex);
  impl_->edited.meshes.push_back({std::move(mesh), bounds, nullptr, std::move(normals), nullptr});
  impl_->changed(false);
  return uint32_t(impl_->edited.meshes.size() - 1);
}

void Scene::replace_mesh(uint32_t mesh, MeshPtr replacement, std::vector<glm::vec3> corner_normals) {
  {
    std::lock_guard lock(impl_->mutex);
    impl_->mesh_slot(mesh);  // an unknown id is the first error to report
  }
  if (!replacement) throw std::invalid_argument("mesh is null");
  replacement->validate();
  const Bounds bounds = replacement->bounds();
  // Normals not given: flat, as the old ones belonged to the old triangles.
  auto normals = shared_normals(*replacement, std::move(corner_normals));
  std::lock_guard lock(impl_->mutex);
  impl_->mesh_slot(mesh) = {std::move(replacement), bounds, nullptr, std::move(normals), nullptr};
  impl_->changed(true);  // its instances' world boxes changed
}

void Scene::refit_mesh(uint32_t mesh, std::vector<glm::vec3> vertices, std::vector<glm::vec3> corner_normals) {
  const MeshPtr current = this->mesh(mesh);  // checks the id
  MeshPtr moved = moved_mesh(*current, std::move(vertices));
  const Bounds bounds = moved->bounds();
  auto normals = shared_normals(*moved, std::move(corner_normals));
  std::lock_guard lock(impl_->mutex);
  SceneMesh& slot = impl_->mesh_slot(mesh);
  if (slot.mesh != current)
    throw std::invalid_argument("refit_mesh: mesh " + std::to_string(mesh) +
                                " was replaced while its vertices were checked");
  // Not committed since the last refit: refit from the structure that one would have refitted
  // (the triangles are the same). Stale for another reason (new mesh, new settings): a build.
  std::shared_ptr<const Structure> source = slot.structure ? slot.structure : slot.refit_source;
  slot = {std::move(moved), bounds, nullptr, std::move(normals), std::move(source)};
  impl_->changed(true);  // its instances' world boxes changed
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
  MeshPtr target = this->mesh(mesh);
  validate_shading_normals(*target, corner_normals);
  auto normals = std::make_shared<const std::vector<glm::vec3>>(std::move(corner_normals));
  std::lock_guard lock(impl_->mutex);
  SceneMesh& slot = impl_->mesh_slot(mesh);
  if (slot.mesh != target)
    throw std::invalid_argument("shading normals: mesh " + std::to_string(mesh) +
                                " was replaced while they were checked");
  slot.shading_normals = std::move(normals);
  impl_->changed(false);
}

std::shared_ptr<const std::vector<glm::vec3>> Scene::shading_normals(uint32_t mesh) const {
  std::lock_guard lock(impl_->mutex);
  return impl_->mesh_slot(mesh).shading_normals;
}

uint32_t Scene::add_instance(uint32_t mesh, const glm::mat4& transform, uint32_t material) {
  std::lock_guard lock(impl_->mutex);
  impl_->mesh_slot(mesh);
  const glm::mat4 inverse = checked_inverse(transform);
  impl_->edited.instances.push_back({Instance{mesh, transform, material}, inverse});
  impl_->changed(true, true);
  return uint32_t(impl_->edited.instances.size() - 1);
}

void Scene::set_transform(uint32_t instance, const glm::mat4& transform) {
  std::lock_guard lock(impl_->mutex);
  SceneInstance& slot = impl_->instance_slot(instance);
  const glm::mat4 inverse = checked_inverse(transform);
  slot.instance.transform = transform;
  slot.world_to_object = inverse;
  impl_->changed(true);
}

void Scene::clear_instances() {
  std::lock_guard lock(impl_->mutex);
  impl_->edited.instances.clear();
  impl_->changed(true, true);
}

void Scene::set_settings(const BuildSettings& settings) {
  settings.validate();
  std::lock_guard lock(impl_->mutex);
  impl_->edited.settings = settings;
  for (SceneMesh& m : impl_->edited.meshes) {
    m.structure.reset();
    m.refit_source.reset();  // a refit keeps its source's settings
  }
  impl_->changed(true);
  impl_->edited.settings_generation = impl_->edited.generation;
}

void Scene::commit() {
  std::lock_guard committing(impl_->commit_mutex);
  const auto start = std::chrono::steady_clock::now();
  // The state as it is now; changes made during the build go to the next commit.
  Impl::Edited state;
  SceneSnapshotPtr previous;
  {
    std::lock_guard lock(impl_->mutex);
    state = impl_->edited;
    previous = impl_->committed;
  }
  // Stale meshes build side by side (each build is parallel inside too): many small meshes would
  // otherwise leave cores idle.
  tbb::parallel_for(size_t(0), state.meshes.size(), [&](size_t i) {
    SceneMesh& m = state.meshes[i];
    if (!m.structure)
      m.structure = m.refit_source ? refit_structure(*m.refit_source, m.mesh) : build_structure(m.mesh, state.settings);
    m.refit_source.reset();  // the snapshot does not keep the old structure alive
  });
  std::shared_ptr<const BinaryBvh> top;
  TopLevelUpdate update = TopLevelUpdate::Built;
  double built_cost = 0.0;
  if (previous && state.top_generation <= previous->generation()) {
    top = previous->top_;
    update = TopLevelUpdate::Kept;
    built_cost = previous->top_built_sah_cost_;
  } else {
    std::vector<Bounds> world_bounds(state.instances.size());
    for (size_t i = 0; i < state.instances.size(); ++i) {
      const SceneInstance& inst = state.instances[i];
      world_bounds[i] = transform_bounds(state.meshes[inst.instance.mesh].bounds, inst.instance.transform);
    }
    // The same instances, only their boxes moved: refit the last top level, unless that degrades it
    // past kTopLevelRefitLimit (the last snapshot is never changed: the refit is a copy).
    if (previous && state.instances_generation <= previous->generation()) {
      auto refitted = std::make_shared<BinaryBvh>(*previous->top_);
      if (refit_binary_bvh(*refitted, world_bounds) &&
          sah_cost(*refitted, 1) <= kTopLevelRefitLimit * previous->top_built_sah_cost_) {
        top = std::move(refitted);
        update = TopLevelUpdate::Refitted;
        built_cost = previous->top_built_sah_cost_;
      }
    }
    if (!top) {
      // One instance per leaf: entering an instance costs a whole structure query.
      top = std::make_shared<const BinaryBvh>(build_binary_bvh(world_bounds, 1));
      built_cost = sah_cost(*top, 1);
    }
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const uint64_t generation = state.generation;
  auto made = std::make_shared<SceneSnapshot>(state.settings, std::move(state.meshes), std::move(state.instances),
                                              std::move(top), generation, seconds);
  made->top_update_ = update;
  made->top_built_sah_cost_ = built_cost;
  SceneSnapshotPtr snapshot = std::move(made);

  std::lock_guard lock(impl_->mutex);
  // The new structures stay for later commits, unless their mesh or the settings changed meanwhile.
  Impl::Edited& edited = impl_->edited;
  if (edited.settings_generation == state.settings_generation)
    for (uint32_t m = 0; m < snapshot->mesh_count(); ++m) {
      SceneMesh& slot = edited.meshes[m];
      if (!slot.structure && slot.mesh == snapshot->meshes_[m].mesh) {
        slot.structure = snapshot->meshes_[m].structure;
        slot.refit_source.reset();
      }
    }
  impl_->committed = std::move(snapshot);
  std::erase_if(impl_->editors, [&](const Impl::Editor& e) { return e.generation <= generation; });
}

SceneSnapshotPtr Scene::snapshot() const {
  std::lock_guard lock(impl_->mutex);
  const uint64_t self = this_thread_serial();
  const bool changed_here = std::any_of(impl_->editors.begin(), impl_->editors.end(),
                                        [&](const Impl::Editor& e) { return e.thread == self; });
  if (!impl_->committed || changed_here)
    throw std::logic_error("scene changed since the last commit(): call commit() before querying");
  return impl_->committed;
}

bool Scene::closest(const Ray& ray, Hit& hit, TraversalStats* stats) const {
  return snapshot()->closest(ray, hit, stats);
}

bool Scene::any(const Ray& ray, TraversalStats* stats) const { return snapshot()->any(ray, stats); }

SceneStory Scene::story(const Ray& ray) const { return snapshot()->story(ray); }

size_t Scene::mesh_count() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->edited.meshes.size();
}

size_t Scene::instance_count() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->edited.instances.size();
}

Instance Scene::instance(uint32_t i) const {
  std::lock_guard lock(impl_->mutex);
  return impl_->instance_slot(i).instance;
}

MeshPtr Scene::mesh(uint32_t m) const {
  std::lock_guard lock(impl_->mutex);
  return impl_->mesh_slot(m).mesh;
}

const Structure& Scene::structure(uint32_t m) const {
  std::lock_guard lock(impl_->mutex);
  const SceneMesh& slot = impl_->mesh_slot(m);
  if (!slot.structure) throw std::logic_error("mesh " + std::to_string(m) + " has no structure before commit()");
  return *slot.structure;
}

Bounds Scene::bounds() const {
  std::lock_guard lock(impl_->mutex);
  Bounds b;
  for (const SceneInstance& inst : impl_->edited.instances)
    b.extend(transform_bounds(impl_->edited.meshes[inst.instance.mesh].bounds, inst.instance.transform));
  return b;
}

size_t Scene::memory_bytes() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->committed ? impl_->committed->memory_bytes() : 0;
}

double Scene::build_seconds() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->committed ? impl_->committed->build_seconds() : 0.0;
}

TopLevelUpdate Scene::top_level_update() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->committed ? impl_->committed->top_level_update() : TopLevelUpdate::Built;
}

double Scene::top_level_sah_cost() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->committed ? impl_->committed->top_level_sah_cost() : 0.0;
}

void intersect_closest(const Scene& scene, std::span<const Ray> rays, std::span<Hit> hits, TraversalStats* stats,
                       int threads, std::span<TraversalStats> per_ray) {
  intersect_closest(*scene.snapshot(), rays, hits, stats, threads, per_ray);
}

void intersect_any(const Scene& scene, std::span<const Ray> rays, std::span<uint8_t> occluded, TraversalStats* stats,
                   int threads, std::span<TraversalStats> per_ray) {
  intersect_any(*scene.snapshot(), rays, occluded, stats, threads, per_ray);
}

void intersect_with_status(const Scene& scene, std::span<const Ray> rays, std::span<Hit> hits,
                           std::span<RayStatus> statuses, int threads) {
  intersect_with_status(*scene.snapshot(), rays, hits, statuses, threads);
}

}  // namespace raylab
