// LocalMapper steps on exact worlds (sequential processAll(), no local BA):
// triangulation of new points between neighbouring keyframes, culling of
// recent points (ORB-SLAM MapPointCulling), culling of redundant keyframes
// (KeyFrameCulling), nested pauses of the mapper thread, and what local BA
// and fusion do with the points a persistence filter made inactive.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <random>
#include <set>
#include <thread>

#include "dslam/mapping/local_mapper.h"
#include "plugin_util.h"
#include "synth_map.h"

using namespace dslam;

namespace {

LocalMapperParams noBa() {
  LocalMapperParams p;
  p.local_ba = false;  // no backend needed: the steps under test are the mapper's own
  return p;
}

/** A keyframe that sees nothing (camera turned away from every point): a
 *  keyframe for the mapper to process, which changes nothing but the
 *  keyframe count (ages the recent points). */
KeyFramePtr blind(const test::SynthWorld& w, Map& m, int index) {
  return w.keyframe(m, test::poseAt({0, 0, 0}, 180), index);
}

/** The origin keyframe with a map point for each keypoint whose world index
 *  is below `mapped` (as tracking initialises a map). */
KeyFramePtr origin(const test::SynthWorld& w, Map& m, std::vector<int>& seen, int mapped) {
  auto kf = w.keyframe(m, test::poseAt({0, 0, 0}), 0, &seen);
  for (size_t k = 0; k < seen.size(); k++)
    if (seen[k] < mapped) w.point(m, seen[k], kf.get(), static_cast<int>(k));
  m.addKeyFrame(kf);
  return kf;
}

/** Tracking's view of a new keyframe: its keypoints of mapped world points
 *  hold those points (observations are added by the mapper). */
void track(KeyFrame* kf, const std::vector<int>& seen, const KeyFrame* from, const std::vector<int>& seen_from) {
  for (size_t k = 0; k < seen.size(); k++)
    if (const int j = test::keypointOf(seen_from, seen[k]); j >= 0 && from->points[j]) kf->points[k] = from->points[j];
}

}  // namespace

TEST(LocalMapper, TriangulatesNewPointsWithTheCovisibleKeyFrame) {
  test::SynthWorld w;
  Map m(0);
  std::vector<int> s0, s1;
  auto kf0 = origin(w, m, s0, 150);
  auto kf1 = w.keyframe(m, test::poseAt({0.3, 0, 0}, -3), 10, &s1);
  track(kf1.get(), s1, kf0.get(), s0);
  int free_both = 0;  // unmapped world points both keyframes see
  for (int i : s1) free_both += i >= 150 && test::keypointOf(s0, i) >= 0;
  ASSERT_GT(free_both, 80);
  const size_t points_before = m.numPoints();

  LocalMapper mapper(noBa(), nullptr);
  std::vector<KeyFramePtr> done;
  mapper.setKeyFrameCallback([&](const KeyFramePtr& k) { done.push_back(k); });
  mapper.insertKeyFrame(kf1);
  EXPECT_EQ(mapper.queuedKeyFrames(), 1u);
  mapper.processAll();
  EXPECT_EQ(mapper.queuedKeyFrames(), 0u);
  ASSERT_EQ(done.size(), 1u);
  EXPECT_EQ(done[0], kf1);
  EXPECT_EQ(m.numKeyFrames(), 2u);
  EXPECT_GE(kf1->weight(kf0.get()), 100);  // covisibility from the tracked points

  EXPECT_EQ(m.numPoints(), points_before + static_cast<size_t>(free_both));
  for (size_t k = 0; k < s1.size(); k++) {
    const int i = s1[k];
    if (i < 150 || test::keypointOf(s0, i) < 0) continue;
    const MapPointPtr& mp = kf1->points[k];
    ASSERT_NE(mp, nullptr) << "world point " << i;
    EXPECT_LT((mp->pos - w.X[i]).norm(), 1e-3) << "world point " << i;
    EXPECT_EQ(mp->indexIn(kf0.get()), test::keypointOf(s0, i));
    EXPECT_EQ(mp->indexIn(kf1.get()), static_cast<int>(k));
    EXPECT_EQ(mp->numObservations(), 4);  // two stereo observations
  }
}

TEST(LocalMapper, CullsRecentPointsFoundTooRarelyOrSeenByTooFewKeyFrames) {
  test::SynthWorld w;
  Map m(0);
  std::vector<int> s0, s1;
  auto kf0 = origin(w, m, s0, 150);
  Frame f1 = w.frame(test::poseAt({0.3, 0, 0}, -3), 10, &s1);
  // Every other unmapped keypoint of kf1 has no depth (monocular): points
  // triangulated from it have 1 + 2 = 3 observations (ORB-SLAM nObs).
  std::set<int> mono;
  for (size_t k = 0; k < s1.size(); k++)
    if (s1[k] >= 150 && k % 2 == 0) {
      f1.depth[k] = -1;
      f1.u_right[k] = -1;
      mono.insert(s1[k]);
    }
  auto kf1 = std::make_shared<KeyFrame>(Map::nextKeyFrameId(), f1, test::poseAt({0.3, 0, 0}, -3), w.cam, w.scale, &m);
  track(kf1.get(), s1, kf0.get(), s0);

  LocalMapper mapper(noBa(), nullptr);
  mapper.insertKeyFrame(kf1);
  mapper.processAll();
  // The new points, by kind: found rarely (A), monocular + stereo (B), others (C).
  std::vector<MapPointPtr> A, B, C;
  for (size_t k = 0; k < s1.size(); k++) {
    const MapPointPtr& mp = kf1->points[k];
    if (!mp || mp->first_kf_id != kf1->id) continue;
    if (mono.count(s1[k])) {
      EXPECT_EQ(mp->numObservations(), 3);
      B.push_back(mp);
    } else if (A.size() < 10) {
      mp->n_visible = 10;  // predicted in 10 frames, found in 1: ratio 0.1 < 0.25
      mp->n_found = 1;
      A.push_back(mp);
    } else {
      C.push_back(mp);
    }
  }
  ASSERT_EQ(A.size(), 10u);
  ASSERT_GT(B.size(), 20u);
  ASSERT_GT(C.size(), 20u);
  auto alive = [](const std::vector<MapPointPtr>& v) {
    size_t n = 0;
    for (const auto& p : v) n += !p->bad;
    return n;
  };

  // Next keyframe: the rarely found points go at once.
  mapper.insertKeyFrame(blind(w, m, 20));
  mapper.processAll();
  EXPECT_EQ(alive(A), 0u);
  EXPECT_EQ(alive(B), B.size());
  EXPECT_EQ(alive(C), C.size());
  for (const auto& p : A) EXPECT_EQ(m.point(p->id), nullptr);

  // Two keyframes after their creation: points with <= 3 observations go.
  mapper.insertKeyFrame(blind(w, m, 30));
  mapper.processAll();
  EXPECT_EQ(alive(B), 0u);
  EXPECT_EQ(alive(C), C.size());
  for (const auto& p : B) {
    EXPECT_FALSE(p->isIn(kf1.get()));  // gone from the keyframes and the map
    EXPECT_EQ(m.point(p->id), nullptr);
  }

  // Three keyframes after: the survivors leave the recent list; from then on
  // a low found ratio does not cull them any more.
  mapper.insertKeyFrame(blind(w, m, 40));
  mapper.processAll();
  EXPECT_EQ(alive(C), C.size());
  for (auto& p : C) {
    p->n_visible = 100;
    p->n_found = 1;
  }
  mapper.insertKeyFrame(blind(w, m, 50));
  mapper.processAll();
  EXPECT_EQ(alive(C), C.size());
}

TEST(LocalMapper, CullsKeyFramesWhoseClosePointsOthersSee) {
  // Close points (z 1.5-3 m < the 3.2 m close depth), five keyframes 1 cm
  // apart seeing all of them: a keyframe is culled once 90 % of its close
  // points are seen by three other keyframes.
  test::SynthWorld w(300, 11, 1.5, 3.0);
  Map m(0);
  std::vector<int> s0;
  auto kf0 = origin(w, m, s0, 1000);
  LocalMapper mapper(noBa(), nullptr);
  std::vector<KeyFramePtr> kfs = {kf0};
  for (int k = 1; k <= 4; k++) {
    std::vector<int> s;
    auto kf = w.keyframe(m, test::poseAt({0.01 * k, 0, 0}), 10 * k, &s);
    track(kf.get(), s, kf0.get(), s0);
    kfs.push_back(kf);
    mapper.insertKeyFrame(kf);
    mapper.processAll();
  }
  // Processing kf3: kf1's points are seen by kf0, kf2, kf3 -> kf1 culled.
  // Processing kf4: kf2's by kf0, kf3, kf4 -> culled; kf3's only by kf0 and
  // kf4 then (kf2 is gone). The origin is never culled.
  EXPECT_FALSE(kfs[0]->bad);
  EXPECT_TRUE(kfs[1]->bad);
  EXPECT_TRUE(kfs[2]->bad);
  EXPECT_FALSE(kfs[3]->bad);
  EXPECT_FALSE(kfs[4]->bad);
  EXPECT_EQ(m.numKeyFrames(), 3u);
  EXPECT_EQ(kfs[3]->parent, kfs[0].get());  // the spanning tree survives the culling

  // The same keyframes over far points (3.5-5 m, beyond the close depth):
  // stereo/RGB-D culling counts close points only, so none is culled.
  test::SynthWorld far(300, 11, 3.5, 5.0);
  Map m2(1);
  std::vector<int> f0;
  auto g0 = origin(far, m2, f0, 1000);
  LocalMapper mapper2(noBa(), nullptr);
  std::vector<KeyFramePtr> gs;
  for (int k = 1; k <= 4; k++) {
    std::vector<int> s;
    auto kf = far.keyframe(m2, test::poseAt({0.01 * k, 0, 0}), 10 * k, &s);
    track(kf.get(), s, g0.get(), f0);
    gs.push_back(kf);
    mapper2.insertKeyFrame(kf);
    mapper2.processAll();
  }
  for (const auto& g : gs) EXPECT_FALSE(g->bad);
  EXPECT_EQ(m2.numKeyFrames(), 5u);
}

namespace {

struct InactiveRun {
  std::vector<Eigen::Vector3d> inactive_before, inactive_after, active_err_after;
  std::vector<int> inactive_obs_before, inactive_obs_after, unassociated_obs_gain;
  LocalBAStats ba;
};

/** Three keyframes over the synthetic world with local BA: kf0 (origin) maps
 *  150 points, kf1 tracks them; then 15 of the points all three keyframes
 *  see become inactive (persistence filter) and are moved 2 mm off their
 *  true place, 15 active ones 1 cm (random directions); kf2 tracks the
 *  active points only (tracking never matches inactive ones) and leaves 10
 *  active points unassociated (fusion's job). */
InactiveRun runWithInactivePoints(bool fixed) {
  test::SynthWorld w;
  Map m(0);
  std::vector<int> s0, s1, s2;
  auto kf0 = origin(w, m, s0, 150);
  auto kf1 = w.keyframe(m, test::poseAt({0.3, 0, 0}, -3), 10, &s1);
  track(kf1.get(), s1, kf0.get(), s0);
  LocalMapperParams p;
  p.ba_inactive_points_fixed = fixed;
  LocalMapper mapper(p, test::defaultBackend());
  mapper.insertKeyFrame(kf1);
  mapper.processAll();

  auto kf2 = w.keyframe(m, test::poseAt({0.15, 0.05, 0}, 2), 20, &s2);
  std::vector<int> shared;  // world points of kf0's map points seen by kf1 and kf2
  for (int i : s1)
    if (i < 150 && test::keypointOf(s0, i) >= 0 && test::keypointOf(s2, i) >= 0) shared.push_back(i);
  EXPECT_GE(shared.size(), 60u);
  std::mt19937 rng(3);
  std::normal_distribution<double> n01;
  auto off = [&] { return Eigen::Vector3d(n01(rng), n01(rng), n01(rng)).normalized() * 0.01; };
  InactiveRun r;
  std::vector<MapPointPtr> inactive, perturbed, unassociated;
  std::vector<int> perturbed_world;
  for (size_t k = 0; k < shared.size(); k++) {
    const MapPointPtr& mp = kf0->points[test::keypointOf(s0, shared[k])];
    if (k < 15) {
      mp->active = false;
      mp->pos += 0.2 * off();
      inactive.push_back(mp);
    } else if (k < 30) {
      mp->pos += off();
      perturbed.push_back(mp);
      perturbed_world.push_back(shared[k]);
    } else if (k < 40) {
      unassociated.push_back(mp);
    }
  }
  for (size_t k = 0; k < s2.size(); k++) {
    const int j = test::keypointOf(s0, s2[k]);
    if (j < 0 || !kf0->points[j]) continue;
    const MapPointPtr& mp = kf0->points[j];
    const bool skip = !mp->active || std::find(unassociated.begin(), unassociated.end(), mp) != unassociated.end();
    if (!skip) kf2->points[k] = mp;
  }
  for (const auto& mp : inactive) {
    r.inactive_before.push_back(mp->pos);
    r.inactive_obs_before.push_back(mp->numObservations());
  }
  std::vector<int> unassoc_before;
  for (const auto& mp : unassociated) unassoc_before.push_back(mp->numObservations());
  mapper.insertKeyFrame(kf2);
  mapper.processAll();
  r.ba = mapper.lastLocalBA();
  for (const auto& mp : inactive) {
    r.inactive_after.push_back(mp->pos);
    r.inactive_obs_after.push_back(mp->numObservations());
  }
  for (size_t k = 0; k < perturbed.size(); k++) r.active_err_after.push_back(perturbed[k]->pos - w.X[perturbed_world[k]]);
  for (size_t k = 0; k < unassociated.size(); k++)
    r.unassociated_obs_gain.push_back(unassociated[k]->numObservations() - unassoc_before[k]);
  return r;
}

}  // namespace

TEST(LocalMapper, InactivePointsStayFixedInLocalBAAndGainNoObservations) {
  const InactiveRun with_fixed = runWithInactivePoints(true), with_skip = runWithInactivePoints(false);
  // 'fixed' keeps them in the problem as constants, 'skip' leaves them out.
  EXPECT_EQ(with_fixed.ba.points - with_skip.ba.points, 15);
  for (const bool fixed : {true, false}) {
    SCOPED_TRACE(fixed ? "ba_inactive_points: fixed" : "ba_inactive_points: skip");
    const InactiveRun& r = fixed ? with_fixed : with_skip;
    ASSERT_EQ(r.inactive_before.size(), 15u);
    EXPECT_GE(r.ba.optimised, 1);
    EXPECT_GE(r.ba.iterations, 1);
    // Active points moved 1 cm off their place are brought back by the BA...
    ASSERT_EQ(r.active_err_after.size(), 15u);
    for (const auto& e : r.active_err_after) EXPECT_LT(e.norm(), 0.0015);
    // ... the inactive ones (2 mm off) are not touched (bit for bit),
    // and neither fusion nor the new keyframe gives them observations.
    for (size_t k = 0; k < r.inactive_before.size(); k++) {
      EXPECT_EQ(r.inactive_after[k], r.inactive_before[k]) << "inactive point " << k;
      EXPECT_EQ(r.inactive_obs_after[k], r.inactive_obs_before[k]) << "inactive point " << k;
    }
    // Control: active points the new keyframe sees but tracking did not
    // associate are fused into it (two stereo observations each).
    ASSERT_EQ(r.unassociated_obs_gain.size(), 10u);
    for (int g : r.unassociated_obs_gain) EXPECT_EQ(g, 2);
  }
}

TEST(LocalMapper, PausesNestAndQueuedKeyFramesWait) {
  test::SynthWorld w;
  Map m(0);
  std::vector<int> s0;
  origin(w, m, s0, 0);
  LocalMapper mapper(noBa(), nullptr);
  std::atomic<int> processed{0};
  mapper.setKeyFrameCallback([&](const KeyFramePtr&) { processed++; });
  mapper.start();
  mapper.requestPause();  // e.g. the System switching maps
  EXPECT_TRUE(mapper.isStopped());
  mapper.requestPause();  // loop closing pauses meanwhile...
  mapper.insertKeyFrame(blind(w, m, 10));
  mapper.resume();  // ...and resumes: the System's pause still holds
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_TRUE(mapper.isStopped());
  EXPECT_EQ(processed.load(), 0);
  EXPECT_EQ(mapper.queuedKeyFrames(), 1u);
  mapper.resume();
  for (int i = 0; i < 400 && processed.load() == 0; i++) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_EQ(processed.load(), 1);
  EXPECT_FALSE(mapper.isStopped());
  mapper.resume();  // an unmatched resume is ignored
  mapper.stop();
}
