#pragma once
/** \file local_mapper.h
 *  Local mapping (ORB-SLAM2 LocalMapping): keyframe insertion, covisibility
 *  update, recent map-point culling, new points by triangulation between
 *  neighbouring keyframes, fusion of duplicates, local bundle adjustment
 *  through a Backend plugin, redundant keyframe culling.
 *
 *  Sequential mode: the owner calls processAll() after each tracked frame
 *  (deterministic). Parallel mode: start() runs the same steps in a
 *  dslam::Worker thread that takes keyframes from its queue. */
#include <atomic>
#include <functional>
#include <list>
#include <memory>
#include <mutex>

#include "dslam/core/backend.h"
#include "dslam/core/params.h"
#include "dslam/core/timing.h"
#include "dslam/core/worker.h"
#include "dslam/map/map.h"
#include "dslam/tracking/tracker.h"

namespace dslam {

struct LocalMapperParams {
  int triangulation_neighbours = 10;  ///< ORB-SLAM2: 10 (stereo/RGB-D), 20 monocular
  float kf_culling_redundancy = 0.9f; ///< keyframe culled if > this fraction of its points is seen by 3 others
  int kf_culling_min_obs = 3;         ///< thObs
  float found_ratio_min = 0.25f;      ///< recent point culled if found/visible below
  bool local_ba = true;
  int ba_iterations = 10;             ///< second pass iterations (first pass 5, ORB-SLAM)
  int ba_max_keyframes = 20;          ///< optimised keyframes: the new one + its best covisibles
  int ba_max_fixed_keyframes = 20;    ///< fixed keyframes: those seeing the most local points
  double ba_max_ms = 200;             ///< parallel mode: local BA stops with its best estimate after this long (0 = never)
  bool ba_inactive_points_fixed = true; ///< inactive points (persistence filters) constant in local BA; false = left out
  bool monocular = false;

  static std::vector<ParamSpec> specs();
  static LocalMapperParams fromParams(const Params& p);
};

/** Size and outcome of the last local bundle adjustment. */
struct LocalBAStats {
  int64_t keyframe = -1;  ///< the new keyframe it was run for
  int optimised = 0, fixed = 0, points = 0, observations = 0, iterations = 0, outliers = 0;
  bool aborted = false;
  double ms = 0;
};

class LocalMapper : public KeyFrameSink {
 public:
  LocalMapper(const LocalMapperParams& p, std::shared_ptr<Backend> backend, StageTimer* timer = nullptr);
  ~LocalMapper() override;

  /** Computes a keyframe's bag of words when it is processed (vocabulary). */
  void setBowFunction(std::function<void(KeyFrame*)> fn) { bow_fn_ = std::move(fn); }
  /** Called with every processed keyframe (loop closing queue). */
  void setKeyFrameCallback(std::function<void(const KeyFramePtr&)> cb) { on_kf_ = std::move(cb); }
  /** Called first for every keyframe, in the mapping thread, before it
   *  takes the map lock: may wait (System: for the detection of the
   *  keyframe's own image when detection is asynchronous) and may change
   *  its keypoints' labels and drop points of keypoints that became
   *  dynamic, under the map's update_mutex, before the keyframe's points are
   *  observed and new points triangulated. */
  void setKeyFrameGate(std::function<void(KeyFrame&)> fn) { gate_fn_ = std::move(fn); }

  // KeyFrameSink
  bool acceptsKeyFrames() const override { return !worker_.busy(); }
  size_t queuedKeyFrames() const override { return worker_.queued(); }
  bool isStopped() const override { return worker_.paused(); }
  void interruptBA() override { abort_ba_ = true; }
  void insertKeyFrame(const KeyFramePtr& kf) override;

  /** Sequential mode: processes every queued keyframe now. */
  void processAll();
  /** Parallel mode. */
  void start();
  void stop();  ///< finishes the queue and joins the thread
  /** Asks local mapping to hold between keyframes: returns once the keyframe
   *  being processed is finished (its local BA is asked to stop early and is
   *  skipped if it has not started); queued keyframes wait. resume() lets it
   *  go on. Pauses nest (the System holds one while it switches maps, loop
   *  closing takes its own meanwhile): local mapping goes on when every
   *  requestPause() has had its resume(). No-ops in sequential mode. */
  void requestPause();
  void resume();
  /** Clears the queue and recent points (map reset). */
  void reset();
  /** The last local BA (parallel mode: read after waitIdle / stop). */
  LocalBAStats lastLocalBA() const { return last_ba_; }

 private:
  void processOne(const KeyFramePtr& kf);
  void processNewKeyFrame();
  void mapPointCulling();
  void createNewMapPoints();
  void searchInNeighbors();
  void localBundleAdjustment();
  void keyFrameCulling();

  LocalMapperParams p_;
  std::shared_ptr<Backend> backend_;
  StageTimer* timer_;
  Map* map_ = nullptr;  ///< map of the keyframe being processed
  std::function<void(const KeyFramePtr&)> on_kf_;
  std::function<void(KeyFrame*)> bow_fn_;
  std::function<void(KeyFrame&)> gate_fn_;

  KeyFramePtr cur_;
  std::list<MapPointPtr> recent_points_;
  std::atomic<bool> abort_ba_{false}, pause_req_{false};
  LocalBAStats last_ba_;
  std::mutex pause_mtx_;
  int pauses_ = 0;  ///< requestPause() calls not yet resumed (under pause_mtx_)
  Worker<KeyFramePtr> worker_;  ///< last member: its thread stops before the rest is destroyed
};

}  // namespace dslam
