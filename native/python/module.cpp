#include <pybind11/pybind11.h>
namespace py = pybind11;
// Placeholder until the bindings land.
PYBIND11_MODULE(_raylab, m) { m.attr("__version__") = "0.1.0"; }
