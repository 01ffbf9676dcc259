#pragma once
/** \file dense_eval.h
 *  `dslam eval dense MAP GT_SCENE`: a dense map (map.bt + dense.json) against
 *  the static geometry of a synthetic scene (docs/dense_map.md, "Evaluation").
 *
 *  - ghost rate: occupied voxels farther than one voxel from every static
 *    surface and within one voxel of space a moving person or object
 *    occupied at some frame, over all occupied voxels;
 *  - accuracy: distance of every occupied voxel centre to the nearest static
 *    surface (median, mean, 90th percentile);
 *  - completeness: the static surface visible from the integrated keyframes
 *    (ground-truth render at their frames, within the map's range, sampled
 *    every half voxel) that lies within one voxel of an occupied voxel.
 *  The map frame is aligned to the scene with the keyframe poses (the SE(3)
 *  that best maps the estimated keyframe poses onto the ground truth). */
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "dslam/core/se3.h"
#include "dslam/synth/scenario.h"

namespace dslam::dense {

/** A dense map as written by `dslam run` (map.bt + dense.json). */
struct DenseMapFile {
  double resolution = 0.05, max_range = 4.0, min_range = 0.3;
  std::vector<Eigen::Vector3d> occupied;  ///< occupied voxel centres (map frame)
  struct KeyFrame {
    int frame = -1;
    double timestamp = 0;
    SE3 T_wc;  ///< map frame
  };
  std::vector<KeyFrame> keyframes;  ///< the integrated keyframes
  /** The dataset of the run (dense.json "dataset"; empty in files written
   *  before it was recorded) and, for a `dslam synth` scene, its scenario,
   *  seed and frame count. */
  std::string dataset_path, dataset_scenario;
  std::optional<uint64_t> dataset_seed;
  int dataset_frames = 0;
};

/** Reads an OctoMap binary file and its dense.json (default: beside it).
 *  Throws DataError naming the file. */
DenseMapFile loadDenseMap(const std::string& bt_path, const std::string& json_path = "");

/** The scenario of a `dslam synth` folder (objects.json: source file, seed,
 *  frames, resolution); `scenario_file` overrides the source file. */
synth::Scenario sceneScenario(const std::string& scene_dir, const std::string& scenario_file = "");

struct DenseEvalOptions {
  int frame_step = 1;   ///< frames sampled for the movers' swept volume
  int pixel_step = 0;   ///< completeness: render pixels sampled (0 = width / 320)
  std::optional<SE3> T_scene_map;  ///< alignment (default: from the keyframe poses)
};

struct DenseEvalResult {
  double resolution = 0;
  size_t occupied = 0;
  size_t near_static = 0;  ///< within one voxel of a static surface
  size_t ghost = 0;        ///< not near static, in space only movers occupied
  size_t other = 0;        ///< neither (depth noise, stray points)
  double ghost_rate = 0;   ///< ghost / occupied
  double accuracy_median = 0, accuracy_mean = 0, accuracy_p90 = 0;  ///< m
  size_t surface_samples = 0, surface_covered = 0;
  double completeness = 0;  ///< covered / samples
  size_t keyframes = 0, movers = 0;
  SE3 T_scene_map;
  double alignment_rmse = 0;  ///< keyframe positions after alignment (m)
};

DenseEvalResult evaluateDense(const DenseMapFile& map, const synth::Scenario& s, const DenseEvalOptions& o = {});

std::string toText(const DenseEvalResult& r);
std::string toJson(const DenseEvalResult& r);

}  // namespace dslam::dense
