#pragma once
/** \file renderer.h
 *  Deterministic CPU ray caster for synthetic scenarios: RGB, stereo right
 *  image, Kinect-like depth and exact labels (semantic, instance, panoptic,
 *  boxes). Output depends only on the scenario (and its seed), never on the
 *  thread count. */
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "dslam/core/camera.h"
#include "dslam/synth/scenario.h"
#include "dslam/synth/scene.h"

namespace dslam::synth {

/** A COCO panoptic segment of one frame. */
struct Segment {
  int id = 0;           ///< value in the panoptic PNG (R + 256 G + 256^2 B)
  int category_id = 0;  ///< COCO id
  int instance_id = 0;  ///< scene instance (0 for stuff)
  bool iscrowd = false;
  cv::Rect bbox;        ///< visible pixels
  int area = 0;
};

/** A ground-truth "detection" (visible bounding box of a labelled thing). */
struct Box2D {
  int category_id = 0;
  int instance_id = 0;
  std::string name;     ///< object / person name in the scenario
  cv::Rect2f box;       ///< x, y, w, h in pixels
  float score = 1.0f;
  int area = 0;         ///< visible pixels
};

struct FrameRender {
  int index = 0;
  double timestamp = 0;
  SE3 T_wc;
  cv::Mat rgb;       ///< CV_8UC3, BGR (OpenCV order)
  cv::Mat right;     ///< CV_8UC3 BGR right stereo image (empty if disabled)
  cv::Mat depth;     ///< CV_16UC1, 5000 units per metre, sensor model applied (0 = invalid)
  cv::Mat depth_m;   ///< CV_32FC1 exact depth (camera z, metres), before noise
  cv::Mat semantic;  ///< CV_8UC1 COCO id per pixel, 255 = none / not in label set
  cv::Mat instance;  ///< CV_32SC1 instance id (0 = room)
  cv::Mat panoptic;  ///< CV_32SC1 panoptic segment id (0 = void)
  std::vector<Segment> segments;
  std::vector<Box2D> boxes;
};

struct RenderOptions {
  int threads = 0;      ///< 0 = hardware concurrency
  bool right = true;    ///< render the stereo right image
  bool labels = true;   ///< compute segments and boxes
};

/** Panoptic segment id of an instance / a stuff category (documented in
 *  docs/scenarios.md): things 1000 + instance id, stuff = category id. */
int panopticId(const InstanceInfo& inst);

class Renderer {
 public:
  explicit Renderer(const Scenario& s, const RenderOptions& opt = {});
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  const Scenario& scenario() const;
  const SceneModel& scene() const;
  /** Intrinsics of the rendered images. */
  const PinholeCamera& intrinsics() const;
  /** RGB-D camera model (baseline = stereo baseline, depth factor 5000). */
  CameraModel cameraModel() const;
  int frames() const;

  /** Renders frame i (0-based). Throws DataError if out of range. */
  FrameRender render(int frame) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dslam::synth
