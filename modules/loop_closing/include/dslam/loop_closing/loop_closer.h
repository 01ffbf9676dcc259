#pragma once
/** \file loop_closer.h
 *  Loop closing and map merging (ORB-SLAM2 LoopClosing, ORB-SLAM3 merging)
 *  for RGB-D / stereo, where scale is observable: candidates from the
 *  keyframe database with covisibility consistency over several keyframes,
 *  geometric verification by 3D-3D RANSAC (SE(3), Horn/Umeyama) on BoW
 *  matches plus guided matching, map-point fusion, essential-graph
 *  pose-graph optimisation through the Backend, optional global BA. A
 *  candidate in another map of the atlas merges that map into the current
 *  one. Only active map points take part.
 *
 *  Sequential mode: processAll() after local mapping (deterministic);
 *  parallel mode: start() runs it in a dslam::Worker thread.
 *
 *  Sources: loop_closer.cpp (parameters, queue, detection),
 *  loop_verification.cpp (SE(3) RANSAC and guided matching),
 *  loop_correction.cpp (fusion, essential graph, global BA). */
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>

#include "dslam/core/backend.h"
#include "dslam/core/params.h"
#include "dslam/core/timing.h"
#include "dslam/core/worker.h"
#include "dslam/loop_closing/keyframe_database.h"
#include "dslam/core/map_manager.h"
#include "dslam/map/map.h"
#include "dslam/mapping/local_mapper.h"

namespace dslam {

struct LoopClosingParams {
  bool enabled = true;
  int consistency = 3;             ///< ORB-SLAM mnCovisibilityConsistencyTh
  int strong_inliers = 100;        ///< one keyframe suffices with this many RANSAC inliers (0 = never)
  int min_bow_matches = 20;        ///< BoW matches with a candidate (ORB-SLAM: 20)
  int min_inliers = 20;            ///< RANSAC + guided-matching inliers (ORB-SLAM: 20)
  int min_total_matches = 40;      ///< matches with the loop's covisible points (ORB-SLAM: 40)
  int ransac_iterations = 300;     ///< ORB-SLAM Sim3Solver: 300
  bool refine_correction = true;   ///< refine the 3D-3D correction by reprojection errors (ORB-SLAM OptimizeSim3)
  int keyframes_between_loops = 10;///< no detection for this many keyframes after a loop (ORB-SLAM: 10)
  int essential_min_weight = 100;  ///< covisibility edges of the essential graph (ORB-SLAM: 100)
  int pose_graph_iterations = 20;  ///< ORB-SLAM: 20
  bool global_ba = true;           ///< full BA after a loop (ORB-SLAM2: yes)
  int global_ba_iterations = 10;
  bool global_ba_reject_outliers = true;  ///< optimise, drop chi2 outliers, optimise again (ORB-SLAM2's GBA: no)
  int global_ba_again_after = 0;   ///< keyframes after a loop/merge before a second global BA (0 = none, as ORB-SLAM)
  bool global_ba_at_end = false;   ///< a run that closed a loop or merge ends with a global BA (ORB-SLAM: no)
  bool merge_maps = true;          ///< candidates in other maps merge them into the current one
  uint64_t seed = 42;

  static std::vector<ParamSpec> specs();
  static LoopClosingParams fromParams(const Params& p);
};

struct LoopEvent {
  enum class Type { Loop, Merge };
  Type type = Type::Loop;
  int frame = -1;            ///< frame of the current keyframe
  int64_t kf = -1, other_kf = -1;
  int64_t map = -1, other_map = -1;
  int inliers = 0, matches = 0;
  double correction_m = 0, correction_deg = 0;  ///< change of the current keyframe's pose
  /// Predicted std [m] of the corrected camera position along its weakest
  /// axis, from the refinement's inliers at one pixel of keypoint noise
  /// (poseCovariance); -1 when the correction was not refined.
  double position_sigma_m = -1;
  std::string json() const;  ///< one JSON object, "event": "loop" | "merge"
};

const char* toString(LoopEvent::Type t);

class LoopCloser {
 public:
  LoopCloser(const LoopClosingParams& p, std::shared_ptr<Backend> backend, std::shared_ptr<KeyFrameDatabase> db,
             MapManager* maps, LocalMapper* mapper, StageTimer* timer = nullptr);
  ~LoopCloser();

  void setEventCallback(std::function<void(const LoopEvent&)> cb) { on_event_ = std::move(cb); }
  /** Queues a keyframe processed by local mapping. */
  void insertKeyFrame(const KeyFramePtr& kf);
  void processAll();
  void start();
  void stop();
  /** Waits until the queue is empty and no correction is running. */
  void waitIdle();
  /** End of the run (after stop() and processAll()): the global BA of
   *  `current` when global_ba_at_end is set and the run closed a loop or
   *  merge; timed as stage global_ba_at_end in `frame` (the last one). */
  void finish(Map& current, int frame);

  int loops() const { return loops_; }
  int merges() const { return merges_; }

 private:
  struct Candidate {
    KeyFrame* kf = nullptr;
    SE3 T12;                        ///< loop keyframe camera -> current keyframe camera
    std::vector<MapPointPtr> matches;  ///< per current keypoint: loop point
    std::vector<MapPointPtr> loop_points;
    int inliers = 0, total = 0;
    double position_sigma = -1;     ///< refinement's camera-position std [m], weakest axis (-1: not refined)
  };

  void process(const KeyFramePtr& kf);
  bool verify(KeyFrame* cur, const std::vector<KeyFrame*>& cands, Candidate& out);
  /** Pose-only refinement of the corrected T_cw of `cur` on its matched
   *  points (reprojection errors); false (Tcw unchanged) with too few inliers. */
  bool refineCorrection(KeyFrame* cur, const std::vector<MapPointPtr>& matched, SE3& Tcw,
                        double* position_sigma = nullptr) const;
  bool ransacSE3(KeyFrame* cur, KeyFrame* cand, const std::vector<MapPointPtr>& matches, SE3& T12,
                 std::vector<char>& inlier);
  int countInliers(KeyFrame* cur, KeyFrame* cand, const std::vector<MapPointPtr>& matches, const SE3& T12,
                   std::vector<char>* inlier) const;
  void correctLoop(KeyFrame* cur, Candidate& c, LoopEvent::Type type, const std::shared_ptr<Map>& other);
  void essentialGraph(Map& map, KeyFrame* fixed_kf, KeyFrame* cur, const std::map<int64_t, SE3>& non_corrected,
                      const std::map<int64_t, std::set<int64_t>>& new_links);
  /** Full BA of `map`, timed as `stage` in `frame`. */
  void globalBundleAdjustment(Map& map, const char* stage, int frame);

  LoopClosingParams p_;
  std::shared_ptr<Backend> backend_;
  std::shared_ptr<KeyFrameDatabase> db_;
  MapManager* maps_;
  LocalMapper* mapper_;
  StageTimer* timer_;
  std::function<void(const LoopEvent&)> on_event_;

  int64_t last_loop_kf_ = -1000000;
  int keyframes_to_second_ba_ = -1;  ///< countdown to the second global BA (-1: none due)
  int64_t second_ba_map_ = -1;       ///< the map it is due in (a new map after a loss cancels it)
  int loops_ = 0, merges_ = 0;
  Worker<KeyFramePtr> worker_;  ///< last member: its thread stops before the rest is destroyed
};

}  // namespace dslam
