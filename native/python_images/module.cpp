// The `_raylab_images` extension module: raylab.write_image through OpenImageIO, and read_channels
// (every channel of a file by name, what the tests read multilayer EXRs with). It is a module of its
// own so that the one Blender loads (`_raylab`) needs no OpenImageIO, whose Debian build pulls in some
// 250 shared libraries (codecs, OpenCV, ...): the Blender extension ships `_raylab` alone and saves
// images through Blender (api.write_image).
#include "raylab/image_io.h"

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>
#include <vector>

namespace py = pybind11;

namespace {

[[noreturn]] void value_error(const std::string& message) { throw py::value_error(message); }

void write_image_from_python(py::handle path_object, py::handle image_object) {
  const std::string path = py::module_::import("os").attr("fspath")(path_object).cast<std::string>();
  py::array_t<float, py::array::c_style | py::array::forcecast> image;
  try {
    image =
        py::array_t<float, py::array::c_style | py::array::forcecast>(py::reinterpret_borrow<py::object>(image_object));
  } catch (const py::error_already_set&) {
    value_error("image must be an array of numbers");
  }
  if (image.ndim() != 3 || (image.shape(2) != 3 && image.shape(2) != 4) || image.shape(0) == 0 || image.shape(1) == 0)
    value_error("image must be (H, W, 4) or (H, W, 3) with H, W > 0");
  const int h = int(image.shape(0)), w = int(image.shape(1)), channels = int(image.shape(2));
  std::vector<float> rgba(size_t(w) * h * 4, 1.0f);  // a missing alpha is opaque
  const float* src = image.data();
  for (size_t p = 0; p < size_t(w) * h; ++p)
    for (int c = 0; c < channels; ++c) rgba[p * 4 + c] = src[p * channels + c];
  py::gil_scoped_release release;
  raylab::write_image(path, rgba, w, h);
}

// Every channel by name -> (H, W) float32, row 0 the top row.
py::dict read_channels_from_python(py::handle path_object) {
  const std::string path = py::module_::import("os").attr("fspath")(path_object).cast<std::string>();
  raylab::ImageChannels image;
  {
    py::gil_scoped_release release;
    image = raylab::read_channels(path);
  }
  const size_t n = image.names.size(), pixels = size_t(image.width) * size_t(image.height);
  py::dict out;
  for (size_t c = 0; c < n; ++c) {
    py::array_t<float> a({py::ssize_t(image.height), py::ssize_t(image.width)});
    float* p = a.mutable_data();
    for (size_t i = 0; i < pixels; ++i) p[i] = image.pixels[i * n + c];
    out[py::str(image.names[c])] = a;
  }
  return out;
}

}  // namespace

PYBIND11_MODULE(_raylab_images, m) {
  m.doc() = "raylab's image files (OpenImageIO)";
  m.def("write_image", &write_image_from_python, py::arg("path"), py::arg("image"),
        "Writes an (H, W, 4) linear image: .png 8-bit sRGB-encoded, .exr float.");
  m.def("read_channels", &read_channels_from_python, py::arg("path"),
        "Reads every channel of an image file: {channel name: (H, W) float32, row 0 the top row}; a "
        "multilayer EXR's names are 'ViewLayer.Pass.Channel'. RuntimeError naming the path if unreadable.");
}
