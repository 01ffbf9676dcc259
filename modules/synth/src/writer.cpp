#include "dslam/synth/writer.h"

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "dslam/config/camera_yaml.h"
#include "dslam/core/coco.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/core/trajectory.h"
#include "dslam/synth/json.h"
#include "dslam/trajectory/io.h"

namespace fs = std::filesystem;

namespace dslam::synth {

namespace {

std::string stampName(double t) {
  char b[64];
  std::snprintf(b, sizeof b, "%.6f", t);
  return b;
}

std::string num(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

std::string num9(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}

void writeText(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  if (!f) throw DataError("cannot write " + path);
  f << text;
  if (!f) throw DataError("write failed: " + path);
}

void writePng(const std::string& path, const cv::Mat& m) {
  if (!cv::imwrite(path, m, {cv::IMWRITE_PNG_COMPRESSION, 3})) throw DataError("cannot write image " + path);
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

std::string poseJson(int frame, const SE3& T) {
  const auto& q = T.quaternion();
  const auto& t = T.translation();
  std::ostringstream o;
  o << '[' << frame << ", " << num9(t.x()) << ", " << num9(t.y()) << ", " << num9(t.z()) << ", " << num9(q.x()) << ", "
    << num9(q.y()) << ", " << num9(q.z()) << ", " << num9(q.w()) << ']';
  return o.str();
}

bool samePose(const SE3& a, const SE3& b) {
  return (a.translation() - b.translation()).norm() < 1e-9 && a.quaternion().angularDistance(b.quaternion()) < 1e-9;
}

void prepareDir(const std::string& out, bool overwrite) {
  if (fs::exists(out)) {
    if (!fs::is_directory(out)) throw ConfigError("output path exists and is not a folder: " + out);
    if (!fs::is_empty(out)) {
      if (!overwrite) throw ConfigError("output folder already exists: " + out + " (use --overwrite to replace it)");
      // Only replace what looks like an earlier `dslam synth` output.
      if (!fs::exists(fs::path(out) / "objects.json") || !fs::exists(fs::path(out) / "rgb.txt"))
        throw ConfigError("refusing to overwrite " + out +
                          ": it is not a `dslam synth` output (no objects.json / rgb.txt); remove it yourself");
      fs::remove_all(out);
    }
  }
  fs::create_directories(out);
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

  std::ostringstream rgb_txt, depth_txt, assoc, times, pan_images, pan_annos;
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
      std::ostringstream bj;
      bj << "{\"frame\": " << f << ", \"timestamp\": " << st << ", \"width\": " << s.width << ", \"height\": " << s.height
         << ", \"boxes\": [";
      for (size_t i = 0; i < fr.boxes.size(); i++) {
        const Box2D& b = fr.boxes[i];
        bj << (i ? ",\n  " : "\n  ") << "{\"category_id\": " << b.category_id << ", \"category\": "
           << json::quote(coco::name(b.category_id)) << ", \"instance_id\": " << b.instance_id
           << ", \"name\": " << json::quote(b.name) << ", \"bbox\": [" << b.box.x << ", " << b.box.y << ", " << b.box.width
           << ", " << b.box.height << "], \"area\": " << b.area << ", \"score\": 1.0}";
      }
      bj << (fr.boxes.empty() ? "]}\n" : "\n]}\n");
      writeText((root / "boxes" / (st + ".json")).string(), bj.str());
      pan_images << (f ? ",\n    " : "\n    ") << "{\"id\": " << f << ", \"file_name\": \"" << st << ".png\", \"width\": "
                 << s.width << ", \"height\": " << s.height << ", \"timestamp\": " << st << "}";
      pan_annos << (f ? ",\n    " : "\n    ") << "{\"image_id\": " << f << ", \"file_name\": \"" << st
                << ".png\", \"segments_info\": [";
      for (size_t i = 0; i < fr.segments.size(); i++) {
        const Segment& sg = fr.segments[i];
        pan_annos << (i ? ", " : "") << "{\"id\": " << sg.id << ", \"category_id\": " << sg.category_id
                  << ", \"iscrowd\": 0, \"bbox\": [" << sg.bbox.x << ", " << sg.bbox.y << ", " << sg.bbox.width << ", "
                  << sg.bbox.height << "], \"area\": " << sg.area;
        if (sg.instance_id > 0) pan_annos << ", \"instance_id\": " << sg.instance_id;
        pan_annos << "}";
      }
      pan_annos << "]}";
    }
    if (opt.progress) prog.update(static_cast<size_t>(f + 1));
  }
  if (opt.progress) prog.finish();

  writeText((root / "rgb.txt").string(), rgb_txt.str());
  writeText((root / "depth.txt").string(), depth_txt.str());
  writeText((root / "associations.txt").string(), assoc.str());
  writeText((root / "times.txt").string(), times.str());
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
  writeText((root / "camera.yaml").string(),
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
    writeText((root / "calib.txt").string(), calib);
  }
  if (opt.labels) {
    std::ostringstream pj;
    pj << "{\n  \"info\": {\"description\": " << json::quote("dslam synth scenario " + s.name)
       << ", \"version\": \"1.0\"},\n  \"licenses\": [],\n  \"images\": [" << pan_images.str() << "\n  ],\n  \"annotations\": ["
       << pan_annos.str() << "\n  ],\n  \"categories\": [";
    bool first = true;
    for (const auto& c : coco::categories()) {
      pj << (first ? "\n    " : ",\n    ") << "{\"id\": " << c.id << ", \"name\": " << json::quote(c.name)
         << ", \"supercategory\": " << json::quote(c.isthing ? "thing" : "stuff") << ", \"isthing\": " << (c.isthing ? 1 : 0)
         << ", \"color\": [" << (c.id * 37) % 256 << ", " << (c.id * 91) % 256 << ", " << (c.id * 53) % 256 << "]}";
      first = false;
    }
    pj << "\n  ]\n}\n";
    writeText((root / "panoptic.json").string(), pj.str());
  }

  // objects.json: classes, sizes, poses over time, visibility, events.
  std::ostringstream oj;
  oj << "{\n  \"scenario\": " << json::quote(s.name) << ",\n  \"source\": " << json::quote(s.file) << ",\n  \"seed\": " << s.seed
     << ",\n  \"frames\": " << s.frames << ",\n  \"rate\": " << num(s.rate) << ",\n  \"start_time\": " << stampName(s.start_time)
     << ",\n  \"width\": " << s.width << ",\n  \"height\": " << s.height << ",\n  \"intrinsics\": {\"fx\": " << num9(s.intrinsics.fx)
     << ", \"fy\": " << num9(s.intrinsics.fy) << ", \"cx\": " << num9(s.intrinsics.cx) << ", \"cy\": " << num9(s.intrinsics.cy)
     << "},\n  \"baseline\": " << num(s.baseline) << ",\n  \"depth_factor\": 5000,\n  \"room\": {\"size\": [" << num(s.room.size.x())
     << ", " << num(s.room.size.y()) << ", " << num(s.room.size.z())
     << "], \"walls_category_id\": 199, \"floor_category_id\": 190, \"ceiling_category_id\": 186},\n  \"objects\": [";
  auto rangesJson = [&](const std::vector<char>& on) {
    std::string r = "[";
    int a = -1;
    bool firstr = true;
    for (int f = 0; f <= s.frames; f++) {
      const bool v = f < s.frames && on[static_cast<size_t>(f)];
      if (v && a < 0) a = f;
      if (!v && a >= 0) {
        r += (firstr ? "[" : ", [") + std::to_string(a) + ", " + std::to_string(f - 1) + "]";
        firstr = false;
        a = -1;
      }
    }
    return r + "]";
  };
  auto visJson = [&](int iid) {
    std::ostringstream r;
    r << '[';
    for (int f = 0; f < s.frames; f++) r << (f ? "," : "") << visible[static_cast<size_t>(iid)][static_cast<size_t>(f)];
    r << ']';
    return r.str();
  };
  for (size_t i = 0; i < s.objects.size(); i++) {
    const ObjectSpec& o = s.objects[i];
    std::vector<char> on(static_cast<size_t>(s.frames));
    std::string track;
    SE3 last;
    bool have = false;
    for (int f = 0; f < s.frames; f++) {
      const ObjectState st = scene.objectState(i, f);
      on[static_cast<size_t>(f)] = st.present;
      if (st.present && (!have || !samePose(st.T_wo, last))) {
        track += (track.empty() ? "\n      " : ",\n      ") + poseJson(f, st.T_wo);
        last = st.T_wo;
        have = true;
      }
    }
    oj << (i ? ",\n    " : "\n    ") << "{\"instance_id\": " << o.instance_id << ", \"name\": " << json::quote(o.name)
       << ", \"kind\": \"object\", \"type\": " << json::quote(o.type) << ", \"class\": " << json::quote(o.class_name)
       << ", \"category_id\": " << o.category_id << ", \"labelled\": " << (o.labelled ? "true" : "false")
       << ", \"isthing\": " << (scene.instances()[static_cast<size_t>(o.instance_id)].isthing ? "true" : "false")
       << ", \"panoptic_id\": " << panopticId(scene.instances()[static_cast<size_t>(o.instance_id)]) << ", \"size\": ["
       << num(o.size.x()) << ", " << num(o.size.y()) << ", " << num(o.size.z()) << "], \"moving\": "
       << (o.path.empty() ? "false" : "true") << ",\n     \"present\": " << rangesJson(on)
       << ",\n     \"track\": [" << track << "],\n     \"visible_pixels\": " << visJson(o.instance_id) << "}";
  }
  oj << "\n  ],\n  \"people\": [";
  for (size_t i = 0; i < s.people.size(); i++) {
    const PersonSpec& p = s.people[i];
    std::vector<char> on(static_cast<size_t>(s.frames));
    std::string track;
    for (int f = 0; f < s.frames; f++) {
      on[static_cast<size_t>(f)] = scene.personPresent(i, f);
      if (on[static_cast<size_t>(f)])
        track += (track.empty() ? "\n      " : ",\n      ") + poseJson(f, scene.personRoot(i, s.time(f)));
    }
    oj << (i ? ",\n    " : "\n    ") << "{\"instance_id\": " << p.instance_id << ", \"name\": " << json::quote(p.name)
       << ", \"kind\": \"person\", \"action\": " << json::quote(p.action)
       << ", \"class\": \"person\", \"category_id\": 1, \"labelled\": true, \"isthing\": true, \"panoptic_id\": "
       << 1000 + p.instance_id << ", \"height\": " << num(p.height) << ",\n     \"present\": " << rangesJson(on)
       << ",\n     \"track_frame\": \"pelvis (x forward, z up)\",\n     \"track\": [" << track
       << "],\n     \"visible_pixels\": " << visJson(p.instance_id) << "}";
  }
  oj << "\n  ],\n  \"events\": [";
  for (size_t i = 0; i < s.events.size(); i++) {
    const EventSpec& e = s.events[i];
    const ObjectSpec* a = s.findObject(e.object);
    const ObjectSpec* b = e.by.empty() ? nullptr : s.findObject(e.by);
    // Visibility of the objects concerned during the change (frames first-1 .. last).
    int vis = 0;
    for (int f = std::max(0, e.first - 1); f <= e.last; f++) {
      vis += visible[static_cast<size_t>(a->instance_id)][static_cast<size_t>(f)];
      if (b) vis += visible[static_cast<size_t>(b->instance_id)][static_cast<size_t>(f)];
    }
    oj << (i ? ",\n    " : "\n    ") << "{\"type\": " << json::quote(e.type) << ", \"object\": " << json::quote(e.object)
       << ", \"instance_id\": " << a->instance_id;
    if (b) oj << ", \"by\": " << json::quote(e.by) << ", \"by_instance_id\": " << b->instance_id;
    oj << ", \"frames\": [" << e.first << ", " << e.last << "], \"timestamps\": [" << stampName(s.stamp(e.first)) << ", "
       << stampName(s.stamp(e.last)) << "]";
    if (e.type == "moved")
      oj << ", \"to\": [" << num(e.position.x()) << ", " << num(e.position.y()) << ", " << num(e.position.z()) << "]";
    oj << ", \"visible_pixels_during\": " << vis << ", \"in_view\": " << (vis > 0 ? "true" : "false") << "}";
  }
  oj << "\n  ]\n}\n";
  writeText((root / "objects.json").string(), oj.str());

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
  const json::Value v = json::parseFile(file);
  std::vector<Box2D> out;
  const json::Value& arr = v["boxes"];
  for (size_t i = 0; i < arr.size(); i++) {
    const json::Value& b = arr[i];
    Box2D box;
    box.category_id = b["category_id"].integer();
    box.instance_id = b["instance_id"].integer();
    if (b.has("name")) box.name = b["name"].string();
    const json::Value& bb = b["bbox"];
    box.box = cv::Rect2f(static_cast<float>(bb[0].number()), static_cast<float>(bb[1].number()),
                         static_cast<float>(bb[2].number()), static_cast<float>(bb[3].number()));
    box.score = static_cast<float>(b["score"].number());
    if (b.has("area")) box.area = b["area"].integer();
    out.push_back(box);
  }
  return out;
}

}  // namespace dslam::synth
