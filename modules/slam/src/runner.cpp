// runPipeline(): the `dslam run` command. Steps, one function each: the
// dataset section and its reader, the camera, the output folder, the System
// with its plug-ins, the frame loop, the output files and the summary.
#include <mrpt/containers/yaml.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <atomic>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <iostream>
#include <sstream>

#include <unistd.h>

#include "dslam/core/atomic_file.h"
#include "dslam/core/dataset.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/core/paths.h"
#include "dslam/core/registry.h"
#include "dslam/dense/dense_map.h"
#include "dslam/eval/eval.h"
#include "dslam/map/map.h"
#include "dslam/slam/system.h"
#include "dslam/trajectory/io.h"

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace dslam {

namespace {

/** SIGINT / SIGTERM during a run: the frame loop stops at the next frame and
 *  every output is written for what was processed. The handler is one-shot
 *  (SA_RESETHAND): a second Ctrl-C ends the process at once. */
std::atomic<int> g_stop_signal{0};

extern "C" void onStopSignal(int sig) { g_stop_signal = sig; }

class StopSignals {
 public:
  StopSignals() {
    g_stop_signal = 0;
    struct sigaction sa {};
    sa.sa_handler = onStopSignal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESETHAND;
    sigaction(SIGINT, &sa, &old_int_);
    sigaction(SIGTERM, &sa, &old_term_);
  }
  ~StopSignals() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

 private:
  struct sigaction old_int_ {}, old_term_ {};
};

/** trajectory.txt while the run goes on: each tracked frame's pose as
 *  tracking estimated it, flushed per frame, so that a killed run leaves a
 *  trajectory `dslam eval` reads. At the end the final, keyframe-corrected
 *  trajectory replaces it (temporary file + rename). */
class IncrementalTrajectory {
 public:
  void open(const std::string& path, const std::string& pipeline) {
    if (path.empty()) return;
    f_.open(path);
    if (!f_) throw DataError("cannot write trajectory file: " + path);
    f_ << "# dslam camera trajectory (T_wc), pipeline " << pipeline << "\n"
       << "# RUN NOT FINISHED: poses as tracked, written while the run goes on; a finished run replaces this file\n"
       << "# timestamp tx ty tz qx qy qz qw\n"
       << std::flush;
  }
  void add(double t, const SE3& T_cw) {
    if (!f_.is_open()) return;
    const SE3 T = T_cw.inverse();
    const auto& q = T.quaternion();
    const auto& p = T.translation();
    char buf[256];
    std::snprintf(buf, sizeof(buf), "%.9f %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", t, p.x(), p.y(), p.z(), q.x(), q.y(),
                  q.z(), q.w());
    f_ << buf << std::flush;
  }
  void close() { f_.close(); }

 private:
  std::ofstream f_;
};

/** events.jsonl: one JSON object per line, flushed at once. */
struct EventLog {
  std::ofstream f;
  void open(const std::string& path) {
    if (!path.empty()) f.open(path);
  }
  void write(const std::string& line) {
    if (f) f << line << "\n" << std::flush;
  }
  void write(const json& e) { write(e.dump()); }
  void frameEvent(const char* what, size_t frame) { write(json{{"event", what}, {"frame", frame}}); }
};

std::shared_ptr<Plugin> makeModule(const config::ModuleConfig& m, const PluginContext& base) {
  auto p = createPlugin(m.type, CLASS_ID(Plugin));
  PluginContext ctx = base;
  ctx.instance_name = m.name;
  p->configure(m.params, ctx);
  return p;
}

/** The dataset section that applies: the file's, or one detected from
 *  --dataset; --dataset replaces only the path. */
config::DatasetConfig datasetConfig(const config::PipelineConfig& pc, const RunOverrides& ov) {
  config::DatasetConfig dc;
  if (pc.dataset) dc = *pc.dataset;
  if (ov.dataset.empty()) {
    if (!pc.dataset)
      throw ConfigError("no dataset: add a 'dataset:' section to " +
                        (pc.file.empty() ? std::string("the pipeline") : pc.file) + " or pass --dataset PATH");
    return dc;
  }
  if (!fs::exists(ov.dataset)) throw DataError("dataset not found: " + ov.dataset);
  if (!pc.dataset) {
    const std::string detected = config::detectDatasetType(ov.dataset);
    if (detected.empty())
      throw DataError("cannot tell the dataset type of " + ov.dataset +
                      " (expected a TUM/Bonn folder with rgb.txt, a KITTI folder with calib.txt, an EuRoC folder with "
                      "mav0/, or a .rawlog file)");
    dc.type = detected;
    auto reader = createPlugin(detected, CLASS_ID(DatasetSource));
    mrpt::containers::yaml given = mrpt::containers::yaml::Map();
    given["path"] = ov.dataset;
    dc.params = Params::resolve(reader->paramSpecs(), &given, SourceLocation{});
  }
  dc.params.setString("path", fs::absolute(ov.dataset).lexically_normal().string());
  return dc;
}

CameraModel resolveCamera(const config::PipelineConfig& pc, const DatasetSource& reader) {
  std::optional<CameraModel> cam = pc.camera;
  if (!cam) cam = reader.camera();
  if (!cam)
    throw ConfigError(
        "no camera: the dataset carries no calibration; add a 'camera:' section (or "
        "$include{../cameras/<name>.yaml})");
  return *cam;
}

/** Output file of `outputs.<key>` in the run folder; "" when switched off. */
std::string outPath(const config::PipelineConfig& pc, const std::string& out, const char* key) {
  const std::string n = pc.outputs.getString(key);
  return n.empty() ? std::string() : (fs::path(out) / n).string();
}

std::string prepareOutputDir(const config::PipelineConfig& pc, const RunOverrides& ov,
                             const config::DatasetConfig& dc, const CameraModel& cam) {
  std::string out = ov.out_dir;
  if (out.empty()) out = pc.outputs.getString("dir");
  if (out.empty()) out = "out/" + pc.name;
  // The run's files (trajectory.txt, objects.json, ...) must not replace the dataset's own.
  const std::string ds = dc.params.has("path") ? dc.params.getString("path") : std::string();
  std::error_code ec1, ec2;
  if (!ds.empty() && fs::is_directory(ds, ec1) && fs::equivalent(fs::path(out), fs::path(ds), ec2))
    throw DataError("the output folder " + out + " is the dataset folder " + ds +
                    ": the run's files (trajectory.txt, objects.json, ...) would replace the dataset's; give another --out");
  makeOutputDir(out, "output folder");
  // An atlas path that cannot be written is found now, not after the whole run.
  if (const std::string ap = ov.save_atlas.empty() ? outPath(pc, out, "atlas") : ov.save_atlas; !ap.empty()) {
    makeOutputDir(fs::absolute(ap).parent_path().string(), "folder of the atlas file " + ap + ":");
  }
  if (const std::string rc = outPath(pc, out, "resolved_config"); !rc.empty()) {
    config::PipelineConfig resolved = pc;
    resolved.dataset = dc;
    resolved.camera = cam;
    AtomicOfstream f(rc);
    f << resolved.toYaml();
    f.commit();
  }
  return out;
}

std::unique_ptr<System> assembleSystem(const config::PipelineConfig& pc, const RunOverrides& ov,
                                       const CameraModel& cam, const PluginContext& base) {
  if (ov.load_atlas.empty() && (ov.localization_only || SlamParams::fromConfig(pc).tracker.localization_only))
    throw ConfigError(std::string(ov.localization_only ? "--localization-only" : "tracking.localization_only") +
                      " tracks against a saved map and never makes one: give the map with --load-atlas FILE");
  auto sys = buildSystem(pc, cam, base, ov.localization_only);
  if (!ov.load_atlas.empty()) sys->loadMaps(ov.load_atlas);
  return sys;
}

/** outputs.dense_map: the dense-map stage (docs/dense_map.md), fed with
 *  every keyframe; checks the dataset's first frame for depth or a stereo pair.
 *  Its per-keyframe work runs on its own thread in both modes: it is a pure
 *  function of the keyframe and the map is integrated in frame order at the
 *  end, so sequential runs stay deterministic. */
std::unique_ptr<dense::DenseMapper> startDenseMap(const config::PipelineConfig& pc, System& sys,
                                                  const CameraModel& cam, DatasetSource& reader, size_t first) {
  if (!pc.outputs.getBool("dense_map")) return nullptr;
  auto d = std::make_unique<dense::DenseMapper>(sys.camera(), cam,
                                                dense::DenseMapParams::fromParams(pc.sections.at("dense_map")),
                                                /*threaded=*/true);
  d->setDatasetRoot(reader.root());
  if (first < reader.size()) {
    SensorFrame f;
    try {
      f = reader.read(first);
    } catch (const DataError&) {  // the frame loop reports it
    }
    if (!f.image.empty()) d->checkInput(f);
  }
  sys.setKeyFrameObserver([p = d.get()](const Frame& f, const std::vector<Detections>& dets) { p->addKeyFrame(f, dets); });
  return d;
}

/** The dense map from the final keyframe poses, its files and one line of summary. */
std::string finishDenseMap(dense::DenseMapper& d, System& sys, const Trajectory& traj, const std::string& out) {
  d.integrate(dense::keyFramePosesByFrame(*sys.map()));
  d.writeOutputs(out, traj);
  const dense::DenseStats& s = d.stats();
  char b[480];
  std::snprintf(b, sizeof(b),
                "dense map: %zu occupied voxels (%.0f mm) from %zu of %zu keyframes (%zu without depth, %zu not in "
                "the final map), %zu points integrated, %zu dropped as dynamic; preprocessing %.1f ms per keyframe "
                "(max %.1f) off the tracking thread (which waited %.2f s for it), integration %.2f s; memory: "
                "clouds %.1f MB, octree %.1f MB: map.bt dense.ply dense_top.png dense_side.png dense.json\n",
                s.occupied_voxels, d.params().resolution * 1e3, s.keyframes_integrated, s.keyframes_received,
                s.keyframes_empty_depth, s.keyframes_without_pose, s.points_inserted, s.points_masked,
                s.keyframes_received ? s.preprocess_ms_total / static_cast<double>(s.keyframes_received) : 0.0,
                s.preprocess_ms_max, s.producer_wait_s, s.integrate_s, static_cast<double>(s.stored_bytes) / 1048576.0,
                static_cast<double>(s.octree_bytes) / 1048576.0);
  return b;
}

/** What the frame loop leaves behind. */
struct LoopOutcome {
  std::vector<double> frame_ms;
  std::exception_ptr failure;
  int stop_signal = 0;  ///< SIGINT/SIGTERM that stopped the loop, 0 if none
};

/** Resident memory of this process in MB (/proc/self/statm), 0 if unknown. */
double residentMb() {
  std::ifstream f("/proc/self/statm");
  long pages = 0, resident = 0;
  if (!(f >> pages >> resident)) return 0;
  return static_cast<double>(resident) * static_cast<double>(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

/** An RGB-D frame whose depth image has no valid pixel (all 0: sensor
 *  dropout, a blank file) is tracked like a monocular frame against the map;
 *  said as a warning for the first three, counted in the summary and the
 *  events for every one. */
void noteEmptyDepth(const SensorFrame& sf, size_t i, EventLog& ev, RunSummary& sum) {
  if (sf.depth.empty() || cv::countNonZero(sf.depth) > 0) return;
  if (++sum.empty_depth_frames <= 3)
    DSLAM_LOG(Warn, "frame " << i << ": depth image " << sf.depth_path
                             << " has no valid depth (every pixel 0): tracked without depth"
                             << (sum.empty_depth_frames == 3 ? " (further frames like this are counted in summary.json)" : ""));
  ev.write(json{{"event", "empty_depth"}, {"frame", i}, {"file", sf.depth_path}});
}

/** Tracks frames [start, start + n*stride) of `reader`; the next frame is read
 *  and decoded on a helper thread while the current one is processed
 *  (reading is deterministic, so sequential runs stay repeatable). */
LoopOutcome frameLoop(DatasetSource& reader, System& sys, const config::DatasetConfig& dc, size_t start,
                      size_t stride, size_t n, const RunOverrides& ov, EventLog& ev, std::ofstream& frames_csv,
                      IncrementalTrajectory& traj_out, RunSummary& sum) {
  LoopOutcome lo;
  log::Progress progress("tracking", n, 100);
  TrackState prev_state = TrackState::NotInitialized;
  size_t done = 0;
  double rss_mb = residentMb();
  try {
    auto readAsync = [&](size_t k) {
      return std::async(std::launch::async, [&reader, i = start + k * stride] { return reader.read(i); });
    };
    std::future<SensorFrame> next;
    if (n > 0) next = readAsync(0);
    for (size_t k = 0; k < n; k++) {
      if (const int sig = g_stop_signal.load()) {
        lo.stop_signal = sig;
        DSLAM_LOG(Warn, "interrupted (" << (sig == SIGINT ? "SIGINT" : "SIGTERM") << ") after " << done
                                        << " frames: writing the outputs (Ctrl-C again to abort)");
        break;
      }
      const size_t i = start + k * stride;
      SensorFrame sf;
      std::exception_ptr read_error;
      try {
        sf = next.get();
      } catch (...) {
        read_error = std::current_exception();
      }
      if (k + 1 < n) next = readAsync(k + 1);  // readers are not thread-safe: one read at a time
      try {
        if (read_error) std::rethrow_exception(read_error);
      } catch (const DataError& e) {
        if (dc.on_bad_frame != config::OnBadFrame::Skip) throw;
        const std::string what = e.what();  // reader errors name the frame: "frame N: ..."
        DSLAM_LOG(Warn, "skipping " << (what.rfind("frame ", 0) == 0 ? "" : "frame " + std::to_string(i) + ": ") << what);
        ev.write(json{{"event", "bad_frame"}, {"frame", i}, {"error", e.what()}});
        sum.skipped_frames++;
        continue;
      }
      noteEmptyDepth(sf, i, ev, sum);
      const FrameResult r = sys.track(sf);
      lo.frame_ms.push_back(r.ms_total);
      sum.frames++;
      if (r.track.state == TrackState::Ok) sum.tracked++;
      if (r.track.state == TrackState::Ok && r.track.T_cw) traj_out.add(r.timestamp, *r.track.T_cw);
      if (r.track.initialized) ev.write(json{{"event", "map_initialised"}, {"frame", i}, {"map", sys.map()->id}});
      if (r.track.relocalized) ev.frameEvent("relocalised", i);
      if (r.track.state == TrackState::Lost && prev_state == TrackState::Ok) ev.frameEvent("lost", i);
      if (frames_csv.is_open()) {
        if (done % 100 == 0) rss_mb = residentMb();  // sampled every 100 frames (a /proc read)
        char line[192];
        std::snprintf(line, sizeof(line), "%d,%.6f,%s,%zu,%zu,%d,%d,%.1f\n", r.frame_index, r.timestamp,
                      toString(r.track.state), r.keypoints, r.keypoints - r.dynamic_keypoints, r.track.matches,
                      r.feature_count, rss_mb);
        frames_csv << line << std::flush;
      }
      prev_state = r.track.state;
      done = k + 1;
      if (!ov.quiet_progress)
        progress.update(done, std::string(toString(r.track.state)) + ", " + std::to_string(r.track.matches) + " matches");
    }
  } catch (...) {
    lo.failure = std::current_exception();
    DSLAM_LOG(Error, "run stopped after " << done << " frames; writing the results so far to " << sum.out_dir);
  }
  if (!ov.quiet_progress) progress.finish();
  if (done > 0 && sum.tracked == 0 && !ov.localization_only)
    DSLAM_LOG(Warn, "no frame was tracked: the map never initialised (it needs more than tracking.init_min_points "
                    "usable keypoints with depth on one frame; features.n_features, the detector boxes and the "
                    "depth range decide how many there are)");
  return lo;
}

void writeTrajectory(const std::string& path, const config::PipelineConfig& pc, const Trajectory& traj,
                     const std::vector<int>& lost, const RunSummary& sum) {
  const size_t frames = sum.frames;
  traj::WriteOptions wo;
  wo.format = traj::formatFromString(pc.outputs.getString("trajectory_format"));
  wo.kitti_with_times = true;
  std::ostringstream h;
  h << "dslam camera trajectory (T_wc), pipeline " << pc.name << "\n"
    << "tracked frames only: " << traj.size() << " of " << frames << " processed frames";
  if (!lost.empty()) {
    h << "; not tracked (omitted):";
    for (size_t i = 0; i < lost.size() && i < 200; i++) h << " " << lost[i];
    if (lost.size() > 200) h << " ...";
  }
  if (!sum.finished) h << "\nrun stopped early (" << sum.stopped_by << "): the frames after these were not processed";
  h << "\ntimestamp tx ty tz qx qy qz qw";
  wo.header = h.str();
  traj::write(path, traj, wo);
}

/** ATE against the reader's ground truth, as text for the summary. */
std::string evaluateAte(const DatasetSource& reader, const Trajectory& traj, RunSummary& sum) {
  const Trajectory& gt = reader.groundTruth();
  if (gt.empty()) return "n/a (no ground truth)";
  if (traj.size() < 3) return "n/a (" + std::to_string(traj.size()) + " tracked frames)";
  try {
    eval::AteOptions ao;
    ao.align = eval::Align::SE3;
    const auto ate = eval::computeAte(gt, traj, ao);
    sum.ate_rmse = ate.stats.rmse;
    sum.ate_pairs = ate.stats.count;
    char b[128];
    std::snprintf(b, sizeof(b), "%.4f m RMSE (%zu pairs, SE(3) alignment)", ate.stats.rmse, ate.stats.count);
    return b;
  } catch (const Error& e) {
    return std::string("n/a: ") + e.what();
  }
}

/** Peak resident memory of this process image, MB (VmHWM of
 *  /proc/self/status: unlike getrusage's ru_maxrss it does not include what
 *  the process that forked this one had resident); 0 if unknown. */
double peakRssMb() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::strtod(line.c_str() + 6, nullptr) / 1024.0;
  return 0;
}

void writeSummaryJson(const std::string& path, const config::PipelineConfig& pc, const RunSummary& sum) {
  json j;
  j["pipeline"] = pc.name;
  j["finished"] = sum.finished;
  j["stopped_by"] = sum.stopped_by;
  j["frames"] = sum.frames;
  j["tracked"] = sum.tracked;
  j["keyframes"] = sum.keyframes;
  j["map_points"] = sum.map_points;
  j["maps"] = sum.maps;
  j["median_ms"] = sum.median_ms;
  j["mean_ms"] = sum.mean_ms;
  j["fps"] = sum.fps;
  j["wall_s"] = sum.wall_s;
  j["skipped_frames"] = sum.skipped_frames;
  j["empty_depth_frames"] = sum.empty_depth_frames;
  j["peak_rss_mb"] = peakRssMb();
  if (sum.ate_rmse) {
    j["ate_rmse"] = *sum.ate_rmse;
    j["ate_pairs"] = sum.ate_pairs;
  }
  AtomicOfstream f(path);
  f << j.dump() << "\n";
  f.commit();
}

void printSummary(const config::PipelineConfig& pc, const RunSummary& sum, const std::string& ate_txt,
                  const StageTimer& timer) {
  std::ostringstream s;
  char b[256];
  s << "\n---- " << pc.name << " ----\n";
  std::snprintf(b, sizeof(b), "frames: %zu processed, %zu tracked (%.1f%%), %zu keyframes, %zu map points, %zu map(s)\n",
                sum.frames, sum.tracked, sum.frames ? 100.0 * sum.tracked / sum.frames : 0.0, sum.keyframes,
                sum.map_points, sum.maps);
  s << b;
  std::snprintf(b, sizeof(b), "tracking time per frame: median %.2f ms, mean %.2f ms; %.1f frames/s wall clock\n",
                sum.median_ms, sum.mean_ms, sum.fps);
  s << b;
  s << "ATE: " << ate_txt << "\n";
  s << "stage timing (ms):\n" << timer.summary();
  s << "outputs: " << sum.out_dir << "\n";
  std::cout << s.str() << std::flush;
}

/** Trajectories, map, timing and atlas files; fills the summary's counts. */
Trajectory writeOutputs(System& sys, const config::PipelineConfig& pc, const RunOverrides& ov, RunSummary& sum) {
  const std::string& out = sum.out_dir;
  std::vector<int> lost;
  Trajectory traj = sys.cameraTrajectory(&lost);
  if (const std::string tp = outPath(pc, out, "trajectory"); !tp.empty())
    writeTrajectory(tp, pc, traj, lost, sum);
  const Trajectory kft = sys.keyframeTrajectory();
  if (const std::string kp = outPath(pc, out, "keyframe_trajectory"); !kp.empty())
    traj::writeTum(kp, kft, "dslam keyframe trajectory (T_wc), pipeline " + pc.name);
  if (const std::string mp = outPath(pc, out, "map"); !mp.empty()) sys.writePly(mp);
  sys.writeObjects(outPath(pc, out, "objects"), outPath(pc, out, "objects_ply"),
                   static_cast<size_t>(pc.outputs.getInt("objects_min_points")),
                   static_cast<int>(pc.outputs.getInt("objects_min_sightings")),
                   static_cast<size_t>(pc.outputs.getInt("objects_confirm_points")));
  if (const std::string tc = outPath(pc, out, "timing_csv"); !tc.empty()) {
    sys.timer().writeCsv(tc);
    sys.timer().writeMrptCsv((fs::path(out) / "timing_summary.csv").string());
  }
  if (const std::string ap = ov.save_atlas.empty() ? outPath(pc, out, "atlas") : ov.save_atlas; !ap.empty())
    sys.mapManager().save(ap);
  sum.keyframes = kft.size();
  sum.map_points = sys.map()->numPoints();
  sum.maps = sys.mapManager().maps().size();
  return traj;
}

}  // namespace

std::unique_ptr<System> buildSystem(const config::PipelineConfig& pc, const CameraModel& cam, PluginContext base,
                                    bool localization_only) {
  if (base.config_dir.empty()) base.config_dir = pc.dir;
  if (base.shared_dir.empty()) base.shared_dir = sharedDir();
  base.seed = pc.seed;
  base.camera = &cam;
  SlamParams sp = SlamParams::fromConfig(pc);
  if (localization_only) sp.tracker.localization_only = true;
  std::shared_ptr<Backend> backend;
  std::shared_ptr<MapManager> maps;
  for (const auto* m : pc.modulesOf("Backend"))
    if (!backend) backend = std::dynamic_pointer_cast<Backend>(makeModule(*m, base));
  if (!backend) {
    backend = create<Backend>("dslam::SchurBackend");
    backend->configure(Params::resolve(backend->paramSpecs(), ""), base);
  }
  // Map managers chain in the order listed: a filter (persistence filters)
  // wraps the one before it, the first filter without one wraps an Atlas.
  for (const auto* m : pc.modulesOf("MapManager")) {
    auto mm = std::dynamic_pointer_cast<MapManager>(makeModule(*m, base));
    if (mm->filtersAnother()) {
      if (maps) mm->setInner(maps);
    } else if (maps) {
      throw ConfigError("modules: '" + m->name + "' (" + m->type + ") is a map manager that keeps its own maps; only "
                        "filters (persistence filters) may follow another map manager");
    }
    maps = mm;
  }

  auto sys = std::make_unique<System>(cam, sp, backend, pc.mode, maps);
  const auto detectors = pc.modulesOf("Detector");
  for (const auto* m : detectors) {
    const auto dm = m->detection == "sync"    ? System::DetectionMode::Sync
                    : m->detection == "async" ? System::DetectionMode::Async
                                              : System::DetectionMode::Auto;
    sys->addDetector(m->name, std::dynamic_pointer_cast<Detector>(makeModule(*m, base)), m->every, dm,
                     m->carry == "flow", m->keyframes == "redetect", m->hold, m->wait_coverage);
  }
  for (const auto* m : pc.modulesOf("KeypointClassifier")) {
    auto c = std::dynamic_pointer_cast<KeypointClassifier>(makeModule(*m, base));
    std::string input;
    for (const auto& in : m->inputs)
      for (const auto* d : detectors)
        if (d->name == in) input = in;
    sys->addClassifier(m->name, c, input);
  }
  return sys;
}

RunSummary runPipeline(const config::PipelineConfig& pc, const RunOverrides& ov) {
  RunSummary sum;
  const config::DatasetConfig dc = datasetConfig(pc, ov);
  auto reader = create<DatasetSource>(dc.type);
  PluginContext base;
  base.config_dir = pc.dir;
  base.shared_dir = sharedDir();
  base.seed = pc.seed;
  reader->configure(dc.params, base);
  base.dataset_root = reader->root();
  const CameraModel cam = resolveCamera(pc, *reader);
  base.camera = &cam;
  sum.out_dir = prepareOutputDir(pc, ov, dc, cam);
  const std::string& out = sum.out_dir;

  std::unique_ptr<System> sys = assembleSystem(pc, ov, cam, base);
  EventLog ev;
  ev.open(outPath(pc, out, "events"));
  std::ofstream frames_csv;
  if (const std::string fp = outPath(pc, out, "frames_csv"); !fp.empty()) {
    frames_csv.open(fp);
    if (!frames_csv) throw DataError("cannot write per-frame CSV: " + fp);
    frames_csv << "frame,timestamp,state,keypoints,usable_keypoints,tracked_points,feature_count,rss_mb\n";
  }
  sys->setEventSink([&ev](const std::string& e) { ev.write(e); });
  IncrementalTrajectory traj_out;
  traj_out.open(outPath(pc, out, "trajectory"), pc.name);
  StopSignals stop_signals;

  const size_t n_all = reader->size();
  const size_t start = static_cast<size_t>(std::max(0, dc.start));
  const size_t stride = static_cast<size_t>(std::max(1, dc.stride));
  size_t n = start < n_all ? (n_all - start + stride - 1) / stride : 0;
  const int maxf = ov.max_frames > 0 ? ov.max_frames : dc.max_frames;
  if (maxf > 0) n = std::min(n, static_cast<size_t>(maxf));
  DSLAM_LOG(Info, "pipeline '" << pc.name << "' (" << (pc.mode == config::Mode::Parallel ? "parallel" : "sequential")
                               << ") on " << reader->root() << ": " << n << " frames, camera " << cam.name << " "
                               << cam.left.width << "x" << cam.left.height << ", output " << out);
  std::unique_ptr<dense::DenseMapper> dense_map = startDenseMap(pc, *sys, cam, *reader, start);
  const double wall0 = nowSeconds();
  LoopOutcome lo = frameLoop(*reader, *sys, dc, start, stride, n, ov, ev, frames_csv, traj_out, sum);
  traj_out.close();
  sum.finished = !lo.failure && !lo.stop_signal;
  sum.stopped_by = lo.failure ? "error" : lo.stop_signal == SIGINT ? "SIGINT" : lo.stop_signal == SIGTERM ? "SIGTERM" : "";
  sum.stop_signal = lo.stop_signal;
  sys->shutdown();
  sys->setEventSink(nullptr);
  if (dense_map) dense_map->waitIdle();  // its per-keyframe work is part of the frames' cost
  sum.wall_s = nowSeconds() - wall0;

  const Trajectory traj = writeOutputs(*sys, pc, ov, sum);
  sum.median_ms = median(lo.frame_ms);
  double tot = 0;
  for (double x : lo.frame_ms) tot += x;
  sum.mean_ms = lo.frame_ms.empty() ? 0 : tot / lo.frame_ms.size();
  sum.fps = sum.wall_s > 0 ? sum.frames / sum.wall_s : 0;
  const std::string ate_txt = evaluateAte(*reader, traj, sum);
  writeSummaryJson((fs::path(out) / "summary.json").string(), pc, sum);
  std::string dense_txt;
  if (dense_map) {
    try {
      dense_txt = finishDenseMap(*dense_map, *sys, traj, out);
    } catch (const std::exception& e) {
      if (!lo.failure) throw;
      DSLAM_LOG(Error, "dense map not written: " << e.what());
    }
  }
  printSummary(pc, sum, ate_txt, sys->timer());
  std::cout << dense_txt << std::flush;
  if (lo.failure) std::rethrow_exception(lo.failure);
  return sum;
}

}  // namespace dslam
