#pragma once
/** \file rawlog.h
 *  MRPT rawlog reader (both the "observations only" and the
 *  "actions/sensory frames" formats, gzip-compressed or not) for one camera
 *  sensor label:
 *
 *   - CObservation3DRangeScan -> RGB-D: intensity image + range image,
 *     depth in metres = range * rangeUnits (ranges along rays are turned into
 *     depths). If the depth and intensity cameras differ (intrinsics or
 *     relativePoseIntensityWRTDepth), depth is registered into the intensity
 *     camera (forward splatting with a z-buffer). Camera: cameraParamsIntensity.
 *   - CObservationImage -> monocular, camera: cameraParams.
 *   - CObservationStereoImages -> stereo, camera: leftCamera, rightCamera,
 *     rightCameraPose (rectified if the distortion is zero and the right
 *     camera is a pure x translation with the same intrinsics).
 *
 *  Externally stored ("lazy-load") images are looked up in `images_dir`
 *  (default <rawlog without extension>_Images, as rawlog-edit does).
 *  Frames are streamed: configure() scans the file once keeping only
 *  indices; read(i) decodes forward from the last position (reopening the
 *  file when going backwards). MRPT headers stay in the .cpp. */
#include <memory>
#include <string>
#include <vector>

#include "dslam/core/dataset.h"

namespace dslam {

class RawlogDataset : public DatasetSource {
  DEFINE_MRPT_OBJECT(RawlogDataset, dslam)
 public:
  RawlogDataset();
  std::string description() const override;
  std::vector<ParamSpec> paramSpecs() const override;
  void configure(const Params& p, const PluginContext& ctx) override;
  size_t size() const override;
  SensorFrame read(size_t i) override;
  double timestamp(size_t i) const override;
  SensorType sensor() const override;
  std::optional<CameraModel> camera() const override;
  std::string root() const override;

  /** A sensor label found in the file with a supported observation class. */
  struct LabelInfo {
    std::string label;
    std::string obs_class;  ///< e.g. "CObservation3DRangeScan"
    size_t count = 0;
  };
  /** Every supported label of the file (sorted by label). */
  std::vector<LabelInfo> labels() const;
  /** The label being read. */
  std::string sensorLabel() const;
  /** True for the actions/sensory-frames format. */
  bool sensoryFrameFormat() const;
  /** Number of top-level objects in the file. */
  size_t objectCount() const;
  /** True if the RGB-D depth is registered into the intensity camera. */
  bool registersDepth() const;
  /** Folder of externally stored images. */
  std::string imagesDir() const;

  /** Like read(), and for RGB-D frames whose depth needs no registration
   *  also the range image exactly as stored (CV_16UC1, metres = raw *
   *  units). `depth_raw` stays empty otherwise. */
  SensorFrame readRaw(size_t i, cv::Mat* depth_raw, double* units);

 private:
  struct Impl;
  std::shared_ptr<Impl> impl_;
};

}  // namespace dslam
