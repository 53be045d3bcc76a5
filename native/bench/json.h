// Just enough JSON output for the benchmark: values are composed as strings, inside out.
#pragma once

#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

namespace raylab::bench::json {

using Member = std::pair<std::string, std::string>;

inline std::string str(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

inline std::string num(double x) {
  if (!std::isfinite(x)) return "null";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", x);
  return buf;
}

inline std::string object(const std::vector<Member>& members) {
  std::string out = "{";
  for (size_t i = 0; i < members.size(); ++i)
    out += (i ? ", " : "") + str(members[i].first) + ": " + members[i].second;
  return out + "}";
}

inline std::string array(const std::vector<std::string>& values) {
  std::string out = "[";
  for (size_t i = 0; i < values.size(); ++i) out += (i ? ", " : "") + values[i];
  return out + "]";
}

inline std::string numbers(const std::vector<double>& values) {
  std::vector<std::string> s;
  for (double v : values) s.push_back(num(v));
  return array(s);
}

}  // namespace raylab::bench::json
