#pragma once
// Procedural, mip-mapped textures of the synthetic renderer (internal).
#include <opencv2/core.hpp>

#include <cstdint>
#include <cstring>

#include <vector>

#include "dslam/synth/scenario.h"

namespace dslam::synth {

class Texture {
 public:
  /** Builds a texture of `width_m` x `height_m` metres at `tpm` texels per
   *  metre (the image wraps beyond that extent). */
  Texture(const TextureSpec& spec, double width_m, double height_m, double tpm);

  /** Trilinear sample at (u, v) metres (v up) for a pixel footprint of
   *  `footprint_m` metres. Returns BGR in [0, 255]. */
  inline void sample(double u, double v, double footprint_m, float out[3]) const;

  const cv::Mat& level(int i) const { return mips_[i]; }
  int levels() const { return static_cast<int>(mips_.size()); }

 private:
  inline void bilinear(int lvl, double x, double y, float out[3]) const;
  std::vector<cv::Mat> mips_;  // CV_8UC3
  double tpm_;
};

inline void Texture::bilinear(int lvl, double x, double y, float out[3]) const {
  const cv::Mat& m = mips_[lvl];
  const int W = m.cols, H = m.rows;
  // floor() without a libm call (|x|, |y| < 2^31).
  int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  x0 -= x < x0;
  y0 -= y < y0;
  const float ax = static_cast<float>(x - x0), ay = static_cast<float>(y - y0);
  if (x0 < 0 || x0 >= W) {
    x0 %= W;
    if (x0 < 0) x0 += W;
  }
  if (y0 < 0 || y0 >= H) {
    y0 %= H;
    if (y0 < 0) y0 += H;
  }
  const int x1 = x0 + 1 == W ? 0 : x0 + 1, y1 = y0 + 1 == H ? 0 : y0 + 1;
  const uchar* r0 = m.ptr<uchar>(y0);
  const uchar* r1 = m.ptr<uchar>(y1);
  const uchar *p00 = r0 + 3 * x0, *p01 = r0 + 3 * x1, *p10 = r1 + 3 * x0, *p11 = r1 + 3 * x1;
  const float w00 = (1 - ax) * (1 - ay), w01 = ax * (1 - ay), w10 = (1 - ax) * ay, w11 = ax * ay;
  for (int c = 0; c < 3; c++) out[c] = w00 * p00[c] + w01 * p01[c] + w10 * p10[c] + w11 * p11[c];
}

inline void Texture::sample(double u, double v, double footprint_m, float out[3]) const {
  // Level of detail = log2(texels per pixel), by exponent + linear mantissa
  // (|error| < 0.09 level; exact at powers of two).
  const double texels = footprint_m * tpm_;
  double lod = 0;
  if (texels > 1.0) {
    uint64_t b;
    std::memcpy(&b, &texels, sizeof b);
    const int e = static_cast<int>((b >> 52) & 0x7ff) - 1023;        // texels = (1 + f) 2^e
    const double f = static_cast<double>(b & ((1ULL << 52) - 1)) * (1.0 / 4503599627370496.0);
    lod = e + f;
  }
  const double maxl = static_cast<double>(mips_.size() - 1);
  if (lod > maxl) lod = maxl;
  const int l0 = static_cast<int>(lod);
  const float t = static_cast<float>(lod - l0);
  const double H0 = mips_[0].rows;
  auto at = [&](int l, float o[3]) {
    const double s = 1.0 / static_cast<double>(1 << l);
    bilinear(l, u * tpm_ * s - 0.5, (H0 - v * tpm_) * s - 0.5, o);
  };
  at(l0, out);
  if (t > 0.01f && l0 + 1 < static_cast<int>(mips_.size())) {
    float o2[3];
    at(l0 + 1, o2);
    for (int c = 0; c < 3; c++) out[c] += t * (o2[c] - out[c]);
  }
}

}  // namespace dslam::synth
