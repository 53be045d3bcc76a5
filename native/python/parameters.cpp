#include "parameters.h"

#include <pybind11/numpy.h>

#include <cstring>
#include <limits>

namespace raylab::python {

namespace {

constexpr size_t kLongest = 40;  // characters of a value shown in a message

[[noreturn]] void fail(const std::string& name, const std::string& accepted, py::handle value) {
  throw py::value_error(name + " must be " + accepted + ", got " + describe(value));
}

// The value as a Python int when it is a whole number (int, numpy integer) and not a bool, which
// Python counts as an int but no caller means as one.
py::object as_index(py::handle value) {
  if (value.is_none() || PyBool_Check(value.ptr()) || !PyIndex_Check(value.ptr())) return py::object();
  PyObject* index = PyNumber_Index(value.ptr());
  if (!index) PyErr_Clear();
  return py::reinterpret_steal<py::object>(index);
}

// The int's value, or false when it does not fit in 64 bits.
bool fits_int64(const py::object& index, int64_t& out) {
  int overflow = 0;
  const long long x = PyLong_AsLongLongAndOverflow(index.ptr(), &overflow);
  if (overflow != 0 || (x == -1 && PyErr_Occurred())) {
    PyErr_Clear();
    return false;
  }
  out = x;
  return true;
}

std::string shortened(std::string text) {
  if (text.size() > kLongest) text = text.substr(0, kLongest - 3) + "...";
  return text;
}

}  // namespace

std::string describe(py::handle value) {
  PyObject* p = value.ptr();
  if (value.is_none() || PyBool_Check(p) || PyFloat_Check(p) || PyUnicode_Check(p)) {
    const py::object text = py::reinterpret_steal<py::object>(PyObject_Repr(p));
    if (text) return shortened(text.cast<std::string>());
    PyErr_Clear();
  } else if (PyLong_Check(p)) {
    // repr() of a huge int is slow, or refused beyond sys.get_int_max_str_digits().
    const size_t bits = value.attr("bit_length")().cast<size_t>();
    if (bits > 128) return "an integer of " + std::to_string(bits) + " bits";
    return shortened(py::repr(value).cast<std::string>());
  } else if (const py::object index = as_index(value)) {
    return describe(index);  // a numpy integer: its value
  }
  return std::string("a value of type ") + Py_TYPE(p)->tp_name;
}

int64_t integer_parameter(py::handle value, const std::string& name, int64_t lo, int64_t hi, const char* accepted) {
  const std::string expected =
      accepted ? std::string(accepted) : "an integer from " + std::to_string(lo) + " to " + std::to_string(hi);
  const py::object index = as_index(value);
  int64_t x = 0;
  if (!index || !fits_int64(index, x) || x < lo || x > hi) fail(name, expected, value);
  return x;
}

int int32_parameter(py::handle value, const std::string& name) {
  return int(integer_parameter(value, name, std::numeric_limits<int32_t>::min(), std::numeric_limits<int32_t>::max(),
                               "an integer that fits in 32 bits"));
}

int threads_parameter(py::handle value) {
  if (value.is_none()) return 0;
  return int(integer_parameter(value, "threads", 0, std::numeric_limits<int32_t>::max(),
                               "None or an integer from 0 to 2147483647 (None or 0: all cores)"));
}

uint32_t id_parameter(py::handle value, size_t count, const char* what) {
  const py::object index = as_index(value);
  if (!index) fail(what, "an integer id", value);
  int64_t x = 0;
  if (!fits_int64(index, x) || x < 0 || uint64_t(x) >= count)
    throw py::value_error("unknown " + std::string(what) + " id " + describe(value) + ": the scene has " +
                          std::to_string(count) + " " + what + (count == 1 ? "" : "s"));
  return uint32_t(x);
}

double number_parameter(py::handle value, const std::string& name) {
  PyObject* p = value.ptr();
  // float() would also take a one-element array or a numeric string; neither is meant as a number.
  const bool array = py::isinstance<py::array>(value) && py::reinterpret_borrow<py::array>(value).ndim() > 0;
  if (value.is_none() || PyBool_Check(p) || PyUnicode_Check(p) || PyBytes_Check(p) || array)
    fail(name, "a real number", value);
  const double x = PyFloat_AsDouble(p);
  if (x == -1.0 && PyErr_Occurred()) {
    PyErr_Clear();
    fail(name, "a real number", value);
  }
  return x;
}

size_t memory_budget_parameter(py::handle value, const std::string& name, bool or_none) {
  const py::object index = as_index(value);  // an int or a numpy integer, as every other setting takes
  if (!index)
    throw std::invalid_argument(name + " must be a whole number of bytes" + (or_none ? " or None" : "") + ", got " +
                                describe(value));
  const py::int_ budget = py::reinterpret_borrow<py::int_>(index);
  if (budget < py::int_(1)) throw std::invalid_argument(name + " must be positive, got " + describe(budget));
  return budget > py::int_(std::numeric_limits<size_t>::max()) ? std::numeric_limits<size_t>::max()
                                                               : budget.cast<size_t>();
}

bool bool_parameter(py::handle value, const std::string& name) {
  PyObject* p = value.ptr();
  if (p == Py_True) return true;
  if (p == Py_False) return false;
  const char* type = Py_TYPE(p)->tp_name;
  if (std::strcmp(type, "numpy.bool_") == 0 || std::strcmp(type, "numpy.bool") == 0) return PyObject_IsTrue(p) == 1;
  if (const py::object index = as_index(value)) {
    int64_t x = -1;
    if (fits_int64(index, x) && (x == 0 || x == 1)) return x == 1;
  }
  fail(name, "True or False", value);
}

std::string str_parameter(py::handle value, const std::string& name, const char* accepted) {
  if (PyUnicode_Check(value.ptr())) {
    Py_ssize_t size = 0;
    if (const char* text = PyUnicode_AsUTF8AndSize(value.ptr(), &size)) return std::string(text, size_t(size));
    PyErr_Clear();  // a lone surrogate: no UTF-8 for it
  }
  fail(name, std::string("a str: ") + accepted, value);
}

std::string path_parameter(py::handle value, const std::string& name) {
  const py::module_ os = py::module_::import("os");
  py::object path;
  try {
    path = os.attr("fspath")(value);
    // The file system's own bytes, as open() would use them (surrogate escapes included).
    if (PyUnicode_Check(path.ptr())) path = os.attr("fsencode")(path);
  } catch (py::error_already_set& e) {
    if (!e.matches(PyExc_TypeError) && !e.matches(PyExc_UnicodeError)) throw;
    fail(name, "a str, bytes or os.PathLike", value);
  }
  return std::string(PyBytes_AS_STRING(path.ptr()), size_t(PyBytes_GET_SIZE(path.ptr())));
}

}  // namespace raylab::python
