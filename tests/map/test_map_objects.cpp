// MapObjects: the robust 3D box and long-term data association (Changing-SLAM
// Algorithm 1).
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "dslam/map/map_object.h"

using namespace dslam;

namespace {

/** `n` points around `c` (uniform in a cube of side `s`), ids from `id0`. */
std::vector<MapPointPtr> blob(const Eigen::Vector3d& c, int n, int64_t id0, double s = 0.2, int cls = 62) {
  std::mt19937 rng(static_cast<unsigned>(id0 + 1));
  std::uniform_real_distribution<double> u(-s / 2, s / 2);
  std::vector<MapPointPtr> out;
  for (int i = 0; i < n; i++) {
    auto p = std::make_shared<MapPoint>(id0 + i, c + Eigen::Vector3d(u(rng), u(rng), u(rng)), nullptr, nullptr);
    p->class_id = static_cast<int16_t>(cls);
    out.push_back(p);
  }
  return out;
}

ObjectCandidate candidate(int cls, const std::vector<MapPointPtr>& pts) {
  ObjectCandidate c;
  c.class_id = cls;
  c.points = pts;
  for (const auto& p : pts) c.centroid += p->pos;
  c.centroid /= static_cast<double>(pts.size());
  c.box = cv::Rect2f(10, 20, 30, 40);
  return c;
}

}  // namespace

TEST(MapObject, RobustBoxIgnoresAFewStrayPoints) {
  std::vector<Eigen::Vector3d> pts;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 400; i++) pts.emplace_back(u(rng), 2 + u(rng), -1 + 0.5 * u(rng));
  pts.emplace_back(10, 10, 10);  // two stray points (e.g. background behind the object)
  pts.emplace_back(-9, -9, -9);
  Eigen::Vector3d lo, hi;
  robustBox(pts, lo, hi);
  // 5% of 402 = 20 points per side: the median of the 20 extremes is ~2.5% in.
  EXPECT_NEAR(lo.x(), 0.025, 0.02);
  EXPECT_NEAR(hi.x(), 0.975, 0.02);
  EXPECT_NEAR(lo.y(), 2.025, 0.02);
  EXPECT_NEAR(hi.z(), -0.5125, 0.02);
  // With `median`: the per-axis median of all 402 (the mean of the middle two).
  Eigen::Vector3d med;
  robustBox(pts, lo, hi, 0.05, &med);
  for (int a = 0; a < 3; a++) {
    std::vector<double> v;
    for (const auto& x : pts) v.push_back(x[a]);
    std::sort(v.begin(), v.end());
    EXPECT_EQ(med[a], 0.5 * (v[201] + v[200])) << a;
  }
  EXPECT_NEAR(med.x(), 0.5, 0.05);
  EXPECT_NEAR(med.y(), 2.5, 0.05);
  EXPECT_NEAR(med.z(), -0.75, 0.03);
  robustBox({}, lo, hi, 0.05, &med);
  EXPECT_EQ(lo, Eigen::Vector3d::Zero());
  EXPECT_EQ(med, Eigen::Vector3d::Zero());
}

TEST(MapObject, CentroidNearTheMedianStaysOnTheObjectWhenAnOccludersPointsJoinIt) {
  // A refrigerator's face (200 points, 0.6 x 1.2 m, at depth 2.3-2.35 m)
  // and 80 points of a plant 0.8 m in front of it that joined it (its
  // detection missed, the refrigerator's box labelled them): the mean of
  // all moves 0.24 m off the face; the mean of the points within 0.5 m of
  // the per-axis median stays on it.
  std::map<int64_t, MapObjectPtr> objects;
  LtdaParams p;
  p.centroid_radius = 0.5;
  int64_t next = 1;
  auto face = blob({0, 0, 2.325}, 200, 0, 0.05);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  for (auto& q : face) q->pos = Eigen::Vector3d(u(rng), 2 * u(rng), q->pos.z());
  associateObjects(objects, {candidate(82, face)}, 1, 1.0, p, next);
  const MapObjectPtr o = objects.at(1);
  EXPECT_EQ(o->centroid_radius, 0.5);
  const Eigen::Vector3d alone = o->centroid;
  EXPECT_LT((alone - Eigen::Vector3d(0, 0, 2.325)).norm(), 0.1);
  auto plant = blob({0.1, 0.1, 1.5}, 80, 1000, 0.2, 82);
  std::vector<MapPointPtr> view(face.begin(), face.begin() + 20);
  view.insert(view.end(), plant.begin(), plant.end());
  const auto r = associateObjects(objects, {candidate(82, view)}, 2, 2.0, p, next);  // shared points: the same object
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].object, 1);
  EXPECT_EQ(o->numPoints(), 280u);
  EXPECT_NEAR(o->centroid.z(), 2.325, 0.01);  // on the face, the plant's points left out
  EXPECT_NEAR(o->centroid.x(), alone.x(), 0.05);
  // The mean of all (Changing-SLAM's centroid) of the same points is 0.24 m in front.
  o->centroid_radius = 0;
  o->refresh();
  EXPECT_NEAR(o->centroid.z(), 2.325 - 80.0 / 280.0 * 0.825, 0.01);
  // Every point within the radius of the median: the mean of all.
  MapObject clean;
  clean.centroid_radius = 1.0;  // the face's corners are 0.67 m from its centre
  Eigen::Vector3d mean_all = Eigen::Vector3d::Zero();
  for (const auto& q : face) {
    clean.addPoint(q);
    mean_all += q->pos / 200.0;
  }
  clean.refresh();
  EXPECT_LT((clean.centroid - mean_all).norm(), 1e-12);
  // No point within the radius of the median (two far clusters of one
  // point each): the median itself, the mean of the middle two.
  MapObject two;
  two.centroid_radius = 0.1;
  two.addPoint(std::make_shared<MapPoint>(7, Eigen::Vector3d(0, 0, 1), nullptr, nullptr));
  two.refresh();
  EXPECT_EQ(two.centroid, Eigen::Vector3d(0, 0, 1));
  two.addPoint(std::make_shared<MapPoint>(8, Eigen::Vector3d(1, 2, 3), nullptr, nullptr));
  two.refresh();
  EXPECT_EQ(two.centroid, Eigen::Vector3d(0.5, 1, 2));
}

TEST(MapObject, ConfirmedBySightingsOrByPoints) {
  MapObject o;
  for (const auto& p : blob({0, 0, 2}, 12, 0)) o.addPoint(p);
  o.sightings = 1;
  EXPECT_TRUE(o.confirmed(1, 0));    // the default: every object
  EXPECT_FALSE(o.confirmed(2, 0));   // seen by one keyframe: tentative
  EXPECT_FALSE(o.confirmed(2, 13));  // 12 points < 13
  EXPECT_TRUE(o.confirmed(2, 12));   // ... but 12 points are enough for 12
  o.sightings = 2;
  EXPECT_TRUE(o.confirmed(2, 0));
  EXPECT_FALSE(o.confirmed(3, 0));
}

TEST(MapObject, LongTermDataAssociationMergesNearAndCreatesFar) {
  std::map<int64_t, MapObjectPtr> objects;
  LtdaParams p;  // threshold 0.25 m
  int64_t next = 100;
  auto a = blob({1, 0, 0}, 30, 0);
  auto r = associateObjects(objects, {candidate(62, a)}, /*kf*/ 5, 1.0, p, next);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_TRUE(r[0].created);
  EXPECT_EQ(r[0].object, 100);
  EXPECT_EQ(r[0].previous_seen_kf, -1);
  const MapObject& o = *objects.at(100);
  EXPECT_EQ(o.numPoints(), 30u);
  EXPECT_LT((o.centroid - Eigen::Vector3d(1, 0, 0)).norm(), 0.05);
  EXPECT_EQ(o.first_seen_kf, 5);
  EXPECT_EQ(a[0]->map_object, 100);

  // The same chair 10 cm further (tracking noise), a chair 1 m away and a
  // plant (another class) at the first place, seen by keyframe 9.
  auto b = blob({1.1, 0, 0}, 20, 1000);
  auto c = blob({2.0, 0, 0}, 15, 2000);
  auto d = blob({1.0, 0, 0}, 12, 3000, 0.2, 64);
  r = associateObjects(objects, {candidate(62, b), candidate(62, c), candidate(64, d)}, 9, 2.0, p, next);
  ASSERT_EQ(r.size(), 3u);
  EXPECT_FALSE(r[0].created);
  EXPECT_EQ(r[0].object, 100);
  EXPECT_NEAR(r[0].distance, 0.1, 0.05);
  EXPECT_EQ(r[0].previous_seen_kf, 5);
  EXPECT_TRUE(r[1].created);
  EXPECT_TRUE(r[2].created);
  EXPECT_EQ(objects.size(), 3u);
  EXPECT_EQ(objects.at(100)->numPoints(), 50u);  // points combined
  EXPECT_EQ(objects.at(100)->last_seen_kf, 9);
  EXPECT_EQ(objects.at(100)->sightings, 2);
  EXPECT_EQ(objects.at(r[2].object)->class_id, 64);

  // One object, two candidates within the threshold: the nearer one joins it.
  auto e = blob({1.2, 0, 0}, 10, 4000);
  auto f = blob({1.02, 0.05, 0}, 10, 5000);
  r = associateObjects(objects, {candidate(62, e), candidate(62, f)}, 12, 3.0, p, next);
  EXPECT_EQ(r[1].object, 100);
  EXPECT_TRUE(r[0].created);

  // Bad points leave the object at the next refresh.
  for (int i = 0; i < 10; i++) a[i]->bad = true;
  objects.at(100)->refresh();
  EXPECT_EQ(objects.at(100)->numPoints(), 50u);
  // Deactivation reaches the points.
  objects.at(100)->setActive(false);
  EXPECT_FALSE(b[0]->active);
}

TEST(MapObject, SharedPointsDecideTheObjectWhateverThePartialViewsCentroid) {
  std::map<int64_t, MapObjectPtr> objects;
  LtdaParams p;  // threshold 0.25 m, 3 shared points
  int64_t next = 1;
  // A desk seen first at its left end: 20 points around x = 0.
  auto left = blob({0, 0, 0}, 20, 0, 0.3, 67);
  associateObjects(objects, {candidate(67, left)}, 1, 1.0, p, next);
  ASSERT_EQ(objects.size(), 1u);
  // Later its right end (centroid 0.9 m away) with 4 tracked points of the left end.
  auto right = blob({0.9, 0, 0}, 16, 100, 0.3, 67);
  std::vector<MapPointPtr> view = right;
  view.insert(view.end(), left.begin(), left.begin() + 4);
  auto r = associateObjects(objects, {candidate(67, view)}, 2, 2.0, p, next);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_FALSE(r[0].created);
  EXPECT_EQ(r[0].object, 1);
  EXPECT_EQ(objects.at(1)->numPoints(), 36u);
  // Two shared points are not enough: a new object (centroid too far for Algorithm 1).
  auto far = blob({2.5, 0, 0}, 16, 200, 0.3, 67);
  std::vector<MapPointPtr> view2 = far;
  view2.insert(view2.end(), right.begin(), right.begin() + 2);
  r = associateObjects(objects, {candidate(67, view2)}, 3, 3.0, p, next);
  EXPECT_TRUE(r[0].created);
  // ... and shared points of another class do not count.
  auto plant = blob({0.1, 0, 0}, 10, 300, 0.3, 64);
  std::vector<MapPointPtr> view3 = plant;
  view3.insert(view3.end(), left.begin() + 4, left.begin() + 10);
  r = associateObjects(objects, {candidate(64, view3)}, 4, 4.0, p, next);
  EXPECT_TRUE(r[0].created);
}

TEST(MapObject, ADormantObjectIsAssociatedByDistanceOnlyWithTheOption) {
  for (bool by_distance : {true, false}) {
    std::map<int64_t, MapObjectPtr> objects;
    LtdaParams p;  // threshold 0.25 m, 3 shared points
    p.dormant_by_distance = by_distance;
    int64_t next = 1;
    auto old = blob({1, 0, 0}, 20, 0, 0.2, 28);  // a suitcase
    associateObjects(objects, {candidate(28, old)}, 1, 1.0, p, next);
    ASSERT_EQ(objects.size(), 1u);
    objects.at(1)->dormant = true;  // tracking was lost
    // New points labelled suitcase 0.15 m from its centroid (another thing
    // under a suitcase's box): woken only when distance alone may do it.
    auto near = blob({1.15, 0, 0}, 10, 100, 0.2, 28);
    auto r = associateObjects(objects, {candidate(28, near)}, 2, 2.0, p, next);
    ASSERT_EQ(r.size(), 1u);
    EXPECT_EQ(r[0].created, !by_distance);
    EXPECT_EQ(objects.size(), by_distance ? 1u : 2u);
    // A candidate with 3 of its points is it either way.
    std::vector<MapPointPtr> view = blob({1.1, 0, 0}, 8, 200, 0.2, 28);
    view.insert(view.end(), old.begin(), old.begin() + 3);
    r = associateObjects(objects, {candidate(28, view)}, 3, 3.0, p, next);
    EXPECT_FALSE(r[0].created);
    EXPECT_EQ(r[0].object, 1);
    // Not dormant: distance alone associates with or without the option.
    objects.at(1)->dormant = false;
    r = associateObjects(objects, {candidate(28, blob({1.05, 0, 0}, 10, 300, 0.2, 28))}, 4, 4.0, p, next);
    EXPECT_FALSE(r[0].created);
    EXPECT_EQ(r[0].object, 1);
  }
}

TEST(MapObject, OverlappingPartsOfOneObjectMerge) {
  std::map<int64_t, MapObjectPtr> objects;
  LtdaParams p;
  p.min_shared_points = 1000;  // keep the parts apart at association
  int64_t next = 10;
  auto a = blob({0, 0, 0}, 40, 0, 1.0, 67);      // a 1 m table ...
  auto b = blob({0.3, 0.1, 0}, 10, 100, 0.2, 67);  // ... a part of it, 0.3 m from its centre
  auto c = blob({3, 0, 0}, 10, 200, 0.2, 67);    // another table
  auto d = blob({0.2, 0, 0}, 10, 300, 0.2, 62);  // a chair at the table
  associateObjects(objects, {candidate(67, a)}, 1, 1.0, p, next);
  associateObjects(objects, {candidate(67, b), candidate(67, c), candidate(62, d)}, 2, 2.0, p, next);
  ASSERT_EQ(objects.size(), 4u);
  objects.at(12)->active = false;  // not eligible: left alone even where it overlaps
  const auto merged = mergeOverlappingObjects(objects, [](const MapObject& o) { return o.active; });
  ASSERT_EQ(merged.size(), 1u);
  EXPECT_EQ(merged[0], std::make_pair(int64_t{10}, int64_t{11}));  // (kept, erased)
  ASSERT_EQ(objects.size(), 3u);
  EXPECT_EQ(objects.at(10)->numPoints(), 50u);  // the older id keeps both
  EXPECT_EQ(objects.at(10)->sightings, 2);
  EXPECT_EQ(objects.at(10)->last_seen_kf, 2);
  EXPECT_EQ(b[0]->map_object, 10);
  EXPECT_TRUE(objects.count(12));  // the far table
  EXPECT_TRUE(objects.count(13));  // the chair: another class
}

namespace {

/** An object of class `cls` made of `pts`, each with a random descriptor
 *  (seed `seed`) unless `desc` gives them. */
MapObject objectOf(int cls, const std::vector<MapPointPtr>& pts, unsigned seed) {
  MapObject o;
  o.class_id = cls;
  std::mt19937 rng(seed);
  for (const auto& p : pts) {
    for (auto& b : p->desc) b = static_cast<uint8_t>(rng() & 0xff);
    o.points[p->id] = p;
  }
  o.refresh();
  return o;
}

/** Copies of `pts` (new ids from `id0`) moved by (R, t), with the same
 *  descriptors but `flip` bits changed. */
std::vector<MapPointPtr> movedCopy(const std::vector<MapPointPtr>& pts, const Eigen::Matrix3d& R,
                                   const Eigen::Vector3d& t, int64_t id0, int flip = 6) {
  std::vector<MapPointPtr> out;
  std::mt19937 rng(99);
  std::normal_distribution<double> noise(0, 0.01);
  for (size_t i = 0; i < pts.size(); i++) {
    auto p = std::make_shared<MapPoint>(id0 + static_cast<int64_t>(i),
                                        R * pts[i]->pos + t + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)),
                                        nullptr, nullptr);
    p->class_id = pts[i]->class_id;
    p->desc = pts[i]->desc;
    for (int k = 0; k < flip; k++) p->desc[rng() % 32] ^= static_cast<uint8_t>(1u << (rng() % 8));
    out.push_back(p);
  }
  return out;
}

}  // namespace

TEST(MapObject, ReidentifiesAnObjectMovedRigidlyOnly) {
  auto a = blob({0, 0, 2}, 40, 0, 0.4);
  const MapObject old = objectOf(62, a, 1);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d t(0.6, 0, 0.2);
  // Moved 0.6 m and turned 23 degrees, with 10 points of something else.
  auto moved = movedCopy(std::vector<MapPointPtr>(a.begin(), a.begin() + 30), R, t, 1000);
  auto clutter = blob({0.6, 0, 2}, 10, 2000, 0.4);
  MapObject seen = objectOf(62, clutter, 2);
  for (const auto& p : moved) seen.points[p->id] = p;
  seen.refresh();
  ReidParams p;  // 8 inliers within 8 cm, at least 0.25 m
  const ObjectMotion m = reidentify(seen, old, p);
  EXPECT_TRUE(m.moved);
  EXPECT_GE(m.inliers, 28);
  EXPECT_LE(m.matches, 32);  // the clutter's random descriptors rarely match
  EXPECT_NEAR(m.shift, (R * old.centroid + t - old.centroid).norm(), 0.02);
  EXPECT_LT((m.R * old.centroid + m.t - (R * old.centroid + t)).norm(), 0.02);
  // Another class, or fewer matches than min_inliers: not it.
  MapObject other_class = seen;
  other_class.class_id = 63;
  EXPECT_FALSE(reidentify(other_class, old, p).moved);
  p.min_inliers = 31;
  EXPECT_FALSE(reidentify(seen, old, p).moved);
  p = ReidParams{};
  // The same appearance at the same place is no move (association's business).
  const MapObject in_place = objectOf(62, movedCopy(a, Eigen::Matrix3d::Identity(), {0.1, 0, 0}, 3000), 0);
  MapObject same_place = in_place;
  for (auto& [id, q] : same_place.points) q->desc = a[static_cast<size_t>(id - 3000)]->desc;
  EXPECT_FALSE(reidentify(same_place, old, p).moved);
  // The descriptors match but no rigid motion explains the positions: not one object.
  auto shuffled = movedCopy(a, R, t, 4000, 0);
  std::mt19937 rng(5);
  for (size_t i = shuffled.size() - 1; i > 0; i--) std::swap(shuffled[i]->pos, shuffled[rng() % (i + 1)]->pos);
  MapObject scrambled;
  scrambled.class_id = 62;
  for (const auto& q : shuffled) scrambled.points[q->id] = q;
  scrambled.refresh();
  const ObjectMotion s = reidentify(scrambled, old, p);
  EXPECT_GE(s.matches, 35);
  EXPECT_FALSE(s.moved);
  EXPECT_LT(s.inliers, 8);
  // Objects sharing a map point are parts of one.
  MapObject sharing = seen;
  sharing.points[a[0]->id] = a[0];
  EXPECT_FALSE(reidentify(sharing, old, p).moved);
}

TEST(MapObject, ReidentifiesASmallObjectMoved) {
  // The face of a suitcase: 10 points on a 15 x 15 cm patch (no triangle of
  // them spans more than 0.012 m^2), moved 0.6 m sideways. Hypotheses are
  // not bounded by the triangle's size, only by its shape.
  auto face = blob({0.9, 0.45, 2.2}, 10, 0, 0.15, 33);
  for (auto& q : face) q->pos.z() = 2.2 + 0.1 * (q->pos.z() - 2.2);
  const MapObject old = objectOf(33, face, 3);
  MapObject seen;
  seen.class_id = 33;
  for (const auto& q : movedCopy(face, Eigen::Matrix3d::Identity(), {-0.6, 0, 0}, 100)) seen.points[q->id] = q;
  seen.refresh();
  const ObjectMotion m = reidentify(seen, old, ReidParams{});
  EXPECT_TRUE(m.moved);
  EXPECT_GE(m.inliers, 9);
  EXPECT_NEAR(m.shift, 0.6, 0.03);
  // Collinear points fix no rotation: no hypothesis, no move.
  for (size_t i = 0; i < face.size(); i++) face[i]->pos = Eigen::Vector3d(0.9 + 0.015 * static_cast<double>(i), 0.45, 2.2);
  const MapObject line = objectOf(33, face, 3);
  MapObject line_seen;
  line_seen.class_id = 33;
  for (const auto& q : movedCopy(face, Eigen::Matrix3d::Identity(), {-0.6, 0, 0}, 200, 6)) {
    q->pos = Eigen::Vector3d(q->pos.x(), 0.45, 2.2);  // on the line exactly
    line_seen.points[q->id] = q;
  }
  line_seen.refresh();
  EXPECT_FALSE(reidentify(line_seen, line, ReidParams{}).moved);
}

TEST(MapObject, ReidentifiesAPartWithTooFewMatchesByTheMotionOfAnObjectMovedNearIt) {
  // A 6-point part of a suitcase whose views before and after the move share
  // only 4 descriptor matches: too few for a motion of its own (8), enough
  // to confirm the motion found for the refrigerator next to it.
  auto part = blob({0.6, 0.1, 2.2}, 6, 0, 0.2, 33);
  const MapObject old = objectOf(33, part, 7);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d t(-0.6, 0, 0.05);
  auto moved = movedCopy(part, R, t, 100);
  for (size_t i = 4; i < moved.size(); i++)  // two of them look different after the move
    for (auto& b : moved[i]->desc) b = static_cast<uint8_t>(~b);
  MapObject seen;
  seen.class_id = 33;
  for (const auto& q : moved) seen.points[q->id] = q;
  seen.refresh();
  ReidParams p;  // min_inliers 8, prior_min_inliers 3
  EXPECT_FALSE(reidentify(seen, old, p).moved);  // no priors: 6 points, fewer than min_inliers
  ObjectMotion fridge;  // the neighbour's motion
  fridge.R = R, fridge.t = t + Eigen::Vector3d(0.01, 0, 0.01);
  ObjectMotion elsewhere;  // another object's motion, 0.5 m another way
  elsewhere.t = {0, 0, 0.5};
  const ObjectMotion m = reidentify(seen, old, reidAppearance(old), p, {elsewhere, fridge});
  EXPECT_TRUE(m.moved);
  EXPECT_TRUE(m.from_prior);
  EXPECT_EQ(m.inliers, 4);
  EXPECT_NEAR(m.shift, (R * old.centroid + t - old.centroid).norm(), 0.02);
  // A prior the matches do not confirm, or priors off: not moved.
  const ObjectMotion e = reidentify(seen, old, reidAppearance(old), p, {elsewhere});
  EXPECT_EQ(e.matches, 4);
  EXPECT_FALSE(e.moved);
  p.prior_min_inliers = 0;
  EXPECT_FALSE(reidentify(seen, old, reidAppearance(old), p, {fridge}).moved);
  p.prior_min_inliers = 5;  // more than the 4 matches
  EXPECT_FALSE(reidentify(seen, old, reidAppearance(old), p, {fridge}).moved);
  // Another class: never, whatever the priors.
  p = ReidParams{};
  MapObject other = seen;
  other.class_id = 62;
  EXPECT_FALSE(reidentify(other, old, reidAppearance(old), p, {fridge}).moved);
}

TEST(MapObject, SmallViewsOfOneObjectAddUpToACandidate) {
  LtdaParams p;  // min_points 5, threshold 0.25 m
  SmallCandidatePool pool;
  // Keyframe 10: 3 points of a chair at (1, 0, 3) and 2 of a tv far from it.
  auto chair_a = blob({1, 0, 3}, 3, 0, 0.1);
  auto tv = blob({-1, 0, 3}, 2, 10, 0.1, 72);
  EXPECT_TRUE(pool.add({candidate(62, chair_a), candidate(72, tv)}, 0, 10, 5, p).empty());
  EXPECT_EQ(pool.size(), 2u);
  // Keyframe 10 again cannot add to itself: one view is one view.
  EXPECT_TRUE(pool.add({candidate(62, blob({1, 0.2, 3}, 3, 20, 0.05))}, 0, 10, 5, p).empty());
  EXPECT_EQ(pool.size(), 3u);
  // Keyframe 12: 3 more chair points 0.05 m away, one of them seen before:
  // 5 distinct points make one candidate of the chair class.
  auto chair_b = blob({1.05, 0, 3}, 2, 30, 0.1);
  chair_b.push_back(chair_a[0]);
  const auto made = pool.add({candidate(62, chair_b)}, 0, 12, 5, p);
  ASSERT_EQ(made.size(), 1u);
  EXPECT_EQ(made[0].class_id, 62);
  EXPECT_EQ(made[0].points.size(), 5u);
  EXPECT_NEAR(made[0].centroid.x(), 1.02, 0.06);
  // Another class at the same place, or the same class 0.5 m away, does not join.
  EXPECT_TRUE(pool.add({candidate(72, blob({1, 0, 3}, 3, 40, 0.1, 72))}, 0, 13, 5, p).empty());
  EXPECT_TRUE(pool.add({candidate(62, blob({1.5, 0, 3}, 3, 50, 0.1))}, 0, 13, 5, p).empty());
  // Nor does the same class of another map.
  EXPECT_TRUE(pool.add({candidate(72, blob({-1, 0, 3}, 3, 60, 0.1, 72))}, 1, 14, 5, p).empty());
  // The tv of keyframe 10 is forgotten after 5 keyframes: 3 more points at
  // keyframe 16 make no candidate with its 2.
  EXPECT_TRUE(pool.add({candidate(72, blob({-1, 0, 3}, 3, 70, 0.1, 72))}, 0, 16, 5, p).empty());
  // A map's views are dropped when its tracking is lost.
  const size_t before = pool.size();
  pool.clear(0);
  EXPECT_LT(pool.size(), before);
  EXPECT_EQ(pool.size(), 1u);  // map 1's tv
}

// A map point is in one object. When the detector misses an object for a
// frame, the box behind it takes its keypoints (a plant in front of a desk
// becomes "desk" in that view) and an object of the wrong class gets its
// points; when a later candidate of the right class takes them, they leave
// the wrong object: its centroid and box no longer hold them, and
// deactivating it (the desk judged gone) leaves the plant's points active.
TEST(MapObject, APointTakenByAnotherObjectLeavesTheOneItWasIn) {
  constexpr int kPlant = 64, kDesk = 67;
  LtdaParams p;
  std::map<int64_t, MapObjectPtr> objects;
  int64_t next_id = 0;
  auto desk = blob({0, 0, 4}, 10, 0, 0.3, kDesk);
  auto plant = blob({0, 0, 3}, 12, 100, 0.2, kPlant);
  // Keyframe 1: the plant's box missed: 4 plant points labelled desk.
  std::vector<MapPointPtr> wrong = desk;
  wrong.insert(wrong.end(), plant.begin(), plant.begin() + 4);
  auto m1 = associateObjects(objects, {candidate(kDesk, wrong)}, 1, 1.0, p, next_id);
  ASSERT_EQ(m1.size(), 1u);
  MapObject& d = *objects.at(m1[0].object);
  EXPECT_EQ(d.numPoints(), 14u);
  EXPECT_LT(d.box_min.z(), 3.2);  // stretched to the plant
  // Keyframe 2: the plant's box is back; its candidate takes its 4 points.
  auto m2 = associateObjects(objects, {candidate(kPlant, plant)}, 2, 2.0, p, next_id);
  ASSERT_EQ(m2.size(), 1u);
  ASSERT_TRUE(m2[0].created);
  MapObject& pl = *objects.at(m2[0].object);
  EXPECT_EQ(pl.numPoints(), 12u);
  EXPECT_EQ(d.numPoints(), 10u);
  for (const auto& mp : plant) {
    EXPECT_EQ(mp->map_object, pl.id);
    EXPECT_EQ(d.points.count(mp->id), 0u);
  }
  EXPECT_GT(d.box_min.z(), 3.8);  // the desk's own points only
  EXPECT_NEAR(d.centroid.z(), 4.0, 0.1);
  d.setActive(false);
  for (const auto& mp : plant) EXPECT_TRUE(mp->active);
  for (const auto& mp : desk) EXPECT_FALSE(mp->active);
  // An object listing a point another object holds (an atlas written before
  // this rule) drops it when refreshed.
  d.points[plant[0]->id] = plant[0];
  EXPECT_EQ(d.refresh(), 10u);
  EXPECT_EQ(plant[0]->map_object, pl.id);
}

// The detector misses a chair for a keyframe; the backpack's box behind it
// labels the chair's keypoints "backpack". The backpack candidate leaves out
// the chair object's points and the new points made on the chair, unless the
// chair is labelled in its box, or was not seen lately, or is of its class,
// or is mostly the candidate's (then a wrong object the candidate takes back).
TEST(MapObject, AMissedObjectsPointsAreLeftOutOfAnotherClassCandidate) {
  constexpr int kChair = 62, kBackpack = 27;
  std::map<int64_t, MapObjectPtr> objects;
  int64_t next_id = 0;
  auto chair = blob({0, 0, 2}, 20, 0, 0.3, kChair);
  LtdaParams lp;
  associateObjects(objects, {candidate(kChair, chair)}, 8, 8.0, lp, next_id);
  associateObjects(objects, {candidate(kChair, chair)}, 9, 9.0, lp, next_id);
  ASSERT_EQ(objects.size(), 1u);
  MapObject& c = *objects.begin()->second;
  ASSERT_EQ(c.sightings, 2);
  // New points on the chair (within 0.1 m of one of its points) and the backpack's own.
  std::vector<MapPointPtr> near_chair;
  for (int k = 0; k < 2; k++) {
    auto q = std::make_shared<MapPoint>(200 + k, chair[k]->pos + Eigen::Vector3d(0.03, 0, 0), nullptr, nullptr);
    near_chair.push_back(q);
  }
  auto backpack = blob({0, 0, 2.6}, 6, 100, 0.2, kBackpack);
  auto make = [&](size_t chair_points) {
    std::vector<MapPointPtr> pts(chair.begin(), chair.begin() + static_cast<long>(chair_points));
    pts.insert(pts.end(), near_chair.begin(), near_chair.end());
    pts.insert(pts.end(), backpack.begin(), backpack.end());
    return std::vector<ObjectCandidate>{candidate(kBackpack, pts)};
  };
  auto nothing = [](int, const cv::Rect2f&) { return false; };
  MissedObjectParams mp;  // 3 keyframes, 2 sightings, 0.1 m, half
  auto cands = make(6);
  EXPECT_EQ(dropMissedObjectPoints(cands, objects, 10, nothing, mp, 5), 8u);
  ASSERT_EQ(cands.size(), 1u);
  EXPECT_EQ(cands[0].points, backpack);
  EXPECT_NEAR(cands[0].centroid.z(), 2.6, 0.1);
  // The chair detected over the candidate's box: not missed, its points stay in the candidate.
  auto chair_seen = [&](int cls, const cv::Rect2f&) { return cls == kChair; };
  cands = make(6);
  EXPECT_EQ(dropMissedObjectPoints(cands, objects, 10, chair_seen, mp, 5), 0u);
  EXPECT_EQ(cands[0].points.size(), 14u);
  // Not seen in the last 3 keyframes, or off: nothing left out.
  cands = make(6);
  EXPECT_EQ(dropMissedObjectPoints(cands, objects, 13, nothing, mp, 5), 0u);
  MissedObjectParams off = mp;
  off.recent_keyframes = 0;
  EXPECT_EQ(dropMissedObjectPoints(cands, objects, 10, nothing, off, 5), 0u);
  // Half of the chair's points or more in the candidate: kept.
  cands = make(10);
  EXPECT_EQ(dropMissedObjectPoints(cands, objects, 10, nothing, mp, 5), 0u);
  // Only the chair's points: the candidate is dropped.
  cands = {candidate(kBackpack, std::vector<MapPointPtr>(chair.begin(), chair.begin() + 6))};
  EXPECT_EQ(dropMissedObjectPoints(cands, objects, 10, nothing, mp, 5), 6u);
  EXPECT_TRUE(cands.empty());
  // A candidate of the chair's own class keeps them.
  cands = {candidate(kChair, std::vector<MapPointPtr>(chair.begin(), chair.begin() + 6))};
  EXPECT_EQ(dropMissedObjectPoints(cands, objects, 10, nothing, mp, 5), 0u);
}
