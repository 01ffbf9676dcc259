#pragma once
/** \file plot.h
 *  Plots of an evaluation: the C++ side writes a CSV (one row per associated
 *  pose pair) and scripts/plot_trajectory.py (matplotlib) draws ground truth
 *  vs the aligned estimate (xy and xz views) and the error over time. */
#include <string>
#include <vector>

#include "dslam/eval/eval.h"

namespace dslam::eval {

struct PlotRow {
  double t = 0;            ///< ground-truth stamp, seconds
  Eigen::Vector3d gt, est;  ///< positions; est after alignment
  double error = 0;         ///< NaN where there is none (RPE: last poses)
};

/** One row per associated pair; error = the ATE of the pair. */
std::vector<PlotRow> plotRows(const Trajectory& gt, const AteResult& r);
/** One row per associated pair; error = translational RPE of the pair that
 *  starts there (NaN if none). The estimate is drawn with the RPE alignment,
 *  or SE3-aligned for display if that was `none` and there are >= 3 pairs. */
std::vector<PlotRow> plotRows(const Trajectory& gt, const Trajectory& est, const RpeResult& r);

/** CSV with header `t,gt_x,gt_y,gt_z,est_x,est_y,est_z,error`. */
void writePlotCsv(const std::string& path, const std::vector<PlotRow>& rows);

/** A script shipped with dslam (plot_trajectory.py, plot_study.py): next to
 *  the executable (../share/dslam/), in the installed data folder
 *  (dslam::installDataDir()), $DSLAM_SOURCE_DIR/scripts, else the source
 *  tree baked in at build time. Empty if none exists. */
std::string findScript(const std::string& file_name);
/** scripts/plot_trajectory.py: $DSLAM_PLOT_SCRIPT, else findScript(). */
std::string plotScriptPath();
/** Runs `args` (PATH lookup for args[0]) and waits; returns the exit status,
 *  -1 if it could not be started or was killed. quiet: output to /dev/null. */
int runProgram(const std::vector<std::string>& args, bool quiet = false);
/** A Python interpreter that can `import matplotlib`: $DSLAM_PYTHON if set,
 *  else `python3` on PATH, else /usr/bin/python3. Empty if none. */
std::string findPlotPython();

/** Writes `<png without extension>.csv`, then runs the plot script to
 *  produce `png`. Returns the CSV path. Throws Error (after writing the CSV)
 *  if no Python with matplotlib is found (the message gives the install
 *  command), the script is missing, or it fails. */
std::string plot(const std::string& png, const std::vector<PlotRow>& rows, const std::string& title,
                 const std::string& error_label);

}  // namespace dslam::eval
