#include "dslam/slam/system.h"

#include <condition_variable>
#include <fstream>
#include <mutex>
#include <thread>

#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/map/map.h"

namespace dslam {

// ---------------------------------------------------------------------------
// Sections
// ---------------------------------------------------------------------------

void registerSlamSections() {
  config::registerSection("features", &FrontendParams::specs,
                          "ORB front end (ORB-SLAM2 defaults): feature count, pyramid, FAST thresholds, stereo matching.");
  config::registerSection("tracking", &TrackerParams::specs,
                          "Tracking: initialisation, motion model, local map, keyframe decision (ORB-SLAM2 defaults).");
  config::registerSection("mapping", &LocalMapperParams::specs,
                          "Local mapping: triangulation, culling, local bundle adjustment (ORB-SLAM2 defaults).");
}

SlamParams SlamParams::fromConfig(const config::PipelineConfig& pc) {
  SlamParams p;
  auto sec = [&](const char* n) {
    auto it = pc.sections.find(n);
    if (it == pc.sections.end()) throw ConfigError(std::string("section '") + n + "' is not registered (call registerSlamSections())");
    return it->second;
  };
  p.frontend = FrontendParams::fromParams(sec("features"));
  p.tracker = TrackerParams::fromParams(sec("tracking"));
  p.mapper = LocalMapperParams::fromParams(sec("mapping"));
  return p;
}

// ---------------------------------------------------------------------------
// Single-map manager used when the pipeline configures none.
// ---------------------------------------------------------------------------

namespace {
class SingleMapManager : public MapManager {
  DEFINE_MRPT_OBJECT(SingleMapManager, dslam)
 public:
  SingleMapManager() { reset(); }
  std::string description() const override { return "one map, no save/load (internal default)"; }
  std::shared_ptr<Map> currentMap() override { return map_; }
  std::shared_ptr<Map> createMap() override {
    map_ = std::make_shared<Map>(next_id_++);
    return map_;
  }
  std::vector<std::shared_ptr<Map>> maps() const override { return {map_}; }
  void reset() override { createMap(); }
  void save(const std::string&) const override {
    throw Error("the default map manager cannot save maps: configure a dslam::Atlas module");
  }
  void load(const std::string&) override {
    throw Error("the default map manager cannot load maps: configure a dslam::Atlas module");
  }

 private:
  std::shared_ptr<Map> map_;
  int64_t next_id_ = 0;
};
}  // namespace
}  // namespace dslam

IMPLEMENTS_MRPT_OBJECT(SingleMapManager, MapManager, dslam)

namespace dslam {

// ---------------------------------------------------------------------------
// Detector worker: runs detect() in its own thread; the tracking thread waits
// on a condition variable (no busy waiting).
// ---------------------------------------------------------------------------

struct System::DetectorSlot {
  std::string name;
  std::shared_ptr<Detector> det;
  int every = 1;
  Detections last;  ///< reused on skipped frames
  // worker
  std::thread th;
  std::mutex m;
  std::condition_variable cv;
  const SensorFrame* job = nullptr;
  bool has_result = false, quit = false;
  Detections result;
  std::exception_ptr error;
  double ms = 0;

  void startThread() {
    th = std::thread([this] {
      std::unique_lock<std::mutex> lk(m);
      for (;;) {
        cv.wait(lk, [this] { return quit || job != nullptr; });
        if (quit) return;
        const SensorFrame* f = job;
        lk.unlock();
        Detections d;
        std::exception_ptr e;
        const double t0 = nowSeconds();
        try {
          d = det->detect(*f);
        } catch (...) {
          e = std::current_exception();
        }
        const double dt = (nowSeconds() - t0) * 1e3;
        lk.lock();
        result = std::move(d);
        error = e;
        ms = dt;
        job = nullptr;
        has_result = true;
        cv.notify_all();
      }
    });
  }
  void submit(const SensorFrame& f) {
    std::lock_guard<std::mutex> lk(m);
    job = &f;
    has_result = false;
    cv.notify_all();
  }
  Detections wait(double& out_ms) {
    std::unique_lock<std::mutex> lk(m);
    cv.wait(lk, [this] { return has_result; });
    has_result = false;
    if (error) std::rethrow_exception(error);
    out_ms = ms;
    return std::move(result);
  }
  ~DetectorSlot() {
    if (th.joinable()) {
      {
        std::lock_guard<std::mutex> lk(m);
        quit = true;
      }
      cv.notify_all();
      th.join();
    }
  }
};

// ---------------------------------------------------------------------------

System::System(const CameraModel& camera, const SlamParams& p, std::shared_ptr<Backend> backend, config::Mode mode,
               std::shared_ptr<MapManager> maps)
    : mode_(mode), p_(p), backend_(std::move(backend)), maps_(std::move(maps)) {
  if (!backend_) throw ConfigError("System needs a Backend (e.g. dslam::CeresBackend)");
  if (camera.sensor == SensorType::Monocular)
    throw ConfigError("monocular SLAM is not implemented yet: use an RGB-D or stereo camera");
  frontend_ = std::make_unique<FeatureFrontend>(camera, p_.frontend);
  base_features_ = p_.frontend.orb.n_features;
  if (!maps_) maps_ = std::make_shared<SingleMapManager>();
  const CameraModel& cam = frontend_->camera();
  CameraIntrinsics ci;
  ci.fx = static_cast<float>(cam.left.fx);
  ci.fy = static_cast<float>(cam.left.fy);
  ci.cx = static_cast<float>(cam.left.cx);
  ci.cy = static_cast<float>(cam.left.cy);
  ci.invfx = 1.f / ci.fx;
  ci.invfy = 1.f / ci.fy;
  ci.bf = static_cast<float>(cam.bf());
  ci.close_depth = static_cast<float>(cam.closeDepth());
  ci.bounds = frontend_->imageBounds();
  auto scale = std::make_shared<ScaleLevels>(ScaleLevels::make(p_.frontend.orb.n_levels, p_.frontend.orb.scale_factor));
  if (p_.tracker.max_frames <= 0) p_.tracker.max_frames = std::max(1, static_cast<int>(std::lround(cam.fps)));
  p_.tracker.sensor = cam.sensor;
  p_.mapper.monocular = false;
  mapper_ = std::make_unique<LocalMapper>(p_.mapper, backend_, &timer_);
  tracker_ = std::make_unique<Tracker>(p_.tracker, ci, scale, mapper_.get());
  auto m = maps_->currentMap();
  mapper_->setMap(m);
  tracker_->setMap(m);
  if (mode_ == config::Mode::Parallel) mapper_->start();
}

System::~System() { shutdown(); }

MapPtr System::map() const { return maps_->currentMap(); }

void System::addDetector(const std::string& name, std::shared_ptr<Detector> det, int every) {
  auto s = std::make_unique<DetectorSlot>();
  s->name = name;
  s->det = std::move(det);
  s->every = std::max(1, every);
  if (mode_ == config::Mode::Parallel) s->startThread();
  detectors_.push_back(std::move(s));
}

void System::addClassifier(const std::string& name, std::shared_ptr<KeypointClassifier> c, const std::string& detector) {
  ClassifierSlot s{name, std::move(c), -1};
  if (!detectors_.empty()) s.detector = 0;
  if (!detector.empty()) {
    s.detector = -1;
    for (size_t i = 0; i < detectors_.size(); i++)
      if (detectors_[i]->name == detector) s.detector = static_cast<int>(i);
    if (s.detector < 0) throw ConfigError("classifier '" + name + "': input '" + detector + "' is not a detector of this pipeline");
  }
  classifiers_.push_back(std::move(s));
}

FrameResult System::track(const SensorFrame& in) {
  const double t0 = nowSeconds();
  const int fi = in.index;
  FrameResult res;
  res.frame_index = fi;
  res.timestamp = in.timestamp;

  // Detectors: start now (parallel: concurrently with ORB extraction).
  std::vector<Detections> dets(detectors_.size());
  std::vector<char> ran(detectors_.size(), 0);
  for (size_t d = 0; d < detectors_.size(); d++) {
    auto& s = *detectors_[d];
    if (static_cast<int>(frames_) % s.every != 0) continue;
    ran[d] = 1;
    if (mode_ == config::Mode::Parallel) s.submit(in);
  }

  res.feature_count = frontend_->featureCount();
  Frame f;
  {
    const double ta = nowSeconds();
    f = frontend_->process(in);
    timer_.add("orb", fi, (nowSeconds() - ta) * 1e3);
  }
  for (size_t d = 0; d < detectors_.size(); d++) {
    auto& s = *detectors_[d];
    if (!ran[d]) {
      dets[d] = s.last;
      continue;
    }
    double ms = 0;
    if (mode_ == config::Mode::Parallel) {
      const double tw = nowSeconds();
      dets[d] = s.wait(ms);
      timer_.add("detector_wait", fi, (nowSeconds() - tw) * 1e3);
    } else {
      const double td = nowSeconds();
      dets[d] = s.det->detect(in);
      ms = (nowSeconds() - td) * 1e3;
    }
    timer_.add("detector", fi, ms);
    dets[d].frame_index = fi;
    s.last = dets[d];
  }

  if (!classifiers_.empty()) {
    const double tc = nowSeconds();
    ClassifierContext ctx;
    ctx.camera = &frontend_->camera();
    ctx.previous = prev_frame_ ? &*prev_frame_ : nullptr;
    ctx.previous_T_wc = prev_T_wc_;
    if (auto pred = tracker_->predictedPose()) ctx.predicted_T_wc = pred->inverse();
    ctx.base_feature_count = base_features_;
    static const Detections kNone;
    int want = 0;
    for (auto& c : classifiers_) {
      const Detections& d = c.detector >= 0 ? dets[c.detector] : kNone;
      ctx.previous_detections = (c.detector >= 0 && c.detector < static_cast<int>(prev_dets_.size())) ? &prev_dets_[c.detector] : nullptr;
      const double t1 = nowSeconds();
      c.c->classify(f, d, ctx);
      timer_.add("classifier_" + c.name, fi, (nowSeconds() - t1) * 1e3);
      want = std::max(want, c.c->requestedFeatureCount());
    }
    frontend_->setFeatureCount(want > 0 ? want : base_features_);
    timer_.add("classify", fi, (nowSeconds() - tc) * 1e3);
  }
  res.keypoints = f.size();
  res.dynamic_keypoints = f.countLabel(KpLabel::Dynamic);

  const bool keep_prev = !classifiers_.empty();
  std::optional<Frame> copy;
  if (keep_prev) copy = f;  // classifiers look at the previous frame (images and keypoints)

  {
    const double tt = nowSeconds();
    res.track = tracker_->track(std::move(f));
    timer_.add("track", fi, (nowSeconds() - tt) * 1e3);
  }
  std::optional<SE3> T_wc;
  if (res.track.T_cw) T_wc = res.track.T_cw->inverse();
  for (size_t k = 0; k < classifiers_.size(); k++) {
    auto& c = classifiers_[k];
    static const Detections kNone;
    c.c->afterTracking(copy ? *copy : Frame{}, c.detector >= 0 ? dets[c.detector] : kNone, T_wc);
  }
  res.ms_total = (nowSeconds() - t0) * 1e3;
  timer_.add("frame", fi, res.ms_total);

  if (mode_ == config::Mode::Sequential) mapper_->processAll();

  if (keep_prev) prev_frame_ = std::move(copy);
  prev_dets_ = std::move(dets);
  prev_T_wc_ = T_wc;
  frames_++;
  return res;
}

void System::shutdown() {
  if (shut_) return;
  shut_ = true;
  if (mode_ == config::Mode::Parallel) mapper_->stop();
  mapper_->processAll();
  detectors_.clear();
}

Trajectory System::cameraTrajectory(std::vector<int>* lost) const {
  Trajectory t;
  auto m = map();
  std::lock_guard<std::recursive_mutex> lk(m->update_mutex);
  for (const auto& r : tracker_->records()) {
    if (r.lost || !r.ref) {
      if (lost) lost->push_back(r.frame_index);
      continue;
    }
    // Follow erased keyframes to a live ancestor (ORB-SLAM SaveTrajectoryTUM).
    KeyFrame* kf = r.ref;
    SE3 Trw;
    int guard = 0;
    while (kf->bad && kf->parent && guard++ < 10000) {
      Trw = Trw * kf->T_cp;
      kf = kf->parent;
    }
    const SE3 T_cw = r.T_cr * Trw * kf->T_cw();
    t.push_back(r.timestamp, T_cw.inverse());
  }
  return t;
}

Trajectory System::keyframeTrajectory() const {
  Trajectory t;
  auto m = map();
  std::lock_guard<std::recursive_mutex> lk(m->update_mutex);
  for (const auto& [id, kf] : m->keyframes())
    if (!kf->bad) t.push_back(kf->timestamp, kf->T_wc());
  // keyframes() is ordered by id = creation order = time order
  return t;
}

void System::writePly(const std::string& path) const {
  auto m = map();
  std::lock_guard<std::recursive_mutex> lk(m->update_mutex);
  std::ofstream f(path);
  if (!f) throw DataError("cannot write map PLY: " + path);
  size_t n = 0;
  for (const auto& [id, p] : m->points()) n += !p->bad;
  f << "ply\nformat ascii 1.0\ncomment dslam map " << m->id << "\nelement vertex " << n
    << "\nproperty float x\nproperty float y\nproperty float z\n"
    << "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty int class_id\nend_header\n";
  char buf[160];
  for (const auto& [id, p] : m->points()) {
    if (p->bad) continue;
    int r = 160, g = 160, b = 160;
    if (p->label == KpLabel::Movable) r = 40, g = 90, b = 220;
    if (p->label == KpLabel::Dynamic) r = 220, g = 40, b = 40;
    std::snprintf(buf, sizeof(buf), "%.5f %.5f %.5f %d %d %d %d\n", p->pos.x(), p->pos.y(), p->pos.z(), r, g, b,
                  static_cast<int>(p->class_id));
    f << buf;
  }
}

}  // namespace dslam
