// How many threads a batch query or a render runs on (threads.h): 0 for all cores, more than the
// machine's cores clamped to them, negative refused.
#include "batch.h"
#include "threads.h"

#include <gtest/gtest.h>
#include <tbb/info.h>

#include <atomic>
#include <limits>
#include <stdexcept>

using namespace raylab;

TEST(Threads, ZeroAndMoreThanTheCoresMeanAllCores) {
  const int cores = tbb::info::default_concurrency();
  EXPECT_EQ(thread_count(0), cores);
  EXPECT_EQ(thread_count(1), 1);
  EXPECT_EQ(thread_count(cores), cores);
  EXPECT_EQ(thread_count(65537), cores);
  EXPECT_EQ(thread_count(std::numeric_limits<int>::max()), cores);
  EXPECT_THROW(thread_count(-1), std::invalid_argument);
}

TEST(Threads, AQueryOnFarMoreThreadsThanTbbCanHoldVisitsEveryRayOnce) {
  // An arena of more than 65536 slots terminated the process.
  for (const int threads : {65537, std::numeric_limits<int>::max()}) {
    std::vector<std::atomic<int>> visits(10000);
    for_each_ray(visits.size(), threads, nullptr, [&](size_t i, TraversalStats*) { visits[i].fetch_add(1); });
    for (const auto& v : visits) ASSERT_EQ(v.load(), 1);
  }
}
