#pragma once
/** \file results.h
 *  Results of a study: one CellResult per run (the cell's result.json), the
 *  aggregation over repeats and seeds (median and spread, ratio to the
 *  reference variant) and the output files results.csv, results.md,
 *  results.json and the plots (docs/ablation.md, "Outputs"). */
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "dslam/study/study.h"

namespace dslam::study {

/** What one run of a cell gave. */
struct CellResult {
  std::string cell, variant, base, dataset;
  std::optional<uint64_t> seed;
  int repeat = 0;
  std::string status;  ///< "ok" | "failed"
  std::string error;   ///< failed: why (exit code / signal and the run's error line)
  int exit_code = 0;   ///< of `dslam run`; 128 + signal if it was killed
  std::optional<double> ate_rmse;   ///< metres (study alignment)
  std::optional<double> ate_scale;  ///< Sim(3) alignment scale
  std::optional<double> rpe_trans;  ///< RMSE, metres
  std::optional<double> rpe_rot;    ///< RMSE, degrees
  size_t frames = 0, tracked = 0, keyframes = 0;
  /** From the run's frames.csv: the fewest usable (not dynamic) keypoints
   *  in a frame, and the largest ORB feature count asked for (adaptive
   *  feature count); nullopt without frames.csv. */
  std::optional<double> min_usable_keypoints, max_feature_count;
  double median_ms = 0, fps = 0, wall_s = 0;
  /** Peak resident memory of the run, MB: its own VmHWM (summary.json
   *  peak_rss_mb), else wait4's ru_maxrss (which also counts what the
   *  forking process had resident, ~80 MB for dslam ablate). */
  double peak_mb = 0;
  std::string inputs_hash;
  bool ok() const { return status == "ok"; }
  double trackedPercent() const { return frames ? 100.0 * static_cast<double>(tracked) / static_cast<double>(frames) : 0; }

  std::string toJson() const;
  static CellResult fromJson(const std::string& text, const std::string& source = "result.json");
};

/** Median and spread of one metric over the runs of a variant on a dataset. */
struct Spread {
  size_t n = 0;  ///< runs with a value
  double median = 0, min = 0, max = 0;
};
/** numpy semantics (median of an even count = mean of the middle two). */
std::optional<Spread> spread(const std::vector<double>& v);

/** One (variant, dataset) group. */
struct GroupSummary {
  std::string variant, dataset, reference;
  size_t runs = 0, failed = 0;
  std::optional<Spread> ate, rpe_trans, tracked_pct, keyframes, median_ms, fps, peak_mb, min_usable_keypoints,
      max_feature_count;
  /** median ATE / the reference variant's median ATE on the same dataset. */
  std::optional<double> ratio;
};

/** Groups the finished runs by variant and dataset (study order). */
std::vector<GroupSummary> summarize(const Study& st, const std::vector<CellResult>& results);
/** Geometric mean of a variant's ratios over the datasets (nullopt if none). */
std::optional<double> meanRatio(const std::vector<GroupSummary>& groups, const std::string& variant);

/** Information printed with every table. */
struct Provenance {
  std::string tool;        ///< "dslam 0.1.0 (commit 1a2b3c4d5e6f)"
  std::string study_file;  ///< as given on the command line
  size_t planned = 0;      ///< cells in the plan
};

/** results.csv: one row per run. */
std::string resultsCsv(const Study& st, const std::vector<CellResult>& results);
/** results.md: the pivot table variant x dataset (median ATE [min-max],
 *  ratio to the reference), then tracking/speed/memory per group and the
 *  failed runs with their errors. */
std::string resultsMarkdown(const Study& st, const std::vector<CellResult>& results, const Provenance& prov);
/** results.json: provenance, runs and group summaries. */
std::string resultsJson(const Study& st, const std::vector<CellResult>& results, const Provenance& prov);

}  // namespace dslam::study
