// Embree (3 on Debian 12, 4 on Debian 13) on the same mesh and the same rays as raylab: the reference of the README's
// "Benchmarks" (see ARCHITECTURE.md for the parts) and the hit oracle of the benchmark. raylab's own structures never
// call it.
#pragma once

#include "raylab/geometry.h"

// CMake defines RAYLAB_EMBREE_MAJOR from the Embree it found; the two differ only in the query calls.
#if RAYLAB_EMBREE_MAJOR >= 4
#include <embree4/rtcore.h>
#else
#include <embree3/rtcore.h>
#endif

#include <atomic>
#include <cstdint>
#include <span>
#include <vector>

namespace raylab::bench {

class EmbreeTracer {
 public:
  explicit EmbreeTracer(const TriangleMesh& mesh);
  ~EmbreeTracer();
  EmbreeTracer(const EmbreeTracer&) = delete;
  EmbreeTracer& operator=(const EmbreeTracer&) = delete;

  // Builds a new scene (RTC_SCENE_FLAG_NONE) with the given quality, replacing the previous one;
  // returns the seconds rtcCommitScene took. The threads Embree builds on are TBB's, so a
  // tbb::global_control around the call limits them.
  double build(RTCBuildQuality quality);
  size_t memory_bytes() const { return scene_bytes_; }  // what the last build allocated, net

  // rtcIntersect1 / rtcOccluded1 over the rays, parallel over TBB threads.
  void closest(std::span<const Ray> rays, std::span<Hit> hits) const;
  void any(std::span<const Ray> rays, std::span<uint8_t> occluded) const;

  // Embree's packet API: rtcIntersect8 / rtcOccluded8 over each run of 8 consecutive rays (the last
  // run's missing lanes masked off), marked coherent (RTC_INTERSECT_CONTEXT_FLAG_COHERENT, Embree 4's
  // RTC_RAY_QUERY_FLAG_COHERENT), parallel over TBB threads in whole runs: what a renderer that hands
  // Embree its camera rays 8 at a time gets. The same scene as closest / any.
  void closest_packets(std::span<const Ray> rays, std::span<Hit> hits) const;
  void any_packets(std::span<const Ray> rays, std::span<uint8_t> occluded) const;

 private:
  static bool monitor(void* self, ssize_t bytes, bool post);

  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  // Embree reads vertices with 16-byte loads: the buffer must stay readable 16 bytes past the last
  // vertex, hence a padded copy rather than the mesh's own vector.
  std::vector<float> padded_vertices_;
  const TriangleMesh& mesh_;
  std::atomic<int64_t> allocated_{0};
  size_t scene_bytes_ = 0;
};

}  // namespace raylab::bench
