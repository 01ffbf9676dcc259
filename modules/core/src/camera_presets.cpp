#include "dslam/core/camera_presets.h"

namespace dslam {

namespace {
CameraModel rgbd(const char* name, double fx, double fy, double cx, double cy, std::array<double, 5> d) {
  CameraModel c;
  c.name = name;
  c.sensor = SensorType::RGBD;
  c.left.width = 640;
  c.left.height = 480;
  c.left.fx = fx;
  c.left.fy = fy;
  c.left.cx = cx;
  c.left.cy = cy;
  c.left.dist = d;
  c.baseline = 40.0 / fx;  // ORB-SLAM2 TUM*.yaml: Camera.bf = 40
  c.depth_factor = 5000.0;
  c.depth_threshold = 40.0;
  c.fps = 30.0;
  c.rgb_order = true;
  return c;
}
CameraModel kitti(const char* name, int w, int h, double f, double cx, double cy, double bf) {
  CameraModel c;
  c.name = name;
  c.sensor = SensorType::Stereo;
  c.left.width = w;
  c.left.height = h;
  c.left.fx = c.left.fy = f;
  c.left.cx = cx;
  c.left.cy = cy;
  c.right = c.left;
  c.baseline = bf / f;
  c.T_left_right = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(c.baseline, 0, 0));
  c.depth_threshold = 35.0;  // ORB-SLAM2 KITTI*.yaml ThDepth
  c.fps = 10.0;
  c.rgb_order = true;
  return c;
}
}  // namespace

std::vector<std::string> cameraPresetNames() {
  return {"tum_fr1", "tum_fr2", "tum_fr3", "bonn", "kitti_00_02", "kitti_03", "kitti_04_12", "euroc"};
}

std::optional<CameraModel> cameraPreset(const std::string& n) {
  // TUM RGB-D: https://cvg.cit.tum.de/data/datasets/rgbd-dataset/file_formats (ROS default for fr3).
  if (n == "tum_fr1")
    return rgbd("tum_fr1", 517.306408, 516.469215, 318.643040, 255.313989,
                {0.262383, -0.953104, -0.005358, 0.002628, 1.163314});
  if (n == "tum_fr2")
    return rgbd("tum_fr2", 520.908620, 521.007327, 325.141442, 249.701764,
                {0.231222, -0.784899, -0.003257, -0.000105, 0.917205});
  if (n == "tum_fr3") return rgbd("tum_fr3", 535.4, 539.2, 320.1, 247.6, {0, 0, 0, 0, 0});
  // Bonn RGB-D Dynamic: https://www.ipb.uni-bonn.de/data/rgbd-dynamic-dataset/
  if (n == "bonn")
    return rgbd("bonn", 542.822841, 542.576870, 315.593520, 237.756098, {0.039903, -0.099343, -0.000730, -0.000144, 0.0});
  // KITTI odometry calib.txt P0/P1 (as ORB-SLAM2 KITTI00-02.yaml, KITTI03.yaml, KITTI04-12.yaml).
  if (n == "kitti_00_02") return kitti("kitti_00_02", 1241, 376, 718.856, 607.1928, 185.2157, 386.1448);
  if (n == "kitti_03") return kitti("kitti_03", 1242, 375, 721.5377, 609.5593, 172.854, 387.5744);
  if (n == "kitti_04_12") return kitti("kitti_04_12", 1226, 370, 707.0912, 601.8873, 183.1104, 379.8145);
  if (n == "euroc") {
    // ORB-SLAM2 EuRoC.yaml: the pair after stereo rectification.
    auto c = kitti("euroc", 752, 480, 435.2046959714599, 367.4517211914062, 252.2008514404297, 47.90639384423901);
    c.depth_threshold = 35.0;
    c.fps = 20.0;
    c.rgb_order = false;
    return c;
  }
  return std::nullopt;
}

}  // namespace dslam
