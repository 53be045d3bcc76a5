// Structure.tree() and split_costs (raylab/tree.h): which kinds have a tree, and how it is read.
#include "raylab/tree.h"

#include "bvh.h"
#include "octree.h"

#include <stdexcept>
#include <string>

namespace raylab {

namespace {

// The octree's nodes are its boxes (ids alike); children by octant.
StructureTree octree_tree(const Octree& octree) {
  StructureTree t;
  t.width = 8;
  const std::vector<BoxInfo> boxes = octree.boxes();
  const std::span<const OctreeNode> nodes = octree.nodes();
  t.parent.assign(boxes.size(), -1);
  t.children.assign(boxes.size() * 8, -1);
  for (size_t i = 0; i < nodes.size(); ++i) {
    if (nodes[i].leaf()) continue;
    for (int octant = 0; octant < 8; ++octant)
      if ((nodes[i].child_mask() >> octant) & 1u) {
        const uint32_t c = nodes[i].child(octant);
        t.children[i * 8 + size_t(octant)] = int32_t(c);
        t.parent[c] = int32_t(i);
      }
  }
  for (const BoxInfo& b : boxes) {
    t.depth.push_back(b.depth);
    t.bounds.push_back(b.bounds);
    t.leaf.push_back(b.leaf);
    t.triangle_count.push_back(b.triangle_count);
  }
  return t;
}

}  // namespace

std::optional<StructureTree> structure_tree(const Structure& s) {
  if (const auto* bvh = dynamic_cast<const Bvh*>(&s)) return bvh->tree();
  if (const auto* octree = dynamic_cast<const Octree*>(&s)) return octree_tree(*octree);
  return std::nullopt;
}

SplitCosts structure_split_costs(const Structure& s, uint32_t node) {
  const auto* bvh = dynamic_cast<const Bvh*>(&s);
  if (!bvh)
    throw std::invalid_argument("split_costs is the BVH's (its builder's split decisions); structure '" +
                                std::string(structure_kind_name(s.kind())) + "' has none");
  return bvh->split_costs(node);
}

}  // namespace raylab
