// Many rays at once: the one parallel loop behind every batch query (structures and scenes).
#pragma once

#include "raylab/traversal_record.h"
#include "threads.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>
// On Windows TBB's thread-local storage includes <windows.h>, whose `near` and `far` macros (16-bit
// pointer words, defined as nothing) would erase the SIMD code's variables of those names.
#ifdef _WIN32
#undef near
#undef far
#endif

#include <cstddef>
#include <span>
#include <stdexcept>

namespace raylab {

// The rays of one TBB task: batches are split into chunks of at most this many.
inline constexpr size_t kRayChunk = 256;

// Runs `run(begin, end)` on the chunks of [0, n) in parallel, on the calling thread's arena.
template <class Run>
void parallel_chunks(size_t n, Run run) {
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, kRayChunk),
                    [&](const tbb::blocked_range<size_t>& r) { run(r.begin(), r.end()); });
}

// Runs `query(i, stats_or_null)` for every ray index in parallel (TBB), on at most `threads` threads
// (thread_count's rule, as the renderer's RenderSettings::threads). With `stats`, each thread counts
// into its own TraversalStats and the totals are added to *stats at the end. With `per_ray` (one per ray, or
// empty for none), each ray counts into its own per_ray[i], and *stats (if given) gets their sum: the
// totals and each ray's counts are the same StatsRecord's. Every ray's answer is the same on any
// number of threads: only the split of the work changes.
template <class Query>
void for_each_ray(size_t n, int threads, TraversalStats* stats, Query query, std::span<TraversalStats> per_ray = {}) {
  if (!per_ray.empty() && per_ray.size() != n) throw std::invalid_argument("per_ray and rays differ in length");
  const auto run = [&] {
    if (!per_ray.empty()) {
      parallel_chunks(n, [&](size_t begin, size_t end) {
        for (size_t i = begin; i != end; ++i) {
          per_ray[i] = TraversalStats{};
          query(i, &per_ray[i]);
        }
      });
      if (stats)
        for (const TraversalStats& s : per_ray) *stats += s;
      return;
    }
    if (!stats) {
      parallel_chunks(n, [&](size_t begin, size_t end) {
        for (size_t i = begin; i != end; ++i) query(i, nullptr);
      });
      return;
    }
    tbb::combinable<TraversalStats> local;
    parallel_chunks(n, [&](size_t begin, size_t end) {
      TraversalStats& s = local.local();
      for (size_t i = begin; i != end; ++i) query(i, &s);
    });
    local.combine_each([&](const TraversalStats& s) { *stats += s; });
  };
  run_on_threads(threads, run);
}

// Runs `run(begin, end)` on for_each_ray's chunks of [0, n) in parallel, on at most `threads` threads:
// the uncounted batch queries, which trace a chunk's coherent groups together.
template <class Run>
void for_each_ray_range(size_t n, int threads, Run run) {
  run_on_threads(threads, [&] { parallel_chunks(n, run); });
}

// Closest hits and each ray's status, derived from that ray's own counters as its story would be
// (ray_status): `closest(ray, hit, own_stats)` is a structure's or a scene's counted query.
template <class Closest>
void statuses_of_rays(std::span<const Ray> rays, std::span<Hit> hits, std::span<RayStatus> statuses, int threads,
                      Closest closest) {
  if (hits.size() != rays.size() || statuses.size() != rays.size())
    throw std::invalid_argument("hits, statuses and rays differ in length");
  for_each_ray(rays.size(), threads, nullptr, [&](size_t i, TraversalStats*) {
    TraversalStats own;  // this ray's counters alone
    Hit h;
    const bool hit = closest(rays[i], h, own);
    hits[i] = h;
    statuses[i] = ray_status(hit, own.rays_ignored > 0, own.triangle_tests > 0);
  });
}

}  // namespace raylab
