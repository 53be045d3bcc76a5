#include "raylab/mesh_io.h"

#include <tiny_obj_loader.h>

#include <stdexcept>

namespace raylab {

TriangleMesh load_mesh(const std::string& path) {
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  if (!reader.ParseFromFile(path, config))
    throw std::runtime_error("cannot read mesh '" + path + "': " +
                             (reader.Error().empty() ? std::string("unknown error") : reader.Error()));
  const tinyobj::attrib_t& attrib = reader.GetAttrib();
  TriangleMesh mesh;
  mesh.vertices.resize(attrib.vertices.size() / 3);
  for (size_t i = 0; i < mesh.vertices.size(); ++i)
    mesh.vertices[i] = {attrib.vertices[3 * i], attrib.vertices[3 * i + 1], attrib.vertices[3 * i + 2]};
  for (const tinyobj::shape_t& shape : reader.GetShapes()) {
    const auto& idx = shape.mesh.indices;
    for (size_t f = 0; f + 2 < idx.size(); f += 3)
      mesh.triangles.push_back({uint32_t(idx[f].vertex_index), uint32_t(idx[f + 1].vertex_index),
                                uint32_t(idx[f + 2].vertex_index)});
  }
  mesh.validate();
  return mesh;
}

}  // namespace raylab
