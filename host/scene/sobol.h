// The first two Sobol' dimensions in closed form (Sobol' 1967), shared by the CPU reference's
// samplers (host/cpu/sampler.cpp) and the host's pmj02bn tables (host/scene/pmj02bn.cpp). The
// GLSL side has its own (shaders/include/sampler.glsl, sobol0 and sobol1).
#pragma once
#include <cstdint>

namespace basalt {

/// Bits of \p v in reverse order.
inline std::uint32_t reverse_bits(std::uint32_t v) {
  v = ((v >> 1) & 0x55555555u) | ((v & 0x55555555u) << 1);
  v = ((v >> 2) & 0x33333333u) | ((v & 0x33333333u) << 2);
  v = ((v >> 4) & 0x0f0f0f0fu) | ((v & 0x0f0f0f0fu) << 4);
  v = ((v >> 8) & 0x00ff00ffu) | ((v & 0x00ff00ffu) << 8);
  return (v >> 16) | (v << 16);
}

/// First Sobol' dimension of index \p a: the van der Corput sequence, a 32-bit fraction.
inline std::uint32_t sobol0(std::uint32_t a) { return reverse_bits(a); }

/// Second Sobol' dimension of index \p a (primitive polynomial x + 1): column i is column i-1
/// xor itself shifted right by one.
inline std::uint32_t sobol1(std::uint32_t a) {
  std::uint32_t v = 0, c = 0x80000000u;
  for (; a != 0; a >>= 1) {
    if (a & 1u) v ^= c;
    c ^= c >> 1;
  }
  return v;
}

}  // namespace basalt
