#pragma once
/** \file dataset.h
 *  Interface of dataset readers (TUM, Bonn, KITTI, EuRoC, MRPT rawlog,...). */
#include <optional>
#include <string>

#include "dslam/core/camera.h"
#include "dslam/core/frame.h"
#include "dslam/core/plugin.h"
#include "dslam/core/trajectory.h"

namespace dslam {

class DatasetSource : public Plugin {
  DEFINE_VIRTUAL_MRPT_OBJECT(DatasetSource)
 public:
  const char* interfaceName() const override { return "DatasetSource"; }

  /** configure() opens the dataset: it throws DataError naming the missing
   *  file or folder and describing the expected layout. */

  /** Number of frames. */
  virtual size_t size() const = 0;
  /** Loads frame i (0-based). Throws DataError with the index and path for a
   *  missing or corrupt image; the runner applies `on_bad_frame`. */
  virtual SensorFrame read(size_t i) = 0;
  /** Timestamp of frame i without loading images. */
  virtual double timestamp(size_t i) const = 0;
  virtual SensorType sensor() const = 0;
  /** Calibration carried by the dataset itself (KITTI calib.txt, EuRoC
   *  sensor.yaml, rawlog observations, TUM presets), if any. */
  virtual std::optional<CameraModel> camera() const { return std::nullopt; }
  /** Ground-truth trajectory (T_wc of the camera), empty if none. */
  virtual const Trajectory& groundTruth() const { return gt_; }
  /** Root folder / file of the dataset. */
  virtual std::string root() const = 0;

 protected:
  Trajectory gt_;
};

}  // namespace dslam
