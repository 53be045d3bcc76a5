// Meshes, structures and their queries. The native module returns plain dicts of numpy arrays;
// addon/raylab/api.py gives them the attribute names of the agreed Python API.
#include "bindings.h"
#include "core_arrays.h"

#include "raylab/mesh_io.h"
#include "raylab/structure.h"

#include <algorithm>
#include <limits>

namespace raylab::python {

namespace {

constexpr double kNoLimit = std::numeric_limits<double>::infinity();

using StructurePtr = std::shared_ptr<Structure>;

StructurePtr build(MeshPtr mesh, const BuildSettings& settings) {
  py::gil_scoped_release release;
  return build_structure(std::move(mesh), settings);
}

// A mesh file that cannot be read is an OSError naming the path, as for Python's own open(); a path
// that names no file (NUL, directory) or a file with invalid content is a ValueError.
TriangleMesh read_mesh_file(const std::string& path) {
  try {
    py::gil_scoped_release release;
    return load_mesh(path);
  } catch (const std::invalid_argument&) {
    throw;  // a bad path or a file that reads but holds an invalid mesh: ValueError
  } catch (const std::runtime_error& e) {
    std::string message = e.what();
    message.erase(message.find_last_not_of(" \n") + 1);  // the loader ends its messages with a newline
    PyErr_SetString(PyExc_OSError, message.c_str());
    throw py::error_already_set();
  }
}

py::tuple mesh_to_arrays(const TriangleMesh& mesh) {
  py::array_t<float> v({py::ssize_t(mesh.vertices.size()), py::ssize_t(3)});
  py::array_t<uint32_t> t({py::ssize_t(mesh.triangles.size()), py::ssize_t(3)});
  // glm vectors are three packed scalars; an empty mesh has no data() to take a member of (UBSan).
  std::copy_n(reinterpret_cast<const float*>(mesh.vertices.data()), 3 * mesh.vertices.size(), v.mutable_data());
  std::copy_n(reinterpret_cast<const uint32_t*>(mesh.triangles.data()), 3 * mesh.triangles.size(), t.mutable_data());
  return py::make_tuple(v, t);
}

py::array_t<float> rows(const std::vector<glm::vec3>& points) {
  py::array_t<float> a({py::ssize_t(points.size()), py::ssize_t(3)});
  float* p = a.mutable_data();
  for (size_t i = 0; i < points.size(); ++i)
    for (int c = 0; c < 3; ++c) p[3 * i + c] = points[i][c];
  return a;
}

template <class T, class Item, class Field>
py::array_t<T> column(const std::vector<Item>& items, Field field) {
  py::array_t<T> a(py::ssize_t(items.size()));
  T* p = a.mutable_data();
  for (size_t i = 0; i < items.size(); ++i) p[i] = T(field(items[i]));
  return a;
}

py::dict boxes(const Structure& s) {
  const std::vector<BoxInfo> b = s.boxes();
  std::vector<glm::vec3> lo, hi;
  for (const BoxInfo& box : b) {
    lo.push_back(box.bounds.lo);
    hi.push_back(box.bounds.hi);
  }
  py::dict d;
  d["lo"] = rows(lo);
  d["hi"] = rows(hi);
  d["depth"] = column<int32_t>(b, [](const BoxInfo& x) { return x.depth; });
  d["leaf"] = column<bool>(b, [](const BoxInfo& x) { return x.leaf; });
  d["triangle_count"] = column<uint32_t>(b, [](const BoxInfo& x) { return x.triangle_count; });
  return d;
}

py::dict story(const Structure& s, py::handle origin, py::handle direction, py::handle tmin, py::handle tmax) {
  const Ray ray = ray_from_arrays(origin, direction, tmin, tmax);
  RayStory st;
  {
    py::gil_scoped_release release;
    st = s.story(ray);
  }
  std::vector<glm::vec3> lo, hi;
  for (const StoryBox& b : st.boxes) {
    lo.push_back(b.bounds.lo);
    hi.push_back(b.bounds.hi);
  }
  py::dict box_dict;
  box_dict["lo"] = rows(lo);
  box_dict["hi"] = rows(hi);
  box_dict["depth"] = column<int32_t>(st.boxes, [](const StoryBox& b) { return b.depth; });
  box_dict["hit"] = column<bool>(st.boxes, [](const StoryBox& b) { return b.hit; });
  box_dict["t_entry"] = column<float>(st.boxes, [](const StoryBox& b) { return b.hit ? b.t_entry : kInfinity; });
  box_dict["node"] = column<int32_t>(st.boxes, [](const StoryBox& b) { return b.node; });

  py::dict d;
  d["status"] = ray_status_name(st.status);
  d["boxes"] = box_dict;
  d["nodes"] = column<int32_t>(st.nodes, [](const StoryNode& n) { return n.node; });
  d["node_depths"] = column<int32_t>(st.nodes, [](const StoryNode& n) { return n.depth; });
  d["triangles"] = column<int32_t>(st.triangles, [](const StoryTriangle& t) { return t.triangle; });
  d["triangle_hits"] = column<bool>(st.triangles, [](const StoryTriangle& t) { return t.hit; });
  if (st.hit.valid()) {
    py::dict hit;
    hit["t"] = st.hit.t;
    hit["triangle"] = int32_t(st.hit.triangle);
    hit["u"] = st.hit.u;
    hit["v"] = st.hit.v;
    const glm::vec3 point = ray.at(st.hit.t);
    hit["point"] = py::array_t<float>(3, &point.x);
    d["hit"] = hit;
  } else {
    d["hit"] = py::none();
  }
  d["stats"] = stats_to_dict(st.stats);
  return d;
}

// Closest hits plus each ray's status as an index into RAY_STATUSES.
py::dict statuses(const Structure& s, py::handle origins, py::handle directions, py::handle tmin, py::handle tmax) {
  const std::vector<Ray> rays = rays_from_arrays(origins, directions, tmin, tmax);
  std::vector<Hit> hits(rays.size());
  std::vector<RayStatus> status(rays.size());
  {
    py::gil_scoped_release release;
    intersect_with_status(s, rays, hits, status);
  }
  py::dict d = hits_to_dict(hits, true);
  d["status"] = column<int8_t>(status, [](RayStatus r) { return int8_t(r); });
  return d;
}

}  // namespace

void bind_core(py::module_& m) {
  py::register_exception<BuildError>(m, "BuildError", PyExc_RuntimeError);

  m.def(
      "load_mesh",
      [](py::handle path) { return mesh_to_arrays(read_mesh_file(path_parameter(path, "path"))); }, py::arg("path"),
      "Reads an OBJ file: ((V,3) float32 vertices, (T,3) uint32 triangles).");

  py::class_<Structure, StructurePtr>(m, "Structure", "An acceleration structure over one mesh (keeps it alive).")
      .def_property_readonly("structure", [](const Structure& s) { return structure_kind_name(s.kind()); })
      .def_property_readonly("build_seconds", &Structure::build_seconds)
      .def_property_readonly("memory_bytes", &Structure::memory_bytes)
      .def_property_readonly("triangle_count", [](const Structure& s) { return s.mesh().triangle_count(); })
      .def_property_readonly("vertex_count", [](const Structure& s) { return s.mesh().vertices.size(); })
      .def_property_readonly("max_depth", [](const Structure& s) { return max_depth_object(s.settings().max_depth); })
      .def_property_readonly("leaf_size", [](const Structure& s) { return s.settings().leaf_size; })
      .def_property_readonly("triangle_test",
                             [](const Structure& s) { return triangle_test_name(s.settings().triangle_test); })
      .def_property_readonly("mesh", [](const Structure& s) { return mesh_to_arrays(s.mesh()); },
                             "A copy of the mesh: (vertices, triangles).")
      .def("intersect", &intersect_rays<Structure>, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
           py::arg("tmax") = kNoLimit, py::arg("count") = false)
      .def("occluded", &occluded_rays<Structure>, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
           py::arg("tmax") = kNoLimit, py::arg("count") = false)
      .def("boxes", &boxes)
      .def("statuses", &statuses, py::arg("origins"), py::arg("directions"), py::arg("tmin") = 0.0,
           py::arg("tmax") = kNoLimit)
      .def("story", &story, py::arg("origin"), py::arg("direction"), py::arg("tmin") = 0.0,
           py::arg("tmax") = kNoLimit);

  with_settings_keywords(
      [&](auto... keywords) {
        m.def(
            "build",
            [](py::handle vertices, py::handle triangles, py::handle structure, py::handle max_depth,
               py::handle leaf_size, py::handle triangle_test, py::handle memory_budget) {
              const BuildSettings settings =
                  settings_from_arguments(structure, max_depth, leaf_size, triangle_test, memory_budget);
              return build(mesh_from_arrays(vertices, triangles), settings);
            },
            keywords...);
      },
      py::arg("vertices"), py::arg("triangles"));

  with_settings_keywords(
      [&](auto... keywords) {
        m.def(
            "build_file",
            [](py::handle path, py::handle structure, py::handle max_depth, py::handle leaf_size,
               py::handle triangle_test, py::handle memory_budget) {
              const std::string file = path_parameter(path, "path");
              const BuildSettings settings =
                  settings_from_arguments(structure, max_depth, leaf_size, triangle_test, memory_budget);
              return build(std::make_shared<const TriangleMesh>(read_mesh_file(file)), settings);
            },
            keywords...);
      },
      py::arg("path"));

  bind_scene(m);
}

}  // namespace raylab::python
