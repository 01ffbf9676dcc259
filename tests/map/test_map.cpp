// modules/map: covisibility edges from shared points (ORB-SLAM
// UpdateConnections), the spanning tree when a keyframe is erased, and
// Map::absorb (map merging), on small exact worlds.
#include <gtest/gtest.h>

#include "synth_map.h"

using namespace dslam;

namespace {

/** Makes `n` map points of world points seen by both keyframes: observed in
 *  `a` (which owns them) and in `b`. Returns how many it made. */
int share(const test::SynthWorld& w, Map& m, KeyFrame* a, const std::vector<int>& seen_a, KeyFrame* b,
          const std::vector<int>& seen_b, int first, int n) {
  int made = 0;
  for (int i = first; i < static_cast<int>(w.X.size()) && made < n; i++) {
    const int ia = test::keypointOf(seen_a, i), ib = test::keypointOf(seen_b, i);
    if (ia < 0 || ib < 0 || a->points[ia] || b->points[ib]) continue;
    auto mp = w.point(m, i, a, ia);
    mp->addObservation(b, ib);
    b->addPoint(mp, ib);
    made++;
  }
  return made;
}

/** Three keyframes of one map, 10 cm apart along x (the first is the origin). */
struct ThreeKeyFrames {
  test::SynthWorld w;
  Map m{0};
  std::vector<int> seen[3];
  KeyFramePtr kf[3];
  ThreeKeyFrames() {
    for (int i = 0; i < 3; i++) {
      kf[i] = w.keyframe(m, test::poseAt({0.1 * i, 0, 0}), i, &seen[i]);
      m.addKeyFrame(kf[i]);
    }
  }
  /** n points of world points first.. that keyframes a and b both see. */
  int share(int a, int b, int first, int n) {
    return ::share(w, m, kf[a].get(), seen[a], kf[b].get(), seen[b], first, n);
  }
};

}  // namespace

TEST(Covisibility, UpdateConnectionsKeepsEdgesOfAtLeast15SharedPoints) {
  ThreeKeyFrames t;
  auto &A = t.kf[0], &B = t.kf[1], &C = t.kf[2];
  ASSERT_EQ(t.share(0, 1, 0, 40), 40);
  ASSERT_EQ(t.share(0, 2, 200, 10), 10);

  A->updateConnections();
  EXPECT_EQ(A->weight(B.get()), 40);
  EXPECT_EQ(A->weight(C.get()), 0);  // 10 shared points < 15: no edge
  EXPECT_EQ(B->weight(A.get()), 40);  // edges are symmetric
  EXPECT_EQ(C->weight(A.get()), 0);
  ASSERT_EQ(A->covisibles().size(), 1u);
  EXPECT_EQ(A->covisibles()[0], B.get());
  EXPECT_EQ(A->parent, nullptr);  // the origin has no parent

  // 30 more points shared with C: C now passes the threshold and orders after B.
  ASSERT_EQ(t.share(0, 2, 100, 30), 30);
  A->updateConnections();
  EXPECT_EQ(A->weight(C.get()), 40);
  ASSERT_EQ(A->covisibles().size(), 2u);
  EXPECT_EQ(A->covisibles()[0], B.get());  // equal weights: lower id first
  EXPECT_EQ(A->covisiblesByWeight(41).size(), 0u);
  EXPECT_EQ(A->bestCovisibles(1), std::vector<KeyFrame*>{B.get()});
}

TEST(Covisibility, WeakNeighboursKeepTheBestOneAndItBecomesTheParent) {
  ThreeKeyFrames t;
  auto &O = t.kf[0], &A = t.kf[1], &B = t.kf[2];
  ASSERT_EQ(t.share(0, 2, 0, 12), 12);
  ASSERT_EQ(t.share(1, 2, 100, 8), 8);

  B->updateConnections();  // 12 and 8 shared points: both below 15
  EXPECT_EQ(B->weight(O.get()), 12);  // ORB-SLAM keeps the strongest anyway
  EXPECT_EQ(B->weight(A.get()), 0);
  EXPECT_EQ(O->weight(B.get()), 12);
  EXPECT_EQ(B->parent, O.get());  // first connection: the best covisible is the parent
  EXPECT_EQ(O->children.count(B->id), 1u);
}

TEST(Covisibility, ErasedKeyFrameHandsItsChildrenToACovisibleCandidate) {
  ThreeKeyFrames t;
  auto &O = t.kf[0], &B = t.kf[1], &C = t.kf[2];
  Map& m = t.m;
  t.share(0, 1, 0, 40);
  B->updateConnections();  // B joins the tree under O
  t.share(1, 2, 60, 50);
  t.share(0, 2, 150, 20);
  C->updateConnections();
  ASSERT_EQ(B->parent, O.get());
  ASSERT_EQ(C->parent, B.get());  // 50 shared with B, 20 with O
  const SE3 T_cp_expected = B->T_cw() * O->T_wc();
  const size_t points_before = m.numPoints();

  B->setBad();
  EXPECT_TRUE(B->bad);
  EXPECT_EQ(C->parent, O.get());  // O was B's parent and is covisible with C
  EXPECT_EQ(O->children.count(C->id), 1u);
  EXPECT_EQ(O->children.count(B->id), 0u);
  EXPECT_EQ(O->weight(B.get()), 0);  // edges of B are gone on both sides
  EXPECT_EQ(C->weight(B.get()), 0);
  EXPECT_EQ(m.numKeyFrames(), 2u);  // B left the map but stays reachable (trajectory)
  EXPECT_EQ(m.keyframe(B->id), B);
  EXPECT_TRUE(B->T_cp.matrix().isApprox(T_cp_expected.matrix(), 1e-12));
  // B's 90 points had two observations (stereo: nObs 2 each): with B gone they
  // keep one keyframe, nObs 2 <= 2, and are erased (ORB-SLAM EraseObservation).
  EXPECT_EQ(m.numPoints(), points_before - 90);
  for (const auto& p : B->points) EXPECT_EQ(p, nullptr);

  // The origin is never erased.
  O->setBad();
  EXPECT_FALSE(O->bad);
}

TEST(MapAbsorb, MovesKeyFramesAndPointsIntoThisMapsFrame) {
  test::SynthWorld w;
  Map a(1), b(2);
  std::vector<int> s0, s1, s2;
  auto K0 = w.keyframe(b, test::poseAt({0, 0, 0}), 0, &s0);
  auto K1 = w.keyframe(b, test::poseAt({0.3, 0, 0}, 5), 1, &s1);
  auto K2 = w.keyframe(b, test::poseAt({0.6, 0, 0}, 10), 2, &s2);
  for (auto& k : {K0, K1, K2}) b.addKeyFrame(k);
  share(w, b, K0.get(), s0, K1.get(), s1, 0, 30);
  share(w, b, K1.get(), s1, K2.get(), s2, 100, 30);
  K1->updateConnections();
  K2->updateConnections();
  K2->setBad();  // an erased keyframe: it moves too (its frames' poses depend on it)
  ASSERT_EQ(b.numKeyFrames(), 2u);
  ASSERT_EQ(b.allKeyFramesEver().size(), 3u);

  const SE3 T_ab(Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, 1, 0.1).normalized())),
                 Eigen::Vector3d(1.5, -0.4, 2.0));
  std::map<int64_t, Eigen::Vector3d> centre, pos, normal;
  std::map<int64_t, Eigen::Vector3d> in_camera;  // a point as its reference keyframe sees it
  for (const auto& [id, k] : b.allKeyFramesEver()) centre[id] = k->center();
  for (const auto& [id, p] : b.points()) {
    pos[id] = p->pos;
    normal[id] = p->normal;
    in_camera[id] = p->ref_kf->T_cw() * p->pos;
  }
  const size_t n_points = b.numPoints();

  a.absorb(b, T_ab);
  EXPECT_EQ(b.numKeyFrames(), 0u);
  EXPECT_EQ(b.numPoints(), 0u);
  EXPECT_TRUE(b.allKeyFramesEver().empty());
  EXPECT_EQ(b.origin(), nullptr);
  EXPECT_EQ(a.numKeyFrames(), 2u);  // live keyframes stay live, the erased one stays erased
  EXPECT_EQ(a.allKeyFramesEver().size(), 3u);
  EXPECT_EQ(a.keyframes().count(K2->id), 0u);
  EXPECT_EQ(a.numPoints(), n_points);
  for (const auto& [id, k] : a.allKeyFramesEver()) {
    EXPECT_EQ(k->map, &a);
    EXPECT_LT((k->center() - T_ab * centre[id]).norm(), 1e-12) << "keyframe " << id;
  }
  for (const auto& [id, p] : a.points()) {
    EXPECT_EQ(p->map, &a);
    EXPECT_LT((p->pos - T_ab * pos[id]).norm(), 1e-12) << "point " << id;
    EXPECT_LT((p->normal - T_ab.rotation() * normal[id]).norm(), 1e-12);
    // Keyframes and points moved together: what a camera sees is unchanged.
    EXPECT_LT((p->ref_kf->T_cw() * p->pos - in_camera[id]).norm(), 1e-9);
  }
}
