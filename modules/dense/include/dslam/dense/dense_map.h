#pragma once
/** \file dense_map.h
 *  Dense 3D map without dynamic objects (STDyn-SLAM's OctoMap output),
 *  module `modules/dense` (docs/dense_map.md).
 *
 *  Per keyframe, when it is created (a dslam::Worker thread in parallel
 *  mode, in line in sequential mode):
 *   1. depth: the RGB-D depth image, or OpenCV SGBM disparity on the
 *      rectified stereo pair (depth = bf / disparity);
 *   2. the dynamic-pixel mask (dynamicMask()): pixels of dynamic classes in
 *      the semantic image / panoptic segments, boxes of dynamic classes
 *      (pixels near the object's depth, the depth-repopulation test),
 *      regions the classifiers found moving and a disk around every keypoint
 *      labelled dynamic; dilated;
 *   3. the masked depth and colour subsampled every `pixel_step` pixels are
 *      kept (KeyframeCloud, camera frame).
 *  At the end (or whenever integrate() is called) the OctoMap is rebuilt
 *  from every stored keyframe at its final, loop-corrected pose
 *  (octomap::ColorOcTree::insertPointCloud with max range), so the dense map
 *  follows loop closures and map merges. OctoMap stays inside the .cpp files. */
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "dslam/core/camera.h"
#include "dslam/core/detection.h"
#include "dslam/core/frame.h"
#include "dslam/core/params.h"
#include "dslam/core/se3.h"
#include "dslam/core/trajectory.h"

namespace dslam {
class Map;
}

namespace dslam::dense {

/** Parameters of the `dense_map:` pipeline section (docs/plugins.md). */
struct DenseMapParams {
  double resolution = 0.05;  ///< voxel edge (m)
  double max_range = 4.0;    ///< rays longer than this are cut (free space only up to it)
  double min_range = 0.3;    ///< nearer depths are ignored
  int pixel_step = 2;        ///< integrate every n-th pixel in x and y
  std::string colour = "image";  ///< image | height | none: voxel colour of dense.ply
  // Dynamic mask
  bool mask = true;                  ///< false: integrate every pixel (comparison baseline)
  std::vector<int> classes{1};       ///< COCO ids always dropped (people)
  bool follow_classifiers = true;    ///< also drop regions (boxes, segments) the classifiers found dynamic
  double min_dynamic_fraction = 0.5; ///< ... when at least this fraction of their keypoints is dynamic
  int min_dynamic_keypoints = 3;     ///< ... and at least this many
  int keypoint_radius = 8;           ///< px: disk dropped around every dynamic keypoint (0 = none)
  int dilation = 4;                  ///< px: the mask grows by this much
  double depth_margin = 0.5;         ///< boxes: pixels within this depth (m) of the object's depth belong to it
  double center_fraction = 0.3;      ///< boxes: object depth = median depth of this central part of the box
  // OctoMap
  double prob_hit = 0.6, prob_miss = 0.4;
  double occupancy_threshold = 0.65;  ///< with prob_hit 0.6: a voxel needs two hits (keyframes) to be occupied
  // Stereo (SGBM on the rectified pair)
  int num_disparities = 0;  ///< multiple of 16; 0 = from stereo_min_depth (bf / stereo_min_depth, at most width / 4)
  double stereo_min_depth = 1.0;  ///< m: nearest depth the automatic disparity range covers
  int block_size = 5;
  int uniqueness = 10;
  int refine_window = 0;  ///< half window of a sub-pixel SAD refinement (0 = SGBM's own)
  // Thread
  int worker_nice = 10;  ///< niceness of the dense map's thread (Linux): tracking goes first on busy cores
  int max_queued_keyframes = 4;  ///< keyframes waiting for that thread at most; more and addKeyFrame() waits
  // Pictures
  int view_size = 900;           ///< px, longest side of the top / side views
  double view_clip = 0.6;        ///< top view: voxels higher than the highest camera + this are left out (ceiling)
  double side_half_width = 2.5;  ///< side view: section of this half width (m) around the trajectory

  static std::vector<ParamSpec> specs();
  static DenseMapParams fromParams(const Params& p);
};

/** Registers the `dense_map:` section with the config loader. */
void registerDenseSection();

/** What dynamicMask() dropped, in pixels of the full image. */
struct MaskStats {
  int semantic = 0, panoptic = 0, boxes = 0, keypoints = 0;
  int total = 0;  ///< after dilation
};

/** Dynamic-pixel mask (CV_8U, 255 = dynamic) of a frame at the size of its
 *  left image, from its detections and classifier labels (rules in the file
 *  comment). `depth` (CV_32F metres, same size, 0 = unknown; may be empty)
 *  decides which pixels of a box without a mask belong to the object. */
cv::Mat dynamicMask(const Frame& f, const std::vector<Detections>& dets, const cv::Mat& depth, const DenseMapParams& p,
                    MaskStats* stats = nullptr);

/** Dense depth of a rectified stereo pair (CV_32F metres, 0 = unknown) by
 *  OpenCV SGBM with a left-right check. `bf` = baseline x fx. */
cv::Mat stereoDepth(const cv::Mat& gray_left, const cv::Mat& gray_right, double bf, const DenseMapParams& p);

/** One keyframe as kept for integration (camera frame). */
struct KeyframeCloud {
  int frame_index = -1;
  double timestamp = 0;
  cv::Mat depth;   ///< CV_32F at every pixel_step-th pixel, 0 = not integrated (unknown, dynamic, out of range)
  cv::Mat colour;  ///< CV_8UC3 RGB, same size (empty with colour: none)
  int points = 0;  ///< samples with depth kept
  int masked = 0;  ///< samples with depth dropped as dynamic
  MaskStats mask;
  double ms = 0;   ///< preprocessing time (depth, mask, subsampling)
  size_t bytes() const { return depth.total() * depth.elemSize() + colour.total() * colour.elemSize(); }
};

/** Counters and costs of a dense map (dense.json). */
struct DenseStats {
  size_t keyframes_received = 0, keyframes_stored = 0, keyframes_empty_depth = 0;
  size_t keyframes_integrated = 0, keyframes_without_pose = 0;
  size_t points_inserted = 0, points_masked = 0;
  size_t occupied_voxels = 0;
  size_t stored_bytes = 0;   ///< memory of the kept keyframe clouds
  size_t octree_bytes = 0;   ///< OctoMap memoryUsage()
  double preprocess_ms_total = 0, preprocess_ms_max = 0;
  double integrate_s = 0;    ///< the last integrate()
  double producer_wait_s = 0;  ///< time addKeyFrame() waited for a queue slot (max_queued_keyframes)
};

/** A voxel of the map: centre (map frame) and colour (RGB). */
struct Voxel {
  Eigen::Vector3d c;
  uint8_t r = 0, g = 0, b = 0;
};

class DenseMapper {
 public:
  /** `camera`: the tracking camera (rectified for stereo: System::camera());
   *  `input_camera`: the camera as configured (tells whether the loaded
   *  colour images are rectified and their channel order). `threaded`: run
   *  the per-keyframe work on a background thread (`dslam run` does in both
   *  modes; the result does not depend on it).
   *  Throws ConfigError when the camera gives neither depth nor a stereo pair. */
  DenseMapper(const CameraModel& camera, const CameraModel& input_camera, const DenseMapParams& p, bool threaded);
  ~DenseMapper();
  DenseMapper(const DenseMapper&) = delete;
  DenseMapper& operator=(const DenseMapper&) = delete;

  /** Start-up check on the first frame of the dataset: an RGB-D dataset
   *  without depth images (and no stereo pair) is a ConfigError naming the
   *  pipeline key `outputs.dense_map`. */
  void checkInput(const SensorFrame& first) const;

  /** A keyframe was created from `f` (its images, keypoints and labels) with
   *  these detections. Cheap for the caller: threaded, the work is queued. A
   *  keyframe without depth is skipped with a warning. */
  void addKeyFrame(const Frame& f, const std::vector<Detections>& dets);
  /** Waits until every queued keyframe is processed. */
  void waitIdle();

  /** Rebuilds the OctoMap from every stored keyframe at T_wc_by_frame[frame
   *  index]; keyframes without a pose (culled without a live ancestor, or in
   *  another map) are left out. */
  void integrate(const std::map<int, SE3>& T_wc_by_frame);

  /** Outputs of `dslam run` with `outputs.dense_map: true` in `dir`: map.bt,
   *  dense.ply, dense_top.png, dense_side.png, dense.json. `trajectory` is
   *  drawn on the views. Returns the paths written. */
  std::vector<std::string> writeOutputs(const std::string& dir, const Trajectory& trajectory) const;
  void writeOctoMap(const std::string& path) const;  ///< OctoMap binary (.bt, octovis)
  void writePly(const std::string& path) const;      ///< occupied voxel centres, coloured
  void writeViews(const std::string& top_png, const std::string& side_png, const Trajectory& trajectory) const;
  void writeJson(const std::string& path) const;
  /** The dataset folder the run reads: dense.json names it and, for a
   *  `dslam synth` scene, its scenario, seed and frame count, so that
   *  `dslam eval dense` can refuse another scene. */
  void setDatasetRoot(const std::string& dir) { dataset_root_ = dir; }

  std::vector<Voxel> occupiedVoxels() const;
  const DenseStats& stats() const { return stats_; }
  const DenseMapParams& params() const { return p_; }
  /** Stored keyframes in arrival order (after waitIdle()). */
  const std::vector<KeyframeCloud>& keyframes() const { return kfs_; }
  /** Preprocessing of one keyframe (what addKeyFrame() queues). */
  KeyframeCloud preprocess(const Frame& f, const std::vector<Detections>& dets) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  CameraModel cam_;
  bool colour_aligned_ = true;  ///< the loaded colour image matches the depth (rectified or RGB-D)
  bool bgr_ = true;
  DenseMapParams p_;
  cv::Mat rays_;  ///< CV_32FC2 (x/z, y/z) per sample
  std::vector<KeyframeCloud> kfs_;
  std::map<int, SE3> poses_;  ///< poses of the last integrate()
  DenseStats stats_;
  std::string dataset_root_;
  void store(KeyframeCloud&& kc);
};

/** Final poses (T_wc) of the keyframes of map `m` by frame index; erased
 *  keyframes follow their parents to a live ancestor (as the saved camera
 *  trajectory). Takes the map lock. */
std::map<int, SE3> keyFramePosesByFrame(Map& m);

/** Orthographic picture of occupied voxels, coloured by height, with the
 *  trajectory drawn on it: `top` looks down along the estimated up axis
 *  (mean camera up of the poses), otherwise from the side. Used by
 *  DenseMapper::writeViews(). */
cv::Mat renderView(const std::vector<Voxel>& voxels, double resolution, const std::vector<SE3>& camera_T_wc,
                   const std::vector<SE3>& keyframe_T_wc, bool top, const DenseMapParams& p, const std::string& title);

}  // namespace dslam::dense
