#pragma once
// Helpers for the place-recognition tests: random BoW vectors, clustered
// random descriptors, ORB descriptors of real images.
#include <array>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dslam/features/frontend.h"
#include "dslam/features/orb_extractor.h"
#include "dslam/place_recognition/bow_vector.h"

namespace dslam::test {

/** n_words random words of 0..universe-1 with random weights, normalised. */
inline BowVector randomVector(std::mt19937& rng, int n_words, int universe, BowNorm norm) {
  std::uniform_int_distribution<int> wd(0, universe - 1);
  std::uniform_real_distribution<double> vd(0.01, 1.0);
  BowVector v;
  for (int i = 0; i < n_words; ++i) v.addWeight(static_cast<WordId>(wd(rng)), vd(rng));
  v.normalize(norm);
  return v;
}

/** `n` random 32-byte prototypes. */
inline std::vector<std::array<uint8_t, 32>> prototypes(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<std::array<uint8_t, 32>> p(static_cast<size_t>(n));
  for (auto& d : p)
    for (auto& b : d) b = static_cast<uint8_t>(rng() & 0xFF);
  return p;
}

/** Copy of `proto` with `flips` random bits flipped. */
inline std::array<uint8_t, 32> noisy(const std::array<uint8_t, 32>& proto, int flips, std::mt19937& rng) {
  auto d = proto;
  for (int i = 0; i < flips; ++i) {
    const int bit = static_cast<int>(rng() % 256);
    d[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
  }
  return d;
}

/** Images of `per_image` descriptors, each a noisy copy of a random prototype. */
inline std::vector<cv::Mat> clusteredImages(const std::vector<std::array<uint8_t, 32>>& protos, int images,
                                            int per_image, int flips, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<cv::Mat> out;
  for (int i = 0; i < images; ++i) {
    cv::Mat m(per_image, 32, CV_8U);
    for (int r = 0; r < per_image; ++r) {
      const auto d = noisy(protos[rng() % protos.size()], flips, rng);
      std::memcpy(m.ptr<uint8_t>(r), d.data(), 32);
    }
    out.push_back(m);
  }
  return out;
}

/** ORB descriptors (our extractor) of an image file. `pipeline_gray`: read
 *  in colour and converted as the SLAM front end does (dslam::toGray, i.e.
 *  cv::cvtColor); otherwise decoded as grey by cv::imread (libpng/libjpeg
 *  conversion, which differs by +-1 grey level on about half the pixels). */
inline cv::Mat orbDescriptors(const std::string& path, int n_features = 1000, bool pipeline_gray = true) {
  cv::Mat g;
  if (pipeline_gray) {
    const cv::Mat c = cv::imread(path, cv::IMREAD_COLOR);
    if (c.empty()) return cv::Mat();
    g = toGray(c, true);
  } else {
    g = cv::imread(path, cv::IMREAD_GRAYSCALE);
  }
  if (g.empty()) return cv::Mat();
  OrbParams p;
  p.n_features = n_features;
  OrbExtractor ex(p);
  std::vector<cv::KeyPoint> kps;
  cv::Mat d;
  ex.extract(g, kps, d);
  return d;
}

}  // namespace dslam::test
