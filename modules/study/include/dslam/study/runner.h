#pragma once
/** \file runner.h
 *  Running the cells of a study (`dslam ablate`, docs/ablation.md).
 *
 *  Each cell runs `dslam run` as a child process (fork + exec of the dslam
 *  executable): a crash of one run does not end the study, and the run's
 *  peak memory is its own (summary.json peak_rss_mb, else wait4()'s
 *  ru_maxrss). A cell's folder
 *  `<out>/cells/<id>/` holds `config.yaml` (its resolved pipeline),
 *  `cell.json`, `log.txt` (the run's output), `run/` (trajectory, summary,
 *  timing...), `aligned.txt`, `result.json` and, written last by an atomic
 *  rename, the `done` marker that --resume and --collect rely on. Cells are
 *  independent, so a cluster scheduler can run each with `--cell ID`. */
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "dslam/core/trajectory.h"
#include "dslam/study/results.h"
#include "dslam/study/study.h"

namespace dslam::study {

struct RunOptions {
  std::string out_dir;      ///< study output folder (shared by every cell)
  std::string scene_cache;  ///< rendered scenarios ("" = <out_dir>/scenes)
  int jobs = 1;             ///< concurrent cells
  bool resume = false;      ///< keep finished cells (same inputs), run the others
  bool overwrite = false;   ///< allow a full run over finished cells without --resume (they are redone)
  std::vector<std::string> only;  ///< glob patterns on cell ids (fnmatch); empty = all
  std::string dslam_exe;    ///< the dslam executable ("" = this process, /proc/self/exe)
  Provenance provenance;    ///< tool version and study file for the tables
  bool plots = true;        ///< draw the PNG plots (needs python3 + matplotlib; skipped with a warning otherwise)
};

/** Folder of a dataset: its path, or the scene-cache folder of a scenario
 *  (rendered there first if missing: into a temporary folder, then renamed,
 *  so concurrent cells on other machines never see a partial scene). */
std::string prepareDataset(const Dataset& d, const std::string& scene_cache, bool log_progress = true);
std::string sceneCacheDir(const RunOptions& o);

/** Ground truth of a dataset folder, read by the reader `dslam run` would
 *  use: the dataset section of `pipeline_yaml` if it has one, else the type
 *  detected from the folder. */
Trajectory datasetGroundTruth(const std::string& folder, const std::string& pipeline_yaml = "");

std::string cellDir(const std::string& out_dir, const Cell& c);
/** The finished result of a cell (done marker present, inputs unchanged). */
std::optional<CellResult> finishedResult(const std::string& out_dir, const Cell& c);
/** Results of every finished cell of the plan, in plan order. */
std::vector<CellResult> collectResults(const Study& st, const std::string& out_dir);

/** Runs one cell in the foreground (renders its dataset if needed). */
CellResult runCell(const Study& st, const Cell& c, const RunOptions& o);

/** Cells selected by `only` (all if empty); throws ConfigError if a pattern
 *  matches nothing. */
std::vector<Cell> selectCells(const std::vector<Cell>& plan, const std::vector<std::string>& only);

struct StudyRunReport {
  size_t planned = 0, selected = 0, skipped = 0, ran = 0, ok = 0, failed = 0;
  int stop_signal = 0;  ///< SIGINT/SIGTERM that interrupted the study
  /** Why no further cell was started although some were left: the dslam
   *  executable was replaced or removed while the study ran (a rebuild);
   *  the running cells finished with the build they started with. */
  std::string stopped_because;
};

/** Runs the selected cells with at most o.jobs at a time, printing progress
 *  (cells done / total, ETA) to stdout, then writes the results. A failed
 *  cell is recorded (result.json with its error) and the others go on.
 *  SIGINT/SIGTERM stop the running cells (not marked done) and return. */
StudyRunReport runStudy(const Study& st, const RunOptions& o);

/** Writes results.csv, results.md, results.json and plots/ from the
 *  finished cells; returns how many results were collected. */
size_t writeResults(const Study& st, const RunOptions& o);

}  // namespace dslam::study
