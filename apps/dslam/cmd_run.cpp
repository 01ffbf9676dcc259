// `dslam run CONFIG.yaml [--dataset PATH] [--out DIR] [--max-frames N]`
#include <iostream>

#include "command.h"
#include "dslam/config/pipeline.h"
#include "dslam/slam/system.h"

namespace {

void setup(CLI::App& sub) {
  static std::string file;
  static dslam::RunOverrides ov;
  sub.add_option("config", file, "pipeline YAML (config/pipelines/...)")->required();
  sub.add_option("-d,--dataset", ov.dataset, "dataset folder or rawlog (type auto-detected); overrides the file's dataset path");
  sub.add_option("-o,--out", ov.out_dir, "output folder (default: outputs.dir or out/<pipeline name>)");
  sub.add_option("-n,--max-frames", ov.max_frames, "process at most N frames")->check(dslam::app::kPositive);
  sub.add_option("--load-atlas", ov.load_atlas, "start from a saved atlas (dslam run --save-atlas / outputs.atlas)");
  sub.add_option("--save-atlas", ov.save_atlas, "save every map to this file at the end (overrides outputs.atlas)");
  sub.add_flag("--localization-only", ov.localization_only, "track against the loaded map without mapping");
  sub.add_flag("--no-progress", ov.quiet_progress, "no progress line");
  sub.callback([] {
    const auto pc = dslam::config::loadPipeline(file);
    const dslam::RunSummary sum = dslam::runPipeline(pc, ov);
    if (sum.stop_signal) dslam::app::exitCode() = 128 + sum.stop_signal;  // as the shell reports a signal
  });
}

}  // namespace

DSLAM_COMMAND(run, "Run a SLAM pipeline on a dataset and write trajectory, map, timing and summary", setup);
