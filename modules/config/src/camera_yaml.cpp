#include "dslam/config/camera_yaml.h"

#include <mrpt/containers/yaml.h>

#include <filesystem>
#include <sstream>
#include <tuple>

#include "dslam/config/yaml_loader.h"
#include "dslam/core/camera_presets.h"
#include "dslam/core/error.h"
#include "dslam/core/format.h"
#include "dslam/core/yaml_util.h"

namespace dslam::config {

std::vector<ParamSpec> cameraParamSpecs() {
  std::vector<std::string> presets = cameraPresetNames();
  presets.insert(presets.begin(), "none");
  return {
      P_enum("preset", "none", presets, "start from a published calibration; other keys override it"),
      P_string("name", "", "free-form camera name"),
      P_enum("sensor", "rgbd", {"monocular", "stereo", "rgbd"}, "sensor type"),
      P_int("width", 0, "image width, pixels", 0),
      P_int("height", 0, "image height, pixels", 0),
      P_double("fx", 0, "focal length x, pixels", 0),
      P_double("fy", 0, "focal length y, pixels", 0),
      P_double("cx", 0, "principal point x, pixels"),
      P_double("cy", 0, "principal point y, pixels"),
      P_list("dist", ParamType::DoubleList, "[]", "distortion k1 k2 p1 p2 [k3] (OpenCV radial-tangential)"),
      P_double("baseline", 0, "stereo baseline in metres (RGB-D: virtual baseline; 0 = from bf)", 0),
      P_double("bf", 0, "baseline * fx (ORB-SLAM Camera.bf); used when baseline is 0", 0),
      P_double("depth_factor", 5000, "raw depth units per metre (TUM: 5000)", 0),
      P_double("depth_threshold", 40, "close/far point limit in baselines (ORB-SLAM ThDepth)", 0),
      P_double("fps", 30, "frame rate", 0),
      P_bool("rgb", true, "colour images are RGB (false: BGR)"),
      P_bool("rectified", true, "stereo pair already rectified; false: rectify from right + T_left_right"),
      {"right", ParamType::Map, "", "right camera intrinsics {width,height,fx,fy,cx,cy,dist} (unrectified stereo)", {}, false, {}, {}},
      P_list("T_left_right", ParamType::DoubleList, "[]", "pose of the right camera in the left frame, 4x4 or 3x4 row-major"),
      P_list("T_body_cam", ParamType::DoubleList, "[]", "camera pose in the body frame (EuRoC T_BS), 4x4 row-major"),
  };
}

SE3 se3FromRowMajor(const std::vector<double>& v, const std::string& what) {
  if (v.size() != 16 && v.size() != 12)
    throw ConfigError(what + ": expected 16 (4x4) or 12 (3x4) numbers, got " + std::to_string(v.size()));
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 4; c++) T(r, c) = v[r * 4 + c];
  const Eigen::Matrix3d R = T.block<3, 3>(0, 0);
  if (!T.allFinite() || !isOrthonormal(R, 1e-2) || R.determinant() < 0)
    throw ConfigError(what + ": the 3x3 block is not a rotation (R^T R differs from the identity by more than 0.01, "
                             "or a reflection)");
  return SE3(T);
}

static std::array<double, 5> distFrom(const std::vector<double>& d, const std::string& where) {
  if (!(d.empty() || d.size() == 4 || d.size() == 5))
    throw ConfigError(where + ": 'dist' needs 4 or 5 values (k1 k2 p1 p2 [k3]), got " + std::to_string(d.size()));
  std::array<double, 5> a{0, 0, 0, 0, 0};
  for (size_t i = 0; i < d.size(); i++) a[i] = d[i];
  return a;
}

static void intrinsicsFrom(const Params& p, PinholeCamera& cam, bool use_preset, const std::string& where) {
  auto take = [&](const char* k) { return !use_preset || p.isGiven(k); };
  if (take("width")) cam.width = static_cast<int>(p.getInt("width"));
  if (take("height")) cam.height = static_cast<int>(p.getInt("height"));
  if (take("fx")) cam.fx = p.getDouble("fx");
  if (take("fy")) cam.fy = p.getDouble("fy");
  if (take("cx")) cam.cx = p.getDouble("cx");
  if (take("cy")) cam.cy = p.getDouble("cy");
  if (take("dist")) cam.dist = distFrom(p.getDoubleList("dist"), where);
  for (const char* k : {"width", "height", "fx", "fy"})  // 0 is only the "not given" default
    if (p.isGiven(k) && !(p.getDouble(k) > 0))
      throw ConfigError(where + ": '" + k + "' must be greater than 0, got " +
                        yamlu::scalarText(*yamlu::findValue(p.asYaml().node(), k)).value_or("?"));
  if (cam.width > 0 && cam.height > 0 && !cam.principalPointInside())
    for (const auto& [k, v, side, side_name] : {std::tuple{"cx", cam.cx, cam.width, "width"},
                                                std::tuple{"cy", cam.cy, cam.height, "height"}})
      if (!(v >= 0 && v <= side))
        throw ConfigError(where + ": '" + k + "' (" +
                          (p.isGiven(k) ? yamlu::scalarText(*yamlu::findValue(p.asYaml().node(), k)).value_or("?")
                                        : formatNumber("%g", v) + ", from the preset") +
                          ") lies outside the image: the principal point must be within 0.." + side_name + " (" +
                          std::to_string(side) + ") pixels");
  if (!use_preset) {
    for (const char* k : {"width", "height", "fx", "fy", "cx", "cy"})
      if (!p.isGiven(k))
        throw ConfigError(where + ": missing required key '" + k +
                          "' (give the intrinsics width, height, fx, fy, cx, cy or a 'preset': " +
                          yamlu::join(cameraPresetNames()) + ")");
  }
}

CameraModel cameraFromParams(const Params& p) {
  const std::string where = p.location().str().empty() ? "camera" : p.location().str();
  const std::string preset = p.getString("preset");
  const bool use_preset = preset != "none";
  CameraModel c;
  if (use_preset) c = *cameraPreset(preset);
  auto take = [&](const char* k) { return !use_preset || p.isGiven(k); };
  if (take("name")) c.name = p.getString("name");
  if (take("sensor")) c.sensor = sensorTypeFromString(p.getString("sensor"));
  intrinsicsFrom(p, c.left, use_preset, where);
  if (take("depth_factor")) c.depth_factor = p.getDouble("depth_factor");
  if (p.isGiven("depth_factor") && !(c.depth_factor > 0))
    throw ConfigError(where + ": 'depth_factor' must be greater than 0 (raw depth units per metre), got 0");
  if (take("depth_threshold")) c.depth_threshold = p.getDouble("depth_threshold");
  if (take("fps")) c.fps = p.getDouble("fps");
  if (take("rgb")) c.rgb_order = p.getBool("rgb");
  if (take("rectified")) c.rectified = p.getBool("rectified");
  if (p.isGiven("baseline") && p.getDouble("baseline") > 0)
    c.baseline = p.getDouble("baseline");
  else if (p.isGiven("bf") && p.getDouble("bf") > 0)
    c.baseline = p.getDouble("bf") / c.left.fx;
  if (p.isGiven("T_left_right")) c.T_left_right = se3FromRowMajor(p.getDoubleList("T_left_right"), where + ".T_left_right");
  if (p.isGiven("T_body_cam")) c.T_body_cam = se3FromRowMajor(p.getDoubleList("T_body_cam"), where + ".T_body_cam");
  if (p.isGiven("right")) {
    SourceLocation rw = p.location();
    rw.key_path += rw.key_path.empty() ? "right" : ".right";
    std::vector<ParamSpec> rs;
    for (const auto& s : cameraParamSpecs())
      for (const char* k : {"width", "height", "fx", "fy", "cx", "cy", "dist"})
        if (s.name == k) rs.push_back(s);
    const auto& node = *yamlu::findValue(p.asYaml().node(), "right");
    mrpt::containers::yaml ry(node);
    Params rp = Params::resolve(rs, &ry, rw);
    intrinsicsFrom(rp, c.right, false, rw.str());
  } else if (c.sensor == SensorType::Stereo && !c.right.valid()) {
    c.right = c.left;
  }
  if (c.sensor == SensorType::Stereo && c.rectified && c.baseline <= 0 && c.T_left_right.translation().norm() > 0)
    c.baseline = c.T_left_right.translation().norm();
  if (c.sensor == SensorType::Stereo && c.baseline <= 0 && c.rectified)
    throw ConfigError(where + ": a rectified stereo camera needs 'baseline' (metres) or 'bf'");
  if (c.sensor == SensorType::Stereo && !c.rectified && !p.isGiven("T_left_right") && !use_preset)
    throw ConfigError(where + ": an unrectified stereo camera needs 'T_left_right' and 'right'");
  if (c.sensor == SensorType::RGBD && c.baseline <= 0) c.baseline = 40.0 / c.left.fx;  // ORB-SLAM2 default bf = 40
  return c;
}

static std::string list(const double* v, size_t n) {
  std::ostringstream o;
  o.precision(12);
  o << "[";
  for (size_t i = 0; i < n; i++) o << (i ? ", " : "") << v[i];
  o << "]";
  return o.str();
}

static std::string mat(const SE3& T) {
  const Eigen::Matrix4d M = T.matrix();
  double v[16];
  for (int r = 0; r < 4; r++)
    for (int c = 0; c < 4; c++) v[r * 4 + c] = M(r, c);
  return list(v, 16);
}

std::string cameraToYaml(const CameraModel& c) {
  std::ostringstream o;
  o.precision(12);
  o << "name: \"" << c.name << "\"\n"
    << "sensor: " << toString(c.sensor) << "\n"
    << "width: " << c.left.width << "\nheight: " << c.left.height << "\n"
    << "fx: " << c.left.fx << "\nfy: " << c.left.fy << "\ncx: " << c.left.cx << "\ncy: " << c.left.cy << "\n"
    << "dist: " << list(c.left.dist.data(), 5) << "\n"
    << "baseline: " << c.baseline << "\n"
    << "depth_factor: " << c.depth_factor << "\n"
    << "depth_threshold: " << c.depth_threshold << "\n"
    << "fps: " << c.fps << "\n"
    << "rgb: " << (c.rgb_order ? "true" : "false") << "\n"
    << "rectified: " << (c.rectified ? "true" : "false") << "\n";
  if (c.sensor == SensorType::Stereo) {
    o << "right: {width: " << c.right.width << ", height: " << c.right.height << ", fx: " << c.right.fx
      << ", fy: " << c.right.fy << ", cx: " << c.right.cx << ", cy: " << c.right.cy
      << ", dist: " << list(c.right.dist.data(), 5) << "}\n";
    o << "T_left_right: " << mat(c.T_left_right) << "\n";
  }
  o << "T_body_cam: " << mat(c.T_body_cam) << "\n";
  return o.str();
}

CameraModel loadCameraFile(const std::string& path) {
  LoadedYaml ly = loadYamlFile(path);
  const auto* node = &ly.root->node();
  std::string kp;
  if (const auto* cam = yamlu::findValue(*node, "camera")) {
    node = cam;
    kp = "camera";
  }
  mrpt::containers::yaml y(*node);
  return cameraFromParams(Params::resolve(cameraParamSpecs(), &y, SourceLocation{path, kp, -1},
                                          std::filesystem::path(path).parent_path().string()));
}

}  // namespace dslam::config
