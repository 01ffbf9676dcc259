#pragma once
/** \file persistence_filters.h
 *  Persistence filters as map managers (issue 12, docs/changing.md). Both
 *  wrap the map manager listed before them (an Atlas by default) and decide
 *  which map points are active: inactive points take no part in tracking,
 *  local BA, relocalisation, loop detection or map merging.
 *
 *  dslam::ObjectPersistenceFilter (Changing-SLAM, sections 4.5-4.8): on each
 *  keyframe, object candidates from its labelled points, long-term data
 *  association into MapObjects, a Bayes belief per object (raised by
 *  sightings after a long absence, lowered by negative evidence: its place
 *  in view, not occluded, nothing of its class there, or its own points in
 *  view and not found again); below
 *  `belief_threshold` its points are inactive. Beyond the paper: objects
 *  not confirmed for `dormant_after_s` seconds, or when tracking is lost,
 *  are dormant (inactive, belief kept) until a keyframe sees them again, so
 *  an object moved while out of view cannot pull relocalisation, loop
 *  closure or map merging to its old place; and an object not seen for long
 *  whose appearance a keyframe shows elsewhere, displaced by one rigid
 *  motion (re-identification), loses belief at its old place.
 *
 *  dslam::PointPersistenceFilter (Rosen et al. 2016, as Hashemifar and Dantu
 *  put it into ORB-SLAM): a feature persistence filter per map point of no
 *  object; a keyframe that should see a point (projects inside the image,
 *  in range, not occluded by closer keypoints) and does not is a miss; below
 *  `belief_threshold` the point is inactive; a descriptor match in a later
 *  keyframe re-activates it. */
#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "dslam/map/class_votes.h"
#include "dslam/map/filtering_map_manager.h"
#include "dslam/map/map_object.h"
#include "dslam/map/persistence.h"

namespace dslam {

/** What a persistence filter did (summary.json, tests). */
struct PersistenceStats {
  int64_t keyframes = 0;
  int64_t created = 0;      ///< objects created (object filter)
  int64_t sightings = 0;    ///< belief raised (long-term sightings; points: seen)
  int64_t misses = 0;       ///< negative evidence applied
  int64_t deactivated = 0;  ///< objects / points put below the threshold
  int64_t reactivated = 0;  ///< brought back above it
  int64_t dormant = 0;      ///< objects made dormant (not confirmed for long, tracking lost)
  int64_t woken = 0;        ///< dormant objects confirmed again
  int64_t keyframe_requests = 0;  ///< keyframes asked for unmapped objects in view
  int64_t place_requests = 0;     ///< keyframes asked for places of objects not seen for long
  int64_t merged = 0;             ///< objects merged into another (partial views of one object)
  int64_t reidentified = 0;       ///< objects whose appearance was seen elsewhere (moved)
  int64_t reidentified_by_prior = 0;  ///< ... of them, confirmed with the motion of an object moved near them
  int64_t reidentified_as_part = 0;   ///< ... of them, dormant parts of an object of their class found moved near them
  int64_t reidentified_by_centroid = 0;  ///< ... of them, dormant objects a neighbour's motion takes onto one of their class
  int64_t accumulated = 0;        ///< candidates made of small candidates of several keyframes
  int64_t missed_points = 0;      ///< candidate points left out as a missed object's (dropMissedObjectPoints)
  int64_t tentative_misses = 0;   ///< ... of the misses, short-term ones of tentative objects (tentative_short_term)
  std::string str() const;
};

/** Links between objects of one class that one detection covered together
 *  in some keyframe: parts of one thing (ObjectPersistenceFilter's
 *  reid_part_links). An object merged into another hands its links to it;
 *  objects of other maps keep theirs (a map merge keeps object ids). */
class ObjectPartLinks {
 public:
  /** Links a and b; false when they were linked already. */
  bool link(int64_t a, int64_t b);
  /** Object `from` was merged into `into`: its links become `into`'s. */
  void carry(int64_t into, int64_t from);
  /** Whether `to` is reachable from `from` through the links. */
  bool linked(int64_t from, int64_t to) const;
  /** Objects with at least one link. */
  size_t size() const { return links_.size(); }
  void clear() { links_.clear(); }

 private:
  std::unordered_map<int64_t, std::set<int64_t>> links_;
};

class ObjectPersistenceFilter : public FilteringMapManager {
  DEFINE_MRPT_OBJECT(ObjectPersistenceFilter, dslam)
 public:
  ~ObjectPersistenceFilter() override;  ///< logs what it did (Info)
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;

  bool isActive(const MapPoint& p) const override { return p.active && inner().isActive(p); }
  void onKeyFrame(const std::shared_ptr<KeyFrame>& kf) override;
  void onTrackingLost(const std::shared_ptr<Map>& m) override;
  /** A detected object (class and tracker id) with `new_object_keypoints`
   *  keypoints with depth of which at most a fifth are matched to
   *  established map points (seen by 3 keyframes; fewer are culled by
   *  local mapping): the next frame becomes a keyframe (at most one request
   *  per `new_object_keyframe_gap` seconds), so that objects seen while
   *  tracking needs no keyframe get mapped.
   *  Also the whole place of an active or dormant object not seen for
   *  `long_term_s` in view (its 3D box inside the image, nearer than
   *  `max_range`): the next frame becomes a keyframe (at most once per
   *  `place_check_gap` seconds per object), so that its place is judged
   *  (negative evidence or a sighting), also where tracking needs no
   *  keyframe: a slow revisit, a run's last frames. */
  bool wantsKeyFrame(const std::shared_ptr<Map>& m, const Frame& f, const SE3& T_cw, const CameraIntrinsics& cam,
                     const std::vector<MapPointPtr>& matched) override;

  const PersistenceStats& stats() const { return stats_; }
  const LtdaParams& ltdaParams() const { return ltda_; }

 private:
  /** What keyframes that did not associate `o` show of it: its points they
   *  should see (in the image, in range, facing them, not occluded by nearer
   *  keypoints) and how many of them they do (tracked, or a keypoint at the
   *  projection with a matching descriptor and depth); and, when its whole
   *  place is in view, the keypoints with depth in the central half of its
   *  place, those seeing through it and those on another object standing
   *  there. Summed over up to `evidence_keyframes` keyframes (weak views of a
   *  small object add up) until it makes a decision. */
  struct Evidence {
    int expected = 0, found = 0;
    int with_depth = 0, through = 0, other = 0;
    int keyframes = 0;
    int undetected = 0;  ///< keyframes that saw its whole place and nothing of its class on it
    Evidence& operator+=(const Evidence& e);
  };
  Evidence pointEvidence(const KeyFrame& kf, const MapObject& o,
                         const std::unordered_set<const MapPoint*>& kf_points) const;
  /** By (class, instance) of a keyframe's keypoint labels: the image
   *  rectangle their keypoints span (a detection's extent as its keypoints
   *  show it). */
  using DetectionExtents = std::map<std::pair<int, int32_t>, cv::Rect2f>;
  static DetectionExtents detectionExtents(const KeyFrame& kf);
  /** Adds the place evidence of `kf` to `ev`, with `undetected` set when
   *  its whole place is in view, not hidden, and no keypoint on it carries
   *  its class (keypoints whose map point is in another object apart from
   *  it, and keypoints of detections spanning less than
   *  `place_overlap` of the place, in `extents`, do not count); false if
   *  its points or keypoints of its class are on its place (it is there: no
   *  negative evidence), unless `undetected`. */
  bool placeEvidence(const KeyFrame& kf, const MapObject& o, const DetectionExtents& extents, Evidence& ev) const;
  /** Whether the map point of keypoint i of `kf` is in an object other
   *  than `o` (a map point is in one object) whose box and o's hold
   *  neither's centroid. */
  static bool ofAnotherObject(const KeyFrame& kf, size_t i, const MapObject& o);
  bool placeFree(const Evidence& ev) const;
  void setDormant(MapObject& o);
  /** Below the belief threshold: inactive, and no longer dormant (gone, not
   *  waiting to be seen again). */
  void setGone(MapObject& o);

  LtdaParams ltda_;
  ReidParams reid_;
  ObjectBeliefParams belief_;
  double initial_belief_ = 0.5, belief_threshold_ = 0.2;
  int long_term_keyframes_ = 5;
  double long_term_s_ = 2.0;
  /** Not seen in the last long_term_keyframes keyframes or for long_term_s seconds. */
  bool longTerm(const KeyFrame& kf, int64_t last_kf, double last_t) const;
  double dormant_after_s_ = 5.0;
  bool dormant_on_lost_ = true;
  double max_range_ = 6.0, occlusion_margin_ = 0.3, min_free_fraction_ = 0.6;
  int min_place_keypoints_ = 8, min_support_points_ = 3;
  int min_expected_points_ = 8, max_descriptor_distance_ = 50;
  int new_object_keypoints_ = 10;
  double new_object_gap_s_ = 1.0, last_request_t_ = -1e300;
  double place_check_gap_s_ = 2.0;
  std::unordered_map<int64_t, double> place_checked_t_;  ///< by object id: when its place last asked for a keyframe
  double match_radius_px_ = 8.0, min_found_fraction_ = 0.15, present_fraction_ = 0.5;
  bool class_at_point_ = true;  ///< a point not found among keypoints of its class at its depth: no evidence
  double place_overlap_ = 0.25;  ///< a detection supports a place only if its keypoints span this much of it
  int evidence_keyframes_ = 3;
  std::unordered_map<int64_t, Evidence> pending_;  ///< by object id: evidence not decided on yet
  int small_candidate_keyframes_ = 5;
  MissedObjectParams missed_;
  int undetected_keyframes_ = 1;
  bool tentative_short_term_ = false;
  std::unordered_set<int64_t> missed_lately_;  ///< tentative objects with short-term negative evidence since their sighting
  SmallCandidatePool small_;  ///< candidates too small for an object, adding up
  enum class LabelVotes { Off, Leave, Follow };
  LabelVotes label_votes_ = LabelVotes::Off;  ///< label_votes
  PointClassVotes votes_;  ///< label fusion (label_votes)
  /** A motion found by re-identification: a prior for objects near `from`. */
  struct PriorMotion {
    int64_t map = -1, kf = -1;
    Eigen::Vector3d from = Eigen::Vector3d::Zero();  ///< where the moved object stood
    ObjectMotion motion;  ///< from_prior: found with another's motion (no prior itself; parts only)
    int64_t object = -1;  ///< the moved object
    int class_id = -1;
  };
  std::vector<PriorMotion> motions_;
  int prior_keyframes_ = 20;
  double prior_radius_ = 2.0;
  double part_radius_ = 1.0;  ///< reid_part_radius
  bool part_links_on_ = true;  ///< reid_part_links
  ObjectPartLinks part_links_;
  /** Records the links of the detections of `kf` (after its association). */
  void linkParts(const KeyFrame& kf, const std::map<int64_t, MapObjectPtr>& objects);
  double centroid_distance_ = 0.25;  ///< reid_centroid_distance
  PersistenceStats stats_;
};

class PointPersistenceFilter : public FilteringMapManager {
  DEFINE_MRPT_OBJECT(PointPersistenceFilter, dslam)
 public:
  ~PointPersistenceFilter() override;  ///< logs what it did (Info)
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;

  bool isActive(const MapPoint& p) const override { return p.active && inner().isActive(p); }
  void onKeyFrame(const std::shared_ptr<KeyFrame>& kf) override;

  const PersistenceStats& stats() const { return stats_; }
  /** Belief of a point at time t (1 if the filter has no record of it). */
  double belief(int64_t point_id, double t) const;

 private:
  FeaturePersistenceParams fp_;
  double belief_threshold_ = 0.3;
  double max_range_ = 6.0, occlusion_margin_ = 0.2, match_radius_px_ = 8.0;
  int max_descriptor_distance_ = 50;
  bool object_points_ = false;  ///< also filter points of MapObjects (default: those are the object filter's)
  std::unordered_map<int64_t, FeaturePersistence> filters_;
  std::map<int64_t, std::weak_ptr<MapPoint>> inactive_;  ///< points this filter deactivated
  PersistenceStats stats_;
};

}  // namespace dslam
