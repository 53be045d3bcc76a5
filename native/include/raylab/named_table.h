// The two look-ups of a vocabulary table (an array of infos, each a value and its name: kTriangleTests,
// kContracts), once: a value's name, and a name's value with an error that lists every name.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>

namespace raylab {

template <class Info, size_t N, class Value>
const char* name_in(const Info (&table)[N], Value Info::*field, Value value) {
  for (const Info& info : table)
    if (info.*field == value) return info.name;
  return "?";
}

// Throws std::invalid_argument: "unknown <what> '<name>': expected a or b".
template <class Info, size_t N, class Value>
Value value_in(const Info (&table)[N], Value Info::*field, const std::string& name, const char* what) {
  std::string names;
  for (const Info& info : table) {
    if (name == info.name) return info.*field;
    names += (names.empty() ? "" : " or ") + std::string(info.name);
  }
  throw std::invalid_argument("unknown " + std::string(what) + " '" + name + "': expected " + names);
}

}  // namespace raylab
