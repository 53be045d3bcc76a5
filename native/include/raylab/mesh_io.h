// Mesh files, read through tinyobjloader (Debian's libtinyobjloader-dev).
#pragma once

#include "raylab/geometry.h"

#include <string>

namespace raylab {

// Loads an OBJ file as one triangle mesh (polygons are fan-triangulated by the loader).
// A file that cannot be opened or parsed throws std::runtime_error naming it. Input that would load
// as something else than it says throws std::invalid_argument naming the file (and line): a path
// with a NUL character, a directory, a `v` line without three finite numbers, an invalid mesh.
TriangleMesh load_mesh(const std::string& path);

}  // namespace raylab
