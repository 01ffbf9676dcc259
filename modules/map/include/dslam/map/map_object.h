#pragma once
/** \file map_object.h
 *  Objects of the semantic map (Changing-SLAM's MapObjects) and their
 *  long-term data association.
 *
 *  A MapObject groups the map points created on one detected object: its
 *  class (COCO id), centroid (mean of its points, or of those near their
 *  per-axis median: `centroid_radius`), 3D box (per axis, the
 *  median of the 5% smallest and of the 5% largest coordinates: robust to
 *  a few stray points), first and latest 2D box, the belief that it is still
 *  there and whether its points are active. Objects live in their Map
 *  (kept across merges, saved with the atlas).
 *
 *  Long-term data association (Changing-SLAM, Algorithm 1): each new
 *  keyframe's labelled points are grouped into object candidates; a
 *  candidate is merged into the existing object of the same class whose
 *  centroid is closest and nearer than `ltda_threshold` (points combined),
 *  otherwise it becomes a new object. Ours: a candidate that shares map
 *  points with an object of its class is that object, wherever its partial
 *  view puts the centroid. Changes of belief are the map
 *  manager's (persistence filters, dslam/map/persistence.h). */
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "dslam/core/object_confirmed.h"
#include "dslam/map/map_point.h"

namespace dslam {

class KeyFrame;

struct MapObject {
  int64_t id = -1;
  int class_id = -1;                          ///< COCO category id
  std::map<int64_t, MapPointPtr> points;      ///< by point id (deterministic order)
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Vector3d box_min = Eigen::Vector3d::Zero(), box_max = Eigen::Vector3d::Zero();
  cv::Rect2f first_box, current_box;          ///< image boxes of the first and latest sighting
  double belief = 0.5;                        ///< P(still there)
  bool active = true;                         ///< its points take part in tracking, BA, loops
  bool dormant = false;                       ///< inactive until seen again, belief kept (persistence filter)
  int64_t first_seen_kf = -1, last_seen_kf = -1;
  double first_seen_t = 0, last_seen_t = 0;
  int sightings = 0;                          ///< keyframes that saw it
  double centroid_radius = 0;                 ///< > 0: centroid = mean of the points within this distance (m)
                                              ///< of their per-axis median (robust to points of an occluder
                                              ///< that joined it; ours); 0 = mean of all (Changing-SLAM)

  /** Drops bad points (follows fused ones) and points another object took
   *  (a point is in one object), recomputes centroid (`centroid_radius`)
   *  and box. Returns the number of points left. */
  size_t refresh();
  size_t numPoints() const { return points.size(); }
  /** Corner k (0-7) of the 3D box: bit 0 picks max x, bit 1 max y, bit 2 max z. */
  Eigen::Vector3d corner(int k) const {
    return {k & 1 ? box_max.x() : box_min.x(), k & 2 ? box_max.y() : box_min.y(), k & 4 ? box_max.z() : box_min.z()};
  }
  /** Whether `x` lies in the 3D box (faces included). */
  bool contains(const Eigen::Vector3d& x) const {
    return (x.array() >= box_min.array()).all() && (x.array() <= box_max.array()).all();
  }
  /** Confirmed for the semantic map output: seen by at least `min_sightings`
   *  keyframes, or of at least `confirm_points` points (0 = no such
   *  exception). Others are tentative (`outputs.objects_min_sightings`). */
  bool confirmed(int min_sightings, size_t confirm_points) const {
    return objectConfirmed(sightings, numPoints(), min_sightings, confirm_points);
  }
  /** Sets `active` on the object and on every one of its points. */
  void setActive(bool a);
  /** Makes `mp` one of its points: the point records the object and takes
   *  its `active` flag. */
  void addPoint(const MapPointPtr& mp);
};

using MapObjectPtr = std::shared_ptr<MapObject>;

/** Per axis: the median of the `fraction` smallest and of the `fraction`
 *  largest coordinates (at least one point each), and with `median` the
 *  median of all (an even count: the mean of the middle two). Empty input:
 *  zeros. */
void robustBox(const std::vector<Eigen::Vector3d>& pts, Eigen::Vector3d& lo, Eigen::Vector3d& hi,
               double fraction = 0.05, Eigen::Vector3d* median = nullptr);

/** Points of one keyframe that belong to one object. */
struct ObjectCandidate {
  int class_id = -1;
  int source_id = -1;  ///< the classifier's object / instance id (-1 = none)
  std::vector<MapPointPtr> points;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  cv::Rect2f box;      ///< image box of its keypoints
};

/** Highest COCO id of a "thing" (1-91); panoptic stuff classes are 92+. */
constexpr int kLastCocoThing = 91;

struct LtdaParams {
  double threshold_m = 0.25;      ///< same class and centroids closer than this: the same object
  double cluster_m = 0.3;         ///< points without an instance id: one candidate per cluster of this radius
  int min_points = 5;             ///< smaller candidates are ignored
  size_t min_shared_points = 3;   ///< a candidate with this many of an object's points is that object
  bool dormant_by_distance = true;  ///< a dormant object may be associated by centroid distance alone (false:
                                    ///< only by shared points; its points found again still wake it)
  double centroid_radius = 0;     ///< new objects' MapObject::centroid_radius (0 = mean of all points)
  std::vector<int> classes;       ///< classes that make objects ([] = every COCO thing, ids 1-91, except ignore_classes)
  std::vector<int> ignore_classes{1};  ///< never objects (people move; they are dynamic, not changing)
};

/** Whether keypoints of class `c` make objects: a COCO thing (or one of
 *  `classes`), not one of `ignore_classes`. */
bool isObjectClass(int c, const LtdaParams& p);

/** The object candidates of a keyframe: its map points whose keypoints carry
 *  a class (KeypointMeta of the keyframe or the point's own class), grouped
 *  by (class, instance id), points without an instance id clustered.
 *  Candidates with fewer than `min_points` points are dropped or, with
 *  `small`, put there, made of the points labelled with the class in this
 *  keyframe only (for SmallCandidatePool). */
std::vector<ObjectCandidate> objectCandidates(const KeyFrame& kf, const LtdaParams& p,
                                             std::vector<ObjectCandidate>* small = nullptr);

/** Candidates too small for an object (fewer than `min_points`, put into
 *  `small` by objectCandidates), kept for a few keyframes so that the views
 *  of a small or barely visible object add up (ours, beyond Changing-SLAM:
 *  an object at the image border or mostly hidden shows 3-4 labelled points
 *  per keyframe, each view alone too few). A small candidate joins the kept
 *  one of its class and map whose centroid (from the points' current
 *  positions) is nearest within the LTDA threshold; when their distinct
 *  points reach `min_points` they become one candidate. */
class SmallCandidatePool {
 public:
  /** Adds the small candidates of keyframe `kf_id` of map `map_id`, forgets
   *  kept ones not joined in the last `keyframes` keyframes (of any map;
   *  keyframe ids grow), and returns the joined ones that reached
   *  `p.min_points`, taken out of the pool. Reads the points of map
   *  `map_id` only: call with its update lock held. */
  std::vector<ObjectCandidate> add(std::vector<ObjectCandidate> small, int64_t map_id, int64_t kf_id, int keyframes,
                                   const LtdaParams& p);
  /** Forgets the kept candidates of one map (tracking lost: the old views
   *  are not added to new ones). */
  void clear(int64_t map_id);
  size_t size() const { return kept_.size(); }

 private:
  struct Kept {
    ObjectCandidate cand;
    int64_t map_id = -1, last_kf = -1;
  };
  std::vector<Kept> kept_;
};

/** Points of a missed object (ours, beyond Changing-SLAM). */
struct MissedObjectParams {
  int recent_keyframes = 3;     ///< the object was seen in one of this many last keyframes (0 = off)
  int min_sightings = 2;        ///< ... by at least this many keyframes in all (established)
  double radius_m = 0.1;        ///< candidate points this near one of its points are its points too
  double max_fraction = 0.5;    ///< no drop when the candidate holds this fraction of its points or more
};

/** When the detector misses an object B for a keyframe, the box of an
 *  object of another class overlapping it labels B's keypoints with that
 *  class, and the candidate made of them takes B's points (a chair in front
 *  of a backpack becomes a "backpack" at the backpack's old place when the
 *  backpack has moved behind it). Takes out of each candidate the points of
 *  an active, not dormant object B of another class, seen by at least
 *  `min_sightings` keyframes and in one of the last `recent_keyframes`
 *  (before `kf_id`), when `detected(B's class, candidate box)` says no
 *  detection of B's class overlaps the candidate's image box; also the
 *  candidate's points within `radius_m` of one of B's points (new points
 *  made on B in this keyframe). Unless the candidate holds `max_fraction`
 *  of B's points or more: then B is more likely a wrong object made of the
 *  candidate's thing, which association lets the candidate take back.
 *  Centroids of the candidates are recomputed (image boxes kept); candidates left
 *  with fewer than `min_points` points are erased. Returns the number of
 *  points taken out. */
size_t dropMissedObjectPoints(std::vector<ObjectCandidate>& candidates,
                              const std::map<int64_t, MapObjectPtr>& objects, int64_t kf_id,
                              const std::function<bool(int, const cv::Rect2f&)>& detected,
                              const MissedObjectParams& p, int min_points);

/** What long-term data association did with one candidate. */
struct LtdaMatch {
  size_t candidate = 0;
  int64_t object = -1;
  bool created = false;
  double distance = 0;               ///< centroid distance to the object it was merged into
  int64_t previous_seen_kf = -1;     ///< the object's last sighting before this one (-1: created now)
  double previous_seen_t = 0;        ///< its time (0: created now)
};

/** Algorithm 1: merges each candidate into the nearest same-class object
 *  within the threshold (nearest first, one candidate per object), or
 *  before that (ours) into the same-class object it shares at least
 *  `min_shared_points` map points with (most shared first), or
 *  creates a new object (id from `next_id`). Marks every map point with its
 *  object id (a point of another object leaves that one: a point is in one
 *  object); sets last_seen / sightings / current_box. Returns one
 *  entry per candidate, in candidate order. */
std::vector<LtdaMatch> associateObjects(std::map<int64_t, MapObjectPtr>& objects,
                                        const std::vector<ObjectCandidate>& candidates, int64_t kf_id, double t,
                                        const LtdaParams& p, int64_t& next_id);

/** Merges objects of one class that are one object seen in parts: the
 *  centroid of one inside the other's 3D box (both `eligible`, both with
 *  min_points). The older object (smaller id) takes the points, sightings
 *  and times of the newer one, which is erased. Returns the merges, one
 *  (kept id, erased id) pair each, in order. */
std::vector<std::pair<int64_t, int64_t>> mergeOverlappingObjects(std::map<int64_t, MapObjectPtr>& objects,
                                                                 const std::function<bool(const MapObject&)>& eligible,
                                                                 size_t min_points = 5);

/** Re-identification of a moved object (ours, beyond Changing-SLAM). */
struct ReidParams {
  int max_descriptor_distance = 50;  ///< ORB distance of a descriptor match
  double ratio = 0.8;                ///< ... and below this fraction of the second best
  double inlier_m = 0.08;            ///< a match within this of the rigid motion is an inlier
  int min_inliers = 8;               ///< fewer: not the same object
  double min_shift_m = 0.25;         ///< a smaller motion is no move (the same place: association's)
  int iterations = 64;               ///< RANSAC hypotheses (3 matches each)
  /** With prior motions (those of objects found moved nearby): this many
   *  matches consistent with one of them, and at least half of the
   *  matches, suffice (0 = priors unused). */
  int prior_min_inliers = 3;
};

/** The rigid motion that takes an object's points onto another's. */
struct ObjectMotion {
  int matches = 0;   ///< descriptor matches
  int inliers = 0;   ///< consistent with `T`
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  double shift = 0;  ///< how far the old centroid moves under (R, t)
  bool moved = false;  ///< min_inliers inliers (or a prior's) and shift >= min_shift_m
  bool from_prior = false;  ///< (R, t) is a prior motion that the matches confirm
};

/** What re-identification compares against in an old object: its usable
 *  points and, as one flat list, the descriptors each may look like (its
 *  distinctive descriptor and up to 6 observation descriptors: the views
 *  before and after a move differ in distance and side). Built once per old
 *  object and compared with every object a keyframe saw. */
struct ReidAppearance {
  std::vector<const MapPoint*> points;
  std::vector<const uint8_t*> rows;  ///< descriptors (32 bytes each)
  std::vector<size_t> row_point;     ///< index into points of each row
};
ReidAppearance reidAppearance(const MapObject& old);

/** Whether `seen` is `old` moved: descriptor matches between their points
 *  (the distinctive descriptor of each point of `seen` against those of
 *  `old`'s points and of up to 6 of their observations; best under
 *  max_descriptor_distance and under `ratio` x the second best point)
 *  that one rigid motion explains (RANSAC on 3 matches, deterministic,
 *  Umeyama on the inliers), moving `old`'s centroid by at least
 *  min_shift_m. Objects of different classes, or sharing map points, are
 *  never one moved. `old_appearance` is reidAppearance(old); the short form
 *  builds it.
 *  `priors`: rigid motions of other objects found moved (objects moved
 *  together, or parts of one object). When the matches are too few for the
 *  object's own motion, prior_min_inliers of them consistent with one prior
 *  (at least half of them) make it moved by that prior: a hypothesis that
 *  needs no RANSAC needs fewer matches to confirm. */
ObjectMotion reidentify(const MapObject& seen, const MapObject& old, const ReidAppearance& old_appearance,
                        const ReidParams& p, const std::vector<ObjectMotion>& priors = {});
ObjectMotion reidentify(const MapObject& seen, const MapObject& old, const ReidParams& p);

}  // namespace dslam
