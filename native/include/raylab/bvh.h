// `bvh`: see DESIGN.md. Implemented in src/bvh.cpp.
#pragma once

#include "raylab/structure.h"

namespace raylab {

std::unique_ptr<Structure> build_bvh(MeshPtr mesh, const BuildSettings& settings);

}  // namespace raylab
