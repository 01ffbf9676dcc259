#pragma once
/** \file pipeline.h
 *  The pipeline YAML (docs/config.md):
 *
 *      pipeline: {name, mode: sequential|parallel, seed}
 *      dataset:  {type, params: {...}, on_bad_frame: fail|skip, start, max_frames, stride}
 *      camera:   {preset | intrinsics...}   # or $include{../cameras/x.yaml}; omit to use the dataset's
 *      features: {...}  tracking: {...}  mapping: {...}
 *      place_recognition: {...}  loop_closing: {...}
 *                # the SLAM engine's sections (registerSection(), registerSlamSections())
 *      modules:  [{name, type, params, inputs, enabled}, ...]
 *      outputs:  {dir, trajectory, trajectory_format, ...}
 *      plugin_dirs: [...]
 *
 *  loadPipeline() validates everything (unknown key, wrong type, missing
 *  required key, unknown plugin type) and fills every default, without
 *  running anything. */
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dslam/core/camera.h"
#include "dslam/core/params.h"

namespace dslam::config {

enum class Mode { Sequential, Parallel };

struct ModuleConfig {
  std::string name;
  std::string type;      ///< registered plugin name, e.g. dslam::BoxFilter
  std::string interface_name;
  Params params;
  std::vector<std::string> inputs;
  bool enabled = true;
  int every = 1;  ///< detectors: run on every N-th frame (the last result is carried in between)
  /** detectors: "auto" | "sync" | "async" (System::DetectionMode; async =
   *  tracking never waits for the detector, parallel mode only). */
  std::string detection = "auto";
  /** detectors: how an older detection is brought to a later frame, "flow"
   *  (moved by optical flow, detection_carry.h) | "none" (left where it was;
   *  its age still grows). */
  std::string carry = "flow";
  /** detectors: frames a box the detector stops reporting is kept (moved
   *  like a carried detection) while no new box of its class overlaps it;
   *  0 = off. Small detectors flicker: Yolo-Fastest misses a walking person
   *  on 8 frames in a row of walking_xyz. */
  int hold = 0;
  /** detectors, asynchronous: "redetect" (a keyframe whose detection was
   *  carried is detected again and labelled again before local mapping uses
   *  it) | "carried" (its carried labels stay). */
  std::string keyframes = "redetect";
  /** detectors, asynchronous: a frame whose carried boxes cover more than
   *  this fraction of the image waits for the running detection (crowded
   *  views leave few keypoints, where a lagging box hurts most); 0 = never. */
  double wait_coverage = 0;
  SourceLocation where;
};

/** What `dslam run` does with a frame the reader cannot read (missing or
 *  corrupt image): stop with the error, or skip it with a warning. */
enum class OnBadFrame { Fail, Skip };
const char* toString(OnBadFrame b);

struct DatasetConfig {
  std::string type;
  Params params;
  OnBadFrame on_bad_frame = OnBadFrame::Fail;
  int start = 0;
  int max_frames = -1;
  int stride = 1;
};

struct PipelineConfig {
  std::string file;  ///< source file ("" when built from text)
  std::string dir;   ///< base folder for relative paths
  std::string name;
  Mode mode = Mode::Sequential;
  uint64_t seed = 42;
  std::optional<DatasetConfig> dataset;
  std::optional<CameraModel> camera;  ///< nullopt: take the dataset's calibration
  std::map<std::string, Params> sections;  ///< registered extra sections ("features", "tracking", ...)
  std::vector<ModuleConfig> modules;
  Params outputs;
  std::vector<std::string> plugin_dirs;

  /** Modules implementing one interface, in file order (enabled only). */
  std::vector<const ModuleConfig*> modulesOf(const std::string& interface_name) const;
  /** The fully resolved configuration as YAML (every default filled). */
  std::string toYaml() const;
};

/** Registers an extra top-level section with its parameter list (the SLAM
 *  engine registers features, tracking, mapping, place_recognition and
 *  loop_closing: dslam::registerSlamSections()). Call before loadPipeline(). */
void registerSection(const std::string& name, std::function<std::vector<ParamSpec>()> specs,
                     const std::string& doc);
struct SectionInfo {
  std::string name, doc;
  std::function<std::vector<ParamSpec>()> specs;
};
std::vector<SectionInfo> registeredSections();

std::vector<ParamSpec> pipelineParamSpecs();
/** The keys of a `modules:` entry (name, type, params, inputs, enabled,
 *  every, detection, carry, hold, keyframes, wait_coverage). */
const std::vector<std::string>& moduleKeys();
std::vector<ParamSpec> datasetCommonParamSpecs();
std::vector<ParamSpec> outputParamSpecs();

/** Loads and validates a pipeline file. Plugins must be registered. */
PipelineConfig loadPipeline(const std::string& file);
/** Same from text (tests, embedding); relative paths resolve against base_dir. */
PipelineConfig loadPipelineText(const std::string& text, const std::string& base_dir = ".");

/** Guesses the dataset plugin for a path: TUM / Bonn folder (rgb.txt),
 *  KITTI (calib.txt), EuRoC (mav0/), MRPT rawlog (*.rawlog). Empty if unknown. */
std::string detectDatasetType(const std::string& path);

}  // namespace dslam::config
