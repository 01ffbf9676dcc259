// EpipolarConsistency and PanopticClassifier on two synthetic views with a
// known camera motion; determinism.
#include <gtest/gtest.h>

#include <cstring>
#include <set>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "classifier_test_util.h"
#include "dslam/plugins/classifiers/epipolar_consistency.h"
#include "dslam/plugins/classifiers/panoptic_classifier.h"

using namespace dslam;
using namespace dslam::test;

namespace {

/** Two views of random 3D points: frame 1 pixels are sampled (in `regions`
 *  if given), lifted at random depths, moved to camera 0 and projected. */
struct TwoView {
  CameraModel cam = pinhole();
  SE3 T_10;  // camera-0 coordinates -> camera-1 coordinates
  Eigen::Matrix3d F;  // x1^T F x0 = 0 (pixels)
  std::vector<cv::Point2f> p0, p1;
  cv::RNG rng{1234};

  TwoView() {
    const Eigen::Vector3d axis = Eigen::Vector3d(0.2, 1.0, 0.1).normalized();
    T_10 = SE3(Eigen::Quaterniond(Eigen::AngleAxisd(2.0 * M_PI / 180.0, axis)), Eigen::Vector3d(0.12, 0.02, 0.04));
    Eigen::Matrix3d K;
    K << cam.left.fx, 0, cam.left.cx, 0, cam.left.fy, cam.left.cy, 0, 0, 1;
    const Eigen::Matrix3d E = SE3::skew(T_10.translation()) * T_10.rotation();
    F = K.inverse().transpose() * E * K.inverse();
  }

  /** Adds a point seen at a frame-1 pixel inside `r1` whose frame-0 pixel
   *  lies inside `r0` (both shrunk by `margin`). Returns its index. */
  int add(cv::Rect r1, cv::Rect r0 = cv::Rect(0, 0, 640, 480), int margin = 12) {
    const SE3 T_01 = T_10.inverse();
    for (int tries = 0; tries < 10000; tries++) {
      const double u = rng.uniform(r1.x + margin, r1.x + r1.width - margin);
      const double v = rng.uniform(r1.y + margin, r1.y + r1.height - margin);
      const double z = rng.uniform(2.0, 8.0);
      const Eigen::Vector3d X0 = T_01 * cam.left.unproject(u, v, z);
      const Eigen::Vector2d q = cam.left.project(X0);
      if (q.x() < r0.x + margin || q.y() < r0.y + margin || q.x() >= r0.x + r0.width - margin ||
          q.y() >= r0.y + r0.height - margin)
        continue;
      p1.emplace_back(static_cast<float>(u), static_cast<float>(v));
      p0.emplace_back(static_cast<float>(q.x()), static_cast<float>(q.y()));
      return static_cast<int>(p1.size()) - 1;
    }
    ADD_FAILURE() << "could not place a point";
    return -1;
  }

  /** Adds n points anywhere in both images. */
  void fill(int n) {
    for (int i = 0; i < n; i++) add(cv::Rect(0, 0, 640, 480));
  }

  /** Moves points 0, step, 2 step... by `px` across their epipolar lines;
   *  returns their indices. */
  std::set<size_t> displaceEvery(int step, double px) {
    std::set<size_t> moved;
    for (int i = 0; i < static_cast<int>(p1.size()); i += step) {
      displace(i, px);
      moved.insert(static_cast<size_t>(i));
    }
    return moved;
  }

  /** Moves frame-1 point i by `px` pixels across its epipolar line. */
  void displace(int i, double px) {
    const Eigen::Vector3d l = F * Eigen::Vector3d(p0[i].x, p0[i].y, 1);
    const Eigen::Vector2d nrm = l.head<2>().normalized();
    p1[i].x += static_cast<float>(px * nrm.x());
    p1[i].y += static_cast<float>(px * nrm.y());
  }

  double trueDistance(int i) const {
    const Eigen::Vector3d l = F * Eigen::Vector3d(p0[i].x, p0[i].y, 1);
    return std::abs(l.dot(Eigen::Vector3d(p1[i].x, p1[i].y, 1))) / l.head<2>().norm();
  }

  /** Frames 0 and 1 with one shared random descriptor per point. */
  void frames(Frame& f0, Frame& f1, uint64_t seed = 99) const {
    f0 = makeFrame(p0, {640, 480}, 0, 0.0);
    f1 = makeFrame(p1, {640, 480}, 1, 1 / 30.0);
    f0.descriptors = randomDescriptors(static_cast<int>(p0.size()), seed);
    f1.descriptors = f0.descriptors.clone();
  }
};

std::set<size_t> dynamicSet(const Frame& f) {
  std::set<size_t> s;
  for (size_t i = 0; i < f.size(); i++)
    if (f.meta[i].label == KpLabel::Dynamic) s.insert(i);
  return s;
}

}  // namespace

TEST(EpipolarConsistency, DescriptorMatchesFlagPointsOffTheirEpipolarLines) {
  TwoView tv;
  tv.fill(300);
  const std::set<size_t> moved = tv.displaceEvery(30, 6.0);
  for (int i = 0; i < 300; i++) ASSERT_NEAR(tv.trueDistance(i), moved.count(i) ? 6.0 : 0.0, 1e-3) << i;
  Frame f0, f1;
  tv.frames(f0, f1);
  f1.meta[5] = {KpLabel::Dynamic, KpReason::InDynamicBox, 1, -1};  // dropped earlier: stays so
  auto ec = makeClassifier<EpipolarConsistency>("EpipolarConsistency", "matching: descriptors");
  ClassifierContext ctx;
  ctx.camera = &tv.cam;
  ctx.previous = &f0;
  ec->classify(f1, {}, ctx);
  std::set<size_t> want = moved;
  want.insert(5);
  EXPECT_EQ(dynamicSet(f1), want);
  for (size_t i : moved) EXPECT_EQ(f1.meta[i].reason, KpReason::EpipolarOutlier) << i;
  EXPECT_EQ(f1.meta[5].reason, KpReason::InDynamicBox);
  const auto& st = ec->lastStats();
  EXPECT_TRUE(st.fitted);
  EXPECT_EQ(st.fit_matches, 299);  // every keypoint but the one already dynamic
  EXPECT_EQ(st.outliers, 10);
  EXPECT_GE(st.fit_inliers, 289);
  // The estimated F explains the static points to a small fraction of a pixel.
  const cv::Matx33d F = ec->lastFundamental();
  for (int i = 1; i < 300; i++) {
    if (moved.count(i)) continue;
    const double a = F(0, 0) * tv.p0[i].x + F(0, 1) * tv.p0[i].y + F(0, 2);
    const double b = F(1, 0) * tv.p0[i].x + F(1, 1) * tv.p0[i].y + F(1, 2);
    const double c = F(2, 0) * tv.p0[i].x + F(2, 1) * tv.p0[i].y + F(2, 2);
    EXPECT_LT(std::abs(a * tv.p1[i].x + b * tv.p1[i].y + c) / std::hypot(a, b), 0.01) << i;
  }

  // A 0.5 px displacement stays under DS-SLAM's 1 px threshold, but not under 0.25 px.
  TwoView small;
  for (int i = 0; i < 200; i++) small.add(cv::Rect(0, 0, 640, 480));
  small.displace(7, 0.5);
  Frame g0, g1, h0, h1;
  small.frames(g0, g1);
  small.frames(h0, h1);
  ctx.previous = &g0;
  makeClassifier<EpipolarConsistency>("EpipolarConsistency", "matching: descriptors")->classify(g1, {}, ctx);
  EXPECT_TRUE(dynamicSet(g1).empty());
  ctx.previous = &h0;
  makeClassifier<EpipolarConsistency>("EpipolarConsistency", "matching: descriptors\nthreshold: 0.25")
      ->classify(h1, {}, ctx);
  EXPECT_EQ(dynamicSet(h1), std::set<size_t>({7}));
}

TEST(EpipolarConsistency, UsacAndSubsampledFitGiveTheSameDecisions) {
  TwoView tv;
  tv.fill(300);
  const std::set<size_t> moved = tv.displaceEvery(25, 3.0);
  for (const char* yaml : {"ransac_method: usac", "max_fit_points: 60", "ransac_method: usac\nmax_fit_points: 60",
                           "ransac_max_iterations: 50"}) {
    for (int run = 0; run < 2; run++) {
      Frame f0, f1;
      tv.frames(f0, f1);
      ClassifierContext ctx;
      ctx.camera = &tv.cam;
      ctx.previous = &f0;
      auto ec = makeClassifier<EpipolarConsistency>("EpipolarConsistency", std::string("matching: descriptors\n") + yaml);
      ec->classify(f1, {}, ctx);
      EXPECT_EQ(dynamicSet(f1), moved) << yaml;
      EXPECT_EQ(ec->lastStats().fit_matches, 300) << yaml;  // correspondences found
      if (std::string(yaml).find("max_fit_points") != std::string::npos) {
        // RANSAC saw every 5th correspondence: 60, of which the 12 moved ones (multiples of 25) are outliers.
        EXPECT_EQ(ec->lastStats().fit_inliers, 48) << yaml;
      } else {
        EXPECT_EQ(ec->lastStats().fit_inliers, 300 - static_cast<int>(moved.size())) << yaml;
      }
      EXPECT_EQ(ec->lastStats().matched, 300) << yaml;  // every tested keypoint still found its match
    }
  }
}

TEST(EpipolarConsistency, ApplyToBoxesAndExcludedRegions) {
  TwoView tv;
  tv.fill(300);
  const std::set<size_t> moved = tv.displaceEvery(15, 5.0);
  Detections d;
  d.boxes = {box(0, 0, 320, 480, 62)};  // chairs: tested
  ClassifierContext ctx;
  ctx.camera = &tv.cam;
  Frame f0, f1;
  tv.frames(f0, f1);
  ctx.previous = &f0;
  auto ec = makeClassifier<EpipolarConsistency>("EpipolarConsistency", "matching: descriptors\napply_to: boxes");
  ec->classify(f1, d, ctx);
  std::set<size_t> want;
  for (size_t i : moved)
    if (tv.p1[i].x < 320) want.insert(i);
  ASSERT_FALSE(want.empty());
  ASSERT_LT(want.size(), moved.size());
  EXPECT_EQ(dynamicSet(f1), want);  // displaced points outside the box are not tested
  int left = 0;
  for (const auto& p : tv.p1) left += p.x < 320;
  EXPECT_EQ(ec->lastStats().tested, left);
  EXPECT_EQ(ec->lastStats().fit_matches, 300 - left);  // fitted on the other keypoints only

  // A person box over the right half: its keypoints leave the fit; too few remain -> no decision at all.
  Detections p;
  p.boxes = {box(0, 0, 320, 480, 62), box(320, 0, 320, 480, 1)};
  Frame g0, g1;
  tv.frames(g0, g1);
  ctx.previous = &g0;
  auto ec2 = makeClassifier<EpipolarConsistency>("EpipolarConsistency", "matching: descriptors\napply_to: boxes");
  ec2->classify(g1, p, ctx);
  EXPECT_FALSE(ec2->lastStats().fitted);
  EXPECT_EQ(ec2->lastStats().fit_matches, 0);
  EXPECT_TRUE(dynamicSet(g1).empty());
}

namespace {

/** Smooth random texture (features of about `cell` pixels). */
cv::Mat texture(cv::Size size, int cell, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat small(size.height / cell + 3, size.width / cell + 3, CV_8U);
  rng.fill(small, cv::RNG::UNIFORM, 20, 235);
  cv::Mat big;
  cv::resize(small, big, cv::Size(small.cols * cell, small.rows * cell), 0, 0, cv::INTER_CUBIC);
  return big(cv::Rect(0, 0, size.width, size.height)).clone();
}

bool near(const cv::Point2f& p, const cv::Rect& r, int m) {
  return p.x >= r.x - m && p.y >= r.y - m && p.x < r.x + r.width + m && p.y < r.y + r.height + m;
}

}  // namespace

// Camera translating along x over a wall at 4 m and a board at 2 m (image
// shifts of 4 and 8 px: horizontal epipolar lines), plus an object moving
// 7 px downwards: LK flow finds it off its epipolar line.
TEST(EpipolarConsistency, OpticalFlowFlagsMovingObject) {
  const cv::Mat wall = texture({720, 520}, 9, 1), board = texture({200, 160}, 7, 2), thing = texture({150, 150}, 8, 3);
  const cv::Rect board0(80, 60, 200, 160), thing0(400, 250, 150, 150);
  const cv::Rect board1 = board0 - cv::Point(8, 0), thing1 = thing0 + cv::Point(-6, 7);
  cv::Mat im0 = wall(cv::Rect(30, 20, 640, 480)).clone(), im1 = wall(cv::Rect(34, 20, 640, 480)).clone();
  board.copyTo(im0(board0));
  board.copyTo(im1(board1));
  thing.copyTo(im0(thing0));
  thing.copyTo(im1(thing1));

  std::vector<cv::Point2f> pts;
  std::vector<int> kind;  // 0 wall, 1 board, 2 moving thing
  for (int y = 30; y < 450; y += 14)
    for (int x = 30; x < 610; x += 14) {
      const cv::Point2f p(static_cast<float>(x), static_cast<float>(y));
      int k = -1;
      if (board1.contains(p) && !near(p, board1, -15)) continue;  // keep 15 px inside / outside the borders
      if (thing1.contains(p) && !near(p, thing1, -15)) continue;
      if (near(p, thing1, -15))
        k = 2;
      else if (near(p, board1, -15))
        k = 1;
      else if (!near(p, board1, 15) && !near(p, board0, 15) && !near(p, thing1, 15) && !near(p, thing0, 15))
        k = 0;
      if (k < 0) continue;
      pts.push_back(p);
      kind.push_back(k);
    }
  CameraModel cam = pinhole();
  Frame f0 = makeFrame({}, {640, 480}, 0, 0.0), f1 = makeFrame(pts, {640, 480}, 1, 1 / 30.0);
  f0.gray = im0;
  f1.gray = im1;
  ClassifierContext ctx;
  ctx.camera = &cam;
  ctx.previous = &f0;
  auto ec = makeClassifier<EpipolarConsistency>("EpipolarConsistency");
  ec->classify(f1, {}, ctx);
  int n[3] = {0, 0, 0}, flagged[3] = {0, 0, 0};
  for (size_t i = 0; i < pts.size(); i++) {
    n[kind[i]]++;
    flagged[kind[i]] += f1.meta[i].label == KpLabel::Dynamic;
  }
  ASSERT_GT(n[0], 300);
  ASSERT_GT(n[1], 30);
  ASSERT_GT(n[2], 20);
  EXPECT_EQ(flagged[0], 0);
  EXPECT_EQ(flagged[1], 0);
  EXPECT_EQ(flagged[2], n[2]);
  EXPECT_TRUE(ec->lastStats().fitted);
  // Horizontal epipolar lines: F ~ [[0,0,0],[0,0,a],[0,-a,0]].
  const cv::Matx33d F = ec->lastFundamental() * (1.0 / cv::norm(ec->lastFundamental()));
  EXPECT_NEAR(std::abs(F(1, 2)), std::sqrt(0.5), 0.01);
  EXPECT_NEAR(std::abs(F(2, 1)), std::sqrt(0.5), 0.01);
}

TEST(EpipolarConsistency, DeterministicLabelsAndFundamentalMatrix) {
  TwoView tv;
  tv.fill(400);
  cv::RNG noise(5);
  for (auto& p : tv.p1) {  // pixel noise: RANSAC has real choices to make
    p.x += static_cast<float>(noise.gaussian(0.3));
    p.y += static_cast<float>(noise.gaussian(0.3));
  }
  tv.displaceEvery(9, 3.0);
  std::vector<std::vector<KeypointMeta>> metas;
  std::vector<cv::Matx33d> Fs;
  for (int run = 0; run < 3; run++) {
    Frame f0, f1;
    tv.frames(f0, f1);
    ClassifierContext ctx;
    ctx.camera = &tv.cam;
    ctx.previous = &f0;
    auto ec = makeClassifier<EpipolarConsistency>("EpipolarConsistency", "matching: descriptors");
    ec->classify(f1, {}, ctx);
    metas.push_back(f1.meta);
    Fs.push_back(ec->lastFundamental());
  }
  for (int run = 1; run < 3; run++) {
    ASSERT_EQ(metas[run].size(), metas[0].size());
    for (size_t i = 0; i < metas[0].size(); i++) {
      EXPECT_EQ(metas[run][i].label, metas[0][i].label) << i;
      EXPECT_EQ(metas[run][i].reason, metas[0][i].reason) << i;
    }
    EXPECT_EQ(std::memcmp(Fs[run].val, Fs[0].val, sizeof(Fs[0].val)), 0);
  }
  // cv::findFundamentalMat(FM_RANSAC) itself: same input, same output, bit for bit.
  cv::Mat a = cv::findFundamentalMat(tv.p0, tv.p1, cv::FM_RANSAC, 0.1, 0.99);
  cv::Mat b = cv::findFundamentalMat(tv.p0, tv.p1, cv::FM_RANSAC, 0.1, 0.99);
  ASSERT_EQ(a.size(), cv::Size(3, 3));
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
}

// ---------------------------------------------------------------------------
// Panoptic-SLAM on crafted segments: wall (stuff) everywhere, a person, a
// moving chair, a static chair, a void region, and (frame 1) a new cup.

namespace {

struct PanScene {
  TwoView tv;
  const cv::Rect person{40, 60, 120, 300}, chair_a{200, 250, 140, 150}, chair_b{420, 240, 150, 160},
      unknown{380, 40, 200, 140}, cup{220, 60, 100, 100};
  std::vector<int> idx_person, idx_a, idx_b, idx_unk_matched, idx_unk_new, idx_stuff, idx_cup;
  int unk_moved = -1;

  static bool inAny(const cv::Point2f& p, const std::vector<cv::Rect>& rs, int m) {
    for (const auto& r : rs)
      if (near(p, r, m)) return true;
    return false;
  }

  PanScene() {
    const cv::Rect all(0, 0, 640, 480);
    for (int i = 0; i < 15; i++) idx_person.push_back(tv.add(person, person));
    for (int i = 0; i < 25; i++) idx_a.push_back(tv.add(chair_a, chair_a));
    for (int i = 0; i < 25; i++) idx_b.push_back(tv.add(chair_b, chair_b));
    for (int i = 0; i < 20; i++) idx_unk_matched.push_back(tv.add(unknown, unknown));
    for (int i = 0; i < 12; i++) idx_cup.push_back(tv.add(cup, cup));
    const std::vector<cv::Rect> things = {person, chair_a, chair_b, unknown, cup};
    while (idx_stuff.size() < 200) {
      const int i = tv.add(all, all);
      if (inAny(tv.p1[i], things, 12) || inAny(tv.p0[i], things, 12)) {  // keep stuff clear of the regions
        tv.p0.pop_back();
        tv.p1.pop_back();
        continue;
      }
      idx_stuff.push_back(i);
    }
    for (int i : idx_a) tv.displace(i, 4.0);  // the chair moves: all its points leave their epipolar lines
    unk_moved = idx_unk_matched[3];
    tv.displace(unk_moved, 4.0);
  }

  /** Panoptic labels of frame k (the cup exists only in frame 1). */
  Detections labels(int k) const {
    Detections d;
    d.frame_index = k;
    d.panoptic = cv::Mat(480, 640, CV_32S, cv::Scalar(199));
    d.panoptic(person).setTo(1001);
    d.panoptic(chair_a).setTo(1002);
    d.panoptic(chair_b).setTo(1003);
    d.panoptic(unknown).setTo(0);
    d.segments = {{199, 199, SegmentKind::Stuff, -1, 0, {}, 1.f},
                  {1001, 1, SegmentKind::Thing, 1, 0, {}, 1.f},
                  {1002, 62, SegmentKind::Thing, 2, 0, {}, 1.f},
                  {1003, 62, SegmentKind::Thing, 3, 0, {}, 1.f}};
    if (k == 1) {
      d.panoptic(cup).setTo(1004);
      d.segments.push_back({1004, 47, SegmentKind::Thing, 4, 0, {}, 1.f});
    }
    return d;
  }

  /** Frames: frame 0 lacks the cup points and the "new" unknown points. */
  void frames(Frame& f0, Frame& f1) {
    Frame a, b;
    tv.frames(a, b);
    // Unknown-region points only visible in frame 1 (fresh descriptors).
    const int extra = 8;
    std::vector<cv::Point2f> p1 = tv.p1;
    cv::Mat d1 = b.descriptors.clone();
    const cv::Mat dn = randomDescriptors(extra, 4242);
    cv::RNG rng(77);
    for (int i = 0; i < extra; i++) {
      p1.emplace_back(static_cast<float>(rng.uniform(unknown.x + 15, unknown.x + unknown.width - 15)),
                      static_cast<float>(rng.uniform(unknown.y + 15, unknown.y + unknown.height - 15)));
      idx_unk_new.push_back(static_cast<int>(p1.size()) - 1);
      d1.push_back(dn.row(i));
    }
    f1 = makeFrame(p1, {640, 480}, 1, 1 / 30.0);
    f1.descriptors = d1;
    // Frame 0 without the cup's points (the cup appears in frame 1).
    std::vector<cv::Point2f> p0;
    cv::Mat d0;
    const std::set<int> cupset(idx_cup.begin(), idx_cup.end());
    for (size_t i = 0; i < tv.p0.size(); i++) {
      if (cupset.count(static_cast<int>(i))) continue;
      p0.push_back(tv.p0[i]);
      d0.push_back(a.descriptors.row(static_cast<int>(i)));
    }
    f0 = makeFrame(p0, {640, 480}, 0, 0.0);
    f0.descriptors = d0;
  }
};

}  // namespace

TEST(PanopticClassifier, CraftedSegments) {
  PanScene s;
  Frame f0, f1;
  s.frames(f0, f1);
  const Detections d0 = s.labels(0), d1 = s.labels(1);
  auto pc = makeClassifier<PanopticClassifier>("PanopticClassifier");
  ClassifierContext c0;
  c0.camera = &s.tv.cam;
  pc->classify(f0, d0, c0);
  // First frame: people dropped a priori, nothing else can be checked yet.
  EXPECT_EQ(f0.countLabel(KpLabel::Dynamic), s.idx_person.size());
  EXPECT_EQ(f0.countLabel(KpLabel::Movable), s.idx_a.size() + s.idx_b.size());
  const std::map<int, int> ids0 = pc->objectIds();
  ASSERT_EQ(ids0.size(), 3u);

  ClassifierContext c1 = c0;
  c1.previous = &f0;
  c1.previous_detections = &d0;
  pc->classify(f1, d1, c1);
  const auto& st = pc->lastStats();
  EXPECT_TRUE(st.fitted);
  EXPECT_EQ(st.stuff_matches, 200);
  EXPECT_EQ(st.new_things, 1);  // the cup
  // Short-term data association kept the object ids of frame 0.
  EXPECT_EQ(pc->objectIds().at(1002), ids0.at(1002));
  EXPECT_EQ(pc->objectIds().at(1003), ids0.at(1003));
  EXPECT_NE(pc->objectIds().at(1004), ids0.at(1002));

  for (int i : s.idx_person) {
    EXPECT_EQ(f1.meta[i].label, KpLabel::Dynamic) << i;
    EXPECT_EQ(f1.meta[i].reason, KpReason::PersonPrior) << i;
    EXPECT_EQ(f1.meta[i].class_id, 1);
  }
  for (int i : s.idx_a) {
    EXPECT_EQ(f1.meta[i].label, KpLabel::Dynamic) << i;
    EXPECT_EQ(f1.meta[i].reason, KpReason::EpipolarOutlier) << i;
    EXPECT_EQ(f1.meta[i].class_id, 62);
  }
  for (int i : s.idx_b) {
    EXPECT_EQ(f1.meta[i].label, KpLabel::Movable) << i;
    EXPECT_EQ(f1.meta[i].reason, KpReason::OnObject) << i;
    EXPECT_EQ(f1.meta[i].object_id, ids0.at(1003)) << i;
  }
  for (int i : s.idx_cup) {
    EXPECT_EQ(f1.meta[i].label, KpLabel::Dynamic) << i;
    EXPECT_EQ(f1.meta[i].reason, KpReason::NewObject) << i;
    EXPECT_EQ(f1.meta[i].class_id, 47);
  }
  for (int i : s.idx_stuff) {
    EXPECT_EQ(f1.meta[i].label, KpLabel::Static) << i;
    EXPECT_EQ(f1.meta[i].class_id, 199) << i;
  }
  for (int i : s.idx_unk_matched) {
    EXPECT_EQ(f1.meta[i].label, i == s.unk_moved ? KpLabel::Dynamic : KpLabel::Static) << i;
    EXPECT_EQ(f1.meta[i].class_id, -1);
  }
  EXPECT_EQ(f1.meta[s.unk_moved].reason, KpReason::EpipolarOutlier);
  for (int i : s.idx_unk_new) {
    EXPECT_EQ(f1.meta[i].label, KpLabel::Dynamic) << i;
    EXPECT_EQ(f1.meta[i].reason, KpReason::UnmatchedUnknown) << i;
  }
  EXPECT_EQ(st.thing_outliers, static_cast<int>(s.idx_a.size()));
  EXPECT_EQ(st.unknown_outliers, 1);
  EXPECT_EQ(st.unknown_unmatched, static_cast<int>(s.idx_unk_new.size()));
}

TEST(PanopticClassifier, ObjectDecisionAndDeterminism) {
  // One outlier on the static chair: dropped alone per keypoint, the chair stays with object decisions.
  std::vector<std::vector<KeypointMeta>> runs;
  for (const char* mode : {"keypoint", "object", "object"}) {
    PanScene s;
    s.tv.displace(s.idx_b[0], 4.0);
    Frame f0, f1;
    s.frames(f0, f1);
    const Detections d0 = s.labels(0), d1 = s.labels(1);
    auto pc = makeClassifier<PanopticClassifier>("PanopticClassifier", std::string("thing_decision: ") + mode);
    ClassifierContext c;
    c.camera = &s.tv.cam;
    pc->classify(f0, d0, c);
    c.previous = &f0;
    c.previous_detections = &d0;
    pc->classify(f1, d1, c);
    size_t b_dyn = 0, a_dyn = 0;
    for (int i : s.idx_b) b_dyn += f1.meta[i].label == KpLabel::Dynamic;
    for (int i : s.idx_a) a_dyn += f1.meta[i].label == KpLabel::Dynamic;
    EXPECT_EQ(b_dyn, std::string(mode) == "keypoint" ? 1u : 0u) << mode;
    EXPECT_EQ(a_dyn, s.idx_a.size()) << mode;
    runs.push_back(f1.meta);
  }
  ASSERT_EQ(runs[1].size(), runs[2].size());
  for (size_t i = 0; i < runs[1].size(); i++) {
    EXPECT_EQ(runs[1][i].label, runs[2][i].label) << i;
    EXPECT_EQ(runs[1][i].reason, runs[2][i].reason) << i;
    EXPECT_EQ(runs[1][i].object_id, runs[2][i].object_id) << i;
  }
}
