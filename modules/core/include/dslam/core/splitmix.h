#pragma once
/** \file splitmix.h
 *  splitmix64 (Steele, Lea, Flood 2014): the 64-bit mixer behind dslam's
 *  portable deterministic random numbers (vocabulary training, synthetic
 *  scenes); unlike std:: distributions, its output is the same everywhere. */
#include <cstdint>

namespace dslam {

/** splitmix64 step: adds the golden-ratio increment to x and mixes it. */
inline uint64_t splitmix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

}  // namespace dslam
