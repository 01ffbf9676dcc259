#include "dslam/synth/writer.h"

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "dslam/config/camera_yaml.h"
#include "dslam/core/atomic_file.h"
#include "dslam/core/coco.h"
#include "dslam/core/error.h"
#include "dslam/core/format.h"
#include "dslam/core/json_layout.h"
#include "dslam/core/log.h"
#include "dslam/core/png.h"
#include "dslam/core/trajectory.h"
#include "dslam/trajectory/io.h"

namespace fs = std::filesystem;
using ojson = nlohmann::ordered_json;

namespace dslam::synth {

namespace {

std::string stampName(double t) { return formatNumber("%.6f", t); }

/** PNG with OpenCV's default zlib level, run-length strategy and the Sub row
 *  filter (what imwrite does when no compression level is given): files about
 *  14% larger than with level 3 and adaptive filters, but Paeth-filtered rows
 *  make decoding slow, and every run decodes every frame: measured with
 *  callgrind on a 640x480 walking_xyz frame, 43 instead of 64 million
 *  instructions per colour image and 33 instead of 39 per depth image. */
void writePng(const std::string& path, const cv::Mat& m) {
  writeImageFile(path, m, {cv::IMWRITE_PNG_STRATEGY, cv::IMWRITE_PNG_STRATEGY_RLE});
}

/** Panoptic id image (CV_32S) -> RGB PNG (stored BGR for OpenCV). */
cv::Mat panopticPng(const cv::Mat& ids) {
  cv::Mat out(ids.size(), CV_8UC3);
  for (int y = 0; y < ids.rows; y++) {
    const int* p = ids.ptr<int>(y);
    auto* q = out.ptr<cv::Vec3b>(y);
    for (int x = 0; x < ids.cols; x++) {
      const int v = p[x];
      q[x] = cv::Vec3b(static_cast<uchar>((v >> 16) & 255), static_cast<uchar>((v >> 8) & 255), static_cast<uchar>(v & 255));
    }
  }
  return out;
}

/** A JSON number printed as `fmt` prints it (the shortest text of the
 *  rounded double is that text). */
ojson rounded(double v, const char* fmt) { return std::strtod(formatNumber(fmt, v).c_str(), nullptr); }
ojson num(double v) { return rounded(v, "%.6g"); }
ojson num9(double v) { return rounded(v, "%.9g"); }
ojson stamp(double t) { return rounded(t, "%.6f"); }

ojson poseJson(int frame, const SE3& T) {
  const auto& q = T.quaternion();
  const auto& t = T.translation();
  return ojson::array({frame, num9(t.x()), num9(t.y()), num9(t.z()), num9(q.x()), num9(q.y()), num9(q.z()), num9(q.w())});
}

bool samePose(const SE3& a, const SE3& b) {
  return (a.translation() - b.translation()).norm() < 1e-9 && a.quaternion().angularDistance(b.quaternion()) < 1e-9;
}

/** Marks a folder as `dslam synth` output from its start. */
constexpr const char* kSynthMarker = ".dslam_synth";

void prepareDir(const std::string& out, bool overwrite) {
  if (fs::exists(out)) {
    if (!fs::is_directory(out)) throw ConfigError("output path exists and is not a folder: " + out);
    if (!fs::is_empty(out)) {
      if (!overwrite) throw ConfigError("output folder already exists: " + out + " (use --overwrite to replace it)");
      // Only replace what looks like an earlier `dslam synth` output, also
      // one that was stopped half-way (its marker is written first).
      if (!fs::exists(fs::path(out) / kSynthMarker) &&
          (!fs::exists(fs::path(out) / "objects.json") || !fs::exists(fs::path(out) / "rgb.txt")))
        throw ConfigError("refusing to overwrite " + out +
                          ": it is not a `dslam synth` output (no objects.json / rgb.txt); remove it yourself");
      fs::remove_all(out);
    }
  }
  fs::create_directories(out);
  std::ofstream(fs::path(out) / kSynthMarker) << "written by dslam synth; --overwrite may replace this folder\n";
}

ojson boxesJson(const Scenario& s, int f, const FrameRender& fr) {
  ojson boxes = ojson::array();
  for (const Box2D& b : fr.boxes)
    boxes.push_back({{"category_id", b.category_id},
                     {"category", coco::name(b.category_id)},
                     {"instance_id", b.instance_id},
                     {"name", b.name},
                     {"bbox", {b.box.x, b.box.y, b.box.width, b.box.height}},
                     {"area", b.area},
                     {"score", 1.0}});
  return {{"frame", f},
          {"timestamp", stamp(fr.timestamp)},
          {"width", s.width},
          {"height", s.height},
          {"boxes", std::move(boxes)}};
}

ojson panopticAnnotation(int f, const std::string& st, const FrameRender& fr) {
  ojson segs = ojson::array();
  for (const Segment& sg : fr.segments) {
    ojson j = {{"id", sg.id},
               {"category_id", sg.category_id},
               {"iscrowd", 0},
               {"bbox", {sg.bbox.x, sg.bbox.y, sg.bbox.width, sg.bbox.height}},
               {"area", sg.area}};
    if (sg.instance_id > 0) j["instance_id"] = sg.instance_id;
    segs.push_back(std::move(j));
  }
  return {{"image_id", f}, {"file_name", st + ".png"}, {"segments_info", std::move(segs)}};
}

/** COCO panoptic annotation file of the sequence. */
ojson panopticJson(const Scenario& s, ojson images, ojson annos) {
  ojson cats = ojson::array();
  for (const auto& c : coco::categories())
    cats.push_back({{"id", c.id},
                    {"name", c.name},
                    {"supercategory", c.isthing ? "thing" : "stuff"},
                    {"isthing", c.isthing ? 1 : 0},
                    {"color", {(c.id * 37) % 256, (c.id * 91) % 256, (c.id * 53) % 256}}});
  return {{"info", {{"description", "dslam synth scenario " + s.name}, {"version", "1.0"}}},
          {"licenses", ojson::array()},
          {"images", std::move(images)},
          {"annotations", std::move(annos)},
          {"categories", std::move(cats)}};
}

/** [[first, last], ...] frame ranges where `on` is set. */
ojson ranges(const std::vector<char>& on) {
  ojson r = ojson::array();
  int a = -1;
  const int n = static_cast<int>(on.size());
  for (int f = 0; f <= n; f++) {
    const bool v = f < n && on[static_cast<size_t>(f)];
    if (v && a < 0) a = f;
    if (!v && a >= 0) {
      r.push_back({a, f - 1});
      a = -1;
    }
  }
  return r;
}

ojson objectJson(const Scenario& s, const SceneModel& scene, size_t i, const std::vector<int>& visible) {
  const ObjectSpec& o = s.objects[i];
  std::vector<char> on(static_cast<size_t>(s.frames));
  ojson track = ojson::array();
  SE3 last;
  bool have = false;
  for (int f = 0; f < s.frames; f++) {
    const ObjectState st = scene.objectState(i, f);
    on[static_cast<size_t>(f)] = st.present;
    if (st.present && (!have || !samePose(st.T_wo, last))) {
      track.push_back(poseJson(f, st.T_wo));
      last = st.T_wo;
      have = true;
    }
  }
  const auto& inst = scene.instances()[static_cast<size_t>(o.instance_id)];
  return {{"instance_id", o.instance_id},
          {"name", o.name},
          {"kind", "object"},
          {"type", o.type},
          {"class", o.class_name},
          {"category_id", o.category_id},
          {"labelled", o.labelled},
          {"isthing", inst.isthing},
          {"panoptic_id", panopticId(inst)},
          {"size", {num(o.size.x()), num(o.size.y()), num(o.size.z())}},
          {"moving", !o.path.empty()},
          {"present", ranges(on)},
          {"track", std::move(track)},
          {"visible_pixels", visible}};
}

ojson personJson(const Scenario& s, const SceneModel& scene, size_t i, const std::vector<int>& visible) {
  const PersonSpec& p = s.people[i];
  std::vector<char> on(static_cast<size_t>(s.frames));
  ojson track = ojson::array();
  for (int f = 0; f < s.frames; f++) {
    on[static_cast<size_t>(f)] = scene.personPresent(i, f);
    if (on[static_cast<size_t>(f)]) track.push_back(poseJson(f, scene.personRoot(i, s.time(f))));
  }
  return {{"instance_id", p.instance_id},
          {"name", p.name},
          {"kind", "person"},
          {"action", p.action},
          {"class", "person"},
          {"category_id", 1},
          {"labelled", true},
          {"isthing", true},
          {"panoptic_id", 1000 + p.instance_id},
          {"height", num(p.height)},
          {"present", ranges(on)},
          {"track_frame", "pelvis (x forward, z up)"},
          {"track", std::move(track)},
          {"visible_pixels", visible}};
}

ojson eventJson(const Scenario& s, const EventSpec& e, const std::vector<std::vector<int>>& visible) {
  const ObjectSpec* a = s.findObject(e.object);
  const ObjectSpec* b = e.by.empty() ? nullptr : s.findObject(e.by);
  // Visibility of the objects concerned during the change (frames first-1 .. last).
  int vis = 0;
  for (int f = std::max(0, e.first - 1); f <= e.last; f++) {
    vis += visible[static_cast<size_t>(a->instance_id)][static_cast<size_t>(f)];
    if (b) vis += visible[static_cast<size_t>(b->instance_id)][static_cast<size_t>(f)];
  }
  ojson j = {{"type", e.type}, {"object", e.object}, {"instance_id", a->instance_id}};
  if (b) {
    j["by"] = e.by;
    j["by_instance_id"] = b->instance_id;
  }
  j["frames"] = {e.first, e.last};
  j["timestamps"] = {stamp(s.stamp(e.first)), stamp(s.stamp(e.last))};
  if (e.type == "moved") j["to"] = {num(e.position.x()), num(e.position.y()), num(e.position.z())};
  j["visible_pixels_during"] = vis;
  j["in_view"] = vis > 0;
  return j;
}

/** objects.json: classes, sizes, poses over time, visibility, events. */
ojson objectsJson(const Scenario& s, const SceneModel& scene, const std::vector<std::vector<int>>& visible) {
  ojson objects = ojson::array(), people = ojson::array(), events = ojson::array();
  for (size_t i = 0; i < s.objects.size(); i++)
    objects.push_back(objectJson(s, scene, i, visible[static_cast<size_t>(s.objects[i].instance_id)]));
  for (size_t i = 0; i < s.people.size(); i++)
    people.push_back(personJson(s, scene, i, visible[static_cast<size_t>(s.people[i].instance_id)]));
  for (const EventSpec& e : s.events) events.push_back(eventJson(s, e, visible));
  return {{"scenario", s.name},
          {"source", s.file},
          {"seed", s.seed},
          {"frames", s.frames},
          {"rate", num(s.rate)},
          {"start_time", stamp(s.start_time)},
          {"width", s.width},
          {"height", s.height},
          {"intrinsics",
           {{"fx", num9(s.intrinsics.fx)}, {"fy", num9(s.intrinsics.fy)}, {"cx", num9(s.intrinsics.cx)},
            {"cy", num9(s.intrinsics.cy)}}},
          {"baseline", num(s.baseline)},
          {"depth_factor", 5000},
          {"room",
           {{"size", {num(s.room.size.x()), num(s.room.size.y()), num(s.room.size.z())}},
            {"walls_category_id", 199},
            {"floor_category_id", 190},
            {"ceiling_category_id", 186}}},
          {"objects", std::move(objects)},
          {"people", std::move(people)},
          {"events", std::move(events)}};
}

}  // namespace

std::string writeSequence(const Scenario& s, const std::string& out_dir, const WriteOptions& opt, WriteStats* stats) {
  const auto t_start = std::chrono::steady_clock::now();
  prepareDir(out_dir, opt.overwrite);
  const fs::path root(out_dir);
  for (const char* d : {"rgb", "depth"}) fs::create_directories(root / d);
  if (opt.right) fs::create_directories(root / "right");
  if (opt.labels)
    for (const char* d : {"boxes", "semantic", "panoptic"}) fs::create_directories(root / d);

  RenderOptions ro;
  ro.threads = opt.threads;
  ro.right = opt.right;
  ro.labels = opt.labels;
  Renderer R(s, ro);
  const SceneModel& scene = R.scene();
  const auto& inst = scene.instances();

  std::ostringstream rgb_txt, depth_txt, assoc, times;
  ojson pan_images = ojson::array(), pan_annos = ojson::array();
  const std::string header = "# dslam synth: scenario '" + s.name + "', seed " + std::to_string(s.seed) + "\n";
  rgb_txt << "# color images\n" << header << "# timestamp filename\n";
  depth_txt << "# depth maps (uint16, 5000 per metre)\n" << header << "# timestamp filename\n";
  Trajectory gt;
  // Visible pixels per instance per frame (for objects.json and events).
  std::vector<std::vector<int>> visible(inst.size(), std::vector<int>(static_cast<size_t>(s.frames), 0));
  double render_s = 0;
  log::Progress prog("synth " + s.name, static_cast<size_t>(s.frames), 30);
  for (int f = 0; f < s.frames; f++) {
    const auto t0 = std::chrono::steady_clock::now();
    FrameRender fr = R.render(f);
    render_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::string st = stampName(fr.timestamp);
    rgb_txt << st << " rgb/" << st << ".png\n";
    depth_txt << st << " depth/" << st << ".png\n";
    assoc << st << " rgb/" << st << ".png " << st << " depth/" << st << ".png\n";
    char tb[64];
    std::snprintf(tb, sizeof tb, "%.6e\n", s.time(f));
    times << tb;
    gt.push_back(fr.timestamp, fr.T_wc);
    for (int y = 0; y < fr.instance.rows; y++) {
      const int* p = fr.instance.ptr<int>(y);
      for (int x = 0; x < fr.instance.cols; x++)
        if (p[x] > 0) visible[static_cast<size_t>(p[x])][static_cast<size_t>(f)]++;
    }
    // Images (encoded in parallel; each file is independent).
    std::vector<std::pair<std::string, cv::Mat>> imgs = {{(root / "rgb" / (st + ".png")).string(), fr.rgb},
                                                         {(root / "depth" / (st + ".png")).string(), fr.depth}};
    if (opt.right) imgs.push_back({(root / "right" / (st + ".png")).string(), fr.right});
    if (opt.labels) {
      imgs.push_back({(root / "semantic" / (st + ".png")).string(), fr.semantic});
      imgs.push_back({(root / "panoptic" / (st + ".png")).string(), panopticPng(fr.panoptic)});
    }
    cv::parallel_for_(cv::Range(0, static_cast<int>(imgs.size())), [&](const cv::Range& r) {
      for (int i = r.start; i < r.end; i++) writePng(imgs[static_cast<size_t>(i)].first, imgs[static_cast<size_t>(i)].second);
    });
    if (opt.labels) {
      writeTextFile((root / "boxes" / (st + ".json")).string(), layoutJson(boxesJson(s, f, fr), 2));
      pan_images.push_back({{"id", f},
                            {"file_name", st + ".png"},
                            {"width", s.width},
                            {"height", s.height},
                            {"timestamp", stamp(fr.timestamp)}});
      pan_annos.push_back(panopticAnnotation(f, st, fr));
    }
    if (opt.progress) prog.update(static_cast<size_t>(f + 1));
  }
  if (opt.progress) prog.finish();

  writeTextFile((root / "rgb.txt").string(), rgb_txt.str());
  writeTextFile((root / "depth.txt").string(), depth_txt.str());
  writeTextFile((root / "associations.txt").string(), assoc.str());
  writeTextFile((root / "times.txt").string(), times.str());
  traj::writeTum((root / "groundtruth.txt").string(), gt,
                 "ground truth of dslam synth scenario '" + s.name + "' (camera pose T_wc: tx ty tz qx qy qz qw)");
  if (opt.right) {
    // KITTI-style ground truth (3x4 T_wc per frame, paired with times.txt) so
    // that the folder is also a complete stereo sequence for KittiDataset.
    traj::WriteOptions kw;
    kw.format = traj::Format::Kitti;
    traj::write((root / "poses.txt").string(), gt, kw);
  }
  const CameraModel cam = R.cameraModel();
  writeTextFile((root / "camera.yaml").string(),
                "# Camera of this synthetic sequence (dslam camera section)\n" + config::cameraToYaml(cam));
  if (opt.right) {
    const auto& K = s.intrinsics;
    char b[512];
    std::string calib;
    std::snprintf(b, sizeof b, "P0: %.12e 0.000000000000e+00 %.12e 0.000000000000e+00 0.000000000000e+00 %.12e %.12e "
                               "0.000000000000e+00 0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 "
                               "0.000000000000e+00\n",
                  K.fx, K.cx, K.fy, K.cy);
    calib += b;
    std::snprintf(b, sizeof b, "P1: %.12e 0.000000000000e+00 %.12e %.12e 0.000000000000e+00 %.12e %.12e "
                               "0.000000000000e+00 0.000000000000e+00 0.000000000000e+00 1.000000000000e+00 "
                               "0.000000000000e+00\n",
                  K.fx, K.cx, -K.fx * s.baseline, K.fy, K.cy);
    calib += b;
    writeTextFile((root / "calib.txt").string(), calib);
  }
  if (opt.labels) writeTextFile((root / "panoptic.json").string(), layoutJson(panopticJson(s, pan_images, pan_annos), 2));
  writeTextFile((root / "objects.json").string(), layoutJson(objectsJson(s, scene, visible), 3));

  if (stats) {
    stats->frames = s.frames;
    stats->render_seconds = render_s;
    stats->total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  }
  return out_dir;
}

std::string renderToFolder(const std::string& scenario_file, const std::string& out_dir, const ScenarioOverrides& ov,
                           const WriteOptions& opt) {
  const Scenario s = loadScenario(scenario_file, ov);
  return writeSequence(s, out_dir, opt);
}

std::vector<Box2D> readBoxes(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw DataError("cannot open box file " + file);
  std::vector<Box2D> out;
  try {
    const ojson v = ojson::parse(in);
    for (const ojson& b : v.at("boxes")) {
      Box2D box;
      box.category_id = b.at("category_id").get<int>();
      box.instance_id = b.at("instance_id").get<int>();
      box.name = b.value("name", "");
      const ojson& bb = b.at("bbox");
      box.box = cv::Rect2f(bb.at(0).get<float>(), bb.at(1).get<float>(), bb.at(2).get<float>(), bb.at(3).get<float>());
      box.score = b.at("score").get<float>();
      box.area = b.value("area", box.area);
      out.push_back(box);
    }
  } catch (const nlohmann::json::exception& e) {
    throw DataError(file + ": " + e.what());
  }
  return out;
}

}  // namespace dslam::synth
