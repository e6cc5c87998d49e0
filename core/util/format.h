// Numbers as the messages print them.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>

namespace vismap {

// Bytes in MiB to the hundredth ("0.95 MiB", never a "0 MiB" rounded down): the budgets' and
// the dicers' messages.
inline std::string mib(uint64_t bytes) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f MiB", double(bytes) / (1 << 20));
  return b;
}

}  // namespace vismap
