// Many rays at once: the one parallel loop behind every batch query (structures and scenes).
#pragma once

#include "raylab/traversal_record.h"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <cstddef>

namespace raylab {

// Runs `query(i, stats_or_null)` for every ray index in parallel (TBB). With `stats`, each thread
// counts into its own TraversalStats and the totals are added to *stats at the end.
template <class Query>
void for_each_ray(size_t n, TraversalStats* stats, Query query) {
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
}

}  // namespace raylab
