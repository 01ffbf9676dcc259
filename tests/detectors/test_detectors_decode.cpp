// Model-independent decoding: crafted output blobs through the YOLO (Darknet
// region) and YOLOX decoders, letterbox and NMS.
#include <gtest/gtest.h>

#include <cmath>

#include "dslam/core/error.h"
#include "dslam/plugins/detectors/decode.h"

using namespace dslam;
using namespace dslam::det;

namespace {

void expectRect(const cv::Rect2f& r, float x, float y, float w, float h, float tol = 1e-3f) {
  EXPECT_NEAR(r.x, x, tol);
  EXPECT_NEAR(r.y, y, tol);
  EXPECT_NEAR(r.width, w, tol);
  EXPECT_NEAR(r.height, h, tol);
}

/** 3 rows of a 2-class region output. */
cv::Mat regionBlob() {
  cv::Mat m(3, 7, CV_32F, cv::Scalar(0));
  const float r0[] = {0.5f, 0.5f, 0.25f, 0.5f, 0.9f, 0.1f, 0.8f};     // class 1, score 0.8
  const float r1[] = {0.1f, 0.1f, 0.1f, 0.1f, 0.3f, 0.15f, 0.05f};    // below 0.2
  const float r2[] = {0.25f, 0.75f, 0.1f, 0.2f, 0.7f, 0.6f, 0.3f};    // class 0, score 0.6
  std::copy(r0, r0 + 7, m.ptr<float>(0));
  std::copy(r1, r1 + 7, m.ptr<float>(1));
  std::copy(r2, r2 + 7, m.ptr<float>(2));
  return m;
}

}  // namespace

TEST(YoloRegionDecode, BoxesScaledToImageAndThresholded) {
  std::vector<RawBox> boxes;
  decodeYoloRegion(regionBlob(), "yolo_1", 2, 0.2f, cv::Size(640, 480), false, boxes);
  ASSERT_EQ(boxes.size(), 2u);
  // cx 0.5*640 = 320, w 0.25*640 = 160; cy 0.5*480 = 240, h 0.5*480 = 240.
  expectRect(boxes[0].box, 240, 120, 160, 240);
  EXPECT_EQ(boxes[0].class_index, 1);
  EXPECT_FLOAT_EQ(boxes[0].score, 0.8f);
  // cx 160, cy 360, w 64, h 96.
  expectRect(boxes[1].box, 128, 312, 64, 96);
  EXPECT_EQ(boxes[1].class_index, 0);
  EXPECT_FLOAT_EQ(boxes[1].score, 0.6f);
}

TEST(YoloRegionDecode, MultiplyObjectnessAndThreeDimBlob) {
  cv::Mat m2 = regionBlob();
  const int sz[] = {1, 3, 7};
  cv::Mat m3(3, sz, CV_32F, m2.ptr<float>());
  std::vector<RawBox> boxes;
  decodeYoloRegion(m3, "yolo_1", 2, 0.4f, cv::Size(100, 100), true, boxes);
  // 0.9 * 0.8 = 0.72 kept, 0.7 * 0.6 = 0.42 kept, row 1 0.045 dropped.
  ASSERT_EQ(boxes.size(), 2u);
  EXPECT_NEAR(boxes[0].score, 0.72f, 1e-6);
  EXPECT_NEAR(boxes[1].score, 0.42f, 1e-6);
  boxes.clear();
  decodeYoloRegion(m3, "yolo_1", 2, 0.5f, cv::Size(100, 100), true, boxes);
  ASSERT_EQ(boxes.size(), 1u);
  EXPECT_EQ(boxes[0].class_index, 1);
}

TEST(YoloRegionDecode, WrongShapeNamesLayerAndShape) {
  std::vector<RawBox> boxes;
  try {
    decodeYoloRegion(regionBlob(), "yolo_23", 80, 0.2f, cv::Size(320, 320), false, boxes);
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("yolo_23"), std::string::npos) << w;
    EXPECT_NE(w.find("[3x7]"), std::string::npos) << w;
    EXPECT_NE(w.find("85"), std::string::npos) << w;
  }
  const int sz[] = {1, 3, 4, 4};
  cv::Mat m4(4, sz, CV_32F, cv::Scalar(0));
  try {
    decodeYoloRegion(m4, "conv_9", -1, 0.2f, cv::Size(320, 320), false, boxes);
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("conv_9"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("[1x3x4x4]"), std::string::npos) << e.what();
  }
  EXPECT_THROW(decodeYoloRegion(cv::Mat(), "x", 2, 0.2f, cv::Size(1, 1), false, boxes), DataError);
  EXPECT_TRUE(boxes.empty());
}

TEST(YoloxDecode, GridStridesAndRatio) {
  const cv::Size input(64, 64);
  const std::vector<int> strides = {8, 16, 32};
  const int n = yoloxAnchorCount(input, strides);
  ASSERT_EQ(n, 64 + 16 + 4);
  const int sz[] = {1, n, 85};
  cv::Mat out(3, sz, CV_32F, cv::Scalar(0));
  cv::Mat rows(n, 85, CV_32F, out.ptr<float>());
  // Stride 8, grid cell (gx 3, gy 2) -> row 2 * 8 + 3 = 19.
  float* a = rows.ptr<float>(19);
  a[0] = 0.5f, a[1] = 0.25f, a[2] = std::log(2.f), a[3] = std::log(4.f), a[4] = 0.9f, a[5 + 17] = 0.8f;
  // Stride 32, cell (1, 1) -> row 64 + 16 + 1 * 2 + 1 = 83.
  float* b = rows.ptr<float>(83);
  b[0] = 0.f, b[1] = 0.f, b[2] = 0.f, b[3] = 0.f, b[4] = 0.5f, b[5 + 0] = 0.9f;
  // Below threshold: 0.5 * 0.5.
  float* c = rows.ptr<float>(70);
  c[4] = 0.5f, c[5 + 3] = 0.5f;

  std::vector<RawBox> boxes;
  decodeYolox(out, "output", input, strides, 0.5f, 80, 0.3f, boxes);
  ASSERT_EQ(boxes.size(), 2u);
  // cx (0.5 + 3) * 8 = 28, cy (0.25 + 2) * 8 = 18, w 2 * 8 = 16, h 4 * 8 = 32
  // -> (20, 2, 16, 32) in input pixels, / ratio 0.5 -> (40, 4, 32, 64).
  expectRect(boxes[0].box, 40, 4, 32, 64, 1e-3f);
  EXPECT_EQ(boxes[0].class_index, 17);
  EXPECT_NEAR(boxes[0].score, 0.72f, 1e-6);
  // cx = cy = 32, w = h = 32 -> (16, 16, 32, 32) / 0.5 -> (32, 32, 64, 64).
  expectRect(boxes[1].box, 32, 32, 64, 64, 1e-3f);
  EXPECT_EQ(boxes[1].class_index, 0);
  EXPECT_NEAR(boxes[1].score, 0.45f, 1e-6);
}

TEST(YoloxDecode, WrongAnchorCountNamesLayerAndShape) {
  const int sz[] = {1, 3549, 85};
  cv::Mat out(3, sz, CV_32F, cv::Scalar(0));
  std::vector<RawBox> boxes;
  // 3549 anchors fit 416x416, not 320x320 (2100).
  EXPECT_NO_THROW(decodeYolox(out, "output", cv::Size(416, 416), {8, 16, 32}, 1.f, 80, 0.3f, boxes));
  try {
    decodeYolox(out, "output", cv::Size(320, 320), {8, 16, 32}, 1.f, 80, 0.3f, boxes);
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("'output'"), std::string::npos) << w;
    EXPECT_NE(w.find("[1x3549x85]"), std::string::npos) << w;
    EXPECT_NE(w.find("2100"), std::string::npos) << w;
  }
}

TEST(Letterbox, ResizesIntoTopLeftAndPads) {
  cv::Mat img(50, 100, CV_8UC3, cv::Scalar(10, 20, 30));
  float ratio = 0;
  cv::Mat lb = letterbox(img, cv::Size(64, 64), 114, ratio);
  EXPECT_FLOAT_EQ(ratio, 0.64f);
  ASSERT_EQ(lb.size(), cv::Size(64, 64));
  EXPECT_EQ(lb.at<cv::Vec3b>(0, 0), cv::Vec3b(10, 20, 30));
  EXPECT_EQ(lb.at<cv::Vec3b>(31, 63), cv::Vec3b(10, 20, 30));  // 50 * 0.64 = 32 rows of image
  EXPECT_EQ(lb.at<cv::Vec3b>(32, 0), cv::Vec3b(114, 114, 114));
  EXPECT_EQ(lb.at<cv::Vec3b>(63, 63), cv::Vec3b(114, 114, 114));
}

TEST(Nms, PerClassAndAgnostic) {
  std::vector<RawBox> in = {
      {cv::Rect2f(0, 0, 10, 10), 0, 0.6f},
      {cv::Rect2f(1, 1, 10, 10), 0, 0.9f},    // overlaps the first (IoU 0.68)
      {cv::Rect2f(0, 0, 10, 10), 1, 0.7f},    // same place, other class
      {cv::Rect2f(50, 50, 10, 10), 0, 0.5f},  // elsewhere
      {cv::Rect2f(80, 80, 10, 10), 0, 0.1f},  // below the score threshold
  };
  auto pc = nms(in, 0.2f, 0.45f, true);
  ASSERT_EQ(pc.size(), 3u);
  EXPECT_FLOAT_EQ(pc[0].score, 0.9f);
  EXPECT_EQ(pc[1].class_index, 1);
  EXPECT_FLOAT_EQ(pc[2].score, 0.5f);
  auto ag = nms(in, 0.2f, 0.45f, false);
  ASSERT_EQ(ag.size(), 2u);
  EXPECT_FLOAT_EQ(ag[0].score, 0.9f);
  EXPECT_FLOAT_EQ(ag[1].score, 0.5f);
  // A looser IoU threshold keeps the overlapping pair.
  EXPECT_EQ(nms(in, 0.2f, 0.7f, true).size(), 4u);
}

TEST(ClipBox, ClipsToImage) {
  const auto r = clipBox(cv::Rect2f(-5, 10, 20, 100), cv::Size(40, 50));
  expectRect(r, 0, 10, 15, 40);
  EXPECT_LE(clipBox(cv::Rect2f(100, 100, 5, 5), cv::Size(40, 50)).area(), 0.f);
}
