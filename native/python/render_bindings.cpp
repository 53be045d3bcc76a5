// The renderer: raylab.render(scene, camera, lights, materials, settings, progress).
// Every dict is read here, with the GIL held, so that a missing or
// unknown key or a bad value is a ValueError naming it; the render itself runs on a worker thread
// while the calling thread, with the GIL released, wakes a few times a second to report progress.
#include "bindings.h"
#include "core_arrays.h"

#include "raylab/renderer.h"

#include <pybind11/numpy.h>

#include <array>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <thread>
#include <vector>

namespace raylab::python {

namespace py = pybind11;

namespace {

[[noreturn]] void value_error(const std::string& message) { throw py::value_error(message); }

// Reads one settings dict: every key it does not know is an error, as is a missing required key.
class Fields {
 public:
  Fields(py::handle object, std::string what) : what_(std::move(what)) {
    if (!py::isinstance<py::dict>(object)) value_error(what_ + " must be a dict");
    dict_ = py::reinterpret_borrow<py::dict>(object);
    for (auto item : dict_) {
      if (!py::isinstance<py::str>(item.first)) value_error(what_ + " has a key that is not a string");
      unused_.insert(item.first.cast<std::string>());
    }
  }

  double number(const char* key, double fallback) {
    const py::object v = take(key);
    if (!v) return fallback;
    const double d = number_parameter(v, name(key));
    if (!std::isfinite(d)) value_error(name(key) + " must be finite");
    return d;
  }
  int integer(const char* key, int fallback) {
    const py::object v = take(key);
    if (!v) return fallback;
    return int32_parameter(v, name(key));
  }
  size_t bytes(const char* key, size_t fallback) {
    const py::object v = take(key);
    return v ? memory_budget_parameter(v, name(key)) : fallback;
  }
  bool boolean(const char* key, bool fallback) {
    const py::object v = take(key);
    if (!v) return fallback;
    return bool_parameter(v, name(key));
  }
  glm::vec3 color(const char* key, glm::vec3 fallback) {
    const py::object v = take(key);
    if (!v) return fallback;
    // Blender colours come with 3 or 4 channels; alpha is not used.
    const auto a = as_array(v, key);
    if (a.ndim() != 1 || (a.shape(0) != 3 && a.shape(0) != 4)) value_error(name(key) + " must have 3 or 4 components");
    const glm::vec3 c(float(a.at(0)), float(a.at(1)), float(a.at(2)));
    if (!std::isfinite(c.x) || !std::isfinite(c.y) || !std::isfinite(c.z)) value_error(name(key) + " must be finite");
    return c;
  }
  // (4, 4) row-major (numpy's and Blender's layout) to glm's column-major matrix. Required.
  glm::mat4 matrix(const char* key) {
    const py::object v = take(key);
    if (!v) value_error(what_ + " is missing the key '" + key + "'");
    const auto a = as_array(v, key);
    if (a.ndim() != 2 || a.shape(0) != 4 || a.shape(1) != 4) value_error(name(key) + " must be a (4, 4) matrix");
    glm::mat4 m;
    for (int row = 0; row < 4; ++row)
      for (int col = 0; col < 4; ++col) {
        const double x = a.at(row, col);
        if (!std::isfinite(x)) value_error(name(key) + " has a NaN or infinite entry");
        m[col][row] = float(x);
      }
    return m;
  }
  // One of `choices`; returns its position.
  int choice(const char* key, std::initializer_list<const char*> choices, int fallback, bool required = false) {
    return choice(key, std::span<const char* const>(choices.begin(), choices.size()), fallback, required);
  }
  int choice(const char* key, std::span<const char* const> choices, int fallback, bool required = false) {
    const py::object v = take(key);
    if (!v) {
      if (required) value_error(what_ + " is missing the key '" + key + "'");
      return fallback;
    }
    std::string list;
    if (py::isinstance<py::str>(v)) {
      const std::string s = v.cast<std::string>();
      int i = 0;
      for (const char* c : choices) {
        if (s == c) return i;
        ++i;
      }
    }
    for (const char* c : choices) list += std::string(list.empty() ? "" : ", ") + "'" + c + "'";
    value_error(name(key) + " must be one of " + list + ", got " + describe(v));
  }
  // A row of a vocabulary table (rows with a `name`) by its name.
  template <class Row, size_t N>
  const Row& row(const char* key, const Row (&table)[N], const Row& fallback) {
    std::array<const char*, N> names;
    for (size_t i = 0; i < N; ++i) names[i] = table[i].name;
    return table[choice(key, names, int(&fallback - table))];
  }
  bool has(const char* key) const { return dict_.contains(key); }
  // Call after reading every key.
  void finish() const {
    if (!unused_.empty()) value_error(what_ + " has an unknown key '" + *unused_.begin() + "'");
  }

 private:
  py::object take(const char* key) {
    unused_.erase(key);
    return dict_.contains(key) ? py::object(dict_[key]) : py::object();
  }
  std::string name(const char* key) const { return what_ + "['" + key + "']"; }
  py::array_t<double> as_array(const py::object& v, const char* key) const {
    try {
      return py::array_t<double, py::array::c_style | py::array::forcecast>(v);
    } catch (const py::error_already_set&) {
      value_error(name(key) + " must be an array of numbers");
    }
  }

  py::dict dict_;
  std::string what_;
  std::set<std::string> unused_;
};

CameraSettings camera_from_dict(py::handle object) {
  Fields f(object, "camera");
  CameraSettings c;
  c.type = f.choice("type", {"PERSP", "ORTHO"}, 0) == 0 ? CameraType::Perspective : CameraType::Orthographic;
  c.matrix_world = f.matrix("matrix_world");
  c.lens = float(f.number("lens", c.lens));
  c.sensor_width = float(f.number("sensor_width", c.sensor_width));
  c.sensor_height = float(f.number("sensor_height", c.sensor_height));
  c.sensor_fit = SensorFit(f.choice("sensor_fit", {"AUTO", "HORIZONTAL", "VERTICAL"}, 0));
  c.shift_x = float(f.number("shift_x", c.shift_x));
  c.shift_y = float(f.number("shift_y", c.shift_y));
  c.ortho_scale = float(f.number("ortho_scale", c.ortho_scale));
  c.clip_start = float(f.number("clip_start", c.clip_start));
  c.clip_end = float(f.number("clip_end", c.clip_end));
  c.resolution_x = f.integer("resolution_x", c.resolution_x);
  c.resolution_y = f.integer("resolution_y", c.resolution_y);
  c.resolution_percentage = f.integer("resolution_percentage", c.resolution_percentage);
  c.pixel_aspect_x = float(f.number("pixel_aspect_x", c.pixel_aspect_x));
  c.pixel_aspect_y = float(f.number("pixel_aspect_y", c.pixel_aspect_y));
  f.finish();
  c.validate();
  return c;
}

std::vector<Light> lights_from_list(py::handle object) {
  if (!py::isinstance<py::sequence>(object) || py::isinstance<py::str>(object) || py::isinstance<py::dict>(object))
    value_error("lights must be a list of dicts");
  std::vector<Light> lights;
  const auto seq = py::reinterpret_borrow<py::sequence>(object);
  for (size_t i = 0; i < seq.size(); ++i) {
    const std::string what = "lights[" + std::to_string(i) + "]";
    Fields f(seq[i], what);
    Light l;
    l.type = LightType(f.choice("type", {"POINT", "SUN", "SPOT", "AREA"}, 0, true));
    l.matrix_world = f.matrix("matrix_world");
    l.color = f.color("color", l.color);
    l.energy = float(f.number("energy", l.energy));
    l.radius = float(f.number("radius", l.radius));
    l.spot_size = float(f.number("spot_size", l.spot_size));
    l.spot_blend = float(f.number("spot_blend", l.spot_blend));
    l.size = float(f.number("size", l.size));
    l.samples = f.integer("samples", l.samples);
    l.shadows = f.boolean("shadows", l.shadows);
    f.finish();
    try {
      l.validate();
    } catch (const std::invalid_argument& e) {
      value_error(what + ": " + e.what());
    }
    lights.push_back(l);
  }
  return lights;
}

std::vector<Material> materials_from_list(py::handle object) {
  if (!py::isinstance<py::sequence>(object) || py::isinstance<py::str>(object) || py::isinstance<py::dict>(object))
    value_error("materials must be a list of dicts");
  std::vector<Material> materials;
  const auto seq = py::reinterpret_borrow<py::sequence>(object);
  for (size_t i = 0; i < seq.size(); ++i) {
    const std::string what = "materials[" + std::to_string(i) + "]";
    Fields f(seq[i], what);
    Material m;
    m.diffuse = f.color("diffuse", m.diffuse);
    m.specular = float(f.number("specular", m.specular));
    m.shininess = float(f.number("shininess", m.shininess));
    m.metallic = float(f.number("metallic", m.metallic));
    m.reflectivity = float(f.number("reflectivity", m.reflectivity));
    m.transmission = float(f.number("transmission", m.transmission));
    m.ior = float(f.number("ior", m.ior));
    m.ambient = float(f.number("ambient", m.ambient));
    f.finish();
    try {
      m.validate();
    } catch (const std::invalid_argument& e) {
      value_error(what + ": " + e.what());
    }
    materials.push_back(m);
  }
  return materials;
}

RenderSettings settings_from_dict(py::handle object) {
  RenderSettings s;
  if (object.is_none()) return s;
  Fields f(object, "settings");
  s.super_sampling = f.integer("super_sampling", s.super_sampling);
  s.max_recursion = f.integer("max_recursion", s.max_recursion);
  // The recursion depth was called max_depth, the octree's build setting's name.
  if (f.has("max_depth"))
    value_error("settings: max_depth is now max_recursion (the octree's max_depth is a build setting)");
  s.shadows = f.boolean("shadows", s.shadows);
  s.background = f.color("background", s.background);
  s.ambient = f.color("ambient", s.ambient);
  s.robust_offset = f.boolean("robust_offset", s.robust_offset);
  s.fixed_epsilon = float(f.number("fixed_epsilon", s.fixed_epsilon));
  s.shadow_terminator = f.boolean("shadow_terminator", s.shadow_terminator);
  s.threads = f.integer("threads", s.threads);
  s.tile_size = f.integer("tile_size", s.tile_size);
  s.cost_rays = f.row("cost_rays", kCostRays, kCostRays[0]).value;
  s.memory_budget = f.bytes("memory_budget", s.memory_budget);
  s.batches = f.boolean("batches", s.batches);
  f.finish();
  try {
    s.validate();
  } catch (const std::invalid_argument& e) {
    value_error(std::string("settings: ") + e.what());
  }
  return s;
}

// The native scene behind either the bound class or api.py's wrapper of it (its `native`).
const Scene& scene_of(py::handle object) {
  if (py::isinstance<Scene>(object)) return object.cast<const Scene&>();
  if (py::hasattr(object, "native")) {
    const py::object native = object.attr("native");
    if (py::isinstance<Scene>(native)) return native.cast<const Scene&>();
  }
  throw py::type_error("scene must be a raylab.Scene");
}

struct PyRenderResult {
  py::array_t<float> image;
  bool cancelled;
  py::dict stats;
  py::array_t<int32_t> instance;
  py::array_t<float> distance;
  std::vector<TraversalStats> pixel_work;
  py::object cost;  // made from pixel_work on first read: a render nobody asks for its cost pays no copies
};

template <class T>
py::array_t<T> to_array(const std::vector<T>& data, std::vector<py::ssize_t> shape) {
  py::array_t<T> a(shape);
  std::copy(data.begin(), data.end(), a.mutable_data());
  return a;
}

// Every counter of every pixel: name -> (H, W) float32, row 0 the top row. float32, as a render pass
// holds it: exact up to 2^24 per pixel.
py::dict cost_dict(const std::vector<TraversalStats>& work, py::ssize_t h, py::ssize_t w) {
  py::dict d;
  for (const CounterInfo& c : kCounters) {
    py::array_t<float> a({h, w});
    float* p = a.mutable_data();
    for (size_t i = 0; i < work.size(); ++i) p[i] = float(work[i].*c.field);
    d[c.name] = a;
  }
  return d;
}

py::dict stats_dict(const RenderStats& s) {
  py::dict d = stats_to_dict(s.traversal);  // rays (all traced), rays_ignored, box/triangle tests, nodes
  d["rays_primary"] = s.rays_primary;
  d["rays_shadow"] = s.rays_shadow;
  d["rays_reflection"] = s.rays_reflection;
  d["rays_refraction"] = s.rays_refraction;
  d["build_seconds"] = s.build_seconds;
  d["render_seconds"] = s.render_seconds;
  d["memory_bytes"] = s.memory_bytes;
  d["structure"] = s.structure;
  d["width"] = s.width;
  d["height"] = s.height;
  return d;
}

PyRenderResult render_from_python(py::handle scene_object, py::handle camera_dict, py::handle light_list,
                                  py::handle material_list, py::handle settings_dict, py::handle progress) {
  const Scene& scene = scene_of(scene_object);
  const CameraSettings camera = camera_from_dict(camera_dict);
  const std::vector<Light> lights = lights_from_list(light_list);
  const std::vector<Material> materials = materials_from_list(material_list);
  const RenderSettings settings = settings_from_dict(settings_dict);
  {
    // Checked here, before anything is allocated: the result's numpy copies (image, instance,
    // distance) and its cost arrays (one float per counter, made when read) live beside its buffers.
    constexpr size_t copies =
        4 * sizeof(float) + sizeof(int32_t) + sizeof(float) + std::size(kCounters) * sizeof(float);
    const Camera view(camera);
    try {
      require_render_memory(view.width(), view.height(), settings, copies);
    } catch (const std::invalid_argument& e) {
      value_error(std::string("settings: ") + e.what());
    }
  }
  const bool reports = !progress.is_none();
  if (reports && !PyCallable_Check(progress.ptr())) throw py::type_error("progress must be callable or None");

  // Taken here, on the caller's thread (whose uncommitted changes it refuses), and held until the
  // render ends: commits from other threads meanwhile change nothing it reads.
  const SceneSnapshotPtr snapshot = scene.snapshot();

  RenderProgress state;
  std::optional<py::error_already_set> python_error;
  // A true answer, an exception or Ctrl-C cancels; the exception is raised once the render stopped.
  const auto report = [&] {
    try {
      if (py::bool_(progress(state.fraction()))) state.cancel();
    } catch (py::error_already_set& e) {
      python_error.emplace(std::move(e));
      state.cancel();
    }
  };
  if (reports) report();  // a caller that cancels at once gets no work done

  RenderResult result;
  std::exception_ptr failure;
  {
    py::gil_scoped_release release;
    std::mutex mutex;
    std::condition_variable finished;
    bool done = false;
    std::thread worker([&] {
      try {
        result = render(*snapshot, camera, lights, materials, settings, &state);
      } catch (...) {
        failure = std::current_exception();
      }
      std::lock_guard lock(mutex);
      done = true;
      finished.notify_all();
    });
    std::unique_lock lock(mutex);
    while (!finished.wait_for(lock, std::chrono::milliseconds(100), [&] { return done; })) {
      if (state.cancel_requested.load()) continue;
      lock.unlock();
      {
        py::gil_scoped_acquire acquire;
        if (PyErr_CheckSignals() != 0) {
          python_error.emplace();  // takes the pending KeyboardInterrupt
          state.cancel();
        } else if (reports) {
          report();
        }
      }
      lock.lock();
    }
    lock.unlock();
    worker.join();
  }
  if (python_error) throw std::move(*python_error);
  if (failure) std::rethrow_exception(failure);

  const py::ssize_t h = result.height, w = result.width;
  PyRenderResult out{to_array(result.image, {h, w, 4}),
                     result.cancelled,
                     stats_dict(result.stats),
                     to_array(result.instance, {h, w}),
                     to_array(result.distance, {h, w}),
                     std::move(result.pixel_work),
                     py::none()};
  if (out.stats["structure"].cast<std::string>().empty() && py::hasattr(scene_object, "structure"))
    out.stats["structure"] = py::str(scene_object.attr("structure"));
  return out;
}

}  // namespace

void bind_render(py::module_& m) {
  py::class_<PyRenderResult>(m, "RenderResult", "A rendered image with its statistics.")
      .def_readonly("image", &PyRenderResult::image, "(H, W, 4) float32 linear RGBA, row 0 the top row")
      .def_readonly("cancelled", &PyRenderResult::cancelled)
      .def_readonly("stats", &PyRenderResult::stats)
      .def_readonly("instance", &PyRenderResult::instance, "(H, W) int32 instance of the pixel-centre ray, -1 on miss")
      .def_readonly("distance", &PyRenderResult::distance, "(H, W) float32 distance of that hit, inf on miss")
      .def_property_readonly(
          "cost",
          [](PyRenderResult& r) {
            if (r.cost.is_none()) r.cost = cost_dict(r.pixel_work, r.image.shape(0), r.image.shape(1));
            return r.cost;
          },
          "Each pixel's traversal work: every COUNTERS name -> (H, W) float32, row 0 the top row, "
          "summed over the rays settings['cost_rays'] names (all, or primary) of all its samples")
      .def("__repr__", [](const PyRenderResult& r) {
        return "<raylab.RenderResult " + std::to_string(r.image.shape(1)) + "x" + std::to_string(r.image.shape(0)) +
               (r.cancelled ? " cancelled>" : ">");
      });

  m.def(
      "camera_rays",
      [](py::handle camera_dict, py::handle points) {
        const Camera camera(camera_from_dict(camera_dict));
        const auto points_array = real_array<double>(points, "points");
        if (!points_array || points_array->ndim() != 2 || points_array->shape(1) != 2)
          throw std::invalid_argument("points must be an (N, 2) array of raster coordinates");
        const auto& raster = *points_array;
        const py::ssize_t n = raster.shape(0);
        py::array_t<float> origins({n, py::ssize_t(3)}), directions({n, py::ssize_t(3)});
        float* o = origins.mutable_data();
        float* d = directions.mutable_data();
        for (py::ssize_t i = 0; i < n; ++i) {
          const double x = raster.at(i, 0), y = raster.at(i, 1);
          if (!std::isfinite(x) || !std::isfinite(y))
            throw std::invalid_argument("points must be finite; row " + std::to_string(i) + " is not");
          const Ray r = camera.ray(float(x), float(y));
          for (int c = 0; c < 3; ++c) {
            o[3 * i + c] = r.origin[c];
            d[3 * i + c] = r.direction[c];
          }
        }
        py::dict out;
        out["origins"] = origins;
        out["directions"] = directions;
        out["width"] = camera.width();
        out["height"] = camera.height();
        return out;
      },
      py::arg("camera"), py::arg("points"),
      "The renderer's own camera rays: unit world rays through (N, 2) raster points (x to the right, y down "
      "from the top edge; pixel (i, j) has its centre at (i + 0.5, j + 0.5)) of a camera dict as render "
      "takes it. Returns origins, directions, and the image's width and height.");

  m.def("render", &render_from_python, py::arg("scene"), py::arg("camera"), py::arg("lights"), py::arg("materials"),
        py::arg("settings") = py::none(), py::arg("progress") = py::none(),
        "Renders a committed raylab.Scene; progress(fraction) is called several times a second and "
        "cancels the render by returning True. settings (all optional): super_sampling (1-4), max_recursion (0-64), "
        "shadows, background, ambient, robust_offset, fixed_epsilon, shadow_terminator, threads, tile_size, "
        "cost_rays (one of COST_RAYS: which of a pixel's rays its result.cost counts), memory_budget (bytes "
        "the render's buffers and the result's arrays may take; resolutions beyond it are refused), batches "
        "(trace camera and shadow rays in coherent batches, the default; False: one ray at a time, the same "
        "image, counters and cost bit for bit).");
}

}  // namespace raylab::python
