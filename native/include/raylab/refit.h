// Refit: a structure over the same triangles at new vertex positions (a deforming mesh, an animation
// frame) that keeps its source's topology and recomputes its boxes bottom-up, instead of a rebuild.
// Faster than a build, but the tree was chosen for the old positions: its quality (sah_cost) degrades
// as the mesh moves away from them. Exactness is untouched: every box is recomputed from the new
// triangles by the build's own rules (the union of its triangles' bounds, padded per ray by BoxRay).
//
// Structures whose topology depends on the positions (octree, grid: which cells a triangle overlaps)
// cannot refit: refit_structure rebuilds them, so that a script animating any kind works, and the
// result says which it did (Structure::refitted()). A refit never changes its source: the source may
// be in use by other threads (a published scene snapshot); the refit is a new structure.
#pragma once

#include "raylab/bvh_build.h"
#include "raylab/structure.h"

#include <memory>
#include <optional>
#include <span>
#include <vector>

namespace raylab {

// `source`'s triangles at `vertices`, validated: as many vertices as source's mesh has, each finite
// and within kMaxCoordinate. Throws std::invalid_argument starting "vertices: " otherwise.
MeshPtr moved_mesh(const TriangleMesh& source, std::vector<glm::vec3> vertices);

// The refit of `source` over `moved` (the same triangles; else std::invalid_argument), timed in
// build_seconds(); a rebuild with source's settings for the kinds without StructureInfo::refit.
std::unique_ptr<Structure> refit_structure(const Structure& source, MeshPtr moved);
std::unique_ptr<Structure> refit_structure(const Structure& source, std::vector<glm::vec3> vertices);

// Refits a binary BVH (the scene's top level) over new primitive bounds in place, keeping its
// topology. Returns false, with `bvh` unspecified, when the tree does not fit the bounds: a different
// primitive count, or a primitive that build_binary_bvh would now leave out or take in (empty bounds).
bool refit_binary_bvh(BinaryBvh& bvh, std::span<const Bounds> prim_bounds);

// The SAH cost of a binary BVH, normalised by its root's area: kSahTraversalCost for every inner node
// plus ceil(count / leaf_block) for every leaf, each weighted by its area over the root's (the
// probability that a ray through the root enters it). 0 for an empty tree; a root of zero area
// (every primitive on one point or line) weighs every node 1.
double sah_cost(const BinaryBvh& bvh, uint32_t leaf_block);
// A BVH structure's sah_cost over its wide tree (Bvh::sah_cost); nullopt for the other kinds.
std::optional<double> structure_sah_cost(const Structure& s);

}  // namespace raylab
