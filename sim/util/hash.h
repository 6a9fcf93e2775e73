// 64-bit FNV-1a hashes: frame image hashes, sequence content hashes and cache keys (DESIGN §3, §7).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace restir {

// FNV-1a 64 over bytes, chainable through `seed`.
uint64_t Fnv1a(const void* data, size_t size, uint64_t seed = 0xcbf29ce484222325ull);

// 16 lower-case hex digits.
std::string HexHash(uint64_t h);

}  // namespace restir
