// A structure's tree as a learner reads it (Structure.tree() in Python), and one BVH node's split
// decision (Structure.split_costs): the numbers behind "why this tree?".
#pragma once

#include "raylab/bvh_build.h"
#include "raylab/geometry.h"
#include "raylab/structure.h"

#include <cstdint>
#include <optional>
#include <vector>

namespace raylab {

// Node i is boxes()[i] (the same ids as boxes() and the stories). Children sit in rows of `width`
// (the wide BVH's 4 or 8, the octree's 8 octants), -1 where a slot is empty.
struct StructureTree {
  int width = 0;
  std::vector<int32_t> parent;    // -1 for the root
  std::vector<int32_t> children;  // node count x width
  std::vector<int32_t> depth;
  std::vector<Bounds> bounds;
  std::vector<uint8_t> leaf;
  std::vector<uint32_t> triangle_count;  // boxes()'s: a subtree's distinct triangles
  // The BVH's: each node's share of sah_cost() (its area over the root's times a node visit, or a
  // leaf's blocks), so that the sum is sah_cost(); empty for kinds without an SAH.
  std::vector<double> sah_cost;
};

// The tree of a BVH or an octree; nullopt for the other kinds (none and aabb have no tree, the grid's
// cells are one level: boxes()).
std::optional<StructureTree> structure_tree(const Structure& s);

// The split decision of BVH node `node` (a tree() id): explain_split over its triangles with the
// build's own builder, settings and binary depth. The wide BVH is a binary tree collapsed: a wide inner
// node is the binary node at its top, whose split decides which of its children lie left (a prefix of
// them); a leaf is a binary leaf. A refitted BVH keeps the tree of the old positions: this is what the
// builder would decide over the moved ones. Throws std::invalid_argument for another kind or a bad id.
SplitCosts structure_split_costs(const Structure& s, uint32_t node);

}  // namespace raylab
