// Writes arrays as NumPy .npy files (format 1.0), so the Python driver and Blender read exactly
// the rays and hits the benchmark used.
#pragma once

#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace raylab::bench {

// `descr` is the NumPy type string, e.g. "<f4"; data is C-ordered with the given shape.
inline void write_npy(const std::string& path, const char* descr, const std::vector<size_t>& shape, const void* data,
                      size_t bytes) {
  std::string dims;
  for (size_t d : shape) dims += std::to_string(d) + ", ";
  std::string header = "{'descr': '" + std::string(descr) + "', 'fortran_order': False, 'shape': (" + dims + "), }";
  // The magic (6), version (2), header length (2) and header with its newline fill 64-byte blocks.
  const size_t unpadded = 10 + header.size() + 1;
  header.append((64 - unpadded % 64) % 64, ' ');
  header += '\n';
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("cannot write " + path);
  const uint16_t length = uint16_t(header.size());
  out.write("\x93NUMPY\x01\x00", 8);
  out.put(char(length & 0xff));
  out.put(char(length >> 8));
  out << header;
  out.write(static_cast<const char*>(data), std::streamsize(bytes));
}

}  // namespace raylab::bench
