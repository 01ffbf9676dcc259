// Label fusion of map points (PointClassVotes): a keyframe whose detector
// missed an object labels its keypoints with the box behind it; with the
// votes, the points stay with the class most keyframes gave them.
#include <gtest/gtest.h>

#include "dslam/map/class_votes.h"
#include "dslam/map/map_object.h"
#include "synth_map.h"

using namespace dslam;

namespace {

constexpr int kPlant = 64, kDesk = 67;
constexpr int kPlantPoints = 12, kPoints = 40;

struct Scene {
  test::SynthWorld w{kPoints};
  Map m{0};
  std::vector<MapPointPtr> pts = std::vector<MapPointPtr>(kPoints);

  Scene() {
    // A plant (12 points, 0.2 m) 1 m in front of a desk (28 points, 0.3 m).
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-0.5, 0.5);
    for (int i = 0; i < kPoints; i++) {
      const bool plant = i < kPlantPoints;
      const double s = plant ? 0.2 : 0.3;
      w.X[i] = (plant ? Eigen::Vector3d(0.2, 0, 3) : Eigen::Vector3d(0, 0, 4)) + s * Eigen::Vector3d(u(rng), u(rng), u(rng));
    }
  }

  /** A keyframe seeing every point; the plant's keypoints labelled
   *  `plant_label` (the desk's box labels them when the plant is missed). */
  KeyFramePtr keyframe(int index, int plant_label) {
    std::vector<int> seen;
    auto kf = w.keyframe(m, test::poseAt({0, 0, 0}), index, &seen);
    for (size_t k = 0; k < seen.size(); k++) {
      const int i = seen[k];
      kf->meta[k].class_id = static_cast<int16_t>(i < kPlantPoints ? plant_label : kDesk);
      if (!pts[i]) {
        pts[i] = w.point(m, i, kf.get(), static_cast<int>(k));
        pts[i]->class_id = kf->meta[k].class_id;
      } else {
        kf->addPoint(pts[i], static_cast<int>(k));
        pts[i]->addObservation(kf.get(), static_cast<int>(k));
      }
    }
    return kf;
  }
};

/** Points of class `cls`'s candidates that are plant points. */
size_t plantPointsIn(const std::vector<ObjectCandidate>& cands, int cls, const Scene& s) {
  size_t n = 0;
  for (const auto& c : cands)
    if (c.class_id == cls)
      for (const auto& mp : c.points)
        for (int i = 0; i < kPlantPoints; i++) n += mp == s.pts[i];
  return n;
}

}  // namespace

TEST(PointClassVotes, APointKeepsTheClassMostKeyFramesGaveIt) {
  Scene s;
  LtdaParams p;
  PointClassVotes votes;
  // Three keyframes label the plant; each makes a plant candidate of its 12 points.
  for (int k = 0; k < 3; k++) {
    const auto c = objectCandidates(*s.keyframe(k, kPlant), p, nullptr, votes);
    EXPECT_EQ(plantPointsIn(c, kPlant, s), 12u);
    EXPECT_EQ(plantPointsIn(c, kDesk, s), 0u);
  }
  EXPECT_EQ(votes.votes(*s.pts[0], kPlant), 3);
  // The fourth misses the plant: the desk's box labels its keypoints.
  auto kf = s.keyframe(3, kDesk);
  // Without the votes the desk gets the plant's points (its candidates hold them) ...
  EXPECT_EQ(plantPointsIn(objectCandidates(*kf, p), kDesk, s), 12u);
  // ... with them, the plant's points stay the plant's (3 votes against 1):
  // left out of this keyframe's candidates, or (follow) the plant's candidate.
  PointClassVotes follow = votes;
  const auto c = objectCandidates(*kf, p, nullptr, votes);
  EXPECT_EQ(votes.votes(*s.pts[0], kDesk), 1);
  EXPECT_EQ(plantPointsIn(c, kDesk, s), 0u);
  EXPECT_EQ(plantPointsIn(c, kPlant, s), 0u);
  for (const auto& cand : c) {  // the desk's candidate is the desk's points alone
    if (cand.class_id != kDesk) continue;
    EXPECT_EQ(cand.points.size(), static_cast<size_t>(kPoints - kPlantPoints));
  }
  const auto cf = objectCandidates(*kf, p, nullptr, follow, true);
  EXPECT_EQ(plantPointsIn(cf, kDesk, s), 0u);
  EXPECT_EQ(plantPointsIn(cf, kPlant, s), 12u);
  EXPECT_EQ(votes.classOf(*s.pts[0], kDesk), kPlant);
  EXPECT_EQ(votes.classOf(*s.pts[kPlantPoints], kPlant), kDesk);  // a desk point stays a desk point
}

TEST(PointClassVotes, ATieGoesToTheKeyFramesLabel) {
  Scene s;
  LtdaParams p;
  PointClassVotes votes;
  // Made in a keyframe that missed the plant: its points start as the desk's ...
  EXPECT_EQ(plantPointsIn(objectCandidates(*s.keyframe(0, kDesk), p, nullptr, votes), kDesk, s), 12u);
  // ... the next keyframe sees the plant: one vote each, its label wins.
  auto c = objectCandidates(*s.keyframe(1, kPlant), p, nullptr, votes);
  EXPECT_EQ(plantPointsIn(c, kPlant, s), 12u);
  EXPECT_EQ(plantPointsIn(c, kDesk, s), 0u);
  // A keyframe without a label for them: the class it was created with,
  // unless the votes say otherwise (one each: the desk, it was created so).
  auto kf = s.keyframe(2, -1);
  c = objectCandidates(*kf, p, nullptr, votes);
  EXPECT_EQ(plantPointsIn(c, kDesk, s), 12u);
  // Two plant votes against one: not the desk's, whatever it was created
  // with (follow: the plant's).
  objectCandidates(*s.keyframe(3, kPlant), p, nullptr, votes);
  kf = s.keyframe(4, -1);
  PointClassVotes follow = votes;
  c = objectCandidates(*kf, p, nullptr, votes);
  EXPECT_EQ(plantPointsIn(c, kDesk, s), 0u);
  EXPECT_EQ(plantPointsIn(c, kPlant, s), 0u);
  EXPECT_EQ(plantPointsIn(objectCandidates(*kf, p, nullptr, follow, true), kPlant, s), 12u);
  EXPECT_EQ(votes.votes(*s.pts[0], kPlant), 2);
  // Dynamic keypoints and keypoints of no object class cast no vote.
  kf = s.keyframe(5, kDesk);
  for (auto& m : kf->meta)
    if (m.class_id == kDesk) m.label = KpLabel::Dynamic;
  objectCandidates(*kf, p, nullptr, votes);
  EXPECT_EQ(votes.votes(*s.pts[0], kDesk), 1);
  EXPECT_EQ(votes.votes(*s.pts[0], -1), 0);
}

TEST(PointClassVotes, PointsGoneAreDropped) {
  Scene s;
  LtdaParams p;
  PointClassVotes votes;
  objectCandidates(*s.keyframe(0, kPlant), p, nullptr, votes);
  EXPECT_EQ(votes.size(), static_cast<size_t>(kPoints));
  for (int i = 0; i < 5; i++) s.pts[i]->bad = true;
  votes.prune();
  EXPECT_EQ(votes.size(), static_cast<size_t>(kPoints - 5));
}
