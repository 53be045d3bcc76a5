// Mesh files, read through tinyobjloader (Debian's libtinyobjloader-dev).
#pragma once

#include "raylab/geometry.h"

#include <string>

namespace raylab {

// Loads an OBJ file as one triangle mesh (polygons are fan-triangulated by the loader).
// Throws std::runtime_error naming the file and the problem.
TriangleMesh load_mesh(const std::string& path);

}  // namespace raylab
