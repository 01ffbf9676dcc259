// `dslam ablate STUDY.yaml --out DIR [--jobs N] [--resume] [--only PATTERN]`:
// ablation studies (docs/ablation.md). Cluster use: `--plan` lists the cells,
// `--cell ID` / `--cell-index N` runs one into the shared output folder,
// `--collect` aggregates what has finished.
#include <csignal>
#include <iostream>
#include <set>
#include <sstream>

#include "command.h"
#include "dslam/core/error.h"
#include "dslam/core/paths.h"
#include "dslam/study/runner.h"
#include "dslam/study/study.h"

namespace {

using namespace dslam;

struct Opts {
  std::string study, out, scene_cache, cell, dslam_exe;
  long long cell_index = -1;
  int jobs = 1;
  bool resume = false, overwrite = false, plan = false, collect = false, prepare = false, no_plots = false;
  std::vector<std::string> only;
};

std::vector<std::string> splitPatterns(const std::vector<std::string>& in) {
  std::vector<std::string> out;
  for (const auto& s : in) {
    std::stringstream ss(s);
    std::string p;
    while (std::getline(ss, p, ','))
      if (!p.empty()) out.push_back(p);
  }
  return out;
}

study::RunOptions runOptions(const Opts& o, const study::Study& st) {
  study::RunOptions r;
  r.out_dir = o.out.empty() ? "out/studies/" + st.name : o.out;
  r.scene_cache = o.scene_cache;
  r.jobs = o.jobs;
  r.resume = o.resume;
  r.overwrite = o.overwrite;
  r.only = splitPatterns(o.only);
  r.dslam_exe = o.dslam_exe;
  r.plots = !o.no_plots;
  r.provenance.tool = app::versionString();
  r.provenance.study_file = o.study;
  return r;
}

const study::Cell& findCell(const std::vector<study::Cell>& plan, const Opts& o) {
  if (o.cell_index >= 0) {
    if (static_cast<size_t>(o.cell_index) >= plan.size())
      throw ConfigError("--cell-index " + std::to_string(o.cell_index) + ": the study has " +
                        std::to_string(plan.size()) + " cells (0.." + std::to_string(plan.size() - 1) + ")");
    return plan[static_cast<size_t>(o.cell_index)];
  }
  for (const auto& c : plan)
    if (c.id == o.cell) return c;
  throw ConfigError("--cell '" + o.cell + "': no such cell in the study (see --plan)");
}

void run(const Opts& o) {
  const int modes = o.plan + o.collect + o.prepare + (!o.cell.empty() || o.cell_index >= 0);
  if (modes > 1) throw ConfigError("--plan, --cell/--cell-index, --collect and --prepare exclude each other");
  if (!o.cell.empty() && o.cell_index >= 0) throw ConfigError("give --cell or --cell-index, not both");
  const study::Study st = study::loadStudy(o.study);
  const auto plan = st.plan();
  if (o.plan) {
    for (const auto& c : study::selectCells(plan, splitPatterns(o.only))) std::cout << c.id << "\n";
    std::cout << std::flush;
    if (o.only.empty())
      std::cerr << st.name << ": " << plan.size() << " cells (line k, from 0, is --cell-index k)" << std::endl;
    else
      std::cerr << st.name << ": cells selected by --only, of " << plan.size() << " (--cell-index counts in the full plan)"
                << std::endl;
    return;
  }
  const study::RunOptions ro = runOptions(o, st);
  if (o.prepare) {  // the datasets of the cells --only selects (all without it)
    std::set<std::string> used;
    for (const auto& c : study::selectCells(plan, ro.only)) used.insert(c.dataset);
    for (const auto& d : st.datasets) {
      if (!used.count(d.name)) continue;
      const std::string dir = study::prepareDataset(d, study::sceneCacheDir(ro));
      std::cout << d.name << ": " << dir << std::endl;
    }
    return;
  }
  if (o.collect) {
    if (!dirExists(ro.out_dir + "/cells"))
      throw DataError(ro.out_dir + " has no finished cells of study " + st.name +
                      " (no cells/ folder): give the --out of a run of this study");
    const size_t n = study::writeResults(st, ro);
    std::cout << "collected " << n << " of " << plan.size() << " cells: " << ro.out_dir << "/results.md" << std::endl;
    return;
  }
  if (!o.cell.empty() || o.cell_index >= 0) {
    const study::Cell& c = findCell(plan, o);
    if (o.resume) {
      if (auto prev = study::finishedResult(ro.out_dir, c); prev && prev->ok()) {
        std::cout << c.id << ": finished earlier (--resume), skipped" << std::endl;
        return;
      }
    }
    std::cout << "cell " << c.id << " (" << c.index + 1 << " of " << plan.size() << ")" << std::endl;
    const study::CellResult r = study::runCell(st, c, ro);
    if (r.ok())
      std::cout << c.id << ": ok" << (r.ate_rmse ? ", ATE " + std::to_string(*r.ate_rmse) + " m" : std::string())
                << ", " << r.wall_s << " s, peak " << r.peak_mb << " MB" << std::endl;
    else
      std::cout << c.id << ": FAILED: " << r.error << std::endl;
    if (!r.ok()) app::exitCode() = 1;
    return;
  }
  const study::StudyRunReport rep = study::runStudy(st, ro);
  if (rep.stop_signal) app::exitCode() = 128 + rep.stop_signal;
  else if (rep.failed || !rep.stopped_because.empty()) app::exitCode() = 1;
}

void setup(CLI::App& sub) {
  static Opts o;
  sub.add_option("study", o.study, "study file (config/studies/*.yaml, docs/ablation.md)")->required();
  sub.add_option("-o,--out", o.out, "output folder shared by every cell (default out/studies/<study name>)");
  sub.add_option("-j,--jobs", o.jobs, "cells run at the same time")->capture_default_str()->check(CLI::Range(1, 256));
  sub.add_flag("--resume", o.resume, "keep the finished cells of an earlier run, run the others");
  sub.add_flag("--overwrite", o.overwrite, "run every cell again even if an earlier run finished it");
  sub.add_option("--only", o.only, "run only the cells whose id matches this glob (repeatable, or comma-separated)")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  sub.add_flag("--plan", o.plan, "print the cell ids, one per line, and exit");
  sub.add_option("--cell", o.cell, "run this one cell (cluster jobs); results: --collect");
  sub.add_option("--cell-index", o.cell_index, "run the cell on line N (from 0) of --plan, e.g. $SLURM_ARRAY_TASK_ID")
      ->check(app::kNonNegative);
  sub.add_flag("--collect", o.collect, "write results.csv/md/json and plots from the finished cells");
  sub.add_flag("--prepare", o.prepare,
               "render the scenario datasets into the scene cache and exit (with --only: those of the selected cells)");
  sub.add_option("--scene-cache", o.scene_cache, "folder of rendered scenarios (default <out>/scenes)");
  sub.add_flag("--no-plots", o.no_plots, "do not draw the PNG plots");
  sub.add_option("--dslam", o.dslam_exe, "dslam executable that runs the cells (default: this one)")
      ->group("");  // hidden: tests and debugging
  sub.callback([] { run(o); });
}

}  // namespace

DSLAM_COMMAND(ablate, "Run an ablation study: variants x datasets x repeats, with resume and cluster cells", setup);
