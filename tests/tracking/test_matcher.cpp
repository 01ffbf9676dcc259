// Matcher search functions (ORB-SLAM2 ORBmatcher) on exact worlds: every
// point has its own descriptor, keypoints sit at the true projections, so
// each search must find the right partner for every point both views see,
// and the tests check what makes a search reject a candidate.
#include <gtest/gtest.h>

#include <set>

#include "dslam/tracking/matcher.h"
#include "synth_map.h"

using namespace dslam;

namespace {

/** World index of a map point made by SynthWorld (its position is X[i]). */
int worldIndex(const test::SynthWorld& w, const MapPoint& mp) {
  for (size_t i = 0; i < w.X.size(); i++)
    if (w.X[i] == mp.pos) return static_cast<int>(i);
  return -1;
}

/** A map point of world point i not observed by any keyframe. */
MapPointPtr loosePoint(const test::SynthWorld& w, Map& m, int i) {
  auto mp = std::make_shared<MapPoint>(Map::nextPointId(), w.X[i], nullptr, &m);
  mp->desc = w.desc[i];
  return mp;
}

/** Map points for every keypoint of kf (kf observes and owns them). */
void populate(const test::SynthWorld& w, Map& m, KeyFrame* kf, const std::vector<int>& seen) {
  for (size_t k = 0; k < seen.size(); k++) w.point(m, seen[k], kf, static_cast<int>(k));
}

/** World points seen by both frames. */
int common(const std::vector<int>& a, const std::vector<int>& b) {
  int n = 0;
  for (int i : a) n += test::keypointOf(b, i) >= 0;
  return n;
}

/** Checks every match of F: the point is the world point of the keypoint. */
int countWrong(const test::SynthWorld& w, const TrackedFrame& F, const std::vector<int>& seen) {
  int wrong = 0;
  for (size_t k = 0; k < F.size(); k++)
    if (F.points[k] && worldIndex(w, *F.points[k]) != seen[k]) wrong++;
  return wrong;
}

}  // namespace

/** Motion-model search: the last tracked frame at the origin with a loose
 *  map point on each keypoint (sl[k] = world point of keypoint k). */
class MatcherMotionModel : public ::testing::Test {
 protected:
  void SetUp() override {
    for (size_t k = 0; k < sl.size(); k++) last.points[k] = loosePoint(w, m, sl[k]);
  }
  test::SynthWorld w;
  Map m{0};
  std::vector<int> sl;
  TrackedFrame last = w.tracked(test::poseAt({0, 0, 0}), 0, &sl);
};

TEST_F(MatcherMotionModel, FindsEveryPointOfTheLastFrame) {
  std::vector<int> sc;
  TrackedFrame cur = w.tracked(test::poseAt({0.02, 0.01, 0.03}, 1), 1, &sc);
  const int both = common(sl, sc);
  ASSERT_GT(both, 200);

  const Matcher matcher(0.9f, true);
  EXPECT_EQ(matcher.searchByProjection(cur, last, 15, true), both);
  EXPECT_EQ(cur.numMatches(), both);
  EXPECT_EQ(countWrong(w, cur, sc), 0);

  // A pose estimate 43 cm off sideways (43-72 px at 3-5 m): with a 7 px
  // window next to nothing is found.
  TrackedFrame off = w.tracked(test::poseAt({0.02, 0.01, 0.03}, 1), 1);
  off.T_cw = test::poseAt({0.45, 0.01, 0.03}, 1);
  EXPECT_LT(matcher.searchByProjection(off, last, 7, true), both / 20);
}

TEST_F(MatcherMotionModel, DropsMatchesOfAnotherRotation) {
  // Current keypoints are turned by 40 degrees (the whole image), except 15
  // that claim 200 degrees: fewer than 10 % of the main bin, so the rotation
  // histogram rejects them (ORB-SLAM keeps the three main bins).
  std::vector<int> sc_all;
  TrackedFrame cur = w.tracked(test::poseAt({0.01, 0, 0}), 1, &sc_all, 40.f);
  std::vector<size_t> odd;
  for (size_t k = 0; k < cur.size() && odd.size() < 15; k += 9)
    if (test::keypointOf(sl, sc_all[k]) >= 0) {  // a keypoint the last frame sees too
      cur.f.keypoints_un[k].angle = 200.f;
      odd.push_back(k);
    }
  ASSERT_EQ(odd.size(), 15u);
  const int both = common(sl, sc_all);
  const Matcher matcher(0.9f, true);
  EXPECT_EQ(matcher.searchByProjection(cur, last, 15, true), both - 15);
  for (size_t k : odd) EXPECT_EQ(cur.points[k], nullptr) << k;
  EXPECT_EQ(countWrong(w, cur, sc_all), 0);

  // Without the orientation check every match stays.
  TrackedFrame cur2 = w.tracked(test::poseAt({0.01, 0, 0}), 1, nullptr, 40.f);
  for (size_t k : odd) cur2.f.keypoints_un[k].angle = 200.f;
  EXPECT_EQ(Matcher(0.9f, false).searchByProjection(cur2, last, 15, true), both);
}

TEST(Matcher, LocalMapProjectionSkipsDynamicKeypointsAndFarDescriptors) {
  test::SynthWorld w;
  Map m(0);
  std::vector<int> sf;
  TrackedFrame F = w.tracked(test::poseAt({0.1, 0, 0}, 3), 5, &sf);
  // The tracker's projection of each visible point (what Tracker fills in).
  std::vector<MapPointPtr> local;
  for (int i : sf) {
    auto mp = loosePoint(w, m, i);
    const Eigen::Vector3d Xc = *F.T_cw * mp->pos;
    mp->track_in_view = true;
    mp->track_proj_x = static_cast<float>(w.cam.fx * Xc.x() / Xc.z() + w.cam.cx);
    mp->track_proj_y = static_cast<float>(w.cam.fy * Xc.y() / Xc.z() + w.cam.cy);
    mp->track_proj_xr = static_cast<float>(mp->track_proj_x - w.cam.bf / Xc.z());
    mp->track_scale_level = 0;
    mp->track_view_cos = 1;
    local.push_back(mp);
  }
  // 10 keypoints marked dynamic by a classifier; 10 points whose descriptor
  // is the complement of the keypoint's (distance 256 > TH_HIGH 100).
  for (size_t k = 0; k < 10; k++) F.f.meta[k].label = KpLabel::Dynamic;
  for (size_t k = 20; k < 30; k++)
    for (auto& b : local[k]->desc) b = static_cast<uint8_t>(~b);
  // One point marked inactive (persistence filter) and one not in view.
  local[40]->active = false;
  local[41]->track_in_view = false;

  const Matcher matcher(0.8f, true);
  const int n = matcher.searchByProjection(F, local, 1);
  EXPECT_EQ(n, static_cast<int>(sf.size()) - 10 - 10 - 2);
  EXPECT_EQ(countWrong(w, F, sf), 0);
  for (size_t k = 0; k < 10; k++) EXPECT_EQ(F.points[k], nullptr);
  for (size_t k = 20; k < 30; k++) EXPECT_EQ(F.points[k], nullptr);
  EXPECT_EQ(F.points[40], nullptr);
  EXPECT_EQ(F.points[41], nullptr);
}

/** A keyframe at the origin with a map point on every keypoint (sk[k] =
 *  world point of keypoint k). */
class MatcherMappedKeyFrame : public ::testing::Test {
 protected:
  void SetUp() override { populate(w, m, kf.get(), sk); }
  test::SynthWorld w;
  Map m{0};
  std::vector<int> sk;
  KeyFramePtr kf = w.keyframe(m, test::poseAt({0, 0, 0}), 0, &sk);
};

TEST_F(MatcherMappedKeyFrame, ToFrameByDescriptorsIsOneToOneAndCorrect) {
  std::vector<int> sf;
  TrackedFrame F = w.tracked(test::poseAt({0.3, 0.05, 0.1}, 8), 9, &sf);
  const int both = common(sk, sf);
  ASSERT_GT(both, 150);

  const Matcher matcher(0.75f, true);
  EXPECT_EQ(matcher.searchByDescriptors(kf.get(), F), both);
  EXPECT_EQ(countWrong(w, F, sf), 0);
  // Without a vocabulary (no feature vectors) searchByBoW is the same search.
  TrackedFrame F2 = w.tracked(test::poseAt({0.3, 0.05, 0.1}, 8), 9);
  EXPECT_EQ(matcher.searchByBoW(kf.get(), F2), both);

  // Two frame keypoints with the same descriptor: the ratio test cannot tell
  // them apart, so that point is not matched at all.
  TrackedFrame F3 = w.tracked(test::poseAt({0.3, 0.05, 0.1}, 8), 9);
  const int j = test::keypointOf(sf, sk[5]);
  ASSERT_GE(j, 0);
  const int other = j == 0 ? 1 : 0;
  F3.f.descriptors.row(j).copyTo(F3.f.descriptors.row(other));
  const int n3 = matcher.searchByDescriptors(kf.get(), F3);
  EXPECT_EQ(F3.points[j], nullptr);
  EXPECT_EQ(F3.points[other], nullptr);
  EXPECT_EQ(n3, both - (test::keypointOf(sk, sf[other]) >= 0 ? 2 : 1));
}

TEST_F(MatcherMappedKeyFrame, RelocalisationProjectionAddsThePointsNotFoundYet) {
  std::vector<int> sf;
  // Five keyframe points whose descriptor differs from their keypoints' by
  // 60 bits: matched with orb_dist 64, not with 50.
  for (size_t k = 100; k < 105; k++) {
    MapPoint& mp = *kf->points[k];
    for (size_t b = 0; b < 60; b++) mp.desc[b / 8] ^= static_cast<uint8_t>(1u << (b % 8));
  }
  auto frame = [&] { return w.tracked(test::poseAt({0.2, -0.05, 0.1}, 6), 40, &sf); };
  TrackedFrame F = frame();
  const int both = common(sk, sf);
  // The first 20 shared points were matched already (e.g. by BoW + PnP).
  std::set<const MapPoint*> found;
  for (size_t k = 0; k < sk.size() && found.size() < 20; k++)
    if (const int j = test::keypointOf(sf, sk[k]); j >= 0) {
      F.points[j] = kf->points[k];
      found.insert(kf->points[k].get());
    }
  int corrupted_seen = 0;
  for (size_t k = 100; k < 105; k++) corrupted_seen += test::keypointOf(sf, sk[k]) >= 0;

  const Matcher matcher(0.9f, true);
  EXPECT_EQ(matcher.searchByProjection(F, kf.get(), found, 10, 50), both - 20 - corrupted_seen);
  EXPECT_EQ(F.numMatches(), both - corrupted_seen);
  EXPECT_EQ(countWrong(w, F, sf), 0);

  TrackedFrame F2 = frame();
  EXPECT_EQ(matcher.searchByProjection(F2, kf.get(), {}, 10, 64), both);
  EXPECT_EQ(countWrong(w, F2, sf), 0);
}

TEST(Matcher, TriangulationCandidatesLieOnEpipolarLinesAndSkipMappedKeypoints) {
  test::SynthWorld w;
  Map m(0);
  std::vector<int> s1, s2;
  auto kf1 = w.keyframe(m, test::poseAt({0, 0, 0}), 0, &s1);
  auto kf2 = w.keyframe(m, test::poseAt({0.3, 0, 0}, -4), 10, &s2);
  // The first 50 keypoints of kf1 already have map points: not candidates.
  for (int k = 0; k < 50; k++) w.point(m, s1[k], kf1.get(), k);
  int free_both = 0;
  for (size_t k = 50; k < s1.size(); k++) free_both += test::keypointOf(s2, s1[k]) >= 0;
  ASSERT_GT(free_both, 150);

  std::vector<std::pair<int, int>> pairs;
  const Matcher matcher(0.6f, false);
  const int n = matcher.searchForTriangulation(kf1.get(), kf2.get(), fundamental12(kf1.get(), kf2.get()), pairs, false);
  EXPECT_EQ(n, static_cast<int>(pairs.size()));
  EXPECT_EQ(n, free_both);
  for (const auto& [i1, i2] : pairs) {
    EXPECT_GE(i1, 50);
    EXPECT_EQ(s1[i1], s2[i2]);  // the same world point
  }

  // Epipolar geometry, not descriptors alone: with kf2's pose wrong by 20
  // cm vertically the same descriptors are rejected by the line distance.
  auto moved = w.keyframe(m, test::poseAt({0.3, 0, 0}, -4), 10);
  moved->setPose(test::poseAt({0.3, 0.2, 0}, -4));
  EXPECT_LT(matcher.searchForTriangulation(kf1.get(), moved.get(), fundamental12(kf1.get(), moved.get()), pairs, false),
            free_both / 10);
}

TEST(Matcher, FuseMergesDuplicatesAndAddsMissingObservations) {
  test::SynthWorld w;
  Map m(0);
  std::vector<int> sk, sr;
  // kf has points for its first 100 keypoints; the current keyframe `cur`,
  // 5 cm behind it, made its own points for every keypoint (duplicates).
  auto kf = w.keyframe(m, test::poseAt({0, 0, 0}), 0, &sk);
  auto cur = w.keyframe(m, test::poseAt({0, 0, -0.05}), 1, &sr);
  for (int k = 0; k < 100; k++) w.point(m, sk[k], kf.get(), k);
  populate(w, m, cur.get(), sr);
  const int both = common(sk, sr);
  int dup = 0;
  for (int k = 0; k < 100; k++) dup += test::keypointOf(sr, sk[k]) >= 0;
  const size_t points_before = m.numPoints();

  const Matcher matcher;
  const int n = matcher.fuse(kf.get(), cur->validPoints(), 3.0f);
  EXPECT_EQ(n, both);
  EXPECT_EQ(m.numPoints(), points_before - static_cast<size_t>(dup));  // one of each duplicate pair is gone
  for (size_t k = 0; k < sk.size(); k++) {
    const int r = test::keypointOf(sr, sk[k]);
    if (r < 0) continue;
    ASSERT_NE(kf->points[k], nullptr) << k;
    // Both keyframes now observe the same point for the same world point.
    EXPECT_EQ(kf->points[k], cur->points[r]) << k;
    EXPECT_EQ(worldIndex(w, *kf->points[k]), sk[k]);
    EXPECT_TRUE(kf->points[k]->isIn(kf.get()));
    EXPECT_TRUE(kf->points[k]->isIn(cur.get()));
  }
}

TEST(Matcher, SE3GuidedSearchKeepsMutualMatchesUnderTheRightTransform) {
  test::SynthWorld w;
  Map m(0);
  std::vector<int> s1, s2;
  auto kf1 = w.keyframe(m, test::poseAt({0, 0, 0}), 0, &s1);
  auto kf2 = w.keyframe(m, test::poseAt({0.4, 0.1, 0.2}, 12), 30, &s2);
  populate(w, m, kf1.get(), s1);
  populate(w, m, kf2.get(), s2);
  const int both = common(s1, s2);
  const SE3 T12 = kf1->T_cw() * kf2->T_wc();

  const Matcher matcher(0.75f, true);
  std::vector<MapPointPtr> matches12(kf1->size());
  // Ten matches known already (e.g. by BoW) are kept as they are.
  int known = 0;
  for (size_t i = 0; i < s1.size() && known < 10; i++)
    if (const int j = test::keypointOf(s2, s1[i]); j >= 0) {
      matches12[i] = kf2->points[j];
      known++;
    }
  EXPECT_EQ(matcher.searchBySE3(kf1.get(), kf2.get(), matches12, T12, 7.5f), both - known);
  for (size_t i = 0; i < s1.size(); i++) {
    const int j = test::keypointOf(s2, s1[i]);
    EXPECT_EQ(matches12[i], j >= 0 ? kf2->points[j] : nullptr) << i;
  }

  // A transform 30 cm off finds (almost) nothing.
  std::vector<MapPointPtr> none(kf1->size());
  const SE3 wrong = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.3, 0, 0)) * T12;
  EXPECT_LT(matcher.searchBySE3(kf1.get(), kf2.get(), none, wrong, 7.5f), both / 20);

  // Inactive points (persistence filters: a moved object's) are matched on
  // neither side: a merge or loop must not tie them to the other map.
  int off1 = 0, off2 = 0;
  for (size_t i = 0; i < s1.size(); i++) {
    const int j = test::keypointOf(s2, s1[i]);
    if (j < 0) continue;
    if (i % 3 == 0 && kf1->points[i]) kf1->points[i]->active = false, off1++;
    else if (i % 3 == 1 && kf2->points[j]) kf2->points[j]->active = false, off2++;
  }
  ASSERT_GT(off1 + off2, 20);
  std::vector<MapPointPtr> guided(kf1->size());
  EXPECT_EQ(matcher.searchBySE3(kf1.get(), kf2.get(), guided, T12, 7.5f), both - off1 - off2);
  for (size_t i = 0; i < guided.size(); i++)
    if (guided[i]) {
      EXPECT_TRUE(guided[i]->active) << i;
      EXPECT_TRUE(kf1->points[i]->active) << i;
    }
}
