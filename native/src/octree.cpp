#include "raylab/octree.h"

#include "raylab/triangle_box_overlap.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <array>
#include <atomic>
#include <bit>
#include <numeric>

namespace raylab {

namespace {

// A node of the level being built: its box and the start of its run in the level's array of
// triangle references (the runs of a level follow each other in node order, so the next node's start
// ends it). The node's index is the level's first node index plus its position in the level.
struct PendingNode {
  Bounds box;
  uint32_t first;
};

// Where a node's output goes, filled in two steps: first what it produces (children, references for
// its children, references of its own if it is a leaf), then, by a running sum, where they start.
struct Placement {
  uint32_t children = 0;
  uint32_t child_refs = 0;
  uint32_t leaf_refs = 0;
};

template <class T>
size_t bytes_of(const std::vector<T>& v) {
  return v.capacity() * sizeof(T);
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

}  // namespace

Octree::Octree(MeshPtr mesh, const BuildSettings& settings) : StructureBase(std::move(mesh), settings) {
  if (mesh_->triangle_count() == 0) return;
  root_ = root_cube(mesh_->bounds());
  const glm::vec3 e = root_.extent();
  root_side_ = std::max({e.x, e.y, e.z});
  build();
}

// Level by level: the nodes of a level are classified in parallel, placed by a running sum in level
// order and filled in parallel, so the tree is the same on every run and the children of a node are
// next to each other. Before anything is allocated, the bytes the build would then hold (the
// finished part, the working arrays of this level and the next, and the old copy of an array while
// it grows) are checked against the budget; while a level is classified, the references it creates
// are counted as they are found, so a tree far over the budget stops early.
void Octree::build() {
  const TriangleMesh& mesh = *mesh_;
  const size_t budget = settings_.memory_budget;
  const uint32_t n = uint32_t(mesh.triangle_count());
  // Per new node: the node itself and its pending entry; per new reference: its slot.
  constexpr size_t kNodeBytes = sizeof(OctreeNode) + sizeof(PendingNode), kRefBytes = sizeof(uint32_t);

  check_budget(kNodeBytes + n * kRefBytes, budget);
  nodes_.assign(1, OctreeNode{});
  std::vector<PendingNode> level{{root_, 0}};
  std::vector<uint32_t> refs(n);  // the level's triangle references, run after run
  std::iota(refs.begin(), refs.end(), 0u);
  std::vector<uint8_t> octants;   // per reference of a splitting node: the octants it goes to
  std::vector<Placement> placement;

  for (int depth = 0; !level.empty(); ++depth) {
    const size_t level_base = nodes_.size() - level.size();  // node index of level[0]
    auto run_end = [&](size_t j) { return j + 1 < level.size() ? size_t(level[j + 1].first) : refs.size(); };
    auto splits = [&](size_t j) {
      return depth < settings_.max_depth && run_end(j) - level[j].first > size_t(settings_.leaf_size);
    };

    // 1. Classify: the octants every triangle of a splitting node overlaps, and what each node
    // will produce.
    const size_t held = bytes_of(nodes_) + bytes_of(triangles_) + bytes_of(level) + bytes_of(refs);
    check_budget(held + refs.size() + level.size() * sizeof(Placement), budget);
    octants.resize(refs.size());
    placement.assign(level.size(), Placement{});
    std::atomic<size_t> produced{0};
    tbb::parallel_for(size_t(0), level.size(), [&](size_t j) {
      const size_t first = level[j].first, end = run_end(j);
      Placement& place = placement[j];
      if (!splits(j)) {
        place.leaf_refs = uint32_t(end - first);
        return;
      }
      auto classify = [&](size_t k) { octants[k] = uint8_t(overlapped_octants(mesh, refs[k], level[j].box)); };
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
      check_budget(held + bytes_of(octants) + bytes_of(placement) + produced.fetch_add(bytes) + bytes, budget);
    });

    // 2. Place, in level order: children get consecutive node indices, leaves consecutive runs.
    size_t new_nodes = 0, next_refs = 0, leaf_refs = triangles_.size();
    for (Placement& place : placement) {
      const Placement counts = place;
      place = {uint32_t(nodes_.size() + new_nodes), uint32_t(next_refs), uint32_t(leaf_refs)};
      new_nodes += counts.children;
      next_refs += counts.child_refs;
      leaf_refs += counts.leaf_refs;
      if (nodes_.size() + new_nodes > OctreeNode::kLeaf || next_refs > 0xffffffffu || leaf_refs > 0xffffffffu)
        throw BuildError("octree build would need more than 2^31 nodes or 2^32 triangle references; "
                         "lower max_depth or raise leaf_size");
    }
    check_budget(held + bytes_of(octants) + bytes_of(placement) + (nodes_.size() + new_nodes) * sizeof(OctreeNode) +
                     leaf_refs * kRefBytes + new_nodes * sizeof(PendingNode) + next_refs * kRefBytes,
                 budget);
    nodes_.resize(nodes_.size() + new_nodes);
    triangles_.resize(leaf_refs);
    std::vector<PendingNode> next_level(new_nodes);
    std::vector<uint32_t> next(next_refs);
    const size_t next_level_base = nodes_.size() - new_nodes;

    // 3. Fill: leaves copy their run; splitting nodes hand each triangle to its octants in
    // ascending order, so every run stays sorted.
    tbb::parallel_for(size_t(0), level.size(), [&](size_t j) {
      const size_t first = level[j].first, end = run_end(j);
      const Placement& place = placement[j];
      OctreeNode& node = nodes_[level_base + j];
      if (!splits(j)) {
        node = {place.leaf_refs, OctreeNode::kLeaf | uint32_t(end - first)};
        std::copy(refs.begin() + ptrdiff_t(first), refs.begin() + ptrdiff_t(end),
                  triangles_.begin() + ptrdiff_t(place.leaf_refs));
        return;
      }
      std::array<uint32_t, 8> cursor{};
      for (size_t k = first; k != end; ++k)
        for (uint32_t m = octants[k]; m != 0; m &= m - 1) ++cursor[std::countr_zero(m)];
      node = {place.children, 0};
      uint32_t start = place.child_refs;
      for (int octant = 0; octant < 8; ++octant) {
        if (cursor[octant] == 0) continue;
        next_level[node.first + uint32_t(std::popcount(node.bits)) - next_level_base] = {
            octant_bounds(level[j].box, octant), start};
        node.bits |= 1u << octant;
        const uint32_t count = cursor[octant];
        cursor[octant] = start;  // from now on: where the octant's next reference goes
        start += count;
      }
      for (size_t k = first; k != end; ++k)
        for (uint32_t m = octants[k]; m != 0; m &= m - 1) next[cursor[std::countr_zero(m)]++] = refs[k];
    });
    level = std::move(next_level);
    refs = std::move(next);
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
  std::vector<uint32_t> counted_for(mesh_->triangle_count(), kInvalidIndex);
  std::vector<uint32_t> stack;
  for (uint32_t i = 0; i < nodes_.size(); ++i) {
    if (nodes_[i].leaf()) continue;
    stack.assign(1, i);
    while (!stack.empty()) {
      const OctreeNode& node = nodes_[stack.back()];
      stack.pop_back();
      if (node.leaf()) {
        for (uint32_t t : leaf_triangles(uint32_t(&node - nodes_.data())))
          if (counted_for[t] != i) {
            counted_for[t] = i;
            ++out[i].triangle_count;
          }
        continue;
      }
      for (int octant = 0; octant < 8; ++octant)
        if ((node.child_mask() >> octant) & 1u) stack.push_back(node.child(octant));
    }
  }
  return out;
}

size_t Octree::memory_bytes() const { return bytes_of(nodes_) + bytes_of(triangles_); }

std::unique_ptr<Structure> build_octree(MeshPtr mesh, const BuildSettings& settings) {
  return std::make_unique<Octree>(std::move(mesh), settings);
}

}  // namespace raylab
