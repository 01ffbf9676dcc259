// detect_and_track FOLDER [--detector TYPE] [--frames N]
//
// Runs an object detector and dslam::EkfObjectTracker (Changing-SLAM's
// per-object EKF) on an RGB-D image folder (TUM layout: rgb.txt, depth.txt,
// e.g. one written by `dslam synth`) and prints which objects move. No SLAM:
// the camera pose comes from the folder's ground truth if it has one,
// otherwise the camera is taken as still.
//
// The detector defaults to dslam::GroundTruthDetector when the folder has the
// labels `dslam synth` writes (boxes/), else dslam::HogPeopleDetector (no
// model file needed); any registered Detector works (--detector).
#include <dslam/config/pipeline.h>
#include <dslam/core/coco.h>
#include <dslam/core/dataset.h>
#include <dslam/core/detector.h>
#include <dslam/core/error.h>
#include <dslam/core/registry.h>
#include <dslam/features/frontend.h>
#include <dslam/plugins/classifiers/ekf_object_tracker.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <string>
#include <vector>

namespace fs = std::filesystem;

int main(int argc, char** argv) {
  std::string folder, detector_type;
  int max_frames = -1;
  for (int i = 1; i < argc; i++) {
    const std::string a = argv[i];
    if (a == "--detector" && i + 1 < argc) detector_type = argv[++i];
    else if (a == "--frames" && i + 1 < argc) max_frames = std::stoi(argv[++i]);
    else if (folder.empty() && a[0] != '-') folder = a;
    else {
      std::cerr << "usage: detect_and_track FOLDER [--detector TYPE] [--frames N]\n";
      return 2;
    }
  }
  if (folder.empty()) {
    std::cerr << "usage: detect_and_track FOLDER [--detector TYPE] [--frames N]\n";
    return 2;
  }
  try {
    dslam::register_builtin_plugins();

    // The folder's reader (type detected from its layout) and its camera.
    const std::string type = dslam::config::detectDatasetType(folder);
    if (type.empty()) throw dslam::DataError("not a dataset folder: " + folder);
    auto reader = dslam::create<dslam::DatasetSource>(type);
    dslam::Params rp = dslam::Params::resolve(reader->paramSpecs(), "path: .");
    rp.setString("path", fs::absolute(folder).string());
    dslam::PluginContext ctx;
    reader->configure(rp, ctx);
    const auto camera = reader->camera();
    if (!camera) throw dslam::DataError(folder + " carries no camera calibration");
    ctx.camera = &*camera;
    ctx.dataset_root = reader->root();

    if (detector_type.empty())
      detector_type = fs::is_directory(fs::path(folder) / "boxes") ? "dslam::GroundTruthDetector" : "dslam::HogPeopleDetector";
    auto detector = dslam::create<dslam::Detector>(detector_type);
    detector->configure(dslam::Params::resolve(detector->paramSpecs(), ""), ctx);

    // The classifier used directly (not through the registry) to read its tracks.
    dslam::EkfObjectTracker ekf;
    ekf.configure(dslam::Params::resolve(ekf.paramSpecs(), ""), ctx);
    dslam::FeatureFrontend frontend(*camera);

    const size_t n = max_frames > 0 ? std::min<size_t>(reader->size(), max_frames) : reader->size();
    std::cout << folder << ": " << n << " frames, " << detector_type << " + dslam::EkfObjectTracker"
              << (reader->groundTruth().empty() ? " (camera taken as still)" : " (camera pose: ground truth)") << "\n";
    struct Seen {
      int class_id = -1, frames = 0, moving = 0;
      std::vector<double> speeds;
    };
    std::map<int, Seen> objects;  // by track id
    std::optional<dslam::SE3> prev;
    for (size_t i = 0; i < n; i++) {
      const dslam::SensorFrame sf = reader->read(i);
      const dslam::SE3 T_wc = sf.gt_T_wc.value_or(dslam::SE3());
      const dslam::Detections det = detector->detect(sf);
      dslam::Frame f = frontend.process(sf);
      f.resetMeta();
      dslam::ClassifierContext cc;
      cc.camera = camera ? &*camera : nullptr;
      cc.predicted_T_wc = T_wc;
      cc.previous_T_wc = prev;
      ekf.classify(f, det, cc);
      ekf.afterTracking(f, det, T_wc);
      prev = T_wc;
      std::string line;
      for (const auto& t : ekf.tracks()) {
        if (t.missed > 0) continue;  // not seen in this frame
        // Dynamic because its estimated speed is above the class threshold
        // (a new object is dynamic too until proven static: not counted).
        const bool moving = t.dynamic && t.reason == dslam::KpReason::ObjectMoving;
        Seen& o = objects[t.id];
        o.class_id = t.class_id;
        o.frames++;
        o.moving += moving;
        if (t.updates > 1) o.speeds.push_back(t.speed());
        char b[96];
        std::snprintf(b, sizeof(b), " #%d(class %d) %.2f m/s%s", t.id, t.class_id, t.speed(),
                      moving ? " MOVING" : t.dynamic ? " new" : "");
        line += b;
      }
      std::printf("frame %4zu: %zu boxes, %zu of %zu keypoints dynamic;%s\n", i, det.boxes.size(),
                  f.countLabel(dslam::KpLabel::Dynamic), f.size(), line.empty() ? " no objects" : line.c_str());
    }
    // Summary: an object "moves" when the tracker called it moving in more
    // than half of the frames it was seen (at least 5 frames).
    std::cout << "objects (id, class, frames seen, frames moving, median speed):\n";
    std::string moved;
    for (auto& [id, o] : objects) {
      if (o.frames < 5) continue;
      std::sort(o.speeds.begin(), o.speeds.end());
      const double med = o.speeds.empty() ? 0.0 : o.speeds[o.speeds.size() / 2];
      std::printf("  #%-3d %-14s %3d %3d  %.2f m/s\n", id, dslam::coco::name(o.class_id).c_str(), o.frames, o.moving, med);
      if (2 * o.moving > o.frames) moved += " #" + std::to_string(id) + " (" + dslam::coco::name(o.class_id) + ")";
    }
    std::cout << "objects that move:" << (moved.empty() ? std::string(" none") : moved) << "\n";
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
