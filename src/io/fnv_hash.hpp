// The 64-bit FNV-1a hash of bytes: checksums of texts (checkpoint sections) and of a partition
// file's parts. Not cryptographic: it finds damage, not tampering.
#pragma once
#include <cstddef>
#include <cstdint>

namespace hyperqn {

struct Fnv1a {
  uint64_t value = 1469598103934665603ull;
  void add(const void* data, size_t bytes) {
    const unsigned char* b = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < bytes; ++i) value = (value ^ b[i]) * 1099511628211ull;
  }
};

}  // namespace hyperqn
