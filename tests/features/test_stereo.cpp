// Stereo matching (synthetic rectified pairs with known disparity, the real
// KITTI pair) and rectification of an unrectified rig (real EuRoC pair).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dslam/core/camera_presets.h"
#include "dslam/core/error.h"
#include "dslam/features/frontend.h"
#include "dslam/features/orb_extractor.h"
#include "dslam/features/stereo_matcher.h"
#include "synth_images.h"
#include "test_support.h"

using namespace dslam;

namespace {

constexpr double kFx = 718.856, kBf = 386.1448;  // KITTI 00-02
constexpr double kBaseline = kBf / kFx;

/** A rectified pair of a fronto-parallel textured plane with disparity `d`
 *  (a multiple of 1/4 px): both images are box-downsampled (x4) from one
 *  high-resolution texture, the right one shifted by 4d high-res pixels, so
 *  right(x) = left(x + d) exactly. */
void renderPlanePair(cv::Size size, double d, uint64_t seed, cv::Mat& left, cv::Mat& right) {
  const int S = 4;
  const int shift = static_cast<int>(std::lround(d * S));
  ASSERT_NEAR(shift, d * S, 1e-9);
  cv::RNG rng(seed);
  const cv::Size hi((size.width + static_cast<int>(std::ceil(d)) + 2) * S, size.height * S);
  cv::Mat tex = test::smoothNoise(hi, 3 * S, rng, 40, 215);
  for (int i = 0; i < hi.area() / 40000; i++) {
    const cv::Point c(rng.uniform(0, hi.width), rng.uniform(0, hi.height));
    const cv::Size s(rng.uniform(4 * S, 30 * S), rng.uniform(4 * S, 30 * S));
    cv::rectangle(tex, cv::Rect(c, s), cv::Scalar(rng.uniform(0, 256)), cv::FILLED);
  }
  cv::resize(tex(cv::Rect(0, 0, size.width * S, size.height * S)), left, size, 0, 0, cv::INTER_AREA);
  cv::resize(tex(cv::Rect(shift, 0, size.width * S, size.height * S)), right, size, 0, 0, cv::INTER_AREA);
}

CameraModel euroc() {
  // mav0/cam0/sensor.yaml and mav0/cam1/sensor.yaml of EuRoC V1_01_easy.
  CameraModel c;
  c.name = "euroc-raw";
  c.sensor = SensorType::Stereo;
  c.rectified = false;
  c.left.width = c.right.width = 752;
  c.left.height = c.right.height = 480;
  c.left.fx = 458.654, c.left.fy = 457.296, c.left.cx = 367.215, c.left.cy = 248.375;
  c.left.dist = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0};
  c.right.fx = 457.587, c.right.fy = 456.134, c.right.cx = 379.999, c.right.cy = 255.238;
  c.right.dist = {-0.28368365, 0.07451284, -0.00010473, -3.55590700e-05, 0};
  Eigen::Matrix4d B0, B1;
  B0 << 0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975, 0.999557249008, 0.0149672133247,
      0.025715529948, -0.064676986768, -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949, 0, 0,
      0, 1;
  B1 << 0.0125552670891, -0.999755099723, 0.0182237714554, -0.0198435579556, 0.999598781151, 0.0130119051815,
      0.0251588363115, 0.0453689425024, -0.0253898008918, 0.0179005838253, 0.999517347078, 0.00786212447038, 0, 0,
      0, 1;
  c.T_body_cam = SE3(B0);
  c.T_left_right = SE3(B0).inverse() * SE3(B1);
  c.depth_threshold = 35;
  c.fps = 20;
  c.rgb_order = false;
  return c;
}

struct PlaneResult {
  int matched = 0, visible = 0, good = 0;  ///< good: |disparity error| <= 0.2 px
  double mean_abs_err = 0, median_rel_depth_err = 0;
  StereoMatchStats stats;
};

/** ORB features of a stereo pair (default extractors) and their matches. */
struct MatchedPair {
  OrbExtractor ex_l, ex_r;
  std::vector<cv::KeyPoint> kl, kr;
  cv::Mat dl, dr;
  std::vector<float> u_right, depth;
  StereoMatchStats stats;

  MatchedPair(const cv::Mat& left, const cv::Mat& right, const StereoMatchParams& sp = StereoMatchParams()) {
    ex_l.extract(left, kl, dl);
    ex_r.extract(right, kr, dr);
    stats = match(static_cast<float>(kBf), static_cast<float>(kBaseline), sp);
  }
  StereoMatchStats match(float bf, float baseline, const StereoMatchParams& sp = StereoMatchParams()) {
    return computeStereoMatches(ex_l, kl, dl, ex_r, kr, dr, bf, baseline, u_right, depth, sp);
  }
};

PlaneResult matchPlane(double d_true, const StereoMatchParams& sp) {
  PlaneResult res;
  cv::Mat left, right;
  renderPlanePair(cv::Size(640, 480), d_true, 100 + static_cast<uint64_t>(d_true * 4), left, right);
  MatchedPair mp(left, right, sp);
  const auto& kl = mp.kl;
  const auto& u_right = mp.u_right;
  const auto& depth = mp.depth;
  res.stats = mp.stats;
  EXPECT_EQ(u_right.size(), kl.size());
  EXPECT_EQ(depth.size(), kl.size());
  const double z_true = kBf / d_true;
  std::vector<double> rel;
  for (size_t i = 0; i < kl.size(); i++) {
    res.visible += (kl[i].pt.x - d_true > 25);  // the point is inside the right image
    if (u_right[i] < 0) {
      EXPECT_EQ(depth[i], -1.0f);
      continue;
    }
    res.matched++;
    const double disp = kl[i].pt.x - u_right[i];
    res.good += std::abs(disp - d_true) <= 0.2;
    res.mean_abs_err += std::abs(disp - d_true);
    EXPECT_NEAR(depth[i], kBf / disp, 1e-3 * depth[i]);
    rel.push_back(std::abs(depth[i] - z_true) / z_true);
  }
  if (res.matched > 0) res.mean_abs_err /= res.matched;
  if (!rel.empty()) {
    std::nth_element(rel.begin(), rel.begin() + rel.size() / 2, rel.end());
    res.median_rel_depth_err = rel[rel.size() / 2];
  }
  return res;
}

/** Frame 0 of a real stereo pair read from disk (images empty if unreadable). */
SensorFrame stereoPair(const std::string& left, const std::string& right) {
  SensorFrame in;
  in.index = 0;
  in.image_path = left;
  in.image_right_path = right;
  in.image = cv::imread(left, cv::IMREAD_UNCHANGED);
  in.image_right = cv::imread(right, cv::IMREAD_UNCHANGED);
  return in;
}

}  // namespace

class SyntheticStereo : public ::testing::TestWithParam<double> {};

TEST_P(SyntheticStereo, SubPixelDisparityOfATexturedPlane) {
  const double d_true = GetParam();
  const PlaneResult r = matchPlane(d_true, StereoMatchParams());
  EXPECT_EQ(r.matched, r.stats.matched);
  EXPECT_GE(r.matched, 0.4 * r.visible) << "matched " << r.matched << " of " << r.visible << " visible";
  EXPECT_GE(r.good, 0.9 * r.matched) << r.good << " of " << r.matched << " within 0.2 px";
  EXPECT_LT(r.median_rel_depth_err, 0.005);
  std::cout << "[ stereo   ] d=" << d_true << ": " << r.matched << " matches (" << r.visible << " visible), "
            << r.good << " within 0.2 px, mean |error| " << r.mean_abs_err << " px, median depth error "
            << 100 * r.median_rel_depth_err << "%\n";

  // ORB-SLAM2's refinement (centre-pixel offset, parabola) works but is less
  // accurate (pixel locking, brightness offset of the corner pixel).
  const PlaneResult o = matchPlane(d_true, StereoMatchParams::orbSlam2());
  EXPECT_GE(o.matched, 0.4 * o.visible);
  EXPECT_LT(o.mean_abs_err, 0.4);
  EXPECT_LT(r.mean_abs_err, 0.6 * o.mean_abs_err);
  std::cout << "[ stereo   ] d=" << d_true << " ORB-SLAM2 refinement: " << o.matched << " matches, " << o.good
            << " within 0.2 px, mean |error| " << o.mean_abs_err << " px\n";
}

INSTANTIATE_TEST_SUITE_P(Disparities, SyntheticStereo, ::testing::Values(12.25, 20.75, 41.5));

TEST(StereoMatcher, NoMatchesOutsideTheDisparityRange) {
  // Right = left shifted the wrong way (negative disparity): nothing valid.
  cv::Mat left, right;
  renderPlanePair(cv::Size(640, 480), 10.0, 5, right, left);  // swapped: x_r = x_l + 10
  MatchedPair mp(left, right);
  // Only accidental matches may survive (and never with negative disparity).
  EXPECT_LT(mp.stats.matched, 0.05 * mp.kl.size());
  for (size_t i = 0; i < mp.kl.size(); i++)
    if (mp.u_right[i] >= 0) {
      EXPECT_GT(mp.kl[i].pt.x - mp.u_right[i], 0.0f);
    }
  EXPECT_THROW(mp.match(0.f, 0.5f), ConfigError);
}

TEST(StereoMatcher, RealKittiPair) {
  const std::string dir = test::shared("data/kitti-stereo-51");
  if (dir.empty()) GTEST_SKIP();
  const SensorFrame in = stereoPair(dir + "/image_l/000000.png", dir + "/image_r/000000.png");
  ASSERT_FALSE(in.image.empty());
  ASSERT_FALSE(in.image_right.empty());
  const CameraModel cam = *cameraPreset("kitti_00_02");
  FrontendParams p;
  p.orb.n_features = 2000;  // ORB-SLAM2 KITTI settings
  FeatureFrontend fe(cam, p);
  const Frame f = fe.process(in);
  ASSERT_GE(f.size(), 1900u);
  const auto& st = fe.lastStereoStats();
  int matched = 0;
  std::vector<float> depths;
  for (size_t i = 0; i < f.size(); i++) {
    if (f.u_right[i] < 0) {
      EXPECT_EQ(f.depth[i], -1.0f);
      continue;
    }
    matched++;
    const float disp = f.keypoints[i].pt.x - f.u_right[i];
    EXPECT_GT(disp, 0.0f);
    EXPECT_LT(disp, kFx);
    EXPECT_GT(f.depth[i], 0.0f);
    EXPECT_NEAR(f.depth[i], kBf / disp, 1e-3 * f.depth[i]);
    depths.push_back(f.depth[i]);
  }
  EXPECT_EQ(matched, st.matched);
  EXPECT_GE(matched, 500);
  std::sort(depths.begin(), depths.end());
  const float med = depths[depths.size() / 2];
  // A street scene: most points between a few metres and the horizon.
  EXPECT_GT(med, 4.0f);
  EXPECT_LT(med, 40.0f);
  std::cout << "[ kitti    ] " << f.size() << " keypoints, " << st.candidates << " descriptor matches, " << matched
            << " stereo matches (" << st.outliers << " outliers removed), median depth " << med << " m\n";
}

TEST(StereoRectification, EurocRawCalibration) {
  const CameraModel cam = euroc();
  const StereoRectification r = computeStereoRectification(cam);
  // ORB-SLAM2's EuRoC.yaml (rectified with the same calibration): bf = 47.906, i.e. baseline 0.110 m.
  EXPECT_NEAR(r.baseline, 0.110078, 5e-4);
  EXPECT_NEAR(r.model.bf() / r.left.fx, r.baseline, 1e-12);
  EXPECT_TRUE(r.model.rectified);
  EXPECT_FALSE(r.model.left.hasDistortion());
  EXPECT_GT(r.left.fx, 380);
  EXPECT_LT(r.left.fx, 460);
  // Rectified images: a raw left pixel and its rectified position see the same ray.
  const cv::Point2f raw(500.f, 100.f);
  const Eigen::Vector2d und = cam.left.undistort(raw.x, raw.y);
  const cv::Vec3d ray = r.R_left * cv::Vec3d((und.x() - cam.left.cx) / cam.left.fx, (und.y() - cam.left.cy) / cam.left.fy, 1);
  const cv::Point2f rect(static_cast<float>(r.left.fx * ray[0] / ray[2] + r.left.cx),
                         static_cast<float>(r.left.fy * ray[1] / ray[2] + r.left.cy));
  cv::Mat img(480, 752, CV_8UC1, cv::Scalar(0));
  cv::circle(img, cv::Point(500, 100), 2, cv::Scalar(255), cv::FILLED);
  cv::Mat out;
  cv::remap(img, out, r.map_left1, r.map_left2, cv::INTER_LINEAR);
  const cv::Moments m = cv::moments(out, false);
  EXPECT_NEAR(m.m10 / m.m00, rect.x, 0.5);
  EXPECT_NEAR(m.m01 / m.m00, rect.y, 0.5);
}

TEST(StereoRectification, RejectsBadRigs) {
  CameraModel c = euroc();
  c.right.width = 640;
  EXPECT_THROW(computeStereoRectification(c), ConfigError);
  c = euroc();
  c.T_left_right = c.T_left_right.inverse();  // right camera on the left
  EXPECT_THROW(computeStereoRectification(c), ConfigError);
  c = euroc();
  c.T_left_right = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0.11, 0));  // vertical rig
  EXPECT_THROW(computeStereoRectification(c), ConfigError);
  c = euroc();
  c.right.fx = 0;
  EXPECT_THROW(FeatureFrontend{c}, ConfigError);
  c = euroc();
  c.rectified = true;  // distortion on a "rectified" pair
  EXPECT_THROW(FeatureFrontend{c}, ConfigError);
}

TEST(StereoFrontend, RealEurocPairIsRectifiedAndMatched) {
  const std::string dir = test::shared("data/euroc-v101-micro/mav0");
  if (dir.empty()) GTEST_SKIP();
  const SensorFrame in = stereoPair(dir + "/cam0/data/1403715273262142976.png", dir + "/cam1/data/1403715273262142976.png");
  ASSERT_FALSE(in.image.empty());
  ASSERT_FALSE(in.image_right.empty());
  FrontendParams p;
  p.orb.n_features = 1200;  // ORB-SLAM2 EuRoC settings
  FeatureFrontend fe(euroc(), p);
  ASSERT_NE(fe.rectification(), nullptr);
  EXPECT_TRUE(fe.camera().rectified);
  EXPECT_NEAR(fe.camera().baseline, 0.110078, 5e-4);
  const Frame f = fe.process(in);
  EXPECT_GE(f.size(), 1100u);
  EXPECT_EQ(f.keypoints_un.size(), f.size());
  for (size_t i = 0; i < f.size(); i++) EXPECT_EQ(f.keypoints_un[i].pt, f.keypoints[i].pt);
  std::vector<float> depths;
  for (size_t i = 0; i < f.size(); i++)
    if (f.depth[i] > 0) depths.push_back(f.depth[i]);
  EXPECT_GE(depths.size(), 300u);
  std::sort(depths.begin(), depths.end());
  const float med = depths[depths.size() / 2];
  EXPECT_GT(med, 1.0f);  // Vicon room, drone on the ground
  EXPECT_LT(med, 10.0f);
  std::cout << "[ euroc    ] rectified fx " << fe.camera().left.fx << ", baseline " << fe.camera().baseline << ", "
            << depths.size() << " stereo matches of " << f.size() << ", median depth " << med << " m\n";

  // Mismatched right image -> DataError naming the frame.
  SensorFrame bad = in;
  bad.image_right = in.image_right(cv::Rect(0, 0, 640, 480)).clone();
  try {
    fe.process(bad);
    FAIL() << "no error";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("frame 0"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("640x480"), std::string::npos) << e.what();
  }
}
