#include "dslam/slam/system.h"

#include <nlohmann/json.hpp>

#include <chrono>
#include <deque>
#include <fstream>
#include <future>
#include <set>

#include "dslam/core/atomic_file.h"
#include "dslam/core/coco.h"
#include "dslam/core/error.h"
#include "dslam/core/json_layout.h"
#include "dslam/core/log.h"
#include "dslam/core/worker.h"
#include "dslam/dense/dense_map.h"
#include "dslam/map/atlas.h"
#include "dslam/map/map.h"
#include "dslam/place_recognition/vocabulary.h"
#include "dslam/slam/detection_carry.h"

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
  config::registerSection("place_recognition", &PlaceRecognitionParams::specs,
                          "Vocabulary and keyframe database (BoW relocalisation, loop detection) and the map policy "
                          "of the atlas when tracking is lost.");
  config::registerSection("loop_closing", &LoopClosingParams::specs,
                          "Loop closing and map merging (ORB-SLAM2/3 defaults, SE(3) for stereo / RGB-D).");
  dense::registerDenseSection();
}

std::vector<ParamSpec> PlaceRecognitionParams::specs() {
  PlaceRecognitionParams d;
  return {
      P_bool("enabled", d.enabled, "load a vocabulary: keyframe database, BoW matching, relocalisation and loop detection"),
      P_path("vocabulary", "", "vocabulary file (dslam binary, ORBvoc.txt, DBoW2/3 .yml[.gz]); '' = the shipped default or $DSLAM_VOCABULARY"),
      P_int("new_map_after_lost", d.new_map_after_lost,
            "frames with tracking lost and relocalisation failing before a new map is started (ORB-SLAM3 waits ~3 s)", 1),
      P_int("min_keyframes_keep_map", d.min_keyframes_keep_map,
            "a lost map with fewer keyframes is discarded instead of kept in the atlas (ORB-SLAM3: 10)", 0),
      P_int("loop_check_every", d.loop_check_every,
            "query the keyframe database with every N-th tracked frame; a possible loop or merge makes the next "
            "frame a keyframe so that loop closing sees it at once (0 = only keyframes are queried, as ORB-SLAM)", 0),
  };
}

PlaceRecognitionParams PlaceRecognitionParams::fromParams(const Params& p) {
  PlaceRecognitionParams r;
  r.enabled = p.getBool("enabled");
  r.vocabulary = p.getString("vocabulary");
  r.new_map_after_lost = static_cast<int>(p.getInt("new_map_after_lost"));
  r.min_keyframes_keep_map = static_cast<int>(p.getInt("min_keyframes_keep_map"));
  r.loop_check_every = static_cast<int>(p.getInt("loop_check_every"));
  return r;
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
  p.place = PlaceRecognitionParams::fromParams(sec("place_recognition"));
  p.loop = LoopClosingParams::fromParams(sec("loop_closing"));
  p.loop.seed = pc.seed;
  return p;
}

}  // namespace dslam

namespace dslam {

// ---------------------------------------------------------------------------
// Detector slot. Parallel mode: detect() runs on a dslam::Worker thread
// concurrently with ORB extraction; the result (or the exception) comes back
// through a promise. Sync: the tracking thread waits for it. Async: it takes
// the latest finished result and carries it to the current frame by optical
// flow (detection_carry.h; on the slot's carrier thread while the tracking
// thread extracts ORB features); a new job starts whenever the worker is free and
// `every` frames have passed since the last one started (every: 1 = as soon
// as it is free). A frame that becomes a keyframe with a carried detection
// is detected again right away (`keyframes: redetect`): local mapping waits
// for that detection and labels the keyframe again before it triangulates
// (System::relabelKeyFrame), so carried boxes that lag behind a person do not
// put the person into the map.
// ---------------------------------------------------------------------------

struct System::DetectorSlot {
  using Result = std::pair<Detections, double>;  ///< detections, ms
  struct Job {
    SensorFrame frame;  ///< shallow copy: an asynchronous job outlives the caller's frame
    std::shared_ptr<std::promise<Result>> result;
  };
  /** A keyframe's own detection, asked for after the frame was tracked. */
  struct Late {
    std::shared_future<Result> result;
    cv::Mat gray;  ///< the keyframe's grey image (its result may become `last`)
  };

  std::string name;
  std::shared_ptr<Detector> det;
  int every = 1;
  bool async = false;
  bool flow = true;  ///< carry older detections by optical flow (false: left in place, age grows)
  bool redetect_keyframes = true;  ///< async: keyframes with a carried detection are detected again
  int hold = 0;                    ///< frames a box the detector stops reporting is kept (holdMissedBoxes)
  double wait_coverage = 0;        ///< async: wait for the running detection above this box coverage (0 = never)
  std::vector<int> last_seen;      ///< hold: frame at which each box of `last` was last reported
  Detections prev;                 ///< async, hold: the detection a new one replaced in this frame
  cv::Mat prev_gray;
  std::vector<int> prev_seen;
  Detections last;    ///< the latest detections given to a frame (carried forward)
  cv::Mat last_gray;  ///< grey image `last` describes
  std::shared_future<Result> pending;  ///< shared: a keyframe's relabelling may wait for it too
  cv::Mat pending_gray;  ///< grey image of the frame the pending job detects
  std::deque<Late> late;  ///< keyframe jobs queued behind `pending`, oldest first
  bool submitted_now = false;
  bool fresh = false;  ///< async: a new detection arrived in this frame (take())
  bool ran = false;    ///< sync: the detector ran on this frame
  int64_t last_submit = -1000000;  ///< frame count when the last asynchronous job started
  /** Fulfils `p` with the detections `work()` returns and the time it
   *  took, or with its exception (the worker threads' jobs). */
  template <class Work>
  static void fulfil(std::promise<Result>& p, Work&& work) {
    try {
      const double t0 = nowSeconds();
      Detections d = work();
      p.set_value({std::move(d), (nowSeconds() - t0) * 1e3});
    } catch (...) {
      p.set_exception(std::current_exception());
    }
  }
  Worker<Job> worker{[this](Job& j) {
    fulfil(*j.result, [&] {
      Detections d = det->detect(j.frame);
      d.frame_index = j.frame.index;
      return d;
    });
  }};

  /** Parallel mode, asynchronous with flow: `last` is carried to the new
   *  frame on this thread while the tracking thread extracts ORB features
   *  (the carry needs only the frame's grey image). */
  struct CarryJob {
    Detections d;
    cv::Mat from, to;
    int age = 0;
    std::shared_ptr<std::promise<Result>> result;
  };
  Worker<CarryJob> carrier{
      [](CarryJob& j) { fulfil(*j.result, [&] { return carryDetections(j.d, j.from, j.to, j.age); }); }};
  std::future<Result> carried;  ///< this frame's carried detection (carrier running)

  void startCarry(const cv::Mat& gray, int frame_index) {
    CarryJob j;
    j.d = last;
    j.from = last_gray;
    j.to = gray;
    j.age = frame_index - last.frame_index;
    j.result = std::make_shared<std::promise<Result>>();
    carried = j.result->get_future();
    carrier.push(std::move(j));
  }

  std::shared_future<Result> push(const SensorFrame& f) {
    Job j;
    j.frame = f;
    j.result = std::make_shared<std::promise<Result>>();
    auto fut = j.result->get_future().share();
    worker.push(std::move(j));
    return fut;
  }
  void submit(const SensorFrame& f) { pending = push(f); }
  static bool ready(const std::shared_future<Result>& r) {
    return r.valid() && r.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
  }
  bool pendingReady() const { return ready(pending); }
  /** Detections of the submitted frame; rethrows the detector's exception. */
  Detections wait(double& out_ms) {
    const std::shared_future<Result> r = std::move(pending);
    pending = {};
    out_ms = r.get().second;
    return r.get().first;
  }
  /** Async: waits for the submitted job, whose detections (of
   *  `pending_gray`) become the latest (take()); returns its time, ms. */
  double takePending() {
    double ms = 0;
    Detections d = wait(ms);
    take(std::move(d), pending_gray);
    return ms;
  }
  /** Async: `d` (of image `gray`) becomes the latest detection; the one it
   *  replaces is kept for `hold` (the first replacement in a frame). */
  void take(Detections d, const cv::Mat& gray) {
    if (!fresh) {
      prev = std::move(last);
      prev_gray = last_gray;
      prev_seen = std::move(last_seen);
      last_seen.clear();
    }
    last = std::move(d);
    last_gray = gray;
    fresh = true;
  }
  /** Waits for every job this slot started (error paths, shutdown). */
  void waitAll() {
    if (carried.valid()) carried.wait();
    if (pending.valid()) pending.wait();
    for (const auto& l : late) l.result.wait();
  }
};

namespace {

/** Bag of words of a frame from its usable keypoints: dynamic ones (people,
 *  moving objects) do not vote in relocalisation or loop detection. */
void computeFrameBow(const KeyFrameDatabase& db, const TrackedFrame& f, BowVector& bow, FeatureVector& feat) {
  std::vector<char> use(f.size(), 1);
  bool all = true;
  for (size_t i = 0; i < f.size(); i++) all &= (use[i] = f.usable(i)) != 0;
  db.computeBow(f.f.descriptors, bow, feat, all ? nullptr : &use);
}

}  // namespace

// ---------------------------------------------------------------------------

System::System(const CameraModel& camera, const SlamParams& p, std::shared_ptr<Backend> backend, config::Mode mode,
               std::shared_ptr<MapManager> maps)
    : mode_(mode), p_(p), backend_(std::move(backend)), maps_(std::move(maps)) {
  if (!backend_) throw ConfigError("System needs a Backend (e.g. dslam::SchurBackend)");
  if (camera.sensor == SensorType::Monocular)
    throw ConfigError("monocular SLAM is not implemented yet: use an RGB-D or stereo camera");
  frontend_ = std::make_unique<FeatureFrontend>(camera, p_.frontend);
  base_features_ = p_.frontend.orb.n_features;
  if (!maps_) maps_ = std::make_shared<Atlas>();
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
  auto scale = std::make_shared<const ScaleLevels>(ScaleLevels::make(p_.frontend.orb.n_levels, p_.frontend.orb.scale_factor));
  intrinsics_ = ci;
  scale_ = scale;
  if (p_.tracker.max_frames <= 0) p_.tracker.max_frames = std::max(1, static_cast<int>(std::lround(cam.fps)));
  p_.tracker.sensor = cam.sensor;
  p_.mapper.monocular = false;
  mapper_ = std::make_unique<LocalMapper>(p_.mapper, backend_, &timer_);
  tracker_ = std::make_unique<Tracker>(p_.tracker, ci, scale, mapper_.get());
  tracker_->setMap(maps_->currentMap());
  if (p_.place.enabled) {
    const std::string vpath = p_.place.vocabulary.empty() ? defaultVocabularyPath() : p_.place.vocabulary;
    const double tv = nowSeconds();
    auto voc = std::make_shared<const Vocabulary>(Vocabulary::load(vpath));
    DSLAM_LOG(Debug, "vocabulary " << vpath << " loaded in " << (nowSeconds() - tv) * 1e3 << " ms (" << voc->size()
                                   << " words)");
    kfdb_ = std::make_shared<KeyFrameDatabase>(voc);
    auto db = kfdb_;
    mapper_->setBowFunction([db](KeyFrame* kf) { db->computeBow(kf); });
    tracker_->setBowFunction([db](TrackedFrame& f) { computeFrameBow(*db, f, f.bow, f.feat); });
    tracker_->setRelocCandidates([db, this](const TrackedFrame& f) {
      return db->detectRelocalizationCandidates(f.bow, tracker_->map().get());
    });
    loop_ = std::make_unique<LoopCloser>(p_.loop, backend_, kfdb_, maps_.get(), mapper_.get(), &timer_);
    loop_->setEventCallback([this](const LoopEvent& e) {
      if (on_event_) on_event_(e.json());
    });
  } else if (p_.loop.enabled) {
    DSLAM_LOG(Info, "loop closing needs place_recognition.enabled: disabled");
  }
  // A processed keyframe goes to the map manager (persistence filters,
  // objects), then to loop closing.
  LoopCloser* lc = loop_.get();
  MapManager* mm = maps_.get();
  StageTimer* timer = &timer_;
  mapper_->setKeyFrameGate([this](KeyFrame& kf) { relabelKeyFrame(kf); });
  mapper_->setKeyFrameCallback([lc, mm, timer](const KeyFramePtr& kf) {
    {
      StageTimer::Scope t(timer, "map_manager", kf->frame_index);
      mm->onKeyFrame(kf);
    }
    if (lc) lc->insertKeyFrame(kf);
  });
  if (mode_ == config::Mode::Parallel) {
    mapper_->start();
    if (loop_) loop_->start();
  }
}

void System::indexKeyFrames() {
  if (!kfdb_) return;
  for (const auto& m : maps_->maps()) {
    std::lock_guard<std::recursive_mutex> lk(m->update_mutex);
    for (const auto& [id, kf] : m->keyframes()) {
      kfdb_->computeBow(kf.get());
      kfdb_->add(kf.get());
    }
  }
}

void System::loadMaps(const std::string& path) {
  if (frames_ > 0) throw Error("loadMaps() must be called before the first frame");
  maps_->setExpectedCamera(intrinsics_, scale_);
  maps_->load(path);
  if (kfdb_) kfdb_->clear();
  indexKeyFrames();
  tracker_->reset();
  tracker_->setMap(maps_->currentMap());
}

void System::checkPlaceRecognition() {
  if (!loop_ || !p_.loop.enabled || p_.place.loop_check_every <= 0 || p_.tracker.localization_only) return;
  if (frames_ % static_cast<size_t>(p_.place.loop_check_every) != 0) return;
  const double t0 = nowSeconds();
  const TrackedFrame& f = tracker_->lastFrame();
  KeyFrame* ref = tracker_->referenceKeyFrame();
  if (!ref || f.f.descriptors.empty()) return;
  auto map = tracker_->map();
  std::lock_guard<std::recursive_mutex> lk(map->update_mutex);
  BowVector bow;
  FeatureVector feat;
  computeFrameBow(*kfdb_, f, bow, feat);
  // As loop detection: the weakest score among the reference keyframe's
  // neighbourhood is the bar; candidates outside it that pass hint a loop.
  std::set<int64_t> near;
  near.insert(ref->id);
  double min_score = ref->bow.empty() ? 1.0 : kfdb_->vocabulary().score(bow, ref->bow);
  for (KeyFrame* c : ref->covisibles()) {
    near.insert(c->id);
    if (!c->bow.empty()) min_score = std::min(min_score, kfdb_->vocabulary().score(bow, c->bow));
  }
  for (KeyFrame* c : kfdb_->detectRelocalizationCandidates(bow, nullptr)) {
    if (near.count(c->id)) continue;
    if (kfdb_->vocabulary().score(bow, c->bow) < min_score) continue;
    tracker_->requestKeyFrame();
    DSLAM_LOG(Debug, "frame " << f.f.index() << ": keyframe " << c->id << " (map " << c->map->id
                              << ") looks like a revisit: next frame becomes a keyframe");
    break;
  }
  timer_.add("place_check", f.f.index(), (nowSeconds() - t0) * 1e3);
}

void System::switchToNewMap(int frame) {
  auto old = maps_->currentMap();
  // Parallel mode: local mapping is held between keyframes for the whole
  // switch (the keyframe it is processing is finished, its local BA cut
  // short; queued keyframes wait and keep their map) and loop closing first
  // empties its queue (it may pause and resume local mapping meanwhile: the
  // pauses nest), so that neither works on the old map while it is discarded
  // or set aside. A discarded map's queued keyframes are dropped (reset()).
  struct Hold {
    LocalMapper* m;
    ~Hold() {
      if (m) m->resume();
    }
  } hold{mode_ == config::Mode::Parallel ? mapper_.get() : nullptr};
  if (hold.m) {
    hold.m->requestPause();
    if (loop_) loop_->waitIdle();
  }
  const size_t n_kf = old->numKeyFrames();
  std::string what;
  if (n_kf < static_cast<size_t>(p_.place.min_keyframes_keep_map)) {
    if (kfdb_)
      for (const auto& [id, kf] : old->allKeyFramesEver()) kfdb_->erase(kf.get());
    tracker_->forgetMap(old.get());
    mapper_->reset();
    maps_->eraseMap(old);
    what = "discarded map " + std::to_string(old->id) + " (" + std::to_string(n_kf) + " keyframes)";
  } else {
    what = "kept map " + std::to_string(old->id) + " (" + std::to_string(n_kf) + " keyframes)";
  }
  auto m = maps_->createMap();
  tracker_->reset();
  tracker_->setMap(m);
  DSLAM_LOG(Info, "tracking lost for " << lost_frames_ << " frames: new map " << m->id << " at frame " << frame << "; "
                                       << what);
  if (on_event_) {
    nlohmann::ordered_json e;
    e["event"] = "new_map";
    e["frame"] = frame;
    e["map"] = m->id;
    e["previous_map"] = old->id;
    e["previous_kept"] = n_kf >= static_cast<size_t>(p_.place.min_keyframes_keep_map);
    on_event_(e.dump());
  }
  lost_frames_ = 0;
}

System::~System() { shutdown(); }

MapPtr System::map() const { return maps_->currentMap(); }

void System::addDetector(const std::string& name, std::shared_ptr<Detector> det, int every, DetectionMode detection,
                         bool carry_by_flow, bool redetect_keyframes, int hold, double wait_coverage) {
  auto s = std::make_unique<DetectorSlot>();
  s->name = name;
  s->det = std::move(det);
  s->every = std::max(1, every);
  s->flow = carry_by_flow;
  s->redetect_keyframes = redetect_keyframes;
  s->hold = std::max(0, hold);
  s->wait_coverage = std::clamp(wait_coverage, 0.0, 1.0);
  const bool parallel = mode_ == config::Mode::Parallel;
  s->async = parallel && (detection == DetectionMode::Async ||
                          (detection == DetectionMode::Auto && !s->det->precomputed()));
  if (detection == DetectionMode::Async && !parallel)
    DSLAM_LOG(Info, "detector '" << name << "': detection: async needs mode: parallel; runs synchronously");
  if (s->async && s->every > 1)
    DSLAM_LOG(Info, "detector '" << name << "': asynchronous, a new detection at most every " << s->every
                                 << " frames");
  if (parallel) s->worker.start();
  if (s->async && s->flow) s->carrier.start();
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

namespace {
const Detections kNoDetections;  ///< input of classifiers without a detector
}  // namespace

Frame System::extract(const SensorFrame& in, std::vector<Detections>& dets) {
  const int fi = in.index;
  // Detectors start first (parallel mode: concurrently with ORB extraction).
  dets.assign(detectors_.size(), Detections{});
  for (auto& sp : detectors_) {
    auto& s = *sp;
    s.submitted_now = s.fresh = s.ran = false;
    s.carried = {};
    if (s.async) {
      // The first frame waits for its detection: a map must not start on undetected movers.
      if (s.pending.valid() && (s.pendingReady() || s.last_gray.empty())) {
        const double ms = s.takePending();
        timer_.add("detector", s.last.frame_index, ms);
      }
      // Keyframes' own detections (queued after `pending`): newer than the
      // last one, they are carried from here on too.
      while (!s.late.empty() && DetectorSlot::ready(s.late.front().result)) {
        const DetectorSlot::Result& r = s.late.front().result.get();  // rethrows the detector's error
        timer_.add("detector", r.first.frame_index, r.second);
        if (r.first.frame_index > s.last.frame_index) s.take(r.first, s.late.front().gray);
        s.late.pop_front();
      }
      const auto n = static_cast<int64_t>(frames_);
      if (!s.pending.valid() && s.late.empty() && n - s.last_submit >= s.every) {
        s.submit(in);
        s.submitted_now = true;
        s.last_submit = n;
      }
      continue;
    }
    if (static_cast<int>(frames_) % s.every != 0) continue;
    s.ran = true;
    if (mode_ == config::Mode::Parallel) s.submit(in);
  }
  // Asynchronous detections are carried to this frame on their carrier
  // threads while this one extracts ORB features.
  auto start_carry = [&](const cv::Mat& gray) {
    for (auto& sp : detectors_)
      if (sp->carrier.running() && !sp->last_gray.empty()) sp->startCarry(gray, fi);
  };
  Frame f;
  try {
    {
      auto t = timer_.scope("orb", fi);
      f = frontend_->process(in, cv::Mat(), start_carry);
    }
    for (size_t d = 0; d < detectors_.size(); d++) {
      auto& s = *detectors_[d];
      if (s.async) {
        if (s.submitted_now) s.pending_gray = f.gray;
        if (s.last_gray.empty() && s.submitted_now && frames_ == 0) {  // first frame: wait once
          double ms = 0;
          Detections d0 = s.wait(ms);
          d0.frame_index = fi;
          s.take(std::move(d0), f.gray);
          timer_.add("detector", fi, ms);
        }
      }
      if (!s.async && s.ran) {
        double ms = 0;
        if (mode_ == config::Mode::Parallel) {
          auto t = timer_.scope("detector_wait", fi);
          dets[d] = s.wait(ms);
        } else {
          const double td = nowSeconds();
          dets[d] = s.det->detect(in);
          ms = (nowSeconds() - td) * 1e3;
        }
        timer_.add("detector", fi, ms);
        dets[d].frame_index = fi;
        dets[d].age_frames = 0;
      } else if (!s.last_gray.empty()) {
        // Async, or a frame between two runs of an every-N detector: the
        // latest detections carried from the image they describe to this one.
        const int age = fi - s.last.frame_index;
        if (s.carried.valid()) {
          std::pair<Detections, double> r;
          {
            auto t = timer_.scope("detection_carry_wait", fi);
            r = s.carried.get();  // rethrows the carry's error
          }
          dets[d] = std::move(r.first);
          timer_.add("detection_carry", fi, r.second);
        } else if (s.flow) {
          auto t = timer_.scope("detection_carry", fi);
          dets[d] = carryDetections(s.last, s.last_gray, f.gray, age);
        } else {
          dets[d] = s.last;
          dets[d].age_frames = age;
        }
        if (s.async && s.wait_coverage > 0 && s.pending.valid() && dets[d].valid &&
            boxCoverage(dets[d], f.gray.size()) > s.wait_coverage) {
          // Boxes over most of the image leave few keypoints, and a carried
          // box that lags behind a person lets the person in: this frame
          // waits for the running detection and takes it carried here.
          double ms = 0;
          {
            auto t = timer_.scope("detector_wait", fi);
            ms = s.takePending();
          }
          timer_.add("detector", s.last.frame_index, ms);
          coverage_waits_++;
          auto t = timer_.scope("detection_carry", fi);
          dets[d] = carryDetections(s.last, s.last_gray, f.gray, fi - s.last.frame_index);
        }
      } else {
        dets[d].valid = false;  // no detection yet
      }
      if (s.hold > 0 && dets[d].valid) {
        if ((!s.async && s.ran) || s.fresh) {
          // A new detection: boxes of the one before that it lacks are held.
          const bool sync_new = !s.async;
          s.last_seen = holdMissedBoxes(sync_new ? s.last : s.prev, sync_new ? s.last_gray : s.prev_gray,
                                        sync_new ? s.last_seen : s.prev_seen, dets[d], f.gray, fi,
                                        dets[d].frame_index, s.hold, s.flow);
        } else {
          dropExpiredBoxes(dets[d], s.last_seen, fi, s.hold);
        }
      }
      if (dets[d].valid) {
        s.last = dets[d];
        s.last_gray = f.gray;
      }
    }
  } catch (...) {
    // Detector threads still work on their copies of the frame: let them finish.
    for (auto& s : detectors_) s->waitAll();
    throw;
  }
  return f;
}

void System::classify(Frame& f, const std::vector<Detections>& dets) {
  const int fi = f.index();
  auto t = timer_.scope("classify", fi);
  ClassifierContext ctx;
  ctx.camera = &frontend_->camera();
  ctx.previous = prev_frame_ ? &*prev_frame_ : nullptr;
  ctx.previous_T_wc = prev_T_wc_;
  if (auto pred = tracker_->predictedPose()) ctx.predicted_T_wc = pred->inverse();
  ctx.base_feature_count = base_features_;
  int want = 0;
  for (auto& c : classifiers_) {
    const Detections& d = c.detector >= 0 ? dets[c.detector] : kNoDetections;
    ctx.previous_detections =
        (c.detector >= 0 && c.detector < static_cast<int>(prev_dets_.size())) ? &prev_dets_[c.detector] : nullptr;
    auto tc = timer_.scope("classifier_" + c.name, fi);
    c.c->classify(f, d, ctx);
    want = std::max(want, c.c->requestedFeatureCount());
  }
  frontend_->setFeatureCount(want > 0 ? want : base_features_);
}

FrameResult System::track(const SensorFrame& in) {
  const double t0 = nowSeconds();
  const int fi = in.index;
  FrameResult res;
  res.frame_index = fi;
  res.timestamp = in.timestamp;
  res.feature_count = frontend_->featureCount();

  std::vector<Detections> dets;
  Frame f = extract(in, dets);
  if (!classifiers_.empty()) classify(f, dets);
  res.keypoints = f.size();
  res.dynamic_keypoints = f.countLabel(KpLabel::Dynamic);

  const bool keep_prev = !classifiers_.empty();
  std::optional<Frame> copy;
  if (keep_prev || kf_observer_) copy = f;  // classifiers look at the previous frame (images and keypoints)

  {
    // Local mapping may take this frame's keyframe before redetectKeyFrame()
    // below has registered it: its gate waits while this frame is tracked.
    std::lock_guard<std::mutex> lk(late_mtx_);
    tracking_frame_ = fi;
  }
  struct EndTracking {
    System* s;
    ~EndTracking() {
      {
        std::lock_guard<std::mutex> lk(s->late_mtx_);
        s->tracking_frame_ = -1;
      }
      s->late_cv_.notify_all();
    }
  };
  {
    EndTracking end{this};
    {
      auto t = timer_.scope("track", fi);
      res.track = tracker_->track(std::move(f));
    }
    if (copy && (res.track.keyframe || res.track.initialized)) redetectKeyFrame(in, *copy, dets);
  }
  std::optional<SE3> T_wc;
  if (res.track.T_cw) T_wc = res.track.T_cw->inverse();
  for (auto& c : classifiers_) {
    c.c->afterTracking(copy ? *copy : Frame{}, c.detector >= 0 ? dets[c.detector] : kNoDetections, T_wc);
  }
  res.ms_total = (nowSeconds() - t0) * 1e3;
  timer_.add("frame", fi, res.ms_total);
  if (kf_observer_ && res.track.keyframe) kf_observer_(*copy, dets);

  if (res.track.state == TrackState::Ok && !res.track.keyframe) {
    checkPlaceRecognition();
    // The tracker has already dropped the frame's outliers from its matches.
    const TrackedFrame& lf = tracker_->lastFrame();
    if (lf.T_cw && maps_->wantsKeyFrame(tracker_->map(), lf.f, *lf.T_cw, lf.cam, lf.points)) tracker_->requestKeyFrame();
  }
  if (mode_ == config::Mode::Sequential) {
    mapper_->processAll();
    if (loop_) loop_->processAll();
  }
  if (res.track.state == TrackState::Lost && lost_frames_ == 0) maps_->onTrackingLost(maps_->currentMap());
  if (res.track.state == TrackState::Lost && !p_.tracker.localization_only) {
    lost_frames_++;
    if (lost_frames_ >= p_.place.new_map_after_lost && maps_->currentMap()->numKeyFrames() > 0) switchToNewMap(fi);
  } else {
    lost_frames_ = 0;
  }

  if (keep_prev) prev_frame_ = std::move(copy);
  prev_dets_ = std::move(dets);
  prev_T_wc_ = T_wc;
  frames_++;
  return res;
}

void System::redetectKeyFrame(const SensorFrame& in, const Frame& f, const std::vector<Detections>& dets) {
  const KeyFrame* kf = tracker_->referenceKeyFrame();
  if (!kf || kf->frame_index != f.index()) return;
  LateLabels late;
  for (size_t d = 0; d < detectors_.size(); d++) {
    auto& s = *detectors_[d];
    if (!s.async || !s.redetect_keyframes) continue;
    if (dets[d].valid && dets[d].age_frames == 0) continue;  // labelled from its own detection already
    bool relabels = false;
    for (const auto& c : classifiers_) relabels |= c.detector == static_cast<int>(d) && c.c->relabelsKeyFrames();
    if (!relabels) continue;
    std::shared_future<DetectorSlot::Result> r;
    if (s.submitted_now) {
      r = s.pending;  // this frame's own detection is running
    } else {
      r = s.push(in);  // queued behind the running job: never waits for this thread
      s.late.push_back({r, f.gray});
    }
    LateLabels::Job job;
    job.detector = static_cast<int>(d);
    job.result = std::move(r);
    if (s.hold > 0) {  // its own detection gets the boxes held in the carried one (as a synchronous frame would)
      job.carried = dets[d];
      job.seen = s.last_seen;
      job.hold = s.hold;
    }
    late.jobs.push_back(std::move(job));
  }
  if (late.jobs.empty()) return;
  // Labels are replaced (not only raised) when every classifier that labels
  // keypoints labels from one of these detections alone.
  late.replace = true;
  for (const auto& c : classifiers_) {
    if (!c.c->labelsKeypoints()) continue;
    bool redetected = false;
    for (const auto& j : late.jobs) redetected |= j.detector == c.detector;
    late.replace &= c.c->relabelsKeyFrames() && redetected;
  }
  late.frame = std::make_shared<Frame>(f);
  std::lock_guard<std::mutex> lk(late_mtx_);
  late_[kf->id] = std::move(late);
}

void System::relabelKeyFrame(KeyFrame& kf) {
  LateLabels late;
  {
    std::unique_lock<std::mutex> lk(late_mtx_);
    late_cv_.wait(lk, [&] { return tracking_frame_ != kf.frame_index; });
    auto it = late_.find(kf.id);
    if (it == late_.end()) return;
    late = std::move(it->second);
    late_.erase(it);
  }
  const double t0 = nowSeconds();
  Frame& f = *late.frame;
  ClassifierContext ctx;
  ctx.camera = &frontend_->camera();
  ctx.base_feature_count = base_features_;
  std::vector<Detections> own(late.jobs.size());
  bool all = true;
  for (size_t k = 0; k < late.jobs.size(); k++) {
    auto& j = late.jobs[k];
    try {
      own[k] = j.result.get().first;  // waits; the job was queued when the keyframe was made
      own[k].age_frames = 0;
      if (j.hold > 0)
        holdMissedBoxes(j.carried, cv::Mat(), j.seen, own[k], cv::Mat(), kf.frame_index, kf.frame_index, j.hold, false);
    } catch (const std::exception& e) {
      DSLAM_LOG(Debug, "keyframe " << kf.id << ": its own detection failed (" << e.what() << "): carried labels kept");
      own[k].valid = false;
      all = false;
    }
  }
  // Replacing: the labels these classifiers give from the keyframe's own
  // detections alone, as in the synchronous mode; else they are only raised.
  const bool replace = late.replace && all;
  if (replace)
    for (auto& m : f.meta) m = KeypointMeta{};
  for (size_t k = 0; k < late.jobs.size(); k++) {
    if (!own[k].valid) continue;
    for (auto& c : classifiers_)
      if (c.detector == late.jobs[k].detector && c.c->relabelsKeyFrames()) c.c->classify(f, own[k], ctx);
  }
  timer_.add("keyframe_detection_wait", kf.frame_index, (nowSeconds() - t0) * 1e3);
  std::lock_guard<std::recursive_mutex> lk(kf.map->update_mutex);
  if (kf.bad || kf.meta.size() != kf.size() || f.meta.size() != kf.size()) return;
  int kps = 0, pts = 0, lowered = 0;
  for (size_t i = 0; i < kf.size(); i++) {
    if (f.meta[i].label != KpLabel::Dynamic && kf.meta[i].label == KpLabel::Dynamic && replace) {
      kf.meta[i] = f.meta[i];  // only the carried box made it dynamic: usable from now on (no point yet)
      lowered++;
      continue;
    }
    if (f.meta[i].label != KpLabel::Dynamic || kf.meta[i].label == KpLabel::Dynamic) continue;
    kf.meta[i] = f.meta[i];
    kps++;
    if (const MapPointPtr mp = kf.points[i]) {
      if (mp->first_kf_id == kf.id)
        mp->setBad();  // made from this keyframe's depth
      else
        kf.points[i].reset();  // a match: its observation is not added
      pts++;
    }
  }
  relabelled_kfs_++;
  relabelled_kps_ += kps;
  relabelled_pts_ += pts;
  relabelled_lowered_ += lowered;
}

void System::shutdown() {
  if (shut_) return;
  shut_ = true;
  if (mode_ == config::Mode::Parallel) mapper_->stop();  // waits for the keyframes' own detections too
  mapper_->processAll();
  if (relabelled_kfs_ > 0)
    DSLAM_LOG(Info, relabelled_kfs_ << " keyframes with carried detections labelled again from their own detection: "
                                    << relabelled_kps_ << " keypoints became dynamic, " << relabelled_pts_
                                    << " of their map points or matches dropped, " << relabelled_lowered_
                                    << " dynamic only in the carried detection became usable");
  if (coverage_waits_ > 0)
    DSLAM_LOG(Info, coverage_waits_ << " frames waited for the running detection (carried boxes over wait_coverage)");
  if (loop_) {
    loop_->waitIdle();
    loop_->stop();
    loop_->processAll();
    loop_->finish(*map(), tracker_->records().empty() ? 0 : tracker_->records().back().frame_index);
  }
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
  AtomicOfstream out(path);
  std::ofstream& f = out.stream();
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
  out.commit();
}

void System::writeObjects(const std::string& json_path, const std::string& ply_path, size_t min_points,
                          int min_sightings, size_t confirm_points) const {
  const auto cur = map();
  nlohmann::ordered_json objs = nlohmann::ordered_json::array();
  std::vector<MapObjectPtr> boxes;
  for (const auto& m : maps_->maps()) {
    std::lock_guard<std::recursive_mutex> lk(m->update_mutex);
    for (const auto& [id, o] : m->objects()) {
      if (o->refresh() < min_points) continue;                      // its points were culled
      if (!o->confirmed(min_sightings, confirm_points)) continue;  // tentative
      auto v3 = [](const Eigen::Vector3d& v) { return nlohmann::ordered_json::array({v.x(), v.y(), v.z()}); };
      objs.push_back({{"id", o->id},
                      {"map", m->id},
                      {"class_id", o->class_id},
                      {"class", coco::name(o->class_id)},
                      {"centroid", v3(o->centroid)},
                      {"box_min", v3(o->box_min)},
                      {"box_max", v3(o->box_max)},
                      {"points", o->numPoints()},
                      {"belief", o->belief},
                      {"active", o->active || o->dormant},  // in the map (dormant: not used to localise until seen again)
                      {"dormant", o->dormant},
                      {"first_seen_kf", o->first_seen_kf},
                      {"last_seen_kf", o->last_seen_kf},
                      {"first_seen_t", o->first_seen_t},
                      {"last_seen_t", o->last_seen_t},
                      {"sightings", o->sightings}});
      if (m == cur) boxes.push_back(o);
    }
  }
  if (!json_path.empty()) {
    nlohmann::ordered_json j = {{"format", "dslam-objects"}, {"version", 1}, {"map", cur->id}, {"objects", objs}};
    AtomicOfstream out(json_path);
    out.stream() << layoutJson(j, 2) << "\n";
    out.commit();
  }
  if (ply_path.empty()) return;
  AtomicOfstream out(ply_path);
  std::ofstream& f = out.stream();
  f << "ply\nformat ascii 1.0\ncomment dslam object boxes of map " << cur->id << " (green active, red inactive)\n"
    << "element vertex " << boxes.size() * 8 << "\nproperty float x\nproperty float y\nproperty float z\n"
    << "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    << "element face " << boxes.size() * 6 << "\nproperty list uchar int vertex_indices\nend_header\n";
  char buf[160];
  for (const auto& o : boxes) {
    const int r = o->active ? 40 : 220, g = o->active ? 200 : 40;
    for (int k = 0; k < 8; k++) {
      const Eigen::Vector3d c = o->corner(k);
      std::snprintf(buf, sizeof(buf), "%.5f %.5f %.5f %d %d 40\n", c.x(), c.y(), c.z(), r, g);
      f << buf;
    }
  }
  static const int kFaces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (size_t b = 0; b < boxes.size(); b++)
    for (const auto& q : kFaces)
      f << "4 " << b * 8 + q[0] << " " << b * 8 + q[1] << " " << b * 8 + q[2] << " " << b * 8 + q[3] << "\n";
  out.commit();
}

}  // namespace dslam
