// Owen-scrambled Sobol points for randomised quasi-Monte Carlo.
//
// The unscrambled Sobol sequence (Joe–Kuo direction numbers, as shipped by Boost.Random)
// is generated once into a shared table, grown on demand. Each of the estimator's R
// replicates applies its own nested uniform (Owen) scramble by hashing, after Burley,
// "Practical Hash-based Owen Scrambling", JCGT 9(4), 2020: reverse the bits, apply the
// Laine–Karras style permutation keyed by a per-dimension seed, reverse back. Point i of
// replicate r is therefore a deterministic function of (i, dimension, seed).
#pragma once

#include <cstdint>
#include <vector>

namespace gonio::twin::detail {

inline constexpr int kSobolDims = 8;

// Raw 32-bit Sobol coordinates, point-major: point i, dimension d at [i * kSobolDims + d].
// Point 0 is the origin so that every prefix of 2^m points is a (t, m, s)-net.
class SobolTable {
 public:
  // Returns a table holding at least `points` points. Thread-safe; the returned reference
  // stays valid (the table only ever grows by replacement kept alive for the process).
  static const std::vector<std::uint32_t>& get(std::uint64_t points);
};

inline std::uint32_t reverse_bits(std::uint32_t x) noexcept {
  x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
  x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
  x = ((x >> 4) & 0x0F0F0F0Fu) | ((x & 0x0F0F0F0Fu) << 4);
  x = ((x >> 8) & 0x00FF00FFu) | ((x & 0x00FF00FFu) << 8);
  return (x >> 16) | (x << 16);
}

// Burley 2020, listing 2 constants (the permutation keyed by `seed`).
inline std::uint32_t owen_scramble(std::uint32_t x, std::uint32_t seed) noexcept {
  x = reverse_bits(x);
  x += seed;
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return reverse_bits(x);
}

// splitmix64 finaliser: decorrelates seeds per replicate and dimension.
inline std::uint64_t mix64(std::uint64_t z) noexcept {
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

inline double to_unit(std::uint32_t x) noexcept {
  // 32 random bits → [0, 1) with the low bits jittered by the scramble already.
  return static_cast<double>(x) * 0x1p-32;
}

}  // namespace gonio::twin::detail
