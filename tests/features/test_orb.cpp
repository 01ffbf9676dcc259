// ORB extractor: distribution, quotas, determinism, descriptor pattern,
// rotation invariance, mask, Hamming distance, feature grid.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <set>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "dslam/core/camera.h"
#include "dslam/core/error.h"
#include "dslam/core/descriptor.h"
#include "dslam/features/feature_grid.h"
#include "dslam/features/orb_extractor.h"
#include "synth_images.h"

using namespace dslam;

namespace {

const cv::Size kVga(640, 480);

bool sameKeypoints(const std::vector<cv::KeyPoint>& a, const std::vector<cv::KeyPoint>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); i++) {
    if (a[i].pt != b[i].pt || a[i].angle != b[i].angle || a[i].octave != b[i].octave ||
        a[i].response != b[i].response || a[i].size != b[i].size)
      return false;
  }
  return true;
}

bool sameMat(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && (a.empty() || cv::norm(a, b, cv::NORM_INF) == 0);
}

}  // namespace

TEST(OrbExtractor, LevelQuotasAndScalesFollowOrbSlam) {
  OrbExtractor ex;
  // ORB-SLAM2 ORBextractor with 1000 features, 1.2, 8 levels.
  const std::vector<int> expect{217, 181, 151, 126, 105, 87, 73, 60};
  EXPECT_EQ(ex.featuresPerLevel(), expect);
  ASSERT_EQ(ex.scaleFactors().size(), 8u);
  for (int l = 0; l < 8; l++) {
    EXPECT_NEAR(ex.scaleFactors()[l], std::pow(1.2, l), 1e-5);
    EXPECT_NEAR(ex.invScaleFactors()[l], std::pow(1.2, -l), 1e-6);
    EXPECT_NEAR(ex.levelSigma2()[l], std::pow(1.44, l), 1e-4);
    EXPECT_NEAR(ex.invLevelSigma2()[l], std::pow(1.44, -l), 1e-6);
  }
  ex.setFeatureCount(500);
  int sum = 0;
  for (int q : ex.featuresPerLevel()) sum += q;
  EXPECT_EQ(sum, 500);
  EXPECT_EQ(ex.featuresPerLevel()[0], 109);  // cvRound(500 * (1 - 1/1.2) / (1 - 1.2^-8))
}

TEST(OrbExtractor, SpreadsFeaturesOverTheImageAndMeetsTheCount) {
  const cv::Mat img = test::texturedScene(kVga);
  OrbExtractor ex;
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  ex.extract(img, kps, desc);
  ASSERT_EQ(desc.rows, static_cast<int>(kps.size()));
  EXPECT_EQ(desc.cols, 32);
  EXPECT_EQ(desc.type(), CV_8U);
  EXPECT_GE(kps.size(), 950u);
  EXPECT_LE(kps.size(), 1050u);

  // Without distribution the fine-noise corner (10% of the area) would hold
  // most of the corners: check FAST alone, then the extractor's 8x6 grid.
  std::vector<cv::KeyPoint> fast;
  cv::FAST(img, fast, 20, true);
  size_t in_corner = 0;
  for (const auto& k : fast) in_corner += (k.pt.x < 200 && k.pt.y < 150);
  ASSERT_GT(static_cast<double>(in_corner) / fast.size(), 0.4) << "test image not skewed enough";

  int cells[6][8] = {};
  for (const auto& k : kps) {
    ASSERT_GE(k.pt.x, 0);
    ASSERT_GE(k.pt.y, 0);
    ASSERT_LT(k.pt.x, kVga.width);
    ASSERT_LT(k.pt.y, kVga.height);
    cells[std::min(5, static_cast<int>(k.pt.y / 80))][std::min(7, static_cast<int>(k.pt.x / 80))]++;
  }
  int max_cell = 0, empty = 0;
  for (auto& row : cells)
    for (int c : row) {
      max_cell = std::max(max_cell, c);
      empty += (c == 0);
    }
  EXPECT_LE(max_cell, 0.15 * kps.size()) << "one 80x80 cell holds " << max_cell << " of " << kps.size();
  std::cout << "[ orb      ] " << kps.size() << " keypoints; FAST alone puts " << in_corner << " of " << fast.size()
            << " in the textured corner; fullest 8x6 cell holds " << max_cell << "\n";
  EXPECT_LE(empty, 2) << "the features do not cover the image";

  // Keypoint attributes.
  std::vector<int> per_level(8, 0);
  for (const auto& k : kps) {
    ASSERT_GE(k.octave, 0);
    ASSERT_LT(k.octave, 8);
    per_level[k.octave]++;
    EXPECT_NEAR(k.size, 31.0f * ex.scaleFactors()[k.octave], 1e-3);
    EXPECT_GE(k.angle, 0.0f);
    EXPECT_LT(k.angle, 360.0f);
    EXPECT_GE(k.response, 7.0f);
  }
  for (int l = 0; l < 8; l++) EXPECT_LE(per_level[l], ex.featuresPerLevel()[l]) << "level " << l;
  EXPECT_TRUE(std::is_sorted(kps.begin(), kps.end(),
                             [](const cv::KeyPoint& a, const cv::KeyPoint& b) { return a.octave < b.octave; }));
}

TEST(OrbExtractor, FeatureCountCanChangeBetweenFrames) {
  const cv::Mat img = test::texturedScene(kVga, 11);
  OrbExtractor ex;
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  for (int n : {1000, 400, 1500, 1000}) {
    ex.setFeatureCount(n);
    ex.extract(img, kps, desc);
    EXPECT_GE(kps.size(), 0.95 * n) << n;
    EXPECT_LE(kps.size(), 1.0 * n) << n;
  }
}

TEST(OrbExtractor, IsDeterministicAndIndependentOfThreading) {
  const cv::Mat img = test::texturedScene(kVga, 3);
  std::vector<cv::KeyPoint> k1, k2, k3;
  cv::Mat d1, d2, d3;
  OrbExtractor a;
  a.extract(img, k1, d1);
  a.extract(img, k2, d2);
  EXPECT_TRUE(sameKeypoints(k1, k2));
  EXPECT_TRUE(sameMat(d1, d2));

  OrbParams p;
  p.parallel_levels = true;
  OrbExtractor b(p);
  const int threads = cv::getNumThreads();
  cv::setNumThreads(4);
  b.extract(img, k3, d3);
  cv::setNumThreads(threads);
  EXPECT_TRUE(sameKeypoints(k1, k3));
  EXPECT_TRUE(sameMat(d1, d3));
}

TEST(OrbExtractor, LevelZeroDescriptorsEqualOpenCvOrb) {
  // cv::ORB::compute on our level-0 keypoints (same blur, pattern and
  // angles) must give the same bits: checks the pattern table and BRIEF.
  const cv::Mat img = test::texturedScene(kVga, 5);
  OrbExtractor ex;
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  ex.extract(img, kps, desc);
  std::vector<cv::KeyPoint> lvl0;
  std::vector<int> rows;
  for (size_t i = 0; i < kps.size(); i++)
    if (kps[i].octave == 0) {
      lvl0.push_back(kps[i]);
      rows.push_back(static_cast<int>(i));
    }
  ASSERT_GT(lvl0.size(), 150u);
  auto orb = cv::ORB::create(1000, 1.2f, 1, 19, 0, 2, cv::ORB::FAST_SCORE, 31, 20);
  std::vector<cv::KeyPoint> cv_kps = lvl0;
  cv::Mat cv_desc;
  orb->compute(img, cv_kps, cv_desc);
  ASSERT_EQ(cv_kps.size(), lvl0.size()) << "cv::ORB dropped keypoints";
  int identical = 0, max_bits = 0;
  for (size_t i = 0; i < lvl0.size(); i++) {
    ASSERT_EQ(cv_kps[i].pt, lvl0[i].pt);
    const int d = descriptorDistance(desc.ptr<uint8_t>(rows[i]), cv_desc.ptr<uint8_t>(static_cast<int>(i)));
    identical += (d == 0);
    max_bits = std::max(max_bits, d);
  }
  // A wrong pattern entry would flip a bit in about half of the descriptors.
  EXPECT_GE(identical, static_cast<int>(0.99 * lvl0.size()));
  EXPECT_LE(max_bits, 4);
}

TEST(OrbExtractor, DescriptorsSurviveRotation) {
  const cv::Mat img = test::texturedScene(kVga, 21, cv::Rect(0, 0, 0, 0));
  const double angle = 30.0;
  const cv::Mat M = cv::getRotationMatrix2D(cv::Point2f(320, 240), angle, 1.0);
  cv::Mat rot;
  cv::warpAffine(img, rot, M, img.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(128));
  OrbExtractor ex;
  std::vector<cv::KeyPoint> k1, k2;
  cv::Mat d1, d2;
  ex.extract(img, k1, d1);
  ex.extract(rot, k2, d2);
  ASSERT_GT(k1.size(), 800u);
  ASSERT_GT(k2.size(), 800u);

  int tested = 0, correct = 0;
  std::vector<double> angle_err;
  for (size_t i = 0; i < k1.size(); i++) {
    const cv::Point2d p(k1[i].pt);
    const cv::Point2d q(M.at<double>(0, 0) * p.x + M.at<double>(0, 1) * p.y + M.at<double>(0, 2),
                        M.at<double>(1, 0) * p.x + M.at<double>(1, 1) * p.y + M.at<double>(1, 2));
    // Only points whose patch stays inside the rotated image.
    if (q.x < 40 || q.y < 40 || q.x > 600 || q.y > 440) continue;
    tested++;
    int best = 257, best_j = -1;
    for (size_t j = 0; j < k2.size(); j++) {
      const int d = descriptorDistance(d1.ptr<uint8_t>(static_cast<int>(i)), d2.ptr<uint8_t>(static_cast<int>(j)));
      if (d < best) {
        best = d;
        best_j = static_cast<int>(j);
      }
    }
    const cv::Point2d m(k2[best_j].pt);
    if (std::hypot(m.x - q.x, m.y - q.y) < 3.0) {
      correct++;
      // Orientation follows the rotation of the image.
      const double a = k1[i].angle * CV_PI / 180;
      const double ex_a = std::atan2(M.at<double>(1, 0) * std::cos(a) + M.at<double>(1, 1) * std::sin(a),
                                     M.at<double>(0, 0) * std::cos(a) + M.at<double>(0, 1) * std::sin(a));
      double diff = std::fmod(k2[best_j].angle * CV_PI / 180 - ex_a + 4 * CV_PI, 2 * CV_PI);
      if (diff > CV_PI) diff -= 2 * CV_PI;
      angle_err.push_back(std::abs(diff) * 180 / CV_PI);
    }
  }
  ASSERT_GT(tested, 400);
  const double ratio = static_cast<double>(correct) / tested;
  EXPECT_GT(ratio, 0.5) << correct << " / " << tested;
  std::cout << "[ orb      ] rotation 30 deg: " << correct << " of " << tested << " nearest neighbours within 3 px\n";
  ASSERT_FALSE(angle_err.empty());
  std::nth_element(angle_err.begin(), angle_err.begin() + angle_err.size() / 2, angle_err.end());
  EXPECT_LT(angle_err[angle_err.size() / 2], 5.0);
}

TEST(OrbExtractor, HonoursTheMask) {
  const cv::Mat img = test::texturedScene(kVga, 9);
  cv::Mat mask(img.size(), CV_8UC1, cv::Scalar(255));
  mask(cv::Rect(0, 0, 320, 480)).setTo(0);    // left half forbidden
  mask(cv::Rect(400, 200, 100, 100)).setTo(0);  // and a box
  OrbExtractor ex;
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  ex.extract(img, kps, desc, mask);
  ASSERT_GT(kps.size(), 600u);
  for (const auto& k : kps) {
    const int x = std::min(639, cvRound(k.pt.x)), y = std::min(479, cvRound(k.pt.y));
    ASSERT_NE(mask.at<uint8_t>(y, x), 0) << "keypoint at " << k.pt << " octave " << k.octave;
  }
}

TEST(OrbExtractor, RejectsBadInputAndParameters) {
  OrbExtractor ex;
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  EXPECT_THROW(ex.extract(cv::Mat(), kps, desc), DataError);
  EXPECT_THROW(ex.extract(cv::Mat(480, 640, CV_8UC3, cv::Scalar::all(0)), kps, desc), DataError);
  EXPECT_THROW(ex.extract(cv::Mat(480, 640, CV_8UC1, cv::Scalar(0)), kps, desc, cv::Mat(10, 10, CV_8UC1)),
               DataError);
  OrbParams p;
  p.scale_factor = 1.0f;
  EXPECT_THROW(OrbExtractor{p}, ConfigError);
  p = OrbParams();
  p.min_th_fast = 30;  // above ini_th_fast
  EXPECT_THROW(OrbExtractor{p}, ConfigError);
  EXPECT_THROW(ex.setFeatureCount(-1), ConfigError);
}

TEST(OrbExtractor, HandlesTinyAndFlatImages) {
  OrbExtractor ex;
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  for (cv::Size s : {cv::Size(1, 1), cv::Size(5, 3), cv::Size(40, 30)}) {
    ex.extract(cv::Mat(s, CV_8UC1, cv::Scalar(10)), kps, desc);
    EXPECT_TRUE(kps.empty()) << s;
    EXPECT_EQ(desc.rows, 0);
  }
  EXPECT_EQ(desc.rows, 0);
  ex.extract(cv::Mat(480, 640, CV_8UC1, cv::Scalar(100)), kps, desc);
  EXPECT_TRUE(kps.empty());
  cv::RNG rng(1);
  ex.extract(test::smoothNoise(cv::Size(64, 64), 4, rng), kps, desc);
  EXPECT_EQ(desc.rows, static_cast<int>(kps.size()));
  for (const auto& k : kps) EXPECT_EQ(k.octave, 0);  // higher levels are too small for a cell
}

TEST(Descriptor, HammingDistanceMatchesOpenCv) {
  cv::RNG rng(42);
  cv::Mat a(200, 32, CV_8U), b(200, 32, CV_8U);
  rng.fill(a, cv::RNG::UNIFORM, 0, 256);
  rng.fill(b, cv::RNG::UNIFORM, 0, 256);
  for (int i = 0; i < a.rows; i++)
    EXPECT_EQ(descriptorDistance(a.row(i), b.row(i)), static_cast<int>(cv::norm(a.row(i), b.row(i), cv::NORM_HAMMING)));
  EXPECT_EQ(descriptorDistance(a.row(0), a.row(0)), 0);
  cv::Mat z(1, 32, CV_8U, cv::Scalar(0)), o(1, 32, CV_8U, cv::Scalar(255));
  EXPECT_EQ(descriptorDistance(z, o), 256);
}

TEST(FeatureGrid, AreaQueryEqualsBruteForce) {
  cv::RNG rng(8);
  std::vector<cv::KeyPoint> kps(3000);
  for (auto& k : kps) {
    k.pt = cv::Point2f(rng.uniform(-5.f, 645.f), rng.uniform(-5.f, 485.f));  // a few outside the image
    k.octave = rng.uniform(0, 8);
  }
  ImageBounds b;
  b.max_x = 640;
  b.max_y = 480;
  const FeatureGrid grid(kps, b);
  EXPECT_EQ(grid.size(), kps.size());
  EXPECT_LT(grid.indexed(), kps.size());
  EXPECT_GT(grid.indexed(), 2900u);
  for (int q = 0; q < 300; q++) {
    const float x = rng.uniform(-20.f, 660.f), y = rng.uniform(-20.f, 500.f), r = rng.uniform(1.f, 60.f);
    const int min_l = rng.uniform(-1, 4), max_l = rng.uniform(-1, 8);
    std::vector<size_t> got = grid.featuresInArea(x, y, r, min_l, max_l);
    std::set<size_t> want;
    for (size_t i = 0; i < kps.size(); i++) {
      int cx, cy;
      if (!grid.posInGrid(kps[i].pt.x, kps[i].pt.y, cx, cy)) continue;
      if (std::fabs(kps[i].pt.x - x) >= r || std::fabs(kps[i].pt.y - y) >= r) continue;
      if (min_l > 0 && kps[i].octave < min_l) continue;
      if (max_l >= 0 && kps[i].octave > max_l) continue;
      want.insert(i);
    }
    ASSERT_EQ(std::set<size_t>(got.begin(), got.end()), want) << "query " << q;
    ASSERT_EQ(got.size(), want.size()) << "duplicates in query " << q;
  }
  EXPECT_THROW(FeatureGrid(kps, ImageBounds{}), ConfigError);
}

TEST(FeatureGrid, BoundsOfADistortedCamera) {
  PinholeCamera cam;
  cam.width = 640;
  cam.height = 480;
  cam.fx = 517.306408;
  cam.fy = 516.469215;
  cam.cx = 318.643040;
  cam.cy = 255.313989;
  const ImageBounds plain = computeImageBounds(cam);
  EXPECT_EQ(plain.min_x, 0);
  EXPECT_EQ(plain.min_y, 0);
  EXPECT_EQ(plain.max_x, 640);
  EXPECT_EQ(plain.max_y, 480);
  cam.dist = {0.262383, -0.953104, -0.005358, 0.002628, 1.163314};  // TUM fr1
  const ImageBounds b = computeImageBounds(cam);
  // Independent check with OpenCV's undistortPoints (P = K) on the corners.
  const cv::Matx33d K(cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
  std::vector<cv::Point2f> corners{{0, 0}, {640, 0}, {0, 480}, {640, 480}}, und;
  cv::undistortPoints(corners, und, K, std::vector<double>(cam.dist.begin(), cam.dist.end()), cv::noArray(), K,
                      cv::TermCriteria(cv::TermCriteria::COUNT, 50, 0));
  EXPECT_NEAR(b.min_x, std::min(und[0].x, und[2].x), 0.05);
  EXPECT_NEAR(b.max_x, std::max(und[1].x, und[3].x), 0.05);
  EXPECT_NEAR(b.min_y, std::min(und[0].y, und[1].y), 0.05);
  EXPECT_NEAR(b.max_y, std::max(und[2].y, und[3].y), 0.05);
  EXPECT_GT(std::abs(b.min_x), 1.0f);  // the distortion moves the corners
}
