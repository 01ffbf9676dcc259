#pragma once
/** \file convert.h
 *  Dataset converters behind `dslam convert` (docs/datasets.md):
 *
 *   - TUM RGB-D folder -> MRPT rawlog: one CObservation3DRangeScan per
 *     associated frame, lossless: the raw uint16 depth goes into rangeImage
 *     with rangeUnits = 1 / depth_factor, the colour image is embedded raw
 *     (no JPEG), intrinsics from the camera, RGB timestamp kept.
 *   - MRPT rawlog -> TUM folder (rgb/, depth/ 16-bit PNG, rgb.txt,
 *     depth.txt, associations.txt, camera.yaml). Depth whose units match
 *     the target factor is copied bit-exactly. */
#include <cstddef>
#include <string>

namespace dslam {

struct TumToRawlogOptions {
  std::string camera_file;           ///< camera YAML (docs/config.md); overrides `preset`
  std::string preset;                ///< camera preset; '' = the TUM reader's choice
  std::string associations;          ///< as the TUM reader's parameter ('' = default)
  double max_dt = 0.02;              ///< rgb/depth association threshold, seconds
  std::string sensor_label = "RGBD";
  int compression = 1;               ///< gzip level 0..9
};

struct ConvertReport {
  size_t frames = 0;
  std::string camera;  ///< where the intrinsics came from
  double depth_factor = 0;
  size_t depth_clipped = 0;  ///< rawlog2tum: pixels beyond the 16-bit range set to 0
  size_t depth_zeroed = 0;   ///< valid depth pixels that --depth-factor rounded to 0 (warned)
  bool depth_exact = true;   ///< rawlog2tum: raw depth copied unchanged
};

/** Throws DataError / ConfigError. */
ConvertReport convertTumToRawlog(const std::string& in_dir, const std::string& out_rawlog,
                                 const TumToRawlogOptions& opt = {});

struct RawlogToTumOptions {
  std::string sensor_label;  ///< '' = the only camera label
  std::string images_dir;    ///< external images; '' = <rawlog>_Images
  double depth_factor = 0;   ///< depth units per metre in the PNGs; 0 = the rawlog's (1/rangeUnits)
  bool overwrite = false;    ///< allow an OUT_DIR that already has rgb.txt
};

ConvertReport convertRawlogToTum(const std::string& in_rawlog, const std::string& out_dir,
                                 const RawlogToTumOptions& opt = {});

}  // namespace dslam
