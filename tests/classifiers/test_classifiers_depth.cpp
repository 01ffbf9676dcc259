// DepthRepopulation and EkfObjectTracker on hand-made depth frames.
#include <gtest/gtest.h>

#include <cmath>

#include "classifier_test_util.h"
#include "dslam/core/error.h"
#include "dslam/plugins/classifiers/box_filter.h"
#include "dslam/plugins/classifiers/depth_repopulation.h"
#include "dslam/plugins/classifiers/ekf_object_tracker.h"

using namespace dslam;
using namespace dslam::test;

namespace {

/** Frame with a depth image and keypoint depths sampled from it. */
Frame depthFrame(const cv::Mat& depth, const std::vector<cv::Point2f>& pts, int index = 0, double t = 0) {
  Frame f = makeFrame(pts, depth.size(), index, t);
  f.input.depth = depth;
  for (size_t i = 0; i < pts.size(); i++)
    f.depth[i] = depth.at<float>(static_cast<int>(std::lround(pts[i].y)), static_cast<int>(std::lround(pts[i].x)));
  return f;
}

}  // namespace

// Person at 1.5 m covering the box centre, wall at 4 m around it.
TEST(DepthRepopulation, KeepsBackgroundBehindPersonDropsPerson) {
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(4.0f));
  depth(cv::Rect(250, 100, 100, 300)).setTo(1.5f);  // the person (inside the box, covers its centre)
  depth(cv::Rect(420, 250, 80, 120)).setTo(2.0f);   // a chair in front of the wall
  Detections d;
  d.boxes = {box(200, 100, 200, 300, 1), box(410, 240, 100, 140, 62)};
  const std::vector<cv::Point2f> pts = {
      {300, 200}, {270, 380}, {330, 120},  // on the person
      {220, 150}, {380, 350}, {210, 390},  // wall seen inside the person box
      {460, 300}, {415, 245},              // on the chair / wall inside the chair box
      {100, 100}, {600, 450}};             // outside every box
  Frame f = depthFrame(depth, pts);
  auto bf = makeClassifier<BoxFilter>("BoxFilter");
  auto rep = makeClassifier<DepthRepopulation>("DepthRepopulation");
  bf->classify(f, d, {});  // Crowd-SLAM first: the whole person box is dropped
  EXPECT_EQ(f.countLabel(KpLabel::Dynamic), 6u);
  rep->classify(f, d, {});
  for (int i : {0, 1, 2}) {
    EXPECT_EQ(f.meta[i].label, KpLabel::Dynamic) << i;
    EXPECT_EQ(f.meta[i].reason, KpReason::InDynamicBox) << i;
    EXPECT_EQ(f.meta[i].class_id, 1) << i;
  }
  for (int i : {3, 4, 5}) {
    EXPECT_EQ(f.meta[i].label, KpLabel::Static) << i;
    EXPECT_EQ(f.meta[i].reason, KpReason::BoxBackground) << i;
    EXPECT_EQ(f.meta[i].class_id, -1) << i;  // the box filter's person class is withdrawn
  }
  EXPECT_EQ(f.meta[6].label, KpLabel::Movable);
  EXPECT_EQ(f.meta[6].reason, KpReason::OnObject);
  EXPECT_EQ(f.meta[6].class_id, 62);
  EXPECT_EQ(f.meta[7].label, KpLabel::Static);
  EXPECT_EQ(f.meta[7].reason, KpReason::BoxBackground);
  EXPECT_EQ(f.meta[8].reason, KpReason::None);
  EXPECT_EQ(f.meta[9].reason, KpReason::None);

  ASSERT_EQ(rep->lastStats().size(), 2u);
  const BoxDepthStats& s = rep->lastStats()[0];
  EXPECT_FLOAT_EQ(s.min, 1.5f);
  EXPECT_FLOAT_EQ(s.max, 4.0f);
  EXPECT_FLOAT_EQ(s.object_depth, 1.5f);
  EXPECT_FLOAT_EQ(s.center_depth, 1.5f);
  EXPECT_FLOAT_EQ(s.median, 4.0f);  // the person fills exactly half the box: upper median
  EXPECT_NEAR(s.mean, 2.75f, 0.02f);
  EXPECT_NEAR(s.stddev, 1.25f, 0.02f);
  EXPECT_FALSE(s.occluded);
  EXPECT_FLOAT_EQ(rep->lastStats()[1].object_depth, 2.0f);
}

TEST(DepthRepopulation, ClassMarginsAndEarlierReasons) {
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(2.3f));  // wall only 0.8 m behind the person
  depth(cv::Rect(250, 100, 100, 300)).setTo(1.5f);
  Detections d;
  d.boxes = {box(200, 100, 200, 300, 1)};
  const std::vector<cv::Point2f> pts = {{220, 150}, {380, 350}, {300, 200}};
  {  // default margin 0.5: 2.3 > 2.0 -> background
    Frame f = depthFrame(depth, pts);
    f.meta[1] = {KpLabel::Dynamic, KpReason::EpipolarOutlier, -1, -1};  // other evidence: never lowered
    makeClassifier<DepthRepopulation>("DepthRepopulation")->classify(f, d, {});
    EXPECT_EQ(f.meta[0].label, KpLabel::Static);
    EXPECT_EQ(f.meta[1].label, KpLabel::Dynamic);
    EXPECT_EQ(f.meta[1].reason, KpReason::EpipolarOutlier);
    EXPECT_EQ(f.meta[2].label, KpLabel::Dynamic);
  }
  {  // person margin 1.0: the wall at 2.3 m is still "on the person"
    Frame f = depthFrame(depth, pts);
    makeClassifier<DepthRepopulation>("DepthRepopulation", "depth_margin: {person: 1.0, default: 0.5}")
        ->classify(f, d, {});
    EXPECT_EQ(f.countLabel(KpLabel::Dynamic), 3u);
  }
  register_classifiers_plugins();
  auto p = create<KeypointClassifier>("dslam::DepthRepopulation");
  EXPECT_THROW(p->configure(Params::resolve(p->paramSpecs(), "depth_margin: {persn: 1.0, default: 0.5}"), {}),
               ConfigError);
  EXPECT_THROW(p->configure(Params::resolve(p->paramSpecs(), "depth_margin: {person: 1.0}"), {}), ConfigError);
}

// Person at 2.5 m at the box centre, an unlabelled occluder at 1.0 m over the
// bottom of the box: the nearest surface is not the person -> the box's
// keypoints are unusable, including the wall ones.
TEST(DepthRepopulation, UnlabelledOccluderMakesBoxUnusable) {
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(4.0f));
  depth(cv::Rect(250, 100, 100, 300)).setTo(2.5f);
  depth(cv::Rect(150, 320, 300, 80)).setTo(1.0f);  // table edge in front, not detected
  Detections d;
  d.boxes = {box(200, 100, 200, 300, 1)};
  const std::vector<cv::Point2f> pts = {{300, 200}, {220, 150}, {380, 250}, {300, 350}, {100, 100}};
  Frame f = depthFrame(depth, pts);
  auto rep = makeClassifier<DepthRepopulation>("DepthRepopulation");
  rep->classify(f, d, {});
  for (int i : {0, 1, 2, 3}) {
    EXPECT_EQ(f.meta[i].label, KpLabel::Dynamic) << i;
    EXPECT_EQ(f.meta[i].reason, KpReason::Occluded) << i;
  }
  EXPECT_EQ(f.meta[4].label, KpLabel::Static);
  ASSERT_EQ(rep->lastStats().size(), 1u);
  EXPECT_TRUE(rep->lastStats()[0].occluded);
  EXPECT_FLOAT_EQ(rep->lastStats()[0].object_depth, 1.0f);
  EXPECT_FLOAT_EQ(rep->lastStats()[0].center_depth, 2.5f);

  // No single surface at the box centre (person/wall edge through the centre window): occluded by std.
  cv::Mat d2(480, 640, CV_32F, cv::Scalar(4.0f));
  d2(cv::Rect(200, 100, 100, 300)).setTo(1.5f);  // person fills the left half, edge at x = 300
  Frame g = depthFrame(d2, {{250, 200}, {350, 200}});
  rep->classify(g, d, {});
  EXPECT_TRUE(rep->lastStats()[0].occluded);
  EXPECT_GT(rep->lastStats()[0].center_std, 0.3f);
  EXPECT_EQ(g.meta[1].reason, KpReason::Occluded);
}

// A chair in front of a wall: its frame (posts, top rail, seat) spans the box,
// the wall is seen through it, so the box centre is deeper than its front.
// The near layer spanning the box is the chair itself: not an occluder.
TEST(DepthRepopulation, SeeThroughObjectIsNoOccluder) {
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(4.0f));
  depth(cv::Rect(200, 100, 16, 300)).setTo(2.0f);  // left post
  depth(cv::Rect(384, 100, 16, 300)).setTo(2.0f);  // right post
  depth(cv::Rect(200, 100, 200, 20)).setTo(2.0f);  // top rail
  depth(cv::Rect(200, 270, 200, 14)).setTo(2.1f);  // seat
  Detections d;
  d.boxes = {box(200, 100, 200, 300, 62)};
  const std::vector<cv::Point2f> pts = {{300, 276}, {208, 200}, {300, 180}, {300, 350}};  // seat, post, wall, wall
  auto rep = makeClassifier<DepthRepopulation>("DepthRepopulation");
  Frame f = depthFrame(depth, pts);
  rep->classify(f, d, {});
  ASSERT_EQ(rep->lastStats().size(), 1u);
  const BoxDepthStats& st = rep->lastStats()[0];
  EXPECT_GT(st.center_depth, st.object_depth + st.margin);  // the plain test would call it occluded
  EXPECT_GT(st.near_span_x, 0.9f);
  EXPECT_GT(st.near_span_y, 0.9f);
  EXPECT_FALSE(st.occluded);
  for (int i : {0, 1}) {
    EXPECT_EQ(f.meta[i].label, KpLabel::Movable) << i;
    EXPECT_EQ(f.meta[i].class_id, 62) << i;
  }
  for (int i : {2, 3}) EXPECT_EQ(f.meta[i].reason, KpReason::BoxBackground) << i;

  auto plain = makeClassifier<DepthRepopulation>("DepthRepopulation", "occlusion_span: 0");
  Frame g = depthFrame(depth, pts);
  plain->classify(g, d, {});
  EXPECT_TRUE(plain->lastStats()[0].occluded);
  EXPECT_EQ(g.countLabel(KpLabel::Dynamic), 4u);

  // People keep the plain test (dynamic_classes): the same shape as a person box is occluded.
  Detections p = d;
  p.boxes[0].class_id = 1;
  Frame h = depthFrame(depth, pts);
  rep->classify(h, p, {});
  EXPECT_TRUE(rep->lastStats()[0].occluded);
}

// A desk seen from standing height: its top is a band across the box (a
// under half of its height, 2.7-3.0 m), the legs are thin, the wall under it is
// at 4.3 m, so the box centre is deeper than the front. The near layer spans
// the width but not the height: for a table (see_through_classes) that is
// the table seen through, not an occluder; for a class outside the list (or
// with the default see_through_classes: []) the same depths are an occluder.
TEST(DepthRepopulation, TableTopAcrossTheBoxIsNoOccluderForSeeThroughClasses) {
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(4.3f));
  for (int y = 150; y < 250; y++) depth(cv::Rect(200, y, 240, 1)).setTo(2.7f + 0.003f * (y - 150));  // top
  depth(cv::Rect(204, 250, 2, 100)).setTo(2.75f);  // front legs, 2 px wide: under 2 % of the near layer's samples
  depth(cv::Rect(432, 250, 2, 100)).setTo(2.75f);
  Detections d;
  d.boxes = {box(200, 150, 240, 230, 67)};
  const std::vector<cv::Point2f> pts = {{300, 170}, {400, 230}, {320, 300}, {260, 360}};  // top, top, wall, wall
  auto rep = makeClassifier<DepthRepopulation>("DepthRepopulation", "see_through_classes: [67]");
  Frame f = depthFrame(depth, pts);
  rep->classify(f, d, {});
  ASSERT_EQ(rep->lastStats().size(), 1u);
  const BoxDepthStats& st = rep->lastStats()[0];
  EXPECT_GT(st.center_depth, st.object_depth + st.margin);
  EXPECT_GT(st.near_span_x, 0.9f);
  EXPECT_LT(st.near_span_y, 0.5f);
  EXPECT_FALSE(st.occluded);
  for (int i : {0, 1}) {
    EXPECT_EQ(f.meta[i].label, KpLabel::Movable) << i;
    EXPECT_EQ(f.meta[i].class_id, 67) << i;
  }
  for (int i : {2, 3}) EXPECT_EQ(f.meta[i].reason, KpReason::BoxBackground) << i;

  Detections other = d;
  other.boxes[0].class_id = 63;  // couch: needs width and height
  Frame g = depthFrame(depth, pts);
  rep->classify(g, other, {});
  EXPECT_TRUE(rep->lastStats()[0].occluded);
  auto strict = makeClassifier<DepthRepopulation>("DepthRepopulation");
  Frame h = depthFrame(depth, pts);
  strict->classify(h, d, {});
  EXPECT_TRUE(strict->lastStats()[0].occluded);
  EXPECT_EQ(h.countLabel(KpLabel::Dynamic), 4u);
}

// A table seen from above: its top recedes from 2.7 m (the thin front edge)
// to 3.3 m, the wall under it is at 4.3 m. From the nearest point (the paper's
// minimum) the back of the top lies beyond depth_margin and is taken for
// background; with class_percentile the table's depth is the 20th percentile
// of its box and the whole top is on it, the wall still behind.
TEST(DepthRepopulation, ClassPercentilePlacesATableDeeperThanItsFrontEdge) {
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(4.3f));
  for (int y = 150; y < 250; y++) depth(cv::Rect(200, y, 240, 1)).setTo(2.7f + 0.006f * static_cast<float>(y - 150));
  Detections d;
  d.boxes = {box(200, 150, 240, 230, 67)};
  const std::vector<cv::Point2f> pts = {{300, 155}, {320, 245}, {320, 330}};  // front edge, back of the top, wall
  auto run = [&](const std::string& params, Frame& f) {
    auto rep = makeClassifier<DepthRepopulation>("DepthRepopulation", params);
    f = depthFrame(depth, pts);
    rep->classify(f, d, {});
    EXPECT_FALSE(rep->lastStats().at(0).occluded) << params;
    return rep->lastStats().at(0).object_depth;
  };
  Frame minimum, pct, other;
  EXPECT_NEAR(run("see_through_classes: [67]", minimum), 2.7, 0.01);
  EXPECT_EQ(minimum.meta[0].class_id, 67);
  EXPECT_EQ(minimum.meta[1].reason, KpReason::BoxBackground);
  EXPECT_EQ(minimum.meta[2].reason, KpReason::BoxBackground);

  const double z = run("{see_through_classes: [67], class_percentile: {dining table: 20}}", pct);
  EXPECT_GT(z, 2.9);  // 20 % of the box samples: within the top (43 % of the rows)
  EXPECT_LT(z, 3.1);
  for (int i : {0, 1}) {
    EXPECT_EQ(pct.meta[i].label, KpLabel::Movable) << i;
    EXPECT_EQ(pct.meta[i].class_id, 67) << i;
  }
  EXPECT_EQ(pct.meta[2].reason, KpReason::BoxBackground);

  // Other classes keep min_percentile ('default' replaces it).
  EXPECT_NEAR(run("{see_through_classes: [67], class_percentile: {chair: 20}}", other), 2.7, 0.01);
  EXPECT_EQ(other.meta[1].reason, KpReason::BoxBackground);
  Frame dflt;
  EXPECT_NEAR(run("{see_through_classes: [67], class_percentile: {chair: 0, default: 20}}", dflt), z, 1e-6);

  register_classifiers_plugins();
  auto p = create<KeypointClassifier>("dslam::DepthRepopulation");
  EXPECT_THROW(p->configure(Params::resolve(p->paramSpecs(), "class_percentile: {desk: 20}"), {}), ConfigError);
  EXPECT_THROW(p->configure(Params::resolve(p->paramSpecs(), "class_percentile: {chair: 60}"), {}), ConfigError);
  EXPECT_THROW(p->configure(Params::resolve(p->paramSpecs(), "class_percentile: {default: -1}"), {}), ConfigError);
}

// A monitor at 3.2 m (wall at 4 m around it) whose box has the edge of a
// fridge at 2.2 m down its left 15 %, beyond the fridge's own box: the box is
// occluded (Changing-SLAM: every keypoint Dynamic); with side_occluder_span
// the monitor is the surface at the centre, the fridge's edge stays Dynamic.
TEST(DepthRepopulation, SideOccluderLeavesTheObjectAtTheCentre) {
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(4.0f));
  depth(cv::Rect(300, 100, 100, 100)).setTo(3.2f);  // monitor
  depth(cv::Rect(300, 80, 15, 140)).setTo(2.2f);    // fridge edge over its left side
  Detections d;
  d.boxes = {box(300, 100, 100, 100, 72)};
  const std::vector<cv::Point2f> pts = {{350, 150}, {380, 120}, {307, 150}};  // monitor, monitor, fridge edge
  auto paper = makeClassifier<DepthRepopulation>("DepthRepopulation");
  Frame f = depthFrame(depth, pts);
  paper->classify(f, d, {});
  EXPECT_TRUE(paper->lastStats().at(0).occluded);
  EXPECT_EQ(f.countLabel(KpLabel::Dynamic), 3u);

  auto side = makeClassifier<DepthRepopulation>("DepthRepopulation", "side_occluder_span: 0.3");
  Frame g = depthFrame(depth, pts);
  side->classify(g, d, {});
  const BoxDepthStats& st = side->lastStats().at(0);
  EXPECT_FALSE(st.occluded);
  EXPECT_NEAR(st.occluder_depth, 2.2, 0.01);
  EXPECT_NEAR(st.object_depth, 3.2, 0.01);
  for (int i : {0, 1}) {
    EXPECT_EQ(g.meta[i].label, KpLabel::Movable) << i;
    EXPECT_EQ(g.meta[i].class_id, 72) << i;
  }
  EXPECT_EQ(g.meta[2].label, KpLabel::Dynamic);
  EXPECT_EQ(g.meta[2].reason, KpReason::Occluded);

  // An occluder over 40 % of the width is no side occluder: the box stays unusable.
  depth(cv::Rect(300, 80, 40, 140)).setTo(2.2f);
  Frame h = depthFrame(depth, pts);
  side->classify(h, d, {});
  EXPECT_TRUE(side->lastStats().at(0).occluded);
  EXPECT_EQ(h.countLabel(KpLabel::Dynamic), 3u);
}

// An unlabelled box at 1.5 m covers the left 40 % of a table's box (table at
// 3 m): the near layer does not span the box, the occluder is still caught.
TEST(DepthRepopulation, UnlabelledThingInFrontOfPartOfABoxIsStillAnOccluder) {
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(4.5f));
  depth(cv::Rect(200, 100, 200, 300)).setTo(3.0f);  // the table
  depth(cv::Rect(200, 100, 80, 300)).setTo(1.5f);   // unlabelled box in front of its left part
  Detections d;
  d.boxes = {box(200, 100, 200, 300, 67)};
  Frame f = depthFrame(depth, {{240, 200}, {330, 250}});
  auto rep = makeClassifier<DepthRepopulation>("DepthRepopulation");
  rep->classify(f, d, {});
  const BoxDepthStats& st = rep->lastStats()[0];
  EXPECT_NEAR(st.near_span_x, 0.4f, 0.03f);
  EXPECT_TRUE(st.occluded);
  EXPECT_EQ(f.countLabel(KpLabel::Dynamic), 2u);
}

// A labelled plant at 2 m in front of a fridge at 3 m; the plant's box is a
// few pixels too narrow (detector jitter), leaving a sliver of the plant in
// the fridge's box outside the plain overlap. Widened by overlap_dilation,
// the plant's box takes the sliver out of the fridge's statistics.
TEST(DepthRepopulation, LabelledObjectInFrontIsNoOccluderDespiteBoxJitter) {
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(4.5f));
  depth(cv::Rect(300, 100, 150, 300)).setTo(3.0f);  // fridge
  depth(cv::Rect(250, 250, 88, 150)).setTo(2.0f);   // plant: pixels up to x = 338
  Detections d;
  d.boxes = {box(300, 100, 150, 300, 82), box(250, 250, 80, 150, 64)};  // plant box ends at x = 330
  const std::vector<cv::Point2f> pts = {{400, 200}, {420, 350}};
  auto rep = makeClassifier<DepthRepopulation>("DepthRepopulation");
  Frame f = depthFrame(depth, pts);
  rep->classify(f, d, {});
  EXPECT_FLOAT_EQ(rep->lastStats()[0].object_depth, 3.0f);
  EXPECT_FALSE(rep->lastStats()[0].occluded);
  EXPECT_EQ(f.meta[0].label, KpLabel::Movable);
  auto exact = makeClassifier<DepthRepopulation>("DepthRepopulation", "overlap_dilation: 0");
  Frame g = depthFrame(depth, pts);
  exact->classify(g, d, {});
  EXPECT_FLOAT_EQ(exact->lastStats()[0].object_depth, 2.0f);  // the sliver is the nearest surface
  EXPECT_TRUE(exact->lastStats()[0].occluded);
}

TEST(DepthRepopulation, SharedAreaOfOverlappingBoxesIsIgnored) {
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(4.0f));
  depth(cv::Rect(250, 100, 100, 300)).setTo(1.5f);  // person A
  depth(cv::Rect(370, 200, 80, 200)).setTo(0.8f);   // person B, partly inside A's box
  Detections d;
  d.boxes = {box(200, 100, 200, 300, 1), box(360, 150, 150, 250, 1)};
  Frame f = depthFrame(depth, {{220, 150}});
  auto with = makeClassifier<DepthRepopulation>("DepthRepopulation");
  with->classify(f, d, {});
  EXPECT_FLOAT_EQ(with->lastStats()[0].min, 1.5f);
  EXPECT_FLOAT_EQ(with->lastStats()[1].min, 0.8f);
  auto without = makeClassifier<DepthRepopulation>("DepthRepopulation", "exclude_overlap: false");
  Frame g = depthFrame(depth, {{220, 150}});
  without->classify(g, d, {});
  EXPECT_FLOAT_EQ(without->lastStats()[0].min, 0.8f);  // B leaks into A's statistics
}

// A DepthRepopulation configured by `yaml` run on `f`: its box statistics.
static std::vector<BoxDepthStats> repopulate(const std::string& yaml, Frame& f, const Detections& d) {
  auto rep = makeClassifier<DepthRepopulation>("DepthRepopulation", yaml);
  rep->classify(f, d, {});
  return rep->lastStats();
}

// A backpack's box inside a chair's (held-out shift_s11, docs/changing.md
// step 15): with exclude_overlap every pixel of it is shared, so it has no
// statistics of its own and keeps every keypoint in it on the backpack, the
// wall 2.4 m behind it too. With overlap_fallback it takes the shared pixels
// back: object depth 2.6 m, the wall behind it background.
TEST(DepthRepopulation, OverlapFallbackGivesABoxInsideAnotherItsStatistics) {
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(5.0f));  // wall
  depth(cv::Rect(100, 100, 300, 300)).setTo(2.0f);     // the chair
  depth(cv::Rect(200, 250, 60, 80)).setTo(5.0f);       // the wall seen beside the backpack
  depth(cv::Rect(205, 260, 50, 70)).setTo(2.6f);       // the backpack
  Detections d;
  d.boxes = {box(100, 100, 300, 300, 62), box(200, 250, 60, 80, 27)};
  const std::vector<cv::Point2f> pts = {{230, 290}, {202, 255}};  // on the backpack; the wall in its box
  auto run = [&](const std::string& yaml, Frame& f) { return repopulate(yaml, f, d); };
  Frame f = depthFrame(depth, pts);
  const auto off = run("", f);
  ASSERT_EQ(off.size(), 2u);
  EXPECT_LT(off[1].samples, 10);  // no pixel of its own
  EXPECT_FLOAT_EQ(off[0].object_depth, 2.0f);
  for (int i : {0, 1}) {
    EXPECT_EQ(f.meta[i].label, KpLabel::Movable) << i;
    EXPECT_EQ(f.meta[i].class_id, 27) << i;  // the wall too
  }
  Frame g = depthFrame(depth, pts);
  const auto on = run("overlap_fallback: true", g);
  ASSERT_EQ(on.size(), 2u);
  EXPECT_GE(on[1].samples, 10);
  EXPECT_FLOAT_EQ(on[1].object_depth, 2.6f);
  EXPECT_FLOAT_EQ(on[0].object_depth, 2.0f);  // the chair's own statistics as before
  EXPECT_EQ(g.meta[0].label, KpLabel::Movable);
  EXPECT_EQ(g.meta[0].class_id, 27);
  EXPECT_EQ(g.meta[1].label, KpLabel::Static);  // the wall behind both boxes' objects
  EXPECT_NE(g.meta[1].class_id, 27);
}

// The backpack's box inside the chair's again, the chair's seat across the
// top of the backpack's box and the backpack 1 m behind the seat. The plain
// fallback takes the seat back into the backpack's statistics: its object
// depth is the seat's, and the backpack, deeper than the seat by more than
// the margin at the centre, is taken for something seen past an occluder:
// every keypoint in the box Dynamic. fallback_skip_other_objects leaves the
// seat's pixels (the chair's object depth and its margin) out: object depth
// 3 m, the backpack's keypoint on the backpack, the wall behind it
// background, the seat's keypoint the chair's.
TEST(DepthRepopulation, FallbackSkippingOtherObjectsKeepsTheBiggerObjectsSurfaceOut) {
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(5.0f));  // wall
  depth(cv::Rect(100, 100, 300, 300)).setTo(2.0f);     // the chair
  depth(cv::Rect(200, 250, 60, 80)).setTo(5.0f);       // the wall seen under the seat
  depth(cv::Rect(205, 270, 50, 60)).setTo(3.0f);       // the backpack
  depth(cv::Rect(200, 250, 60, 15)).setTo(2.0f);       // the seat across the box's top
  Detections d;
  d.boxes = {box(100, 100, 300, 300, 62), box(200, 250, 60, 80, 27)};
  const std::vector<cv::Point2f> pts = {{230, 300}, {202, 300}, {230, 255}};  // backpack, wall, seat
  auto run = [&](const std::string& yaml, Frame& f) { return repopulate(yaml, f, d); };
  Frame f = depthFrame(depth, pts);
  const auto plain = run("overlap_fallback: true", f);
  ASSERT_EQ(plain.size(), 2u);
  EXPECT_FLOAT_EQ(plain[1].object_depth, 2.0f);  // the seat
  EXPECT_TRUE(plain[1].occluded);
  EXPECT_EQ(f.meta[0].label, KpLabel::Dynamic);
  EXPECT_EQ(f.meta[0].reason, KpReason::Occluded);

  Frame g = depthFrame(depth, pts);
  const auto skip = run("overlap_fallback: true\nfallback_skip_other_objects: true", g);
  ASSERT_EQ(skip.size(), 2u);  // in the order of the boxes
  EXPECT_EQ(skip[0].box, 0);
  EXPECT_FLOAT_EQ(skip[0].object_depth, 2.0f);
  EXPECT_EQ(skip[1].box, 1);
  EXPECT_GE(skip[1].samples, 10);
  EXPECT_EQ(skip[1].own_samples, 0);  // no pixel of its own: support_check no_statistics would check it
  EXPECT_EQ(skip[0].own_samples, skip[0].samples);
  EXPECT_FLOAT_EQ(skip[1].object_depth, 3.0f);
  EXPECT_FALSE(skip[1].occluded);
  EXPECT_EQ(g.meta[0].label, KpLabel::Movable);
  EXPECT_EQ(g.meta[0].class_id, 27);
  EXPECT_EQ(g.meta[1].label, KpLabel::Static);  // the wall
  EXPECT_EQ(g.meta[2].label, KpLabel::Movable);
  EXPECT_EQ(g.meta[2].class_id, 62);  // the seat

  // Without overlap_fallback the option changes nothing.
  Frame h = depthFrame(depth, pts);
  const auto off = run("fallback_skip_other_objects: true", h);
  EXPECT_LT(off[1].samples, 10);
  EXPECT_EQ(h.meta[1].label, KpLabel::Movable);
  EXPECT_EQ(h.meta[1].class_id, 27);  // the wall too, as without the fallback
}

// A backpack standing on the floor (pinhole, f = 525, camera 0.8 m above a
// level floor: the floor's depth at row v is 420 / (v - 240) m; a wall at
// 5 m above the horizon's far part). Its box reaches below its foot, as a
// detector's box does: the floor in front of and beside the backpack lies
// within the depth margin of the box's nearest depth and is put on the
// backpack. support_check all: the floor continues as one plane out of the
// box, so its keypoints are Static; the backpack's face, also the point 8 px
// above its foot and the points of a box cut 10 px inside the backpack (the
// face ends beyond that box's edge within support_extension), stays the
// backpack's.
TEST(DepthRepopulation, SupportCheckTakesTheFloorAtAnObjectsFootOffIt) {
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(5.0f));
  for (int v = 325; v < 480; v++) depth.row(v).setTo(420.0f / static_cast<float>(v - 240));
  depth(cv::Rect(284, 314, 74, 94)).setTo(2.5f);  // the backpack: rows 314-407, foot at 408 (2.5 m)
  const std::vector<cv::Point2f> pts = {
      {320, 350}, {300, 400},  // on the backpack, the second 8 px above its foot
      {281, 400}, {320, 412},  // the floor beside it (2.63 m) and in front of it (2.44 m)
      {340, 330}};             // the backpack again, for the box cut inside it
  Detections d;
  d.boxes = {box(278, 308, 85, 106, 27)};
  auto run = [&](const std::string& yaml, const Detections& det) {
    Frame f = depthFrame(depth, pts);
    repopulate(yaml, f, det);
    return f;
  };
  const Frame off = run("", d);
  for (int i : {0, 1, 2, 3, 4}) EXPECT_EQ(off.meta[i].label, KpLabel::Movable) << i;  // the floor too
  const Frame on = run("support_check: all", d);
  for (int i : {0, 1, 4}) {
    EXPECT_EQ(on.meta[i].label, KpLabel::Movable) << i;
    EXPECT_EQ(on.meta[i].class_id, 27) << i;
  }
  for (int i : {2, 3}) {
    EXPECT_EQ(on.meta[i].label, KpLabel::Static) << i;
    EXPECT_EQ(on.meta[i].reason, KpReason::BoxBackground) << i;
    EXPECT_EQ(on.meta[i].class_id, -1) << i;
  }
  // A box 10 px inside the backpack on every side: its face continues out
  // of the box, but ends before support_extension (25 % of the box) does.
  Detections inner;
  inner.boxes = {box(294, 324, 54, 74, 27)};
  const Frame cut = run("support_check: all", inner);
  for (int i : {0, 4}) EXPECT_EQ(cut.meta[i].label, KpLabel::Movable) << i;
  // With an extension shorter than the cut, the face is taken for a support.
  const Frame short_ext = run("support_check: all\nsupport_extension: 0.1\nsupport_min_samples: 2", inner);
  for (int i : {0, 4}) EXPECT_EQ(short_ext.meta[i].label, KpLabel::Static) << i;
  // no_statistics: only a box without depth samples of its own is checked.
  // Alone, the backpack's box has its statistics: the floor stays on it.
  const Frame alone = run("support_check: no_statistics", d);
  for (int i : {2, 3}) EXPECT_EQ(alone.meta[i].label, KpLabel::Movable) << i;
  // Inside a chair's box (every pixel shared) it has none, and every
  // keypoint in it would be the backpack's whatever its depth: the floor is
  // taken off it, the backpack's face stays.
  Detections in_chair;
  in_chair.boxes = {box(200, 250, 240, 220, 62), box(278, 308, 85, 106, 27)};
  const Frame none = run("", in_chair);
  for (int i : {2, 3}) EXPECT_EQ(none.meta[i].class_id, 27) << i;
  const Frame inside = run("support_check: no_statistics", in_chair);
  for (int i : {0, 1, 4}) EXPECT_EQ(inside.meta[i].class_id, 27) << i;
  for (int i : {2, 3}) {
    EXPECT_EQ(inside.meta[i].label, KpLabel::Static) << i;
    EXPECT_EQ(inside.meta[i].class_id, -1) << i;
  }
  // The overlap fallback gives that box statistics of the shared pixels,
  // not of its own: the floor is within the depth margin of the box's
  // nearest depth and stays the backpack's, unless no_statistics checks it.
  {
    Frame fb = depthFrame(depth, pts);
    const auto st = repopulate("overlap_fallback: true", fb, in_chair);
    ASSERT_EQ(st.size(), 2u);
    EXPECT_GE(st[1].samples, 10);
    EXPECT_EQ(st[1].own_samples, 0);
    EXPECT_EQ(st[0].own_samples, st[0].samples);
    for (int i : {0, 1, 2, 3, 4}) EXPECT_EQ(fb.meta[i].class_id, 27) << i;
  }
  const Frame fb_checked = run("overlap_fallback: true\nsupport_check: no_statistics", in_chair);
  for (int i : {0, 1, 4}) EXPECT_EQ(fb_checked.meta[i].class_id, 27) << i;
  for (int i : {2, 3}) {
    EXPECT_EQ(fb_checked.meta[i].label, KpLabel::Static) << i;
    EXPECT_EQ(fb_checked.meta[i].class_id, -1) << i;
  }
  // People (dynamic_classes) are not checked: the floor at their feet stays dropped.
  Detections person;
  person.boxes = {box(278, 308, 85, 106, 1)};
  const Frame p = run("support_check: all", person);
  EXPECT_EQ(p.meta[3].label, KpLabel::Dynamic);
}

// A plant (COCO 64) in front of a desk (67, listed first): keypoints on the
// plant inside both boxes are the plant's (overlap_class: front), not the
// desk's as with overlap_class: first; the desk seen beside the plant,
// inside the plant's box, stays the desk's.
TEST(DepthRepopulation, KeypointInFrontOfABoxsObjectTakesTheOtherBoxsClass) {
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(4.5f));
  depth(cv::Rect(200, 100, 300, 250)).setTo(3.0f);  // desk
  depth(cv::Rect(190, 260, 80, 190)).setTo(2.0f);   // plant
  Detections d;
  d.boxes = {box(200, 100, 300, 250, 67), box(180, 250, 100, 200, 64)};
  const std::vector<cv::Point2f> pts = {{240, 300}, {275, 255}, {400, 200}};  // plant in both; desk in both; desk
  auto classes = [&](const std::string& yaml) {
    auto rep = makeClassifier<DepthRepopulation>("DepthRepopulation", yaml);
    Frame f = depthFrame(depth, pts);
    rep->classify(f, d, {});
    EXPECT_FLOAT_EQ(rep->lastStats()[0].object_depth, 3.0f);
    EXPECT_FALSE(rep->lastStats()[0].occluded);
    std::vector<int> c;
    for (size_t i = 0; i < pts.size(); i++) {
      EXPECT_EQ(f.meta[i].label, KpLabel::Movable) << yaml << " keypoint " << i;
      c.push_back(f.meta[i].class_id);
    }
    return c;
  };
  EXPECT_EQ(classes(""), (std::vector<int>{64, 67, 67}));
  EXPECT_EQ(classes("overlap_class: first"), (std::vector<int>{67, 67, 67}));
  EXPECT_EQ(classes("front_margin: 1.5"), (std::vector<int>{67, 67, 67}));  // 1 m in front is within the margin
}

// shift_dark frame 557: a monitor box whose left edge (x 583.2) lies just
// right of column 583, where the fridge beside it is 1 m nearer. Pixel 583
// is not in the box (a keypoint there would not be); taken in, the fridge's
// edge was the monitor's object depth and the fridge's keypoints in the
// monitor box were labelled tv. Likewise the top row (y 194.8).
TEST(DepthRepopulation, PixelsJustOutsideAFractionalBoxAreNotSampled) {
  cv::Mat depth(480, 640, CV_32F, cv::Scalar(4.3f));
  depth(cv::Rect(0, 0, 584, 480)).setTo(3.0f);     // fridge, columns 0-583
  depth(cv::Rect(584, 195, 40, 60)).setTo(3.9f);   // monitor
  depth(cv::Rect(584, 194, 40, 1)).setTo(2.9f);    // something nearer on row 194
  Detections d;
  d.boxes = {box(583.2f, 194.8f, 46.3f, 62.0f, 72)};
  Frame f = depthFrame(depth, {{600, 220}});  // on the monitor
  auto rep = makeClassifier<DepthRepopulation>("DepthRepopulation", "occlusion_check: none");
  rep->classify(f, d, {});
  ASSERT_EQ(rep->lastStats().size(), 1u);
  EXPECT_FLOAT_EQ(rep->lastStats()[0].min, 3.9f);  // column 583 and row 194 not sampled
  EXPECT_FLOAT_EQ(rep->lastStats()[0].object_depth, 3.9f);
  EXPECT_EQ(f.meta[0].label, KpLabel::Movable);
  EXPECT_EQ(f.meta[0].class_id, 72);
}

TEST(DepthRepopulation, KeypointDepthsWithoutDepthImage) {
  Detections d;
  d.boxes = {box(200, 100, 200, 300, 1)};
  std::vector<cv::Point2f> pts;
  std::vector<float> z;
  for (int i = 0; i < 30; i++) {  // 15 on the person (1.5 m), 15 on the wall (4 m) at the box's left border
    const float x = i < 15 ? 260.f + 3.f * static_cast<float>(i) : 210.f;
    pts.emplace_back(x, 110.f + 9.f * static_cast<float>(i));
    z.push_back(i < 15 ? 1.5f : 4.0f);
  }
  Frame f = makeFrame(pts);
  f.depth = z;
  auto rep = makeClassifier<DepthRepopulation>("DepthRepopulation", "min_samples: 10\ncenter_fraction: 0.5");
  rep->classify(f, d, {});
  EXPECT_EQ(rep->lastStats()[0].samples, 30);
  for (size_t i = 0; i < pts.size(); i++) EXPECT_EQ(f.meta[i].label, i < 15 ? KpLabel::Dynamic : KpLabel::Static) << i;
}

// ---------------------------------------------------------------------------
// EKF object tracker: a camera moving at 0.2 m/s along x; a chair static in
// the world and a person walking at 0.5 m/s along world x.

namespace {

struct Obj {
  int cls;
  Eigen::Vector3d p0, v;  // world
  double w, h;            // metres
};

struct Scene {
  CameraModel cam = pinhole();
  std::vector<Obj> objs;
  SE3 pose(int k) const { return SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.2 * k / 30.0, 0, 0)); }
  double time(int k) const { return k / 30.0; }

  void make(int k, Frame& f, Detections& d, std::vector<int> visible = {}) const {
    cv::Mat depth(480, 640, CV_32F, cv::Scalar(6.0f));
    std::vector<cv::Point2f> pts = {{20, 20}};
    d = Detections{};
    d.frame_index = k;
    const SE3 T_cw = pose(k).inverse();
    for (size_t o = 0; o < objs.size(); o++) {
      if (!visible.empty() && !visible[o]) continue;
      const Eigen::Vector3d pc = T_cw * (objs[o].p0 + time(k) * objs[o].v);
      const Eigen::Vector2d uv = cam.left.project(pc);
      const double bw = cam.left.fx * objs[o].w / pc.z(), bh = cam.left.fy * objs[o].h / pc.z();
      const cv::Rect2f b(static_cast<float>(uv.x() - bw / 2), static_cast<float>(uv.y() - bh / 2),
                         static_cast<float>(bw), static_cast<float>(bh));
      d.boxes.push_back(box(b.x, b.y, b.width, b.height, objs[o].cls));
      cv::Rect r(cv::Point(static_cast<int>(std::floor(b.x)), static_cast<int>(std::floor(b.y))),
                 cv::Point(static_cast<int>(std::ceil(b.x + b.width)), static_cast<int>(std::ceil(b.y + b.height))));
      depth(r & cv::Rect(0, 0, 640, 480)).setTo(static_cast<float>(pc.z()));
      pts.emplace_back(static_cast<float>(uv.x()), static_cast<float>(uv.y()));
    }
    f = makeFrame(pts, {640, 480}, k, time(k));
    f.input.depth = depth;
    for (size_t i = 0; i < pts.size(); i++)
      f.depth[i] = depth.at<float>(static_cast<int>(pts[i].y), static_cast<int>(pts[i].x));
  }

  /** Frame k (make()) and a classifier context with the scene's camera. */
  ClassifierContext frame(int k, Frame& f, Detections& d, std::vector<int> visible = {}) const {
    make(k, f, d, std::move(visible));
    ClassifierContext ctx;
    ctx.camera = &cam;
    return ctx;
  }
};

}  // namespace

TEST(EkfObjectTracker, FlagsMovingObjectNotStaticOne) {
  Scene s;
  s.objs = {{62, {0.3, 0.2, 3.0}, {0, 0, 0}, 0.5, 0.8}, {1, {-0.8, 0.0, 2.5}, {0.5, 0, 0}, 0.5, 1.7}};
  auto ekf = makeClassifier<EkfObjectTracker>("EkfObjectTracker", "", &s.cam);
  std::vector<KeypointMeta> chair, person;
  for (int k = 0; k < 45; k++) {
    Frame f;
    Detections d;
    ClassifierContext ctx = s.frame(k, f, d);
    if (k > 0) ctx.previous_T_wc = s.pose(k - 1);
    ekf->classify(f, d, ctx);
    chair.push_back(f.meta[1]);
    person.push_back(f.meta[2]);
    EXPECT_EQ(f.meta[0].label, KpLabel::Static);  // background
    ekf->afterTracking(f, d, s.pose(k));
  }
  // New objects are dynamic until proven static: the chair needs 5 slow updates after its first sighting.
  for (int k = 0; k <= 5; k++) {
    EXPECT_EQ(chair[k].label, KpLabel::Dynamic) << k;
    EXPECT_EQ(chair[k].reason, KpReason::NewObject) << k;
  }
  for (int k = 6; k < 45; k++) {
    EXPECT_EQ(chair[k].label, KpLabel::Movable) << k;
    EXPECT_EQ(chair[k].reason, KpReason::OnObject) << k;
  }
  // The person is dynamic throughout, moving once the filter has its speed.
  for (int k = 0; k < 45; k++) EXPECT_EQ(person[k].label, KpLabel::Dynamic) << k;
  for (int k = 10; k < 45; k++) EXPECT_EQ(person[k].reason, KpReason::ObjectMoving) << k;

  ASSERT_EQ(ekf->tracks().size(), 2u);  // one track per object: association held over 45 frames
  const TrackedObject* tc = ekf->track(chair.back().object_id);
  const TrackedObject* tp = ekf->track(person.back().object_id);
  ASSERT_TRUE(tc && tp);
  EXPECT_EQ(tc->class_id, 62);
  EXPECT_EQ(tp->class_id, 1);
  EXPECT_EQ(tc->updates, 45);
  EXPECT_FALSE(tc->dynamic);
  EXPECT_TRUE(tp->dynamic);
  EXPECT_LT(tc->speed(), 0.01);
  EXPECT_NEAR(tp->speed(), 0.5, 0.05);
  EXPECT_NEAR(tp->x(3), 0.5, 0.05);
  EXPECT_NEAR(tc->x(0), 0.3, 1e-3);
  EXPECT_NEAR(tc->x(1), 0.2, 1e-3);
  EXPECT_NEAR(tc->x(2), 3.0, 1e-3);
  EXPECT_NEAR(tp->x(0), -0.8 + 0.5 * 44 / 30.0, 0.01);
  // Class-specific process noise: the person's velocity stays more uncertain than the chair's.
  EXPECT_GT(tp->P(3, 3), 2.0 * tc->P(3, 3));
}

TEST(EkfObjectTracker, ClassNoiseAndThresholdParameters) {
  auto ekf = makeClassifier<EkfObjectTracker>("EkfObjectTracker");
  EXPECT_DOUBLE_EQ(ekf->sigmaAccel(1), 0.5);    // person
  EXPECT_DOUBLE_EQ(ekf->sigmaAccel(62), 0.02);  // chair
  EXPECT_DOUBLE_EQ(ekf->sigmaAccel(3), 0.01);   // car: other
  EXPECT_DOUBLE_EQ(ekf->speedThreshold(1), 0.2);
  EXPECT_DOUBLE_EQ(ekf->speedThreshold(62), 0.1);
  auto custom = makeClassifier<EkfObjectTracker>(
      "EkfObjectTracker", "sigma_accel: {person: 1.0, \"dining table\": 0.005, default: 0.03}\n"
                          "speed_threshold: {62: 0.05, default: 0.2}");
  EXPECT_DOUBLE_EQ(custom->sigmaAccel(1), 1.0);
  EXPECT_DOUBLE_EQ(custom->sigmaAccel(67), 0.005);
  EXPECT_DOUBLE_EQ(custom->sigmaAccel(62), 0.03);
  EXPECT_DOUBLE_EQ(custom->speedThreshold(62), 0.05);
}

TEST(EkfObjectTracker, SlowChairBelowItsThresholdIsStaticAboveIsMoving) {
  // The same 0.15 m/s object: static for a person threshold (0.2), moving as a chair (0.1).
  for (int cls : {1, 62}) {
    Scene s;
    s.objs = {{cls, {0.0, 0.0, 3.0}, {0.15, 0, 0}, 0.5, 1.0}};
    auto ekf = makeClassifier<EkfObjectTracker>("EkfObjectTracker", "", &s.cam);
    for (int k = 0; k < 90; k++) {
      Frame f;
      Detections d;
      ekf->classify(f, d, s.frame(k, f, d));
      ekf->afterTracking(f, d, s.pose(k));
    }
    ASSERT_EQ(ekf->tracks().size(), 1u);
    EXPECT_NEAR(ekf->tracks()[0].speed(), 0.15, 0.02) << cls;
    EXPECT_EQ(ekf->tracks()[0].dynamic, cls == 62) << cls;
  }
}

TEST(EkfObjectTracker, LostTrackIsDroppedAndComesBackAsNew) {
  Scene s;
  s.objs = {{62, {0.3, 0.2, 3.0}, {0, 0, 0}, 0.5, 0.8}};
  auto ekf = makeClassifier<EkfObjectTracker>("EkfObjectTracker", "max_missed: 3", &s.cam);
  int first_id = -1;
  KeypointMeta last;
  for (int k = 0; k < 20; k++) {
    Frame f;
    Detections d;
    const bool vis = k < 10 || k >= 14;  // unseen for 4 frames
    ekf->classify(f, d, s.frame(k, f, d, {vis ? 1 : 0}));
    if (vis) last = f.meta[1];
    if (k == 9) {
      EXPECT_EQ(f.meta[1].label, KpLabel::Movable);
      first_id = f.meta[1].object_id;
    }
    if (k == 14) {
      EXPECT_EQ(f.meta[1].label, KpLabel::Dynamic);
      EXPECT_EQ(f.meta[1].reason, KpReason::NewObject);
      EXPECT_NE(f.meta[1].object_id, first_id);
    }
    ekf->afterTracking(f, d, s.pose(k));
    if (k == 12) {
      EXPECT_EQ(ekf->tracks().size(), 1u);  // missed 3 times: kept
    }
    if (k == 13) {
      EXPECT_EQ(ekf->tracks().size(), 0u);  // 4th miss: dropped
    }
  }
  EXPECT_EQ(last.label, KpLabel::Dynamic);  // 6 frames after its return it is still being proven static
  ekf->reset();
  EXPECT_TRUE(ekf->tracks().empty());
}

TEST(EkfObjectTracker, ObjectIdsAreNeverReused) {
  // Frame 0: a chair is labelled with a new id, but tracking is lost (no
  // pose): no track is made. Frame 1: a table elsewhere. Its id must differ:
  // both are on keypoints (and map points) now.
  Scene s;
  s.objs = {{62, {0.3, 0.2, 3.0}, {0, 0, 0}, 0.5, 0.8}, {67, {-0.8, 0.3, 3.0}, {0, 0, 0}, 0.8, 0.6}};
  auto ekf = makeClassifier<EkfObjectTracker>("EkfObjectTracker", "", &s.cam);
  Frame f0, f1;
  Detections d0, d1;
  ekf->classify(f0, d0, s.frame(0, f0, d0, {1, 0}));
  ekf->afterTracking(f0, d0, std::nullopt);
  EXPECT_TRUE(ekf->tracks().empty());
  ekf->classify(f1, d1, s.frame(1, f1, d1, {0, 1}));
  ekf->afterTracking(f1, d1, s.pose(1));
  const int chair = f0.meta[1].object_id, table = f1.meta[1].object_id;
  EXPECT_GE(chair, 0);
  EXPECT_GE(table, 0);
  EXPECT_NE(chair, table);
  ASSERT_EQ(ekf->tracks().size(), 1u);
  EXPECT_EQ(ekf->tracks()[0].id, table);  // the track carries the id its keypoints got
}

TEST(EkfObjectTracker, AKeypointInTwoBoxesTakesTheIdOfTheBoxOfItsClass) {
  // A chair in front of a table: the chair's keypoint lies in both boxes and
  // carries the chair's class (set by the classifier before, e.g. depth
  // repopulation). Its object id is the chair track's, whatever the box
  // order; the table's keypoint (no class before) gets the table's.
  for (bool chair_first : {true, false}) {
    Scene s;
    const Obj chair{62, {0.3, 0.2, 3.0}, {0, 0, 0}, 0.5, 0.8}, table{67, {0.7, 0.2, 3.0}, {0, 0, 0}, 1.0, 0.6};
    s.objs = chair_first ? std::vector<Obj>{chair, table} : std::vector<Obj>{table, chair};
    const size_t kc = chair_first ? 1 : 2, kt = chair_first ? 2 : 1;  // keypoint 0: background
    auto ekf = makeClassifier<EkfObjectTracker>("EkfObjectTracker", "", &s.cam);
    Frame f;
    for (int k = 0; k < 10; k++) {
      Detections d;
      ClassifierContext ctx = s.frame(k, f, d);
      f.meta.assign(f.size(), KeypointMeta{});
      f.meta[kc].class_id = 62;
      ekf->classify(f, d, ctx);
      ekf->afterTracking(f, d, s.pose(k));
    }
    ASSERT_EQ(ekf->tracks().size(), 2u);
    int chair_track = -1, table_track = -1;
    for (const auto& t : ekf->tracks()) (t.class_id == 62 ? chair_track : table_track) = t.id;
    EXPECT_EQ(f.meta[kc].class_id, 62) << chair_first;
    EXPECT_EQ(f.meta[kc].object_id, chair_track) << chair_first;
    EXPECT_EQ(f.meta[kt].class_id, 67) << chair_first;
    EXPECT_EQ(f.meta[kt].object_id, table_track) << chair_first;
    EXPECT_NE(chair_track, table_track);
  }
}

TEST(EkfObjectTracker, BoxCutByTheImageBorderIsNoEvidenceOfMotion) {
  // A static 1.6 m table whose right part is outside the image: the detector's
  // box is cut at the border, and as the camera moves the cut box's centre
  // slides over the table at half the table's image speed (apparent motion
  // ~0.1 m/s). With the paper's rule alone the table is flagged moving; with
  // the border guard and the significance test it is static.
  Scene s;
  s.objs = {{67, {2.0, 0.3, 3.0}, {0, 0, 0}, 1.6, 0.6}};
  auto run = [&](const std::string& yaml) {
    auto ekf = makeClassifier<EkfObjectTracker>("EkfObjectTracker", "speed_threshold: {default: 0.05}\n" + yaml, &s.cam);
    std::vector<KeypointMeta> m;
    for (int k = 0; k < 60; k++) {
      Frame f;
      Detections d;
      ClassifierContext ctx = s.frame(k, f, d);
      for (auto& b : d.boxes) b.box &= cv::Rect2f(0, 0, 640, 480);  // the detector sees the visible part only
      if (k > 0) ctx.previous_T_wc = s.pose(k - 1);
      ekf->classify(f, d, ctx);
      m.push_back(f.meta[1]);
      ekf->afterTracking(f, d, s.pose(k));
    }
    return m;
  };
  // (The keypoint at the table's centre enters the image at frame 13.)
  const auto guarded = run("");
  for (int k = 13; k < 60; k++) EXPECT_EQ(guarded[k].label, KpLabel::Movable) << k;
  const auto paper = run("truncated_margin: -1\nmoving_chi2: 0");
  int moving = 0;
  for (int k = 13; k < 60; k++) moving += paper[k].reason == KpReason::ObjectMoving;
  EXPECT_GT(moving, 25);
}

TEST(EkfObjectTracker, DepthJumpIsGatedRepeatedJumpsRestartTheTrack) {
  // A static chair whose central depth jumps by 1 m for 2 frames (the window
  // sees the wall through the backrest), then for good (it was another
  // surface all along): the 2-frame jump is not fused, the lasting one
  // restarts the track (new object, dynamic until proven static).
  Scene s;
  s.objs = {{62, {0.0, 0.0, 3.0}, {0, 0, 0}, 0.5, 0.8}};
  auto ekf = makeClassifier<EkfObjectTracker>("EkfObjectTracker", "", &s.cam);
  int restarted_at = -1;
  for (int k = 0; k < 60; k++) {
    Frame f;
    Detections d;
    ClassifierContext ctx = s.frame(k, f, d);
    if ((k >= 20 && k < 22) || k >= 40) f.input.depth.setTo(4.0f, f.input.depth < 5.0f);
    ekf->classify(f, d, ctx);
    ekf->afterTracking(f, d, s.pose(k));
    ASSERT_EQ(ekf->tracks().size(), 1u) << k;
    const TrackedObject& t = ekf->tracks()[0];
    if (k == 25) {
      EXPECT_NEAR(t.x(2), 3.0, 0.01);  // the short jump left no trace
      EXPECT_FALSE(t.dynamic);
      EXPECT_LT(t.speed(), 0.01);
    }
    if (restarted_at < 0 && k >= 40 && t.updates == 1) restarted_at = k;
  }
  EXPECT_EQ(restarted_at, 40 + 2);  // max_gated: 3 consecutive gated measurements
  EXPECT_NEAR(ekf->tracks()[0].x(2), 4.0, 0.05);
  EXPECT_FALSE(ekf->tracks()[0].dynamic);  // proven static again after the restart
}
