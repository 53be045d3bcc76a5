#include "bvh.h"

#include "bvh_packets.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstdlib>
#include <functional>
#include <stdexcept>
#include <string>

namespace raylab {

namespace {

BinaryBvh build_over_triangles(const TriangleMesh& mesh, const BuildSettings& settings) {
  const size_t n = mesh.triangle_count();
  // The binary build, then the wide copy (packets of at most about 2x the triangles; 8-wide nodes are
  // half as many as 4-wide ones and twice the size).
  const size_t needed =
      binary_bvh_build_bytes(n, settings.builder) + 2 * n * sizeof(TrianglePacket) / 4 + n * sizeof(Bvh4Node) / 2;
  if (needed > settings.memory_budget)
    throw BuildError("bvh: building over " + std::to_string(n) + " triangles needs about " + std::to_string(needed) +
                     " bytes, over the memory budget of " + std::to_string(settings.memory_budget));
  const auto bounds_of = [&mesh](uint32_t begin, uint32_t end, Bounds* out) {
    for (uint32_t i = begin; i < end; ++i) out[i - begin] = mesh.triangle_bounds(i);
  };
  // Leaves are tested in packets of four.
  return build_binary_bvh(uint32_t(n), bounds_of, uint32_t(settings.leaf_size), kPacketLanes, settings.builder);
}

template <int W>
BvhWideNode<W> empty_node() {
  BvhWideNode<W> node;
  for (int a = 0; a < 3; ++a)
    for (int i = 0; i < W; ++i) node.lo[a][i] = node.hi[a][i] = 0.0f;  // masked out by child == kInvalidIndex
  for (int i = 0; i < W; ++i) {
    node.child[i] = kInvalidIndex;
    node.count[i] = 0;
  }
  return node;
}

struct Leaf {
  uint32_t first_prim, count, first_packet;
};

// Collapses a binary BVH into a W-wide one: each wide node takes the binary node's children and
// keeps opening its largest inner child (by surface area, the likeliest to be entered) until it has
// W. Leaves only get their packet range here; fill_packets writes them afterwards, in parallel.
template <int W>
class Collapser {
 public:
  using Node = BvhWideNode<W>;

  Collapser(const BinaryBvh& binary, std::vector<Node>& nodes) : binary_(binary), nodes_(nodes) {}

  // Collapses binary node b, at binary depth `depth`.
  uint32_t collapse(uint32_t b, int depth = 0) {
    uint32_t kids[W];
    int kid_depth[W];
    int n = 0;
    const BvhNode& top = binary_.nodes[b];
    if (top.leaf()) {
      kid_depth[n] = depth;
      kids[n++] = b;  // a root that is a leaf: a wide root with one child
    } else {
      kid_depth[n] = kid_depth[n + 1] = depth + 1;
      kids[n++] = top.index;
      kids[n++] = top.index + 1;
    }
    while (n < W) {
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
      for (int i = n; i > open + 1; --i) {
        kids[i] = kids[i - 1];
        kid_depth[i] = kid_depth[i - 1];
      }
      kids[open] = first;
      kids[open + 1] = first + 1;
      kid_depth[open + 1] = ++kid_depth[open];
      ++n;
    }
    const uint32_t w = uint32_t(nodes_.size());
    nodes_.push_back(empty_node<W>());
    node_depths_.push_back(uint8_t(depth));
    for (int i = 0; i < n; ++i) {
      const BvhNode& k = binary_.nodes[kids[i]];
      const uint32_t child = k.leaf() ? add_leaf(k, kid_depth[i]) : collapse(kids[i], kid_depth[i]);
      Node& node = nodes_[w];  // after the recursion: nodes_ may have moved
      for (int a = 0; a < 3; ++a) {
        node.lo[a][i] = k.lo[a];
        node.hi[a][i] = k.hi[a];
      }
      node.child[i] = child;
      node.count[i] = k.leaf() ? k.count : 0;
    }
    return w;
  }

  const std::vector<Leaf>& leaves() const { return leaves_; }
  // The binary depth of each box id: the nodes', then the leaves' (Bvh::split_costs).
  std::vector<uint8_t> binary_depths() const {
    std::vector<uint8_t> out = node_depths_;
    out.insert(out.end(), leaf_depths_.begin(), leaf_depths_.end());
    return out;
  }
  uint32_t packet_count() const { return packet_count_; }

 private:
  uint32_t add_leaf(const BvhNode& leaf, int depth) {
    const uint32_t first = packet_count_;
    leaves_.push_back({leaf.index, leaf.count, first});
    leaf_depths_.push_back(uint8_t(depth));
    packet_count_ += (leaf.count + 3) / 4;
    return first;
  }

  const BinaryBvh& binary_;
  std::vector<Node>& nodes_;
  std::vector<Leaf> leaves_;
  std::vector<uint8_t> node_depths_, leaf_depths_;  // the builder keeps binary depths below 48 + 32
  uint32_t packet_count_ = 0;
};

// Copies each leaf's triangles into its packets; unused lanes repeat the packet's first triangle.
void fill_packets(const TriangleMesh& mesh, const BinaryBvh& binary, const Leaf& leaf, Contract contract,
                  float fast_scale, TrianglePacket* packets) {
  for (uint32_t p = 0; p < leaf.count; p += 4) {
    TrianglePacket& packet = packets[leaf.first_packet + p / 4];
    for (uint32_t lane = 0; lane < 4; ++lane) {
      const bool real = p + lane < leaf.count;
      const uint32_t triangle = binary.prims[leaf.first_prim + (real ? p + lane : p)];
      packet.triangle[lane] = real ? triangle : kInvalidIndex;
      write_packet_lane(packet, int(lane), contract, fast_scale, mesh.vertex(triangle, 0), mesh.vertex(triangle, 1),
                        mesh.vertex(triangle, 2));
    }
  }
}

// The fast contract's 8-wide kernels need FMA as well (every AVX2 CPU but a few has it).
int chosen_width(int width, Contract contract) {
  const bool has8 = contract == Contract::Fast ? cpu_has_avx2_fma() : cpu_has_avx2();
  if (width == 8 && !has8)
    throw std::invalid_argument(contract == Contract::Fast
                                    ? "bvh: an 8-wide BVH of the fast contract needs AVX2 and FMA"
                                    : "bvh: an 8-wide BVH needs a CPU with AVX2");
  if (width != 0 && width != 4 && width != 8) throw std::invalid_argument("bvh: width must be 0, 4 or 8");
  if (width != 0) return width;
  const char* forced = std::getenv("RAYLAB_BVH_WIDTH");
  if (forced && std::string(forced) == "4") return 4;
  return has8 ? 8 : 4;
}

// Collapses `binary` into `nodes` and writes the leaves' packets; returns each leaf's first packet.
// The collapse itself runs in one thread (a few percent of a build; parallel parts were no faster:
// docs/bench/history.md).
template <int W>
std::vector<uint32_t> collapse_into(const TriangleMesh& mesh, const BinaryBvh& binary, Contract contract,
                                    float fast_scale, std::vector<BvhWideNode<W>>& nodes,
                                    HugeArray<TrianglePacket>& packets, size_t& packet_count,
                                    std::vector<uint8_t>& binary_depths) {
  nodes.reserve(binary.nodes.size() / (W - 1) + 1);
  Collapser<W> collapser(binary, nodes);
  collapser.collapse(0);
  nodes.shrink_to_fit();
  const std::vector<Leaf>& leaves = collapser.leaves();
  packet_count = collapser.packet_count();
  binary_depths = collapser.binary_depths();
  packets = make_huge_array<TrianglePacket>(packet_count);  // every packet is written below
  tbb::parallel_for(tbb::blocked_range<size_t>(0, leaves.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i != r.end(); ++i)
      fill_packets(mesh, binary, leaves[i], contract, fast_scale, packets.get());
  });
  std::vector<uint32_t> first_packets(leaves.size());
  for (size_t i = 0; i < leaves.size(); ++i) first_packets[i] = leaves[i].first_packet;
  return first_packets;
}

// The boxes of a wide tree; ids as Bvh::boxes says.
template <int W>
std::vector<BoxInfo> wide_boxes(const Bounds& root, const std::vector<BvhWideNode<W>>& nodes, size_t leaf_count,
                                const std::function<uint32_t(uint32_t)>& leaf_id) {
  std::vector<BoxInfo> out(nodes.size() + leaf_count);
  if (nodes.empty()) return out;
  out[0] = {root, 0, false, 0};
  // Children follow their parent in nodes, so a forward pass sets depths and a backward pass sums
  // the triangles of each subtree.
  for (size_t n = 0; n < nodes.size(); ++n) {
    const BvhWideNode<W>& node = nodes[n];
    for (int i = 0; i < W; ++i) {
      if (!node.used(i)) continue;
      const uint32_t id = node.leaf(i) ? leaf_id(node.child[i]) : node.child[i];
      out[id] = {node.bounds(i), out[n].depth + 1, node.leaf(i), node.count[i]};
    }
  }
  for (size_t n = nodes.size(); n-- > 0;) {
    const BvhWideNode<W>& node = nodes[n];
    uint32_t total = 0;
    for (int i = 0; i < W; ++i)
      if (node.used(i)) total += node.leaf(i) ? node.count[i] : out[node.child[i]].triangle_count;
    out[n].triangle_count = total;
  }
  return out;
}

}  // namespace

Bvh::Bvh(MeshPtr mesh, const BuildSettings& settings, int width)
    : StructureBase(std::move(mesh), settings), width_(chosen_width(width, settings.contract)) {
  const BinaryBvh binary = build_over_triangles(*mesh_, settings_);
  if (binary.nodes.empty()) return;
  root_bounds_ = binary.nodes[0].bounds();
  if (settings_.contract == Contract::Fast) fast_scale_ = fast_contract_scale(root_bounds_);
  const Contract contract = settings_.contract;
  leaf_packets_ =
      width_ == 8
          ? collapse_into(*mesh_, binary, contract, fast_scale_, nodes8_, packets_, packet_count_, binary_depth_)
          : collapse_into(*mesh_, binary, contract, fast_scale_, nodes4_, packets_, packet_count_, binary_depth_);
}

std::vector<BoxInfo> Bvh::boxes() const {
  const auto id = [this](uint32_t first_packet) { return leaf_id(first_packet); };
  return width_ == 8 ? wide_boxes(root_bounds_, nodes8_, leaf_packets_.size(), id)
                     : wide_boxes(root_bounds_, nodes4_, leaf_packets_.size(), id);
}

namespace {

// The tree of a wide BVH, ids as boxes(); each node's SAH term as sah_cost sums them (bvh_refit.cpp).
template <int W>
StructureTree wide_tree(const std::vector<BoxInfo>& boxes, const std::vector<BvhWideNode<W>>& nodes,
                        const std::function<uint32_t(uint32_t)>& leaf_id) {
  StructureTree t;
  t.width = W;
  const size_t n = boxes.size();
  t.parent.assign(n, -1);
  t.children.assign(nodes.size() * W, -1);
  for (size_t p = 0; p < nodes.size(); ++p)
    for (int i = 0; i < W; ++i) {
      if (!nodes[p].used(i)) continue;
      const uint32_t id = nodes[p].leaf(i) ? leaf_id(nodes[p].child[i]) : nodes[p].child[i];
      t.children[p * W + i] = int32_t(id);
      t.parent[id] = int32_t(p);
    }
  const double root = n ? double(boxes[0].bounds.surface_area()) : 0.0;
  for (size_t i = 0; i < n; ++i) {
    const BoxInfo& b = boxes[i];
    t.depth.push_back(b.depth);
    t.bounds.push_back(b.bounds);
    t.leaf.push_back(b.leaf);
    t.triangle_count.push_back(b.triangle_count);
    const double weight = root > 0.0 ? double(b.bounds.surface_area()) / root : 1.0;
    t.sah_cost.push_back(
        weight * (b.leaf ? double((b.triangle_count + kPacketLanes - 1) / kPacketLanes) : double(kSahTraversalCost)));
  }
  return t;
}

}  // namespace

StructureTree Bvh::tree() const {
  const std::vector<BoxInfo> b = boxes();
  const auto id = [this](uint32_t first_packet) { return leaf_id(first_packet); };
  return width_ == 8 ? wide_tree(b, nodes8_, id) : wide_tree(b, nodes4_, id);
}

std::vector<uint32_t> Bvh::triangles_of(uint32_t id) const {
  const size_t n = node_count() + leaf_packets_.size();
  if (id >= n)
    throw std::invalid_argument("node must be a node id below " + std::to_string(n) + ", got " + std::to_string(id));
  // Its leaves' packets, found by walking the wide tree.
  std::vector<uint32_t> triangles;
  const auto add_leaf = [&](uint32_t first_packet, uint32_t count) {
    for (uint32_t p = 0; p < (count + 3) / 4; ++p)
      for (uint32_t lane = 0; lane < 4; ++lane)
        if (packets_[first_packet + p].triangle[lane] != kInvalidIndex)
          triangles.push_back(packets_[first_packet + p].triangle[lane]);
  };
  const auto walk = [&](const auto& nodes) {
    if (id >= node_count()) {
      const uint32_t leaf = id - uint32_t(node_count());
      const uint32_t next = leaf + 1 < leaf_packets_.size() ? leaf_packets_[leaf + 1] : uint32_t(packet_count_);
      add_leaf(leaf_packets_[leaf], 4 * (next - leaf_packets_[leaf]));
      return;
    }
    std::vector<uint32_t> stack{id};
    while (!stack.empty()) {
      const auto& node = nodes[stack.back()];
      stack.pop_back();
      for (size_t i = 0; i < std::size(node.child); ++i) {
        if (!node.used(int(i))) continue;
        if (node.leaf(int(i))) add_leaf(node.child[i], node.count[i]);
        else stack.push_back(node.child[i]);
      }
    }
  };
  if (width_ == 8) walk(nodes8_);
  else walk(nodes4_);
  return triangles;
}

SplitCosts Bvh::split_costs(uint32_t id) const {
  const std::vector<uint32_t> triangles = triangles_of(id);
  const auto bounds_of = [this](uint32_t begin, uint32_t end, Bounds* out) {
    for (uint32_t i = begin; i < end; ++i) out[i - begin] = mesh_->triangle_bounds(i);
  };
  return explain_split(uint32_t(mesh_->triangle_count()), bounds_of, triangles, binary_depth_[id],
                       uint32_t(settings_.leaf_size), kPacketLanes, settings_.builder);
}

size_t Bvh::memory_bytes() const {
  return nodes4_.capacity() * sizeof(Bvh4Node) + nodes8_.capacity() * sizeof(Bvh8Node) +
         packet_count_ * sizeof(TrianglePacket) + leaf_packets_.capacity() * sizeof(uint32_t) +
         binary_depth_.capacity();
}

void Bvh::closest_batch(std::span<const Ray> rays, std::span<Hit> hits, PacketCounts* counts,
                        std::span<TraversalStats> per_ray) const {
  if (hits.size() != rays.size()) throw std::invalid_argument("hits and rays differ in length");
  if (!per_ray.empty() && per_ray.size() != rays.size())
    throw std::invalid_argument("per_ray and rays differ in length");
  if (!closest_packets()) {  // one ray at a time, with no coherence tests
    if (!per_ray.empty()) Structure::closest_batch_counted(rays, hits, per_ray);
    else if (width_ != 8 || node_count() == 0) Structure::closest_batch(rays, hits);
    else
      // Each run of eight rays first meets the root box lane-wise, as a packet does: a ray that misses
      // it (and so every child) gets no hit without its walk (the single walk tests the root's
      // children instead, eight boxes).
      for (size_t i = 0; i < rays.size(); i += kPacketSize) {
        const int n = int(std::min<size_t>(kPacketSize, rays.size() - i));
        const uint32_t entering = settings_.contract == Contract::Fast ? rays_entering_fast(&rays[i], n, root_bounds_)
                                                                       : rays_entering(&rays[i], n, root_bounds_);
        for (int r = 0; r < n; ++r) {
          Hit h;
          if ((entering >> r) & 1) closest(rays[i + r], h);
          hits[i + r] = h;
        }
      }
    if (counts) counts->single_rays += rays.size();
    return;
  }
  trace_batch<true>(rays, hits.data(), nullptr, counts, per_ray.empty() ? nullptr : per_ray.data());
}

void Bvh::any_batch(std::span<const Ray> rays, std::span<uint8_t> occluded, PacketCounts* counts,
                    std::span<TraversalStats> per_ray) const {
  if (occluded.size() != rays.size()) throw std::invalid_argument("occluded and rays differ in length");
  if (!per_ray.empty() && per_ray.size() != rays.size())
    throw std::invalid_argument("per_ray and rays differ in length");
  trace_batch<false>(rays, nullptr, occluded.data(), counts, per_ray.empty() ? nullptr : per_ray.data());
}

void Bvh::closest_packet(std::span<const Ray> rays, std::span<Hit> hits, PacketCounts* counts,
                         std::span<TraversalStats> per_ray) const {
  if (hits.size() != rays.size()) throw std::invalid_argument("hits and rays differ in length");
  if (rays.empty() || rays.size() > size_t(kPacketSize))
    throw std::invalid_argument("a packet holds 1 to " + std::to_string(kPacketSize) + " rays");
  if (!per_ray.empty() && per_ray.size() != rays.size())
    throw std::invalid_argument("per_ray and rays differ in length");
  trace_packet<true>(rays.data(), int(rays.size()), hits.data(), nullptr, counts,
                     per_ray.empty() ? nullptr : per_ray.data());
}

void Bvh::any_packet(std::span<const Ray> rays, std::span<uint8_t> occluded, PacketCounts* counts,
                     std::span<TraversalStats> per_ray) const {
  if (occluded.size() != rays.size()) throw std::invalid_argument("occluded and rays differ in length");
  if (rays.empty() || rays.size() > size_t(kPacketSize))
    throw std::invalid_argument("a packet holds 1 to " + std::to_string(kPacketSize) + " rays");
  if (!per_ray.empty() && per_ray.size() != rays.size())
    throw std::invalid_argument("per_ray and rays differ in length");
  trace_packet<false>(rays.data(), int(rays.size()), nullptr, occluded.data(), counts,
                      per_ray.empty() ? nullptr : per_ray.data());
}

std::unique_ptr<Structure> build_bvh(MeshPtr mesh, const BuildSettings& settings) {
  return std::make_unique<Bvh>(std::move(mesh), settings);
}

}  // namespace raylab
