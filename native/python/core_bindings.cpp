#include "bindings.h"
// Placeholder until the core bindings land.
void raylab::python::bind_core(pybind11::module_&) {}
