// Dense map (modules/dense): the dynamic mask removes exactly the pixels it
// should, SGBM depth of a known disparity, integration of a known plane at a
// known pose lands in the right voxels, and the ghost rate / accuracy /
// completeness of crafted maps against a small scene.
#include <gtest/gtest.h>

#include <octomap/OcTree.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <filesystem>
#include <random>
#include <set>
#include <tuple>

#include "dslam/dense/dense_eval.h"
#include "dslam/dense/dense_map.h"
#include "dslam/synth/renderer.h"
#include "dslam/synth/scene.h"
#include "ray_update.h"
#include "test_support.h"

using namespace dslam;
using namespace dslam::dense;

namespace {

/** A 64x48 frame with a grey image and the given keypoints and labels. */
Frame frameWith(const std::vector<std::tuple<float, float, KpLabel, KpReason>>& kps) {
  Frame f;
  f.input.index = 7;
  f.gray = cv::Mat(48, 64, CV_8U, cv::Scalar(100));
  f.input.image = f.gray;
  for (const auto& [x, y, l, r] : kps) {
    f.keypoints.emplace_back(x, y, 7.f);
    KeypointMeta m;
    m.label = l;
    m.reason = r;
    f.meta.push_back(m);
  }
  f.keypoints_un = f.keypoints;
  return f;
}

DenseMapParams exactParams() {
  DenseMapParams p;
  p.dilation = 0;
  p.keypoint_radius = 0;
  return p;
}

}  // namespace

// Semantic pixels of the dropped classes, and only those.
TEST(DenseMask, SemanticPixelsOfDroppedClasses) {
  const Frame f = frameWith({});
  Detections d;
  d.semantic = cv::Mat(48, 64, CV_8U, cv::Scalar(255));
  d.semantic(cv::Rect(10, 5, 12, 20)).setTo(1);   // person: 240 px
  d.semantic(cv::Rect(40, 30, 10, 10)).setTo(62);  // chair: kept
  MaskStats st;
  const cv::Mat m = dynamicMask(f, {d}, cv::Mat(), exactParams(), &st);
  EXPECT_EQ(cv::countNonZero(m), 240);
  EXPECT_EQ(cv::countNonZero(m(cv::Rect(10, 5, 12, 20))), 240);
  EXPECT_EQ(st.semantic, 240);
  // A half-size label image (a detector working at lower resolution) is scaled.
  Detections h;
  cv::resize(d.semantic, h.semantic, cv::Size(32, 24), 0, 0, cv::INTER_NEAREST);
  EXPECT_EQ(cv::countNonZero(dynamicMask(f, {h}, cv::Mat(), exactParams())), 240);
  // Chairs too when asked; nothing with mask: false.
  DenseMapParams p = exactParams();
  p.classes = {1, 62};
  EXPECT_EQ(cv::countNonZero(dynamicMask(f, {d}, cv::Mat(), p)), 340);
  p.mask = false;
  EXPECT_EQ(cv::countNonZero(dynamicMask(f, {d}, cv::Mat(), p)), 0);
  // Dilation by 1 px (3x3 cross): the rectangle grows by one pixel on each side, corners excepted.
  p = exactParams();
  p.dilation = 1;
  EXPECT_EQ(cv::countNonZero(dynamicMask(f, {d}, cv::Mat(), p)), 14 * 22 - 4);
}

// A person box without a mask: the pixels at the person's depth (the
// depth-repopulation test), not the wall behind; without depth the whole box.
TEST(DenseMask, BoxPixelsNearTheObjectDepth) {
  const Frame f = frameWith({});
  cv::Mat depth(48, 64, CV_32F, cv::Scalar(4.0f));  // wall at 4 m
  depth(cv::Rect(20, 8, 8, 30)).setTo(1.8f);         // person, 240 px, in the box centre
  depth(cv::Rect(14, 8, 2, 30)).setTo(2.2f);         // arm, 60 px: within 0.5 m of the body
  depth(cv::Rect(17, 40, 3, 2)).setTo(0.f);          // no depth: not the object
  Detections d;
  BoundingBox b;
  b.box = cv::Rect2f(12, 4, 22, 40);  // x 12..34, y 4..44
  b.class_id = 1;
  d.boxes.push_back(b);
  BoundingBox chair = b;  // a box of a class that is not dropped: nothing
  chair.class_id = 62;
  chair.box = cv::Rect2f(40, 4, 20, 20);
  d.boxes.push_back(chair);
  MaskStats st;
  const cv::Mat m = dynamicMask(f, {d}, depth, exactParams(), &st);
  EXPECT_EQ(cv::countNonZero(m), 300);
  EXPECT_EQ(st.boxes, 300);
  EXPECT_EQ(cv::countNonZero(m(cv::Rect(20, 8, 8, 30))), 240);
  EXPECT_EQ(cv::countNonZero(dynamicMask(f, {d}, cv::Mat(), exactParams())), 23 * 41);  // box rounded outwards
  // A detector that also gives a semantic image: the box is not used (the mask is exact).
  d.semantic = cv::Mat(48, 64, CV_8U, cv::Scalar(255));
  EXPECT_EQ(cv::countNonZero(dynamicMask(f, {d}, depth, exactParams())), 0);
}

// Keypoints labelled dynamic: a disk around epipolar outliers (no mask of
// their own), none around keypoints a semantic mask already covers; regions
// the classifiers found moving (EKF) are dropped, static ones kept.
TEST(DenseMask, DynamicKeypointsAndRegionsFoundByClassifiers) {
  Frame f = frameWith({{10, 10, KpLabel::Dynamic, KpReason::EpipolarOutlier},
                       {40, 10, KpLabel::Dynamic, KpReason::SemanticDynamic},
                       {10, 40, KpLabel::Static, KpReason::None}});
  DenseMapParams p = exactParams();
  p.keypoint_radius = 3;
  cv::Mat disk = cv::Mat::zeros(48, 64, CV_8U);
  cv::circle(disk, cv::Point(10, 10), 3, cv::Scalar(255), cv::FILLED);
  MaskStats st;
  cv::Mat m = dynamicMask(f, {}, cv::Mat(), p, &st);
  EXPECT_EQ(cv::countNonZero(m), cv::countNonZero(disk));
  EXPECT_EQ(cv::countNonZero(m ^ disk), 0);
  EXPECT_EQ(st.keypoints, 1);

  // Two chair boxes; the EKF says the keypoints of the first one move.
  Frame g = frameWith({{15, 15, KpLabel::Dynamic, KpReason::ObjectMoving},
                       {16, 18, KpLabel::Dynamic, KpReason::ObjectMoving},
                       {18, 16, KpLabel::Dynamic, KpReason::ObjectMoving},
                       {12, 20, KpLabel::Static, KpReason::None},
                       {45, 15, KpLabel::Movable, KpReason::OnObject},
                       {46, 18, KpLabel::Movable, KpReason::OnObject}});
  Detections d;
  BoundingBox a;
  a.box = cv::Rect2f(10, 10, 10, 12);
  a.class_id = 62;
  BoundingBox b = a;
  b.box = cv::Rect2f(40, 10, 10, 12);
  d.boxes = {a, b};
  const cv::Mat depth(48, 64, CV_32F, cv::Scalar(2.0f));
  m = dynamicMask(g, {d}, depth, exactParams());
  EXPECT_EQ(cv::countNonZero(m), 11 * 13);  // the first box (rounded outwards), all at the chair's depth
  EXPECT_EQ(cv::countNonZero(m(cv::Rect(40, 10, 11, 13))), 0);
  p = exactParams();
  p.follow_classifiers = false;
  EXPECT_EQ(cv::countNonZero(dynamicMask(g, {d}, depth, p)), 0);
  p.min_dynamic_keypoints = 4;  // 3 dynamic keypoints are not enough then
  p.follow_classifiers = true;
  EXPECT_EQ(cv::countNonZero(dynamicMask(g, {d}, depth, p)), 0);

  // Panoptic: an unknown (void-class) segment whose keypoints are dynamic is
  // dropped, a stuff segment (wall) never, a person segment always.
  Detections pd;
  pd.panoptic = cv::Mat(48, 64, CV_32S, cv::Scalar(199));  // wall
  pd.panoptic(cv::Rect(10, 10, 12, 12)).setTo(5);           // unknown object
  pd.panoptic(cv::Rect(50, 30, 6, 10)).setTo(1001);         // person
  pd.segments = {{199, 199, SegmentKind::Stuff, -1, 0, {}, 1.f},
                 {5, 0, SegmentKind::Unknown, -1, 144, {}, 1.f},
                 {1001, 1, SegmentKind::Thing, 1, 60, {}, 1.f}};
  Frame h = frameWith({{12, 12, KpLabel::Dynamic, KpReason::EpipolarOutlier},
                       {14, 14, KpLabel::Dynamic, KpReason::EpipolarOutlier},
                       {16, 16, KpLabel::Dynamic, KpReason::EpipolarOutlier},
                       {30, 30, KpLabel::Dynamic, KpReason::EpipolarOutlier},
                       {32, 32, KpLabel::Dynamic, KpReason::EpipolarOutlier},
                       {34, 34, KpLabel::Dynamic, KpReason::EpipolarOutlier}});
  EXPECT_EQ(cv::countNonZero(dynamicMask(h, {pd}, cv::Mat(), exactParams())), 144 + 60);
}

// SGBM on a rectified pair of a fronto-parallel textured plane with an 8 px
// disparity: depth bf / 8 wherever it matches.
TEST(DenseDepth, StereoDepthOfAKnownDisparity) {
  std::mt19937 rng(3);
  cv::Mat tex(120, 200, CV_8U);
  for (int y = 0; y < tex.rows; y++)
    for (int x = 0; x < tex.cols; x++) tex.at<uint8_t>(y, x) = static_cast<uint8_t>(rng() % 256);
  cv::GaussianBlur(tex, tex, cv::Size(3, 3), 0.8);
  const cv::Mat left = tex(cv::Rect(20, 0, 160, 120)).clone();
  const cv::Mat right = tex(cv::Rect(28, 0, 160, 120)).clone();  // x_r = x_l - 8
  DenseMapParams p;
  p.num_disparities = 32;
  const double bf = 40.0;
  const cv::Mat z = stereoDepth(left, right, bf, p);
  std::vector<float> v;
  for (int y = 0; y < z.rows; y++)
    for (int x = 0; x < z.cols; x++)
      if (z.at<float>(y, x) > 0) v.push_back(z.at<float>(y, x));
  ASSERT_GT(v.size(), 0.6 * (160 - 32) * 120);  // the first 32 columns have no match
  std::sort(v.begin(), v.end());
  EXPECT_NEAR(v[v.size() / 2], bf / 8, 0.01 * bf / 8);
  EXPECT_NEAR(v[v.size() / 20], bf / 8, 0.03 * bf / 8);
  EXPECT_NEAR(v[v.size() * 19 / 20], bf / 8, 0.03 * bf / 8);
}

// The map integration's ray update (ray_update.h: a bit cube instead of
// OctoMap's hash sets) gives exactly OctoMap's computeDiscreteUpdate() sets:
// random clouds around random sensor positions, points beyond max_range (rays
// cut, clearing only) and behind the sensor, with the cube (5 cm voxels, 4 m)
// and with the hash-set fallback (1 cm voxels, 5 m: the cube would be 128 MB).
TEST(DenseIntegration, RayUpdateEqualsOctoMapsDiscreteUpdate) {
  auto keys = [](const auto& c) {
    std::set<std::tuple<int, int, int>> s;
    for (const octomap::OcTreeKey& k : c) s.emplace(k[0], k[1], k[2]);
    return s;
  };
  for (const auto& [res, range, cube] : {std::tuple{0.05, 4.0, true}, std::tuple{0.01, 5.0, false}}) {
    const octomap::OcTree tree(res);
    const int half = static_cast<int>(std::ceil(range / res)) + 2;
    VoxelKeySet seen(half), occupied(half);
    EXPECT_EQ(seen.usesCube(), cube);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-1.f, 1.f);
    size_t total_free = 0, total_occupied = 0;
    const int points = cube ? 3000 : 500;  // 1 cm rays are 500 voxels long
    for (int trial = 0; trial < 3; trial++) {
      const octomap::point3d origin(3 * u(rng), 3 * u(rng), u(rng));
      octomap::Pointcloud cloud;
      for (int i = 0; i < points; i++) {
        // a noisy wall 1-7 m in front (part of it beyond max_range), and a few points behind
        const float depth = i % 10 == 0 ? -2.f : 4.f + 3.f * u(rng);
        cloud.push_back(origin.x() + 2 * u(rng), origin.y() + depth, origin.z() + 1.5f * u(rng));
      }
      octomap::KeySet ref_free, ref_occupied;
      octomap::OcTree(res).computeDiscreteUpdate(cloud, origin, ref_free, ref_occupied, range);
      RayUpdate r;
      discreteRayUpdate(tree, cloud, origin, range, seen, occupied, r);
      EXPECT_EQ(r.free.size(), keys(r.free).size()) << "each free key once";
      EXPECT_EQ(r.occupied.size(), keys(r.occupied).size()) << "each occupied key once";
      EXPECT_EQ(keys(r.free), keys(ref_free)) << "resolution " << res << ", trial " << trial;
      EXPECT_EQ(keys(r.occupied), keys(ref_occupied)) << "resolution " << res << ", trial " << trial;
      total_free += r.free.size();
      total_occupied += r.occupied.size();
    }
    EXPECT_GT(total_occupied, 500u);  // the check compares real sets
    EXPECT_GT(total_free, 10 * total_occupied);
  }
}

// An RGB-D keyframe seeing the plane z_c = 2 m, at a pose turning camera z
// into world x: every occupied voxel is in the slab x in [2.10, 2.15) and
// they are exactly the voxels of the back-projected pixels; the masked
// person pixels leave their voxels empty.
TEST(DenseIntegration, KnownPlaneAtAKnownPose) {
  CameraModel cam;
  cam.sensor = SensorType::RGBD;
  cam.left = PinholeCamera{80, 60, 80, 80, 39.5, 29.5, {0, 0, 0, 0, 0}};
  DenseMapParams p;
  p.pixel_step = 1;
  p.dilation = 0;
  p.keypoint_radius = 0;
  p.colour = "image";
  DenseMapper dm(cam, cam, p, /*threaded=*/true);
  Frame f;
  f.input.index = 3;
  f.input.depth = cv::Mat(60, 80, CV_32F, cv::Scalar(2.0f));
  f.input.image = cv::Mat(60, 80, CV_8UC3, cv::Scalar(10, 20, 200));  // BGR: red
  f.gray = cv::Mat(60, 80, CV_8U, cv::Scalar(90));
  Detections d;
  d.semantic = cv::Mat(60, 80, CV_8U, cv::Scalar(255));
  d.semantic(cv::Rect(0, 0, 20, 60)).setTo(1);  // a person on the left quarter of the image
  dm.addKeyFrame(f, {d});
  Frame f2 = f;  // the same view again from the next keyframe: a voxel needs two hits
  f2.input.index = 4;
  dm.addKeyFrame(f2, {d});
  // camera z -> world x, camera x -> world -y, camera y -> world -z; camera at (0.12, 0.3, 1.0)
  Eigen::Matrix3d R;
  R << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  const SE3 T_wc(R, Eigen::Vector3d(0.12, 0.3, 1.0));
  dm.integrate({{3, T_wc}});  // one keyframe: hit once, not occupied (occupancy_threshold 0.65, prob_hit 0.6)
  EXPECT_EQ(dm.stats().keyframes_integrated, 1u);
  EXPECT_EQ(dm.stats().keyframes_without_pose, 1u);
  EXPECT_TRUE(dm.occupiedVoxels().empty());
  dm.integrate({{3, T_wc}, {4, T_wc}});
  EXPECT_EQ(dm.stats().keyframes_integrated, 2u);
  EXPECT_EQ(dm.stats().points_inserted, 2u * 60u * 60u);
  EXPECT_EQ(dm.stats().points_masked, 2u * 60u * 20u);
  std::set<std::tuple<int, int, int>> expected;
  const double res = p.resolution;
  for (int v = 0; v < 60; v++)
    for (int u = 20; u < 80; u++) {
      const Eigen::Vector3d pc((u - 39.5) / 80 * 2.0, (v - 29.5) / 80 * 2.0, 2.0);
      const Eigen::Vector3d pw = T_wc * pc;
      expected.insert({static_cast<int>(std::floor(pw.x() / res)), static_cast<int>(std::floor(pw.y() / res)),
                       static_cast<int>(std::floor(pw.z() / res))});
    }
  const std::vector<Voxel> vox = dm.occupiedVoxels();
  std::set<std::tuple<int, int, int>> got;
  for (const Voxel& v : vox) {
    EXPECT_NEAR(v.c.x(), 2.125, 1e-4);
    EXPECT_EQ(v.r, 200);  // image colour, RGB
    EXPECT_EQ(v.b, 10);
    got.insert({static_cast<int>(std::floor(v.c.x() / res)), static_cast<int>(std::floor(v.c.y() / res)),
                static_cast<int>(std::floor(v.c.z() / res))});
  }
  EXPECT_EQ(got, expected);
  // The person's side of the plane (world y > 0.3 + 0.5 at the image's left) stays empty.
  for (const Voxel& v : vox) EXPECT_LT(v.c.y(), 0.3 + (39.5 - 20) / 80 * 2.0 + res);
  // The same keyframe at another pose: the map follows it (re-integration).
  const SE3 moved(R, Eigen::Vector3d(1.12, 0.3, 1.0));
  dm.integrate({{3, moved}, {4, moved}});
  for (const Voxel& v : dm.occupiedVoxels()) EXPECT_NEAR(v.c.x(), 3.125, 1e-4);
  // Without a pose the keyframe is left out.
  dm.integrate({});
  EXPECT_EQ(dm.stats().keyframes_without_pose, 2u);
  EXPECT_TRUE(dm.occupiedVoxels().empty());
}

// A keyframe with an empty depth image is skipped (warning), not stored; a
// dataset without depth or stereo is refused naming the pipeline key.
TEST(DenseIntegration, EmptyDepthAndMissingInput) {
  CameraModel cam;
  cam.sensor = SensorType::RGBD;
  cam.left = PinholeCamera{80, 60, 80, 80, 39.5, 29.5, {0, 0, 0, 0, 0}};
  DenseMapper dm(cam, cam, DenseMapParams{}, /*threaded=*/false);
  Frame f;
  f.input.index = 4;
  f.input.depth = cv::Mat::zeros(60, 80, CV_32F);
  f.gray = cv::Mat(60, 80, CV_8U, cv::Scalar(90));
  f.input.image = f.gray;
  dm.addKeyFrame(f, {});
  EXPECT_EQ(dm.stats().keyframes_received, 1u);
  EXPECT_EQ(dm.stats().keyframes_empty_depth, 1u);
  EXPECT_TRUE(dm.keyframes().empty());
  SensorFrame first;
  first.index = 0;
  first.image = f.gray;
  first.image_path = "rgb/0.png";
  try {
    dm.checkInput(first);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("outputs.dense_map"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("rgb/0.png"), std::string::npos) << e.what();
  }
  first.depth = f.input.depth;
  EXPECT_NO_THROW(dm.checkInput(first));
  CameraModel mono = cam;
  mono.sensor = SensorType::Monocular;
  EXPECT_THROW(DenseMapper(mono, mono, DenseMapParams{}, false), ConfigError);
}

namespace {

// A 6 x 5 m room, a static crate, a person walking along y = 0 from x = -1.5
// to 1.5 and back; the camera looks along +x.
const char* kScene = R"(
name: dense_eval
frames: 120
seed: 5
resolution: [160, 120]
noise: {enabled: false}
room: {size: [6, 5, 2.8]}
camera:
  trajectory: {type: static, center: [-2.5, 1.0, 1.4], look_at: [3, 0.5, 1.0]}
objects:
  - {name: crate, type: box, class: suitcase, size: [0.6, 0.8, 1.0], position: [1.5, 1.5, 0]}
people:
  - {name: walker, action: walk, path: {waypoints: [[-1.5, 0.0], [1.5, 0.0]], speed: 1.0, mode: pingpong}}
)";

}  // namespace

// Crafted map: 40 voxels on the floor and the crate (static), 6 in the
// walker's path at chest height (ghosts), 3 in the air where nothing ever
// was (noise): ghost rate 6 / 49; distances known.
TEST(DenseEval, GhostRateAccuracyOfACraftedMap) {
  const synth::Scenario s = synth::parseScenario(kScene);
  const synth::SceneModel scene(s);
  DenseMapFile m;
  m.resolution = 0.05;
  m.max_range = 4.0;
  m.keyframes.push_back({0, 0.0, scene.cameraPose(0)});  // map frame = scene frame
  for (int i = 0; i < 30; i++) m.occupied.emplace_back(-2.0 + 0.05 * i + 0.025, -1.525, 0.025);  // floor
  for (int i = 0; i < 10; i++) m.occupied.emplace_back(1.5 + 0.025, 1.5 - 0.2 + 0.05 * i, 1.0 + 0.025);  // crate top
  for (double x : {-1.0, -0.5, 0.0, 0.5, 1.0, 1.2}) m.occupied.emplace_back(x, 0.0, 1.2);  // walker's chest
  for (double x : {-1.0, 0.0, 1.0}) m.occupied.emplace_back(x, -1.5, 2.0);  // empty air
  const DenseEvalResult r = evaluateDense(m, s);
  EXPECT_EQ(r.occupied, 49u);
  EXPECT_EQ(r.near_static, 40u);
  EXPECT_EQ(r.ghost, 6u);
  EXPECT_EQ(r.other, 3u);
  EXPECT_NEAR(r.ghost_rate, 6.0 / 49.0, 1e-12);
  EXPECT_EQ(r.movers, 1u);
  EXPECT_NEAR(r.accuracy_median, 0.025, 1e-9);  // 40 of 49 at 2.5 cm from the floor / crate top
  EXPECT_NEAR(r.alignment_rmse, 0.0, 1e-9);
  // The same map in another frame (the SLAM world is the first camera): the
  // keyframe poses carry the alignment, the numbers do not change.
  const SE3 T_map_scene = scene.cameraPose(0).inverse();
  DenseMapFile moved = m;
  for (auto& c : moved.occupied) c = T_map_scene * c;
  moved.keyframes[0].T_wc = T_map_scene * m.keyframes[0].T_wc;
  const DenseEvalResult r2 = evaluateDense(moved, s);
  EXPECT_EQ(r2.ghost, 6u);
  EXPECT_EQ(r2.near_static, 40u);
  EXPECT_NEAR(r2.accuracy_median, 0.025, 1e-9);
}

// Completeness: a map made of the voxels of every static surface point the
// keyframe sees covers it all; without the voxels of the far wall the
// fraction drops by the far wall's share.
TEST(DenseEval, CompletenessOfACraftedMap) {
  const synth::Scenario s = synth::parseScenario(kScene);
  synth::RenderOptions ro;
  ro.right = false;
  ro.labels = false;
  const synth::Renderer R(s, ro);
  const synth::FrameRender fr = R.render(0);
  DenseMapFile m;
  m.resolution = 0.05;
  m.max_range = 10.0;
  m.keyframes.push_back({0, 0.0, fr.T_wc});
  std::set<std::tuple<int, int, int>> cells;
  const auto& K = s.intrinsics;
  for (int v = 0; v < fr.depth_m.rows; v++)
    for (int u = 0; u < fr.depth_m.cols; u++) {
      const double z = fr.depth_m.at<float>(v, u);
      if (z <= 0) continue;
      const Eigen::Vector3d pw = fr.T_wc * Eigen::Vector3d((u - K.cx) * z / K.fx, (v - K.cy) * z / K.fy, z);
      if (pw.x() > 2.99) continue;  // not the far wall (x = 3)
      cells.insert({static_cast<int>(std::floor(pw.x() / 0.05)), static_cast<int>(std::floor(pw.y() / 0.05)),
                    static_cast<int>(std::floor(pw.z() / 0.05))});
    }
  for (const auto& [x, y, z] : cells) m.occupied.emplace_back((x + 0.5) * 0.05, (y + 0.5) * 0.05, (z + 0.5) * 0.05);
  const DenseEvalResult r = evaluateDense(m, s);
  EXPECT_GT(r.surface_samples, 1000u);
  EXPECT_LT(r.completeness, 0.9);  // the far wall is a large part of the view
  EXPECT_GT(r.completeness, 0.2);
  const double without_wall = r.completeness;
  for (int y = -50; y < 50; y++)
    for (int z = 0; z < 56; z++) m.occupied.emplace_back(3.0 - 0.025, (y + 0.5) * 0.05, (z + 0.5) * 0.05);
  const DenseEvalResult full = evaluateDense(m, s);
  EXPECT_GE(full.completeness, 0.995);
  std::cout << "completeness without the far wall " << without_wall << ", with it " << full.completeness << " of "
            << full.surface_samples << " samples\n";
}

// loadDenseMap checks map.bt against dense.json: a resolution outside 0.1 mm-100 m
// (1e-300 printed a 300-digit median), two files of different runs, a bad max_range.
TEST(DenseEval, LoadRefusesInconsistentFiles) {
  const std::string d = test::tempDir("dense_files");
  auto write = [&](double res, const std::string& json) {
    octomap::OcTree t(res);
    t.updateNode(octomap::point3d(0.1f, 0.2f, 0.3f), true);
    t.writeBinary(d + "/map.bt");
    test::writeFile(d + "/dense.json", json);
  };
  auto errorOf = [&] {
    try {
      loadDenseMap(d + "/map.bt");
    } catch (const DataError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string ok = R"({"resolution": 0.05, "max_range": 4.0, "keyframes": []})";
  write(0.05, ok);
  EXPECT_EQ(errorOf(), "");
  write(1.0, ok);
  EXPECT_NE(errorOf().find("'resolution' 0.05 does not match"), std::string::npos) << errorOf();
  write(1e-300, ok);
  EXPECT_NE(errorOf().find("OctoMap resolution 1e-300 m is outside"), std::string::npos) << errorOf();
  write(0.05, R"({"resolution": 0.05, "max_range": -4, "keyframes": []})");
  EXPECT_NE(errorOf().find("'max_range' must be a number > 0"), std::string::npos) << errorOf();
  write(0.05, R"({"resolution": 0.05, "max_range": 4})");
  EXPECT_NE(errorOf().find("dense.json: key 'keyframes' not found"), std::string::npos) << errorOf();
}

// A map made on another scene, or a --scenario of another scene, is refused
// instead of scored against geometry it was never made in.
TEST(DenseEval, RefusesAMapOrAScenarioOfAnotherScene) {
  const synth::Scenario s = synth::parseScenario(kScene);
  const synth::SceneModel scene(s);
  DenseMapFile m;
  m.keyframes.push_back({0, 0.0, scene.cameraPose(0)});
  m.occupied.emplace_back(0.0, -1.525, 0.025);
  auto errorOf = [&](const DenseMapFile& map) {
    try {
      evaluateDense(map, s);
    } catch (const DataError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(errorOf(m), "");  // no dataset recorded (dense.json of older runs): evaluated
  m.dataset_path = "/data/dense_eval";
  m.dataset_scenario = "dense_eval";
  m.dataset_seed = 5;
  m.dataset_frames = 120;
  EXPECT_EQ(errorOf(m), "");
  for (const auto& [scenario, seed, frames] : {std::tuple{"shift", 5, 120}, {"dense_eval", 6, 120}, {"dense_eval", 5, 60}}) {
    DenseMapFile other = m;
    other.dataset_scenario = scenario;
    other.dataset_seed = static_cast<uint64_t>(seed);
    other.dataset_frames = frames;
    EXPECT_EQ(errorOf(other), "the dense map was made on the scene /data/dense_eval (scenario '" +
                                  std::string(scenario) + "', seed " + std::to_string(seed) + ", " +
                                  std::to_string(frames) +
                                  " frames), not on this one (scenario 'dense_eval', seed 5, 120 frames)");
  }

  // sceneScenario: the scenario file must be the one the scene was rendered from.
  const std::string d = test::tempDir("dense_scenario");
  test::writeFile(d + "/dense_eval.yaml", kScene);
  std::string other = kScene;
  other.replace(other.find("name: dense_eval"), 16, "name: other_room");
  test::writeFile(d + "/other.yaml", other);
  std::string renamed = kScene;
  renamed.replace(renamed.find("name: crate"), 11, "name: chest");
  test::writeFile(d + "/renamed.yaml", renamed);
  std::filesystem::create_directories(d + "/scene");
  test::writeFile(d + "/scene/objects.json",
                  R"({"scenario": "dense_eval", "source": "../dense_eval.yaml", "seed": 5, "frames": 120,
                      "objects": [{"name": "crate"}], "people": [{"name": "walker"}]})");
  EXPECT_EQ(sceneScenario(d + "/scene").name, "dense_eval");
  auto scenarioError = [&](const std::string& file) {
    try {
      sceneScenario(d + "/scene", file);
    } catch (const DataError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(scenarioError(d + "/dense_eval.yaml"), "");
  EXPECT_EQ(scenarioError(d + "/other.yaml"), d + "/other.yaml: scenario 'other_room' is not the scene " + d +
                                                  "/scene's: the scene was rendered from scenario 'dense_eval'");
  EXPECT_NE(scenarioError(d + "/renamed.yaml").find("its objects differ from the scene's"), std::string::npos)
      << scenarioError(d + "/renamed.yaml");
}

// Values the specs cannot check name their parameter (Params::fail).
TEST(DenseMapParams, ValuesTheSpecsCannotCheckNameTheirParameter) {
  auto message = [](const std::string& yaml) {
    try {
      DenseMapParams::fromParams(Params::resolve(DenseMapParams::specs(), yaml));
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message("{classes: [1, 300]}"),
            "parameter 'classes': 300 is not a COCO category id (person = 1, see dslam/core/coco.h)");
  EXPECT_EQ(message("{num_disparities: 40}"), "parameter 'num_disparities': 40 is not a multiple of 16");
  EXPECT_EQ(message("{block_size: 4}"), "parameter 'block_size': 4 is not odd");
  EXPECT_EQ(message("{min_range: 5, max_range: 4}"), "parameter 'min_range': must be smaller than max_range");
  EXPECT_EQ(message("{}"), "no error");
}
