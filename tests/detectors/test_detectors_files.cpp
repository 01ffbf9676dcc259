// FileDetector (box JSON, semantic PNG, COCO panoptic PNG + JSON) and
// GroundTruthDetector (labels + deliberate degradation) on label files
// written by the test.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>

#include "detector_test_util.h"
#include "dslam/core/coco.h"
#include "dslam/core/error.h"
#include "dslam/plugins/detectors/file_detector.h"
#include "dslam/plugins/detectors/ground_truth.h"
#include "dslam/plugins/detectors/label_io.h"
#include "test_support.h"

using namespace dslam;
namespace fs = std::filesystem;

namespace {

SensorFrame frameNamed(const std::string& stem, int index, cv::Size size = {64, 48}) {
  SensorFrame f;
  f.index = index;
  f.timestamp = 100 + index;
  f.image_path = "rgb/" + stem + ".png";
  f.image = cv::Mat(size, CV_8UC3, cv::Scalar(0));
  return f;
}

bool sameMat(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  return a.empty() || cv::countNonZero(a != b) == 0;
}

}  // namespace

// ------------------------------------------------------------------ box JSON

TEST(BoxJson, RoundTrip) {
  const std::string dir = test::tempDir("boxjson");
  std::vector<BoundingBox> in(3);
  in[0] = {cv::Rect2f(12.5f, 80.25f, 96.f, 260.f), 1, 0.93f, 3};
  in[1] = {cv::Rect2f(410, 300, 80, 120), 62, 1.f, -1};
  in[2] = {cv::Rect2f(0, 0, 0, 0), 3, 0.125f, 0};
  labels::writeBoxJson(dir + "/a.json", in, cv::Size(640, 480), "rgb/a.png");
  cv::Size s;
  const auto out = labels::readBoxJson(dir + "/a.json", false, &s);
  EXPECT_EQ(s, cv::Size(640, 480));
  ASSERT_EQ(out.size(), in.size());
  for (size_t i = 0; i < in.size(); i++) {
    EXPECT_EQ(out[i].box, in[i].box) << i;
    EXPECT_EQ(out[i].class_id, in[i].class_id) << i;
    EXPECT_FLOAT_EQ(out[i].score, in[i].score) << i;
    EXPECT_EQ(out[i].instance_id, in[i].instance_id) << i;
  }
}

TEST(BoxJson, AcceptsCocoResultsListNullsAndIndex80) {
  const std::string dir = test::tempDir("boxjson");
  test::writeFile(dir + "/r.json",
                  "[{\"image_id\": 7, \"category_id\": 16, \"bbox\": [1, 2, 3, 4], \"score\": 0.5, "
                  "\"segmentation\": null},\n {\"category_id\": 0, \"bbox\": [5, 6, 7, 8]}]");
  auto b = labels::readBoxJson(dir + "/r.json");
  ASSERT_EQ(b.size(), 2u);
  EXPECT_EQ(b[0].class_id, 16);
  EXPECT_FLOAT_EQ(b[1].score, 1.f);
  EXPECT_EQ(b[1].instance_id, -1);
  // YOLO indices: 16 -> dog (18), 0 -> person (1).
  b = labels::readBoxJson(dir + "/r.json", true);
  EXPECT_EQ(b[0].class_id, 18);
  EXPECT_EQ(b[1].class_id, 1);
}

TEST(BoxJson, ErrorsNameFileAndLine) {
  const std::string dir = test::tempDir("boxjson");
  test::writeFile(dir + "/bad.json", "{\"boxes\": [\n  {\"category_id\": 1, \"bbox\": [1, 2, 3, 4]},\n"
                                     "  {\"category_id\": 1, \"bbox\": [1, 2, 3]}\n]}");
  try {
    labels::readBoxJson(dir + "/bad.json");
    FAIL();
  } catch (const DataError& e) {
    // the place in the file as a JSON path (boxes[1] is on line 3)
    EXPECT_NE(std::string(e.what()).find("bad.json: boxes[1].bbox: must be a list of 4 numbers, got [1,2,3]"),
              std::string::npos) << e.what();
  }
  test::writeFile(dir + "/nocat.json", "{\"boxes\": [{\"bbox\": [1, 2, 3, 4]}]}");
  EXPECT_THROW(labels::readBoxJson(dir + "/nocat.json"), DataError);
  test::writeFile(dir + "/syntax.json", "{\"boxes\": [1, 2}");
  try {
    labels::readBoxJson(dir + "/syntax.json");
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("syntax.json:1:16: invalid JSON: syntax error"), std::string::npos)
        << e.what();
  }
}

// ------------------------------------------------------------ panoptic

namespace {

/** 40x30 panoptic frame: person id 5 (instance 7), wall id 1000, an
 *  out-of-label-set category id 77, an unlisted id 99, a large id 70000
 *  (uses the B channel, category car), void 0. */
void writePanopticFrame(const std::string& root, const std::string& stem) {
  cv::Mat ids(30, 40, CV_32S, cv::Scalar(1000));
  ids(cv::Rect(5, 4, 10, 20)).setTo(5);
  ids(cv::Rect(20, 10, 4, 4)).setTo(77);
  ids(cv::Rect(30, 0, 3, 3)).setTo(99);
  ids(cv::Rect(25, 20, 8, 6)).setTo(70000);
  ids(cv::Rect(0, 28, 40, 2)).setTo(0);
  labels::writePanopticPng(root + "/panoptic/" + stem + ".png", ids);
  labels::PanopticAnnotation a;
  a.file_name = stem + ".png";
  a.image_id = stem;
  PanopticSegment s;
  s.id = 5, s.category_id = 1, s.instance_id = 7;
  a.segments.push_back(s);
  s = {};
  s.id = 1000, s.category_id = 199;
  a.segments.push_back(s);
  s = {};
  s.id = 77, s.category_id = 250;  // not in the label set below
  a.segments.push_back(s);
  s = {};
  s.id = 70000, s.category_id = 3;
  a.segments.push_back(s);
  labels::writePanopticJson(root + "/panoptic.json", {a},
                            {{1, "person", true}, {3, "car", true}, {199, "wall-other-merged", false}});
}

}  // namespace

TEST(FileDetector, CocoPanopticRoundTrip) {
  const std::string root = test::tempDir("pan");
  writePanopticFrame(root, "1305031102.175304");
  auto det = test::makeDetector("dslam::FileDetector", "dir: " + root);
  EXPECT_EQ(det->outputs(), unsigned(kPanoptic | kSemantic));
  const auto d = det->detect(frameNamed("1305031102.175304", 4, cv::Size(40, 30)));
  EXPECT_TRUE(d.valid);
  EXPECT_EQ(d.frame_index, 4);
  ASSERT_EQ(d.panoptic.type(), CV_32S);
  EXPECT_EQ(d.panoptic.at<int>(10, 8), 5);
  EXPECT_EQ(d.panoptic.at<int>(22, 28), 70000);
  EXPECT_EQ(d.panoptic.at<int>(29, 0), 0);
  ASSERT_EQ(d.segments.size(), 5u);  // 4 listed + unlisted 99
  const auto* person = d.segment(5);
  ASSERT_TRUE(person);
  EXPECT_EQ(person->kind, SegmentKind::Thing);
  EXPECT_EQ(person->category_id, 1);
  EXPECT_EQ(person->instance_id, 7);
  EXPECT_EQ(person->area, 200);
  EXPECT_EQ(person->bbox, cv::Rect(5, 4, 10, 20));
  const auto* wall = d.segment(1000);
  ASSERT_TRUE(wall);
  EXPECT_EQ(wall->kind, SegmentKind::Stuff);
  EXPECT_EQ(wall->instance_id, -1);
  EXPECT_EQ(wall->area, 40 * 28 - 200 - 16 - 9 - 48);
  const auto* car = d.segment(70000);
  ASSERT_TRUE(car);
  EXPECT_EQ(car->kind, SegmentKind::Thing);
  EXPECT_EQ(car->instance_id, 70000);  // no instance_id given: the segment id
  EXPECT_EQ(car->area, 48);
  EXPECT_EQ(d.segment(77)->kind, SegmentKind::Unknown);  // category not in the label set
  EXPECT_EQ(d.segment(99)->kind, SegmentKind::Unknown);  // not in segments_info
  EXPECT_EQ(d.segment(99)->category_id, 0);
  EXPECT_EQ(d.segment(0), nullptr);                      // void is not a segment
  // Semantic derived from panoptic: COCO ids, unknown/void -> 255.
  ASSERT_EQ(d.semantic.type(), CV_8U);
  EXPECT_EQ(d.semantic.at<uint8_t>(10, 8), 1);
  EXPECT_EQ(d.semantic.at<uint8_t>(0, 0), 199);
  EXPECT_EQ(d.semantic.at<uint8_t>(22, 28), 3);
  EXPECT_EQ(d.semantic.at<uint8_t>(11, 21), 255);
  EXPECT_EQ(d.semantic.at<uint8_t>(1, 31), 255);
  EXPECT_EQ(d.semantic.at<uint8_t>(29, 0), 255);
}

TEST(FileDetector, PerFramePanopticJsonAndDefaultLabelSet) {
  const std::string root = test::tempDir("pan");
  cv::Mat ids(10, 10, CV_32S, cv::Scalar(3));
  ids(cv::Rect(0, 0, 5, 5)).setTo(4);
  labels::writePanopticPng(root + "/panoptic/000007.png", ids);
  test::writeFile(root + "/panoptic/000007.json",
                  "{\"file_name\": \"000007.png\", \"segments_info\": [{\"id\": 3, \"category_id\": 190}, "
                  "{\"id\": 4, \"category_id\": 62, \"iscrowd\": 0, \"instance_id\": 12}]}");
  auto det = test::makeDetector("dslam::FileDetector",
                                "{dir: " + root + ", naming: index, index_format: '%06d', index_offset: 2}");
  SensorFrame f;
  f.index = 5;
  const auto d = det->detect(f);
  ASSERT_EQ(d.segments.size(), 2u);
  EXPECT_EQ(d.segment(3)->kind, SegmentKind::Stuff);  // 190 floor-other-merged in COCO
  EXPECT_EQ(d.segment(4)->kind, SegmentKind::Thing);  // chair
  EXPECT_EQ(d.segment(4)->instance_id, 12);
  EXPECT_EQ(d.segment(4)->area, 25);
}

TEST(FileDetector, BoxesSemanticMapAndFilters) {
  const std::string root = test::tempDir("files");
  labels::writeBoxJson(root + "/boxes/f1.json", {{cv::Rect2f(1, 2, 30, 40), 1, 0.9f, 4},
                                                  {cv::Rect2f(5, 5, 10, 10), 62, 0.3f, 5},
                                                  {cv::Rect2f(6, 6, 10, 10), 1, 0.1f, 6}});
  cv::Mat sem(48, 64, CV_8U, cv::Scalar(255));
  sem(cv::Rect(0, 0, 10, 10)).setTo(11);  // raw id 11 of some network
  sem(cv::Rect(10, 10, 10, 10)).setTo(1);
  labels::writeSemanticPng(root + "/semantic/f1.png", sem);
  auto det = test::makeDetector("dslam::FileDetector",
                                "{dir: " + root + ", semantic_map: {'11': 62}, min_score: 0.2, classes: [1, 62]}");
  EXPECT_EQ(det->outputs(), unsigned(kBoxes | kSemantic));
  const auto d = det->detect(frameNamed("f1", 0));
  ASSERT_EQ(d.boxes.size(), 2u);  // the 0.1 box is dropped
  EXPECT_EQ(d.boxes[0].box, cv::Rect2f(1, 2, 30, 40));
  EXPECT_EQ(d.boxes[0].instance_id, 4);
  EXPECT_EQ(d.boxes[1].class_id, 62);
  EXPECT_EQ(d.semantic.at<uint8_t>(5, 5), 62);
  EXPECT_EQ(d.semantic.at<uint8_t>(15, 15), 1);
  EXPECT_EQ(d.semantic.at<uint8_t>(40, 40), 255);
  EXPECT_TRUE(d.panoptic.empty());

  auto only_person = test::makeDetector("dslam::FileDetector", "{dir: " + root + ", classes: [1]}");
  EXPECT_EQ(only_person->detect(frameNamed("f1", 0)).boxes.size(), 2u);

  // Label image size differs from the frame: error naming the file.
  try {
    det->detect(frameNamed("f1", 0, cv::Size(32, 24)));
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("f1.png"), std::string::npos) << e.what();
  }
}

TEST(FileDetector, MissingFileSkipOrFail) {
  const std::string root = test::tempDir("files");
  labels::writeBoxJson(root + "/boxes/a.json", {{cv::Rect2f(1, 2, 3, 4), 1, 1.f, -1}});
  auto skip = test::makeDetector("dslam::FileDetector", "dir: " + root);
  const auto d = skip->detect(frameNamed("zzz", 9));
  EXPECT_TRUE(d.valid);
  EXPECT_TRUE(d.empty());
  EXPECT_EQ(d.frame_index, 9);
  EXPECT_EQ(std::dynamic_pointer_cast<FileDetector>(skip)->missingCount(), 1u);
  EXPECT_EQ(skip->detect(frameNamed("a", 0)).boxes.size(), 1u);

  auto fail = test::makeDetector("dslam::FileDetector", "{dir: " + root + ", on_missing: fail}");
  try {
    fail->detect(frameNamed("zzz", 9));
    FAIL();
  } catch (const DataError& e) {
    const std::string w = e.what();
    EXPECT_NE(w.find("frame 9"), std::string::npos) << w;
    EXPECT_NE(w.find("zzz.json"), std::string::npos) << w;
  }
}

TEST(FileDetector, ConfigurationErrors) {
  const std::string root = test::tempDir("files");
  // No label folder at all.
  EXPECT_THROW(test::makeDetector("dslam::FileDetector", "dir: " + root), DataError);
  // Explicitly named folder that does not exist.
  fs::create_directories(root + "/boxes");
  try {
    test::makeDetector("dslam::FileDetector", "{dir: " + root + ", semantic_dir: masks}");
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("masks"), std::string::npos) << e.what();
  }
  // No dir and no dataset root.
  EXPECT_THROW(test::makeDetector("dslam::FileDetector", ""), ConfigError);
  // The dataset root of the context is the default.
  PluginContext ctx;
  ctx.dataset_root = root;
  EXPECT_NO_THROW(test::makeDetector("dslam::FileDetector", "", ctx));
  EXPECT_THROW(test::makeDetector("dslam::FileDetector", "{dir: " + root + ", naming: index, index_format: '%s'}"),
               ConfigError);
}

// ------------------------------------------------------------ ground truth

namespace {

constexpr int kFrames = 200, kObjects = 5;
const cv::Size kSize(80, 60);

/** Synthetic labels: kFrames frames named by TUM-like stamps, kObjects
 *  people/chairs each with box, panoptic segment (instance id = object
 *  id + 1) and semantic pixels; wall stuff elsewhere. Returns the root. */
std::string writeGroundTruth() {
  static std::string root;
  if (!root.empty()) return root;
  root = test::tempDir("gt");
  std::vector<labels::PanopticAnnotation> anns;
  for (int f = 0; f < kFrames; f++) {
    char stem[32];
    std::snprintf(stem, sizeof stem, "%.6f", 1000.0 + f * 0.033);
    cv::Mat ids(kSize, CV_32S, cv::Scalar(500));
    std::vector<BoundingBox> boxes;
    labels::PanopticAnnotation a;
    a.file_name = std::string(stem) + ".png";
    PanopticSegment wall;
    wall.id = 500, wall.category_id = 199;
    a.segments.push_back(wall);
    for (int o = 0; o < kObjects; o++) {
      const cv::Rect r(2 + o * 15, 10 + (f + o) % 20, 10, 20);
      ids(r).setTo(o + 1);
      const int cls = o % 2 ? 62 : 1;
      boxes.push_back({cv::Rect2f(r), cls, 1.f, o + 1});
      PanopticSegment s;
      s.id = o + 1, s.category_id = cls, s.instance_id = o + 1, s.area = r.area(), s.bbox = r;
      a.segments.push_back(s);
    }
    a.segments[0].area = kSize.area() - kObjects * 200;
    labels::writeBoxJson(root + "/boxes/" + stem + ".json", boxes, kSize);
    labels::writePanopticPng(root + "/panoptic/" + stem + ".png", ids);
    Detections tmp;
    tmp.panoptic = ids;
    tmp.segments = a.segments;
    for (auto& s : tmp.segments) s.kind = coco::isThing(s.category_id) ? SegmentKind::Thing : SegmentKind::Stuff;
    labels::writeSemanticPng(root + "/semantic/" + stem + ".png", labels::semanticFromPanoptic(tmp));
    anns.push_back(a);
  }
  labels::writePanopticJson(root + "/panoptic.json", anns, labels::cocoPanopticCategories());
  return root;
}

SensorFrame gtFrame(int f) {
  char stem[32];
  std::snprintf(stem, sizeof stem, "%.6f", 1000.0 + f * 0.033);
  SensorFrame s = frameNamed(stem, f, kSize);
  return s;
}

std::shared_ptr<Detector> gt(const std::string& yaml, uint64_t seed = 42) {
  PluginContext ctx;
  ctx.dataset_root = writeGroundTruth();
  ctx.seed = seed;
  return test::makeDetector("dslam::GroundTruthDetector", yaml, ctx);
}

bool sameBoxes(const std::vector<BoundingBox>& a, const std::vector<BoundingBox>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); i++)
    if (a[i].box != b[i].box || a[i].class_id != b[i].class_id || a[i].instance_id != b[i].instance_id ||
        a[i].score != b[i].score)
      return false;
  return true;
}

bool sameDetections(const Detections& a, const Detections& b) {
  if (!sameBoxes(a.boxes, b.boxes) || !sameMat(a.semantic, b.semantic) || !sameMat(a.panoptic, b.panoptic) ||
      a.segments.size() != b.segments.size())
    return false;
  for (size_t i = 0; i < a.segments.size(); i++)
    if (a.segments[i].id != b.segments[i].id || a.segments[i].category_id != b.segments[i].category_id ||
        a.segments[i].kind != b.segments[i].kind || a.segments[i].instance_id != b.segments[i].instance_id)
      return false;
  return true;
}

}  // namespace

TEST(GroundTruthDetector, NoDegradationReproducesLabels) {
  auto det = gt("");
  auto file = test::makeDetector("dslam::FileDetector", "dir: " + writeGroundTruth());
  EXPECT_EQ(det->outputs(), unsigned(kBoxes | kSemantic | kPanoptic));
  for (int f : {0, 1, 57, kFrames - 1}) {
    const auto d = det->detect(gtFrame(f));
    const auto ref = file->detect(gtFrame(f));
    EXPECT_TRUE(d.valid);
    EXPECT_EQ(d.frame_index, f);
    ASSERT_EQ(d.boxes.size(), size_t(kObjects));
    EXPECT_TRUE(sameDetections(d, ref)) << "frame " << f;
    EXPECT_EQ(d.boxes[2].box, cv::Rect2f(32, float(10 + (f + 2) % 20), 10, 20));
    EXPECT_EQ(d.semantic.at<uint8_t>(10 + (f + 1) % 20, 17), 62);
    EXPECT_EQ(d.segment(1)->kind, SegmentKind::Thing);
    EXPECT_EQ(d.segment(500)->kind, SegmentKind::Stuff);
  }
}

TEST(GroundTruthDetector, MissRateDropsBoxAndMask) {
  auto det = gt("miss_rate: 0.1");
  int dropped = 0, total = 0;
  for (int f = 0; f < kFrames; f++) {
    const auto d = det->detect(gtFrame(f));
    std::set<int> kept;
    for (const auto& b : d.boxes) kept.insert(b.instance_id);
    total += kObjects;
    dropped += kObjects - int(kept.size());
    for (int o = 1; o <= kObjects; o++) {
      const cv::Rect r(2 + (o - 1) * 15, 10 + (f + o - 1) % 20, 10, 20);
      const bool is_kept = kept.count(o) > 0;
      // The segment and its pixels go with the box.
      EXPECT_EQ(d.segment(o) != nullptr, is_kept) << "frame " << f << " object " << o;
      EXPECT_EQ(d.panoptic.at<int>(r.y + 5, r.x + 5), is_kept ? o : 0);
      EXPECT_EQ(d.semantic.at<uint8_t>(r.y + 5, r.x + 5), is_kept ? (o % 2 ? 1 : 62) : 255);
    }
  }
  const double rate = double(dropped) / total;
  EXPECT_NEAR(rate, 0.1, 0.03) << dropped << " of " << total;
}

TEST(GroundTruthDetector, JitterIsBounded) {
  const double j = 0.05;
  auto det = gt("jitter: 0.05");
  int moved = 0;
  for (int f = 0; f < 50; f++) {
    const auto d = det->detect(gtFrame(f));
    ASSERT_EQ(d.boxes.size(), size_t(kObjects));
    for (int o = 0; o < kObjects; o++) {
      const cv::Rect2f t(float(2 + o * 15), float(10 + (f + o) % 20), 10, 20);
      const auto& b = d.boxes[size_t(o)].box;
      const float dcx = (b.x + b.width / 2) - (t.x + t.width / 2), dcy = (b.y + b.height / 2) - (t.y + t.height / 2);
      EXPECT_LE(std::abs(dcx), j * t.width + 1e-4);
      EXPECT_LE(std::abs(dcy), j * t.height + 1e-4);
      EXPECT_GE(b.width, (1 - j) * t.width - 1e-4);
      EXPECT_LE(b.width, (1 + j) * t.width + 1e-4);
      EXPECT_GE(b.height, (1 - j) * t.height - 1e-4);
      EXPECT_LE(b.height, (1 + j) * t.height + 1e-4);
      moved += (b != t);
    }
    // Masks are not jittered.
    EXPECT_EQ(d.panoptic.at<int>(10 + f % 20, 2), 1);
  }
  EXPECT_GT(moved, 240);  // essentially every box moves
}

TEST(GroundTruthDetector, LatencyShiftsFrames) {
  auto lag = gt("{latency: 3, miss_rate: 0.3, jitter: 0.1}");
  auto now = gt("{miss_rate: 0.3, jitter: 0.1}");
  for (int f = 0; f < 3; f++) {
    const auto d = lag->detect(gtFrame(f));
    EXPECT_FALSE(d.valid) << f;
    EXPECT_TRUE(d.empty());
  }
  for (int f = 3; f < 40; f++) {
    const auto d = lag->detect(gtFrame(f));
    const auto ref = now->detect(gtFrame(f - 3));
    EXPECT_TRUE(d.valid);
    EXPECT_EQ(d.frame_index, f);
    EXPECT_TRUE(sameDetections(d, ref)) << "frame " << f;
  }
}

TEST(GroundTruthDetector, DeterministicForSeedIndependentOfCallOrder) {
  const std::string y = "{miss_rate: 0.3, jitter: 0.1, false_positive_rate: 0.5, swap_rate: 0.2}";
  auto a = gt(y, 7), b = gt(y, 7), c = gt(y, 8);
  std::vector<Detections> fwd;
  for (int f = 0; f < 30; f++) fwd.push_back(a->detect(gtFrame(f)));
  int differs = 0;
  for (int f = 29; f >= 0; f--) {
    EXPECT_TRUE(sameDetections(fwd[size_t(f)], b->detect(gtFrame(f)))) << f;
    differs += !sameDetections(fwd[size_t(f)], c->detect(gtFrame(f)));
  }
  EXPECT_GT(differs, 20);  // another seed degrades differently
}

TEST(GroundTruthDetector, FalsePositivesAndSwaps) {
  auto fp = gt("{false_positive_rate: 1.5, fp_class: 18, fp_in_masks: true}");
  int n = 0;
  for (int f = 0; f < kFrames; f++) {
    const auto d = fp->detect(gtFrame(f));
    int extra = 0;
    for (const auto& b : d.boxes) {
      EXPECT_GE(b.box.x, 0);
      EXPECT_LE(b.box.x + b.box.width, kSize.width + 1e-3);
      EXPECT_LE(b.box.y + b.box.height, kSize.height + 1e-3);
      if (b.instance_id < 0) {
        EXPECT_EQ(b.class_id, 18);
        EXPECT_GE(b.box.width, 0.1 * kSize.width - 1e-3);
        EXPECT_LE(b.box.width, 0.4 * kSize.width + 1e-3);
        // Painted into the masks (ellipse centre).
        const int cx = int(b.box.x + b.box.width / 2), cy = int(b.box.y + b.box.height / 2);
        EXPECT_EQ(d.semantic.at<uint8_t>(cy, cx), 18);
        const auto* s = d.segment(d.panoptic.at<int>(cy, cx));
        ASSERT_TRUE(s);
        EXPECT_EQ(s->category_id, 18);
        extra++;
      }
    }
    n += extra;
    EXPECT_TRUE(extra == 1 || extra == 2) << extra;
  }
  EXPECT_NEAR(double(n) / kFrames, 1.5, 0.15);

  auto sw = gt("{swap_rate: 1.0, swap_classes: [3]}");
  const auto d = sw->detect(gtFrame(0));
  for (const auto& b : d.boxes) EXPECT_EQ(b.class_id, 3);
  for (int o = 1; o <= kObjects; o++) EXPECT_EQ(d.segment(o)->category_id, 3);
  EXPECT_EQ(d.semantic.at<uint8_t>(15, 5), 3);
  EXPECT_EQ(d.segment(500)->category_id, 199);  // stuff is never swapped
}

TEST(GroundTruthDetector, HashUniformIsUniformAndStable) {
  double sum = 0;
  int below = 0;
  for (int i = 0; i < 10000; i++) {
    const double u = hashUniform(42, i, 3, 1);
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    sum += u;
    below += u < 0.1;
  }
  EXPECT_NEAR(sum / 10000, 0.5, 0.01);
  EXPECT_NEAR(below / 10000.0, 0.1, 0.01);
  EXPECT_EQ(hashUniform(1, 2, 3, 4), hashUniform(1, 2, 3, 4));
  EXPECT_NE(hashUniform(1, 2, 3, 4), hashUniform(1, 2, 4, 4));
}

TEST(GroundTruthDetector, MissingFramePolicy) {
  auto skip = gt("");
  const auto d = skip->detect(frameNamed("not_a_frame", 3, kSize));
  EXPECT_TRUE(d.valid);
  EXPECT_TRUE(d.empty());
  auto fail = gt("on_missing: fail");
  try {
    fail->detect(frameNamed("not_a_frame", 3, kSize));
    FAIL();
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("not_a_frame"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("frame 3"), std::string::npos) << e.what();
  }
}

TEST(PanopticJson, MalformedFilesNameFileAndPlace) {
  const std::string dir = test::tempDir("panjson");
  test::writeFile(dir + "/a.json", "{\"annotations\": [{\"file_name\": \"1.png\", \"segments_info\": [\n"
                                   "  {\"id\": 5, \"category_id\": \"person\"}]}]}");
  const std::string m = test::dataError([&] { labels::readPanopticJson(dir + "/a.json"); });
  EXPECT_NE(m.find("a.json: annotations[0].segments_info[0].category_id: must be a number, got \"person\""),
            std::string::npos) << m;
  test::writeFile(dir + "/b.json", "{\"annotations\": [{\"segments_info\": 3}]}");
  const std::string m2 = test::dataError([&] { labels::readPanopticJson(dir + "/b.json"); });
  EXPECT_NE(m2.find("b.json: annotations[0].segments_info: must be a list"), std::string::npos) << m2;
  test::writeFile(dir + "/c.json", "{\"annotations\": [\n{\"segments_info\": [}\n]}");
  const std::string m3 = test::dataError([&] { labels::readPanopticJson(dir + "/c.json"); });
  EXPECT_NE(m3.find("c.json:2:"), std::string::npos) << m3;
  EXPECT_NE(m3.find("invalid JSON"), std::string::npos) << m3;
  // Round trip through the writer keeps everything the reader needs.
  labels::PanopticAnnotation ann;
  ann.file_name = "x \"quoted\"\tname.png";
  PanopticSegment s;
  s.id = 7;
  s.category_id = 1;
  s.bbox = {1, 2, 3, 4};
  s.area = 12;
  ann.segments.push_back(s);
  labels::writePanopticJson(dir + "/w.json", {ann}, labels::cocoPanopticCategories());
  const auto j = labels::readPanopticJson(dir + "/w.json");
  ASSERT_EQ(j.annotations.size(), 1u);
  EXPECT_EQ(j.annotations[0].file_name, ann.file_name);
  ASSERT_EQ(j.annotations[0].segments.size(), 1u);
  EXPECT_EQ(j.annotations[0].segments[0].bbox, cv::Rect(1, 2, 3, 4));
  EXPECT_EQ(j.annotations[0].segments[0].kind, SegmentKind::Thing);
}
