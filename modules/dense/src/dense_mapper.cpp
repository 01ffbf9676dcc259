// DenseMapper: per-keyframe depth + dynamic mask (on a worker thread),
// OctoMap integration at the final keyframe poses, outputs.
#include <octomap/OcTree.h>

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <future>
#include <mutex>
#include <unordered_map>

#include "dslam/core/atomic_file.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/core/png.h"
#include "dslam/core/thread_priority.h"
#include "dslam/core/timing.h"
#include "dslam/core/worker.h"
#include "dslam/dense/dense_map.h"
#include "ray_update.h"
#include "dslam/map/map.h"

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace dslam::dense {

namespace {

struct ColourSum {
  uint32_t r = 0, g = 0, b = 0, n = 0;
};

std::array<uint8_t, 3> heightColour(double h, double lo, double hi) {
  static const cv::Mat lut = [] {
    cv::Mat g(1, 256, CV_8U);
    for (int i = 0; i < 256; i++) g.at<uint8_t>(i) = static_cast<uint8_t>(i);
    cv::Mat c;
    cv::applyColorMap(g, c, cv::COLORMAP_TURBO);
    return c;
  }();
  const double t = hi > lo ? std::clamp((h - lo) / (hi - lo), 0.0, 1.0) : 0.5;
  const cv::Vec3b bgr = lut.at<cv::Vec3b>(static_cast<int>(std::lround(t * 255)));
  return {bgr[2], bgr[1], bgr[0]};
}

}  // namespace

struct DenseMapper::Impl {
  struct Job {
    Frame f;
    std::vector<Detections> dets;
  };
  explicit Impl(DenseMapper* owner)
      : worker([owner](Job& j) {
          try {
            KeyframeCloud kc = owner->preprocess(j.f, j.dets);
            owner->store(std::move(kc));
          } catch (const std::exception& e) {
            DSLAM_LOG(Error, "dense map: keyframe of frame " << j.f.index() << " failed: " << e.what());
          }
        }) {}
  std::mutex m;  ///< guards kfs_ and stats_ against the worker
  std::unique_ptr<octomap::OcTree> tree;
  std::unordered_map<octomap::OcTreeKey, ColourSum, octomap::OcTreeKey::KeyHash> colour;
  Worker<Job> worker;
};

DenseMapper::DenseMapper(const CameraModel& camera, const CameraModel& input_camera, const DenseMapParams& p,
                         bool threaded)
    : impl_(std::make_unique<Impl>(this)), cam_(camera), p_(p) {
  if (camera.sensor == SensorType::Monocular)
    throw ConfigError(
        "outputs.dense_map: the dense map needs depth images (RGB-D) or a stereo pair, but camera.sensor is "
        "monocular; set outputs.dense_map: false");
  if (!camera.left.valid()) throw ConfigError("outputs.dense_map: the camera has no valid intrinsics");
  colour_aligned_ = !(input_camera.sensor == SensorType::Stereo && !input_camera.rectified);
  bgr_ = input_camera.rgb_order;
  // Unit-depth rays of the samples (x/z, y/z). RGB-D depth images are
  // registered to the distorted colour image: undistort; a stereo camera is
  // rectified (no distortion).
  const int step = p_.pixel_step;
  const cv::Size ns((camera.left.width + step - 1) / step, (camera.left.height + step - 1) / step);
  rays_.create(ns, CV_32FC2);
  std::vector<cv::Point2f> px;
  px.reserve(ns.area());
  for (int i = 0; i < ns.height; i++)
    for (int j = 0; j < ns.width; j++) px.emplace_back(static_cast<float>(j * step), static_cast<float>(i * step));
  std::vector<cv::Point2f> un;
  if (camera.sensor == SensorType::RGBD && camera.left.hasDistortion()) {
    const cv::Matx33d K(camera.left.fx, 0, camera.left.cx, 0, camera.left.fy, camera.left.cy, 0, 0, 1);
    cv::undistortPoints(px, un, K, cv::Mat(1, 5, CV_64F, const_cast<double*>(camera.left.dist.data())));
  } else {
    un.resize(px.size());
    for (size_t k = 0; k < px.size(); k++)
      un[k] = cv::Point2f(static_cast<float>((px[k].x - camera.left.cx) / camera.left.fx),
                          static_cast<float>((px[k].y - camera.left.cy) / camera.left.fy));
  }
  for (int i = 0; i < ns.height; i++)
    for (int j = 0; j < ns.width; j++) {
      const cv::Point2f& u = un[static_cast<size_t>(i * ns.width + j)];
      rays_.at<cv::Vec2f>(i, j) = cv::Vec2f(u.x, u.y);
    }
  if (threaded) impl_->worker.start([nice = p_.worker_nice] { lowerThreadPriority(nice, "dense map"); });
}

DenseMapper::~DenseMapper() { impl_->worker.stop(); }

void DenseMapper::checkInput(const SensorFrame& first) const {
  if (first.has_depth() || !first.image_right.empty()) return;
  throw ConfigError("outputs.dense_map: the dense map needs depth images (RGB-D) or a stereo pair, but frame " +
                    std::to_string(first.index) + " of the dataset (" +
                    (first.image_path.empty() ? std::string("no file name") : first.image_path) +
                    ") has neither: use a dataset with depth or a stereo camera, or set outputs.dense_map: false");
}

KeyframeCloud DenseMapper::preprocess(const Frame& f, const std::vector<Detections>& dets) const {
  const double t0 = nowSeconds();
  KeyframeCloud kc;
  kc.frame_index = f.index();
  kc.timestamp = f.timestamp();
  cv::Mat depth;
  if (cam_.sensor == SensorType::RGBD)
    depth = f.input.depth;
  else if (!f.gray.empty() && !f.gray_right.empty())
    depth = stereoDepth(f.gray, f.gray_right, cam_.bf(), p_);
  if (depth.empty() || depth.type() != CV_32F || cv::countNonZero(depth) == 0) {
    kc.ms = (nowSeconds() - t0) * 1e3;
    return kc;  // no depth: the caller skips it
  }
  const cv::Mat mask = dynamicMask(f, dets, depth, p_, &kc.mask);
  cv::Mat col;
  if (p_.colour != "none") {
    const cv::Mat& img = f.input.image;
    if (colour_aligned_ && !img.empty() && img.size() == depth.size()) {
      if (img.channels() == 3 && bgr_)
        cv::cvtColor(img, col, cv::COLOR_BGR2RGB);
      else if (img.channels() == 3)
        col = img;  // loaded as RGB already
      else if (img.channels() == 1)
        cv::cvtColor(img, col, cv::COLOR_GRAY2RGB);
    } else if (!f.gray.empty() && f.gray.size() == depth.size()) {
      cv::cvtColor(f.gray, col, cv::COLOR_GRAY2RGB);
    }
  }
  const int step = p_.pixel_step;
  kc.depth = cv::Mat::zeros(rays_.size(), CV_32F);
  if (!col.empty()) kc.colour = cv::Mat::zeros(rays_.size(), CV_8UC3);
  const float zmin = static_cast<float>(p_.min_range);
  for (int i = 0; i < kc.depth.rows; i++) {
    const int v = i * step;
    if (v >= depth.rows) break;
    const float* d = depth.ptr<float>(v);
    const uint8_t* mk = mask.ptr<uint8_t>(v);
    float* o = kc.depth.ptr<float>(i);
    for (int j = 0; j < kc.depth.cols; j++) {
      const int u = j * step;
      if (u >= depth.cols) break;
      const float z = d[u];
      if (!(z > zmin) || !std::isfinite(z)) continue;
      if (mk[u]) {
        kc.masked++;
        continue;
      }
      o[j] = z;
      kc.points++;
      if (!col.empty()) {
        const cv::Vec3b c = col.at<cv::Vec3b>(v, u);
        kc.colour.at<cv::Vec3b>(i, j) = c;
      }
    }
  }
  kc.ms = (nowSeconds() - t0) * 1e3;
  return kc;
}

void DenseMapper::store(KeyframeCloud&& kc) {
  std::lock_guard<std::mutex> lk(impl_->m);
  stats_.preprocess_ms_total += kc.ms;
  stats_.preprocess_ms_max = std::max(stats_.preprocess_ms_max, kc.ms);
  if (kc.depth.empty() || kc.points == 0) {
    stats_.keyframes_empty_depth++;
    DSLAM_LOG(Warn, "dense map: keyframe of frame " << kc.frame_index
                                                    << " has no usable depth (empty depth image or no stereo match): "
                                                       "skipped");
    return;
  }
  stats_.keyframes_stored++;
  stats_.stored_bytes += kc.bytes();
  kfs_.push_back(std::move(kc));
}

void DenseMapper::addKeyFrame(const Frame& f, const std::vector<Detections>& dets) {
  {
    std::lock_guard<std::mutex> lk(impl_->m);
    stats_.keyframes_received++;
  }
  impl_->worker.push(Impl::Job{f, dets});
  if (!impl_->worker.running()) {
    impl_->worker.drain();
    return;
  }
  if (impl_->worker.queued() <= static_cast<size_t>(p_.max_queued_keyframes)) return;
  const double t0 = nowSeconds();  // the thread lags: hold the caller (memory of the queued images)
  impl_->worker.waitQueuedBelow(static_cast<size_t>(p_.max_queued_keyframes) + 1);
  std::lock_guard<std::mutex> lk(impl_->m);
  stats_.producer_wait_s += nowSeconds() - t0;
}

void DenseMapper::waitIdle() { impl_->worker.waitIdle(); }

namespace {

/** What one keyframe changes in the map: the keys OctoMap's
 *  insertPointCloud(cloud, origin, max_range, lazy_eval, discretize=true)
 *  updates as free and as occupied (discreteRayUpdate()), and the colour
 *  sums of its points per voxel. A pure function of the cloud, its pose and
 *  the resolution, so it can be computed off the thread that updates the tree. */
struct KeyframeUpdate {
  RayUpdate rays;
  std::vector<std::pair<octomap::OcTreeKey, ColourSum>> colour;
};

}  // namespace

void DenseMapper::integrate(const std::map<int, SE3>& T_wc_by_frame) {
  waitIdle();
  const double t0 = nowSeconds();
  std::lock_guard<std::mutex> lk(impl_->m);
  auto tree = std::make_unique<octomap::OcTree>(p_.resolution);
  tree->setProbHit(p_.prob_hit);
  tree->setProbMiss(p_.prob_miss);
  tree->setOccupancyThres(p_.occupancy_threshold);
  impl_->colour.clear();
  poses_.clear();
  stats_.keyframes_integrated = stats_.keyframes_without_pose = 0;
  stats_.points_inserted = stats_.points_masked = 0;
  std::vector<std::pair<const KeyframeCloud*, SE3>> order;  // keyframes with a final pose, in frame order
  for (const auto& kc : kfs_) {
    const auto it = T_wc_by_frame.find(kc.frame_index);
    if (it == T_wc_by_frame.end()) {
      stats_.keyframes_without_pose++;
      continue;
    }
    order.emplace_back(&kc, it->second);
  }
  std::stable_sort(order.begin(), order.end(),
                   [](const auto& a, const auto& b) { return a.first->frame_index < b.first->frame_index; });
  const float rmax = static_cast<float>(p_.max_range);
  // Ray casting only needs the resolution: it runs for the next keyframe on
  // another thread while this one applies the current keyframe's update, in
  // frame order. The key sets are those of insertPointCloud(..., discretize)
  // and every key is updated once per keyframe, so the map is the same as
  // with insertPointCloud() and does not depend on the threads.
  const octomap::OcTree scratch(p_.resolution);
  const int half = static_cast<int>(std::ceil(p_.max_range / p_.resolution)) + 2;
  VoxelKeySet seen(half), occupied_set(half);
  auto compute = [&](size_t k) {
    const KeyframeCloud& kc = *order[k].first;
    const Eigen::Matrix3f R = order[k].second.rotation().cast<float>();
    const Eigen::Vector3f t = order[k].second.translation().cast<float>();
    KeyframeUpdate u;
    octomap::Pointcloud cloud;
    cloud.reserve(static_cast<size_t>(kc.points));
    std::unordered_map<octomap::OcTreeKey, ColourSum, octomap::OcTreeKey::KeyHash> colour;
    for (int i = 0; i < kc.depth.rows; i++) {
      const float* d = kc.depth.ptr<float>(i);
      const cv::Vec2f* r = rays_.ptr<cv::Vec2f>(i);
      for (int j = 0; j < kc.depth.cols; j++) {
        const float z = d[j];
        if (z <= 0) continue;
        const Eigen::Vector3f pw = R * Eigen::Vector3f(r[j][0] * z, r[j][1] * z, z) + t;
        cloud.push_back(pw.x(), pw.y(), pw.z());
        if (kc.colour.empty() || z > rmax) continue;
        octomap::OcTreeKey key;
        if (!scratch.coordToKeyChecked(octomap::point3d(pw.x(), pw.y(), pw.z()), key)) continue;
        const cv::Vec3b c = kc.colour.at<cv::Vec3b>(i, j);
        ColourSum& s = colour[key];
        s.r += c[0];
        s.g += c[1];
        s.b += c[2];
        s.n++;
      }
    }
    discreteRayUpdate(scratch, cloud, octomap::point3d(t.x(), t.y(), t.z()), p_.max_range, seen, occupied_set, u.rays);
    u.colour.assign(colour.begin(), colour.end());
    return u;
  };
  std::future<KeyframeUpdate> next;
  if (!order.empty()) next = std::async(std::launch::async, compute, size_t{0});
  for (size_t k = 0; k < order.size(); k++) {
    KeyframeUpdate u = next.get();
    if (k + 1 < order.size()) next = std::async(std::launch::async, compute, k + 1);
    for (const octomap::OcTreeKey& key : u.rays.free) tree->updateNode(key, false, /*lazy_eval=*/false);
    for (const octomap::OcTreeKey& key : u.rays.occupied) tree->updateNode(key, true, /*lazy_eval=*/false);
    for (const auto& [key, c] : u.colour) {
      ColourSum& s = impl_->colour[key];
      s.r += c.r;
      s.g += c.g;
      s.b += c.b;
      s.n += c.n;
    }
    const KeyframeCloud& kc = *order[k].first;
    poses_[kc.frame_index] = order[k].second;
    stats_.keyframes_integrated++;
    stats_.points_inserted += static_cast<size_t>(kc.points);
    stats_.points_masked += static_cast<size_t>(kc.masked);
  }
  impl_->tree = std::move(tree);
  size_t occ = 0;
  for (auto l = impl_->tree->begin_leafs(), end = impl_->tree->end_leafs(); l != end; ++l)
    if (impl_->tree->isNodeOccupied(*l)) {
      const double n = std::round(l.getSize() / p_.resolution);
      occ += static_cast<size_t>(n * n * n);
    }
  stats_.occupied_voxels = occ;
  stats_.octree_bytes = impl_->tree->memoryUsage();
  stats_.integrate_s = nowSeconds() - t0;
}

std::vector<Voxel> DenseMapper::occupiedVoxels() const {
  std::vector<Voxel> out;
  const octomap::OcTree* tree = impl_->tree.get();
  if (!tree) return out;
  const bool height = p_.colour == "height";
  double lo = 0, hi = 0;
  const double res = p_.resolution;
  for (auto l = tree->begin_leafs(), end = tree->end_leafs(); l != end; ++l) {
    if (!tree->isNodeOccupied(*l)) continue;
    const octomap::point3d c = l.getCoordinate();
    const int n = static_cast<int>(std::lround(l.getSize() / res));  // pruned leaves: every voxel inside
    for (int a = 0; a < n; a++)
      for (int b = 0; b < n; b++)
        for (int e = 0; e < n; e++) {
          Voxel v;
          v.c = Eigen::Vector3d(c.x() + (a - (n - 1) / 2.0) * res, c.y() + (b - (n - 1) / 2.0) * res,
                                c.z() + (e - (n - 1) / 2.0) * res);
          const auto it = impl_->colour.find(tree->coordToKey(octomap::point3d(
              static_cast<float>(v.c.x()), static_cast<float>(v.c.y()), static_cast<float>(v.c.z()))));
          if (it != impl_->colour.end() && it->second.n > 0) {
            v.r = static_cast<uint8_t>(it->second.r / it->second.n);
            v.g = static_cast<uint8_t>(it->second.g / it->second.n);
            v.b = static_cast<uint8_t>(it->second.b / it->second.n);
          } else {
            v.r = v.g = v.b = 160;
          }
          out.push_back(v);
        }
  }
  if (height && !poses_.empty()) {
    // Height along the mean camera up axis (world frame = first camera).
    Eigen::Vector3d up = Eigen::Vector3d::Zero();
    for (const auto& [f, T] : poses_) up += T.rotation() * Eigen::Vector3d(0, -1, 0);
    up.normalize();
    std::vector<double> h;
    for (const auto& v : out) h.push_back(v.c.dot(up));
    if (!h.empty()) {
      std::vector<double> s = h;
      std::sort(s.begin(), s.end());
      lo = s[s.size() / 50];
      hi = s[s.size() - 1 - s.size() / 50];
    }
    for (size_t i = 0; i < out.size(); i++) {
      const auto c = heightColour(h[i], lo, hi);
      out[i].r = c[0], out[i].g = c[1], out[i].b = c[2];
    }
  }
  return out;
}

void DenseMapper::writeOctoMap(const std::string& path) const {
  if (!impl_->tree) throw Error("dense map: integrate() before writing " + path);
  // writeBinaryConst: the maximum-likelihood occupancy (octovis, OcTree::readBinary).
  const std::string tmp = path + ".tmp";
  if (!impl_->tree->writeBinaryConst(tmp)) throw DataError("cannot write OctoMap file: " + path);
  fs::rename(tmp, path);
}

void DenseMapper::writePly(const std::string& path) const {
  const std::vector<Voxel> vox = occupiedVoxels();
  AtomicOfstream out(path);
  std::ofstream& f = out.stream();
  f << "ply\nformat ascii 1.0\ncomment dslam dense map: occupied voxel centres, resolution " << p_.resolution
    << " m, colour " << p_.colour << "\nelement vertex " << vox.size()
    << "\nproperty float x\nproperty float y\nproperty float z\n";
  const bool colour = p_.colour != "none";
  if (colour) f << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  f << "end_header\n";
  char buf[128];
  for (const Voxel& v : vox) {
    if (colour)
      std::snprintf(buf, sizeof(buf), "%.4f %.4f %.4f %d %d %d\n", v.c.x(), v.c.y(), v.c.z(), v.r, v.g, v.b);
    else
      std::snprintf(buf, sizeof(buf), "%.4f %.4f %.4f\n", v.c.x(), v.c.y(), v.c.z());
    f << buf;
  }
  out.commit();
}

void DenseMapper::writeViews(const std::string& top_png, const std::string& side_png,
                             const Trajectory& trajectory) const {
  std::vector<Voxel> vox = occupiedVoxels();
  std::vector<SE3> kf;
  for (const auto& [f, T] : poses_) kf.push_back(T);
  char title[160];
  std::snprintf(title, sizeof(title), "%zu voxels of %.0f mm, %zu keyframes%s", vox.size(), p_.resolution * 1e3,
                kf.size(), p_.mask ? ", dynamic pixels removed" : ", NOT masked");
  for (int top = 1; top >= 0; top--) {
    const std::string& path = top ? top_png : side_png;
    if (path.empty()) continue;
    const cv::Mat img = renderView(vox, p_.resolution, trajectory.poses, kf, top == 1, p_,
                                   std::string(top ? "top view: " : "side view: ") + title);
    writeImageFile(path, img);
  }
}

void DenseMapper::writeJson(const std::string& path) const {
  json j;
  j["resolution"] = p_.resolution;
  j["max_range"] = p_.max_range;
  j["min_range"] = p_.min_range;
  j["pixel_step"] = p_.pixel_step;
  j["mask"] = p_.mask;
  j["classes"] = p_.classes;
  j["sensor"] = toString(cam_.sensor);
  const DenseStats& s = stats_;
  j["keyframes_received"] = s.keyframes_received;
  j["keyframes_stored"] = s.keyframes_stored;
  j["keyframes_empty_depth"] = s.keyframes_empty_depth;
  j["keyframes_integrated"] = s.keyframes_integrated;
  j["keyframes_without_pose"] = s.keyframes_without_pose;
  j["points_inserted"] = s.points_inserted;
  j["points_masked"] = s.points_masked;
  j["occupied_voxels"] = s.occupied_voxels;
  j["stored_mb"] = static_cast<double>(s.stored_bytes) / (1024.0 * 1024.0);
  j["octree_mb"] = static_cast<double>(s.octree_bytes) / (1024.0 * 1024.0);
  j["preprocess_ms_mean"] = s.keyframes_received ? s.preprocess_ms_total / static_cast<double>(s.keyframes_received) : 0.0;
  j["preprocess_ms_max"] = s.preprocess_ms_max;
  j["integrate_s"] = s.integrate_s;
  j["producer_wait_s"] = s.producer_wait_s;
  if (!dataset_root_.empty()) {
    std::error_code ec;
    const fs::path root = fs::absolute(dataset_root_, ec);
    json d = {{"path", (ec ? fs::path(dataset_root_) : root).string()}};
    std::ifstream in(fs::path(dataset_root_) / "objects.json");
    const json scene = in ? json::parse(in, nullptr, /*allow_exceptions=*/false) : json();
    if (scene.is_object() && scene.contains("scenario") && scene["scenario"].is_string()) {
      d["scenario"] = scene["scenario"];
      if (scene.contains("seed") && scene["seed"].is_number_unsigned()) d["seed"] = scene["seed"];
      if (scene.contains("frames") && scene["frames"].is_number_integer()) d["frames"] = scene["frames"];
    }
    j["dataset"] = std::move(d);
  }
  json kfs = json::array();
  for (const KeyframeCloud& kc : kfs_) {
    json k;
    k["frame"] = kc.frame_index;
    k["timestamp"] = kc.timestamp;
    k["points"] = kc.points;
    k["masked"] = kc.masked;
    k["mask_px"] = {{"semantic", kc.mask.semantic},
                    {"panoptic", kc.mask.panoptic},
                    {"boxes", kc.mask.boxes},
                    {"keypoint_disks", kc.mask.keypoints},
                    {"total", kc.mask.total}};
    const auto it = poses_.find(kc.frame_index);
    k["integrated"] = it != poses_.end();
    if (it != poses_.end()) {
      const auto& q = it->second.quaternion();
      const auto& t = it->second.translation();
      k["T_wc"] = {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()};
    }
    kfs.push_back(std::move(k));
  }
  j["keyframes"] = std::move(kfs);
  AtomicOfstream f(path);
  f << j.dump(1) << "\n";
  f.commit();
}

std::vector<std::string> DenseMapper::writeOutputs(const std::string& dir, const Trajectory& trajectory) const {
  const fs::path d(dir);
  std::vector<std::string> files = {(d / "map.bt").string(), (d / "dense.ply").string(),
                                    (d / "dense_top.png").string(), (d / "dense_side.png").string(),
                                    (d / "dense.json").string()};
  writeOctoMap(files[0]);
  writePly(files[1]);
  writeViews(files[2], files[3], trajectory);
  writeJson(files[4]);
  return files;
}

std::map<int, SE3> keyFramePosesByFrame(Map& m) {
  std::lock_guard<std::recursive_mutex> lk(m.update_mutex);
  std::map<int, SE3> out;
  for (const auto& [id, kfp] : m.allKeyFramesEver()) {
    KeyFrame* kf = kfp.get();
    SE3 Trw;
    int guard = 0;
    while (kf->bad && kf->parent && guard++ < 10000) {
      Trw = Trw * kf->T_cp;
      kf = kf->parent;
    }
    if (kf->bad) continue;
    out[kfp->frame_index] = (Trw * kf->T_cw()).inverse();
  }
  return out;
}

}  // namespace dslam::dense
