#include "raylab/bvh.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <string>

namespace raylab {

namespace {

BinaryBvh build_over_triangles(const TriangleMesh& mesh, const BuildSettings& settings) {
  const size_t n = mesh.triangle_count();
  // The binary build, then the 4-wide copy (nodes and packets of at most about 2x the triangles).
  const size_t needed = n * sizeof(Bounds) + binary_bvh_build_bytes(n) + 2 * n * sizeof(TrianglePacket) / 4 +
                        n * sizeof(Bvh4Node) / 2;
  if (needed > settings.memory_budget)
    throw BuildError("bvh: building over " + std::to_string(n) + " triangles needs about " +
                     std::to_string(needed) + " bytes, over the memory budget of " +
                     std::to_string(settings.memory_budget));
  std::vector<Bounds> bounds(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i) bounds[i] = mesh.triangle_bounds(uint32_t(i));
  });
  return build_binary_bvh(bounds, uint32_t(settings.leaf_size), 4);  // leaves are tested in packets of four
}

Bvh4Node empty_node() {
  Bvh4Node node;
  for (int a = 0; a < 3; ++a)
    for (int i = 0; i < 4; ++i) node.lo[a][i] = node.hi[a][i] = 0.0f;  // masked out by child == kInvalidIndex
  for (int i = 0; i < 4; ++i) {
    node.child[i] = kInvalidIndex;
    node.count[i] = 0;
  }
  return node;
}

// Collapses a binary BVH into a 4-wide one: each wide node takes the binary node's children and
// keeps opening its largest inner child (by surface area, the likeliest to be entered) until it has
// four.
class Collapser {
 public:
  Collapser(const BinaryBvh& binary, const TriangleMesh& mesh, std::vector<Bvh4Node>& nodes,
            std::vector<TrianglePacket>& packets, std::vector<uint32_t>& leaf_packets)
      : binary_(binary), mesh_(mesh), nodes_(nodes), packets_(packets), leaf_packets_(leaf_packets) {}

  uint32_t collapse(uint32_t b) {
    uint32_t kids[4];
    int n = 0;
    const BvhNode& top = binary_.nodes[b];
    if (top.leaf()) {
      kids[n++] = b;  // a root that is a leaf: a wide root with one child
    } else {
      kids[n++] = top.index;
      kids[n++] = top.index + 1;
    }
    while (n < 4) {
      int open = -1;
      float largest = -1.0f;
      for (int i = 0; i < n; ++i) {
        const BvhNode& k = binary_.nodes[kids[i]];
        const float area = k.bounds().surface_area();
        if (!k.leaf() && area > largest) {
          largest = area;
          open = i;
        }
      }
      if (open < 0) break;
      const uint32_t first = binary_.nodes[kids[open]].index;
      for (int i = n; i > open + 1; --i) kids[i] = kids[i - 1];
      kids[open] = first;
      kids[open + 1] = first + 1;
      ++n;
    }
    const uint32_t w = uint32_t(nodes_.size());
    nodes_.push_back(empty_node());
    for (int i = 0; i < n; ++i) {
      const BvhNode& k = binary_.nodes[kids[i]];
      const uint32_t child = k.leaf() ? add_leaf(k) : collapse(kids[i]);
      Bvh4Node& node = nodes_[w];  // after the recursion: nodes_ may have moved
      for (int a = 0; a < 3; ++a) {
        node.lo[a][i] = k.lo[a];
        node.hi[a][i] = k.hi[a];
      }
      node.child[i] = child;
      node.count[i] = k.leaf() ? k.count : 0;
    }
    return w;
  }

 private:
  uint32_t add_leaf(const BvhNode& leaf) {
    const uint32_t first = uint32_t(packets_.size());
    leaf_packets_.push_back(first);
    for (uint32_t p = 0; p < leaf.count; p += 4) {
      TrianglePacket packet;
      for (uint32_t lane = 0; lane < 4; ++lane) {
        const bool real = p + lane < leaf.count;
        const uint32_t triangle = binary_.prims[leaf.index + (real ? p + lane : p)];
        packet.triangle[lane] = real ? triangle : kInvalidIndex;
        for (int c = 0; c < 3; ++c) {
          const glm::vec3 v = mesh_.vertex(triangle, c);
          for (int a = 0; a < 3; ++a) packet.p[c][a][lane] = v[a];
        }
      }
      packets_.push_back(packet);
    }
    return first;
  }

  const BinaryBvh& binary_;
  const TriangleMesh& mesh_;
  std::vector<Bvh4Node>& nodes_;
  std::vector<TrianglePacket>& packets_;
  std::vector<uint32_t>& leaf_packets_;
};

}  // namespace

Bvh::Bvh(MeshPtr mesh, const BuildSettings& settings) : StructureBase(std::move(mesh), settings) {
  const BinaryBvh binary = build_over_triangles(*mesh_, settings_);
  if (binary.nodes.empty()) return;
  root_bounds_ = binary.nodes[0].bounds();
  nodes_.reserve(binary.nodes.size() / 3 + 1);
  packets_.reserve(binary.prims.size() / 2 + 1);
  Collapser(binary, *mesh_, nodes_, packets_, leaf_packets_).collapse(0);
  nodes_.shrink_to_fit();
  packets_.shrink_to_fit();
  leaf_packets_.shrink_to_fit();
}

std::vector<BoxInfo> Bvh::boxes() const {
  std::vector<BoxInfo> out(nodes_.size() + leaf_packets_.size());
  if (nodes_.empty()) return out;
  out[0] = {root_bounds_, 0, false, 0};
  // Children follow their parent in nodes_, so a forward pass sets depths and a backward pass sums
  // the triangles of each subtree.
  for (size_t n = 0; n < nodes_.size(); ++n) {
    const Bvh4Node& node = nodes_[n];
    for (int i = 0; i < 4; ++i) {
      if (!node.used(i)) continue;
      const uint32_t id = node.leaf(i) ? leaf_id(node.child[i]) : node.child[i];
      out[id] = {node.bounds(i), out[n].depth + 1, node.leaf(i), node.count[i]};
    }
  }
  for (size_t n = nodes_.size(); n-- > 0;) {
    const Bvh4Node& node = nodes_[n];
    uint32_t total = 0;
    for (int i = 0; i < 4; ++i)
      if (node.used(i)) total += node.leaf(i) ? node.count[i] : out[node.child[i]].triangle_count;
    out[n].triangle_count = total;
  }
  return out;
}

size_t Bvh::memory_bytes() const {
  return nodes_.capacity() * sizeof(Bvh4Node) + packets_.capacity() * sizeof(TrianglePacket) +
         leaf_packets_.capacity() * sizeof(uint32_t);
}

std::unique_ptr<Structure> build_bvh(MeshPtr mesh, const BuildSettings& settings) {
  return std::make_unique<Bvh>(std::move(mesh), settings);
}

}  // namespace raylab
