// Mesh files: raylab's own OBJ reader (v and f statements; the rest is skipped).
#pragma once

#include "raylab/geometry.h"

#include <string>

namespace raylab {

// Loads an OBJ file as one triangle mesh: quads split along their shorter diagonal, larger polygons by ear
// clipping (a convex one as a fan from its first corner). Every number is parsed once, and the value
// checked is the value used.
// A file that cannot be opened or read throws std::runtime_error naming it. Input that would load as
// something else than it says throws std::invalid_argument naming the file (and line, in UTF-8 with other
// bytes shown as \xNN): a path with a NUL character, anything but a regular file (a directory, a FIFO, a
// device), a file over 1 GiB, a `v` line without three finite numbers, a face index that is not a whole
// number or names no vertex of the file, a face of fewer than three corners, an invalid mesh.
TriangleMesh load_mesh(const std::string& path);

}  // namespace raylab
