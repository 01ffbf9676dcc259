#include "dslam/plugins/datasets/tum.h"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "common.h"
#include "dslam/config/camera_yaml.h"
#include "dslam/core/camera_presets.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/core/paths.h"
#include "dslam/core/yaml_util.h"
#include "dslam/trajectory/associate.h"
#include "dslam/trajectory/io.h"

IMPLEMENTS_MRPT_OBJECT(TumDataset, DatasetSource, dslam)
IMPLEMENTS_MRPT_OBJECT(BonnDataset, TumDataset, dslam)

namespace fs = std::filesystem;

namespace dslam {

static const char* kTumLayout =
    "expected a TUM RGB-D folder: rgb.txt and depth.txt (\"timestamp path\" lines) or associations.txt "
    "(\"t_rgb rgb t_depth depth\"), rgb/ and depth/ images, optional groundtruth.txt";

namespace {

/** A finite timestamp in field 0, or a DataError naming file:line. */
double stampField(const std::string& file, const TextLine& l, const std::string& field, const char* expected) {
  const auto t = yamlu::parseDouble(field);
  if (!t || !std::isfinite(*t))
    throw DataError(file + ":" + std::to_string(l.lineno) + ": expected " + expected + ", got '" + l.text + "'");
  return *t;
}

}  // namespace

std::vector<TumEntry> readTumList(const std::string& file) {
  // associate.py: commas and tabs are separators, a line with fewer than two
  // fields is skipped, the list is a dict keyed by time (last line wins), sorted.
  std::vector<TumEntry> out;
  size_t skipped = 0;
  for (const auto& l : readDataLines(file, kTumLayout)) {
    const auto f = splitFields(l.text, true);
    if (f.size() < 2) {  // a bare timestamp: nothing to read
      if (!f.empty()) stampField(file, l, f[0], "\"timestamp path\"");
      skipped++;
      continue;
    }
    out.push_back({stampField(file, l, f[0], "\"timestamp path\""), f[1]});
  }
  ds::OrderFix fix = ds::sortKeepLast(out, [](const TumEntry& e) { return e.stamp; });
  fix.skipped = skipped;
  ds::reportOrderFix(file, fix);
  return out;
}

std::vector<TumAssociation> readTumAssociations(const std::string& file) {
  std::vector<TumAssociation> out;
  for (const auto& l : readDataLines(file, kTumLayout)) {
    const auto f = splitFields(l.text, true);
    const char* expected = "\"t_rgb rgb t_depth depth\"";
    if (f.size() < 4) throw DataError(file + ":" + std::to_string(l.lineno) + ": expected " + expected + ", got '" + l.text + "'");
    out.push_back({stampField(file, l, f[0], expected), stampField(file, l, f[2], expected), f[1], f[3]});
  }
  ds::reportOrderFix(file, ds::sortKeepLast(out, [](const TumAssociation& a) { return a.t_rgb; }));
  return out;
}

std::vector<std::pair<size_t, size_t>> associateStamps(const std::vector<double>& a, const std::vector<double>& b,
                                                       double max_dt) {
  return traj::associate(a, b, max_dt);
}

std::string TumDataset::description() const {
  return "TUM RGB-D folder (rgb.txt, depth.txt or associations.txt, groundtruth.txt; depth factor 5000)";
}

std::vector<ParamSpec> TumDataset::paramSpecs() const {
  std::vector<std::string> presets = {"auto"};
  for (auto& n : cameraPresetNames()) presets.push_back(n);
  return {
      P_required("path", ParamType::Path, "dataset folder"),
      P_string("associations", "",
               "association file (t_rgb rgb t_depth depth) relative to the folder; '' = associations.txt if "
               "present, else associate rgb.txt and depth.txt"),
      P_double("max_dt", 0.02, "max |t_rgb - t_depth| when associating, seconds (TUM associate.py)", 1e-9),
      P_enum("preset", "auto", presets,
             "camera preset; auto: <folder>/camera.yaml if present, else from 'freiburgN'/'bonn' in the folder name"),
      P_string("camera_file", "", "camera YAML file relative to the folder (overrides preset); '' = none"),
      P_double("depth_factor", 5000, "raw depth units per metre (default: the camera file's, else 5000)", 1e-9),
      P_bool("load_depth", true, "load depth images (false: monocular frames)"),
      P_string("groundtruth", "groundtruth.txt", "ground-truth file (TUM format, T_wc) relative to the folder ('' = none)"),
  };
}

void TumDataset::configure(const Params& p, const PluginContext& ctx) {
  Plugin::configure(p, ctx);
  root_ = p.getString("path");
  requireDir(root_, "TUM dataset folder", kTumLayout);
  frames_.clear();
  const bool load_depth = p.getBool("load_depth");
  std::string assoc = p.getString("associations");
  if (assoc.empty() && fileExists(root_ + "/associations.txt")) assoc = "associations.txt";
  if (!assoc.empty()) {
    const std::string af = resolvePath(assoc, root_);
    requireFile(af, "TUM association file", kTumLayout);
    for (auto& a : readTumAssociations(af)) frames_.push_back({a.t_rgb, a.t_depth, a.rgb, a.depth});
    if (!load_depth)
      for (auto& f : frames_) {
        f.t_depth = -1;
        f.depth.clear();
      }
  } else {
    requireFile(root_ + "/rgb.txt", "TUM rgb.txt", kTumLayout);
    const auto rgb = readTumList(root_ + "/rgb.txt");
    if (load_depth && fileExists(root_ + "/depth.txt")) {
      const auto depth = readTumList(root_ + "/depth.txt");
      std::vector<double> ta, tb;
      for (auto& e : rgb) ta.push_back(e.stamp);
      for (auto& e : depth) tb.push_back(e.stamp);
      for (auto [i, j] : associateStamps(ta, tb, p.getDouble("max_dt")))
        frames_.push_back({rgb[i].stamp, depth[j].stamp, rgb[i].path, depth[j].path});
      if (frames_.size() < rgb.size())
        DSLAM_LOG(Info, root_ << ": " << frames_.size() << " of " << rgb.size()
                              << " RGB frames have a depth image within " << p.getDouble("max_dt") << " s");
    } else {
      for (auto& e : rgb) frames_.push_back({e.stamp, -1, e.path, ""});
    }
  }
  if (frames_.empty()) throw DataError(root_ + ": no frames (" + kTumLayout + ")");
  has_depth_ = !frames_.front().depth.empty();

  // Camera.
  std::string preset = p.getString("preset");
  const std::string cam_file = p.getString("camera_file");
  bool from_file = false;
  if (!cam_file.empty()) {
    const std::string cf = resolvePath(cam_file, root_);
    requireFile(cf, "camera file", "parameter camera_file of the TUM reader");
    camera_ = config::loadCameraFile(cf);
    camera_source_ = cf;
    from_file = true;
  } else if (preset == "auto" && fileExists(root_ + "/camera.yaml")) {
    camera_ = config::loadCameraFile(root_ + "/camera.yaml");
    camera_source_ = root_ + "/camera.yaml";
    from_file = true;
  } else {
    if (preset == "auto") {
      const std::string name = fs::weakly_canonical(root_).filename().string();
      preset = defaultPreset();
      if (name.find("freiburg1") != std::string::npos) preset = "tum_fr1";
      if (name.find("freiburg2") != std::string::npos) preset = "tum_fr2";
      if (name.find("freiburg3") != std::string::npos) preset = "tum_fr3";
      if (name.find("bonn") != std::string::npos) preset = "bonn";
    }
    camera_ = cameraPreset(preset);
    camera_source_ = "preset " + preset;
  }
  depth_factor_ = p.getDouble("depth_factor");
  if (from_file && !p.isGiven("depth_factor") && camera_ && camera_->depth_factor > 0)
    depth_factor_ = camera_->depth_factor;
  if (camera_) {
    camera_->depth_factor = depth_factor_;
    if (!has_depth_) camera_->sensor = SensorType::Monocular;
  }

  gt_.clear();
  const std::string g = p.getString("groundtruth");
  if (!g.empty() && fileExists(resolvePath(g, root_))) gt_ = traj::readTum(resolvePath(g, root_));
}

double TumDataset::timestamp(size_t i) const { return frames_.at(i).t_rgb; }

std::string TumDataset::rgbPath(size_t i) const { return resolvePath(frames_.at(i).rgb, root_); }

std::string TumDataset::depthPath(size_t i) const {
  const auto& d = frames_.at(i).depth;
  return d.empty() ? std::string() : resolvePath(d, root_);
}

double TumDataset::depthTimestamp(size_t i) const { return frames_.at(i).t_depth; }

SensorFrame TumDataset::read(size_t i) {
  ds::requireFrameIndex(i, frames_.size());
  const Item& it = frames_[i];
  SensorFrame f;
  f.index = static_cast<int>(i);
  f.timestamp = it.t_rgb;
  f.image_path = resolvePath(it.rgb, root_);
  f.image = ds::readCameraImage(f.image_path, i, "image");
  if (!it.depth.empty()) {
    f.depth_path = resolvePath(it.depth, root_);
    cv::Mat raw = ds::readDepthImage(f.depth_path, i);
    if (raw.size() != f.image.size())
      throw DataError("frame " + std::to_string(i) + ": depth " + f.depth_path + " size " +
                      std::to_string(raw.cols) + "x" + std::to_string(raw.rows) + " differs from the RGB image's " +
                      std::to_string(f.image.cols) + "x" + std::to_string(f.image.rows));
    raw.convertTo(f.depth, CV_32F, 1.0 / depth_factor_);
  }
  f.gt_T_wc = ds::nearestPose(gt_, it.t_rgb);
  return f;
}

std::string BonnDataset::description() const {
  return "Bonn RGB-D Dynamic folder (TUM layout, Bonn intrinsics preset)";
}

std::vector<ParamSpec> BonnDataset::paramSpecs() const {
  auto s = TumDataset::paramSpecs();
  for (auto& p : s)
    if (p.name == "preset") p.default_value = "bonn";
  return s;
}

}  // namespace dslam
