// BoxFilter, SemanticFilter, AdaptiveFeatureCount on hand-made frames.
#include <gtest/gtest.h>

#include "classifier_test_util.h"
#include "dslam/core/error.h"
#include "dslam/plugins/classifiers/adaptive_feature_count.h"
#include "dslam/plugins/classifiers/box_filter.h"
#include "dslam/plugins/classifiers/semantic_filter.h"

using namespace dslam;
using namespace dslam::test;

namespace {

// Keypoints on a 20 px grid over 640x480 (offset 10 px).
std::vector<cv::Point2f> gridPoints() {
  std::vector<cv::Point2f> p;
  for (int y = 10; y < 480; y += 20)
    for (int x = 10; x < 640; x += 20) p.emplace_back(static_cast<float>(x), static_cast<float>(y));
  return p;
}

bool inside(const cv::Point2f& p, const cv::Rect2f& r, float m = 0) {
  return p.x >= r.x - m && p.y >= r.y - m && p.x < r.x + r.width + m && p.y < r.y + r.height + m;
}

}  // namespace

TEST(BoxFilter, DropsExactlyTheKeypointsInsidePersonBoxes) {
  auto bf = makeClassifier<BoxFilter>("BoxFilter");
  Frame f = makeFrame(gridPoints());
  Detections d;
  d.boxes = {box(100, 100, 200, 150, 1, 0.9f, 7), box(400, 300, 100, 100, 62), box(500, 20, 60, 60, 1)};
  bf->classify(f, d, {});
  size_t dyn = 0;
  for (size_t i = 0; i < f.size(); i++) {
    const auto& p = f.keypoints[i].pt;
    const bool in_person = inside(p, d.boxes[0].box) || inside(p, d.boxes[2].box);
    EXPECT_EQ(f.meta[i].label, in_person ? KpLabel::Dynamic : KpLabel::Static) << p;
    if (in_person) {
      dyn++;
      EXPECT_EQ(f.meta[i].reason, KpReason::InDynamicBox);
      EXPECT_EQ(f.meta[i].class_id, 1);
      EXPECT_EQ(f.meta[i].object_id, inside(p, d.boxes[0].box) ? 7 : -1);
    } else {
      EXPECT_EQ(f.meta[i].reason, KpReason::None);
      EXPECT_EQ(f.meta[i].class_id, -1);
    }
  }
  // 10 x 8 grid points in the first box ([100,300) x [100,250): x 110..290, y 110..250 excl.), 3 x 3 in the third.
  EXPECT_EQ(dyn, 10u * 7u + 3u * 3u);
}

TEST(BoxFilter, ClassListMarginScoreAndEarlierLabels) {
  Detections d;
  d.boxes = {box(100, 100, 200, 150, 1, 0.4f), box(400, 300, 100, 100, 62, 0.9f)};
  {  // chair listed too
    auto bf = makeClassifier<BoxFilter>("BoxFilter", "classes: [1, 62]");
    Frame f = makeFrame({{450, 350}, {150, 150}, {50, 50}});
    bf->classify(f, d, {});
    EXPECT_EQ(f.meta[0].label, KpLabel::Dynamic);
    EXPECT_EQ(f.meta[0].class_id, 62);
    EXPECT_EQ(f.meta[1].label, KpLabel::Dynamic);
    EXPECT_EQ(f.meta[2].label, KpLabel::Static);
  }
  {  // min_score drops the 0.4 person box
    auto bf = makeClassifier<BoxFilter>("BoxFilter", "min_score: 0.5");
    Frame f = makeFrame({{150, 150}});
    bf->classify(f, d, {});
    EXPECT_EQ(f.meta[0].label, KpLabel::Static);
  }
  {  // margin: 5 px outside the box counts with margin 6, not with 0
    Frame f0 = makeFrame({{95, 150}, {300.5f, 150}});
    auto plain = makeClassifier<BoxFilter>("BoxFilter");
    plain->classify(f0, d, {});
    EXPECT_EQ(f0.countLabel(KpLabel::Dynamic), 0u);
    Frame f1 = makeFrame({{95, 150}, {300.5f, 150}});
    auto grown = makeClassifier<BoxFilter>("BoxFilter", "margin: 6");
    grown->classify(f1, d, {});
    EXPECT_EQ(f1.countLabel(KpLabel::Dynamic), 2u);
  }
  {  // earlier labels: never lowered, reason of an earlier Dynamic kept, Movable raised
    auto bf = makeClassifier<BoxFilter>("BoxFilter");
    Frame f = makeFrame({{150, 150}, {160, 160}, {50, 50}});
    f.meta[0] = {KpLabel::Dynamic, KpReason::EpipolarOutlier, 5, -1};
    f.meta[1] = {KpLabel::Movable, KpReason::OnObject, 62, 3};
    f.meta[2] = {KpLabel::Dynamic, KpReason::SemanticDynamic, 1, -1};
    bf->classify(f, d, {});
    EXPECT_EQ(f.meta[0].reason, KpReason::EpipolarOutlier);
    EXPECT_EQ(f.meta[0].class_id, 5);
    EXPECT_EQ(f.meta[1].label, KpLabel::Dynamic);
    EXPECT_EQ(f.meta[1].reason, KpReason::InDynamicBox);
    EXPECT_EQ(f.meta[1].object_id, 3);
    EXPECT_EQ(f.meta[2].label, KpLabel::Dynamic);  // outside every box, untouched
  }
  {  // detector skipped the frame: nothing happens
    auto bf = makeClassifier<BoxFilter>("BoxFilter");
    Frame f = makeFrame({{150, 150}});
    Detections skipped = d;
    skipped.valid = false;
    bf->classify(f, skipped, {});
    EXPECT_EQ(f.meta[0].label, KpLabel::Static);
  }
}

// A detection carried from an older frame (asynchronous detection) grows by
// age_margin of its size per frame of age on each side.
TEST(BoxFilter, CarriedDetectionsGrowWithTheirAge) {
  Detections d;
  d.boxes = {box(100, 100, 100, 100, 1)};
  const std::vector<cv::Point2f> pts = {{95, 150}, {150, 93}, {88, 150}, {150, 150}};  // 5, 7 and 12 px outside
  auto count = [&](int age, const std::string& yaml) {
    auto bf = makeClassifier<BoxFilter>("BoxFilter", yaml);
    Frame f = makeFrame(pts);
    Detections a = d;
    a.age_frames = age;
    bf->classify(f, a, {});
    return f.countLabel(KpLabel::Dynamic);
  };
  EXPECT_EQ(count(0, ""), 1u);                  // fresh: the box as detected
  EXPECT_EQ(count(2, ""), 2u);                  // 2 frames old: 6 px more on each side (3 % x 100 px x 2)
  EXPECT_EQ(count(3, ""), 3u);                  // 9 px
  EXPECT_EQ(count(4, ""), 4u);                  // 12 px
  EXPECT_EQ(count(4, "age_margin: 0"), 1u);     // off
}

TEST(BoxFilter, RejectsNonCocoClasses) {
  register_classifiers_plugins();
  auto p = create<KeypointClassifier>("dslam::BoxFilter");
  EXPECT_THROW(p->configure(Params::resolve(p->paramSpecs(), "classes: [1, 999]"), {}), ConfigError);
  EXPECT_THROW(p->configure(Params::resolve(p->paramSpecs(), "margin: -1"), {}), ConfigError);
}

TEST(SemanticFilter, CraftedLabelImage) {
  Detections d;
  d.semantic = cv::Mat(480, 640, CV_8U, cv::Scalar(255));
  d.semantic(cv::Rect(200, 100, 100, 200)).setTo(1);   // person
  d.semantic(cv::Rect(400, 300, 80, 80)).setTo(62);    // chair
  d.semantic(cv::Rect(0, 400, 640, 80)).setTo(190);    // floor-other-merged
  const std::vector<cv::Point2f> pts = {{250, 200}, {200, 100}, {299, 299}, {300, 200}, {195, 200},
                                        {185, 200}, {440, 340}, {50, 450},  {50, 50}};
  auto sf = makeClassifier<SemanticFilter>("SemanticFilter");
  Frame f = makeFrame(pts);
  sf->classify(f, d, {});
  const KpLabel D = KpLabel::Dynamic, S = KpLabel::Static;
  const std::vector<KpLabel> want = {D, D, D, S, S, S, S, S, S};
  const std::vector<int> want_cls = {1, 1, 1, -1, -1, -1, 62, 190, -1};
  for (size_t i = 0; i < pts.size(); i++) {
    EXPECT_EQ(f.meta[i].label, want[i]) << i;
    EXPECT_EQ(f.meta[i].class_id, want_cls[i]) << i;
    if (want[i] == D) {
      EXPECT_EQ(f.meta[i].reason, KpReason::SemanticDynamic);
    }
  }

  // Dilation by 8 px: (195,200) and (300,200) join the mask, (185,200) does not.
  auto dil = makeClassifier<SemanticFilter>("SemanticFilter", "dilation: 8");
  Frame g = makeFrame(pts);
  dil->classify(g, d, {});
  EXPECT_EQ(g.meta[3].label, D);
  EXPECT_EQ(g.meta[4].label, D);
  EXPECT_EQ(g.meta[5].label, S);
  EXPECT_EQ(g.countLabel(D), 5u);

  // Chair listed as dynamic, ground-truth reason.
  auto gt = makeClassifier<SemanticFilter>("SemanticFilter", "classes: [1, 62]\nground_truth: true");
  Frame h = makeFrame(pts);
  gt->classify(h, d, {});
  EXPECT_EQ(h.countLabel(D), 4u);
  EXPECT_EQ(h.meta[6].reason, KpReason::GroundTruth);
}

TEST(SemanticFilter, LabelImageAtHalfResolution) {
  Detections d;
  d.semantic = cv::Mat(240, 320, CV_8U, cv::Scalar(255));
  d.semantic(cv::Rect(100, 50, 50, 100)).setTo(1);  // = [200,300) x [100,300) at full size
  auto sf = makeClassifier<SemanticFilter>("SemanticFilter");
  Frame f = makeFrame({{250, 200}, {205, 105}, {320, 200}, {150, 200}});
  sf->classify(f, d, {});
  EXPECT_EQ(f.meta[0].label, KpLabel::Dynamic);
  EXPECT_EQ(f.meta[1].label, KpLabel::Dynamic);
  EXPECT_EQ(f.meta[2].label, KpLabel::Static);
  EXPECT_EQ(f.meta[3].label, KpLabel::Static);
}

TEST(SemanticFilter, PanopticSegments) {
  Detections d;
  d.panoptic = cv::Mat(480, 640, CV_32S, cv::Scalar(199));
  d.panoptic(cv::Rect(200, 100, 100, 200)).setTo(1003);
  d.panoptic(cv::Rect(400, 300, 80, 80)).setTo(1004);
  d.panoptic(cv::Rect(0, 0, 40, 40)).setTo(0);  // void
  d.segments = {{199, 199, SegmentKind::Stuff, -1, 0, {}, 1.f},
                {1003, 1, SegmentKind::Thing, 3, 0, {}, 1.f},
                {1004, 62, SegmentKind::Thing, 4, 0, {}, 1.f}};
  auto sf = makeClassifier<SemanticFilter>("SemanticFilter");  // auto: no semantic image -> panoptic
  Frame f = makeFrame({{250, 200}, {440, 340}, {600, 50}, {10, 10}});
  sf->classify(f, d, {});
  EXPECT_EQ(f.meta[0].label, KpLabel::Dynamic);
  EXPECT_EQ(f.meta[0].class_id, 1);
  EXPECT_EQ(f.meta[0].object_id, 3);
  EXPECT_EQ(f.meta[1].label, KpLabel::Static);
  EXPECT_EQ(f.meta[1].class_id, 62);
  EXPECT_EQ(f.meta[1].object_id, 4);
  EXPECT_EQ(f.meta[2].class_id, 199);
  EXPECT_EQ(f.meta[2].object_id, -1);
  EXPECT_EQ(f.meta[3].class_id, -1);

  // Explicit semantic source without a semantic image: nothing.
  auto sem = makeClassifier<SemanticFilter>("SemanticFilter", "source: semantic");
  Frame g = makeFrame({{250, 200}});
  sem->classify(g, d, {});
  EXPECT_EQ(g.meta[0].label, KpLabel::Static);

  // Wrong image type is a DataError naming the frame.
  Detections bad;
  bad.semantic = cv::Mat(480, 640, CV_16U, cv::Scalar(1));
  Frame h = makeFrame({{250, 200}}, {640, 480}, 12);
  try {
    sf->classify(h, bad, {});
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("frame 12"), std::string::npos) << e.what();
  }
}

TEST(AdaptiveFeatureCount, UnionAreaIsExact) {
  const cv::Size img(640, 480);
  EXPECT_DOUBLE_EQ(boxUnionArea({{0, 0, 100, 100}, {50, 50, 100, 100}}, img), 17500.0);
  EXPECT_DOUBLE_EQ(boxUnionArea({{0, 0, 100, 100}, {0, 0, 100, 100}}, img), 10000.0);
  EXPECT_DOUBLE_EQ(boxUnionArea({{-50, -50, 100, 100}, {600, 400, 100, 100}}, img), 2500.0 + 40.0 * 80.0);
  EXPECT_DOUBLE_EQ(boxUnionArea({}, img), 0.0);
  EXPECT_DOUBLE_EQ(boxUnionArea({{0, 0, 640, 480}, {10, 10, 20, 20}}, img), 640.0 * 480.0);
}

namespace {
// Detections with one person box covering `frac` of a 640x480 image (full height).
Detections coverage(double frac, int cls = 1) {
  Detections d;
  d.boxes = {box(0, 0, static_cast<float>(640.0 * frac), 480, cls)};
  return d;
}
int request(AdaptiveFeatureCount& a, double frac, int base = 1000) {
  Frame f = makeFrame({{1, 1}});
  ClassifierContext ctx;
  ctx.base_feature_count = base;
  a.classify(f, coverage(frac), ctx);
  EXPECT_EQ(f.meta[0].label, KpLabel::Static);  // labels nothing
  return a.requestedFeatureCount();
}
}  // namespace

TEST(AdaptiveFeatureCount, PaperThresholds) {
  auto a = makeClassifier<AdaptiveFeatureCount>("AdaptiveFeatureCount");
  EXPECT_EQ(request(*a, 0.0), 0);
  EXPECT_EQ(request(*a, 0.29), 0);
  EXPECT_EQ(request(*a, 0.30), 1300);
  EXPECT_NEAR(a->lastArea(), 0.30, 1e-12);
  EXPECT_EQ(request(*a, 0.59), 1300);
  EXPECT_EQ(request(*a, 0.60), 1500);
  EXPECT_EQ(request(*a, 0.90), 1700);
  EXPECT_EQ(request(*a, 0.94), 1700);
  EXPECT_EQ(request(*a, 0.96), 2200);
  EXPECT_EQ(request(*a, 1.0, 2000), 3200);  // absolute increments, independent of the base
  // Non-person boxes do not count; a skipped detection keeps the last request.
  Frame f = makeFrame({{1, 1}});
  ClassifierContext ctx;
  a->classify(f, coverage(0.96, 62), ctx);
  EXPECT_EQ(a->requestedFeatureCount(), 0);
  a->classify(f, coverage(0.6), ctx);
  Detections skipped;
  skipped.valid = false;
  a->classify(f, skipped, ctx);
  EXPECT_EQ(a->requestedFeatureCount(), 1500);
}

TEST(AdaptiveFeatureCount, PercentModeAndSumArea) {
  auto a = makeClassifier<AdaptiveFeatureCount>("AdaptiveFeatureCount", "mode: percent");
  EXPECT_EQ(request(*a, 0.0), 0);
  EXPECT_EQ(request(*a, 0.10), 1300);
  EXPECT_EQ(request(*a, 0.29), 1300);
  EXPECT_EQ(request(*a, 0.30), 1500);
  EXPECT_EQ(request(*a, 0.60), 1700);
  EXPECT_EQ(request(*a, 0.90), 1900);
  EXPECT_EQ(request(*a, 0.96), 2200);
  EXPECT_EQ(request(*a, 0.96, 2000), 4400);  // relative to the base count

  // Two identical 20 % boxes: union 20 % (nothing), sum 40 % (+300).
  Detections d;
  d.boxes = {box(0, 0, 128, 480, 1), box(0, 0, 128, 480, 1)};
  Frame f = makeFrame({{1, 1}});
  auto u = makeClassifier<AdaptiveFeatureCount>("AdaptiveFeatureCount");
  u->classify(f, d, {});
  EXPECT_NEAR(u->lastArea(), 0.2, 1e-12);
  EXPECT_EQ(u->requestedFeatureCount(), 0);
  auto s = makeClassifier<AdaptiveFeatureCount>("AdaptiveFeatureCount", "area: sum");
  s->classify(f, d, {});
  EXPECT_NEAR(s->lastArea(), 0.4, 1e-12);
  EXPECT_EQ(s->requestedFeatureCount(), 1300);
}

TEST(AdaptiveFeatureCount, ConfigurableTableIsValidated) {
  auto a = makeClassifier<AdaptiveFeatureCount>(
      "AdaptiveFeatureCount", "mode: percent\npercent_thresholds: [0.5]\npercent_increments: [10]");
  EXPECT_EQ(request(*a, 0.4), 0);
  EXPECT_EQ(request(*a, 0.5), 1100);
  register_classifiers_plugins();
  auto p = create<KeypointClassifier>("dslam::AdaptiveFeatureCount");
  EXPECT_THROW(p->configure(Params::resolve(p->paramSpecs(), "paper_thresholds: [0.3, 0.6]"), {}), ConfigError);
  EXPECT_THROW(p->configure(Params::resolve(p->paramSpecs(),
                                            "paper_thresholds: [0.6, 0.3]\npaper_increments: [1, 2]"),
                            {}),
               ConfigError);
}

TEST(Classifiers, AllRegisteredWithDocumentedParameters) {
  register_classifiers_plugins();
  const auto infos = listPlugins("KeypointClassifier");
  for (const char* n : {"dslam::BoxFilter", "dslam::SemanticFilter", "dslam::AdaptiveFeatureCount",
                        "dslam::DepthRepopulation", "dslam::EpipolarConsistency", "dslam::PanopticClassifier",
                        "dslam::EkfObjectTracker"}) {
    bool found = false;
    for (const auto& i : infos)
      if (i.name == n) {
        found = true;
        EXPECT_FALSE(i.description.empty()) << n;
        for (const auto& s : i.params) EXPECT_FALSE(s.doc.empty()) << n << "." << s.name;
        // Defaults resolve.
        auto p = create<KeypointClassifier>(n);
        EXPECT_NO_THROW(p->configure(Params::resolve(p->paramSpecs(), ""), {})) << n;
      }
    EXPECT_TRUE(found) << n;
  }
}
