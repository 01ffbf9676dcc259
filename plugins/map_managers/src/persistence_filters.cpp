#include "dslam/plugins/map_managers/persistence_filters.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <unordered_set>

#include "dslam/core/coco.h"
#include "dslam/core/descriptor.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/map/keyframe.h"
#include "dslam/map/map.h"

IMPLEMENTS_MRPT_OBJECT(ObjectPersistenceFilter, MapManager, dslam)
IMPLEMENTS_MRPT_OBJECT(PointPersistenceFilter, MapManager, dslam)

namespace dslam {

namespace {

/** Pixel of camera-frame point `Xc` (in front of the camera). */
cv::Point2f pixelOf(const CameraIntrinsics& cam, const Eigen::Vector3d& Xc) {
  return {static_cast<float>(cam.fx * Xc.x() / Xc.z() + cam.cx), static_cast<float>(cam.fy * Xc.y() / Xc.z() + cam.cy)};
}

/** Pixel of world point `Xw` seen from pose T_cw with camera `cam`, and its
 *  depth; false when it is behind the camera, nearer than 0.1 m or outside
 *  the image. */
bool projectInto(const SE3& T_cw, const CameraIntrinsics& cam, const Eigen::Vector3d& Xw, cv::Point2f& uv, double& z) {
  const Eigen::Vector3d Xc = T_cw * Xw;
  z = Xc.z();
  if (z < 0.1) return false;
  uv = pixelOf(cam, Xc);
  return cam.bounds.contains(uv.x, uv.y);
}
bool projectInto(const KeyFrame& kf, const Eigen::Vector3d& Xw, cv::Point2f& uv, double& z) {
  return projectInto(kf.T_cw(), kf.cam, Xw, uv, z);
}

/** Image rectangle of an object's 3D box seen from pose T_cw, and the
 *  depth of its centroid. */
struct PlaceRect {
  float x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  double z = 0;
};
/** Whether the whole place of `o` (its 3D box) is in view of a camera at
 *  T_cw: the centroid in front and nearer than `max_range`, every box corner
 *  in front and inside the image (at the image border a present object is
 *  easily missed: few of its keypoints, a cut box). */
bool placeInView(const SE3& T_cw, const CameraIntrinsics& cam, const MapObject& o, double max_range, PlaceRect& r) {
  cv::Point2f c;
  if (!projectInto(T_cw, cam, o.centroid, c, r.z) || r.z > max_range) return false;
  r.x0 = r.y0 = 1e9f, r.x1 = r.y1 = -1e9f;
  for (int k = 0; k < 8; k++) {
    const Eigen::Vector3d Xc = T_cw * o.corner(k);
    if (Xc.z() < 0.05) return false;
    const cv::Point2f px = pixelOf(cam, Xc);
    r.x0 = std::min(r.x0, px.x), r.x1 = std::max(r.x1, px.x), r.y0 = std::min(r.y0, px.y), r.y1 = std::max(r.y1, px.y);
  }
  const ImageBounds& b = cam.bounds;
  return r.x0 >= b.min_x && r.y0 >= b.min_y && r.x1 <= b.max_x && r.y1 <= b.max_y && r.x1 > r.x0 && r.y1 > r.y0;
}

/** Whether keyframe `kf` should see map point `p`: it projects inside the
 *  image (pixel `uv`, depth `z`), nearer than `max_range`, within the
 *  point's scale-invariance distance range and within 60 degrees of its
 *  mean viewing direction (ORB-SLAM's isInFrustum tests: outside them its
 *  descriptor is not expected to match). */
bool pointInView(const KeyFrame& kf, const MapPoint& p, double max_range, cv::Point2f& uv, double& z) {
  if (!projectInto(kf, p.pos, uv, z) || z > max_range) return false;
  const Eigen::Vector3d PO = p.pos - kf.center();
  const double dist = PO.norm();
  if (p.max_dist > 0 && !p.inScaleRange(static_cast<float>(dist))) return false;  // 0: range never computed
  return PO.dot(p.normal) >= 0.5 * dist;
}

/** What the keypoints of `kf` within `radius` pixels of the projection
 *  (uv, z) of `p` show. */
struct Around {
  bool any_depth = false;  ///< one of them has depth
  bool occluded = false;   ///< one of them is nearer than the point by more than the margin
  bool match = false;      ///< one of them is the point (see Match)
  bool own_class = false;  ///< one of them carries `own_class` at the point's depth (within the margin)
};
constexpr int kNoClassTest = -2;  ///< lookAround: keypoint labels not used
enum class Match {
  None,              ///< no descriptor test
  Descriptor,        ///< descriptor distance only
  DescriptorAndDepth ///< descriptor distance, and a depth within the margin of the point's
};
Around lookAround(const KeyFrame& kf, const MapPoint& p, const cv::Point2f& uv, double z, float radius,
                  double occlusion_margin, int max_descriptor_distance, Match m, int own_class = kNoClassTest) {
  Around a;
  for (size_t i : kf.featuresInArea(uv.x, uv.y, radius)) {
    const float d = i < kf.depth.size() ? kf.depth[i] : 0.f;
    if (d > 0) a.any_depth = true;
    if (d > 0 && d < z - occlusion_margin) a.occluded = true;
    // A keypoint without depth in another object's box: most likely on that
    // object's silhouette (depth sensors drop depth at depth edges), which
    // may stand in front of the point and cover its descriptor's patch.
    if (own_class != kNoClassTest && !(d > 0) && i < kf.meta.size() && kf.meta[i].class_id >= 0 &&
        kf.meta[i].class_id != own_class)
      a.occluded = true;
    if (own_class != kNoClassTest && d > 0 && std::abs(d - z) <= occlusion_margin && i < kf.meta.size() &&
        kf.meta[i].class_id == own_class)
      a.own_class = true;
    if (m == Match::None || a.match) continue;
    if (m == Match::DescriptorAndDepth && !(d > 0 && std::abs(d - z) <= occlusion_margin)) continue;
    a.match = descriptorDistance(kf.descriptors.ptr<uint8_t>(static_cast<int>(i)), p.desc.data()) <=
              max_descriptor_distance;
  }
  return a;
}

/** Debug trace of an object's state change. */
void traceObject(const KeyFrame& kf, const MapObject& o, const char* what) {
  DSLAM_LOG(Debug, "objects: keyframe " << kf.id << " (t " << kf.timestamp << "): object " << o.id << " ("
                                        << coco::name(o.class_id) << ", " << o.numPoints() << " points at "
                                        << o.centroid.transpose() << ") " << what << ", belief " << o.belief);
}

}  // namespace

std::string PersistenceStats::str() const {
  return std::to_string(keyframes) + " keyframes, " + std::to_string(created) + " objects created, " +
         std::to_string(sightings) + " sightings, " + std::to_string(misses) + " misses" +
         (tentative_misses > 0 ? " (" + std::to_string(tentative_misses) + " of tentative objects, short term)" : "") +
         ", " +
         std::to_string(deactivated) + " deactivated, " + std::to_string(reactivated) + " reactivated, " +
         std::to_string(dormant) + " dormant, " + std::to_string(woken) + " woken" +
         (keyframe_requests > 0 ? ", " + std::to_string(keyframe_requests) + " keyframes requested" : "") +
         (place_requests > 0 ? ", " + std::to_string(place_requests) + " keyframes requested for places" : "") +
         (merged > 0 ? ", " + std::to_string(merged) + " merged" : "") +
         (reidentified > 0 ? ", " + std::to_string(reidentified) + " re-identified elsewhere" : "") +
         (reidentified_by_prior > 0 ? " (" + std::to_string(reidentified_by_prior) + " by a neighbour's motion)" : "") +
         (reidentified_as_part > 0 ? " (" + std::to_string(reidentified_as_part) + " as parts of a moved object)" : "") +
         (reidentified_by_centroid > 0
              ? " (" + std::to_string(reidentified_by_centroid) + " moved with a neighbour onto an object of their class)"
              : "") +
         (accumulated > 0 ? ", " + std::to_string(accumulated) + " candidates from small views added up" : "") +
         (missed_points > 0 ? ", " + std::to_string(missed_points) + " candidate points of missed objects left out" : "");
}

// ---------------------------------------------------------------------------
// ObjectPersistenceFilter

ObjectPersistenceFilter::~ObjectPersistenceFilter() {
  if (stats_.keyframes > 0) DSLAM_LOG(Info, "object persistence filter: " << stats_.str());
}

std::string ObjectPersistenceFilter::description() const {
  return "Changing-SLAM object persistence filter: MapObjects by long-term data association, a Bayes belief per "
         "object (sightings, negative evidence); objects below belief_threshold, and dormant ones, have inactive points";
}

std::vector<ParamSpec> ObjectPersistenceFilter::paramSpecs() const {
  return {
      P_double("ltda_threshold", 0.25, "same class and centroids closer than this (m): the same object (LTDA)", 0, 100),
      P_double("cluster_radius", 0.3, "points of one class without an instance id: one candidate per cluster (m)", 0.01,
               100),
      P_int("min_points", 5, "smaller object candidates are ignored", 1, 100000),
      P_int("min_shared_points", 3,
            "a candidate sharing this many map points with an object of its class is that object (before the "
            "centroid test; ours)",
            1, 100000),
      P_bool("dormant_by_distance", true,
             "a dormant object (not confirmed for long, or tracking was lost) may be associated with a candidate of "
             "its class by centroid distance alone (ltda_threshold), which wakes it; false: only a candidate "
             "sharing min_shared_points of its points, or its points found again (point evidence), wake it, so "
             "that another thing labelled with its class next to its place does not (ours)"),
      P_double("centroid_radius", 0,
               "an object's centroid: 0 = the mean of its points (Changing-SLAM's MapObject); > 0 = the mean of "
               "its points within this distance (m) of their per-axis median, which points of an occluder that "
               "joined the object (a thing in front of it whose detection was missed, labelled with the box behind "
               "it) cannot drag off the object while they are fewer than half and farther than this (ours; "
               "docs/changing.md step 14). Objects loaded from an atlas follow this setting from the first "
               "keyframe on",
               0, 100),
      P_enum("label_votes", "off", {"off", "leave", "follow"},
             "label fusion: each map point counts the classes keyframes label its keypoint with (object classes, "
             "not dynamic); when most keyframes gave it another class than this keyframe's label (a detector that "
             "missed its object, the box behind labelling it), leave = the point is left out of this keyframe's "
             "candidates (it stays in its object), follow = it joins the candidates of the class the votes give it "
             "(ours; off = this keyframe's label, or the class the point was created with; docs/changing.md)"),
      P_list("classes", ParamType::IntList, "[]", "COCO ids that make objects ([] = every COCO thing, ids 1-91)"),
      P_list("ignore_classes", ParamType::IntList, "[1]", "COCO ids that never make objects (people are dynamic)"),
      P_int("long_term_keyframes", 5,
            "the belief changes only for objects not seen in the last N keyframes (long-term evidence)", 0, 1000000),
      P_double("long_term_s", 2.0,
               "... or not seen for this long (s): a camera that comes back to a known view makes few keyframes",
               0, 1e9),
      P_double("initial_belief", 0.5, "belief of a new object (Changing-SLAM: 0.5)", 0.01, 0.99),
      P_double("belief_threshold", 0.2, "objects below this belief have inactive points", 0, 1),
      P_double("belief_max", 0.99,
               "sightings raise the belief up to this clamp (like OctoMap's clamping thresholds), so that an object "
               "seen often still falls below belief_threshold after a few keyframes of negative evidence: 0.99, 4 "
               "keyframes whose points are not found; 0.95, 3 (ours)",
               0.5, 0.999999),
      P_double("sigma", 0.5, "spread of the sighting likelihood for a one-point object (m)", 1e-3, 100),
      P_double("min_sigma", 0.15,
               "the spread shrinks as 1/sqrt(points) down to this (m; partial views move a centroid by up to half "
               "the object)",
               1e-3, 100),
      P_double("p_detect", 0.8, "P(a present object in view is seen with points)", 0.01, 0.99),
      P_double("p_false", 0.1, "P(something of its class seen there although it is gone)", 0.001, 0.99),
      P_double("p_see_through", 0.1,
               "P(its place seen through, or another object seen there, although it is there: open or thin objects, "
               "depth noise; ours: stronger negative evidence than 1 - p_detect for its points not found again)",
               0.001, 0.99),
      P_double("p_twin", 0.01,
               "P(its appearance seen elsewhere, moved rigidly, although it is still there: an identical twin; "
               "ours)",
               1e-6, 1),
      P_int("reid_min_inliers", 8,
            "re-identification (ours): an object seen in a keyframe whose points match the descriptors of this many "
            "points of a same-class object not seen for long, all moved by one rigid motion, is that object moved: "
            "negative evidence (p_twin) for it at its old place; 0 = off",
            0, 100000),
      P_int("reid_prior_min_inliers", 3,
            "re-identification by a neighbour's motion: an object with too few matches for a motion of its own is "
            "moved when this many of its matches (and at least half) agree with the motion of an object found moved "
            "within reid_prior_radius of it in the last reid_prior_keyframes keyframes (objects moved together, "
            "parts of one object; ours, 0 = off)",
            0, 1000),
      P_int("reid_prior_keyframes", 20, "re-identification: how long a found motion serves as a prior (keyframes)", 0,
            100000),
      P_double("reid_prior_radius", 2.0,
               "re-identification: a found motion is a prior for objects whose centroid is this near to where the moved "
               "object stood (m)",
               0, 1000),
      P_double("reid_part_radius", 1.0,
               "re-identification: a dormant object whose centroid is this near to where an object of its class "
               "stood that was found moved (in the last reid_prior_keyframes keyframes), and that this keyframe does "
               "not show at its place, was part of it (an object mapped from several sides as several objects) and "
               "moved with it: the same negative evidence (p_twin); ours, 0 = off",
               0, 1000),
      P_bool("reid_part_links", true,
             "re-identification: a dormant object that one detection covered together with an object of its class "
             "found moved (at least min_shared_points points of each labelled by that detection in one keyframe; "
             "through other objects so covered, transitively) was part of it and moved with it, at any distance "
             "(a large object mapped from several sides; ours, false = off)"),
      P_double("reid_centroid_distance", 0.25,
               "re-identification by a neighbour's motion without matches: a dormant object that the motion of an "
               "object found moved within reid_prior_radius of it (in the last reid_prior_keyframes keyframes) takes "
               "to within this distance (m) of an object of its class that the keyframe sees, first seen after it "
               "was and seen by two keyframes or more (not one keyframe's fragment of an object that did not move: a "
               "desk's other side), and that the keyframe does not show at its place, moved with it: the same "
               "negative evidence (p_twin) (objects moved together whose new view shares too few descriptor matches "
               "with the old one; ours, 0 = off)",
               0, 1000),
      P_double("reid_inlier_distance", 0.08, "re-identification: a match within this of the rigid motion (m)", 1e-3,
               10),
      P_double("dormant_after_s", 5.0,
               "objects not confirmed for this long are dormant (inactive, belief kept) until seen again; 0 = never",
               0, 1e9),
      P_bool("dormant_on_lost", true, "tracking lost: every object of the map is dormant until seen again"),
      P_double("max_range", 6.0, "negative evidence only for objects closer than this (m)", 0.1, 1000),
      P_double("occlusion_margin", 0.3,
               "negative evidence: keypoints beyond the object's centroid by more than this (m) see through its place",
               0, 100),
      P_double("min_free_fraction", 0.6,
               "negative evidence needs this fraction of the keypoints in the central half of its place to see "
               "through it",
               0, 1),
      P_int("min_place_keypoints", 8, "negative evidence needs this many keypoints with depth in the central half of "
            "its place", 1, 100000),
      P_int("min_support", 3, "its points or keypoints of its class on its place: it is there (no negative evidence)",
            1, 100000),
      P_int("min_expected_points", 8,
            "point evidence: at least this many of its points (or half of a smaller object's, at least 3) must be "
            "in view (in range, facing the camera, not occluded by nearer keypoints)",
            1, 100000),
      P_double("min_found_fraction", 0.15,
               "point evidence: fewer of its points in view found again than this fraction is negative evidence "
               "(it is not there any more)",
               0, 1),
      P_double("present_fraction", 0.5,
               "point evidence: at least this fraction found again is a sighting (wakes a dormant object) even "
               "without a detection",
               0, 1),
      P_double("match_radius", 8.0, "point evidence: pixels around a point's projection searched for it", 1, 1000),
      P_bool("class_at_point", true,
             "point evidence: a point not found where a keypoint labelled with its object's class lies at its depth "
             "(within occlusion_margin, match_radius around its projection) is no evidence either way: the object "
             "is there, seen from a side where this point looks otherwise (a table's edge) (ours; false = every "
             "point in view not found counts against it)"),
      P_double("place_overlap", 0.25,
               "place evidence: a keypoint labelled with an object's class on its place supports it (and makes its "
               "class detected there) only if the keypoints of that detection (class and instance) span at least this "
               "fraction of the place's image rectangle: another object of its class whose edge reaches into the "
               "place (the same corner found on several pyramid levels) is not the object there (ours; 0 = any "
               "keypoint of its class on its place counts)",
               0, 1),
      P_int("evidence_keyframes", 3,
            "point and place evidence too weak in one keyframe (a small object: few points or keypoints on its "
            "place) adds up over this many keyframes that show it (ours; 1 = each keyframe on its own)",
            1, 1000),
      P_int("max_descriptor_distance", 50, "point evidence: a keypoint this close (ORB) at the projection is the point",
            0, 256),
      P_int("small_candidate_keyframes", 5,
            "object candidates with fewer than min_points points (only the points labelled with the class in that "
            "keyframe) are kept this many keyframes: views of a small or barely visible object of one class within "
            "ltda_threshold add up until their points make min_points (ours; 0 = off, each keyframe on its own as "
            "in Changing-SLAM; docs/changing.md)",
            0, 1000),
      P_int("missed_object_keyframes", 0,
            "a keyframe's object candidate leaves out the points of an active object of another class seen by 2 "
            "keyframes or more, one of them among this many last keyframes, when no detection of its class (the "
            "extent of its labelled keypoints) overlaps the candidate's image box (the detector missed it and the "
            "candidate's box labelled its keypoints), "
            "unless the candidate holds half of its points or more (ours; 0 = off, the plug-in's default; the "
            "changing_slam pipelines set 3: over 49 shift_dark runs of seven pipeline seeds, stale objects 5 -> 1 "
            "and no run above 5 cm after the return; docs/changing.md step 9)",
            0, 1000),
      P_double("missed_object_radius", 0.1,
               "... and the candidate's points within this distance (m) of one of that object's points (new points "
               "made on it in that keyframe)",
               0, 10),
      P_int("undetected_keyframes", 1,
            "negative evidence when this many keyframes of one evidence window (evidence_keyframes) see an "
            "object's whole place with at least min_place_keypoints keypoints with depth on it, fewer than half of "
            "them in front of it by occlusion_margin, and none labelled with its class (Changing-SLAM: no "
            "detection supports it); its own points found there are then no sighting (background points of its "
            "box, the floor between a chair's legs, are still there after it left) (ours; 0 = off: points found "
            "are a sighting without a detection; docs/changing.md)",
            0, 1000),
      P_bool("tentative_short_term", false,
             "an object seen by one keyframe only (tentative) is judged also in the keyframes right after that "
             "sighting, when the long-term gate (long_term_keyframes, long_term_s) still holds back evidence: "
             "negative evidence only (its place seen through, nothing of its class detected on it, its points not "
             "found), and a later sighting of it counts however soon it comes. A false object made of one "
             "keyframe's labels near the end of a run is otherwise never judged (ours; false = off, the default: "
             "docs/changing.md)"),
      P_int("new_object_keypoints", 10,
            "a detected object with this many keypoints with depth, at most a fifth of them on established map "
            "points (seen by 3 keyframes), asks for a keyframe, so that objects seen while tracking needs none get "
            "mapped (ours; 0 = off: static objects found by the semantic map 18/20 -> 8/20 on the changing scenes; "
            "docs/changing.md)",
            0, 100000),
      P_double("new_object_keyframe_gap", 0.5,
               "at most one such keyframe request per this many seconds (1 s before 2026-11-28: more stale objects "
               "on shift_dark; docs/changing.md)",
               0, 1e9),
      P_double("place_check_gap", 2.0,
               "the whole place of an active or dormant object not seen for long_term_s in view asks for a keyframe, "
               "at most once per this many seconds per object (and one request of any kind per "
               "new_object_keyframe_gap), so that its place is judged also where tracking makes no keyframe: a slow "
               "revisit, a run's last frames (ours; 0 = off)",
               0, 1e9),
  };
}

void ObjectPersistenceFilter::configure(const Params& p, const PluginContext& ctx) {
  MapManager::configure(p, ctx);
  ltda_.threshold_m = p.getDouble("ltda_threshold");
  ltda_.cluster_m = p.getDouble("cluster_radius");
  ltda_.min_points = static_cast<int>(p.getInt("min_points"));
  ltda_.min_shared_points = static_cast<size_t>(p.getInt("min_shared_points"));
  ltda_.dormant_by_distance = p.getBool("dormant_by_distance");
  ltda_.centroid_radius = p.getDouble("centroid_radius");
  const std::string votes = p.getString("label_votes");
  label_votes_ = votes == "follow" ? LabelVotes::Follow : votes == "leave" ? LabelVotes::Leave : LabelVotes::Off;
  ltda_.classes = p.getIntList("classes");
  ltda_.ignore_classes = p.getIntList("ignore_classes");
  long_term_keyframes_ = static_cast<int>(p.getInt("long_term_keyframes"));
  long_term_s_ = p.getDouble("long_term_s");
  initial_belief_ = p.getDouble("initial_belief");
  belief_threshold_ = p.getDouble("belief_threshold");
  belief_.belief_max = p.getDouble("belief_max");
  if (initial_belief_ > belief_.belief_max || belief_threshold_ >= belief_.belief_max) {
    p.fail("belief_max", std::to_string(belief_.belief_max) + " must be at least initial_belief (" +
                             std::to_string(initial_belief_) + ") and above belief_threshold (" +
                             std::to_string(belief_threshold_) + ")");
  }
  belief_.sigma_m = p.getDouble("sigma");
  belief_.min_sigma_m = p.getDouble("min_sigma");
  belief_.p_detect = p.getDouble("p_detect");
  belief_.p_false = p.getDouble("p_false");
  belief_.p_see_through = p.getDouble("p_see_through");
  belief_.p_twin = p.getDouble("p_twin");
  reid_.min_inliers = static_cast<int>(p.getInt("reid_min_inliers"));
  reid_.inlier_m = p.getDouble("reid_inlier_distance");
  reid_.prior_min_inliers = static_cast<int>(p.getInt("reid_prior_min_inliers"));
  prior_keyframes_ = static_cast<int>(p.getInt("reid_prior_keyframes"));
  prior_radius_ = p.getDouble("reid_prior_radius");
  part_radius_ = p.getDouble("reid_part_radius");
  part_links_on_ = p.getBool("reid_part_links");
  part_links_.clear();
  centroid_distance_ = p.getDouble("reid_centroid_distance");
  motions_.clear();
  dormant_after_s_ = p.getDouble("dormant_after_s");
  dormant_on_lost_ = p.getBool("dormant_on_lost");
  max_range_ = p.getDouble("max_range");
  occlusion_margin_ = p.getDouble("occlusion_margin");
  min_free_fraction_ = p.getDouble("min_free_fraction");
  min_place_keypoints_ = static_cast<int>(p.getInt("min_place_keypoints"));
  min_support_points_ = static_cast<int>(p.getInt("min_support"));
  min_expected_points_ = static_cast<int>(p.getInt("min_expected_points"));
  min_found_fraction_ = p.getDouble("min_found_fraction");
  present_fraction_ = p.getDouble("present_fraction");
  match_radius_px_ = p.getDouble("match_radius");
  class_at_point_ = p.getBool("class_at_point");
  place_overlap_ = p.getDouble("place_overlap");
  evidence_keyframes_ = static_cast<int>(p.getInt("evidence_keyframes"));
  max_descriptor_distance_ = static_cast<int>(p.getInt("max_descriptor_distance"));
  reid_.max_descriptor_distance = max_descriptor_distance_;
  reid_.min_shift_m = ltda_.threshold_m;
  small_candidate_keyframes_ = static_cast<int>(p.getInt("small_candidate_keyframes"));
  small_ = SmallCandidatePool();
  missed_.recent_keyframes = static_cast<int>(p.getInt("missed_object_keyframes"));
  missed_.radius_m = p.getDouble("missed_object_radius");
  undetected_keyframes_ = static_cast<int>(p.getInt("undetected_keyframes"));
  tentative_short_term_ = p.getBool("tentative_short_term");
  missed_lately_.clear();
  new_object_keypoints_ = static_cast<int>(p.getInt("new_object_keypoints"));
  new_object_gap_s_ = p.getDouble("new_object_keyframe_gap");
  last_request_t_ = -1e300;
  place_check_gap_s_ = p.getDouble("place_check_gap");
  place_checked_t_.clear();
}

bool ObjectPersistenceFilter::wantsKeyFrame(const std::shared_ptr<Map>& map, const Frame& f, const SE3& T_cw,
                                            const CameraIntrinsics& cam, const std::vector<MapPointPtr>& matched) {
  if (new_object_keypoints_ > 0 && map && f.timestamp() - last_request_t_ >= new_object_gap_s_ &&
      f.meta.size() == f.size()) {
    std::lock_guard<std::recursive_mutex> lk(map->update_mutex);  // observations are local mapping's
    // (class, tracker id) -> (keypoints, matched to established points)
    std::map<std::pair<int, int>, std::pair<int, int>> by_object;
    for (size_t i = 0; i < f.size(); i++) {
      const KeypointMeta& m = f.meta[i];
      if (m.label == KpLabel::Dynamic || !isObjectClass(m.class_id, ltda_)) continue;
      if (i >= f.depth.size() || !(f.depth[i] > 0)) continue;
      auto& n = by_object[{m.class_id, m.object_id}];
      n.first++;
      n.second += i < matched.size() && matched[i] && matched[i]->numObservations() >= 3;
    }
    for (const auto& [key, n] : by_object)
      if (n.first >= new_object_keypoints_ && 5 * n.second <= n.first) {
        last_request_t_ = f.timestamp();
        stats_.keyframe_requests++;
        return true;
      }
  }
  // The place of an object not seen for long in full view: a keyframe judges it.
  if (place_check_gap_s_ > 0 && map && f.timestamp() - last_request_t_ >= new_object_gap_s_) {
    std::lock_guard<std::recursive_mutex> lk(map->update_mutex);
    for (const auto& [id, op] : map->objects()) {
      const MapObject& o = *op;
      if ((!o.active && !o.dormant) || o.points.empty() || f.timestamp() - o.last_seen_t <= long_term_s_) continue;
      auto it = place_checked_t_.find(id);
      if (it != place_checked_t_.end() && f.timestamp() - it->second < place_check_gap_s_) continue;
      PlaceRect r;
      if (!placeInView(T_cw, cam, o, max_range_, r)) continue;
      place_checked_t_[id] = f.timestamp();
      last_request_t_ = f.timestamp();
      stats_.place_requests++;
      DSLAM_LOG(Trace, "objects: frame " << f.index() << ": place of object " << o.id << " in view, keyframe requested");
      return true;
    }
  }
  return FilteringMapManager::wantsKeyFrame(map, f, T_cw, cam, matched);
}

ObjectPersistenceFilter::Evidence& ObjectPersistenceFilter::Evidence::operator+=(const Evidence& e) {
  expected += e.expected, found += e.found;
  with_depth += e.with_depth, through += e.through, other += e.other;
  keyframes += e.keyframes;
  undetected += e.undetected;
  return *this;
}

ObjectPersistenceFilter::Evidence ObjectPersistenceFilter::pointEvidence(
    const KeyFrame& kf, const MapObject& o, const std::unordered_set<const MapPoint*>& kf_points) const {
  Evidence ev;
  for (const auto& [id, p] : o.points) {
    if (!p || p->bad) continue;
    cv::Point2f uv;
    double z = 0;
    if (!pointInView(kf, *p, max_range_, uv, z)) continue;
    if (kf_points.count(p.get())) {
      ev.expected++;
      ev.found++;
      continue;
    }
    const Around a = lookAround(kf, *p, uv, z, static_cast<float>(match_radius_px_), occlusion_margin_,
                                max_descriptor_distance_, Match::DescriptorAndDepth, o.class_id);
    if (a.occluded || !a.any_depth) continue;  // hidden, or nothing to tell
    // Its class detected right there, at its depth, but no keypoint like
    // it: the object is seen from a side where this point looks otherwise
    // (a table's edge), no sign that it left.
    if (class_at_point_ && !a.match && a.own_class) continue;
    ev.expected++;
    ev.found += a.match;
  }
  return ev;
}

bool ObjectPersistenceFilter::ofAnotherObject(const KeyFrame& kf, size_t i, const MapObject& o) {
  const MapPointPtr& mp = kf.points[i];
  if (!mp || !kf.map || mp->map_object < 0 || mp->map_object == o.id) return false;
  auto jt = kf.map->objects().find(mp->map_object);
  if (jt == kf.map->objects().end()) return false;
  const MapObject& x = *jt->second;
  return !x.contains(o.centroid) && !o.contains(x.centroid);  // overlapping: parts of one object
}

ObjectPersistenceFilter::DetectionExtents ObjectPersistenceFilter::detectionExtents(const KeyFrame& kf) {
  DetectionExtents ex;
  for (size_t i = 0; i < kf.meta.size() && i < kf.keys_un.size(); i++) {
    const KeypointMeta& m = kf.meta[i];
    if (m.class_id < 0) continue;
    const cv::Point2f& u = kf.keys_un[i].pt;
    auto [it, fresh] = ex.try_emplace({m.class_id, m.object_id}, u.x, u.y, 0.f, 0.f);
    if (fresh) continue;
    cv::Rect2f& r = it->second;
    const float x0 = std::min(r.x, u.x), y0 = std::min(r.y, u.y);
    const float x1 = std::max(r.x + r.width, u.x), y1 = std::max(r.y + r.height, u.y);
    r = cv::Rect2f(x0, y0, x1 - x0, y1 - y0);
  }
  return ex;
}

bool ObjectPersistenceFilter::placeEvidence(const KeyFrame& kf, const MapObject& o, const DetectionExtents& extents,
                                            Evidence& ev) const {
  if (o.points.empty()) return true;
  PlaceRect r;
  if (!placeInView(kf.T_cw(), kf.cam, o, max_range_, r)) return true;
  const double z = r.z;
  const float x0 = r.x0, y0 = r.y0, x1 = r.x1, y1 = r.y1;
  // The central half of its place: the camera must see *through* it (depth
  // beyond the centroid by occlusion_margin), not onto something there.
  const float cx0 = x0 + 0.25f * (x1 - x0), cx1 = x1 - 0.25f * (x1 - x0);
  const float cy0 = y0 + 0.25f * (y1 - y0), cy1 = y1 - 0.25f * (y1 - y0);
  // Whether the detection keypoint i belongs to spans enough of the place.
  const cv::Rect2f place(x0, y0, x1 - x0, y1 - y0);
  std::map<int32_t, bool> spans;  // by instance
  auto onPlace = [&](const KeypointMeta& m) {
    if (place_overlap_ <= 0) return true;
    auto [it, fresh] = spans.try_emplace(m.object_id, false);
    if (fresh) {
      auto e = extents.find({m.class_id, m.object_id});
      it->second = e != extents.end() && (e->second & place).area() >= place_overlap_ * place.area();
    }
    return it->second;
  };
  int support = 0;
  int labelled = 0, rect_depth = 0, rect_front = 0;
  Evidence here;
  for (size_t i = 0; i < kf.size(); i++) {
    const cv::Point2f& pt = kf.keys_un[i].pt;
    if (pt.x < x0 || pt.x > x1 || pt.y < y0 || pt.y > y1) continue;
    const MapPointPtr& mp = kf.points[i];
    const bool of_class = !kf.meta.empty() && kf.meta[i].class_id == o.class_id && !ofAnotherObject(kf, i, o) &&
                          onPlace(kf.meta[i]);
    if ((mp && mp->map_object == o.id) || of_class) support++;
    labelled += of_class;
    if (!(i < kf.depth.size() && kf.depth[i] > 0)) continue;  // no depth: no place evidence
    rect_depth++;
    rect_front += kf.depth[i] < z - occlusion_margin_;
    if (pt.x < cx0 || pt.x > cx1 || pt.y < cy0 || pt.y > cy1) continue;
    here.with_depth++;
    if (kf.depth[i] > z + occlusion_margin_) here.through++;
    // ... or onto another object standing where it stood.
    const KeypointMeta* km = kf.meta.empty() ? nullptr : &kf.meta[i];
    if (km && km->label != KpLabel::Dynamic && isObjectClass(km->class_id, ltda_) && km->class_id != o.class_id &&
        std::abs(kf.depth[i] - z) <= occlusion_margin_)
      here.other++;
  }
  // Nothing of its class detected on its place, in full view and mostly not
  // hidden: its own points found there are no support (they may be the
  // floor between a chair's legs, still there after the chair left).
  if (undetected_keyframes_ > 0 && labelled == 0 && rect_depth >= min_place_keypoints_ && 2 * rect_front < rect_depth) {
    ev.undetected = 1;
    support = 0;
  }
  if (support >= min_support_points_) return false;
  ev += here;
  return true;
}

bool ObjectPersistenceFilter::placeFree(const Evidence& ev) const {
  return ev.with_depth >= min_place_keypoints_ &&
         (ev.through >= min_free_fraction_ * ev.with_depth || ev.other >= min_free_fraction_ * ev.with_depth);
}

bool ObjectPersistenceFilter::longTerm(const KeyFrame& kf, int64_t last_kf, double last_t) const {
  return last_kf < 0 || kf.id - last_kf > long_term_keyframes_ || kf.timestamp - last_t > long_term_s_;
}

void ObjectPersistenceFilter::setDormant(MapObject& o) {
  if (!o.active) return;
  o.setActive(false);
  o.dormant = true;
  stats_.dormant++;
}

void ObjectPersistenceFilter::setGone(MapObject& o) {
  o.dormant = false;
  if (!o.active) return;
  o.setActive(false);
  stats_.deactivated++;
}

void ObjectPersistenceFilter::linkParts(const KeyFrame& kf, const std::map<int64_t, MapObjectPtr>& objects) {
  // By detection (class, instance): the objects of its class whose points it labelled, and how many.
  std::map<std::pair<int, int32_t>, std::map<int64_t, size_t>> covered;
  for (size_t i = 0; i < kf.points.size() && i < kf.meta.size(); i++) {
    const MapPointPtr& mp = kf.points[i];
    const KeypointMeta& k = kf.meta[i];
    if (!mp || mp->bad || mp->map_object < 0 || k.label == KpLabel::Dynamic || k.class_id < 0 || k.object_id < 0)
      continue;
    const auto it = objects.find(mp->map_object);
    if (it != objects.end() && it->second->class_id == k.class_id) covered[{k.class_id, k.object_id}][mp->map_object]++;
  }
  for (const auto& [det, counts] : covered) {
    std::vector<int64_t> ids;
    for (const auto& [id, n] : counts)
      if (n >= ltda_.min_shared_points) ids.push_back(id);
    for (size_t a = 0; a < ids.size(); a++)
      for (size_t b = a + 1; b < ids.size(); b++)
        if (part_links_.link(ids[a], ids[b])) {
          DSLAM_LOG(Trace, "objects: keyframe " << kf.id << ": objects " << ids[a] << " and " << ids[b]
                                                << " covered by one detection (parts of one thing)");
        }
  }
}

bool ObjectPartLinks::link(int64_t a, int64_t b) {
  if (a == b || !links_[a].insert(b).second) return false;
  links_[b].insert(a);
  return true;
}

void ObjectPartLinks::carry(int64_t into, int64_t from) {
  const auto it = links_.find(from);
  if (it == links_.end()) return;
  const std::set<int64_t> links = std::move(it->second);
  links_.erase(it);
  for (int64_t x : links) {
    const auto back = links_.find(x);
    if (back != links_.end()) back->second.erase(from);
    if (x != into) {
      links_[x].insert(into);
      links_[into].insert(x);
    } else if (back != links_.end() && back->second.empty()) {
      links_.erase(back);
    }
  }
}

bool ObjectPartLinks::linked(int64_t from, int64_t to) const {
  std::set<int64_t> reached{from};
  std::vector<int64_t> open{from};
  while (!open.empty()) {
    const int64_t id = open.back();
    open.pop_back();
    const auto it = links_.find(id);
    if (it == links_.end()) continue;
    for (int64_t next : it->second) {
      if (next == to) return true;
      if (reached.insert(next).second) open.push_back(next);
    }
  }
  return false;
}

void ObjectPersistenceFilter::onKeyFrame(const std::shared_ptr<KeyFrame>& kf) {
  FilteringMapManager::onKeyFrame(kf);
  Map* m = kf ? kf->map : nullptr;
  if (!m) return;
  std::lock_guard<std::recursive_mutex> lk(m->update_mutex);
  if (kf->bad) return;
  stats_.keyframes++;
  auto& objects = m->objects();
  for (auto& [id, o] : objects) o->centroid_radius = ltda_.centroid_radius;  // also objects loaded from an atlas
  std::vector<ObjectCandidate> small;
  std::vector<ObjectCandidate>* const small_out = small_candidate_keyframes_ > 0 ? &small : nullptr;
  auto candidates =
      label_votes_ != LabelVotes::Off
          ? objectCandidates(*kf, ltda_, small_out, votes_, label_votes_ == LabelVotes::Follow)
          : objectCandidates(*kf, ltda_, small_out);
  if (small_candidate_keyframes_ > 0)
    for (auto& c : small_.add(std::move(small), m->id, kf->id, small_candidate_keyframes_, ltda_)) {
      stats_.accumulated++;
      candidates.push_back(std::move(c));
    }
  const DetectionExtents extents = detectionExtents(*kf);
  if (missed_.recent_keyframes > 0) {
    // Detected: a detection of the class (its keypoints' extent) overlaps the
    // candidate's box. A box inside another one labels the keypoints it
    // shares with it (a backpack on a chair), so labels inside the box alone
    // would call the chair missed.
    const size_t before = candidates.size();
    const size_t n = dropMissedObjectPoints(
        candidates, objects, kf->id,
        [&](int cls, const cv::Rect2f& box) {
          for (const auto& [key, r] : extents)
            if (key.first == cls && r.x <= box.x + box.width && box.x <= r.x + r.width && r.y <= box.y + box.height &&
                box.y <= r.y + r.height)
              return true;
          return false;
        },
        missed_, ltda_.min_points);
    stats_.missed_points += n;
    if (n > 0)
      DSLAM_LOG(Trace, "objects: keyframe " << kf->id << ": " << n << " candidate points of missed objects left out, "
                                            << before - candidates.size() << " candidates dropped");
  }
  const auto matches = associateObjects(objects, candidates, kf->id, kf->timestamp, ltda_, Map::objectIdCounter());
  std::set<int64_t> seen;
  for (const LtdaMatch& mt : matches) {
    auto it = objects.find(mt.object);
    if (it == objects.end()) continue;
    MapObject& o = *it->second;
    seen.insert(o.id);
    pending_.erase(o.id);
    if (mt.created) {
      o.belief = initial_belief_;
      stats_.created++;
      traceObject(*kf, o, "created");
      continue;
    }
    const bool was_dormant = o.dormant;
    o.dormant = false;
    const bool missed_lately = missed_lately_.erase(o.id) > 0;  // short-term negative evidence since its sighting
    if (was_dormant || missed_lately || longTerm(*kf, mt.previous_seen_kf, mt.previous_seen_t)) {
      o.belief = objectBeliefSighted(o.belief, mt.distance, static_cast<int>(o.numPoints()), belief_);
      stats_.sightings++;
    }
    if (was_dormant) {
      stats_.woken++;
      traceObject(*kf, o, "woken (associated)");
    }
    if (!o.active && o.belief >= belief_threshold_) {
      o.setActive(true);
      if (!was_dormant) stats_.reactivated++;
      traceObject(*kf, o, "re-activated (associated)");
    } else if (o.active && o.belief < belief_threshold_) {  // seen far from where it was
      o.setActive(false);
      stats_.deactivated++;
      traceObject(*kf, o, "deactivated (associated far from it)");
    }
  }
  // Partial views of one object that association kept apart become one.
  const auto merged = mergeOverlappingObjects(objects, [this](const MapObject& o) {
    return o.active && !o.dormant && o.belief >= belief_threshold_;
  });
  stats_.merged += static_cast<int64_t>(merged.size());
  for (const auto& [into, from] : merged) part_links_.carry(into, from);
  if (part_links_on_) linkParts(*kf, objects);
  std::vector<const MapObject*> seen_now;  // what this keyframe saw, for re-identification
  for (int64_t id : seen)
    if (auto it = objects.find(id); it != objects.end()) seen_now.push_back(it->second.get());
  std::unordered_set<const MapPoint*> kf_points;
  for (const auto& p : kf->points)
    if (p) kf_points.insert(p.get());
  // Objects with the most points first: their motions, when they were moved,
  // are priors for the smaller ones near them (re-identification below).
  std::vector<std::pair<int64_t, MapObject*>> order;
  order.reserve(objects.size());
  for (auto& [id, op] : objects) order.emplace_back(id, op.get());
  std::stable_sort(order.begin(), order.end(),
                   [](const auto& a, const auto& b) { return a.second->numPoints() > b.second->numPoints(); });
  for (auto& [id, op] : order) {
    MapObject& o = *op;
    if (seen.count(id)) continue;
    // Short gaps are no evidence, but for a tentative object (seen by one
    // keyframe): negative evidence only, judged from the next keyframe on.
    const bool short_term = !longTerm(*kf, o.last_seen_kf, o.last_seen_t);
    const bool tentative = short_term && tentative_short_term_ && o.active && !o.dormant && o.sightings <= 1;
    if (short_term && !tentative) continue;
    o.refresh();  // its points may have moved (local BA, loop correction, map merge) or been culled
    Evidence now = pointEvidence(*kf, o, kf_points);
    const bool place_taken = !placeEvidence(*kf, o, extents, now);
    const bool undetected = now.undetected > 0;
    DSLAM_LOG(Trace, "objects: keyframe " << kf->id << ": object " << o.id << " evidence: points found "
                                          << now.found << " of " << now.expected << ", place keypoints "
                                          << now.with_depth << " with depth, " << now.through << " through, "
                                          << now.other << " on another object" << (undetected ? ", undetected" : "")
                                          << (place_taken ? ", its class on its place" : ""));
    Evidence ev;  // what earlier keyframes gathered without a decision, and this one
    if (auto it = pending_.find(id); it != pending_.end()) {
      ev = it->second;
      pending_.erase(it);
    }
    if (place_taken) {  // something of its class on its place: what was gathered on it is void
      ev = Evidence{};
      now.with_depth = now.through = now.other = 0;
    }
    if (now.expected > 0 || now.with_depth > 0 || undetected) {
      now.keyframes = 1;
      ev += now;
    }
    // A small object has few points to expect: half of them (at least 3) suffice;
    // fewer than 3 points are never judged (summed keyframes see the same ones).
    const int need = std::min(min_expected_points_, std::max(3, static_cast<int>(o.numPoints() / 2)));
    const bool judged = o.numPoints() >= 3 && ev.expected >= need;
    if (!tentative && judged && ev.found >= present_fraction_ * ev.expected && !undetected) {
      // Its points are there although no candidate was made of them (detector miss, labels): a sighting.
      const bool was_dormant = o.dormant;
      o.dormant = false;
      o.belief = objectBeliefSighted(o.belief, 0.0, static_cast<int>(o.numPoints()), belief_);
      o.last_seen_kf = kf->id;
      o.last_seen_t = kf->timestamp;
      stats_.sightings++;
      if (was_dormant) stats_.woken++;
      if (!o.active && o.belief >= belief_threshold_) o.setActive(true);
      traceObject(*kf, o, was_dormant ? "woken (points found)" : "sighted (points found)");
      continue;
    }
    // Its appearance seen elsewhere, displaced rigidly: it was moved (ours).
    if (!tentative && reid_.min_inliers > 0 && (o.active || o.dormant)) {  // gone objects are gone already
      bool moved = false;
      // Moved (by any rule below): the negative evidence p_twin, counted by
      // rule, and its motion (if any) kept as a prior for objects near it.
      auto movedAway = [&](int64_t* rule, const ObjectMotion* motion, const std::string& how) {
        o.belief = objectBeliefSeenElsewhere(o.belief, belief_);
        stats_.reidentified++;
        if (rule) ++*rule;
        if (motion) motions_.push_back({m->id, kf->id, o.centroid, *motion, o.id, o.class_id});
        traceObject(*kf, o, how.c_str());
        moved = true;
      };
      // A motion found in this map in the last reid_prior_keyframes keyframes.
      auto recent = [&](const PriorMotion& q) { return q.map == m->id && kf->id - q.kf <= prior_keyframes_; };
      std::optional<ReidAppearance> appearance;  // built once, for the first seen object of its class
      std::vector<ObjectMotion> priors;           // ... and the motions of objects found moved near it, lately
      for (const MapObject* s : seen_now) {
        if (s->class_id != o.class_id) continue;
        if (!appearance) {
          appearance = reidAppearance(o);
          for (const PriorMotion& q : motions_)
            if (recent(q) && !q.motion.from_prior && (q.from - o.centroid).norm() <= prior_radius_)
              priors.push_back(q.motion);
        }
        const ObjectMotion mv = reidentify(*s, o, *appearance, reid_, priors);
        if (!mv.moved) {
          if (mv.matches > 0)
            DSLAM_LOG(Trace, "objects: keyframe " << kf->id << ": object " << o.id << " not object " << s->id
                                                  << " moved (" << mv.inliers << " of " << mv.matches
                                                  << " matches, shift " << mv.shift << " m)");
          continue;
        }
        movedAway(mv.from_prior ? &stats_.reidentified_by_prior : nullptr, &mv,
                  "re-identified as object " + std::to_string(s->id) + ", moved " + std::to_string(mv.shift) +
                      " m (" + std::to_string(mv.inliers) + " of " + std::to_string(mv.matches) + " matches" +
                      (mv.from_prior ? ", by the motion of an object moved near it)" : ")"));
        break;
      }
      // Not found elsewhere itself, but a part of an object of its class
      // found moved: an object mapped from several sides is several objects
      // (their centroids too far apart for association, their boxes too
      // thin to contain each other), and the parts the camera saw before the
      // move but not after it have no descriptor matches with the new view.
      // Or, at any distance, covered by one detection with it or with its parts (reid_part_links).
      if (!moved && o.dormant && (part_radius_ > 0 || part_links_on_))
        for (const PriorMotion& q : motions_) {
          if (!recent(q) || q.class_id != o.class_id || q.object == o.id) continue;
          const double d = (q.from - o.centroid).norm();
          const bool near = part_radius_ > 0 && d <= part_radius_;
          if (!near && !(part_links_on_ && part_links_.linked(q.object, o.id))) continue;
          movedAway(&stats_.reidentified_as_part, nullptr,
                    "a part of object " + std::to_string(q.object) + " (found moved " + std::to_string(q.motion.shift) +
                        " m, " + std::to_string(d) + " m from it" + (near ? ")" : "; one detection covered both)"));
          break;
        }
      // Not found elsewhere by its own matches, but the motion of an object
      // found moved near it takes its centroid onto an object of its class
      // seen now, first seen after it was and seen twice (not one view's
      // fragment of an object that stayed): moved with it (objects moved
      // together, a backpack on a moved chair, whose old place the chair now
      // hides and whose new view shares too few matches with the old one).
      // Its motion is kept, for the parts of it (reid_part_radius).
      if (!moved && o.dormant && centroid_distance_ > 0)
        for (const PriorMotion& q : motions_) {
          if (!recent(q) || q.object == o.id || (q.from - o.centroid).norm() > prior_radius_) continue;
          const Eigen::Vector3d to = q.motion.R * o.centroid + q.motion.t;
          const auto at = std::find_if(seen_now.begin(), seen_now.end(), [&](const MapObject* s) {
            return s->class_id == o.class_id && s->first_seen_t > o.last_seen_t && s->sightings >= 2 &&
                   (s->centroid - to).norm() <= centroid_distance_;
          });
          if (at == seen_now.end()) continue;
          ObjectMotion mv = q.motion;
          mv.from_prior = true;
          mv.shift = (to - o.centroid).norm();
          // The arguments read q before movedAway appends to motions_; q is not used after.
          movedAway(&stats_.reidentified_by_centroid, &mv,
                    "moved with object " + std::to_string(q.object) + " (found moved " +
                        std::to_string(q.motion.shift) + " m, " + std::to_string((q.from - o.centroid).norm()) +
                        " m from it): its motion takes it " + std::to_string(((*at)->centroid - to).norm()) +
                        " m from object " + std::to_string((*at)->id));
          break;
        }
      if (moved && o.belief < belief_threshold_) {
        setGone(o);
        continue;
      }
    }
    const bool free = placeFree(ev);
    const bool undetected_enough = undetected_keyframes_ > 0 && ev.undetected >= undetected_keyframes_;
    if (free || undetected_enough || (judged && ev.found < min_found_fraction_ * ev.expected)) {
      o.belief = objectBeliefMissed(o.belief, belief_, free);
      stats_.misses++;
      if (tentative) {
        stats_.tentative_misses++;
        missed_lately_.insert(id);
      }
      if (log::enabled(log::Level::Debug))  // the counts behind the decision
        traceObject(*kf, o,
                    (std::string(free ? "negative evidence (its place seen through"
                                      : undetected_enough ? "negative evidence (nothing of its class detected on its place"
                                                          : "negative evidence (its points not found") +
                     "; points found " + std::to_string(ev.found) + " of " + std::to_string(ev.expected) +
                     ", place keypoints " + std::to_string(ev.with_depth) + " with depth, " +
                     std::to_string(ev.through) + " through, " + std::to_string(ev.keyframes) + " keyframes" +
                     (tentative ? ", tentative, short term)" : ")"))
                        .c_str());
      if (o.belief < belief_threshold_) {
        setGone(o);
        continue;
      }
    } else if (ev.keyframes > 0 && ev.keyframes < evidence_keyframes_) {
      pending_[id] = ev;  // not enough to decide on yet (a full window that was not enough starts again)
    }
    if (dormant_after_s_ > 0 && o.active && kf->timestamp - o.last_seen_t > dormant_after_s_) setDormant(o);
  }
  // Objects merged into others, or of another map (kept dormant until seen again).
  for (auto it = pending_.begin(); it != pending_.end();) it = objects.count(it->first) ? std::next(it) : pending_.erase(it);
  for (auto it = missed_lately_.begin(); it != missed_lately_.end();)
    it = objects.count(*it) ? std::next(it) : missed_lately_.erase(it);
  const int64_t kf_id = kf->id;
  motions_.erase(std::remove_if(motions_.begin(), motions_.end(),
                                [&](const PriorMotion& q) { return kf_id - q.kf > prior_keyframes_; }),
                 motions_.end());
}

void ObjectPersistenceFilter::onTrackingLost(const std::shared_ptr<Map>& m) {
  FilteringMapManager::onTrackingLost(m);
  if (!m || !dormant_on_lost_) return;
  std::lock_guard<std::recursive_mutex> lk(m->update_mutex);
  for (auto& [id, o] : m->objects()) {
    setDormant(*o);
    pending_.erase(id);  // evidence from before the loss is not added to evidence after it
  }
  small_.clear(m->id);
}

// ---------------------------------------------------------------------------
// PointPersistenceFilter

PointPersistenceFilter::~PointPersistenceFilter() {
  if (stats_.keyframes > 0) DSLAM_LOG(Info, "point persistence filter: " << stats_.str());
}

std::string PointPersistenceFilter::description() const {
  return "Feature persistence filter (Rosen et al. 2016) on map points of no object: points a keyframe should see but "
         "does not lose belief; below belief_threshold they are inactive; a descriptor match re-activates them";
}

std::vector<ParamSpec> PointPersistenceFilter::paramSpecs() const {
  return {
      P_double("mean_survival", 3600.0, "prior mean survival time of a feature (s; exponential prior)", 1e-3, 1e12),
      P_double("p_miss", 0.5,
               "P(not matched | present): a keyframe matches about half of the visible points of its local map "
               "(measured on walking_rpy; Rosen et al. use 0.1 for their detector)",
               1e-4, 0.99),
      P_double("p_false_alarm", 0.01, "P(matched | absent)", 1e-6, 0.99),
      P_double("belief_threshold", 0.3, "points below this survival belief are inactive", 0, 1),
      P_double("max_range", 6.0, "a keyframe should see points closer than this (m)", 0.1, 1000),
      P_double("occlusion_margin", 0.2, "a keypoint nearer than the point by more than this (m) occludes it", 0, 100),
      P_double("match_radius", 8.0, "pixels around the projection searched for occluders and re-detections", 1, 1000),
      P_int("max_descriptor_distance", 50, "an inactive point is seen again if a keypoint there is this close (ORB)",
            0, 256),
      P_bool("object_points", false, "also filter points of MapObjects (by default the object filter's)"),
  };
}

void PointPersistenceFilter::configure(const Params& p, const PluginContext& ctx) {
  MapManager::configure(p, ctx);
  fp_.mean_survival_s = p.getDouble("mean_survival");
  fp_.p_miss = p.getDouble("p_miss");
  fp_.p_false_alarm = p.getDouble("p_false_alarm");
  belief_threshold_ = p.getDouble("belief_threshold");
  max_range_ = p.getDouble("max_range");
  occlusion_margin_ = p.getDouble("occlusion_margin");
  match_radius_px_ = p.getDouble("match_radius");
  max_descriptor_distance_ = static_cast<int>(p.getInt("max_descriptor_distance"));
  object_points_ = p.getBool("object_points");
}

double PointPersistenceFilter::belief(int64_t point_id, double t) const {
  auto it = filters_.find(point_id);
  return it == filters_.end() ? 1.0 : it->second.belief(t);
}

void PointPersistenceFilter::onKeyFrame(const std::shared_ptr<KeyFrame>& kf) {
  FilteringMapManager::onKeyFrame(kf);
  Map* m = kf ? kf->map : nullptr;
  if (!m) return;
  std::lock_guard<std::recursive_mutex> lk(m->update_mutex);
  if (kf->bad) return;
  stats_.keyframes++;
  const double t = kf->timestamp;
  // The local map: points of this keyframe and of its best covisibles.
  std::set<const MapPoint*> observed;
  for (const auto& p : kf->points)
    if (p) observed.insert(p.get());
  std::map<int64_t, MapPointPtr> local;
  auto collect = [&](const KeyFrame& k) {
    for (const auto& p : k.points)
      if (p && !p->bad && (object_points_ || p->map_object < 0) && p->label != KpLabel::Dynamic) local[p->id] = p;
  };
  collect(*kf);
  for (KeyFrame* k : kf->bestCovisibles(10)) collect(*k);
  // Inactive points, wherever they were seen: a keyframe may bring them back.
  for (auto it = inactive_.begin(); it != inactive_.end();) {
    MapPointPtr p = it->second.lock();
    if (!p || p->bad || p->active) {
      it = inactive_.erase(it);
      continue;
    }
    if (p->map == m) local[p->id] = p;
    ++it;
  }
  for (const auto& [id, p] : local) {
    auto [it, inserted] = filters_.try_emplace(id, fp_, t);
    FeaturePersistence& f = it->second;
    if (t < f.lastTime()) continue;  // keyframes arrive in time order; a re-inserted one does not count twice
    bool seen = observed.count(p.get()) > 0;
    if (!seen) {
      cv::Point2f uv;
      double z = 0;
      if (!pointInView(*kf, *p, max_range_, uv, z)) continue;
      // An inactive point is seen again where a keypoint matches its descriptor.
      const Around a = lookAround(*kf, *p, uv, z, static_cast<float>(match_radius_px_), occlusion_margin_,
                                  max_descriptor_distance_, p->active ? Match::None : Match::Descriptor);
      seen = a.match;
      if (a.occluded || !a.any_depth) continue;  // hidden, or nothing to tell (no keypoint there)
    }
    f.update(seen, t);
    if (seen) {
      stats_.sightings++;
    } else {
      stats_.misses++;
    }
    const bool keep = f.belief(t) >= belief_threshold_;
    if (p->active && !keep) {
      p->active = false;
      inactive_[p->id] = p;
      stats_.deactivated++;
    } else if (!p->active && keep && seen) {
      p->active = true;
      stats_.reactivated++;
    }
  }
}

}  // namespace dslam
