// writeResults(): the study's tables (CSV, Markdown, JSON) and plots (PNG,
// drawn by scripts/plot_study.py with matplotlib from CSV files written here).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "dslam/config/pipeline.h"
#include "dslam/core/atomic_file.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/eval/plot.h"
#include "dslam/study/runner.h"
#include "dslam/trajectory/io.h"

namespace fs = std::filesystem;

namespace dslam::study {

namespace {

void writeAtomic(const fs::path& p, const std::string& text) {
  AtomicOfstream f(p.string());
  f << text;
  f.commit();
}

std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof(b), "%.9g", v);
  return b;
}

/** The run of a group whose ATE is closest to the group's median. */
const CellResult* representative(const std::vector<CellResult>& results, const GroupSummary& g) {
  const CellResult* best = nullptr;
  for (const auto& r : results) {
    if (r.variant != g.variant || r.dataset != g.dataset || !r.ok() || !r.ate_rmse) continue;
    if (!best || std::abs(*r.ate_rmse - g.ate->median) < std::abs(*best->ate_rmse - g.ate->median)) best = &r;
  }
  return best;
}

/** plots/ate.png and plots/trajectories_<dataset>.png; false if skipped. */
bool drawPlots(const Study& st, const RunOptions& o, const std::vector<CellResult>& results) {
  const auto groups = summarize(st, results);
  const fs::path dir = fs::path(o.out_dir) / "plots";
  fs::create_directories(dir);
  {
    std::ostringstream a;
    a << "variant,dataset,n,median,min,max\n";
    for (const auto& g : groups)
      if (g.ate)
        a << g.variant << "," << g.dataset << "," << g.ate->n << "," << num(g.ate->median) << "," << num(g.ate->min)
          << "," << num(g.ate->max) << "\n";
    writeAtomic(dir / "ate.csv", a.str());
  }
  std::vector<std::pair<std::string, std::string>> traj_csvs;  // dataset, csv
  for (const auto& d : st.datasets) {
    std::string folder = d.path;
    if (d.isScenario()) folder = (fs::path(sceneCacheDir(o)) / d.cacheName()).string();
    std::error_code ec;
    if (!fs::exists(folder, ec)) continue;
    std::ostringstream t;
    t << "label,x,y,z\n";
    size_t rows = 0;
    try {
      for (const auto& p : datasetGroundTruth(folder).poses) {
        const auto& x = p.translation();
        t << "ground truth," << num(x.x()) << "," << num(x.y()) << "," << num(x.z()) << "\n";
      }
    } catch (const Error& e) {
      DSLAM_LOG(Warn, "plots: no ground truth for " << d.name << ": " << e.what());
    }
    for (const auto& g : groups) {
      if (g.dataset != d.name || !g.ate) continue;
      const CellResult* r = representative(results, g);
      if (!r) continue;
      const fs::path aligned = fs::path(o.out_dir) / "cells" / r->cell / "aligned.txt";
      if (!fs::exists(aligned, ec)) continue;
      for (const auto& p : traj::readTum(aligned.string()).poses) {
        const auto& x = p.translation();
        t << g.variant << "," << num(x.x()) << "," << num(x.y()) << "," << num(x.z()) << "\n";
        rows++;
      }
    }
    if (!rows) continue;
    const fs::path csv = dir / ("trajectories_" + d.name + ".csv");
    writeAtomic(csv, t.str());
    traj_csvs.push_back({d.name, csv.string()});
  }
  const std::string py = eval::findPlotPython();
  const std::string script = eval::findScript("plot_study.py");
  if (py.empty() || script.empty()) {
    std::cout << "plots skipped: " << (py.empty() ? "no python3 with matplotlib" : "plot_study.py not found")
              << " (the plot data is in " << dir.string() << ")" << std::endl;
    return false;
  }
  bool ok = true;
  const std::string align = eval::toString(st.evaluation.align);
  ok &= eval::runProgram({py, script, "ate", "--csv", (dir / "ate.csv").string(), "--out", (dir / "ate.png").string(),
                          "--title", "Study " + st.name + ": ATE RMSE (" + align + " alignment), median and range"}) == 0;
  for (const auto& [d, csv] : traj_csvs)
    ok &= eval::runProgram({py, script, "traj", "--csv", csv, "--out", (dir / ("trajectories_" + d + ".png")).string(),
                            "--title", "Study " + st.name + ", " + d + ": trajectories (" + align +
                                           "-aligned), top view"}) == 0;
  if (!ok) std::cout << "some plots failed (see the messages above); the data is in " << dir.string() << std::endl;
  return ok;
}

}  // namespace

size_t writeResults(const Study& st, const RunOptions& o) {
  const auto results = collectResults(st, o.out_dir);
  fs::create_directories(o.out_dir);
  Provenance prov = o.provenance;
  prov.planned = st.plan().size();
  if (prov.study_file.empty()) prov.study_file = st.file;
  writeAtomic(fs::path(o.out_dir) / "results.csv", resultsCsv(st, results));
  writeAtomic(fs::path(o.out_dir) / "results.md", resultsMarkdown(st, results, prov));
  writeAtomic(fs::path(o.out_dir) / "results.json", resultsJson(st, results, prov));
  if (o.plots && !results.empty()) {
    try {
      drawPlots(st, o, results);
    } catch (const Error& e) {
      std::cout << "plots failed: " << e.what() << std::endl;
    }
  }
  return results.size();
}

}  // namespace dslam::study
