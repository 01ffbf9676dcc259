#include "dslam/eval/plot.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>

#include "dslam/core/error.h"
#include "dslam/core/paths.h"

extern char** environ;

namespace fs = std::filesystem;

namespace dslam::eval {

std::vector<PlotRow> plotRows(const Trajectory& gt, const AteResult& r) {
  std::vector<PlotRow> rows;
  rows.reserve(r.assoc.size());
  for (size_t k = 0; k < r.assoc.size(); k++) {
    const auto [i, j] = r.assoc.pairs[k];
    rows.push_back({gt.stamps[i], gt.poses[i].translation(), r.aligned.poses[j].translation(), r.errors[k]});
  }
  return rows;
}

std::vector<PlotRow> plotRows(const Trajectory& gt, const Trajectory& est, const RpeResult& r) {
  Trajectory shown = r.aligned;
  if (r.alignment.method == Align::None && r.assoc.size() >= 3)
    shown = alignTrajectories(gt, est, r.assoc, Align::SE3).apply(est);
  std::vector<PlotRow> rows;
  rows.reserve(r.assoc.size());
  for (const auto& [i, j] : r.assoc.pairs)
    rows.push_back({gt.stamps[i], gt.poses[i].translation(), shown.poses[j].translation(),
                    std::numeric_limits<double>::quiet_NaN()});
  for (const auto& p : r.pairs) rows[p.k0].error = p.trans;
  return rows;
}

void writePlotCsv(const std::string& path, const std::vector<PlotRow>& rows) {
  std::ofstream f(path);
  if (!f) throw DataError("cannot write plot data: " + path);
  f << "t,gt_x,gt_y,gt_z,est_x,est_y,est_z,error\n";
  char buf[320];
  for (const auto& r : rows) {
    std::snprintf(buf, sizeof(buf), "%.9f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9g\n", r.t, r.gt.x(), r.gt.y(), r.gt.z(),
                  r.est.x(), r.est.y(), r.est.z(), r.error);
    f << buf;
  }
  if (!f) throw DataError("error writing plot data: " + path);
}

namespace {

std::string exeDir() {
  std::error_code ec;
  const fs::path p = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : p.parent_path().string();
}

}  // namespace

int runProgram(const std::vector<std::string>& args, bool quiet) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  if (quiet) {
    posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&fa, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  }
  std::fflush(nullptr);
  pid_t pid;
  const int rc = posix_spawnp(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0) return -1;
  int st = 0;
  while (waitpid(pid, &st, 0) < 0)
    if (errno != EINTR) return -1;
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

std::string findScript(const std::string& file_name) {
  std::vector<std::string> cands;
  if (auto d = exeDir(); !d.empty()) cands.push_back(d + "/../share/dslam/" + file_name);
  if (auto d = installDataDir(); !d.empty()) cands.push_back(d + "/" + file_name);
  if (const char* e = std::getenv("DSLAM_SOURCE_DIR"); e && *e) cands.push_back(std::string(e) + "/scripts/" + file_name);
#ifdef DSLAM_EVAL_SOURCE_DIR
  cands.push_back(std::string(DSLAM_EVAL_SOURCE_DIR) + "/scripts/" + file_name);
#endif
  for (const auto& c : cands) {
    std::error_code ec;
    if (fs::is_regular_file(c, ec)) return fs::weakly_canonical(c, ec).string();
  }
  return "";
}

std::string plotScriptPath() {
  if (const char* e = std::getenv("DSLAM_PLOT_SCRIPT"); e && *e) return fs::exists(e) ? e : "";
  return findScript("plot_trajectory.py");
}

std::string findPlotPython() {
  std::vector<std::string> cands;
  if (const char* e = std::getenv("DSLAM_PYTHON"); e && *e)
    cands.push_back(e);
  else
    cands = {"python3", "/usr/bin/python3"};
  for (const auto& py : cands)
    if (runProgram({py, "-c", "import matplotlib"}, true) == 0) return py;
  return "";
}

std::string plot(const std::string& png, const std::vector<PlotRow>& rows, const std::string& title,
                 const std::string& error_label) {
  const std::string csv = fs::path(png).replace_extension(".csv").string();
  if (csv == png) throw ConfigError("--plot: the image name must not end in .csv: " + png);
  writePlotCsv(csv, rows);
  const std::string py = findPlotPython();
  if (py.empty())
    throw Error("plotting needs python3 with matplotlib (Debian/Ubuntu: apt-get install python3-matplotlib; "
                "or set DSLAM_PYTHON to an interpreter that has it); the plot data was written to " + csv);
  const std::string script = plotScriptPath();
  if (script.empty())
    throw Error("plot script plot_trajectory.py not found (set DSLAM_PLOT_SCRIPT); the plot data was written to " +
                csv);
  const int rc =
      runProgram({py, script, "--csv", csv, "--out", png, "--title", title, "--error-label", error_label}, false);
  if (rc != 0)
    throw Error(py + " " + script + " failed (exit " + std::to_string(rc) + "); the plot data was written to " + csv);
  std::error_code ec;
  if (!fs::is_regular_file(png, ec) || fs::file_size(png, ec) == 0)
    throw Error("plot script produced no image: " + png);
  return csv;
}

}  // namespace dslam::eval
