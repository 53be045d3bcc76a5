// Scalar arguments of the Python API (integers, ids, numbers, flags, names, paths), read from any
// Python object. The bound functions take py::handle instead of C++ types because pybind11's own
// conversion failure is a TypeError that names no parameter and prints every argument, arrays
// included; here a wrong type or range is a short ValueError that names the parameter and what it
// accepts.
#pragma once

#include <pybind11/pybind11.h>

#include <cstdint>
#include <string>

namespace raylab::python {

namespace py = pybind11;

// At most a few dozen characters about a value for an error message: the repr of a number, a short
// string or None (shortened when long), else only its type.
std::string describe(py::handle value);

// A whole number in [lo, hi] (int or numpy integer; not bool, not float). `accepted` replaces the
// generic "an integer from lo to hi" in the message when given.
int64_t integer_parameter(py::handle value, const std::string& name, int64_t lo, int64_t hi,
                          const char* accepted = nullptr);
// A whole number that fits the C++ int (range checks stay with the settings' own validate()).
int int32_parameter(py::handle value, const std::string& name);
// An index into a list of `count` items named `what` ("mesh", "instance").
uint32_t id_parameter(py::handle value, size_t count, const char* what);
// How many threads a batch query may use: None or 0 for all cores, else a positive integer.
int threads_parameter(py::handle value);
// A real number (int, float or numpy scalar; not bool); NaN and infinities pass through.
double number_parameter(py::handle value, const std::string& name);
// A positive whole number of bytes (a structure's or a render's memory budget); anything beyond
// size_t is no limit at all. `or_none`: the message says None is accepted too (the caller's default).
size_t memory_budget_parameter(py::handle value, const std::string& name, bool or_none = false);
// True or False (numpy.bool_ and the integers 0 and 1 as well).
bool bool_parameter(py::handle value, const std::string& name);
// A str; `accepted` says which ones, for the message ("none, aabb, octree or bvh").
std::string str_parameter(py::handle value, const std::string& name, const char* accepted);
// A str, bytes or os.PathLike, as the file system's bytes.
std::string path_parameter(py::handle value, const std::string& name);

}  // namespace raylab::python
