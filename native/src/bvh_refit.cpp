// The BVH's refit and its SAH cost (refit.h says what a refit is and when it pays).
#include "bvh.h"
#include "raylab/refit.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <stdexcept>
#include <type_traits>

namespace raylab {

namespace {

template <int W>
void set_slot(BvhWideNode<W>& node, int i, const Bounds& b) {
  for (int a = 0; a < 3; ++a) {
    node.lo[a][i] = b.lo[a];
    node.hi[a][i] = b.hi[a];
  }
}

// Rewrites the packets of the leaf in slot i of `node` from `mesh` (the same triangle ids and lane
// layout as `source`, unused lanes repeating the packet's first triangle as the build does) and
// returns the union of its triangles' bounds, as the build computes a leaf's box.
template <int W>
Bounds refit_leaf(const TriangleMesh& mesh, const BvhWideNode<W>& node, int i, Contract contract, float fast_scale,
                  const TrianglePacket* source, TrianglePacket* packets) {
  Bounds box;
  const uint32_t first = node.child[i], count = node.count[i];
  for (uint32_t p = 0; p < (count + kPacketLanes - 1) / kPacketLanes; ++p) {
    const TrianglePacket& from = source[first + p];
    TrianglePacket& to = packets[first + p];
    for (uint32_t lane = 0; lane < kPacketLanes; ++lane) {
      const uint32_t id = from.triangle[lane];
      to.triangle[lane] = id;
      const uint32_t triangle = id != kInvalidIndex ? id : from.triangle[0];
      write_packet_lane(to, int(lane), contract, fast_scale, mesh.vertex(triangle, 0), mesh.vertex(triangle, 1),
                        mesh.vertex(triangle, 2));
      if (id != kInvalidIndex)
        for (int c = 0; c < 3; ++c) box.extend(mesh.vertex(triangle, c));
    }
  }
  return box;
}

// Sets the inner slots of node n's subtree from their children, bottom-up (post-order from the
// node, whatever order the build stored the nodes in); returns the node's box. The depth is the
// tree's, at most kMaxBinaryDepth (bvh_build.h).
template <int W>
Bounds refit_inner(std::vector<BvhWideNode<W>>& nodes, uint32_t n) {
  Bounds box;
  for (int i = 0; i < W; ++i) {
    if (!nodes[n].used(i)) continue;
    if (!nodes[n].leaf(i)) set_slot(nodes[n], i, refit_inner(nodes, nodes[n].child[i]));
    box.extend(nodes[n].bounds(i));
  }
  return box;
}

// Leaves first (in parallel: each slot and packet belongs to one node), then the inner slots
// bottom-up. Returns the root box.
template <int W>
Bounds refit_wide(const TriangleMesh& mesh, std::vector<BvhWideNode<W>>& nodes, Contract contract, float fast_scale,
                  const TrianglePacket* source, TrianglePacket* packets) {
  if (nodes.empty()) return {};
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nodes.size(), 256), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t n = r.begin(); n != r.end(); ++n)
      for (int i = 0; i < W; ++i)
        if (nodes[n].leaf(i))
          set_slot(nodes[n], i, refit_leaf(mesh, nodes[n], i, contract, fast_scale, source, packets));
  });
  return refit_inner(nodes, 0);
}

// sah_cost (refit.h) on a wide tree: the root node, every inner slot (a node visit) and every leaf
// slot (its blocks of kPacketLanes triangles), weighted by area over the root's.
template <int W>
double wide_sah_cost(const std::vector<BvhWideNode<W>>& nodes, const Bounds& root_box) {
  if (nodes.empty()) return 0.0;
  const double root = root_box.surface_area();
  double sum = kSahTraversalCost;
  for (const BvhWideNode<W>& node : nodes)
    for (int i = 0; i < W; ++i) {
      if (!node.used(i)) continue;
      const double weight = root > 0.0 ? node.bounds(i).surface_area() / root : 1.0;
      sum += weight *
             (node.leaf(i) ? double((node.count[i] + kPacketLanes - 1) / kPacketLanes) : double(kSahTraversalCost));
    }
  return sum;
}

}  // namespace

Bvh::Bvh(const Bvh& source, MeshPtr moved)
    : StructureBase(std::move(moved), source.settings_),
      width_(source.width_),
      nodes4_(source.nodes4_),
      nodes8_(source.nodes8_),
      packets_(make_huge_array<TrianglePacket>(source.packet_count_)),  // every packet is rewritten
      packet_count_(source.packet_count_),
      leaf_packets_(source.leaf_packets_),
      binary_depth_(source.binary_depth_) {
  if (mesh_->triangles != source.mesh_->triangles)
    throw std::invalid_argument("bvh refit: the moved mesh must have the source's triangles");
  // The moved mesh's own scale: a refit may shrink or grow it by any factor.
  if (settings_.contract == Contract::Fast) fast_scale_ = fast_contract_scale(mesh_->bounds());
  const Contract contract = settings_.contract;
  root_bounds_ = width_ == 8
                     ? refit_wide(*mesh_, nodes8_, contract, fast_scale_, source.packets_.get(), packets_.get())
                     : refit_wide(*mesh_, nodes4_, contract, fast_scale_, source.packets_.get(), packets_.get());
}

double Bvh::sah_cost() const {
  return width_ == 8 ? wide_sah_cost(nodes8_, root_bounds_) : wide_sah_cost(nodes4_, root_bounds_);
}

std::optional<double> structure_sah_cost(const Structure& s) {
  const auto* bvh = dynamic_cast<const Bvh*>(&s);
  return bvh ? std::optional<double>(bvh->sah_cost()) : std::nullopt;
}

std::unique_ptr<Structure> refit_bvh(const Structure& source, MeshPtr moved) {
  const auto* bvh = dynamic_cast<const Bvh*>(&source);
  if (!bvh) throw std::invalid_argument("refit_bvh: the source is not a bvh");
  return std::make_unique<Bvh>(*bvh, std::move(moved));
}

}  // namespace raylab
