// `octree`: see DESIGN.md. Implemented in src/octree.cpp.
#pragma once

#include "raylab/structure.h"

namespace raylab {

std::unique_ptr<Structure> build_octree(MeshPtr mesh, const BuildSettings& settings);

}  // namespace raylab
