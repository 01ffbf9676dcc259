#include "dslam/plugins/datasets/euroc.h"

#include <mrpt/containers/yaml.h>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "common.h"
#include "dslam/core/error.h"
#include "dslam/core/format.h"
#include "dslam/core/log.h"
#include "dslam/core/paths.h"
#include "dslam/core/yaml_util.h"
#include "dslam/trajectory/associate.h"
#include "dslam/trajectory/io.h"

IMPLEMENTS_MRPT_OBJECT(EurocDataset, DatasetSource, dslam)

namespace dslam {

static const char* kEurocLayout =
    "expected a EuRoC MAV (ASL) folder: mav0/cam0/ and mav0/cam1/ each with data.csv "
    "(\"timestamp_ns,filename\"), data/*.png and sensor.yaml (intrinsics, distortion_coefficients, resolution, "
    "T_BS); optional mav0/state_groundtruth_estimate0/data.csv or groundtruth.txt (TUM format)";

namespace {

using node_t = yamlu::node_t;

std::vector<double> numbers(const node_t* n, const std::string& file, const std::string& key) {
  if (!n) throw DataError(file + ": missing key '" + key + "' (" + kEurocLayout + ")");
  if (!n->isSequence()) throw DataError(file + ": key '" + key + "' must be a list of numbers, got " + yamlu::describe(*n));
  std::vector<double> v;
  for (const auto& e : n->asSequence()) {
    auto t = yamlu::scalarText(e);
    auto d = t ? yamlu::parseDouble(*t) : std::nullopt;
    if (!d || !std::isfinite(*d))
      throw DataError(file + ": key '" + key + "': " + yamlu::describe(e) + " is not a number");
    v.push_back(*d);
  }
  return v;
}

}  // namespace

EurocCameraInfo readEurocSensorYaml(const std::string& file) {
  requireFile(file, "EuRoC sensor.yaml", kEurocLayout);
  std::ifstream f(file);
  std::stringstream text;
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind("%YAML", 0) == 0) continue;  // OpenCV-style "%YAML:1.0" directive
    text << line << "\n";
  }
  mrpt::containers::yaml y;
  const std::string txt = text.str();
  if (const size_t bad = yamlu::invalidUtf8(txt); bad != std::string::npos)  // libfyaml can hang on it
    throw DataError(file + ": not valid UTF-8 text (byte " + std::to_string(bad) + " after dropping the %YAML line)");
  try {
    y = mrpt::containers::yaml::FromText(txt);
  } catch (const std::exception& e) {
    throw DataError(file + ": cannot parse YAML: " + e.what());
  }
  const node_t& root = y.node();
  if (!root.isMap()) throw DataError(file + ": expected a YAML map (" + kEurocLayout + ")");
  auto str = [&](const char* key) -> std::string {
    const node_t* n = yamlu::findValue(root, key);
    return n ? yamlu::scalarText(*n).value_or("") : "";
  };
  EurocCameraInfo info;
  if (const auto m = str("camera_model"); !m.empty() && m != "pinhole")
    throw DataError(file + ": camera_model '" + m + "' is not supported (pinhole only)");
  if (const auto d = str("distortion_model");
      !d.empty() && d != "radial-tangential" && d != "radtan" && d != "plumb_bob")
    throw DataError(file + ": distortion_model '" + d +
                    "' is not supported (radial-tangential only: k1 k2 p1 p2 [k3])");
  const auto in = numbers(yamlu::findValue(root, "intrinsics"), file, "intrinsics");
  if (in.size() != 4) throw DataError(file + ": 'intrinsics' must have 4 values [fu, fv, cu, cv]");
  info.cam.fx = in[0];
  info.cam.fy = in[1];
  info.cam.cx = in[2];
  info.cam.cy = in[3];
  if (!(info.cam.fx > 0) || !(info.cam.fy > 0)) throw DataError(file + ": 'intrinsics' focal lengths must be > 0");
  const node_t* dn = yamlu::findValue(root, "distortion_coefficients");
  if (dn) {
    const auto d = numbers(dn, file, "distortion_coefficients");
    if (d.size() < 4 || d.size() > 5)
      throw DataError(file + ": 'distortion_coefficients' must have 4 or 5 values (k1 k2 p1 p2 [k3])");
    for (size_t i = 0; i < d.size(); i++) info.cam.dist[i] = d[i];
  }
  const auto res = numbers(yamlu::findValue(root, "resolution"), file, "resolution");
  // Whole pixel counts in 1..65535 (a larger value would not even fit an int).
  if (res.size() != 2 || !(res[0] >= 1 && res[0] <= 65535 && res[0] == std::floor(res[0])) ||
      !(res[1] >= 1 && res[1] <= 65535 && res[1] == std::floor(res[1])))
    throw DataError(file + ": 'resolution' must be [width, height], whole numbers of pixels in 1..65535");
  info.cam.width = static_cast<int>(res[0]);
  info.cam.height = static_cast<int>(res[1]);
  if (!info.cam.principalPointInside())
    throw DataError(file + ": 'intrinsics' principal point (" + formatNumber("%g", info.cam.cx) + ", " +
                    formatNumber("%g", info.cam.cy) + ") lies outside the " + std::to_string(info.cam.width) + "x" +
                    std::to_string(info.cam.height) + " image of 'resolution'");
  const node_t* tn = yamlu::findValue(root, "T_BS");
  if (!tn) throw DataError(file + ": missing key 'T_BS' (" + kEurocLayout + ")");
  const auto T = numbers(tn->isMap() ? yamlu::findValue(*tn, "data") : tn, file, "T_BS.data");
  if (T.size() != 16) throw DataError(file + ": 'T_BS' data must have 16 values (4x4 row-major)");
  Eigen::Matrix4d M;
  for (int r = 0; r < 4; r++)
    for (int c = 0; c < 4; c++) M(r, c) = T[r * 4 + c];
  const Eigen::Matrix3d R = M.block<3, 3>(0, 0);
  if (!isOrthonormal(R, 1e-3) || std::abs(R.determinant() - 1) > 1e-3)
    throw DataError(file + ": 'T_BS' rotation part is not a rotation matrix");
  info.T_BS = SE3(M);
  if (const auto r = str("rate_hz"); !r.empty()) info.rate_hz = yamlu::parseDouble(r).value_or(0);
  return info;
}

std::vector<EurocImageEntry> readEurocImageList(const std::string& cam_dir) {
  std::vector<EurocImageEntry> out;
  const std::string csv = cam_dir + "/data.csv";
  if (fileExists(csv)) {
    for (const auto& l : readDataLines(csv, kEurocLayout)) {
      const auto f = splitFields(l.text, true);
      const auto t = f.size() >= 2 ? yamlu::parseInt(f[0]) : std::nullopt;
      if (!t)
        throw DataError(csv + ":" + std::to_string(l.lineno) + ": expected \"timestamp_ns,filename\", got '" + l.text +
                        "'");
      out.push_back({*t, f[1]});
    }
    // Repeated or unordered times: sorted, the last line of a time kept (one warning), as for TUM lists.
    ds::reportOrderFix(csv, ds::sortKeepLast(out, [](const EurocImageEntry& e) { return e.stamp_ns; }));
  } else {
    requireDir(cam_dir + "/data", "EuRoC image folder", kEurocLayout);
    for (const auto& n : ds::listFiles(cam_dir + "/data", ".png")) {
      const auto t = yamlu::parseInt(n.substr(0, n.size() - 4));
      if (!t) throw DataError(cam_dir + "/data/" + n + ": file name is not a nanosecond timestamp (and no data.csv)");
      out.push_back({*t, n});
    }
  }
  return out;
}

std::string EurocDataset::description() const {
  return "EuRoC MAV stereo sequence (mav0/cam0, cam1 with data.csv and sensor.yaml; unrectified, distortion; "
         "ground truth converted to camera poses)";
}

std::vector<ParamSpec> EurocDataset::paramSpecs() const {
  return {
      P_required("path", ParamType::Path, "sequence folder (the one containing mav0/)"),
      P_bool("stereo", true, "read cam1 as the right camera (false: monocular cam0)"),
      P_string("left", "cam0", "left camera folder under mav0/"),
      P_string("right", "cam1", "right camera folder under mav0/"),
      P_double("stereo_max_dt", 0.001, "max |t_left - t_right| of a stereo pair, seconds", 1e-9),
      P_string("groundtruth", "auto",
               "ground truth relative to the folder: auto = mav0/state_groundtruth_estimate0/data.csv, else "
               "groundtruth.txt, else none; '' = none; any TUM/EuRoC trajectory file"),
      P_enum("groundtruth_frame", "body", {"body", "camera"},
             "frame of the ground-truth poses: body (EuRoC; converted with T_BS of the left camera) or camera"),
  };
}

void EurocDataset::configure(const Params& p, const PluginContext& ctx) {
  Plugin::configure(p, ctx);
  root_ = p.getString("path");
  requireDir(root_, "EuRoC sequence folder", kEurocLayout);
  requireDir(root_ + "/mav0", "EuRoC mav0 folder", kEurocLayout);
  stereo_ = p.getBool("stereo");
  const std::string ldir = root_ + "/mav0/" + p.getString("left");
  const std::string rdir = root_ + "/mav0/" + p.getString("right");
  requireDir(ldir, "EuRoC left camera folder", kEurocLayout);
  const EurocCameraInfo li = readEurocSensorYaml(ldir + "/sensor.yaml");
  const auto lefts = readEurocImageList(ldir);
  if (lefts.empty()) throw DataError(ldir + ": no images (" + kEurocLayout + ")");

  CameraModel cam;
  cam.name = "euroc";
  cam.left = li.cam;
  cam.T_body_cam = li.T_BS;
  cam.rectified = false;
  cam.depth_threshold = 35.0;  // ORB-SLAM2 EuRoC.yaml ThDepth
  cam.rgb_order = false;
  cam.depth_factor = 1.0;
  frames_.clear();
  if (stereo_) {
    requireDir(rdir, "EuRoC right camera folder", kEurocLayout);
    const EurocCameraInfo ri = readEurocSensorYaml(rdir + "/sensor.yaml");
    const auto rights = readEurocImageList(rdir);
    cam.sensor = SensorType::Stereo;
    cam.right = ri.cam;
    cam.T_left_right = li.T_BS.inverse() * ri.T_BS;
    cam.baseline = cam.T_left_right.translation().norm();
    if (cam.baseline < 1e-6)
      throw DataError(rdir + "/sensor.yaml: T_BS puts the right camera where the left one is (" + ldir +
                      "/sensor.yaml): stereo baseline 0");
    std::vector<double> ta, tb;
    for (const auto& e : lefts) ta.push_back(e.stamp_ns * 1e-9);
    for (const auto& e : rights) tb.push_back(e.stamp_ns * 1e-9);
    for (auto [i, j] : traj::associate(ta, tb, p.getDouble("stereo_max_dt")))
      frames_.push_back({lefts[i].stamp_ns, ldir + "/data/" + lefts[i].file, rdir + "/data/" + rights[j].file});
    if (frames_.size() < lefts.size())
      DSLAM_LOG(Warn, "EuRoC: " << lefts.size() - frames_.size() << " of " << lefts.size()
                                << " left images have no right image within " << p.getDouble("stereo_max_dt")
                                << " s and are skipped");
    if (frames_.empty()) throw DataError(root_ + ": no stereo pair matched by timestamp (" + kEurocLayout + ")");
  } else {
    cam.sensor = SensorType::Monocular;
    for (const auto& e : lefts) frames_.push_back({e.stamp_ns, ldir + "/data/" + e.file, ""});
  }
  const double dur = (frames_.back().t_ns - frames_.front().t_ns) * 1e-9;
  cam.fps = li.rate_hz > 0 ? li.rate_hz : (frames_.size() > 1 && dur > 0 ? (frames_.size() - 1) / dur : 20.0);
  camera_ = cam;

  // Ground truth.
  gt_.clear();
  gt_body_.clear();
  gt_file_.clear();
  const std::string g = p.getString("groundtruth");
  if (g == "auto") {
    for (const char* c : {"mav0/state_groundtruth_estimate0/data.csv", "groundtruth.txt"})
      if (fileExists(root_ + "/" + c)) {
        gt_file_ = root_ + "/" + c;
        break;
      }
  } else if (!g.empty()) {
    gt_file_ = resolvePath(g, root_);
    requireFile(gt_file_, "EuRoC ground-truth file", "parameter groundtruth");
  }
  if (!gt_file_.empty()) {
    gt_body_ = traj::read(gt_file_);
    const bool body = p.getString("groundtruth_frame") == "body";
    for (size_t k = 0; k < gt_body_.size(); k++)
      gt_.push_back(gt_body_.stamps[k], body ? gt_body_.poses[k] * cam.T_body_cam : gt_body_.poses[k]);
  }
}

double EurocDataset::timestamp(size_t i) const { return frames_.at(i).t_ns * 1e-9; }

SensorFrame EurocDataset::read(size_t i) {
  ds::requireFrameIndex(i, frames_.size());
  const Item& it = frames_[i];
  SensorFrame f;
  f.index = static_cast<int>(i);
  f.timestamp = it.t_ns * 1e-9;
  f.image_path = it.left;
  f.image = ds::readCameraImage(it.left, i, "left image");
  const auto check = [&](const cv::Mat& m, const PinholeCamera& c, const std::string& path) {
    if (m.cols != c.width || m.rows != c.height)
      throw DataError("frame " + std::to_string(i) + ": image " + path + " is " + std::to_string(m.cols) + "x" +
                      std::to_string(m.rows) + " but sensor.yaml says " + std::to_string(c.width) + "x" +
                      std::to_string(c.height));
  };
  check(f.image, camera_->left, it.left);
  if (stereo_) {
    f.image_right_path = it.right;
    f.image_right = ds::readCameraImage(it.right, i, "right image");
    check(f.image_right, camera_->right, it.right);
  }
  f.gt_T_wc = ds::nearestPose(gt_, f.timestamp);
  return f;
}

}  // namespace dslam
