#pragma once
/** \file tracker.h
 *  Camera tracking (ORB-SLAM2 Tracking for stereo / RGB-D): map
 *  initialisation from the first frame with enough depth, constant-velocity
 *  prediction with projection search, fallback to the reference keyframe,
 *  local-map tracking over covisible keyframes, pose-only optimisation,
 *  keyframe decision and creation, relocalisation when lost. */
#include <functional>
#include <memory>
#include <optional>
#include <unordered_map>
#include <sstream>
#include <string>
#include <vector>

#include "dslam/core/camera.h"
#include "dslam/core/params.h"
#include "dslam/map/map.h"
#include "dslam/tracking/matcher.h"
#include "dslam/tracking/tracked_frame.h"

namespace dslam {

enum class TrackState { NotInitialized, Ok, Lost };
const char* toString(TrackState s);

struct TrackerParams {
  int init_min_points = 500;      ///< usable keypoints needed to initialise (ORB-SLAM2: N > 500)
  int init_min_depth_points = 100;///< of which with depth (stereo match / valid depth)
  int min_frames = 0;             ///< ORB-SLAM mMinFrames
  int max_frames = 30;            ///< ORB-SLAM mMaxFrames (= fps)
  float ref_ratio = 0.75f;        ///< thRefRatio
  int close_tracked_min = 100;    ///< bNeedToInsertClose: tracked close points below this...
  int close_untracked_min = 70;   ///< ...and untracked close points above this
  int motion_th_rgbd = 15;        ///< projection window (px) of the motion model, RGB-D
  int motion_th_stereo = 7;       ///< same, stereo
  int local_map_th = 1;           ///< SearchLocalPoints window (RGB-D uses 3)
  int min_inliers = 30;           ///< TrackLocalMap success threshold
  int min_inliers_after_reloc = 50;
  int max_local_keyframes = 80;
  int reloc_candidates = 10;      ///< keyframes tried when relocalising without a vocabulary
  bool localization_only = false; ///< track against a fixed map, no keyframes
  int young_frames = 0;           ///< points made in the last N frames are checked against the older ones' pose (0: off)
  int young_min_older = 50;       ///< ...when at least this many older points are matched
  SensorType sensor = SensorType::RGBD;  ///< set from the camera, not from YAML

  static std::vector<ParamSpec> specs();
  static TrackerParams fromParams(const Params& p);
};

/** The tracker's view of local mapping (implemented by LocalMapper). */
class KeyFrameSink {
 public:
  virtual ~KeyFrameSink() = default;
  virtual bool acceptsKeyFrames() const = 0;
  virtual size_t queuedKeyFrames() const = 0;
  virtual bool isStopped() const = 0;
  virtual void interruptBA() = 0;
  virtual void insertKeyFrame(const KeyFramePtr& kf) = 0;
};

/** Source of relocalisation candidates (a keyframe database when a vocabulary exists). */
using RelocCandidates = std::function<std::vector<KeyFrame*>(const TrackedFrame&)>;

/** How a frame's pose was found. */
enum class TrackMethod {
  None,       ///< not tracked (or waiting to initialise)
  Init,       ///< the frame initialised the map
  Motion,     ///< constant-velocity motion model
  Reference,  ///< matching against the reference keyframe
  Reloc,      ///< relocalisation (keyframe database or nearest keyframes)
};
const char* toString(TrackMethod m);

struct TrackResult {
  TrackState state = TrackState::NotInitialized;
  std::optional<SE3> T_cw;
  int matches = 0;            ///< inlier map-point matches
  bool keyframe = false;      ///< a keyframe was created from this frame
  bool initialized = false;   ///< this frame initialised the map
  bool relocalized = false;
  TrackMethod method = TrackMethod::None;
};

class Tracker {
 public:
  Tracker(const TrackerParams& p, const CameraIntrinsics& cam, std::shared_ptr<const ScaleLevels> scale,
          KeyFrameSink* sink);

  /** Map to track in (the current map of the MapManager). */
  void setMap(const MapPtr& map) { map_ = map; }
  const MapPtr& map() const { return map_; }
  void setRelocCandidates(RelocCandidates fn) { reloc_fn_ = std::move(fn); }
  /** Computes a frame's bag of words (vocabulary) for BoW matching. */
  void setBowFunction(std::function<void(TrackedFrame&)> fn) { bow_fn_ = std::move(fn); }

  /** Tracks one frame. The caller holds no map lock; the tracker takes it. */
  TrackResult track(Frame frame);

  TrackState state() const { return state_; }
  /** Constant-velocity prediction of the next frame's T_cw (nullopt unless tracking is OK). */
  std::optional<SE3> predictedPose() const {
    if (state_ != TrackState::Ok || !last_.T_cw) return std::nullopt;
    return velocity_ ? *velocity_ * *last_.T_cw : *last_.T_cw;
  }
  const TrackedFrame& lastFrame() const { return last_; }
  KeyFrame* referenceKeyFrame() const { return ref_kf_; }
  const std::vector<MapPointPtr>& localPoints() const { return local_points_; }
  /** Makes the next tracked frame a keyframe (if mapping accepts it): place
   *  recognition saw a possible loop and the loop closer needs a keyframe. */
  void requestKeyFrame() { force_kf_ = true; }
  /** Forget everything (new map). */
  void reset();
  /** Marks the frames recorded against keyframes of `m` as lost (the map is
   *  about to be discarded). */
  void forgetMap(const Map* m);

  /** Per-frame record for the final trajectory (ORB-SLAM mlRelativeFramePoses). */
  struct Record {
    int frame_index;
    double timestamp;
    KeyFrame* ref;
    SE3 T_cr;  ///< pose relative to the reference keyframe
    bool lost;
  };
  const std::vector<Record>& records() const { return records_; }

 private:
  bool initialize();
  /** New map point from keypoint i's depth/stereo, observed by kf and matched in the current frame. */
  bool createPointFromDepth(KeyFrame* kf, size_t i);
  /** Records why a tracking step failed (logged when tracking is lost); returns false. */
  template <typename... A>
  bool fail(const A&... parts) {
    std::ostringstream o;
    (o << ... << parts);
    fail_reason_ = o.str();
    return false;
  }
  bool trackReferenceKeyFrame();
  bool trackWithMotionModel();
  bool trackLocalMap();
  bool relocalize();
  void updateLastFrame();
  void updateLocalMap();
  void searchLocalPoints();
  bool isInFrustum(MapPoint& mp, float view_cos_limit);
  int optimizePose();
  int discardOutliers();
  bool needNewKeyFrame();
  void createNewKeyFrame();

  bool isStereoRig() const { return p_.sensor == SensorType::Stereo; }

  TrackerParams p_;
  CameraIntrinsics cam_;
  std::shared_ptr<const ScaleLevels> scale_;
  KeyFrameSink* sink_;
  MapPtr map_;
  RelocCandidates reloc_fn_;
  std::function<void(TrackedFrame&)> bow_fn_;
  Matcher matcher_;

  TrackState state_ = TrackState::NotInitialized;
  TrackedFrame cur_, last_;
  std::optional<SE3> velocity_;
  KeyFrame* ref_kf_ = nullptr;
  std::unordered_map<int64_t, int64_t> kf_frame_;  ///< frame_id_ of every keyframe this tracker made (young_frames)
  std::vector<KeyFrame*> local_kfs_;
  std::vector<MapPointPtr> local_points_;
  int matches_inliers_ = 0;
  bool force_kf_ = false;
  std::string fail_reason_;
  int64_t frame_id_ = -1;         ///< internal running frame counter
  int64_t last_kf_frame_ = -1, last_reloc_frame_ = -100000;
  KeyFrame* last_kf_ = nullptr;
  std::vector<Record> records_;
};

}  // namespace dslam
