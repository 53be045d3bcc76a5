// Many rays at once: the one parallel loop behind every batch query (structures and scenes).
#pragma once

#include "raylab/traversal_record.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <cstddef>
#include <stdexcept>

namespace raylab {

// Runs `query(i, stats_or_null)` for every ray index in parallel (TBB), on at most `threads` threads
// (0: all cores), as the renderer's RenderSettings::threads. With `stats`, each thread counts into its
// own TraversalStats and the totals are added to *stats at the end. Every ray's answer is the same
// on any number of threads: only the split of the work changes.
template <class Query>
void for_each_ray(size_t n, int threads, TraversalStats* stats, Query query) {
  const auto run = [&] {
    if (!stats) {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 256), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i != r.end(); ++i) query(i, nullptr);
      });
      return;
    }
    tbb::combinable<TraversalStats> local;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 256), [&](const tbb::blocked_range<size_t>& r) {
      TraversalStats& s = local.local();
      for (size_t i = r.begin(); i != r.end(); ++i) query(i, &s);
    });
    local.combine_each([&](const TraversalStats& s) { *stats += s; });
  };
  if (threads < 0) throw std::invalid_argument("threads must be >= 0 (0: all cores)");
  if (threads > 0) {
    tbb::task_arena arena(threads);
    arena.execute(run);
  } else {
    run();
  }
}

}  // namespace raylab
