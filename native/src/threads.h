// How many threads a parallel loop runs on: one rule for every batch query and every render.
#pragma once

#include <tbb/info.h>
#include <tbb/task_arena.h>

#include <stdexcept>
#include <string>

namespace raylab {

// `threads` as a caller gives it: 0 for all cores, else at most that many. More than the machine's
// cores (its affinity mask) are clamped to the cores: more would only wait, and a TBB arena of more
// than 65536 slots terminates the process.
inline int thread_count(int threads) {
  if (threads < 0) throw std::invalid_argument("threads must be >= 0 (0: all cores), got " + std::to_string(threads));
  const int cores = tbb::info::default_concurrency();
  return threads == 0 || threads > cores ? cores : threads;
}

// Runs `work` (which starts TBB loops) on at most thread_count(threads) threads.
template <class Work>
void run_on_threads(int threads, const Work& work) {
  const int n = thread_count(threads);
  if (n == tbb::info::default_concurrency()) {
    work();
    return;
  }
  tbb::task_arena arena(n);
  arena.execute(work);
}

}  // namespace raylab
