// The `_raylab` extension module; the pieces live one concept per file and register here.
#include "bindings.h"

PYBIND11_MODULE(_raylab, m) {
  m.doc() = "raylab native core: acceleration structures, scenes and the renderer";
  raylab::python::bind_vocabulary(m);
  raylab::python::bind_core(m);
  raylab::python::bind_render(m);
}
