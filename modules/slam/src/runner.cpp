// runPipeline(): the `dslam run` command (dataset loop, outputs, summary).
#include <filesystem>
#include <fstream>
#include <future>
#include <iostream>
#include <sstream>

#include "dslam/core/dataset.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/core/paths.h"
#include "dslam/core/registry.h"
#include "dslam/eval/eval.h"
#include "dslam/map/map.h"
#include "dslam/slam/system.h"
#include "dslam/trajectory/io.h"

namespace fs = std::filesystem;

namespace dslam {

namespace {

std::string jsonEscape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    if (c == '\n') {
      o += "\\n";
      continue;
    }
    o += c;
  }
  return o;
}

struct EventLog {
  std::ofstream f;
  void open(const std::string& path) {
    if (!path.empty()) f.open(path);
  }
  void write(const std::string& json) {
    if (f) f << json << "\n" << std::flush;
  }
};

std::shared_ptr<Plugin> makeModule(const config::ModuleConfig& m, const PluginContext& base) {
  auto p = createPlugin(m.type, CLASS_ID(Plugin));
  PluginContext ctx = base;
  ctx.instance_name = m.name;
  p->configure(m.params, ctx);
  return p;
}

}  // namespace

RunSummary runPipeline(const config::PipelineConfig& pc, const RunOverrides& ov) {
  RunSummary sum;
  // ---- dataset ------------------------------------------------------------
  std::string ds_type;
  Params ds_params;
  config::DatasetConfig dc;
  if (pc.dataset) dc = *pc.dataset;
  if (!ov.dataset.empty()) {
    if (!fs::exists(ov.dataset)) throw DataError("dataset not found: " + ov.dataset);
    if (pc.dataset) {
      // The file's reader and parameters; only the path changes.
      dc.type = pc.dataset->type;
      dc.params = pc.dataset->params;
    } else {
      const std::string detected = config::detectDatasetType(ov.dataset);
      if (detected.empty())
        throw DataError("cannot tell the dataset type of " + ov.dataset +
                        " (expected a TUM/Bonn folder with rgb.txt, a KITTI folder with calib.txt, an EuRoC folder with "
                        "mav0/, or a .rawlog file)");
      dc.type = detected;
      auto reader = createPlugin(detected, CLASS_ID(DatasetSource));
      dc.params = Params::resolve(reader->paramSpecs(), "path: \"" + ov.dataset + "\"\n");
    }
    dc.params.set("path", "\"" + fs::absolute(ov.dataset).lexically_normal().string() + "\"");
  } else if (!pc.dataset) {
    throw ConfigError("no dataset: add a 'dataset:' section to " + (pc.file.empty() ? std::string("the pipeline") : pc.file) +
                      " or pass --dataset PATH");
  }
  auto reader = create<DatasetSource>(dc.type);
  PluginContext base;
  base.config_dir = pc.dir;
  base.shared_dir = sharedDir();
  base.seed = pc.seed;
  reader->configure(dc.params, base);
  base.dataset_root = reader->root();

  // ---- camera -------------------------------------------------------------
  std::optional<CameraModel> cam = pc.camera;
  if (!cam) cam = reader->camera();
  if (!cam) throw ConfigError("no camera: the dataset carries no calibration; add a 'camera:' section (or $include{../cameras/<name>.yaml})");
  base.camera = &*cam;

  // ---- output folder --------------------------------------------------------
  std::string out = ov.out_dir;
  if (out.empty()) out = pc.outputs.getString("dir");
  if (out.empty()) out = "out/" + pc.name;
  fs::create_directories(out);
  sum.out_dir = out;
  auto outPath = [&](const char* key) {
    const std::string n = pc.outputs.getString(key);
    return n.empty() ? std::string() : (fs::path(out) / n).string();
  };
  {
    config::PipelineConfig resolved = pc;
    resolved.dataset = dc;
    resolved.camera = cam;
    if (const std::string rc = outPath("resolved_config"); !rc.empty()) {
      std::ofstream f(rc);
      f << resolved.toYaml();
    }
  }

  // ---- system -------------------------------------------------------------
  SlamParams sp = SlamParams::fromConfig(pc);
  if (ov.localization_only) sp.tracker.localization_only = true;
  std::shared_ptr<Backend> backend;
  std::shared_ptr<MapManager> maps;
  for (const auto* m : pc.modulesOf("Backend"))
    if (!backend) backend = std::dynamic_pointer_cast<Backend>(makeModule(*m, base));
  if (!backend) {
    backend = create<Backend>("dslam::CeresBackend");
    backend->configure(Params::resolve(backend->paramSpecs(), ""), base);
  }
  for (const auto* m : pc.modulesOf("MapManager"))
    if (!maps) maps = std::dynamic_pointer_cast<MapManager>(makeModule(*m, base));

  System sys(*cam, sp, backend, pc.mode, maps);
  if (!ov.load_atlas.empty()) sys.loadMaps(ov.load_atlas);
  for (const auto* m : pc.modulesOf("Detector")) {
    auto d = std::dynamic_pointer_cast<Detector>(makeModule(*m, base));
    sys.addDetector(m->name, d, m->every);
  }
  for (const auto* m : pc.modulesOf("KeypointClassifier")) {
    auto c = std::dynamic_pointer_cast<KeypointClassifier>(makeModule(*m, base));
    std::string input;
    for (const auto& in : m->inputs)
      for (const auto* d : pc.modulesOf("Detector"))
        if (d->name == in) input = in;
    sys.addClassifier(m->name, c, input);
  }

  EventLog ev;
  ev.open(outPath("events"));
  std::ofstream frames_csv;
  if (const std::string fp = outPath("frames_csv"); !fp.empty()) {
    frames_csv.open(fp);
    if (!frames_csv) throw DataError("cannot write per-frame CSV: " + fp);
    frames_csv << "frame,timestamp,state,keypoints,usable_keypoints,tracked_points,feature_count\n";
  }
  sys.setEventSink([&ev](const std::string& json) { ev.write(json); });

  // ---- frame loop ---------------------------------------------------------
  const size_t n_all = reader->size();
  const size_t start = static_cast<size_t>(std::max(0, dc.start));
  const size_t stride = static_cast<size_t>(std::max(1, dc.stride));
  size_t n = start < n_all ? (n_all - start + stride - 1) / stride : 0;
  int maxf = ov.max_frames > 0 ? ov.max_frames : dc.max_frames;
  if (maxf > 0) n = std::min(n, static_cast<size_t>(maxf));
  DSLAM_LOG(Info, "pipeline '" << pc.name << "' (" << (pc.mode == config::Mode::Parallel ? "parallel" : "sequential")
                               << ") on " << reader->root() << ": " << n << " frames, camera " << cam->name << " "
                               << cam->left.width << "x" << cam->left.height << ", output " << out);
  log::Progress progress("tracking", n, 100);
  std::vector<double> frame_ms;
  TrackState prev_state = TrackState::NotInitialized;
  std::exception_ptr failure;
  const double wall0 = nowSeconds();
  size_t done = 0;
  try {
    // The next frame is read and decoded on a helper thread while this one is
    // processed (reading is deterministic, so sequential runs stay repeatable).
    auto readAsync = [&](size_t k) {
      return std::async(std::launch::async, [&reader, i = start + k * stride] { return reader->read(i); });
    };
    std::future<SensorFrame> next;
    if (n > 0) next = readAsync(0);
    for (size_t k = 0; k < n; k++) {
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
        if (dc.on_bad_frame != "skip") throw;
        DSLAM_LOG(Warn, "skipping frame " << i << ": " << e.what());
        ev.write("{\"event\": \"bad_frame\", \"frame\": " + std::to_string(i) + ", \"error\": \"" + jsonEscape(e.what()) + "\"}");
        continue;
      }
      const FrameResult r = sys.track(sf);
      frame_ms.push_back(r.ms_total);
      sum.frames++;
      if (r.track.state == TrackState::Ok) sum.tracked++;
      if (r.track.initialized)
        ev.write("{\"event\": \"map_initialised\", \"frame\": " + std::to_string(i) + ", \"map\": " + std::to_string(sys.map()->id) + "}");
      if (r.track.relocalized) ev.write("{\"event\": \"relocalised\", \"frame\": " + std::to_string(i) + "}");
      if (r.track.state == TrackState::Lost && prev_state == TrackState::Ok)
        ev.write("{\"event\": \"lost\", \"frame\": " + std::to_string(i) + "}");
      if (frames_csv.is_open()) {
        char line[160];
        std::snprintf(line, sizeof(line), "%d,%.6f,%s,%zu,%zu,%d,%d\n", r.frame_index, r.timestamp,
                      toString(r.track.state), r.keypoints, r.keypoints - r.dynamic_keypoints, r.track.matches,
                      r.feature_count);
        frames_csv << line;
      }
      prev_state = r.track.state;
      done = k + 1;
      if (!ov.quiet_progress) progress.update(done, std::string(toString(r.track.state)) + ", " + std::to_string(r.track.matches) + " matches");
    }
  } catch (...) {
    failure = std::current_exception();
    DSLAM_LOG(Error, "run stopped after " << done << " frames; writing the results so far to " << out);
  }
  sys.shutdown();
  sys.setEventSink(nullptr);
  sum.wall_s = nowSeconds() - wall0;
  if (!ov.quiet_progress) progress.finish();

  // ---- outputs ------------------------------------------------------------
  std::vector<int> lost;
  const Trajectory traj = sys.cameraTrajectory(&lost);
  if (const std::string tp = outPath("trajectory"); !tp.empty()) {
    traj::WriteOptions wo;
    wo.format = traj::formatFromString(pc.outputs.getString("trajectory_format"));
    wo.kitti_with_times = true;
    std::ostringstream h;
    h << "dslam camera trajectory (T_wc), pipeline " << pc.name << "\n"
      << "tracked frames only: " << traj.size() << " of " << sum.frames << " processed frames";
    if (!lost.empty()) {
      h << "; not tracked (omitted):";
      for (size_t i = 0; i < lost.size() && i < 200; i++) h << " " << lost[i];
      if (lost.size() > 200) h << " ...";
    }
    h << "\ntimestamp tx ty tz qx qy qz qw";
    wo.header = h.str();
    traj::write(tp, traj, wo);
  }
  const Trajectory kft = sys.keyframeTrajectory();
  if (const std::string kp = outPath("keyframe_trajectory"); !kp.empty())
    traj::writeTum(kp, kft, "dslam keyframe trajectory (T_wc), pipeline " + pc.name);
  if (const std::string mp = outPath("map"); !mp.empty()) sys.writePly(mp);
  if (const std::string tc = outPath("timing_csv"); !tc.empty()) {
    sys.timer().writeCsv(tc);
    sys.timer().writeMrptCsv((fs::path(out) / "timing_summary.csv").string());
  }
  if (const std::string ap = ov.save_atlas.empty() ? outPath("atlas") : ov.save_atlas; !ap.empty())
    sys.mapManager().save(ap);

  sum.keyframes = kft.size();
  sum.map_points = sys.map()->numPoints();
  sum.maps = sys.mapManager().maps().size();
  sum.median_ms = median(frame_ms);
  double tot = 0;
  for (double x : frame_ms) tot += x;
  sum.mean_ms = frame_ms.empty() ? 0 : tot / frame_ms.size();
  sum.fps = sum.wall_s > 0 ? sum.frames / sum.wall_s : 0;

  const Trajectory& gt = reader->groundTruth();
  std::string ate_txt = "n/a (no ground truth)";
  if (!gt.empty() && traj.size() >= 3) {
    try {
      eval::AteOptions ao;
      ao.align = eval::Align::SE3;
      const auto ate = eval::computeAte(gt, traj, ao);
      sum.ate_rmse = ate.stats.rmse;
      sum.ate_pairs = ate.stats.count;
      char b[128];
      std::snprintf(b, sizeof(b), "%.4f m RMSE (%zu pairs, SE(3) alignment)", ate.stats.rmse, ate.stats.count);
      ate_txt = b;
    } catch (const Error& e) {
      ate_txt = std::string("n/a: ") + e.what();
    }
  }
  {
    std::ofstream f((fs::path(out) / "summary.json").string());
    f << "{\"pipeline\": \"" << jsonEscape(pc.name) << "\", \"frames\": " << sum.frames << ", \"tracked\": " << sum.tracked
      << ", \"keyframes\": " << sum.keyframes << ", \"map_points\": " << sum.map_points << ", \"maps\": " << sum.maps
      << ", \"median_ms\": " << sum.median_ms << ", \"mean_ms\": " << sum.mean_ms << ", \"fps\": " << sum.fps
      << ", \"wall_s\": " << sum.wall_s;
    if (sum.ate_rmse) f << ", \"ate_rmse\": " << *sum.ate_rmse << ", \"ate_pairs\": " << sum.ate_pairs;
    f << "}\n";
  }
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
  s << "stage timing (ms):\n" << sys.timer().summary();
  s << "outputs: " << out << "\n";
  std::cout << s.str() << std::flush;
  if (failure) std::rethrow_exception(failure);
  return sum;
}

}  // namespace dslam
