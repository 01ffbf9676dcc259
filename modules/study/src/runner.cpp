// Running a study's cells as `dslam run` child processes, with a bounded
// number of concurrent jobs, resume and per-cell results (docs/ablation.md).
#include "dslam/study/runner.h"

#include <fcntl.h>
#include <fnmatch.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include <mrpt/containers/yaml.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>

#include "dslam/config/pipeline.h"
#include "dslam/core/atomic_file.h"
#include "dslam/core/dataset.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/core/paths.h"
#include "dslam/core/registry.h"
#include "dslam/core/timing.h"
#include "dslam/synth/writer.h"
#include "dslam/trajectory/io.h"

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace dslam::study {

namespace {

std::string readText(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

void writeAtomic(const fs::path& p, const std::string& text) {
  AtomicOfstream f(p.string());
  f << text;
  f.commit();
}

std::string hostTag() {
  char h[256] = {0};
  if (gethostname(h, sizeof(h) - 1) != 0) std::strcpy(h, "host");
  return std::string(h) + "." + std::to_string(::getpid());
}

std::string fmtDuration(double s) {
  char b[64];
  if (s < 60) std::snprintf(b, sizeof(b), "%.0fs", s);
  else if (s < 3600) std::snprintf(b, sizeof(b), "%dm%02ds", static_cast<int>(s) / 60, static_cast<int>(s) % 60);
  else std::snprintf(b, sizeof(b), "%dh%02dm", static_cast<int>(s) / 3600, (static_cast<int>(s) % 3600) / 60);
  return b;
}

std::string exePath(const RunOptions& o) {
  if (!o.dslam_exe.empty()) return o.dslam_exe;
  std::error_code ec;
  const fs::path p = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw Error("cannot find the dslam executable (/proc/self/exe): " + ec.message());
  return p.string();
}

/** Non-empty when the executable the cells run is gone: this process's own
 *  file was replaced or removed since it started (Linux names it
 *  "PATH (deleted)"), or the given one no longer exists. Cells started now
 *  would run another build than the ones before (or fail to start). */
std::string exeGone(const RunOptions& o) {
  const std::string p = exePath(o);
  const std::string deleted = " (deleted)";
  const bool gone = o.dslam_exe.empty()
                        ? p.size() > deleted.size() && p.compare(p.size() - deleted.size(), deleted.size(), deleted) == 0
                        : !fs::exists(p);
  if (!gone) return "";
  return "the dslam executable " + (o.dslam_exe.empty() ? p.substr(0, p.size() - deleted.size()) : p) +
         " was replaced or removed while the study ran (rebuilt?): no further cell started, so that one study "
         "runs one build; the finished cells are kept, `dslam ablate STUDY --resume` runs the rest";
}

// ------------------------------------------------------------ processes --

/** fork + exec of `args` with stdout and stderr into `log`, stdin from
 *  /dev/null. The child dies with the study (PR_SET_PDEATHSIG), so a killed
 *  study leaves no run behind that would race a resumed one. */
pid_t spawn(const std::vector<std::string>& args, const std::string& log) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const int logfd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (logfd < 0) throw DataError("cannot write " + log + ": " + std::strerror(errno));
  const int nullfd = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  const pid_t parent = ::getpid();
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);
    if (nullfd >= 0) ::dup2(nullfd, 0);
    ::dup2(logfd, 1);
    ::dup2(logfd, 2);
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    ::execv(argv[0], argv.data());
    const int e = errno;
    const char msg[] = "dslam ablate: cannot execute ";
    (void)!::write(2, msg, sizeof(msg) - 1);
    (void)!::write(2, argv[0], std::strlen(argv[0]));
    const char* why = e == ENOENT ? " (no such file)\n" : e == EACCES ? " (permission denied)\n" : "\n";
    (void)!::write(2, why, std::strlen(why));
    ::_exit(127);
  }
  const int err = errno;
  ::close(logfd);
  if (nullfd >= 0) ::close(nullfd);
  if (pid < 0) throw Error(std::string("fork failed: ") + std::strerror(err));
  return pid;
}

struct Exit {
  int status = 0;
  struct rusage ru {};
};

// ------------------------------------------------------- ground truth --

}  // namespace

Trajectory datasetGroundTruth(const std::string& folder, const std::string& pipeline_yaml) {
  // The reader `dslam run` uses: the pipeline's dataset section if it has one
  // (only its path replaced), else the type detected from the folder.
  std::string type;
  Params params;
  if (!pipeline_yaml.empty()) {
    const config::PipelineConfig pc = config::loadPipelineText(pipeline_yaml, folder);
    if (pc.dataset) {
      type = pc.dataset->type;
      params = pc.dataset->params;
    }
  }
  if (type.empty()) {
    type = config::detectDatasetType(folder);
    if (type.empty()) throw DataError("cannot tell the dataset type of " + folder);
  }
  auto reader = create<DatasetSource>(type);
  if (!params.has("path")) {
    mrpt::containers::yaml given = mrpt::containers::yaml::Map();
    given["path"] = folder;
    params = Params::resolve(reader->paramSpecs(), &given, SourceLocation{});
  }
  params.setString("path", folder);
  PluginContext ctx;
  ctx.shared_dir = sharedDir();
  reader->configure(params, ctx);
  return reader->groundTruth();
}

namespace {

const Trajectory& groundTruth(const std::string& folder, const std::string& pipeline_yaml) {
  static std::map<std::string, Trajectory> cache;
  std::string key = folder;
  if (!pipeline_yaml.empty()) {
    const config::PipelineConfig pc = config::loadPipelineText(pipeline_yaml, folder);
    if (pc.dataset) key += "|" + pc.dataset->type + "|" + pc.dataset->params.toYamlText();
  }
  auto it = cache.find(key);
  if (it == cache.end()) it = cache.emplace(key, datasetGroundTruth(folder, pipeline_yaml)).first;
  return it->second;
}

// --------------------------------------------------------------- cells --

struct Started {
  Cell cell;
  std::string dir, dataset_dir;
  double t0 = 0;
};

/** The line of the run's log that says what went wrong. */
std::string errorFromLog(const std::string& log) {
  std::istringstream in(readText(log));
  std::string line, last, err;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    last = line;
    if (line.find("error:") != std::string::npos || line.find("[E]") != std::string::npos ||
        line.find("ERROR") != std::string::npos)
      err = line;
  }
  std::string s = err.empty() ? last : err;
  if (s.size() > 400) s = s.substr(0, 400) + "...";
  return s;
}

std::string signalName(int sig) {
  const char* d = strsignal(sig);
  return std::to_string(sig) + (d ? std::string(" (") + d + ")" : std::string());
}

/** Prepares the cell folder (fresh), writes its config and metadata. */
Started startCell(const Study& st, const Cell& c, const RunOptions& o, const std::string& dataset_dir) {
  Started s;
  s.cell = c;
  s.dir = cellDir(o.out_dir, c);
  s.dataset_dir = dataset_dir;
  std::error_code ec;
  fs::remove_all(s.dir, ec);
  fs::create_directories(s.dir);
  writeAtomic(fs::path(s.dir) / "config.yaml", c.config_yaml);
  const Dataset& d = st.dataset(c.dataset);
  json j;
  j["cell"] = c.id;
  j["index"] = c.index;
  j["study"] = st.name;
  j["study_file"] = st.file;
  j["variant"] = c.variant;
  j["base"] = c.base;
  j["dataset"] = c.dataset;
  j["dataset_path"] = dataset_dir;
  if (d.isScenario()) j["scenario"] = d.scenario;
  j["seed"] = c.seed ? json(*c.seed) : json(nullptr);
  j["repeat"] = c.repeat;
  j["inputs_hash"] = c.inputs_hash;
  j["tool"] = o.provenance.tool;
  writeAtomic(fs::path(s.dir) / "cell.json", j.dump(2) + "\n");
  s.t0 = nowSeconds();
  return s;
}

std::vector<std::string> runArgs(const Study& st, const Started& s, const RunOptions& o) {
  std::vector<std::string> a = {exePath(o),
                                "run",
                                (fs::path(s.dir) / "config.yaml").string(),
                                "--dataset",
                                s.dataset_dir,
                                "--out",
                                (fs::path(s.dir) / "run").string(),
                                "--no-progress"};
  const Dataset& d = st.dataset(s.cell.dataset);
  if (d.max_frames > 0) {
    a.push_back("--max-frames");
    a.push_back(std::to_string(d.max_frames));
  }
  return a;
}

/** ATE / RPE of the run against the dataset's ground truth. */
void evaluate(const Study& st, const Started& s, CellResult& r) {
  const fs::path tp = fs::path(s.dir) / "run" / "trajectory.txt";
  if (!fs::exists(tp)) {
    r.error = "no trajectory.txt";
    return;
  }
  const Trajectory est = traj::read(tp.string());
  const Trajectory& gt = groundTruth(s.dataset_dir, s.cell.config_yaml);
  if (gt.empty()) {
    r.error = "the dataset has no ground truth";
    return;
  }
  if (est.size() < 3) {
    r.error = "fewer than 3 tracked poses";
    return;
  }
  try {
    eval::AteOptions ao;
    ao.align = st.evaluation.align;
    ao.max_dt = st.evaluation.max_dt;
    ao.gt_name = s.dataset_dir;
    ao.est_name = tp.string();
    const auto ate = eval::computeAte(gt, est, ao);
    r.ate_rmse = ate.stats.rmse;
    if (st.evaluation.align == eval::Align::Sim3) r.ate_scale = ate.alignment.scale;
    traj::WriteOptions wo;
    wo.header = "estimate of cell " + s.cell.id + " aligned onto the ground truth (" +
                eval::toString(st.evaluation.align) + ")";
    traj::write((fs::path(s.dir) / "aligned.txt").string(), ate.aligned, wo);
  } catch (const Error& e) {
    r.error = std::string("ATE: ") + e.what();
  }
  try {
    eval::RpeOptions ro;
    ro.delta = st.evaluation.rpe_delta;
    ro.unit = st.evaluation.rpe_unit;
    ro.max_dt = st.evaluation.max_dt;
    if (st.evaluation.align == eval::Align::Sim3) ro.align = eval::Align::Sim3;
    const auto rpe = eval::computeRpe(gt, est, ro);
    r.rpe_trans = rpe.trans.rmse;
    r.rpe_rot = rpe.rot.rmse;
  } catch (const Error& e) {
    DSLAM_LOG(Debug, s.cell.id << ": no RPE: " << e.what());
  }
}

/** The fewest usable keypoints in a frame and the largest feature count of
 *  the run, from frames.csv (columns found by their header names
 *  usable_keypoints and feature_count). */
void readFramesCsv(const fs::path& p, CellResult& r) {
  std::ifstream f(p);
  std::string line;
  if (!f || !std::getline(f, line)) return;
  auto split = [](const std::string& l) {
    std::vector<std::string> c;
    std::stringstream ss(l);
    std::string x;
    while (std::getline(ss, x, ',')) c.push_back(x);
    return c;
  };
  const auto header = split(line);
  const auto col = [&](const char* name) {
    const auto it = std::find(header.begin(), header.end(), name);
    return it == header.end() ? std::string::npos : static_cast<size_t>(it - header.begin());
  };
  const size_t cu = col("usable_keypoints"), cf = col("feature_count");
  if (cu == std::string::npos || cf == std::string::npos) return;
  double usable = -1, feat = -1;
  while (std::getline(f, line)) {
    const auto c = split(line);
    if (c.size() <= std::max(cu, cf)) continue;
    const double u = std::atof(c[cu].c_str()), n = std::atof(c[cf].c_str());
    usable = usable < 0 ? u : std::min(usable, u);
    feat = std::max(feat, n);
  }
  if (usable >= 0) r.min_usable_keypoints = usable;
  if (feat >= 0) r.max_feature_count = feat;
}

/** Result of a finished child; writes result.json then the done marker. */
CellResult finishCell(const Study& st, const Started& s, const Exit& ex) {
  CellResult r;
  r.cell = s.cell.id;
  r.variant = s.cell.variant;
  r.base = s.cell.base;
  r.dataset = s.cell.dataset;
  r.seed = s.cell.seed;
  r.repeat = s.cell.repeat;
  r.inputs_hash = s.cell.inputs_hash;
  r.wall_s = nowSeconds() - s.t0;
  r.peak_mb = static_cast<double>(ex.ru.ru_maxrss) / 1024.0;  // kB on Linux; replaced by the run's own figure below
  const std::string log = (fs::path(s.dir) / "log.txt").string();
  if (WIFSIGNALED(ex.status)) {
    r.exit_code = 128 + WTERMSIG(ex.status);
    r.status = "failed";
    r.error = "dslam run killed by signal " + signalName(WTERMSIG(ex.status)) + "; " + errorFromLog(log);
  } else {
    r.exit_code = WEXITSTATUS(ex.status);
    if (r.exit_code != 0) {
      r.status = "failed";
      r.error = "dslam run exit code " + std::to_string(r.exit_code) + ": " + errorFromLog(log);
    }
  }
  const fs::path sp = fs::path(s.dir) / "run" / "summary.json";
  if (fs::exists(sp)) {
    try {
      const json j = json::parse(readText(sp));
      r.frames = j.value("frames", size_t{0});
      r.tracked = j.value("tracked", size_t{0});
      r.keyframes = j.value("keyframes", size_t{0});
      r.median_ms = j.value("median_ms", 0.0);
      r.fps = j.value("fps", 0.0);
      // The run's own peak (VmHWM of its image): exact. wait4's ru_maxrss
      // also counts what this process had resident when it forked the run.
      if (const double p = j.value("peak_rss_mb", 0.0); p > 0) r.peak_mb = p;
      if (r.status.empty() && !j.value("finished", false)) {
        r.status = "failed";
        r.error = "run stopped early (" + j.value("stopped_by", std::string("?")) + "): " + errorFromLog(log);
      }
    } catch (const json::exception& e) {
      if (r.status.empty()) {
        r.status = "failed";
        r.error = "unreadable summary.json: " + std::string(e.what());
      }
    }
  } else if (r.status.empty()) {
    r.status = "failed";
    r.error = "no summary.json: " + errorFromLog(log);
  }
  readFramesCsv(fs::path(s.dir) / "run" / "frames.csv", r);
  if (r.status.empty()) {
    r.status = "ok";
    try {
      evaluate(st, s, r);
    } catch (const Error& e) {
      r.error = std::string("evaluation: ") + e.what();
    }
  }
  writeAtomic(fs::path(s.dir) / "result.json", r.toJson());
  json done{{"status", r.status}, {"inputs_hash", r.inputs_hash}};
  writeAtomic(fs::path(s.dir) / "done", done.dump() + "\n");  // last: the cell counts as finished from here
  return r;
}

std::string resultLine(const CellResult& r) {
  char b[512];
  if (r.ok()) {
    char ate[32] = "n/a";
    if (r.ate_rmse) std::snprintf(ate, sizeof(ate), "%.4f m", *r.ate_rmse);
    std::snprintf(b, sizeof(b), "ok      %s  ATE %s  tracked %.0f%%  %.1f s  peak %.0f MB", r.cell.c_str(), ate,
                  r.trackedPercent(), r.wall_s, r.peak_mb);
    return b;
  }
  return "FAILED  " + r.cell + "  " + r.error;
}

std::atomic<int> g_stop{0};
extern "C" void onStudySignal(int sig) { g_stop = sig; }

class SignalScope {
 public:
  SignalScope() {
    g_stop = 0;
    struct sigaction sa {};
    sa.sa_handler = onStudySignal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESETHAND;  // no SA_RESTART: wait4 returns EINTR
    sigaction(SIGINT, &sa, &old_int_);
    sigaction(SIGTERM, &sa, &old_term_);
  }
  ~SignalScope() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  SignalScope(const SignalScope&) = delete;
  SignalScope& operator=(const SignalScope&) = delete;

 private:
  struct sigaction old_int_ {}, old_term_ {};
};

}  // namespace

std::string sceneCacheDir(const RunOptions& o) {
  return o.scene_cache.empty() ? (fs::path(o.out_dir) / "scenes").string() : o.scene_cache;
}

std::string prepareDataset(const Dataset& d, const std::string& scene_cache, bool log_progress) {
  if (!d.isScenario()) return d.path;
  const fs::path dir = fs::path(scene_cache) / d.cacheName();
  auto rendered = [&dir] { return fs::exists(dir / "groundtruth.txt"); };  // written before the rename: complete
  if (rendered()) return dir.string();
  std::error_code ec;
  if (fs::is_symlink(fs::symlink_status(dir, ec)) && !fs::exists(dir, ec)) {  // its target was deleted
    DSLAM_LOG(Warn, "scene cache: " << dir.string() << " links to " << fs::read_symlink(dir, ec).string()
                                    << ", which is gone; rendering the scene again in its place");
    fs::remove(dir, ec);
  }
  fs::create_directories(scene_cache);
  const fs::path tmp = fs::path(scene_cache) / (d.cacheName() + ".tmp." + hostTag());
  synth::ScenarioOverrides ov;
  ov.frames = d.frames;
  ov.width = d.width;
  ov.height = d.height;
  ov.seed = d.seed;
  ov.noise = d.noise;
  synth::WriteOptions wo;
  wo.overwrite = true;
  wo.progress = false;
  wo.right = d.right;
  wo.labels = d.labels;
  const double t0 = nowSeconds();
  if (log_progress)
    std::cout << "rendering dataset " << d.name << " (" << fs::path(d.scenario).filename().string() << ") into "
              << dir.string() << std::endl;
  synth::renderToFolder(d.scenario, tmp.string(), ov, wo);
  writeAtomic(tmp / "dslam_scene_key.txt", d.scenario_key_text);
  fs::rename(tmp, dir, ec);  // another process may have rendered it meanwhile: keep theirs
  if (ec) {
    const std::string why = ec.message();
    fs::remove_all(tmp, ec);
    if (!rendered())
      throw Error("cannot put the rendered scene " + d.name + " at " + dir.string() + " (" + why +
                  "): something that is not a rendered scene is in the way; remove it");
  }
  if (log_progress) std::cout << "  rendered in " << fmtDuration(nowSeconds() - t0) << std::endl;
  return dir.string();
}

std::string cellDir(const std::string& out_dir, const Cell& c) { return (fs::path(out_dir) / "cells" / c.id).string(); }

std::optional<CellResult> finishedResult(const std::string& out_dir, const Cell& c) {
  const fs::path dir = cellDir(out_dir, c);
  const fs::path done = dir / "done";
  if (!fs::exists(done)) return std::nullopt;
  try {
    const json j = json::parse(readText(done));
    if (j.value("inputs_hash", "") != c.inputs_hash) return std::nullopt;  // stale: the study changed
    return CellResult::fromJson(readText(dir / "result.json"), (dir / "result.json").string());
  } catch (const std::exception& e) {
    DSLAM_LOG(Warn, c.id << ": ignoring an unreadable result (" << e.what() << ")");
    return std::nullopt;
  }
}

std::vector<CellResult> collectResults(const Study& st, const std::string& out_dir) {
  std::vector<CellResult> v;
  for (const auto& c : st.plan())
    if (auto r = finishedResult(out_dir, c)) v.push_back(*r);
  return v;
}

std::vector<Cell> selectCells(const std::vector<Cell>& plan, const std::vector<std::string>& only) {
  if (only.empty()) return plan;
  std::vector<Cell> out;
  for (const auto& pat : only) {
    bool any = false;
    for (const auto& c : plan)
      if (::fnmatch(pat.c_str(), c.id.c_str(), 0) == 0) any = true;
    if (!any) throw ConfigError("--only '" + pat + "' matches no cell (see --plan)");
  }
  for (const auto& c : plan)
    for (const auto& pat : only)
      if (::fnmatch(pat.c_str(), c.id.c_str(), 0) == 0) {
        out.push_back(c);
        break;
      }
  return out;
}

CellResult runCell(const Study& st, const Cell& c, const RunOptions& o) {
  const std::string ds = prepareDataset(st.dataset(c.dataset), sceneCacheDir(o));
  const Started s = startCell(st, c, o, ds);
  const pid_t pid = spawn(runArgs(st, s, o), (fs::path(s.dir) / "log.txt").string());
  Exit ex;
  while (::wait4(pid, &ex.status, 0, &ex.ru) < 0) {
    if (errno != EINTR) throw Error(std::string("wait4: ") + std::strerror(errno));
  }
  return finishCell(st, s, ex);
}

StudyRunReport runStudy(const Study& st, const RunOptions& o) {
  StudyRunReport rep;
  makeOutputDir(o.out_dir, "study output folder");
  const auto plan = st.plan();
  rep.planned = plan.size();
  const auto selected = selectCells(plan, o.only);
  rep.selected = selected.size();
  std::vector<Cell> todo;
  size_t finished_before = 0;
  for (const auto& c : selected) {
    const auto prev = finishedResult(o.out_dir, c);
    if (prev && prev->ok()) {
      finished_before++;
      if (o.resume) continue;
    }
    todo.push_back(c);
  }
  if (finished_before && !o.resume && !o.overwrite)
    throw ConfigError(o.out_dir + " holds " + std::to_string(finished_before) +
                      " finished cells of an earlier run of this study: --resume keeps them and runs the rest, "
                      "--overwrite runs them again (or choose another --out)");
  rep.skipped = selected.size() - todo.size();
  const int jobs = std::max(1, o.jobs);
  std::cout << "study " << st.name << ": " << plan.size() << " cells";
  if (selected.size() != plan.size()) std::cout << ", " << selected.size() << " selected";
  if (rep.skipped) std::cout << ", " << rep.skipped << " finished earlier (--resume)";
  std::cout << "; running " << todo.size() << " with " << jobs << " job" << (jobs > 1 ? "s" : "") << " into "
            << o.out_dir << std::endl;

  // Datasets first (rendering uses every core).
  std::map<std::string, std::string> dataset_dir;
  for (const auto& c : todo)
    if (!dataset_dir.count(c.dataset)) dataset_dir[c.dataset] = prepareDataset(st.dataset(c.dataset), sceneCacheDir(o));

  SignalScope signals;
  std::map<pid_t, Started> running;
  size_t next = 0, done = 0;
  double busy = 0;  // wall seconds of finished cells
  const double t0 = nowSeconds();
  auto stopRequested = [] { return g_stop.load() != 0; };
  bool forwarded = false;
  auto canStart = [&] {
    if (stopRequested() || !rep.stopped_because.empty()) return false;
    rep.stopped_because = exeGone(o);
    return rep.stopped_because.empty();
  };
  while ((next < todo.size() && !stopRequested() && rep.stopped_because.empty()) || !running.empty()) {
    if (stopRequested() && !forwarded) {  // stop the running cells; they write their outputs and exit
      for (const auto& [p, s] : running) ::kill(p, SIGTERM);
      forwarded = true;
    }
    while (running.size() < static_cast<size_t>(jobs) && next < todo.size() && canStart()) {
      const Cell& c = todo[next++];
      Started s = startCell(st, c, o, dataset_dir[c.dataset]);
      const pid_t pid = spawn(runArgs(st, s, o), (fs::path(s.dir) / "log.txt").string());
      running.emplace(pid, std::move(s));
    }
    Exit ex;
    const pid_t pid = ::wait4(-1, &ex.status, 0, &ex.ru);
    if (pid < 0) {
      if (errno == EINTR) continue;
      if (errno == ECHILD) break;
      throw Error(std::string("wait4: ") + std::strerror(errno));
    }
    auto it = running.find(pid);
    if (it == running.end()) continue;  // not one of ours
    if (stopRequested()) {  // interrupted: the cell stays unfinished (no done marker)
      std::cout << "stopped  " << it->second.cell.id << std::endl;
      running.erase(it);
      continue;
    }
    const CellResult r = finishCell(st, it->second, ex);
    running.erase(it);
    done++;
    rep.ran++;
    (r.ok() ? rep.ok : rep.failed)++;
    busy += r.wall_s;
    const size_t remaining = todo.size() - done;
    const double eta = remaining ? busy / static_cast<double>(done) * static_cast<double>(remaining) / jobs : 0;
    char head[64];
    std::snprintf(head, sizeof(head), "[%zu/%zu] ", done, todo.size());
    std::cout << head << resultLine(r)
              << (remaining ? "  | elapsed " + fmtDuration(nowSeconds() - t0) + ", ETA " + fmtDuration(eta) : "")
              << std::endl;
  }
  rep.stop_signal = g_stop.load();
  if (rep.stop_signal) {
    std::cout << "study interrupted (" << (rep.stop_signal == SIGINT ? "SIGINT" : "SIGTERM") << "): " << done
              << " cells finished in this session; `--resume` runs the rest" << std::endl;
  }
  if (!rep.stopped_because.empty())
    std::cout << "study stopped after " << done << " cells of " << todo.size() << ": " << rep.stopped_because
              << std::endl;
  const size_t collected = writeResults(st, o);
  std::cout << "results of " << collected << " of " << plan.size() << " cells: " << o.out_dir << "/results.md"
            << " (" << rep.ok << " ok, " << rep.failed << " failed in this session, "
            << fmtDuration(nowSeconds() - t0) << ")" << std::endl;
  return rep;
}

}  // namespace dslam::study
