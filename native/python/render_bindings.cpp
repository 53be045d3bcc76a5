#include "bindings.h"
// Placeholder until the renderer bindings land.
void raylab::python::bind_render(pybind11::module_&) {}
