// Renderer: exact geometry against analytic projection, labels, sensor model,
// stereo, thread-count independence, scenario properties.
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <set>

#include "dslam/synth/renderer.h"
#include "dslam/synth/scenario.h"
#include "test_support.h"

using namespace dslam::synth;
using dslam::SE3;

namespace {

const char* kScene = R"(
name: geometry
frames: 30
seed: 5
resolution: [320, 240]
noise: {enabled: false}
room: {size: [6, 5, 2.8]}
camera:
  trajectory: {type: xyz, center: [-2, 0.2, 1.4], look_at: [3, 0, 1.0], amplitude: 0.2, period: 4}
objects:
  - {name: crate, type: box, class: suitcase, size: [0.6, 0.8, 1.0], position: [1, -0.5, 0], yaw: 20}
)";

Scenario scenario(const std::string& name, int w, int h, int frames = 0, bool noise = false) {
  ScenarioOverrides ov;
  ov.width = w;
  ov.height = h;
  ov.frames = frames;
  ov.noise = noise;
  return loadScenario(dslam::test::source("config/scenarios/" + name + ".yaml"), ov);
}

/** Render options without the right image. */
RenderOptions leftOnly() {
  RenderOptions ro;
  ro.right = false;
  return ro;
}

struct PinholeCameraRef {
  double fx, fy, cx, cy;
};
/** Depth (camera z) where the ray of pixel (x, y) meets the plane n.p = c. */
double planeDepth(const PinholeCameraRef& K, const SE3& T, int x, int y, const Vec3& n, double c) {
  const Vec3 d = T.rotation() * Vec3((x - K.cx) / K.fx, (y - K.cy) / K.fy, 1.0);
  return (c - n.dot(T.translation())) / n.dot(d);
}
}  // namespace

// Known 3D surface points (wall, floor, box face) projected with the
// ground-truth pose and intrinsics land on pixels of that surface whose
// depth is the analytic ray/plane depth to within one depth unit.
TEST(SynthRender, ProjectionOfKnownPointsMatchesDepth) {
  const Scenario s = parseScenario(kScene);
  Renderer r(s, leftOnly());
  const PinholeCameraRef K{s.intrinsics.fx, s.intrinsics.fy, s.intrinsics.cx, s.intrinsics.cy};
  const int crate = s.objects[0].instance_id;
  const double yaw = 20 * M_PI / 180;
  const Eigen::Matrix3d Rc = Eigen::AngleAxisd(yaw, Vec3::UnitZ()).toRotationMatrix();
  int checked_wall = 0, checked_floor = 0, checked_box = 0;
  for (int f : {0, 7, 19, 29}) {
    const FrameRender fr = r.render(f);
    const SE3 T = fr.T_wc;
    auto check = [&](const Vec3& P, const Vec3& n, double c, int want_instance, int want_class, int& count) {
      const Vec3 pc = T.inverse() * P;
      if (pc.z() <= 0.1) return;
      const int x = static_cast<int>(std::lround(K.fx * pc.x() / pc.z() + K.cx));
      const int y = static_cast<int>(std::lround(K.fy * pc.y() / pc.z() + K.cy));
      if (x < 0 || y < 0 || x >= s.width || y >= s.height) return;
      const int inst = fr.instance.at<int>(y, x);
      if (inst != want_instance) return;  // occluded by something else
      // Away from silhouettes (a 1-pixel shift would change the surface).
      for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++) {
          const int xx = std::clamp(x + dx, 0, s.width - 1), yy = std::clamp(y + dy, 0, s.height - 1);
          if (fr.instance.at<int>(yy, xx) != want_instance || fr.semantic.at<uchar>(yy, xx) != want_class) return;
        }
      EXPECT_EQ(fr.semantic.at<uchar>(y, x), want_class);
      const double z = planeDepth(K, T, x, y, n, c);
      const double raw = fr.depth.at<uint16_t>(y, x);
      EXPECT_NEAR(raw, z * 5000.0, 1.0) << "frame " << f << " pixel " << x << "," << y;
      EXPECT_NEAR(fr.depth_m.at<float>(y, x), z, 1e-4);
      // The point itself is within a pixel footprint of the pixel-centre ray.
      EXPECT_NEAR(pc.z(), z, 0.02 * z);
      count++;
    };
    for (double yy = -2.3; yy <= 2.3; yy += 0.23)
      for (double zz = 0.2; zz <= 2.6; zz += 0.2) check(Vec3(3.0, yy, zz), Vec3(1, 0, 0), 3.0, 0, 199, checked_wall);
    for (double xx = -1.2; xx <= 2.8; xx += 0.2)
      for (double yy = -2.3; yy <= 2.3; yy += 0.25) check(Vec3(xx, yy, 0), Vec3(0, 0, 1), 0.0, 0, 190, checked_floor);
    // The two crate faces that face the camera (local -x and +y).
    const Vec3 c0(1, -0.5, 0);
    for (double a = -0.35; a <= 0.35; a += 0.07)
      for (double b = 0.05; b <= 0.95; b += 0.1) {
        const Vec3 nf = Rc * Vec3(-1, 0, 0), nl = Rc * Vec3(0, 1, 0);
        const Vec3 pf = c0 + Rc * Vec3(-0.3, a, b), pl = c0 + Rc * Vec3(a * 0.8, 0.4, b);
        ASSERT_GT(nf.dot(T.translation() - pf), 0);
        ASSERT_GT(nl.dot(T.translation() - pl), 0);
        check(pf, nf, nf.dot(pf), crate, 33, checked_box);
        check(pl, nl, nl.dot(pl), crate, 33, checked_box);
      }
  }
  EXPECT_GT(checked_wall, 200);
  EXPECT_GT(checked_floor, 100);
  EXPECT_GT(checked_box, 40);
}

// Every pixel labelled "person" back-projects (exact depth, GT pose) onto the
// surface of that person's body.
TEST(SynthRender, PersonPixelsLieOnPersonSurfaces) {
  const Scenario s = scenario("walking_xyz", 320, 240, 0, false);
  Renderer r(s, leftOnly());
  const auto& K = s.intrinsics;
  size_t person_px = 0;
  for (int f : {20, 60, 100, 140}) {
    const FrameRender fr = r.render(f);
    double worst = 0;
    for (int y = 0; y < s.height; y += 2)
      for (int x = 0; x < s.width; x += 2) {
        if (fr.semantic.at<uchar>(y, x) != 1) continue;
        const int inst = fr.instance.at<int>(y, x);
        ASSERT_TRUE(r.scene().instances().at(static_cast<size_t>(inst)).is_person);
        EXPECT_EQ(fr.panoptic.at<int>(y, x), 1000 + inst);
        const Vec3 pw = fr.T_wc * K.unproject(x, y, fr.depth_m.at<float>(y, x));
        worst = std::max(worst, std::abs(r.scene().distanceToInstance(f, inst, pw)));
        person_px++;
      }
    EXPECT_LT(worst, 0.002) << "frame " << f;
  }
  EXPECT_GT(person_px, 500u);
}

// Panoptic ids, semantic classes, segments and boxes agree with each other.
TEST(SynthRender, LabelsAreConsistent) {
  const Scenario s = scenario("walking_static", 320, 240, 0, true);
  Renderer r(s, leftOnly());
  const FrameRender fr = r.render(45);
  std::map<int, int> area;
  for (int y = 0; y < s.height; y++)
    for (int x = 0; x < s.width; x++) {
      const int pid = fr.panoptic.at<int>(y, x);
      const int sem = fr.semantic.at<uchar>(y, x);
      if (pid >= 1000) {
        EXPECT_EQ(fr.instance.at<int>(y, x), pid - 1000);
      } else if (pid > 0) {
        EXPECT_EQ(pid, sem);  // stuff: segment id = category
      } else {
        EXPECT_EQ(sem, 255);
      }
      area[pid]++;
    }
  int total = 0;
  std::set<int> ids;
  for (const auto& sg : fr.segments) {
    EXPECT_TRUE(ids.insert(sg.id).second);
    EXPECT_EQ(sg.area, area[sg.id]);
    EXPECT_EQ(sg.category_id, sg.id < 1000 ? sg.id : r.scene().instances()[static_cast<size_t>(sg.id - 1000)].category_id);
    total += sg.area;
  }
  EXPECT_EQ(total + area[0], s.width * s.height);
  // Walls, floor are stuff segments.
  EXPECT_TRUE(ids.count(199));
  EXPECT_TRUE(ids.count(190));
  // Every box encloses all pixels of its instance.
  ASSERT_FALSE(fr.boxes.empty());
  for (const auto& b : fr.boxes) {
    EXPECT_FLOAT_EQ(b.score, 1.0f);
    int n = 0;
    for (int y = 0; y < s.height; y++)
      for (int x = 0; x < s.width; x++)
        if (fr.instance.at<int>(y, x) == b.instance_id) {
          n++;
          EXPECT_TRUE(b.box.contains(cv::Point2f(x + 0.5f, y + 0.5f)));
        }
    EXPECT_EQ(n, b.area);
  }
}

// Objects whose class is outside the label set are panoptic void, semantic
// 255 and have no box.
TEST(SynthRender, UnlabelledObjectsAreVoid) {
  const Scenario s = scenario("unknown_object", 160, 120);
  Renderer r(s, leftOnly());
  const int balloon = s.findObject("balloon")->instance_id, box = s.findObject("moving_box")->instance_id;
  int seen_balloon = 0, seen_box = 0;
  for (int f = 0; f < s.frames; f += 30) {
    const FrameRender fr = r.render(f);
    for (int y = 0; y < s.height; y++)
      for (int x = 0; x < s.width; x++) {
        const int inst = fr.instance.at<int>(y, x);
        if (inst != balloon && inst != box) continue;
        (inst == balloon ? seen_balloon : seen_box)++;
        EXPECT_EQ(fr.panoptic.at<int>(y, x), 0);
        EXPECT_EQ(fr.semantic.at<uchar>(y, x), 255);
      }
    for (const auto& b : fr.boxes) {
      EXPECT_NE(b.instance_id, balloon);
      EXPECT_NE(b.instance_id, box);
    }
  }
  EXPECT_GT(seen_balloon, 100);
  EXPECT_GT(seen_box, 100);
}

// Kinect-like depth: sigma = 1.425e-3 z^2, 1/5000 quantisation, invalid
// beyond the range.
TEST(SynthRender, DepthNoiseFollowsKinectModel) {
  const Scenario s = parseScenario(std::string(kScene) + "\n", "geometry.yaml");
  Scenario sn = s;
  sn.noise.enabled = true;
  sn.noise.depth_max = 4.0;
  Renderer r(sn, leftOnly());
  const FrameRender fr = r.render(3);
  double sum2 = 0, model2 = 0;
  int n = 0, beyond = 0, beyond_zero = 0, near_valid = 0, near_total = 0;
  for (int y = 0; y < s.height; y++)
    for (int x = 0; x < s.width; x++) {
      const double z = fr.depth_m.at<float>(y, x);
      const double d = fr.depth.at<uint16_t>(y, x) / 5000.0;
      if (z > 4.0) {
        beyond++;
        beyond_zero += d == 0;
        continue;
      }
      near_total++;
      if (d == 0) continue;
      near_valid++;
      if (z > 2.5 && z < 3.8) {
        sum2 += (d - z) * (d - z);
        model2 += std::pow(1.425e-3 * z * z, 2);
        n++;
      }
    }
  ASSERT_GT(n, 1000);
  const double ratio = std::sqrt(sum2 / model2);
  EXPECT_NEAR(ratio, 1.0, 0.1);
  EXPECT_GT(beyond, 1000);
  EXPECT_EQ(beyond_zero, beyond);
  // Depth-edge dropout removes a few pixels only.
  EXPECT_GT(near_valid, 0.95 * near_total);
  EXPECT_LT(near_valid, near_total);
}

// The right image is the left one shifted by the disparity fx * b / z.
TEST(SynthRender, RightImageIsRectifiedStereo) {
  const Scenario s = parseScenario(kScene);
  Renderer r(s);
  const FrameRender fr = r.render(10);
  ASSERT_FALSE(fr.right.empty());
  cv::Mat gl, gr;
  cv::cvtColor(fr.rgb, gl, cv::COLOR_BGR2GRAY);
  cv::cvtColor(fr.right, gr, cv::COLOR_BGR2GRAY);
  double diff_disp = 0, diff_none = 0;
  int n = 0;
  const double bf = s.intrinsics.fx * s.baseline;
  for (int y = 10; y < s.height - 10; y += 2)
    for (int x = 40; x < s.width - 10; x += 2) {
      const double z = fr.depth_m.at<float>(y, x);
      const int xr = static_cast<int>(std::lround(x - bf / z));
      if (xr < 0) continue;
      diff_disp += std::abs(gl.at<uchar>(y, x) - gr.at<uchar>(y, xr));
      diff_none += std::abs(gl.at<uchar>(y, x) - gr.at<uchar>(y, x));
      n++;
    }
  diff_disp /= n;
  diff_none /= n;
  EXPECT_LT(diff_disp, 6.0);
  EXPECT_GT(diff_none, 2 * diff_disp);
}

// Output does not depend on the number of render threads.
TEST(SynthRender, ThreadCountDoesNotChangeOutput) {
  const Scenario s = scenario("walking_xyz", 200, 150, 0, true);
  RenderOptions one, two;
  one.threads = 1;
  two.threads = 3;
  Renderer r1(s, one), r2(s, two);
  const FrameRender a = r1.render(33), b = r2.render(33);
  auto same = [](const cv::Mat& x, const cv::Mat& y) {
    return x.size() == y.size() && x.type() == y.type() && cv::countNonZero(cv::Mat(x != y).reshape(1)) == 0;
  };
  EXPECT_TRUE(same(a.rgb, b.rgb));
  EXPECT_TRUE(same(a.right, b.right));
  EXPECT_TRUE(same(a.depth, b.depth));
  EXPECT_TRUE(same(a.semantic, b.semantic));
  EXPECT_TRUE(same(a.panoptic, b.panoptic));
  EXPECT_EQ(a.boxes.size(), b.boxes.size());
}

// close_person: the person covers more than 60% of the image for a while.
TEST(SynthRender, ClosePersonCoversMostOfTheImage) {
  const Scenario s = scenario("close_person", 160, 120);
  Renderer r(s, leftOnly());
  int frames_over = 0;
  double best = 0;
  for (int f = 180; f <= 280; f += 5) {
    const FrameRender fr = r.render(f);
    const double frac = cv::countNonZero(fr.semantic == 1) / double(s.width * s.height);
    best = std::max(best, frac);
    frames_over += frac > 0.6;
  }
  EXPECT_GT(best, 0.6);
  EXPECT_GE(frames_over, 4);  // >= 4 samples 5 frames apart: well over half a second
}

// Dynamic scenarios keep enough static background in view at all times.
TEST(SynthRender, StaticBackgroundStaysVisible) {
  for (const char* n : {"walking_xyz", "walking_static", "walking_rpy", "walking_halfsphere", "sitting_xyz", "crowd",
                        "unknown_object"}) {
    const Scenario s = scenario(n, 80, 60);
    Renderer r(s, leftOnly());
    std::set<int> movers;
    for (const auto& p : s.people) movers.insert(p.instance_id);
    for (const auto& o : s.objects)
      if (!o.path.empty()) movers.insert(o.instance_id);
    double worst = 1;
    for (int f = 0; f < s.frames; f += 10) {
      const FrameRender fr = r.render(f);
      int st = 0;
      for (int y = 0; y < s.height; y++)
        for (int x = 0; x < s.width; x++) st += movers.count(fr.instance.at<int>(y, x)) == 0;
      worst = std::min(worst, st / double(s.width * s.height));
    }
    EXPECT_GT(worst, 0.45) << n;
  }
}

// crowd: at least ten people, many of them visible at once.
TEST(SynthRender, CrowdShowsManyPeople) {
  const Scenario s = scenario("crowd", 160, 120);
  Renderer r(s, leftOnly());
  size_t best = 0;
  for (int f = 0; f < s.frames; f += 60) best = std::max(best, r.render(f).boxes.size());
  EXPECT_GE(best, 8u);
}

// Changing scenes: objects vanish after their event and the change happens
// out of view.
TEST(SynthRender, VanishingObjectsDisappearOutOfView) {
  const Scenario s = scenario("vanishing", 160, 120);
  Renderer r(s, leftOnly());
  std::set<int> gone;
  for (const auto& e : s.events) gone.insert(s.findObject(e.object)->instance_id);
  ASSERT_EQ(gone.size(), 3u);
  auto visible = [&](int f) {
    const FrameRender fr = r.render(f);
    int n = 0;
    for (int y = 0; y < s.height; y++)
      for (int x = 0; x < s.width; x++) n += gone.count(fr.instance.at<int>(y, x));
    return std::make_pair(n, cv::countNonZero(fr.semantic == 62));  // chair pixels
  };
  const auto before = visible(0), during1 = visible(299), during2 = visible(300), after = visible(599);
  EXPECT_GT(before.first, 500);
  EXPECT_GT(before.second, 50);
  EXPECT_EQ(during1.first, 0);  // the camera looks away when it happens
  EXPECT_EQ(during2.first, 0);
  EXPECT_EQ(after.first, 0);
  EXPECT_EQ(after.second, 0);
}

// PUC-USP-like scenes: every change happens while the objects concerned are
// out of view (frames first-1 .. last have no pixel of them).
TEST(SynthRender, ChangesHappenOutOfView) {
  for (const char* n : {"one_chair", "vanishing", "replacing", "shift"}) {
    const Scenario s = scenario(n, 80, 60);
    Renderer r(s, leftOnly());
    std::set<int> ids;
    int lo = s.frames, hi = 0;
    for (const auto& e : s.events) {
      ids.insert(s.findObject(e.object)->instance_id);
      if (!e.by.empty()) ids.insert(s.findObject(e.by)->instance_id);
      lo = std::min(lo, e.first - 1);
      hi = std::max(hi, e.last);
    }
    auto count = [&](int f) {
      const FrameRender fr = r.render(f);
      int c = 0;
      for (int y = 0; y < s.height; y++)
        for (int x = 0; x < s.width; x++) c += ids.count(fr.instance.at<int>(y, x));
      return c;
    };
    for (int f = lo; f <= hi; f += std::max(1, (hi - lo) / 8)) EXPECT_EQ(count(f), 0) << n << " frame " << f;
    EXPECT_EQ(count(hi), 0) << n;
    // ... and the camera sees the place before and after (a revisit).
    EXPECT_GT(count(0), 50) << n;
    if (std::string(n) != "vanishing") {
      EXPECT_GT(count(s.frames - 1), 50) << n;
    }
    const SE3 d = r.scene().cameraPose(0).inverse() * r.scene().cameraPose(s.frames - 1);
    EXPECT_LT(d.translation().norm(), 0.3) << n;
    EXPECT_LT(d.angle() * 180 / M_PI, 15) << n;
  }
}

// Optional motion blur averages sub-frame renders over the exposure: a moving
// camera gives a smoother (lower gradient energy) image, deterministically.
TEST(SynthRender, MotionBlurSmoothsMovingCamera) {
  Scenario s = scenario("walking_rpy", 160, 120, 0, true);
  s.noise.image_sigma = 0;
  RenderOptions ro;
  ro.right = false;
  auto energy = [](const cv::Mat& bgr) {
    cv::Mat g, lap;
    cv::cvtColor(bgr, g, cv::COLOR_BGR2GRAY);
    cv::Laplacian(g, lap, CV_32F);
    return cv::sum(cv::abs(lap))[0];
  };
  const int f = 40;  // rotating at ~15 deg/s
  const double sharp = energy(Renderer(s, ro).render(f).rgb);
  s.noise.motion_blur = 1.0;
  s.noise.blur_samples = 5;
  const cv::Mat b1 = Renderer(s, ro).render(f).rgb, b2 = Renderer(s, ro).render(f).rgb;
  EXPECT_LT(energy(b1), 0.97 * sharp);
  EXPECT_EQ(cv::countNonZero(cv::Mat(b1 != b2).reshape(1)), 0);
}
