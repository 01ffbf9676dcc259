#pragma once
/** \file rng.h
 *  Portable deterministic random numbers for the synthetic renderer
 *  (dslam::splitmix64; no std distributions, whose output is implementation
 *  defined). hashNoise() gives per-pixel values independent of threads. */
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "dslam/core/splitmix.h"

namespace dslam::synth {

/** Sequential generator seeded by (seed, stream). */
class Rng {
 public:
  Rng(uint64_t seed, uint64_t stream) : s_(splitmix64(seed ^ splitmix64(stream + 0x1234567ULL))) {}
  uint64_t next() { return splitmix64(s_ += 0x9e3779b97f4a7c15ULL); }
  /** Uniform in [0, 1). */
  double uniform() { return (next() >> 11) * (1.0 / 9007199254740992.0); }
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  int integer(int lo, int hi_inclusive) {
    return lo + static_cast<int>(uniform() * (hi_inclusive - lo + 1));
  }
  double gauss() {
    const double u1 = std::max(uniform(), 1e-300), u2 = uniform();
    return std::sqrt(-2 * std::log(u1)) * std::cos(2 * M_PI * u2);
  }

 private:
  uint64_t s_;
};

/** Hash of (seed, a, b, c) -> uniform [0, 1). */
inline double hashUniform(uint64_t seed, uint64_t a, uint64_t b, uint64_t c) {
  const uint64_t h = splitmix64(seed ^ splitmix64(a ^ splitmix64(b ^ splitmix64(c))));
  return (h >> 11) * (1.0 / 9007199254740992.0);
}

/** Standard normal from a hash of (seed, a, b, c) (Box-Muller). */
inline double hashGauss(uint64_t seed, uint64_t a, uint64_t b, uint64_t c) {
  const uint64_t h1 = splitmix64(seed ^ splitmix64(a ^ splitmix64(b ^ splitmix64(c))));
  const uint64_t h2 = splitmix64(h1 ^ 0x632be59bd9b4e019ULL);
  const double u1 = std::max((h1 >> 11) * (1.0 / 9007199254740992.0), 1e-300);
  const double u2 = (h2 >> 11) * (1.0 / 9007199254740992.0);
  return std::sqrt(-2 * std::log(u1)) * std::cos(2 * M_PI * u2);
}

}  // namespace dslam::synth
