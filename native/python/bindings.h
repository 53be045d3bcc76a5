// Each bindings file registers one part of the module.
#pragma once

#include <pybind11/pybind11.h>

namespace raylab::python {

void bind_core(pybind11::module_& m);        // core_bindings.cpp: meshes, structures, scenes, queries
void bind_render(pybind11::module_& m);      // render_bindings.cpp: the renderer
void bind_vocabulary(pybind11::module_& m);  // vocabulary.cpp: structure kinds, triangle tests, counters, defaults

}  // namespace raylab::python
