#include "raylab/scene_snapshot.h"

#include "batch.h"
#include "box_intersection.h"
#include "bvh.h"
#include "raylab/refit.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace raylab {

namespace {

// The far limit for the top level's box tests, whose boxes are not padded: about 1e-5 relative slack
// for the box and triangle tests rounding the same point differently. The structures themselves need
// none: their boxes are padded (box_intersection.h), and they open every box entered at or before the
// best hit (inclusive, for the index tie-break).
float box_limit(float best_t) { return best_t + std::abs(best_t) * 0x1p-16f; }

Ray to_object(const SceneInstance& inst, const Ray& ray, float tmax) {
  Ray r;
  r.origin = glm::vec3(inst.world_to_object * glm::vec4(ray.origin, 1.0f));
  // Not normalised: the object-space ray keeps the world ray's parameter t.
  r.direction = glm::mat3(inst.world_to_object) * ray.direction;
  r.tmin = ray.tmin;
  r.tmax = tmax;
  return r;
}

}  // namespace

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

SceneSnapshot::SceneSnapshot(const BuildSettings& settings, std::vector<SceneMesh> meshes,
                             std::vector<SceneInstance> instances, std::shared_ptr<const BinaryBvh> top,
                             uint64_t generation, double build_seconds)
    : settings_(settings),
      meshes_(std::move(meshes)),
      instances_(std::move(instances)),
      top_(std::move(top)),
      generation_(generation),
      build_seconds_(build_seconds) {
  for (size_t m = 0; m < meshes_.size(); ++m)
    if (!meshes_[m].structure) throw std::logic_error("snapshot of mesh " + std::to_string(m) + " without a structure");
  if (!top_) throw std::logic_error("snapshot without a top level");
}

bool SceneSnapshot::uses_top_level() const { return structure_info(settings_.kind).uses_top_level; }

// One traversal of the top level for both queries. `visit(instance, tmax)` queries one instance
// and returns the new far limit (any-hit returns -inf to stop).
template <class Recorder, class Visit>
void SceneSnapshot::traverse(const Ray& ray, Recorder& record, float& tmax, Visit visit) const {
  struct Entry {
    uint32_t node;
    int depth;
    float t_entry;
  };
  record.ray();
  if (!uses_top_level()) {
    for (uint32_t k = 0; k < instances_.size() && tmax >= ray.tmin; ++k) tmax = visit(k, tmax);
    return;
  }
  const BinaryBvh& top = *top_;
  if (top.nodes.empty()) return;
  // Padded like a structure's own boxes, relative to the top root: the object-space ray is the world
  // ray transformed in float, so an instance's hit can lie a rounding of the origin's distance
  // outside its world box (transform_bounds pads only by the box's own coordinates).
  const BoxRay box_ray(ray, top.nodes[0].bounds());
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

template <class Recorder, class Query>
bool SceneSnapshot::query_instance(uint32_t k, const Ray& ray, float limit, Recorder& record, bool& entered,
                                   Query query) const {
  const SceneInstance& inst = instances_[k];
  const Structure& s = *meshes_[inst.instance.mesh].structure;
  const Ray r = to_object(inst, ray, limit);
  if constexpr (Recorder::kActive) {
    TraversalStats counts;
    const bool found = query(k, s, r, &counts);
    if (counts.rays_ignored == 0) entered = true;
    for (const CounterInfo& c : kCounters)
      if (c.object_work) record.stats.*c.field += counts.*c.field;
    return found;
  } else {
    return query(k, s, r, nullptr);
  }
}

template <class Recorder, class Query>
bool SceneSnapshot::closest(const Ray& ray, Hit& hit, Recorder& record, Query query) const {
  Hit best = initial_hit(ray);
  float tmax = ray.tmax;
  bool entered = false;
  traverse(ray, record, tmax, [&](uint32_t k, float limit) {
    Hit h;
    const bool found = query_instance(
        k, ray, limit, record, entered,
        [&](uint32_t k, const Structure& s, const Ray& r, TraversalStats* st) { return query(k, s, r, h, st); });
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
bool SceneSnapshot::any(const Ray& ray, Recorder& record) const {
  bool found = false;
  float tmax = ray.tmax;
  bool entered = false;
  traverse(ray, record, tmax, [&](uint32_t k, float limit) {
    found = query_instance(
        k, ray, limit, record, entered,
        [&](uint32_t, const Structure& s, const Ray& r, TraversalStats* st) { return st ? s.any(r, *st) : s.any(r); });
    return found ? -kInfinity : limit;
  });
  if (!entered) record.ignored();
  return found;
}

namespace {

bool closest_in(const Structure& s, const Ray& r, Hit& h, TraversalStats* st) {
  return st ? s.closest(r, h, *st) : s.closest(r, h);
}

// The top level's part of a scene story; the instances' parts come from their own stories. It counts
// through StatsRecord, so that a new counter is counted here as everywhere else.
struct SceneStoryRecord {
  static constexpr bool kActive = true;
  SceneStory& story;
  TraversalStats& stats;
  void ray() { StatsRecord{stats}.ray(); }
  void ignored() {
    StatsRecord{stats}.ignored();
    story.ignored = true;
  }
  void box(uint32_t node, const Bounds& b, int depth, bool hit, float t_entry) {
    StatsRecord{stats}.box(node, b, depth, hit, t_entry);
    story.top_boxes.push_back({node, b, depth, hit, t_entry});
  }
  void node(uint32_t node, int depth) {
    StatsRecord{stats}.node(node, depth);
    story.top_nodes.push_back({node, depth});
  }
};

}  // namespace

void SceneStory::finish() {
  const bool tested =
      std::any_of(instances.begin(), instances.end(), [](const Part& p) { return !p.story.triangles.empty(); });
  status = ray_status(hit.valid(), ignored, tested);
}

bool SceneSnapshot::closest(const Ray& ray, Hit& hit, TraversalStats* stats) const {
  const auto query = [](uint32_t, const Structure& s, const Ray& r, Hit& h, TraversalStats* st) {
    return closest_in(s, r, h, st);
  };
  if (stats) {
    StatsRecord record{*stats};
    return closest(ray, hit, record, query);
  }
  NoRecord record;
  return closest(ray, hit, record, query);
}

SceneStory SceneSnapshot::story(const Ray& ray) const {
  SceneStory st;
  st.ray = ray;
  SceneStoryRecord record{st, st.stats};
  closest(ray, st.hit, record, [&](uint32_t k, const Structure& s, const Ray& r, Hit& h, TraversalStats* counts) {
    RayStory part = s.story(r);
    *counts = part.stats;
    h = part.hit;
    const bool found = part.hit.valid();
    st.instances.push_back({k, std::move(part)});
    return found;
  });
  st.finish();
  return st;
}

bool SceneSnapshot::any(const Ray& ray, TraversalStats* stats) const {
  if (stats) {
    StatsRecord record{*stats};
    return any(ray, record);
  }
  NoRecord record;
  return any(ray, record);
}

const Instance& SceneSnapshot::instance(uint32_t i) const {
  if (i >= instances_.size())
    throw std::invalid_argument("unknown instance id " + std::to_string(i) + ": the scene has " +
                                std::to_string(instances_.size()) + " instances");
  return instances_[i].instance;
}

const TriangleMesh& SceneSnapshot::mesh(uint32_t m) const {
  if (m >= meshes_.size())
    throw std::invalid_argument("unknown mesh id " + std::to_string(m) + ": the scene has " +
                                std::to_string(meshes_.size()) + " meshes");
  return *meshes_[m].mesh;
}

const Structure& SceneSnapshot::structure(uint32_t m) const {
  mesh(m);  // checks the id
  return *meshes_[m].structure;
}

std::shared_ptr<const Structure> SceneSnapshot::structure_ptr(uint32_t m) const {
  mesh(m);  // checks the id
  return meshes_[m].structure;
}

const std::vector<glm::vec3>* SceneSnapshot::shading_normals(uint32_t m) const {
  mesh(m);  // checks the id
  return meshes_[m].shading_normals.get();
}

Bounds SceneSnapshot::bounds() const {
  Bounds b;
  for (const SceneInstance& inst : instances_)
    b.extend(transform_bounds(meshes_[inst.instance.mesh].bounds, inst.instance.transform));
  return b;
}

double SceneSnapshot::top_level_sah_cost() const { return sah_cost(*top_, 1); }

size_t SceneSnapshot::memory_bytes() const {
  size_t bytes = top_->nodes.capacity() * sizeof(BvhNode) + top_->prims.capacity() * sizeof(uint32_t);
  for (const SceneMesh& m : meshes_) bytes += m.structure->memory_bytes();
  return bytes;
}

void intersect_closest(const SceneSnapshot& scene, std::span<const Ray> rays, std::span<Hit> hits,
                       TraversalStats* stats, int threads, std::span<TraversalStats> per_ray) {
  if (hits.size() != rays.size()) throw std::invalid_argument("hits and rays differ in length");
  for_each_ray(
      rays.size(), threads, stats, [&](size_t i, TraversalStats* st) { scene.closest(rays[i], hits[i], st); }, per_ray);
}

void intersect_any(const SceneSnapshot& scene, std::span<const Ray> rays, std::span<uint8_t> occluded,
                   TraversalStats* stats, int threads, std::span<TraversalStats> per_ray) {
  if (occluded.size() != rays.size()) throw std::invalid_argument("occluded and rays differ in length");
  for_each_ray(
      rays.size(), threads, stats, [&](size_t i, TraversalStats* st) { occluded[i] = scene.any(rays[i], st); },
      per_ray);
}

void intersect_with_status(const SceneSnapshot& scene, std::span<const Ray> rays, std::span<Hit> hits,
                           std::span<RayStatus> statuses, int threads) {
  statuses_of_rays(rays, hits, statuses, threads,
                   [&](const Ray& ray, Hit& hit, TraversalStats& own) { return scene.closest(ray, hit, &own); });
}

}  // namespace raylab
