// The two contracts a query can be held to. Exact, the default: every structure returns brute force's
// hit bit for bit (watertight triangles decided in double precision, boxes padded to contain every hit
// the triangle test can report). Fast: the contract Embree keeps by default, for measuring what
// exactness costs (README "The price of exactness").
#pragma once

#include "raylab/named_table.h"

#include <string>

namespace raylab {

enum class Contract { Exact, Fast };

// The contracts' names, once: the bindings parse and print them and export the table to Python
// (_raylab.CONTRACTS), where the add-on's render settings and the benchmark read it.
struct ContractInfo {
  Contract contract;
  const char* name;
  const char* label;
  const char* description;
};

inline constexpr ContractInfo kContracts[] = {
    {Contract::Exact, "exact", "Exact",
     "The same hit as brute force, bit for bit: watertight triangles decided in double precision, boxes "
     "padded to contain every hit (Embree calls its like robust mode)"},
    {Contract::Fast, "fast", "Fast",
     "Embree's default: Möller–Trumbore on precomputed edges, eight triangles at a time, and the slab test "
     "with fused multiply-adds, unpadded; faster, and wrong on some rays through edges and vertices"},
};

inline const char* contract_name(Contract contract) { return name_in(kContracts, &ContractInfo::contract, contract); }

// Throws std::invalid_argument listing the known names.
inline Contract contract_from_name(const std::string& name) {
  return value_in(kContracts, &ContractInfo::contract, name, "contract");
}

}  // namespace raylab
