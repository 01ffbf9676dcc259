// `dslam eval dense`: ghost rate, accuracy and completeness of a dense map
// against the static geometry of a synthetic scene.
#include "dslam/dense/dense_eval.h"

#include <octomap/OcTree.h>

#include <nlohmann/json.hpp>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include "dslam/core/error.h"
#include "dslam/core/format.h"
#include "dslam/core/json_layout.h"
#include "dslam/core/log.h"
#include "dslam/synth/renderer.h"
#include "dslam/synth/scene.h"

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

namespace dslam::dense {

namespace {

/** Integer cell of a point on a grid of edge `h` (packed into 64 bits). */
struct Cell {
  int64_t x, y, z;
};
Cell cellOf(const Eigen::Vector3d& p, double h) {
  return {static_cast<int64_t>(std::floor(p.x() / h)), static_cast<int64_t>(std::floor(p.y() / h)),
          static_cast<int64_t>(std::floor(p.z() / h))};
}
uint64_t pack(const Cell& c) {
  auto u = [](int64_t v) { return static_cast<uint64_t>(v + (1 << 20)) & 0x1fffffu; };
  return (u(c.x) << 42) | (u(c.y) << 21) | u(c.z);
}

/** Distance from p to the room's surface (the room is the box [-sx/2, sx/2]
 *  x [-sy/2, sy/2] x [0, sz] seen from inside). */
double roomDistance(const Eigen::Vector3d& room, const Eigen::Vector3d& p) {
  const Eigen::Vector3d lo(-room.x() / 2, -room.y() / 2, 0), hi(room.x() / 2, room.y() / 2, room.z());
  const bool inside = (p.array() >= lo.array()).all() && (p.array() <= hi.array()).all();
  if (inside)
    return std::min({p.x() - lo.x(), hi.x() - p.x(), p.y() - lo.y(), hi.y() - p.y(), p.z() - lo.z(), hi.z() - p.z()});
  const Eigen::Vector3d q = p.cwiseMax(lo).cwiseMin(hi);
  return (p - q).norm();
}

/** Distance from p to the nearest surface of `prims` (at most `best`). */
double minDistance(const std::vector<synth::Primitive>& prims, const Eigen::Vector3d& p, double best) {
  for (const auto& pr : prims) {
    if ((p - pr.T_wl.translation()).norm() - pr.bound_radius > best) continue;
    best = std::min(best, std::abs(synth::signedDistance(pr, p)));
  }
  return best;
}

/** True if p is inside one of `prims` or within `r` of its surface. */
bool within(const std::vector<synth::Primitive>& prims, const Eigen::Vector3d& p, double r) {
  for (const auto& pr : prims) {
    if ((p - pr.T_wl.translation()).norm() - pr.bound_radius > r) continue;
    if (synth::signedDistance(pr, p) <= r) return true;
  }
  return false;
}

/** Distance from p to the axis-aligned cube of cell c (edge h). */
double cubeDistance(const Eigen::Vector3d& p, const Cell& c, double h) {
  const Eigen::Vector3d lo(static_cast<double>(c.x) * h, static_cast<double>(c.y) * h, static_cast<double>(c.z) * h);
  const Eigen::Vector3d q = p.cwiseMax(lo).cwiseMin(lo + Eigen::Vector3d::Constant(h));
  return (p - q).norm();
}

bool samePose(const SE3& a, const SE3& b) {
  return (a.translation() - b.translation()).norm() < 1e-9 && a.quaternion().angularDistance(b.quaternion()) < 1e-9;
}

}  // namespace

DenseMapFile loadDenseMap(const std::string& bt_path, const std::string& json_path) {
  if (!fs::is_regular_file(bt_path)) throw DataError("dense map not found: " + bt_path);
  const std::string jp = json_path.empty() ? (fs::path(bt_path).parent_path() / "dense.json").string() : json_path;
  if (!fs::is_regular_file(jp))
    throw DataError("dense map metadata not found: " + jp + " (written by dslam run next to " +
                    fs::path(bt_path).filename().string() + ")");
  DenseMapFile m;
  octomap::OcTree tree(0.1);
  if (!tree.readBinary(bt_path)) throw DataError("cannot read OctoMap binary file " + bt_path);
  m.resolution = tree.getResolution();
  if (!(m.resolution >= 1e-4 && m.resolution <= 100)) {
    throw DataError(bt_path + ": OctoMap resolution " + formatNumber("%g", m.resolution) +
                    " m is outside 0.0001-100 m (not a dslam dense map?)");
  }
  const json j = parseJsonFile(jp);
  if (j.contains("resolution") &&
      (!j["resolution"].is_number() || std::abs(j["resolution"].get<double>() - m.resolution) > 1e-6 * m.resolution))
    throw DataError(jp + ": 'resolution' " + j["resolution"].dump() + " does not match " + bt_path + "'s " +
                    std::to_string(m.resolution) + " m (files of two different runs?)");
  for (auto l = tree.begin_leafs(), end = tree.end_leafs(); l != end; ++l) {
    if (!tree.isNodeOccupied(*l)) continue;
    const octomap::point3d c = l.getCoordinate();
    const int n = static_cast<int>(std::lround(l.getSize() / m.resolution));
    for (int a = 0; a < n; a++)
      for (int b = 0; b < n; b++)
        for (int e = 0; e < n; e++)
          m.occupied.emplace_back(c.x() + (a - (n - 1) / 2.0) * m.resolution, c.y() + (b - (n - 1) / 2.0) * m.resolution,
                                  c.z() + (e - (n - 1) / 2.0) * m.resolution);
  }
  try {
    m.max_range = j.at("max_range").get<double>();
    if (!(m.max_range > 0)) throw DataError(jp + ": 'max_range' must be a number > 0, got " + j["max_range"].dump());
    m.min_range = j.value("min_range", 0.0);
    if (j.contains("dataset")) {
      const json& d = j.at("dataset");
      m.dataset_path = d.value("path", "");
      m.dataset_scenario = d.value("scenario", "");
      if (d.contains("seed")) m.dataset_seed = d.at("seed").get<uint64_t>();
      m.dataset_frames = d.value("frames", 0);
    }
    for (const json& k : j.at("keyframes")) {
      if (!k.value("integrated", false)) continue;
      DenseMapFile::KeyFrame kf;
      kf.frame = k.at("frame").get<int>();
      kf.timestamp = k.value("timestamp", 0.0);
      const auto& v = k.at("T_wc");
      kf.T_wc = SE3(Eigen::Quaterniond(v.at(6).get<double>(), v.at(3).get<double>(), v.at(4).get<double>(),
                                       v.at(5).get<double>()),
                    Eigen::Vector3d(v.at(0).get<double>(), v.at(1).get<double>(), v.at(2).get<double>()));
      m.keyframes.push_back(kf);
    }
  } catch (const json::exception& e) {
    throw DataError(jp + ": " + jsonErrorText(e));
  }
  return m;
}

synth::Scenario sceneScenario(const std::string& scene_dir, const std::string& scenario_file) {
  const fs::path oj = fs::path(scene_dir) / "objects.json";
  if (!fs::is_regular_file(oj))
    throw DataError("not a dslam synth scene (no objects.json): " + scene_dir);
  json j;
  try {
    std::ifstream in(oj);
    j = json::parse(in);
  } catch (const json::exception& e) {
    throw DataError(oj.string() + ": " + e.what());
  }
  std::string src = scenario_file;
  if (src.empty()) {
    const std::string given = j.value("source", "");
    for (const fs::path& c : {fs::path(given), fs::path(scene_dir) / given})
      if (!given.empty() && fs::is_regular_file(c)) {
        src = c.string();
        break;
      }
    if (src.empty())
      throw DataError(oj.string() + ": its scenario file '" + given +
                      "' is not found from here: pass it with --scenario FILE");
  }
  synth::ScenarioOverrides ov;
  ov.frames = j.value("frames", 0);
  ov.width = j.value("width", 0);
  ov.height = j.value("height", 0);
  if (j.contains("seed")) ov.seed = j.at("seed").get<uint64_t>();
  synth::Scenario s = synth::loadScenario(src, ov);
  // A scenario of another scene would evaluate the map against geometry it
  // was never made in: the scene's own record must name the same scenario
  // and the same objects and people.
  auto names = [&](const char* key) {
    std::vector<std::string> n;
    if (j.contains(key) && j.at(key).is_array())
      for (const auto& o : j.at(key))
        if (o.is_object()) n.push_back(o.value("name", ""));
    return n;
  };
  std::vector<std::string> objects, people;
  for (const auto& o : s.objects) objects.push_back(o.name);
  for (const auto& p : s.people) people.push_back(p.name);
  const std::string rendered = j.value("scenario", "");
  std::string differs;
  if (!rendered.empty() && rendered != s.name)
    differs = "the scene was rendered from scenario '" + rendered + "'";
  else if (names("objects") != objects)
    differs = "its objects differ from the scene's (" + std::to_string(objects.size()) + " against " +
              std::to_string(names("objects").size()) + " in " + oj.string() + ")";
  else if (names("people") != people)
    differs = "its people differ from the scene's (" + std::to_string(people.size()) + " against " +
              std::to_string(names("people").size()) + " in " + oj.string() + ")";
  if (!differs.empty())
    throw DataError(src + ": scenario '" + s.name + "' is not the scene " + scene_dir + "'s: " + differs);
  return s;
}

DenseEvalResult evaluateDense(const DenseMapFile& map, const synth::Scenario& s, const DenseEvalOptions& o) {
  if (!map.dataset_scenario.empty() &&
      (map.dataset_scenario != s.name || (map.dataset_seed && *map.dataset_seed != s.seed) ||
       (map.dataset_frames > 0 && map.dataset_frames != s.frames))) {
    auto what = [](const std::string& name, std::optional<uint64_t> seed, int frames) {
      return "scenario '" + name + "'" + (seed ? ", seed " + std::to_string(*seed) : std::string()) +
             (frames > 0 ? ", " + std::to_string(frames) + " frames" : std::string());
    };
    throw DataError("the dense map was made on the scene " + map.dataset_path + " (" +
                    what(map.dataset_scenario, map.dataset_seed, map.dataset_frames) + "), not on this one (" +
                    what(s.name, s.seed, s.frames) + ")");
  }
  const synth::SceneModel scene(s);
  DenseEvalResult r;
  const double res = map.resolution;
  r.resolution = res;
  r.keyframes = map.keyframes.size();
  r.occupied = map.occupied.size();
  if (map.occupied.empty())
    throw DataError("the dense map has no occupied voxels: nothing to evaluate (accuracy and completeness would "
                    "read as perfect and as 0); it integrated " + std::to_string(map.keyframes.size()) +
                    " keyframe(s), and with the default sensor model a voxel is occupied once two keyframes hit it");

  // Alignment of the map frame onto the scene: chordal mean of the
  // rotations GT_i * EST_i^-1, then the translation of the mean positions.
  if (o.T_scene_map) {
    r.T_scene_map = *o.T_scene_map;
  } else {
    if (map.keyframes.empty()) throw DataError("the dense map lists no integrated keyframe: cannot align it to the scene");
    Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
    Eigen::Vector3d mg = Eigen::Vector3d::Zero(), me = Eigen::Vector3d::Zero();
    for (const auto& kf : map.keyframes) {
      if (kf.frame < 0 || kf.frame >= s.frames)
        throw DataError("keyframe of frame " + std::to_string(kf.frame) + " is outside the scene's " +
                        std::to_string(s.frames) + " frames: wrong scene?");
      const SE3 gt = scene.cameraPose(kf.frame);
      S += (gt.rotation() * kf.T_wc.rotation().transpose());
      mg += gt.translation();
      me += kf.T_wc.translation();
    }
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(S, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
    if (R.determinant() < 0) {
      Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
      D(2, 2) = -1;
      R = svd.matrixU() * D * svd.matrixV().transpose();
    }
    const double n = static_cast<double>(map.keyframes.size());
    r.T_scene_map = SE3(R, mg / n - R * (me / n));
  }
  double se = 0;
  for (const auto& kf : map.keyframes)
    se += (r.T_scene_map * kf.T_wc.translation() - scene.cameraPose(kf.frame).translation()).squaredNorm();
  r.alignment_rmse = map.keyframes.empty() ? 0 : std::sqrt(se / static_cast<double>(map.keyframes.size()));

  // Static geometry: the room and the objects present at every frame with one pose.
  std::vector<synth::Primitive> stat;
  std::vector<size_t> moving_objects;
  std::unordered_set<int> static_ids{0};
  for (size_t k = 0; k < s.objects.size(); k++) {
    const synth::ObjectState s0 = scene.objectState(k, 0);
    bool fixed = s0.present;
    for (int f = 1; f < s.frames && fixed; f++) {
      const synth::ObjectState sf = scene.objectState(k, f);
      fixed = sf.present && samePose(sf.T_wo, s0.T_wo);
    }
    if (fixed) {
      const auto p = scene.objectPrimitives(k, 0, s.time(0));
      stat.insert(stat.end(), p.begin(), p.end());
      static_ids.insert(s.objects[k].instance_id);
    } else {
      moving_objects.push_back(k);
    }
  }
  r.movers = moving_objects.size() + s.people.size();

  std::vector<Eigen::Vector3d> pts(map.occupied.size());
  std::vector<double> dist(map.occupied.size());
  for (size_t i = 0; i < pts.size(); i++) {
    pts[i] = r.T_scene_map * map.occupied[i];
    dist[i] = minDistance(stat, pts[i], roomDistance(s.room.size, pts[i]));
  }

  // Space the movers occupied: occupied voxels within one voxel of a mover at
  // some frame (only voxels near their bounding boxes are tested).
  std::unordered_map<uint64_t, std::vector<uint32_t>> grid;
  for (size_t i = 0; i < pts.size(); i++)
    if (dist[i] > res) grid[pack(cellOf(pts[i], res))].push_back(static_cast<uint32_t>(i));
  std::vector<uint8_t> mover(pts.size(), 0);
  const int fstep = std::max(1, o.frame_step);
  for (int f = 0; f < s.frames && !grid.empty(); f += fstep) {
    const double t = s.time(f);
    std::vector<std::vector<synth::Primitive>> movers;
    for (size_t k : moving_objects) movers.push_back(scene.objectPrimitives(k, f, t));
    for (size_t k = 0; k < s.people.size(); k++) movers.push_back(scene.personPrimitives(k, f, t));
    for (const auto& prims : movers) {
      if (prims.empty()) continue;
      Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
      for (const auto& pr : prims) {
        const Eigen::Vector3d c = pr.T_wl.translation(), e = Eigen::Vector3d::Constant(pr.bound_radius + res);
        lo = lo.cwiseMin(c - e);
        hi = hi.cwiseMax(c + e);
      }
      const Cell a = cellOf(lo, res), b = cellOf(hi, res);
      for (int64_t x = a.x; x <= b.x; x++)
        for (int64_t y = a.y; y <= b.y; y++)
          for (int64_t z = a.z; z <= b.z; z++) {
            const auto it = grid.find(pack({x, y, z}));
            if (it == grid.end()) continue;
            for (uint32_t i : it->second)
              if (!mover[i] && within(prims, pts[i], res)) mover[i] = 1;
          }
    }
  }
  for (size_t i = 0; i < pts.size(); i++) {
    if (dist[i] <= res)
      r.near_static++;
    else if (mover[i])
      r.ghost++;
    else
      r.other++;
  }
  r.ghost_rate = r.occupied ? static_cast<double>(r.ghost) / static_cast<double>(r.occupied) : 0.0;
  if (!dist.empty()) {
    std::vector<double> d = dist;
    std::sort(d.begin(), d.end());
    r.accuracy_median = d[d.size() / 2];
    r.accuracy_p90 = d[std::min(d.size() - 1, d.size() * 9 / 10)];
    double sum = 0;
    for (double x : d) sum += x;
    r.accuracy_mean = sum / static_cast<double>(d.size());
  }

  // Completeness: static surface seen by the keyframes (ground-truth render
  // at their frames, within the map's range), sampled every half voxel.
  std::unordered_set<uint64_t> occ;
  for (const auto& c : map.occupied) occ.insert(pack(cellOf(c, res)));
  synth::RenderOptions ro;
  ro.right = false;
  ro.labels = false;
  synth::Renderer R(s, ro);
  const int step = o.pixel_step > 0 ? o.pixel_step : std::max(1, s.width / 320);
  std::unordered_set<uint64_t> seen;
  const SE3 T_map_scene = r.T_scene_map.inverse();
  const auto& K = s.intrinsics;
  for (const auto& kf : map.keyframes) {
    const synth::FrameRender fr = R.render(kf.frame);
    for (int v = 0; v < fr.depth_m.rows; v += step) {
      const float* d = fr.depth_m.ptr<float>(v);
      const int* in = fr.instance.ptr<int>(v);
      for (int u = 0; u < fr.depth_m.cols; u += step) {
        const double z = d[u];
        if (!(z > map.min_range)) continue;
        if (!static_ids.count(std::max(0, in[u]))) continue;  // room surfaces are coded <= 0
        const Eigen::Vector3d pc((u - K.cx) * z / K.fx, (v - K.cy) * z / K.fy, z);
        if (pc.norm() > map.max_range) continue;  // OctoMap's max range is along the ray
        const Eigen::Vector3d pw = fr.T_wc * pc;
        if (!seen.insert(pack(cellOf(pw, res / 2))).second) continue;
        r.surface_samples++;
        const Eigen::Vector3d q = T_map_scene * pw;
        const Cell c = cellOf(q, res);
        bool hit = false;
        for (int dx = -1; dx <= 1 && !hit; dx++)
          for (int dy = -1; dy <= 1 && !hit; dy++)
            for (int dz = -1; dz <= 1 && !hit; dz++) {
              const Cell n{c.x + dx, c.y + dy, c.z + dz};
              hit = occ.count(pack(n)) && cubeDistance(q, n, res) <= res;
            }
        r.surface_covered += hit;
      }
    }
  }
  r.completeness =
      r.surface_samples ? static_cast<double>(r.surface_covered) / static_cast<double>(r.surface_samples) : 0.0;
  return r;
}

std::string toText(const DenseEvalResult& r) {
  std::ostringstream s;
  char b[256];
  std::snprintf(b, sizeof(b), "occupied voxels: %zu (%.0f mm), %zu keyframes, %zu movers in the scene\n", r.occupied,
                r.resolution * 1e3, r.keyframes, r.movers);
  s << b;
  std::snprintf(b, sizeof(b), "ghost rate: %.3f%% (%zu voxels in space only movers occupied)\n", 100 * r.ghost_rate,
                r.ghost);
  s << b;
  std::snprintf(b, sizeof(b), "near static surface (<= 1 voxel): %.1f%%; other (noise): %zu voxels\n",
                r.occupied ? 100.0 * static_cast<double>(r.near_static) / static_cast<double>(r.occupied) : 0.0,
                r.other);
  s << b;
  std::snprintf(b, sizeof(b), "accuracy (distance to the static surface): median %.4f m (%.2f voxel), mean %.4f m, p90 %.4f m\n",
                r.accuracy_median, r.accuracy_median / r.resolution, r.accuracy_mean, r.accuracy_p90);
  s << b;
  std::snprintf(b, sizeof(b), "completeness: %.1f%% of %zu static surface samples seen by the keyframes\n",
                100 * r.completeness, r.surface_samples);
  s << b;
  std::snprintf(b, sizeof(b), "alignment: keyframe positions %.4f m RMSE\n", r.alignment_rmse);
  s << b;
  return s.str();
}

std::string toJson(const DenseEvalResult& r) {
  json j;
  j["resolution"] = r.resolution;
  j["occupied"] = r.occupied;
  j["ghost"] = r.ghost;
  j["ghost_rate"] = r.ghost_rate;
  j["near_static"] = r.near_static;
  j["other"] = r.other;
  j["accuracy_median"] = r.accuracy_median;
  j["accuracy_mean"] = r.accuracy_mean;
  j["accuracy_p90"] = r.accuracy_p90;
  j["completeness"] = r.completeness;
  j["surface_samples"] = r.surface_samples;
  j["surface_covered"] = r.surface_covered;
  j["keyframes"] = r.keyframes;
  j["movers"] = r.movers;
  j["alignment_rmse"] = r.alignment_rmse;
  return j.dump();
}

}  // namespace dslam::dense
