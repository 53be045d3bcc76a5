#include "raylab/ray_rows.h"

#include "batch.h"

#include <algorithm>
#include <atomic>
#include <cstring>
#include <new>
#include <span>

namespace raylab {

namespace {

uint32_t bits_of(const float* p) {
  uint32_t bits;
  std::memcpy(&bits, p, sizeof(bits));
  return bits;
}

// Whether any of n floats from p is NaN or infinite (an unsigned minimum: the loop vectorizes).
bool any_not_finite(const float* p, size_t n) {
  uint32_t least = ~0u;
  for (size_t k = 0; k < n; ++k) least = std::min(least, (bits_of(p + k) & 0x7f800000u) ^ 0x7f800000u);
  return least == 0;
}

// Whether any of `rows` rows of three floats from p is zero (+0 or -0 in each coordinate).
bool any_zero_row(const float* p, size_t rows) {
  uint32_t least = ~0u;
  for (size_t i = 0; i < rows; ++i)
    least = std::min(least, (bits_of(p + 3 * i) | bits_of(p + 3 * i + 1) | bits_of(p + 3 * i + 2)) & 0x7fffffffu);
  return least == 0;
}

// The first unusable ray, or rows.count.
size_t first_unusable(const RayRows& rows) {
  for (size_t i = 0; i < rows.count; ++i)
    if (!rows.usable(i)) return i;
  return rows.count;
}

// Runs `trace(first, rays)` on each chunk of at most kRayChunk rays, built from the rows on the
// tracing thread's stack. A chunk with an unusable ray is not traced, and the others stop once one is
// seen: the first unusable ray is then found again in order (an error costs a second pass).
template <class Trace>
size_t trace_rows(const RayRows& rows, int threads, Trace trace) {
  std::atomic<bool> refused{false};
  for_each_ray_range(rows.count, threads, [&](size_t begin, size_t end) {
    // A task's range may be longer than kRayChunk (TBB's auto partitioner): chunk by chunk.
    alignas(Ray) unsigned char storage[kRayChunk * sizeof(Ray)];  // every ray is written before it is read
    Ray* rays = reinterpret_cast<Ray*>(storage);
    for (size_t first = begin; first < end; first += kRayChunk) {
      if (refused.load(std::memory_order_relaxed)) return;
      const size_t last = std::min(end, first + kRayChunk);
      if (!rows.usable_range(first, last)) {
        refused.store(true, std::memory_order_relaxed);
        return;
      }
      for (size_t i = first; i != last; ++i) new (&rays[i - first]) Ray(rows.ray(i));
      trace(first, std::span<const Ray>(rays, last - first));
    }
  });
  return refused.load() ? first_unusable(rows) : rows.count;
}

template <class Target>
size_t closest_rows_of(const Target& target, const RayRows& rows, const HitColumns& out, int threads) {
  return trace_rows(rows, threads, [&](size_t first, std::span<const Ray> rays) {
    alignas(Hit) unsigned char storage[kRayChunk * sizeof(Hit)];  // the batch query writes every hit
    Hit* hits = reinterpret_cast<Hit*>(storage);
    target.closest_batch(rays, std::span<Hit>(hits, rays.size()));
    write_hits(out, first, std::span<const Hit>(hits, rays.size()));
  });
}

template <class Target>
size_t any_rows_of(const Target& target, const RayRows& rows, bool* occluded, int threads) {
  static_assert(sizeof(bool) == sizeof(uint8_t));
  return trace_rows(rows, threads, [&](size_t first, std::span<const Ray> rays) {
    uint8_t answers[kRayChunk];
    target.any_batch(rays, std::span<uint8_t>(answers, rays.size()));
    for (size_t k = 0; k < rays.size(); ++k) occluded[first + k] = answers[k] != 0;
  });
}

}  // namespace

bool RayRows::usable_range(size_t first, size_t last) const {
  const size_t n = last - first;
  const size_t origin_rows = origin_stride != 0 ? n : 1, direction_rows = direction_stride != 0 ? n : 1;
  return !any_not_finite(origin(first), 3 * origin_rows) && !any_not_finite(direction(first), 3 * direction_rows) &&
         !any_zero_row(direction(first), direction_rows);
}

void write_hits(const HitColumns& out, size_t first, std::span<const Hit> hits) {
  for (size_t k = 0; k < hits.size(); ++k) {
    const Hit& h = hits[k];
    const size_t i = first + k;
    const bool valid = h.valid();
    out.t[i] = valid ? h.t : kInfinity;
    out.u[i] = valid ? h.u : 0.0f;
    out.v[i] = valid ? h.v : 0.0f;
    out.triangle[i] = valid ? int32_t(h.triangle) : -1;
    out.instance[i] = !valid ? -1 : out.single_instance ? 0 : int32_t(h.instance);
    out.hit[i] = valid;
  }
}

size_t closest_rows(const Structure& s, const RayRows& rows, const HitColumns& out, int threads) {
  return closest_rows_of(s, rows, out, threads);
}
size_t closest_rows(const SceneSnapshot& scene, const RayRows& rows, const HitColumns& out, int threads) {
  return closest_rows_of(scene, rows, out, threads);
}
size_t any_rows(const Structure& s, const RayRows& rows, bool* occluded, int threads) {
  return any_rows_of(s, rows, occluded, threads);
}
size_t any_rows(const SceneSnapshot& scene, const RayRows& rows, bool* occluded, int threads) {
  return any_rows_of(scene, rows, occluded, threads);
}

}  // namespace raylab
