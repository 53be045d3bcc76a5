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
  const auto m = real_array<float>(matrix, "matrix");
  if (!m || m->ndim() != 2 || m->shape(0) != 4 || m->shape(1) != 4)
    throw std::invalid_argument("matrix must be a (4, 4) array of real numbers, got " + describe(matrix));
  glm::mat4 g;
  for (int row = 0; row < 4; ++row)
    for (int col = 0; col < 4; ++col) g[col][row] = m->at(row, col);
  return g;
}

// Per-corner normals (T,3,3) or per-vertex normals (V,3), expanded to corners, for `mesh`; the
// scene validates their count and values.
std::vector<glm::vec3> corner_normals_from_array(const TriangleMesh& mesh, py::handle normals) {
  const auto a = real_array<float>(normals, "normals");
  const size_t t = mesh.triangles.size(), v = mesh.vertices.size();
  const bool per_corner = a && a->ndim() == 3 && size_t(a->shape(0)) == t && a->shape(1) == 3 && a->shape(2) == 3;
  const bool per_vertex = a && a->ndim() == 2 && size_t(a->shape(0)) == v && a->shape(1) == 3;
  if (!per_corner && !per_vertex)
    throw std::invalid_argument("normals must be a (T, 3, 3) array of per-corner normals (T = " + std::to_string(t) +
                                ") or a (V, 3) array of per-vertex normals (V = " + std::to_string(v) + ")");
  const float* data = (*a).data();
  std::vector<glm::vec3> corners(3 * t);
  for (size_t i = 0; i < 3 * t; ++i) {
    const size_t row = per_corner ? i : mesh.triangles[i / 3][int(i % 3)];
    corners[i] = glm::vec3(data[3 * row], data[3 * row + 1], data[3 * row + 2]);
  }
  validate_shading_normals(mesh, corners);
  return corners;
}

// A new mesh with optional smooth normals, checked in full before the scene changes.
template <class Store>
auto with_normals(py::handle vertices, py::handle triangles, py::handle normals, Store store) {
  MeshPtr mesh = mesh_from_arrays(vertices, triangles);
  std::vector<glm::vec3> corners;
  if (!normals.is_none()) corners = corner_normals_from_array(*mesh, normals);
  return store(std::move(mesh), std::move(corners));
}

}  // namespace

void bind_scene(py::module_& m) {
  constexpr double kNoLimit = std::numeric_limits<double>::infinity();
  py::class_<Scene> scene(m, "Scene", "Meshes and their instances; one structure per mesh shared by its instances.");
  with_settings_keywords([&](auto... keywords) {
    scene.def(py::init([](py::handle structure, py::handle max_depth, py::handle leaf_size, py::handle triangle_test,
                          py::handle contract, py::handle builder, py::handle memory_budget) {
                return std::make_unique<Scene>(settings_from_arguments(structure, max_depth, leaf_size, triangle_test,
                                                                       contract, builder, memory_budget));
              }),
              keywords...);
    scene.def(
        "set_settings",
        [](Scene& s, py::handle structure, py::handle max_depth, py::handle leaf_size, py::handle triangle_test,
           py::handle contract, py::handle builder, py::handle memory_budget) {
          s.set_settings(settings_from_arguments(structure, max_depth, leaf_size, triangle_test, contract, builder,
                                                 memory_budget));
        },
        keywords...);
  });
  scene
      .def(
          "add_mesh",
          [](Scene& s, py::handle vertices, py::handle triangles, py::handle normals) {
            return with_normals(vertices, triangles, normals, [&](MeshPtr m, std::vector<glm::vec3> corners) {
              return s.add_mesh(std::move(m), std::move(corners));
            });
          },
          py::arg("vertices"), py::arg("triangles"), py::arg("normals") = py::none())
      .def(
          "replace_mesh",
          [](Scene& s, py::handle mesh, py::handle vertices, py::handle triangles, py::handle normals) {
            const uint32_t m = id_parameter(mesh, s.mesh_count(), "mesh");
            with_normals(vertices, triangles, normals, [&](MeshPtr replacement, std::vector<glm::vec3> corners) {
              s.replace_mesh(m, std::move(replacement), std::move(corners));
              return m;
            });
          },
          py::arg("mesh"), py::arg("vertices"), py::arg("triangles"), py::arg("normals") = py::none())
      .def(
          "refit_mesh",
          [](Scene& s, py::handle mesh, py::handle vertices, py::handle normals) {
            const uint32_t m = id_parameter(mesh, s.mesh_count(), "mesh");
            std::vector<glm::vec3> points = vertices_from_array(vertices);
            const MeshPtr current = s.mesh(m);
            // The normals are read against the moved mesh (the same triangles and vertex count).
            std::vector<glm::vec3> corners;
            if (!normals.is_none()) corners = corner_normals_from_array(*current, normals);
            py::gil_scoped_release release;
            s.refit_mesh(m, std::move(points), std::move(corners));
          },
          py::arg("mesh"), py::arg("vertices"), py::arg("normals") = py::none())
      .def(
          "add_instance",
          [](Scene& s, py::handle mesh, py::handle matrix, py::handle material) {
            const uint32_t m = id_parameter(mesh, s.mesh_count(), "mesh");
            const auto index = uint32_t(integer_parameter(material, "material", 0, std::numeric_limits<uint32_t>::max(),
                                                          "a non-negative index that fits in 32 bits"));
            return s.add_instance(m, matrix_from_array(matrix), index);
          },
          py::arg("mesh"), py::arg("matrix"), py::arg("material") = 0)
      .def(
          "set_transform",
          [](Scene& s, py::handle instance, py::handle matrix) {
            s.set_transform(id_parameter(instance, s.instance_count(), "instance"), matrix_from_array(matrix));
          },
          py::arg("instance"), py::arg("matrix"))
      .def("commit",
           [](Scene& s) {
             py::gil_scoped_release release;
             s.commit();
           })
      .def("intersect", &intersect_rays<Scene>, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
           py::arg("tmax") = kNoLimit, py::arg("count") = false, py::arg("per_ray") = false,
           py::arg("threads") = py::none())
      .def("occluded", &occluded_rays<Scene>, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
           py::arg("tmax") = kNoLimit, py::arg("count") = false, py::arg("per_ray") = false,
           py::arg("threads") = py::none())
      .def("clear_instances", &Scene::clear_instances)
      .def(
          "statuses",
          [](const Scene& s, py::handle origins, py::handle directions, py::handle tmin, py::handle tmax,
             py::handle threads) {
            return status_arrays(origins, directions, tmin, tmax, threads, false,
                                 [&](const auto& rays, auto& hits, auto& status, int n_threads) {
                                   intersect_with_status(s, rays, hits, status, n_threads);
                                 });
          },
          py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0, py::arg("tmax") = kNoLimit,
          py::arg("threads") = py::none())
      .def(
          "story",
          [](const Scene& s, py::handle origin, py::handle direction, py::handle tmin, py::handle tmax) {
            const Ray ray = ray_from_arrays(origin, direction, tmin, tmax);
            const SceneSnapshotPtr snapshot = s.snapshot();
            SceneStory st;
            {
              py::gil_scoped_release release;
              st = snapshot->story(ray);
            }
            return scene_story_to_dict(st, *snapshot);
          },
          py::arg("origin"), py::arg("direction"), py::arg("tmin") = 0.0, py::arg("tmax") = kNoLimit)
      .def(
          "structure",
          [](const Scene& s, py::handle mesh) {
            const SceneSnapshotPtr snapshot = s.snapshot();
            // Every Structure method Python reaches is const; the binding's holder type is not.
            return std::const_pointer_cast<Structure>(
                snapshot->structure_ptr(id_parameter(mesh, snapshot->mesh_count(), "mesh")));
          },
          py::arg("mesh"))
      .def(
          "matrix",
          [](const Scene& s, py::handle instance) {
            return matrix_to_array(s.instance(id_parameter(instance, s.instance_count(), "instance")).transform);
          },
          py::arg("instance"))
      .def_property_readonly("mesh_count", &Scene::mesh_count)
      .def_property_readonly("instance_count", &Scene::instance_count)
      .def_property_readonly("memory_bytes", &Scene::memory_bytes)
      .def_property_readonly("build_seconds", &Scene::build_seconds)
      .def_property_readonly("top_level_update",
                             [](const Scene& s) { return top_level_update_name(s.top_level_update()); })
      .def_property_readonly("top_level_sah_cost", &Scene::top_level_sah_cost)
      .def("bounds", [](const Scene& s) {
        const Bounds b = s.bounds();
        return py::make_tuple(py::array_t<float>(3, &b.lo.x), py::array_t<float>(3, &b.hi.x));
      });
}

}  // namespace raylab::python
