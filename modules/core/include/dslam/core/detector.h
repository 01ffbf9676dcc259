#pragma once
/** \file detector.h
 *  Interface of object detectors and segmenters. */
#include "dslam/core/detection.h"
#include "dslam/core/frame.h"
#include "dslam/core/plugin.h"

namespace dslam {

/** Bit flags of what a detector produces. */
enum DetectorOutput : unsigned { kBoxes = 1u, kSemantic = 2u, kPanoptic = 4u };

class Detector : public Plugin {
  DEFINE_VIRTUAL_MRPT_OBJECT(Detector)
 public:
  const char* interfaceName() const override { return "Detector"; }
  /** Runs on one frame. Must be callable from a worker thread (one call at
   *  a time per instance). */
  virtual Detections detect(const SensorFrame& frame) = 0;
  /** DetectorOutput flags. */
  virtual unsigned outputs() const = 0;
  /** True when detect() only reads results computed beforehand (files,
   *  ground truth) and costs next to nothing: `detection: auto` then runs it
   *  synchronously also in parallel mode. */
  virtual bool precomputed() const { return false; }
};

}  // namespace dslam
