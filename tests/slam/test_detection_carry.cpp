// Carrying detections to a later frame (asynchronous detection, every-N).
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "dslam/slam/detection_carry.h"

namespace dslam {
namespace {

/** Random texture with fine and coarse structure, like a real image
 *  (corners everywhere, and something for the coarse pyramid levels). */
cv::Mat texture(cv::Size s, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat sum(s, CV_32F, cv::Scalar(0));
  for (double sigma : {1.5, 4.0, 10.0}) {
    cv::Mat noise(s, CV_32F), t;
    rng.fill(noise, cv::RNG::UNIFORM, 0, 1);
    cv::GaussianBlur(noise, t, cv::Size(0, 0), sigma);
    cv::normalize(t, t, 0, 1, cv::NORM_MINMAX);
    sum += t;
  }
  cv::Mat out;
  cv::normalize(sum, sum, 0, 255, cv::NORM_MINMAX);
  sum.convertTo(out, CV_8U);
  return out;
}

/** Background with an object patch pasted at `at` (top-left), scaled by `scale`. */
cv::Mat scene(const cv::Mat& bg, const cv::Mat& obj, cv::Point2f at, double scale = 1.0) {
  cv::Mat im = bg.clone();
  cv::Mat o;
  cv::resize(obj, o, cv::Size(), scale, scale, cv::INTER_LINEAR);
  o.copyTo(im(cv::Rect(cvRound(at.x), cvRound(at.y), o.cols, o.rows)));
  return im;
}

struct Fixture {
  cv::Mat bg = texture({640, 480}, 1), obj = texture({120, 200}, 2);
};

/** The fixture's object as a detected person, where scene(.., {200, 150}) puts it. */
Detections personDetection() {
  Detections d;
  d.boxes.push_back({cv::Rect2f(200, 150, 120, 200), 1, 0.9f, -1});
  return d;
}

TEST(DetectionCarry, BoxMovesWithItsObject) {
  Fixture fx;
  const cv::Mat a = scene(fx.bg, fx.obj, {200, 150});
  const cv::Mat b = scene(fx.bg, fx.obj, {212, 143});  // the object moved by (12, -7); the background did not
  Detections d;
  d.frame_index = 10;
  d.boxes.push_back({cv::Rect2f(200, 150, 120, 200), 1, 0.9f, 3});
  const Detections c = carryDetections(d, a, b, 2);
  ASSERT_EQ(c.boxes.size(), 1u);
  EXPECT_NEAR(c.boxes[0].box.x, 212, 1.0);
  EXPECT_NEAR(c.boxes[0].box.y, 143, 1.0);
  EXPECT_NEAR(c.boxes[0].box.width, 120, 2.0);
  EXPECT_NEAR(c.boxes[0].box.height, 200, 2.0);
  EXPECT_EQ(c.age_frames, 2);
  EXPECT_EQ(c.frame_index, 10);  // still says which image the detector saw
  EXPECT_EQ(c.boxes[0].class_id, 1);
  EXPECT_EQ(c.boxes[0].instance_id, 3);
}

TEST(DetectionCarry, BoxFollowsAnApproachingObject) {
  Fixture fx;
  const cv::Mat a = scene(fx.bg, fx.obj, {200, 150});
  const cv::Mat b = scene(fx.bg, fx.obj, {194, 140}, 1.1);  // 10% larger, centre moved by (0, 0)
  Detections d;
  d.boxes.push_back({cv::Rect2f(200, 150, 120, 200), 1, 0.9f, -1});
  const Detections c = carryDetections(d, a, b, 1);
  const auto& r = c.boxes[0].box;
  EXPECT_NEAR(r.width / 120.f, 1.1f, 0.03f);
  EXPECT_NEAR(r.x + r.width / 2, 194 + 66, 1.5);
  EXPECT_NEAR(r.y + r.height / 2, 140 + 110, 1.5);
}

TEST(DetectionCarry, StaticImageLeavesEverythingInPlace) {
  Fixture fx;
  const cv::Mat a = scene(fx.bg, fx.obj, {200, 150});
  Detections d;
  d.boxes.push_back({cv::Rect2f(200, 150, 120, 200), 1, 0.9f, -1});
  const Detections c = carryDetections(d, a, a.clone(), 1);
  EXPECT_NEAR(c.boxes[0].box.x, 200, 0.1);
  EXPECT_NEAR(c.boxes[0].box.y, 150, 0.1);
}

TEST(DetectionCarry, TexturelessRegionStaysPut) {
  cv::Mat a(480, 640, CV_8U, cv::Scalar(128)), b = a.clone();
  Detections d;
  d.boxes.push_back({cv::Rect2f(100, 100, 50, 50), 1, 0.9f, -1});
  const Detections c = carryDetections(d, a, b, 1);
  EXPECT_FLOAT_EQ(c.boxes[0].box.x, 100.f);
  EXPECT_EQ(regionMotion(a, b, cv::Rect(100, 100, 50, 50), cv::Mat()).points, 0);
}

TEST(DetectionCarry, MasksMoveWithTheirRegions) {
  Fixture fx;
  const cv::Mat a = scene(fx.bg, fx.obj, {200, 150});
  const cv::Mat b = scene(fx.bg, fx.obj, {215, 150});  // object +15 px in x
  Detections d;
  d.panoptic = cv::Mat::zeros(480, 640, CV_32S);
  d.panoptic(cv::Rect(200, 150, 120, 200)).setTo(7);     // the object
  d.panoptic(cv::Rect(400, 50, 100, 100)).setTo(9);      // a static region
  PanopticSegment s7, s9;
  s7.id = 7;
  s7.bbox = cv::Rect(200, 150, 120, 200);
  s9.id = 9;
  s9.bbox = cv::Rect(400, 50, 100, 100);
  d.segments = {s7, s9};
  d.semantic = cv::Mat(480, 640, CV_8U, cv::Scalar(255));
  d.semantic(cv::Rect(200, 150, 120, 200)).setTo(1);  // person
  const Detections c = carryDetections(d, a, b, 1);
  // The object's pixels moved by 15 in x; the static region did not.
  EXPECT_EQ(c.panoptic.at<int32_t>(250, 330), 7);   // was outside (x = 330 > 319), now inside
  EXPECT_EQ(c.panoptic.at<int32_t>(250, 205), 0);   // left edge uncovered
  EXPECT_EQ(c.panoptic.at<int32_t>(100, 450), 9);
  EXPECT_EQ(c.segments[0].bbox, cv::Rect(215, 150, 120, 200));
  EXPECT_EQ(c.segments[1].bbox, cv::Rect(400, 50, 100, 100));
  EXPECT_EQ(c.semantic.at<uchar>(250, 330), 1);
  EXPECT_EQ(c.semantic.at<uchar>(250, 205), 255);
  EXPECT_EQ(cv::countNonZero(c.semantic == 1), 120 * 200);
}

TEST(DetectionCarry, ChainedCarriesReuseThePyramidAndGiveTheSameBoxes) {
  // Carried frame to frame (a -> b -> c), the second call reuses the pyramid
  // the first built for b; its boxes are those of a call that builds both
  // (bit for bit). An image changed in place after it was carried to is not
  // mistaken for the one the kept pyramid was built from.
  Fixture fx;
  const cv::Mat a = scene(fx.bg, fx.obj, {200, 150}), b = scene(fx.bg, fx.obj, {208, 146}),
                c = scene(fx.bg, fx.obj, {217, 141}), other = scene(fx.bg, fx.obj, {100, 100});
  Detections d;
  d.boxes.push_back({cv::Rect2f(200, 150, 120, 200), 1, 0.9f, 3});
  auto box = [](const Detections& x) { return x.boxes.at(0).box; };
  carryDetections(d, other, a, 1);  // leaves a's pyramid, not b's
  const cv::Rect2f fresh = box(carryDetections(d, b, c, 1));  // builds both
  carryDetections(d, a, b, 1);                                // keeps b's
  const cv::Rect2f chained = box(carryDetections(d, b, c, 1));
  EXPECT_EQ(chained, fresh);
  EXPECT_NEAR(chained.x, 200 + 217 - 208, 1.0);  // moved by (c - b)
  EXPECT_NEAR(chained.y, 150 + 141 - 146, 1.0);

  cv::Mat buf = b.clone();
  carryDetections(d, a, buf, 1);  // keeps the pyramid of buf as it is now
  scene(fx.bg, fx.obj, {230, 160}).copyTo(buf);  // same buffer, other pixels
  const cv::Rect2f changed = box(carryDetections(d, buf, c, 1));
  carryDetections(d, other, a, 1);
  EXPECT_EQ(changed, box(carryDetections(d, buf, c, 1)));
  EXPECT_NEAR(changed.x, 200 + 217 - 230, 1.0);  // moved by (c - buf), not (c - b)
  EXPECT_NEAR(changed.y, 150 + 141 - 160, 1.0);
}

TEST(DetectionCarry, HoldKeepsAMissedBoxAndMovesItWithItsObject) {
  Fixture fx;
  const cv::Mat a = scene(fx.bg, fx.obj, {200, 150});
  const cv::Mat b = scene(fx.bg, fx.obj, {212, 143});
  Detections prev;
  prev.boxes.push_back({cv::Rect2f(200, 150, 120, 200), 1, 0.9f, -1});
  prev.boxes.push_back({cv::Rect2f(450, 40, 60, 60), 3, 0.8f, -1});  // a car, reported again below
  Detections cur;  // the detector missed the person on the new image
  cur.frame_index = 21;
  cur.boxes.push_back({cv::Rect2f(452, 41, 60, 60), 3, 0.7f, -1});
  const std::vector<int> seen = holdMissedBoxes(prev, a, {18, 20}, cur, b, 21, 21, /*hold=*/5, /*flow=*/true);
  ASSERT_EQ(cur.boxes.size(), 2u) << "the missed person is held, the car not duplicated";
  EXPECT_EQ(cur.boxes[0].class_id, 3);
  EXPECT_EQ(cur.boxes[1].class_id, 1);
  EXPECT_NEAR(cur.boxes[1].box.x, 212, 1.0) << "held boxes move with their object";
  EXPECT_NEAR(cur.boxes[1].box.y, 143, 1.0);
  EXPECT_EQ(seen, (std::vector<int>{21, 18}));
}

TEST(DetectionCarry, HoldKeepsTheWholeBoxWhenOnlyAFragmentOfItIsReported) {
  Fixture fx;
  const cv::Mat a = scene(fx.bg, fx.obj, {200, 150});
  const Detections prev = personDetection();
  // The detector sees only the legs: 45 % of the box, all of it inside.
  const cv::Rect2f legs(205, 255, 108, 100);
  Detections cur;
  cur.boxes.push_back({legs, 1, 0.21f, -1});
  std::vector<int> seen = holdMissedBoxes(prev, a, {15}, cur, a, 16, 16, /*hold=*/5, true);
  ASSERT_EQ(cur.boxes.size(), 2u) << "the fragment and the whole person";
  EXPECT_NEAR(cur.boxes[1].box.x, 200, 1.0);
  EXPECT_NEAR(cur.boxes[1].box.height, 200, 2.0);
  EXPECT_EQ(seen, (std::vector<int>{16, 15}));
  // Boxes after holding, when the detector reports only `box`.
  auto held = [&](const cv::Rect2f& box, const HoldParams& hp = {}) {
    Detections c;
    c.boxes.push_back({box, 1, 0.6f, -1});
    holdMissedBoxes(prev, a, {15}, c, a, 16, 16, 5, true, hp);
    return c.boxes.size();
  };
  // Larger than fragment_area of it: the person reported again, it replaces the held box.
  EXPECT_EQ(held(cv::Rect2f(205, 190, 115, 160)), 1u);  // 77 %
  // Small but mostly outside it (under fragment_inside): another object of the class, it replaces as before.
  EXPECT_EQ(held(cv::Rect2f(250, 250, 100, 120)), 1u);  // IoU 0.24, 58 % inside
  // fragment_area 0: every overlapping box replaces (the rule off).
  HoldParams off;
  off.fragment_area = 0;
  EXPECT_EQ(held(legs, off), 1u);
}

TEST(DetectionCarry, HoldEndsAfterItsFramesAndWhenTheClassIsReportedThere) {
  Fixture fx;
  const cv::Mat a = scene(fx.bg, fx.obj, {200, 150});
  const Detections prev = personDetection();
  Detections cur;
  auto seen = holdMissedBoxes(prev, a, {10}, cur, a, 16, 16, /*hold=*/5, true);
  EXPECT_TRUE(cur.boxes.empty()) << "reported 6 frames ago, held 5";
  cur.boxes.push_back({cv::Rect2f(230, 160, 110, 190), 1, 0.5f, -1});  // the person, reported again
  seen = holdMissedBoxes(prev, a, {15}, cur, a, 16, 16, 5, true);
  EXPECT_EQ(cur.boxes.size(), 1u);
  holdMissedBoxes(prev, a, {15}, cur, a, 16, 16, /*hold=*/0, true);
  EXPECT_EQ(cur.boxes.size(), 1u) << "hold 0 is off";
  // Between detections, held boxes expire with their age.
  Detections d;
  d.boxes = {{cv::Rect2f(0, 0, 10, 10), 1, 1.f, -1}, {cv::Rect2f(20, 0, 10, 10), 1, 1.f, -1}};
  std::vector<int> s = {30, 22};
  dropExpiredBoxes(d, s, 30, 7);
  ASSERT_EQ(d.boxes.size(), 1u);
  EXPECT_EQ(d.boxes[0].box.x, 0);
  EXPECT_EQ(s, std::vector<int>{30});
}

// wait_coverage compares the union of the boxes, clipped to the image.
TEST(DetectionCarry, BoxCoverageIsTheUnionOfTheBoxesInsideTheImage) {
  const cv::Size size(100, 50);  // 5000 pixels
  Detections d;
  EXPECT_EQ(boxCoverage(d, size), 0.0);
  d.boxes.push_back({cv::Rect2f(0, 0, 40, 50), 1, 0.9f, 0});  // 2000
  EXPECT_DOUBLE_EQ(boxCoverage(d, size), 0.4);
  d.boxes.push_back({cv::Rect2f(20, 0, 40, 25), 1, 0.9f, 0});  // 1000, half of it inside the first
  EXPECT_DOUBLE_EQ(boxCoverage(d, size), 0.5);
  d.boxes.push_back({cv::Rect2f(90, 40, 50, 50), 1, 0.9f, 0});  // 10 x 10 inside the image
  EXPECT_DOUBLE_EQ(boxCoverage(d, size), 0.52);
  d.boxes.push_back({cv::Rect2f(-30, -30, 200, 200), 1, 0.9f, 0});
  EXPECT_DOUBLE_EQ(boxCoverage(d, size), 1.0);
  d.boxes = {{cv::Rect2f(200, 0, 10, 10), 1, 0.9f, 0}};  // outside
  EXPECT_EQ(boxCoverage(d, size), 0.0);
}

}  // namespace
}  // namespace dslam
