// kStructures: the one table of structure kinds (StructureInfo, structure.h), and its look-ups.
#include "raylab/structure.h"

#include "aabb_structure.h"
#include "brute_force.h"
#include "bvh.h"
#include "grid.h"
#include "octree.h"

#include <stdexcept>
#include <string>

namespace raylab {

namespace {

template <class T>
std::unique_ptr<Structure> make(MeshPtr mesh, const BuildSettings& settings) {
  return std::make_unique<T>(std::move(mesh), settings);
}

// The refit of a structure without topology (brute force, one box): the same structure made anew.
template <class T>
std::unique_ptr<Structure> remake(const Structure& source, MeshPtr moved) {
  return std::make_unique<T>(std::move(moved), source.settings());
}

// VRT's levels in order, then what raylab adds. `none` and `aabb` are VRT's models: every object meets
// every ray and its own structure decides, so a Scene gives them no top level.
constexpr StructureInfo kStructures[] = {
    {StructureKind::None, "none", "None", "Every ray tests every triangle (brute force)", "the object", false, false,
     false, false, false, false, &make<BruteForce>, &remake<BruteForce>},
    {StructureKind::Aabb, "aabb", "AABB", "One axis-aligned bounding box per object; rays that miss it are ignored",
     "the AABB", false, false, false, false, false, true, &make<AabbStructure>, &remake<AabbStructure>},
    {StructureKind::Octree, "octree", "Octree",
     "A cube split into octants while a node holds more than leaf size triangles, down to the maximum depth "
     "(auto: derived from the triangle count and the memory budget)",
     "the octree root", true, true, false, false, true, true, &build_octree, nullptr},
    {StructureKind::Bvh, "bvh", "BVH",
     "A bounding volume hierarchy, built with the binned surface area heuristic or another builder", "the BVH root",
     false, true, true, true, true, true, &build_bvh, &refit_bvh},
    {StructureKind::Grid, "grid", "Uniform grid",
     "Equal cells over the mesh's box, about 3 times the cube root of the triangle count along the longest "
     "side, walked front to back (3D-DDA)",
     "the grid's box", false, false, false, false, true, true, &build_grid, nullptr},
};

}  // namespace

std::span<const StructureInfo> structure_kinds() { return kStructures; }

const StructureInfo& structure_info(StructureKind kind) {
  for (const StructureInfo& info : kStructures)
    if (info.kind == kind) return info;
  throw std::logic_error("structure kind " + std::to_string(int(kind)) + " has no row in kStructures");
}

const StructureInfo& structure_info(const std::string& name) {
  std::string names;
  for (const StructureInfo& info : kStructures) {
    if (name == info.name) return info;
    names += (names.empty() ? "" : ", ") + std::string(info.name);
  }
  throw std::invalid_argument("unknown structure '" + name + "': expected one of " + names);
}

}  // namespace raylab
