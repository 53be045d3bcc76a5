// raylab.Scene: meshes, instances with a 4x4 transform, one structure per mesh, batch queries.
#include "core_arrays.h"

#include "raylab/scene.h"

#include <cmath>
#include <limits>

namespace raylab::python {

namespace {

// numpy's row-major (4,4) object-to-world matrix -> glm's column-major mat4.
glm::mat4 matrix_from_array(py::handle matrix) {
  if (matrix.is_none()) throw std::invalid_argument("matrix must be a (4, 4) array, got None");
  auto m = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(matrix);
  if (!m || m.ndim() != 2 || m.shape(0) != 4 || m.shape(1) != 4)
    throw std::invalid_argument("matrix must be a (4, 4) array of numbers");
  glm::mat4 g;
  for (int row = 0; row < 4; ++row)
    for (int col = 0; col < 4; ++col) g[col][row] = m.at(row, col);
  return g;
}

uint32_t id(int64_t value, size_t count, const char* what) {
  if (value < 0 || uint64_t(value) >= count)
    throw std::invalid_argument("unknown " + std::string(what) + " id " + std::to_string(value) + ": the scene has " +
                                std::to_string(count));
  return uint32_t(value);
}

}  // namespace

void bind_scene(py::module_& m) {
  constexpr double kNoLimit = std::numeric_limits<double>::infinity();
  py::class_<Scene>(m, "Scene", "Meshes and their instances; one structure per mesh shared by its instances.")
      .def(py::init([](const std::string& structure, int max_depth, int leaf_size, const std::string& triangle_test,
                       py::handle memory_budget) {
             return std::make_unique<Scene>(
                 settings_from_arguments(structure, max_depth, leaf_size, triangle_test, memory_budget));
           }),
           py::arg("structure") = "bvh", py::arg("max_depth") = 6, py::arg("leaf_size") = 8,
           py::arg("triangle_test") = "watertight", py::arg("memory_budget") = py::none())
      .def(
          "add_mesh",
          [](Scene& s, py::handle vertices, py::handle triangles) {
            return s.add_mesh(mesh_from_arrays(vertices, triangles));
          },
          py::arg("vertices"), py::arg("triangles"))
      .def(
          "replace_mesh",
          [](Scene& s, int64_t mesh, py::handle vertices, py::handle triangles) {
            s.replace_mesh(id(mesh, s.mesh_count(), "mesh"), mesh_from_arrays(vertices, triangles));
          },
          py::arg("mesh"), py::arg("vertices"), py::arg("triangles"))
      .def(
          "add_instance",
          [](Scene& s, int64_t mesh, py::handle matrix, int64_t material) {
            if (material < 0 || material > int64_t(std::numeric_limits<uint32_t>::max()))
              throw std::invalid_argument("material must be a non-negative index, got " + std::to_string(material));
            return s.add_instance(id(mesh, s.mesh_count(), "mesh"), matrix_from_array(matrix), uint32_t(material));
          },
          py::arg("mesh"), py::arg("matrix"), py::arg("material") = 0)
      .def(
          "set_transform",
          [](Scene& s, int64_t instance, py::handle matrix) {
            s.set_transform(id(instance, s.instance_count(), "instance"), matrix_from_array(matrix));
          },
          py::arg("instance"), py::arg("matrix"))
      .def(
          "set_settings",
          [](Scene& s, const std::string& structure, int max_depth, int leaf_size, const std::string& triangle_test,
             py::handle memory_budget) {
            s.set_settings(settings_from_arguments(structure, max_depth, leaf_size, triangle_test, memory_budget));
          },
          py::arg("structure") = "bvh", py::arg("max_depth") = 6, py::arg("leaf_size") = 8,
          py::arg("triangle_test") = "watertight", py::arg("memory_budget") = py::none())
      .def("commit",
           [](Scene& s) {
             py::gil_scoped_release release;
             s.commit();
           })
      .def("intersect", &intersect_rays<Scene>, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
           py::arg("tmax") = kNoLimit, py::arg("count") = false)
      .def("occluded", &occluded_rays<Scene>, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
           py::arg("tmax") = kNoLimit, py::arg("count") = false)
      .def_property_readonly("mesh_count", &Scene::mesh_count)
      .def_property_readonly("instance_count", &Scene::instance_count)
      .def_property_readonly("memory_bytes", &Scene::memory_bytes)
      .def_property_readonly("build_seconds", &Scene::build_seconds)
      .def("bounds", [](const Scene& s) {
        const Bounds b = s.bounds();
        return py::make_tuple(py::array_t<float>(3, &b.lo.x), py::array_t<float>(3, &b.hi.x));
      });
}

}  // namespace raylab::python
