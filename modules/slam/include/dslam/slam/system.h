#pragma once
/** \file system.h
 *  The SLAM system: feature front end, detectors, keypoint-classifier
 *  chain, tracking, local mapping (and, when configured, loop closing).
 *  Usable on its own (embedding: feed SensorFrames) or through
 *  runPipeline() (the `dslam run` command).
 *
 *  Threads: `Mode::Sequential` runs everything in the caller's thread and is
 *  deterministic; `Mode::Parallel` runs local mapping and loop closing in
 *  their own threads and each detector on a dslam::Worker thread
 *  concurrently with ORB extraction (the tracking thread then waits for the
 *  detections on a future). */
#include <atomic>
#include <condition_variable>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "dslam/config/pipeline.h"
#include "dslam/core/backend.h"
#include "dslam/core/camera.h"
#include "dslam/core/detector.h"
#include "dslam/core/keypoint_classifier.h"
#include "dslam/core/map_manager.h"
#include "dslam/core/timing.h"
#include "dslam/core/trajectory.h"
#include "dslam/features/frontend.h"
#include "dslam/loop_closing/keyframe_database.h"
#include "dslam/loop_closing/loop_closer.h"
#include "dslam/mapping/local_mapper.h"
#include "dslam/tracking/tracker.h"

namespace dslam {

/** Place recognition (`place_recognition:` section) and the map policy. */
struct PlaceRecognitionParams {
  bool enabled = true;           ///< vocabulary, keyframe database, BoW relocalisation
  std::string vocabulary;        ///< '' = the shipped default (defaultVocabularyPath())
  int new_map_after_lost = 15;   ///< frames lost (relocalisation failing) before a new map starts
  int min_keyframes_keep_map = 10;  ///< smaller maps are discarded instead (ORB-SLAM3: 10)
  int loop_check_every = 3;      ///< frames between place-recognition checks of tracked frames (0 = keyframes only)
  static std::vector<ParamSpec> specs();
  static PlaceRecognitionParams fromParams(const Params& p);
};

/** Parameters of the built-in pipeline sections `features:`, `tracking:`,
 *  `mapping:`, `place_recognition:`, `loop_closing:`. */
struct SlamParams {
  FrontendParams frontend;
  TrackerParams tracker;
  LocalMapperParams mapper;
  PlaceRecognitionParams place;
  LoopClosingParams loop;
  static SlamParams fromConfig(const config::PipelineConfig& pc);
};

/** Registers the `features`, `tracking`, `mapping`, `place_recognition` and
 *  `loop_closing` sections with the config loader. */
void registerSlamSections();

struct FrameResult {
  int frame_index = -1;
  double timestamp = 0;
  TrackResult track;
  size_t keypoints = 0, dynamic_keypoints = 0;
  int feature_count = 0;  ///< ORB feature count used for this frame
  double ms_total = 0;    ///< per-frame tracking-thread time
};

class System {
 public:
  System(const CameraModel& camera, const SlamParams& p, std::shared_ptr<Backend> backend,
         config::Mode mode = config::Mode::Sequential, std::shared_ptr<MapManager> maps = nullptr);
  ~System();
  System(const System&) = delete;
  System& operator=(const System&) = delete;

  /** How a detector's results reach the frames (`detection:` of a module). */
  enum class DetectionMode {
    Auto,   ///< Async in parallel mode for detectors that are not precomputed(), else Sync
    Sync,   ///< each frame waits for its own detection (every N-th frame: carried in between)
    Async,  ///< parallel mode: tracking never waits; the latest finished detection is carried to each frame
  };
  /** Adds a detector; classifiers name it as their input (first one by default).
   *  Sequential mode is always Sync (deterministic). Async with
   *  `wait_coverage` > 0: a frame whose carried boxes cover more than that
   *  fraction of the image waits for the running detection (boxCoverage()). */
  void addDetector(const std::string& name, std::shared_ptr<Detector> det, int every_n_frames = 1,
                   DetectionMode detection = DetectionMode::Auto, bool carry_by_flow = true,
                   bool redetect_keyframes = true, int hold = 0, double wait_coverage = 0.0);
  /** Appends a classifier to the chain; `detector` = "" uses the first detector. */
  void addClassifier(const std::string& name, std::shared_ptr<KeypointClassifier> c, const std::string& detector = "");

  /** Runs the whole pipeline on one frame. */
  FrameResult track(const SensorFrame& frame);
  /** Loads a saved atlas (MapManager::load) and indexes its keyframes;
   *  call before the first frame. */
  void loadMaps(const std::string& path);
  /** Receives every event as one JSON object (loop, merge, new map...). */
  void setEventSink(std::function<void(const std::string&)> sink) { on_event_ = std::move(sink); }
  /** Receives, in the tracking thread, every frame that became a keyframe
   *  (images, keypoints, classifier labels) with its detections: the dense
   *  map (dslam/dense/dense_map.h) keeps what it needs. Must return quickly. */
  using KeyFrameObserver = std::function<void(const Frame&, const std::vector<Detections>&)>;
  void setKeyFrameObserver(KeyFrameObserver fn) { kf_observer_ = std::move(fn); }
  const LoopCloser* loopCloser() const { return loop_.get(); }
  /** Waits for local mapping to finish its queue and stops the threads. */
  void shutdown();

  /** Camera trajectory of the tracked frames (T_wc), corrected by the
   *  latest keyframe poses; `lost` receives the frame indices not tracked. */
  Trajectory cameraTrajectory(std::vector<int>* lost = nullptr) const;
  Trajectory keyframeTrajectory() const;
  /** Map points as ASCII PLY (x y z, RGB by label: static grey, movable blue, dynamic red). */
  void writePly(const std::string& path) const;
  /** The semantic object map (MapObjects of every map, issue 12): JSON with
   *  class, centroid, 3D box, belief, active, points, first/last seen, and
   *  the boxes of the current map's objects as PLY faces (green active, red
   *  inactive). Objects with fewer than `min_points` map points (the rest
   *  culled; `outputs.objects_min_points`) are left out, and so are
   *  objects seen by fewer than `min_sightings` keyframes that have fewer
   *  than `confirm_points` points (`outputs.objects_min_sightings`, ...:
   *  tentative objects). An empty path skips that file. */
  void writeObjects(const std::string& json_path, const std::string& ply_path, size_t min_points,
                    int min_sightings = 1, size_t confirm_points = 0) const;

  StageTimer& timer() { return timer_; }
  const CameraModel& camera() const { return frontend_->camera(); }
  MapPtr map() const;
  MapManager& mapManager() { return *maps_; }
  const Tracker& tracker() const { return *tracker_; }
  const LocalMapper& mapper() const { return *mapper_; }
  size_t framesProcessed() const { return frames_; }
  /** Keyframes registered for labelling from their own detection that
   *  local mapping has not taken yet (0 after shutdown()). */
  size_t keyFramesAwaitingLabels() {
    std::lock_guard<std::mutex> lk(late_mtx_);
    return late_.size();
  }

 private:
  struct DetectorSlot;
  struct ClassifierSlot {
    std::string name;
    std::shared_ptr<KeypointClassifier> c;
    int detector = -1;
  };

  config::Mode mode_;
  SlamParams p_;
  StageTimer timer_;
  std::unique_ptr<FeatureFrontend> frontend_;
  std::shared_ptr<Backend> backend_;
  std::shared_ptr<MapManager> maps_;
  std::unique_ptr<LocalMapper> mapper_;
  std::unique_ptr<Tracker> tracker_;
  std::shared_ptr<KeyFrameDatabase> kfdb_;
  std::unique_ptr<LoopCloser> loop_;
  std::function<void(const std::string&)> on_event_;
  KeyFrameObserver kf_observer_;
  CameraIntrinsics intrinsics_;
  std::shared_ptr<const ScaleLevels> scale_;
  int lost_frames_ = 0;
  void switchToNewMap(int frame);
  void checkPlaceRecognition();
  /** Runs the detectors (parallel: on their threads) and the ORB front end. */
  Frame extract(const SensorFrame& in, std::vector<Detections>& dets);
  /** The classifier chain on `f`; sets the next frame's feature count. */
  void classify(Frame& f, const std::vector<Detections>& dets);
  void indexKeyFrames();
  /** Asynchronous detection: when frame `f` (classified, before tracking)
   *  became a keyframe with a detection carried from an older image, its
   *  own detection is queued; relabelKeyFrame() (local mapping's gate)
   *  waits for it, labels the keyframe again with the classifiers that
   *  relabelsKeyFrames(), and drops the map points and matches of keypoints
   *  that became dynamic. */
  void redetectKeyFrame(const SensorFrame& in, const Frame& f, const std::vector<Detections>& dets);
  void relabelKeyFrame(KeyFrame& kf);
  struct LateLabels {
    std::shared_ptr<Frame> frame;  ///< the keyframe's frame, classified with its carried detections
    struct Job {
      int detector = -1;
      std::shared_future<std::pair<Detections, double>> result;  ///< the keyframe's own detection
      Detections carried;     ///< with `hold`: the detection carried to the keyframe,
      std::vector<int> seen;  ///< the frame each of its boxes was last reported,
      int hold = 0;           ///< and the detector's hold
    };
    std::vector<Job> jobs;
    /** Every classifier that labels keypoints labels from these detections
     *  alone: the own detections' labels replace the carried ones (lowered
     *  too), else they are only raised. */
    bool replace = false;
  };
  std::mutex late_mtx_;
  std::condition_variable late_cv_;
  int tracking_frame_ = -1;  ///< frame in tracker_->track() (late_mtx_): its keyframe may not be registered yet
  std::map<int64_t, LateLabels> late_;  ///< by keyframe id
  std::atomic<int> relabelled_kfs_{0}, relabelled_kps_{0}, relabelled_pts_{0}, relabelled_lowered_{0};
  int coverage_waits_ = 0;  ///< frames that waited for a detection (`wait_coverage`)
  std::vector<std::unique_ptr<DetectorSlot>> detectors_;
  std::vector<ClassifierSlot> classifiers_;
  std::optional<Frame> prev_frame_;
  std::vector<Detections> prev_dets_;
  std::optional<SE3> prev_T_wc_;
  int base_features_ = 1000;
  size_t frames_ = 0;
  bool shut_ = false;
};

/** Builds the System a pipeline describes: its backend (default
 * *dslam::SchurBackend), map manager, detectors and classifier chain (file
 *  order), for `camera`. This is what `dslam run` does before its frame loop;
 *  programs that produce their own frames call it and then System::track().
 *  `ctx` is passed to every plug-in's configure() (config_dir defaults to
 *  the pipeline's folder, shared_dir to dslam::sharedDir(); seed and camera
 *  are set from `pc` and `camera`). Plugins must be registered
 *  (dslam::register_builtin_plugins()). */
std::unique_ptr<System> buildSystem(const config::PipelineConfig& pc, const CameraModel& camera,
                                    PluginContext ctx = {}, bool localization_only = false);

/** Options of `dslam run` that override the pipeline file. */
struct RunOverrides {
  std::string dataset;          ///< dataset path (type auto-detected unless the file has one)
  std::string out_dir;
  int max_frames = -1;
  bool quiet_progress = false;
  std::string load_atlas;
  std::string save_atlas;
  bool localization_only = false;
};

/** Summary of a run (also written to <out>/summary.json). */
struct RunSummary {
  size_t frames = 0, tracked = 0, keyframes = 0, map_points = 0, maps = 1;
  size_t skipped_frames = 0;      ///< unreadable frames skipped (dataset.on_bad_frame: skip)
  size_t empty_depth_frames = 0;  ///< RGB-D frames whose depth image has no valid pixel (tracked without depth)
  double median_ms = 0, mean_ms = 0, fps = 0, wall_s = 0;
  std::optional<double> ate_rmse;  ///< metres, SE(3) alignment, when ground truth exists
  size_t ate_pairs = 0;
  std::string out_dir;
  bool finished = false;   ///< every frame was processed (no error, no signal)
  std::string stopped_by;  ///< "" | "error" | "SIGINT" | "SIGTERM"
  int stop_signal = 0;     ///< the signal that stopped the run (dslam run exits with 128 + it)
};

/** Runs a pipeline on its dataset, writes every output, prints the summary. */
RunSummary runPipeline(const config::PipelineConfig& pc, const RunOverrides& ov = {});

}  // namespace dslam
