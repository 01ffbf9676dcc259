#pragma once
/** \file objects.h
 *  Evaluation of a run's semantic object map (`objects.json`, format
 *  "dslam-objects" version 1) against the ground truth of a synthetic scene
 *  (the scene folder's `objects.json` and `groundtruth.txt` written by
 *  `dslam synth`). Definitions: docs/evaluation.md, "Semantic object map".
 *
 *  - The estimated objects are brought into the ground-truth frame by the
 *    alignment of the run's trajectory to the scene's ground truth, computed
 *    on the poses before `align_until` (default: the start of the first
 *    change event) so that a map that went wrong after a change does not
 *    pull the alignment.
 *  - Ground-truth objects: labelled COCO things other than person, each with
 *    its oriented 3D box (object frame at the centre of the bottom face,
 *    box = size around (0, 0, size.z / 2)) at the end of the sequence and
 *    the boxes of the places it left (moved, removed, replaced).
 *  - Distance of an estimated object to a ground-truth box: the distance of
 *    its centroid to the box (0 inside). An estimated centroid is a mean of
 *    points on the visible surfaces; a mean of points on a convex box lies
 *    in the box, so a correct object has distance 0 whatever part of it was
 *    seen, and any positive distance is error. The distance between the
 *    centroid and the box centre is reported too (it mixes error with the
 *    viewpoint: up to half the box diagonal for a perfect map).
 *  - Matching: one-to-one, greedy by the smallest box distance, active
 *    estimated objects of the same class within `match_radius`; an
 *    estimated object nearer to a place a same-class object left than to the
 *    present box is not a match of the present object (it is the old one).
 *
 *  Every "nothing to compare" condition throws DataError naming the file. */
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "dslam/core/se3.h"
#include "dslam/core/trajectory.h"
#include "dslam/eval/eval.h"

namespace dslam::eval {

/** An oriented 3D box: object frame T_wo (origin at the centre of the bottom
 *  face, z up) and size (x, y, z) in that frame. */
struct ObjectBox {
  SE3 T_wo;
  Eigen::Vector3d size = Eigen::Vector3d::Zero();
  Eigen::Vector3d centre() const;
  /** Euclidean distance from p to the box (0 inside or on it). */
  double distance(const Eigen::Vector3d& p) const;
};

// ------------------------------------------------------ estimated objects --

/** One object of a run's objects.json (fields of dslam::MapObject). */
struct EstObject {
  int64_t id = -1;
  int map = 0;
  int class_id = -1;  ///< COCO id
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Vector3d box_min = Eigen::Vector3d::Zero(), box_max = Eigen::Vector3d::Zero();
  int points = 0;
  double belief = 0;
  bool active = true;
  /** In the map but not used to localise until seen again (dslam's object
   *  persistence filter: not confirmed for long, or tracking was lost);
   *  false when the file does not say. */
  bool dormant = false;
  int64_t first_seen_kf = -1, last_seen_kf = -1;
  double first_seen_t = 0, last_seen_t = 0;
  int sightings = -1;  ///< keyframes that saw it; -1 = the file does not say
};

struct EstObjects {
  std::string file;
  int map = 0;  ///< the map trajectory.txt is expressed in
  std::vector<EstObject> objects;  ///< every object of the file (all maps)
};

/** Reads a run's objects.json. DataError (naming the file) if it is missing,
 *  not JSON, not "dslam-objects" version 1 (a scene's objects.json is
 *  recognised and named as such), or has a malformed object (missing or
 *  mistyped field, class id that is not a COCO category, class name that is
 *  not the name of the class id). */
EstObjects readEstObjects(const std::string& file);

// --------------------------------------------------------- scene truth --

struct SceneObject {
  int instance_id = 0;
  std::string name, type, cls;
  int category_id = 0;
  bool labelled = false, moving = false;
  Eigen::Vector3d size = Eigen::Vector3d::Zero();
  std::vector<std::pair<int, int>> present;        ///< frame ranges [first, last]
  std::vector<std::pair<int, SE3>> track;          ///< (frame, T_wo) whenever the pose changes
  std::vector<int> visible_pixels;                 ///< per frame
  bool presentAt(int frame) const;
  /** Pose at `frame`: the last track entry at or before it (the first one
   *  if none). */
  SE3 poseAt(int frame) const;
  /** Visible pixels summed over frames [first, last]. */
  int64_t visibleIn(int first, int last) const;
};

struct SceneEvent {
  std::string type, object, by;  ///< moved | removed | added | replaced
  int first = 0, last = 0;       ///< frames
  double t_first = 0, t_last = 0;
};

/** The scene's ground-truth depth maps (what the camera saw), for the
 *  visibility of places objects left. Empty `files` when the folder has no
 *  depth.txt or objects.json no intrinsics (older scenes): unknown. */
struct SceneDepth {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double depth_factor = 0;          ///< stored value per metre
  std::vector<std::string> files;   ///< per frame, paths relative to the scene folder
};

/** A `dslam synth` scene folder: objects.json + groundtruth.txt (+ depth). */
struct Scene {
  std::string dir, name;
  int frames = 0;
  Trajectory gt;
  std::vector<SceneObject> objects;
  std::vector<SceneEvent> events;
  SceneDepth depth;
  const SceneObject* find(const std::string& name) const;
};

/** DataError (naming the folder or file) if the folder, its objects.json or
 *  groundtruth.txt is missing, or objects.json is not a scene's (a run's
 *  "dslam-objects" file is recognised and named as such). */
Scene readScene(const std::string& dir);

// ---------------------------------------------------------- evaluation --

struct ObjectEvalOptions {
  Align align = Align::SE3;  ///< None or SE3 (objects are metric)
  /** Align on the poses with ground-truth stamp < align_until; NaN = the
   *  start of the first event (all poses if the scene has none). */
  double align_until = std::numeric_limits<double>::quiet_NaN();
  double match_radius = 0.5;       ///< metres, centroid-to-box distance
  /** An estimate whose centroid lies within this distance (m) of the box of
   *  an object of its class present at the end is on that object, also when
   *  a place an object of its class left holds it (an object moved by less
   *  than its size: the places overlap, and the centroid of a fragment of
   *  its surface lies a few cm outside its box with depth noise and the
   *  alignment's error): matched or a duplicate, not stale. 0 = the nearer
   *  of the two boxes decides. */
  double on_object_margin = 0.05;
  int64_t min_visible_pixels = 2000;  ///< a ground-truth object (place) counts if seen at least this much
  /** Estimated objects with fewer map points are left out (as if not in the
   *  file): the precision/recall trade-off of `outputs.objects_min_points`
   *  from one run that wrote every object. 0 = every object of the file. */
  int min_points = 0;
  /** Estimated objects seen by fewer keyframes (their `sightings`) are left
   *  out too, unless they have at least `confirm_points` map points: the
   *  trade-off of `outputs.objects_min_sightings` from one run. 0 or 1 =
   *  every object; a file without sightings is an error then. */
  int min_sightings = 0;
  int confirm_points = 0;  ///< see min_sightings; 0 = no exception
  double max_dt = 0.02;            ///< trajectory association, seconds
  /** The run and the scene do not match if the ATE of the alignment poses
   *  exceeds this (metres) or less than half the trajectory's poses have a
   *  ground-truth pose within max_dt. */
  double max_ate = 0.5;
  std::string run_name = "run", traj_name = "trajectory";  ///< for messages (file paths)
  /** A place an object left counts as seen since when, in one frame after
   *  it left, at least this fraction of a 5x5x5 grid of points filling its
   *  box is in the image and not hidden (ground-truth depth at the pixel >=
   *  the point's depth - 0.1 m): the camera saw through the place or onto
   *  what stands there now. 0 = not computed. */
  double place_seen_fraction = 0.5;
};

/** What happened to a ground-truth object during the sequence. */
enum class Fate {
  Static,    ///< present throughout, never moved
  Moved,     ///< present at the end, at another place
  Added,     ///< absent at the start (added, or the new object of a replacement)
  Removed,   ///< gone at the end
  Replaced,  ///< gone at the end, another object took its place
  Other      ///< not evaluated (a moving object, unlabelled or not a COCO thing, a person)
};
const char* toString(Fate f);

struct GtObjectResult {
  int instance_id = 0;
  std::string name, cls;
  int category_id = 0;
  Fate fate = Fate::Other;
  bool at_end = false;  ///< present at the end of the sequence
  /** Visible pixels at its final place (after it got there); 0 if gone. */
  int64_t seen_at_end = 0;
  /** Counted in the recall / moved / added metrics (at_end, seen_at_end >=
   *  min_visible_pixels, fate Static/Moved/Added). Objects present at the end
   *  that are not counted still absorb matches (neither found nor false). */
  bool counted = false;
  ObjectBox box;  ///< at the end (if at_end)
  int64_t match = -1;  ///< id of the matched estimated object
  double box_dist = -1, centre_dist = -1;  ///< of the match, metres
  /** Places it left (moved, removed, replaced), seen before it left. */
  struct OldPlace {
    ObjectBox box;
    int frame = 0;          ///< last frame there
    int64_t seen = 0;       ///< visible pixels before leaving
    bool counted = false;   ///< seen >= min_visible_pixels
    std::vector<int64_t> est;  ///< unmatched estimated objects of the class within match_radius
    std::string state;      ///< "inactive" (all of them), "active" (one is stale), "not mapped" (none)
    int left_at = 0;        ///< last frame of the event (it is gone from the place after it)
    double left_t = 0;      ///< time of that frame (the event's t_last)
    /** Largest fraction of the place seen in one frame after it left
     *  (ObjectEvalOptions::place_seen_fraction); -1 = unknown (no depth). */
    double seen_after = -1;
    bool seenSince(double fraction) const { return fraction > 0 && seen_after >= fraction; }
  };
  std::vector<OldPlace> old_places;
};

enum class Verdict { Match, DontCare, Stale, False, Inactive, Ignored };
const char* toString(Verdict v);

struct EstObjectResult {
  EstObject obj;          ///< centroid and box in the ground-truth frame
  Verdict verdict = Verdict::Ignored;
  int gt_instance = -1;   ///< Match / DontCare: the object; Stale: the object that left
  double box_dist = -1;   ///< to that object's box
  std::string note;       ///< why it is ignored
};

struct ObjectEvalResult {
  ObjectEvalOptions options;
  std::string run_file, traj_file, scene_dir;
  int map = 0;
  // alignment
  Alignment alignment;
  double align_until = 0;     ///< used (+inf: all)
  size_t align_pairs = 0, assoc_pairs = 0, traj_poses = 0;
  double align_ate = 0;       ///< ATE RMSE on the alignment poses, metres
  double ate = 0;             ///< ATE RMSE on every associated pose
  // inputs
  size_t est_in_file = 0, est_other_maps = 0, est_evaluated = 0;
  size_t est_too_few_points = 0;  ///< of the map, left out by min_points
  size_t est_too_few_sightings = 0;  ///< of the map, left out by min_sightings
  std::vector<GtObjectResult> gt;
  std::vector<EstObjectResult> est;  ///< the objects of the map
  // headline
  int static_total = 0, static_found = 0;
  int moved_total = 0, moved_found = 0;
  std::vector<double> moved_errors, moved_centre_errors;  ///< per found moved object
  int added_total = 0, added_found = 0;
  int gone_total = 0, gone_inactive = 0, gone_unmapped = 0;  ///< removed / replaced objects seen before
  int stale = 0, false_objects = 0;
  /** Stale objects at places the camera saw after the object left (the
   *  persistence filter had evidence to act on); the others stand at
   *  places never seen since, which no observation can have corrected. */
  int stale_seen = 0;
  /** Stale objects that are dormant (`EstObject::dormant`): in the semantic
   *  map, but taking no part in tracking or relocalisation. */
  int stale_dormant = 0;
  bool place_visibility = false;  ///< seen_after computed (the scene has depth)
  double recall() const { return static_total ? double(static_found) / static_total : 0; }
};

/** Evaluates `est` (objects of est.map only) against the scene. `traj` is
 *  the run's trajectory (may be empty when options.align == None: no
 *  alignment and no match check). Throws DataError when the run and the
 *  scene do not match or the alignment has fewer than 3 poses. */
ObjectEvalResult evaluateObjects(const Scene& scene, const EstObjects& est, const Trajectory& traj,
                                 const ObjectEvalOptions& opt = {});

/** A readable table (ground-truth objects, then estimated objects that are
 *  stale / false) and the headline lines. */
std::string toText(const ObjectEvalResult& r);
/** One JSON object (docs/evaluation.md lists the keys). */
std::string toJson(const ObjectEvalResult& r);

}  // namespace dslam::eval
