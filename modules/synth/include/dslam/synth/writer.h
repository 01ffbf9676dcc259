#pragma once
/** \file writer.h
 *  Writes a rendered scenario as a TUM RGB-D folder with stereo, labels and
 *  object ground truth (layout in docs/scenarios.md). */
#include <string>

#include "dslam/synth/renderer.h"
#include "dslam/synth/scenario.h"

namespace dslam::synth {

struct WriteOptions {
  bool overwrite = false;  ///< replace an existing output folder
  int threads = 0;         ///< render threads (0 = all cores)
  bool progress = true;    ///< log progress
  bool right = true;       ///< write right/ and calib.txt
  bool labels = true;      ///< write boxes/, semantic/, panoptic/
};

/** Statistics of a written sequence. */
struct WriteStats {
  int frames = 0;
  double render_seconds = 0;  ///< time spent rendering (without PNG encoding)
  double total_seconds = 0;
};

/** Renders every frame of `s` into `out_dir`. Refuses an existing non-empty
 *  folder unless opt.overwrite (ConfigError). Returns the output path. */
std::string writeSequence(const Scenario& s, const std::string& out_dir, const WriteOptions& opt = {},
                          WriteStats* stats = nullptr);

/** Loads `scenario_file`, applies overrides (frames, resolution, seed,
 *  noise) and writes it to `out_dir`; returns the output path. */
std::string renderToFolder(const std::string& scenario_file, const std::string& out_dir,
                           const ScenarioOverrides& ov = {}, const WriteOptions& opt = {});

/** Reads a boxes/<stamp>.json file written by writeSequence(). */
std::vector<Box2D> readBoxes(const std::string& file);

}  // namespace dslam::synth
