#include "octree.h"

#include "triangle_box_overlap.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <array>
#include <atomic>
#include <bit>
#include <cassert>
#include <cstdlib>
#include <limits>
#include <memory>
#include <new>
#include <numeric>

namespace raylab {

namespace {

// A node of the level being built: its box and the start of its run in the level's array of
// triangle references (the runs of a level follow each other in node order, so the next node's start
// ends it). The node's index is the level's first node index plus its position in the level.
struct PendingNode {
  glm::vec3 lo, hi;
  uint32_t first;
};

// Where a node's output goes, filled in two steps: first what it produces (children, references for
// its children, references of its own if it is a leaf), then, by a running sum, where they start.
struct Placement {
  uint32_t children;
  uint32_t child_refs;
  uint32_t leaf_refs;
};

// A working array whose elements are all written before they are read. It is allocated without
// initialisation (at the deep levels of a big tree, zeroing would cost as much as the filling) and
// keeps its memory when it shrinks, so that two of them can swap roles level after level. Large
// arrays ask Linux for transparent huge pages, as Embree's builders do: the deep levels of a big
// octree write hundreds of megabytes once each, and with 4 KiB pages page faults and TLB misses
// took a large share of the build time (docs/bench/history.md).
template <class T>
class WorkArray {
 public:
  void resize(size_t n) {
    if (n > capacity_) {
      constexpr size_t kHugePage = size_t(2) << 20;
      const size_t bytes =
          n * sizeof(T) < kHugePage ? n * sizeof(T) : (n * sizeof(T) + kHugePage - 1) & ~(kHugePage - 1);
      data_.reset();
      data_.reset(static_cast<T*>(allocate_huge(bytes)));
      capacity_ = bytes / sizeof(T);
    }
    size_ = n;
  }
  size_t size() const { return size_; }
  size_t bytes() const { return capacity_ * sizeof(T); }
  T& operator[](size_t i) { return data_[i]; }
  const T& operator[](size_t i) const { return data_[i]; }
  T* begin() { return data_.get(); }
  T* end() { return data_.get() + size_; }

 private:
  HugeArray<T> data_;
  size_t size_ = 0, capacity_ = 0;
};

template <class T>
size_t bytes_of(const std::vector<T>& v) {
  return v.capacity() * sizeof(T);
}
template <class T>
size_t bytes_of(const WorkArray<T>& v) {
  return v.bytes();
}

void check_budget(size_t needed, size_t budget) {
  if (needed > budget)
    throw BuildError("octree build would need more than " + std::to_string(budget) +
                     " bytes (memory budget); lower max_depth or raise leaf_size");
}

// The mesh's bounding box grown to a cube about the same centre.
Bounds root_cube(const Bounds& mesh_bounds) {
  const glm::vec3 c = mesh_bounds.center();
  const glm::vec3 e = mesh_bounds.extent();
  // A mesh that is a single point still needs a box with a volume to split.
  const float tiny = 1e-6f * std::max({1.0f, std::abs(c.x), std::abs(c.y), std::abs(c.z)});
  const float side = std::max({e.x, e.y, e.z, tiny});
  Bounds cube(c - 0.5f * side, c + 0.5f * side);
  cube.extend(mesh_bounds);  // rounding of c +- side/2 must not cut off a vertex
  return cube;
}

uint32_t overlapped_octants(const TriangleMesh& mesh, uint32_t triangle, const Bounds& box) {
  return triangle_octant_overlaps(box, box.center(), mesh.vertex(triangle, 0), mesh.vertex(triangle, 1),
                                  mesh.vertex(triangle, 2));
}

// The build classifies every reference at every level from the octree's corner rows (CornerRows):
// reading them through the index array from the mesh's shared vertices cost two dependent cache
// misses per reference (a large share of a deep build: docs/bench/history.md).
uint32_t overlapped_octants(const CornerRows& t, const Bounds& box) {
  return triangle_octant_overlaps(box, box.center(), t.corner(0), t.corner(1), t.corner(2));
}

// What a sample of subtrees holds at each depth, counted without building them (the size estimate in
// Octree::build). `final_bytes` sums the finished tree's nodes and leaf references; counting stops
// once it passes `cap`.
struct SubtreeCounts {
  static constexpr int kDepths = Octree::kMaxDepth + 2;
  std::array<std::atomic<size_t>, kDepths> nodes{}, refs{}, leaf_refs{};
  std::atomic<size_t> final_bytes{0};
  size_t cap = 0;

  bool over_cap() const { return final_bytes.load(std::memory_order_relaxed) > cap; }
};

void count_subtree(const TriangleMesh& mesh, int max_depth, int leaf_size, const Bounds& box,
                   std::vector<uint32_t> triangles, int depth, SubtreeCounts& counts) {
  if (counts.over_cap()) return;
  const bool splits = depth < max_depth && triangles.size() > size_t(leaf_size);
  counts.nodes[depth] += 1;
  counts.refs[depth] += triangles.size();
  if (!splits) {
    counts.leaf_refs[depth] += triangles.size();
    counts.final_bytes += sizeof(OctreeNode) + triangles.size() * sizeof(uint32_t);
    return;
  }
  counts.final_bytes += sizeof(OctreeNode);
  std::array<std::vector<uint32_t>, 8> children;
  for (uint32_t t : triangles)
    for (uint32_t m = overlapped_octants(mesh, t, box); m != 0; m &= m - 1) children[std::countr_zero(m)].push_back(t);
  triangles = {};  // give the memory back before going deeper
  for (int octant = 0; octant < 8; ++octant)
    if (!children[octant].empty())
      count_subtree(mesh, max_depth, leaf_size, octant_bounds(box, octant), std::move(children[octant]), depth + 1,
                    counts);
}

}  // namespace

Octree::Octree(MeshPtr mesh, const BuildSettings& settings, int leaf_lanes) : StructureBase(std::move(mesh), settings) {
  if (leaf_lanes == 8 && !cpu_has_avx2()) throw std::invalid_argument("octree: 8 leaf lanes need a CPU with AVX2");
  if (leaf_lanes != 0 && leaf_lanes != 4 && leaf_lanes != 8)
    throw std::invalid_argument("octree: leaf_lanes must be 0, 4 or 8");
  leaf_lanes_ = leaf_lanes != 0 ? leaf_lanes : cpu_has_avx2() ? 8 : 4;
  // The traversal stack is sized for kMaxDepth, BuildSettings::validate()'s limit (build_structure checked it).
  assert(settings.max_depth <= kMaxDepth);
  automatic_depth_ = settings.max_depth == BuildSettings::kAutoDepth;
  max_depth_ = automatic_depth_ ? auto_max_depth(mesh_->triangle_count(), settings.leaf_size) : settings.max_depth;
  if (mesh_->triangle_count() == 0) return;
  root_ = root_cube(mesh_->bounds());
  build();
}

// A surface's triangles spread over about 4^d of the 8^d octants at depth d, so about
// log4(triangles / leaf_size) levels bring the average leaf down to leaf_size; kAutoDepthMargin more
// let the dense parts of a mesh split further. Nodes stop splitting at leaf_size anyway: the cap only
// matters where triangles crowd a point (a fan around one vertex splits into the same triangles
// level after level).
int Octree::auto_max_depth(size_t triangle_count, int leaf_size) {
  int depth = 0;
  for (double held = double(std::max(leaf_size, 1)); held < double(triangle_count) && depth < kMaxDepth; held *= 4.0)
    ++depth;
  return std::min(depth + kAutoDepthMargin, kMaxDepth);
}

// Level by level: the nodes of a level are classified in parallel, placed by a running sum in level
// order and filled in parallel, so the tree is the same on every run and the children of a node are
// next to each other. Before anything is allocated, the bytes the build would then hold (the
// finished part, the working arrays of this level and the next, and the old copy of an array while
// it grows) are checked against the budget; while a level is classified, the references it creates
// are counted as they are found, so a tree far over the budget stops early. With max_depth auto,
// the level that would pass the budget becomes the last one (its nodes leaves) instead.
void Octree::build() {
  const TriangleMesh& mesh = *mesh_;
  const size_t budget = settings_.memory_budget;
  const uint32_t n = uint32_t(mesh.triangle_count());
  // Per new node: the node itself and its pending entry; per new reference: its slot.
  constexpr size_t kNodeBytes = sizeof(OctreeNode) + sizeof(PendingNode), kRefBytes = sizeof(uint32_t);
  // The size estimate: subtrees sampled at the first level with this many nodes, while at least
  // this many levels remain (with fewer, the build itself is cheap).
  constexpr size_t kEstimateLevelNodes = 1024, kEstimateSamples = 64;
  constexpr int kEstimateDepthsLeft = 3;
  constexpr double kEstimateMargin = 1.125;  // refuse only an estimate this far over the budget
  constexpr size_t kPrefetchAhead = 8;       // references

  check_budget(kNodeBytes + n * (kRefBytes + sizeof(CornerRows)), budget);
  corners_ = make_huge_array<CornerRows>(n);
  CornerRows* const corners = corners_.get();
  const size_t corner_bytes = n * sizeof(CornerRows);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 4096), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t t = r.begin(); t != r.end(); ++t) {
      CornerRows& rows = corners[t];
      for (int c = 0; c < 3; ++c) {
        const glm::vec3 p = mesh.vertex(t, c);
        rows.p[c][0] = p.x, rows.p[c][1] = p.y, rows.p[c][2] = p.z, rows.p[c][3] = 0.0f;
      }
    }
  });
  nodes_.assign(1, OctreeNode{});
  // This level's nodes and triangle references (run after run), and the next level's.
  WorkArray<PendingNode> level, next_level;
  WorkArray<uint32_t> refs, next;
  level.resize(1);
  level[0] = {root_.lo, root_.hi, 0};
  refs.resize(n);
  std::iota(refs.begin(), refs.end(), 0u);
  WorkArray<uint8_t> octants;  // per reference of a splitting node: the octants it goes to
  WorkArray<Placement> placement;

  bool estimated = false;
  for (int depth = 0; level.size() > 0; ++depth) {
    const size_t level_base = nodes_.size() - level.size();  // node index of level[0]
    auto run_end = [&](size_t j) { return j + 1 < level.size() ? size_t(level[j + 1].first) : refs.size(); };

    // Before the deep levels, where a tree far over the budget spends its time: what the build would
    // hold at its peak, estimated from a systematic sample of this level's subtrees, counted without
    // building them, so that a build far over the budget is refused early (docs/bench/history.md).
    // Where the sample's finished tree alone is over the budget, counting stops
    // early: that decision does not depend on thread timing.
    // With max_depth auto the build never refuses: the checks below end it at the last level that fits.
    if (!estimated && !automatic_depth_ && level.size() >= kEstimateLevelNodes &&
        depth + kEstimateDepthsLeft <= max_depth_) {
      estimated = true;
      const double scale = double(level.size()) / double(kEstimateSamples);
      const size_t finished = level_base * sizeof(OctreeNode) + triangles_.size() * kRefBytes;
      SubtreeCounts counts;
      const double limit = double(budget) * kEstimateMargin;
      const double held_throughout = double(finished + corner_bytes);
      counts.cap = held_throughout < limit ? size_t((limit - held_throughout) / scale) : 0;
      tbb::parallel_for(size_t(0), kEstimateSamples, [&](size_t i) {
        const size_t j = (2 * i + 1) * level.size() / (2 * kEstimateSamples);
        count_subtree(mesh, max_depth_, settings_.leaf_size, Bounds(level[j].lo, level[j].hi),
                      std::vector<uint32_t>(refs.begin() + level[j].first, refs.begin() + run_end(j)), depth, counts);
      });
      // The build's largest moment, level by level as in the checks below: the finished arrays while
      // they grow (old and new copy), the references of a level (with their octant bytes) and of the
      // next, and both levels' pending nodes. It comes close to the largest check below
      // (docs/bench/history.md); it refuses only past kEstimateMargin, so that the
      // sample's error does not refuse a build the checks would let through.
      double peak = counts.over_cap() ? limit + 1.0 : 0.0;
      double done = double(finished) + scale * double(counts.nodes[depth] * sizeof(OctreeNode));
      for (int d = depth; d + 1 < SubtreeCounts::kDepths && !counts.over_cap(); ++d) {
        const double before = done;
        done += scale * double(counts.nodes[d + 1] * sizeof(OctreeNode) + counts.leaf_refs[d] * kRefBytes);
        // The working arrays swap roles level after level and keep their capacity, so the previous
        // level's are still held while the next level's are counted.
        const size_t previous_refs = d > depth ? counts.refs[d - 1].load() : 0;
        const size_t previous_nodes = d > depth ? counts.nodes[d - 1].load() : 0;
        const double working =
            scale * double(counts.refs[d] * (kRefBytes + 1) + (previous_refs + counts.refs[d + 1]) * kRefBytes +
                           (previous_nodes + counts.nodes[d] + counts.nodes[d + 1]) * sizeof(PendingNode) +
                           counts.nodes[d] * sizeof(Placement));
        peak = std::max(peak, before + done + working + double(corner_bytes));
      }
      if (peak > limit)
        throw BuildError("octree build would need more than " + std::to_string(budget) +
                         " bytes (memory budget), estimated before building from " + std::to_string(kEstimateSamples) +
                         " of the " + std::to_string(level.size()) + " nodes at depth " + std::to_string(depth) +
                         "; lower max_depth or raise leaf_size");
    }
    // max_depth auto: set when splitting this level would pass the budget; its nodes become leaves.
    bool last_level = false;
    auto splits = [&](size_t j) {
      return !last_level && depth < max_depth_ && run_end(j) - level[j].first > size_t(settings_.leaf_size);
    };
    // Whether `needed` bytes fit the budget; over it, a fixed depth refuses the build.
    auto fits = [&](size_t needed) {
      if (needed <= budget) return true;
      if (!automatic_depth_) check_budget(needed, budget);
      return false;
    };
    auto held = [&] {
      return bytes_of(nodes_) + bytes_of(triangles_) + level.bytes() + next_level.bytes() + refs.bytes() +
             next.bytes() + octants.bytes() + placement.bytes() + corner_bytes;
    };

    // 1. Classify: the octants every triangle of a splitting node overlaps, and what each node
    // will produce.
    if (!fits(held() + refs.size() + level.size() * sizeof(Placement))) last_level = true;
    if (!last_level) octants.resize(refs.size());
    placement.resize(level.size());
    // While they grow, the finished arrays need a second copy of what they already hold.
    const size_t held_while_classifying = held() + nodes_.size() * sizeof(OctreeNode) + triangles_.size() * kRefBytes;
    std::atomic<size_t> produced{0};
    std::atomic<bool> over_budget{false};  // auto only: stop classifying, this level ends the tree
    auto classify_level = [&] {
      tbb::parallel_for(size_t(0), level.size(), [&](size_t j) {
        const size_t first = level[j].first, end = run_end(j);
        Placement& place = placement[j];
        place = {0, 0, 0};
        if (!splits(j) || over_budget.load(std::memory_order_relaxed)) {
          place.leaf_refs = uint32_t(end - first);
          return;
        }
        const Bounds box(level[j].lo, level[j].hi);
        // The corners of a reference a few ahead (in the level's array, past this node's run too: the
        // next node is most often this thread's) are loaded while this one is classified. They lie
        // scattered, and the wait for them was two thirds of triangle_octant_overlaps' samples.
        auto classify = [&](size_t k) {
          if (k + kPrefetchAhead < refs.size()) {
            const char* ahead = reinterpret_cast<const char*>(&corners[refs[k + kPrefetchAhead]]);
            __builtin_prefetch(ahead);
            __builtin_prefetch(ahead + sizeof(CornerRows) - 1);
          }
          octants[k] = uint8_t(overlapped_octants(corners[refs[k]], box));
        };
        if (end - first > 4096) {
          tbb::parallel_for(first, end, classify);
        } else {
          for (size_t k = first; k != end; ++k) classify(k);
        }
        uint32_t mask = 0;
        for (size_t k = first; k != end; ++k) {
          mask |= octants[k];
          place.child_refs += uint32_t(std::popcount(octants[k]));
        }
        place.children = uint32_t(std::popcount(mask));
        const size_t bytes = place.children * kNodeBytes + place.child_refs * kRefBytes;
        if (!fits(held_while_classifying + produced.fetch_add(bytes) + bytes)) over_budget = true;
      });
    };
    classify_level();
    if (over_budget) {
      last_level = true;
      classify_level();  // now every node is a leaf
    }

    // 2. Place, in level order: children get consecutive node indices, leaves consecutive runs.
    // Returns the bytes the build then holds, or SIZE_MAX past the 32-bit indices.
    size_t new_nodes = 0, next_refs = 0, leaf_refs = 0;
    auto place_level = [&]() -> size_t {
      new_nodes = 0, next_refs = 0, leaf_refs = triangles_.size();
      bool overflow = false;
      for (Placement& place : placement) {
        const Placement counts = place;
        place = {uint32_t(nodes_.size() + new_nodes), uint32_t(next_refs), uint32_t(leaf_refs)};
        new_nodes += counts.children;
        next_refs += counts.child_refs;
        leaf_refs += counts.leaf_refs;
        overflow |= nodes_.size() + new_nodes > OctreeNode::kLeaf || next_refs > 0xffffffffu || leaf_refs > 0xffffffffu;
      }
      if (overflow) return std::numeric_limits<size_t>::max();
      // The growing arrays hold their old copy while they move.
      return held() + (nodes_.size() + new_nodes) * sizeof(OctreeNode) + leaf_refs * kRefBytes +
             (new_nodes * sizeof(PendingNode) > next_level.bytes() ? new_nodes * sizeof(PendingNode) : 0) +
             (next_refs * kRefBytes > next.bytes() ? next_refs * kRefBytes : 0);
    };
    size_t needed = place_level();
    if (needed > budget && automatic_depth_ && !last_level) {
      last_level = true;
      classify_level();
      needed = place_level();
    }
    if (needed == std::numeric_limits<size_t>::max())
      throw BuildError(
          "octree build would need more than 2^31 nodes or 2^32 triangle references; "
          "lower max_depth or raise leaf_size");
    check_budget(needed, budget);
    if (last_level) max_depth_ = depth;  // auto: the budget chose this depth
    // Exact reservations: growing by doubling would hold up to twice the finished tree.
    nodes_.reserve(nodes_.size() + new_nodes);
    nodes_.resize(nodes_.size() + new_nodes);
    triangles_.reserve(leaf_refs);
    triangles_.resize(leaf_refs);
    next_level.resize(new_nodes);
    next.resize(next_refs);
    const size_t next_level_base = nodes_.size() - new_nodes;

    // 3. Fill: leaves copy their run; splitting nodes hand each triangle to its octants in
    // ascending order, so every run stays sorted.
    tbb::parallel_for(size_t(0), level.size(), [&](size_t j) {
      const size_t first = level[j].first, end = run_end(j);
      const Placement& place = placement[j];
      OctreeNode& node = nodes_[level_base + j];
      if (!splits(j)) {
        node = {place.leaf_refs, OctreeNode::kLeaf | uint32_t(end - first)};
        std::copy(refs.begin() + first, refs.begin() + end, triangles_.begin() + ptrdiff_t(place.leaf_refs));
        return;
      }
      std::array<uint32_t, 8> cursor{};
      for (size_t k = first; k != end; ++k)
        for (uint32_t m = octants[k]; m != 0; m &= m - 1) ++cursor[std::countr_zero(m)];
      node = {place.children, 0};
      const Bounds box(level[j].lo, level[j].hi);
      uint32_t start = place.child_refs;
      for (int octant = 0; octant < 8; ++octant) {
        if (cursor[octant] == 0) continue;
        const Bounds child = octant_bounds(box, octant);
        next_level[node.first + uint32_t(std::popcount(node.bits)) - next_level_base] = {child.lo, child.hi, start};
        node.bits |= 1u << octant;
        const uint32_t count = cursor[octant];
        cursor[octant] = start;  // from now on: where the octant's next reference goes
        start += count;
      }
      for (size_t k = first; k != end; ++k)
        for (uint32_t m = octants[k]; m != 0; m &= m - 1) next[cursor[std::countr_zero(m)]++] = refs[k];
    });
    std::swap(level, next_level);
    std::swap(refs, next);
  }
}

std::vector<BoxInfo> Octree::boxes() const {
  if (nodes_.empty()) return {};
  std::vector<BoxInfo> out(nodes_.size());
  out[0] = {root_, 0, nodes_[0].leaf(), 0};
  // Breadth-first order: a parent's box is known before its children's.
  for (uint32_t i = 0; i < nodes_.size(); ++i) {
    const OctreeNode& node = nodes_[i];
    if (node.leaf()) {
      out[i].triangle_count = node.triangle_count();
      continue;
    }
    for (int octant = 0; octant < 8; ++octant)
      if ((node.child_mask() >> octant) & 1u) {
        const uint32_t c = node.child(octant);
        out[c] = {octant_bounds(out[i].bounds, octant), out[i].depth + 1, nodes_[c].leaf(), 0};
      }
  }
  // An inner node counts each triangle below it once, though it may sit in several of its leaves.
  // One depth-first walk: a leaf's triangle counts for each of its ancestors unless an earlier leaf
  // under that ancestor had it (counted_at[t][depth] names the last ancestor at that depth that
  // counted t; the walk finishes one subtree before the next). The ancestors are visited deepest
  // first: where one has already counted t, so have all above it (the earlier leaf lay under them
  // too), and the rest are skipped. A triangle's entries share a cache line. Walking each inner
  // node's subtree again instead was too slow for a deep octree (docs/bench/history.md).
  int deepest = 0;
  for (const BoxInfo& b : out) deepest = std::max(deepest, b.depth);
  const size_t n_triangles = mesh_->triangle_count();
  std::vector<uint32_t> counted_at(size_t(deepest) * n_triangles, kInvalidIndex);
  uint32_t path[BuildSettings::kMaxDepthLimit + 1];
  std::vector<uint32_t> stack{0};
  while (!stack.empty()) {
    const uint32_t i = stack.back();
    stack.pop_back();
    const OctreeNode& node = nodes_[i];
    const int depth = out[i].depth;
    path[depth] = i;
    if (!node.leaf()) {
      for (int octant = 8; octant-- > 0;)
        if ((node.child_mask() >> octant) & 1u) stack.push_back(node.child(octant));
      continue;
    }
    for (uint32_t t : leaf_triangles(i)) {
      uint32_t* last = counted_at.data() + size_t(t) * size_t(deepest);
      for (int d = depth; d-- > 0;) {
        if (last[d] == path[d]) break;
        last[d] = path[d];
        ++out[path[d]].triangle_count;
      }
    }
  }
  return out;
}

size_t Octree::memory_bytes() const {
  return bytes_of(nodes_) + bytes_of(triangles_) + mesh_->triangle_count() * sizeof(CornerRows);
}

std::unique_ptr<Structure> build_octree(MeshPtr mesh, const BuildSettings& settings) {
  return std::make_unique<Octree>(std::move(mesh), settings);
}

}  // namespace raylab
