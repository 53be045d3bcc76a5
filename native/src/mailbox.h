// Mailboxing (Amanatides and Woo 1987): a structure whose leaves share triangles (an octree node, a
// grid cell) would test a triangle that straddles several leaves once in each of them. A mailbox
// remembers which triangles this ray has already tested, so a repeat is skipped.
//
// Why skipping is exact. The leaf walks keep one search state for the whole ray (triangle_loop.h:
// the closest hit so far, wherever it lies, not only inside the current leaf), so a triangle hit
// beyond the leaf it was tested in stays the best candidate until something closer is found, and
// the walk goes on while a leaf's entry lies before it. A second test of the same triangle would
// give the same t, u and v (the test is a function of the ray and the triangle) against a limit
// that can only have shrunk, so it cannot change the result: a miss stays a miss, and a hit is
// already the best or lost to a closer (or equally close, lower-index) one.
//
// The state lives on the caller's stack, one mailbox per query, so any number of threads trace at
// once without locks. It is a small direct-mapped table (the hashed per-ray mailbox of Benthin's
// and Wald's theses, rather than one stamp per triangle in the mesh, which is not thread-safe and
// costs memory per triangle): a triangle evicted by a later one with the same slot is tested again
// if met again. That test is real and is counted, so the counters and the story stay true: a
// skipped repeat is no test. Consecutive indices take different slots, and a leaf's triangles are
// sorted, so neighbouring triangles (which share leaves) rarely evict each other.
#pragma once

#include "raylab/geometry.h"

#include <array>
#include <cstdint>

namespace raylab {

class Mailbox {
 public:
  // 32 slots (128 bytes to clear per query): a camera ray through a tree of small leaves tests a
  // few dozen triangles.
  static constexpr uint32_t kSlots = 32;

  Mailbox() { slots_.fill(kInvalidIndex); }

  // True when `triangle` is to be tested (and remembers it); false for a repeat this ray has
  // already tested.
  bool first_test(uint32_t triangle) {
    uint32_t& slot = slots_[triangle & (kSlots - 1)];
    if (slot == triangle) return false;
    slot = triangle;
    return true;
  }

 private:
  std::array<uint32_t, kSlots> slots_;
};

// For structures whose leaves never share a triangle (or to measure what mailboxing saves).
struct NoMailbox {
  static constexpr bool first_test(uint32_t) { return true; }
};

}  // namespace raylab
