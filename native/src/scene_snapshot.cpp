#include "raylab/scene_snapshot.h"

#include "batch.h"
#include "box_intersection.h"
#include "bvh.h"
#include "bvh_packets.h"
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
      uses_top_level_(structure_info(settings.kind).uses_top_level),
      meshes_(std::move(meshes)),
      instances_(std::move(instances)),
      top_(std::move(top)),
      generation_(generation),
      build_seconds_(build_seconds) {
  for (size_t m = 0; m < meshes_.size(); ++m)
    if (!meshes_[m].structure) throw std::logic_error("snapshot of mesh " + std::to_string(m) + " without a structure");
  if (!top_) throw std::logic_error("snapshot without a top level");
}

// One ray's walk of the top level (or, without one, of every instance in order) for every query,
// suspended at each instance it visits: the single queries run it to its end at once (traverse), the
// batches run many at a time and serve the rays waiting on one instance together (trace_batch). The
// caller lowers `tmax` after each visit (any hit: to -inf, which ends the walk).
struct SceneSnapshot::TopWalk {
  struct Entry {
    uint32_t node;
    int depth;
    float t_entry;
  };
  TopWalk(const Ray& r, const BinaryBvh& top)
      : ray(r), box_ray(r, top.nodes.empty() ? Bounds{} : top.nodes[0].bounds()), tmax(r.tmax) {}
  Ray ray;
  // Padded like a structure's own boxes, relative to the top root: the object-space ray is the world
  // ray transformed in float, so an instance's hit can lie a rounding of the origin's distance
  // outside its world box (transform_bounds pads only by the box's own coordinates).
  BoxRay box_ray;
  float tmax;
  uint32_t leaf_next = 0, leaf_end = 0;  // the current leaf's instances not visited yet
  bool in_leaf = false;
  uint32_t linear_next = 0;  // without a top level: the next instance
  int size = 0;
  // The top level is a binary tree (kMaxBinaryDepth deep at most): a node pushes one child more than it
  // pops.
  Entry stack[kMaxBinaryDepth + 2];
};

template <class Recorder>
void SceneSnapshot::start(TopWalk& w, Recorder& record) const {
  record.ray();
  if (!uses_top_level()) return;
  const BinaryBvh& top = *top_;
  if (top.nodes.empty()) return;
  float t_root = w.ray.tmin;
  const bool root_hit = intersect_box(top.nodes[0].bounds(), w.box_ray, w.ray.tmax, t_root);
  record.box(0, top.nodes[0].bounds(), 0, root_hit, t_root);
  if (root_hit) w.stack[w.size++] = {0, 0, t_root};
}

// The next instance the walk visits within w.tmax; false when it is over.
template <class Recorder>
bool SceneSnapshot::next_instance(TopWalk& w, Recorder& record, uint32_t& instance) const {
  const Ray& ray = w.ray;
  if (!uses_top_level()) {
    if (w.linear_next < instances_.size() && w.tmax >= ray.tmin) {
      instance = w.linear_next++;
      return true;
    }
    return false;
  }
  const BinaryBvh& top = *top_;
  for (;;) {
    if (w.in_leaf) {
      if (w.leaf_next < w.leaf_end && w.tmax >= ray.tmin) {
        instance = top.prims[w.leaf_next++];
        return true;
      }
      w.in_leaf = false;
      if (w.tmax < ray.tmin) {
        w.size = 0;
        return false;
      }
    }
    if (w.size == 0) return false;
    const TopWalk::Entry e = w.stack[--w.size];
    if (e.t_entry > box_limit(w.tmax)) continue;
    const BvhNode& node = top.nodes[e.node];
    record.node(e.node, e.depth);
    if (node.leaf()) {
      w.in_leaf = true;
      w.leaf_next = node.index;
      w.leaf_end = node.index + node.count;
      continue;
    }
    float t[2] = {ray.tmin, ray.tmin};
    bool h[2];
    for (uint32_t c = 0; c < 2; ++c) {
      const BvhNode& child = top.nodes[node.index + c];
      h[c] = intersect_box(child.bounds(), w.box_ray, box_limit(w.tmax), t[c]);
      record.box(node.index + c, child.bounds(), e.depth + 1, h[c], t[c]);
    }
    const uint32_t near = (h[0] && h[1] && t[1] < t[0]) ? 1 : 0;
    for (uint32_t c : {1 - near, near})
      if (h[c]) w.stack[w.size++] = {node.index + c, e.depth + 1, t[c]};
  }
}

// The walk run to its end: `visit(instance, tmax)` queries one instance and returns the new far limit.
template <class Recorder, class Visit>
void SceneSnapshot::traverse(const Ray& ray, Recorder& record, float& tmax, Visit visit) const {
  TopWalk w(ray, *top_);
  start(w, record);
  uint32_t k;
  while (next_instance(w, record, k)) w.tmax = visit(k, w.tmax);
  tmax = w.tmax;
}

namespace {

// An instance query's work, as the scene counts it: its object work added, and whether the object's
// structure took the ray.
template <class Recorder>
void add_instance_work(Recorder& record, const TraversalStats& counts, bool& entered) {
  if (counts.rays_ignored == 0) entered = true;
  for (const CounterInfo& c : kCounters)
    if (c.object_work) record.stats.*c.field += counts.*c.field;
}

// Equal t across instances: the lower instance index wins, whatever the visiting order.
void take_instance_hit(Hit& best, const Hit& h, bool found, uint32_t k) {
  if (found && (h.t < best.t || (h.t == best.t && k < best.instance))) {
    best = h;
    best.instance = k;
  }
}

}  // namespace

template <class Recorder, class Query>
bool SceneSnapshot::query_instance(uint32_t k, const Ray& ray, float limit, Recorder& record, bool& entered,
                                   Query query) const {
  const SceneInstance& inst = instances_[k];
  const Structure& s = *meshes_[inst.instance.mesh].structure;
  const Ray r = to_object(inst, ray, limit);
  if constexpr (Recorder::kActive) {
    TraversalStats counts;
    const bool found = query(k, s, r, &counts);
    add_instance_work(record, counts, entered);
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
    take_instance_hit(best, h, found, k);
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
  static constexpr bool kIds = true;
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

// Rays `kGroup` at a time: each walks the top level as alone up to the next instance it visits; the
// first ray still walking names the instance served next, and every ray waiting on that one goes to
// its structure's batch query, moved to its object space with its own far limit, then walks on.
template <bool kClosest, bool kCount>
void SceneSnapshot::trace_batch(std::span<const Ray> rays, Hit* hits, uint8_t* occluded,
                                TraversalStats* per_ray) const {
  constexpr size_t kGroup = 16;
  struct Lane {
    TopWalk walk;
    Hit best;
    uint32_t instance = 0;
    bool waiting = false, entered = false, found = false;
    Lane(const Ray& ray, const BinaryBvh& top) : walk(ray, top), best(initial_hit(ray)) {}
  };
  const auto record_of = [&](size_t i) {
    if constexpr (kCount) return StatsRecord{per_ray[i]};
    else return NoRecord{};
  };
  std::vector<Lane> lanes;
  lanes.reserve(std::min(kGroup, rays.size()));
  std::vector<uint32_t> served;
  std::vector<Ray> object_rays;
  std::vector<Hit> object_hits;
  std::vector<uint8_t> object_found;
  std::vector<TraversalStats> object_counts;
  // Uncounted, a group whose rays all miss the top level's root box (the camera's sky) is answered
  // after one lane-wise test of that box per eight rays instead of each ray's own walk.
  const bool cull = !kCount && uses_top_level() && !top_->nodes.empty() && cpu_has_avx2();
  for (size_t g = 0; g < rays.size(); g += kGroup) {
    const size_t n = std::min(kGroup, rays.size() - g);
    if (cull) {
      uint32_t entering = 0;
      for (size_t b = 0; b < n && entering == 0; b += 8)
        entering |= rays_entering(&rays[g + b], int(std::min<size_t>(8, n - b)), top_->nodes[0].bounds());
      if (entering == 0) {
        for (size_t r = 0; r < n; ++r) {
          if constexpr (kClosest) hits[g + r] = Hit{};
          else occluded[g + r] = 0;
        }
        continue;
      }
    }
    lanes.clear();
    for (size_t r = 0; r < n; ++r) {
      Lane& lane = lanes.emplace_back(rays[g + r], *top_);
      auto record = record_of(g + r);
      start(lane.walk, record);
      lane.waiting = next_instance(lane.walk, record, lane.instance);
    }
    for (size_t first = 0;;) {
      while (first < n && !lanes[first].waiting) ++first;
      if (first == n) break;
      const uint32_t k = lanes[first].instance;
      const SceneInstance& inst = instances_[k];
      served.clear();
      object_rays.clear();
      for (size_t r = first; r < n; ++r)
        if (lanes[r].waiting && lanes[r].instance == k) {
          served.push_back(uint32_t(r));
          object_rays.push_back(to_object(inst, rays[g + r], lanes[r].walk.tmax));
        }
      const Structure& s = *meshes_[inst.instance.mesh].structure;
      const size_t m = served.size();
      if constexpr (kCount) object_counts.assign(m, TraversalStats{});
      if constexpr (kClosest) {
        object_hits.resize(m);
        if constexpr (kCount) s.closest_batch_counted(object_rays, object_hits, object_counts);
        else s.closest_batch(object_rays, object_hits);
      } else {
        object_found.resize(m);
        if constexpr (kCount) s.any_batch_counted(object_rays, object_found, object_counts);
        else s.any_batch(object_rays, object_found);
      }
      for (size_t j = 0; j < m; ++j) {
        Lane& lane = lanes[served[j]];
        auto record = record_of(g + served[j]);
        if constexpr (kCount) add_instance_work(record, object_counts[j], lane.entered);
        if constexpr (kClosest) {
          take_instance_hit(lane.best, object_hits[j], object_hits[j].valid(), k);
          lane.walk.tmax = lane.best.t;
        } else {
          lane.found = object_found[j] != 0;
          if (lane.found) lane.walk.tmax = -kInfinity;
        }
        lane.waiting = next_instance(lane.walk, record, lane.instance);
      }
    }
    for (size_t r = 0; r < n; ++r) {
      const Lane& lane = lanes[r];
      auto record = record_of(g + r);
      if (!lane.entered) record.ignored();
      if constexpr (kClosest) hits[g + r] = lane.best.valid() ? lane.best : Hit{};
      else occluded[g + r] = lane.found;
    }
  }
}

void SceneSnapshot::closest_batch(std::span<const Ray> rays, std::span<Hit> hits,
                                  std::span<TraversalStats> per_ray) const {
  if (hits.size() != rays.size()) throw std::invalid_argument("hits and rays differ in length");
  if (per_ray.empty()) return trace_batch<true, false>(rays, hits.data(), nullptr, nullptr);
  if (per_ray.size() != rays.size()) throw std::invalid_argument("per_ray and rays differ in length");
  trace_batch<true, true>(rays, hits.data(), nullptr, per_ray.data());
}

void SceneSnapshot::any_batch(std::span<const Ray> rays, std::span<uint8_t> occluded,
                              std::span<TraversalStats> per_ray) const {
  if (occluded.size() != rays.size()) throw std::invalid_argument("occluded and rays differ in length");
  if (per_ray.empty()) return trace_batch<false, false>(rays, nullptr, occluded.data(), nullptr);
  if (per_ray.size() != rays.size()) throw std::invalid_argument("per_ray and rays differ in length");
  trace_batch<false, true>(rays, nullptr, occluded.data(), per_ray.data());
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
