// What a traversal reports about its work. Every structure writes one traversal template,
// parameterised by a recorder; the three recorders below give the three uses of that one code path:
//   NoRecord      the fast path: every call is empty and compiles away (counting off costs nothing);
//   StatsRecord   the counters (kCounters below: rays, rays ignored, box, triangle and node counts);
//   StoryRecord   the single-ray story the levels draw: every box, node and triangle in order.
#pragma once

#include "raylab/geometry.h"

#include <cstdint>
#include <string>
#include <vector>

namespace raylab {

struct TraversalStats {
  uint64_t rays = 0;
  uint64_t rays_ignored = 0;  // rays that missed the root box (or the object's AABB)
  uint64_t box_tests = 0;
  uint64_t triangle_tests = 0;
  uint64_t nodes_visited = 0;

  TraversalStats& operator+=(const TraversalStats& o);
};

// The counters, once. `+=`, the Scene's adding up of its instances' work, the Python dicts and the
// add-on's tables all go through this list (exported as _raylab.COUNTERS); a new counter is a field
// above, a row here and the recorder call that counts it.
struct CounterInfo {
  const char* name;  // the key in Python dicts
  uint64_t TraversalStats::*field;
  const char* label;        // for tables
  const char* description;  // for tooltips
  bool object_work;         // counted inside an object's structure (a Scene adds it up per instance)
};

inline constexpr CounterInfo kCounters[] = {
    {"rays", &TraversalStats::rays, "Rays", "Rays traced", false},
    {"rays_ignored", &TraversalStats::rays_ignored, "Rays ignored",
     "Rays that missed the root box (or every object's AABB) and tested no triangle", false},
    {"box_tests", &TraversalStats::box_tests, "Box tests", "Ray/box tests", true},
    {"triangle_tests", &TraversalStats::triangle_tests, "Triangle tests", "Ray/triangle tests", true},
    {"nodes_visited", &TraversalStats::nodes_visited, "Nodes visited", "Nodes the traversal entered", true},
};

inline TraversalStats& TraversalStats::operator+=(const TraversalStats& o) {
  for (const CounterInfo& c : kCounters) this->*c.field += o.*c.field;
  return *this;
}

// The recorder interface (duck-typed, resolved at compile time):
//   ray()                                   once per query
//   ignored()                               the ray missed the root box
//   box(node, bounds, depth, hit, t_entry)  one ray/box test
//   node(node, depth)                       a node entered (visited)
//   triangle(index, hit)                    one ray/triangle test
// kIds: whether it reads the ids it is given; a traversal whose ids cost work to find (the BVH's leaf
// ids, a search) passes 0 to a recorder that does not.
struct NoRecord {
  static constexpr bool kActive = false;
  static constexpr bool kIds = false;
  void ray() {}
  void ignored() {}
  void box(uint32_t, const Bounds&, int, bool, float) {}
  void node(uint32_t, int) {}
  void triangle(uint32_t, bool) {}
};

struct StatsRecord {
  static constexpr bool kActive = true;
  static constexpr bool kIds = false;  // counts only
  TraversalStats& stats;
  void ray() { ++stats.rays; }
  void ignored() { ++stats.rays_ignored; }
  void box(uint32_t, const Bounds&, int, bool, float) { ++stats.box_tests; }
  void node(uint32_t, int) { ++stats.nodes_visited; }
  void triangle(uint32_t, bool) { ++stats.triangle_tests; }
};

// What happened to one ray, in the four cases VRT's levels show.
enum class RayStatus {
  MissedRoot,       // ignored: missed the AABB / the root node; no triangle was tested
  MissedNodes,      // hit the root box but entered no node that holds triangles
  MissedTriangles,  // entered nodes holding triangles, tested them, hit none
  HitObject,        // hit a triangle of the object
};

// The names, in the enum's order (rising priority: over several objects the highest one is the ray's).
inline constexpr const char* kRayStatusNames[] = {"missed_root", "missed_nodes", "missed_triangles", "hit_object"};
inline const char* ray_status_name(RayStatus status) { return kRayStatusNames[int(status)]; }

// A ray's status from what its one query did: the story and the batch statuses derive it alike.
inline RayStatus ray_status(bool hit, bool ignored, bool tested_triangles) {
  if (hit) return RayStatus::HitObject;
  if (ignored) return RayStatus::MissedRoot;
  return tested_triangles ? RayStatus::MissedTriangles : RayStatus::MissedNodes;
}

struct StoryBox {
  uint32_t node;
  Bounds bounds;
  int depth;
  bool hit;
  float t_entry;  // meaningful when hit
};

struct StoryNode {
  uint32_t node;
  int depth;
};

struct StoryTriangle {
  uint32_t triangle;
  bool hit;
};

struct RayStory {
  Ray ray;
  std::vector<StoryBox> boxes;           // in test order
  std::vector<StoryNode> nodes;          // in visit order
  std::vector<StoryTriangle> triangles;  // in test order
  Hit hit;
  TraversalStats stats;
  RayStatus status = RayStatus::MissedRoot;
  bool ignored = false;

  // Derives the status from what was recorded: the story, not a second computation.
  void finish() { status = ray_status(hit.valid(), ignored, !triangles.empty()); }
};

// Counts through StatsRecord (a new counter is counted in one place) and keeps every event in order.
struct StoryRecord {
  static constexpr bool kActive = true;
  static constexpr bool kIds = true;
  RayStory& story;
  void ray() { StatsRecord{story.stats}.ray(); }
  void ignored() {
    StatsRecord{story.stats}.ignored();
    story.ignored = true;
  }
  void box(uint32_t node, const Bounds& b, int depth, bool hit, float t_entry) {
    StatsRecord{story.stats}.box(node, b, depth, hit, t_entry);
    story.boxes.push_back({node, b, depth, hit, t_entry});
  }
  void node(uint32_t node, int depth) {
    StatsRecord{story.stats}.node(node, depth);
    story.nodes.push_back({node, depth});
  }
  void triangle(uint32_t index, bool hit) {
    StatsRecord{story.stats}.triangle(index, hit);
    story.triangles.push_back({index, hit});
  }
};

}  // namespace raylab
