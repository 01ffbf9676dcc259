#pragma once
/** \file descriptor.h
 *  Hamming distance between 32-byte (256-bit) ORB descriptors: the one
 *  implementation (front end, matcher, classifiers, vocabulary), and the
 *  best-two bookkeeping of the ratio test. */
#include <cstdint>
#include <cstring>

#include <opencv2/core.hpp>

#if defined(__POPCNT__)
#include <bit>
#endif

namespace dslam {

/** Bytes in one ORB descriptor row. */
inline constexpr int kOrbDescriptorBytes = 32;

namespace detail {
inline int popcount64(uint64_t v) {
#if defined(__POPCNT__)
  return std::popcount(v);
#else
  // Bit-parallel count: without -mpopcnt the builtin is a library call.
  v = v - ((v >> 1) & 0x5555555555555555ULL);
  v = (v & 0x3333333333333333ULL) + ((v >> 2) & 0x3333333333333333ULL);
  v = (v + (v >> 4)) & 0x0f0f0f0f0f0f0f0fULL;
  return static_cast<int>((v * 0x0101010101010101ULL) >> 56);
#endif
}
}  // namespace detail

/** Hamming distance (0..256) between two 32-byte descriptors. */
inline int descriptorDistance(const uint8_t* a, const uint8_t* b) {
  int d = 0;
  for (int i = 0; i < kOrbDescriptorBytes; i += 8) {
    uint64_t x, y;
    std::memcpy(&x, a + i, 8);
    std::memcpy(&y, b + i, 8);
    d += detail::popcount64(x ^ y);
  }
  return d;
}

/** Hamming distance between two descriptor rows (CV_8U, 32 columns each). */
inline int descriptorDistance(const cv::Mat& a, const cv::Mat& b) {
  CV_DbgAssert(a.type() == CV_8U && b.type() == CV_8U && a.cols == kOrbDescriptorBytes &&
               b.cols == kOrbDescriptorBytes);
  return descriptorDistance(a.ptr<uint8_t>(), b.ptr<uint8_t>());
}

/** The two smallest descriptor distances offered and the index of the
 *  smallest: ORB-SLAM's bestDist / bestDist2 for the nearest-neighbour ratio
 *  test. `none` is the distance before any offer (idx -1). */
struct BestTwo {
  int d1, d2, idx = -1;
  explicit BestTwo(int none = 256) : d1(none), d2(none) {}
  void offer(int d, int i) {
    if (d < d1) {
      d2 = d1;
      d1 = d;
      idx = i;
    } else if (d < d2) {
      d2 = d;
    }
  }
};

}  // namespace dslam
