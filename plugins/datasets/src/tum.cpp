#include "dslam/plugins/datasets/tum.h"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "dslam/core/camera_presets.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/core/paths.h"
#include "dslam/core/yaml_util.h"
#include "dslam/trajectory/io.h"

IMPLEMENTS_MRPT_OBJECT(TumDataset, DatasetSource, dslam)
IMPLEMENTS_MRPT_OBJECT(BonnDataset, TumDataset, dslam)

namespace fs = std::filesystem;

namespace dslam {

static const char* kTumLayout =
    "expected a TUM RGB-D folder: rgb.txt and depth.txt (\"timestamp path\" lines) or associations.txt, "
    "rgb/ and depth/ images, optional groundtruth.txt";

std::vector<TumEntry> readTumList(const std::string& file) {
  std::ifstream f(file);
  if (!f) throw DataError("cannot open " + file + " (" + kTumLayout + ")");
  std::vector<TumEntry> out;
  std::string s;
  int n = 0;
  while (std::getline(f, s)) {
    n++;
    if (!s.empty() && s.back() == '\r') s.pop_back();
    const size_t p = s.find_first_not_of(" \t");
    if (p == std::string::npos || s[p] == '#') continue;
    std::istringstream in(s);
    std::string ts, path;
    in >> ts >> path;
    auto t = yamlu::parseDouble(ts);
    if (!t || path.empty())
      throw DataError(file + ":" + std::to_string(n) + ": expected \"timestamp path\", got '" + s + "'");
    if (!out.empty() && *t <= out.back().stamp)
      throw DataError(file + ":" + std::to_string(n) + ": timestamps must increase (" + ts + " after " +
                      std::to_string(out.back().stamp) + ")");
    out.push_back({*t, path});
  }
  return out;
}

std::vector<std::pair<size_t, size_t>> associateStamps(const std::vector<double>& a, const std::vector<double>& b,
                                                       double max_dt) {
  // Candidate pairs within max_dt (both lists sorted: two-pointer window).
  struct Cand {
    double d;
    size_t i, j;
  };
  std::vector<Cand> cands;
  size_t lo = 0;
  for (size_t i = 0; i < a.size(); i++) {
    while (lo < b.size() && b[lo] < a[i] - max_dt) lo++;
    for (size_t j = lo; j < b.size() && b[j] < a[i] + max_dt; j++) {
      const double d = std::abs(a[i] - b[j]);
      if (d < max_dt) cands.push_back({d, i, j});
    }
  }
  // associate.py sorts (diff, a, b) tuples and takes greedily.
  std::sort(cands.begin(), cands.end(), [&](const Cand& x, const Cand& y) {
    if (x.d != y.d) return x.d < y.d;
    if (a[x.i] != a[y.i]) return a[x.i] < a[y.i];
    return b[x.j] < b[y.j];
  });
  std::vector<char> ua(a.size(), 0), ub(b.size(), 0);
  std::vector<std::pair<size_t, size_t>> out;
  for (const auto& c : cands) {
    if (ua[c.i] || ub[c.j]) continue;
    ua[c.i] = ub[c.j] = 1;
    out.emplace_back(c.i, c.j);
  }
  std::sort(out.begin(), out.end());
  return out;
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
      P_double("max_dt", 0.02, "max |t_rgb - t_depth| when associating, seconds", 0),
      P_enum("preset", "auto", presets, "camera preset; auto: from 'freiburgN' in the folder name"),
      P_double("depth_factor", 5000, "raw depth units per metre", 0),
      P_bool("load_depth", true, "load depth images"),
      P_string("groundtruth", "groundtruth.txt", "ground-truth file relative to the folder ('' = none)"),
  };
}

void TumDataset::configure(const Params& p, const PluginContext& ctx) {
  Plugin::configure(p, ctx);
  root_ = p.getString("path");
  requireDir(root_, "TUM dataset folder", kTumLayout);
  depth_factor_ = p.getDouble("depth_factor");
  frames_.clear();
  std::string assoc = p.getString("associations");
  if (assoc.empty() && fileExists(root_ + "/associations.txt")) assoc = "associations.txt";
  if (!assoc.empty()) {
    const std::string af = resolvePath(assoc, root_);
    std::ifstream f(af);
    if (!f) throw DataError("association file not found: " + af + " (" + kTumLayout + ")");
    std::string s;
    int n = 0;
    while (std::getline(f, s)) {
      n++;
      if (!s.empty() && s.back() == '\r') s.pop_back();
      const size_t q = s.find_first_not_of(" \t");
      if (q == std::string::npos || s[q] == '#') continue;
      std::istringstream in(s);
      std::string a, b, c, d;
      in >> a >> b >> c >> d;
      auto ta = yamlu::parseDouble(a), tc = yamlu::parseDouble(c);
      if (!ta || !tc || b.empty() || d.empty())
        throw DataError(af + ":" + std::to_string(n) + ": expected \"t_rgb rgb t_depth depth\", got '" + s + "'");
      if (!frames_.empty() && *ta <= frames_.back().t_rgb)
        throw DataError(af + ":" + std::to_string(n) + ": timestamps must increase");
      frames_.push_back({*ta, *tc, b, d});
    }
  } else {
    const auto rgb = readTumList(root_ + "/rgb.txt");
    if (p.getBool("load_depth") && fileExists(root_ + "/depth.txt")) {
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

  std::string preset = p.getString("preset");
  if (preset == "auto") {
    const std::string name = fs::weakly_canonical(root_).filename().string();
    preset = defaultPreset();
    if (name.find("freiburg1") != std::string::npos) preset = "tum_fr1";
    if (name.find("freiburg2") != std::string::npos) preset = "tum_fr2";
    if (name.find("freiburg3") != std::string::npos) preset = "tum_fr3";
    if (name.find("bonn") != std::string::npos) preset = "bonn";
  }
  camera_ = cameraPreset(preset);
  if (camera_) camera_->depth_factor = depth_factor_;

  gt_.clear();
  const std::string g = p.getString("groundtruth");
  if (!g.empty() && fileExists(resolvePath(g, root_))) gt_ = traj::readTum(resolvePath(g, root_));
}

double TumDataset::timestamp(size_t i) const { return frames_.at(i).t_rgb; }

SensorFrame TumDataset::read(size_t i) {
  if (i >= frames_.size())
    throw DataError("frame index " + std::to_string(i) + " out of range (" + std::to_string(frames_.size()) + " frames)");
  const Item& it = frames_[i];
  SensorFrame f;
  f.index = static_cast<int>(i);
  f.timestamp = it.t_rgb;
  f.image_path = resolvePath(it.rgb, root_);
  f.image = cv::imread(f.image_path, cv::IMREAD_UNCHANGED);
  if (f.image.empty())
    throw DataError("frame " + std::to_string(i) + ": cannot read image " + f.image_path +
                    (fileExists(f.image_path) ? " (corrupt or unsupported)" : " (missing)"));
  if (!it.depth.empty()) {
    f.depth_path = resolvePath(it.depth, root_);
    cv::Mat raw = cv::imread(f.depth_path, cv::IMREAD_ANYDEPTH);
    if (raw.empty())
      throw DataError("frame " + std::to_string(i) + ": cannot read depth " + f.depth_path +
                      (fileExists(f.depth_path) ? " (corrupt or unsupported)" : " (missing)"));
    if (raw.type() != CV_16UC1)
      throw DataError("frame " + std::to_string(i) + ": depth image " + f.depth_path + " is not 16-bit single channel");
    if (raw.size() != f.image.size())
      throw DataError("frame " + std::to_string(i) + ": depth " + f.depth_path + " size differs from the RGB image");
    raw.convertTo(f.depth, CV_32F, 1.0 / depth_factor_);
  }
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
