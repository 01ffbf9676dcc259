#include "dslam/eval/objects.h"

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "dslam/core/coco.h"
#include "dslam/core/error.h"
#include "dslam/core/format.h"
#include "dslam/core/json_layout.h"
#include "dslam/core/object_confirmed.h"
#include "dslam/core/png.h"
#include "dslam/trajectory/io.h"

namespace fs = std::filesystem;
using json = nlohmann::json;
using ojson = nlohmann::ordered_json;

namespace dslam::eval {

// ------------------------------------------------------------------ box --

Eigen::Vector3d ObjectBox::centre() const { return T_wo * Eigen::Vector3d(0, 0, 0.5 * size.z()); }

double ObjectBox::distance(const Eigen::Vector3d& p) const {
  const Eigen::Vector3d q = T_wo.inverse() * p - Eigen::Vector3d(0, 0, 0.5 * size.z());
  const Eigen::Vector3d d = (q.cwiseAbs() - 0.5 * size).cwiseMax(0.0);
  return d.norm();
}

namespace {


std::string describe(const json& v) {
  std::string t = v.dump();
  if (t.size() > 60) t = t.substr(0, 60) + "...";
  return t;
}


/** Typed access with errors naming the file and the element. */
struct At {
  const std::string& file;
  std::string where;  ///< e.g. "objects[3] (id 7)"
  [[noreturn]] void fail(const std::string& what) const {
    throw DataError(file + ": " + (where.empty() ? "" : where + ": ") + what);
  }
  const json& need(const json& o, const char* key) const {
    if (!o.is_object() || !o.contains(key)) fail(std::string("missing '") + key + "'");
    return o.at(key);
  }
  double number(const json& v, const char* key) const {
    if (!v.is_number() || !std::isfinite(v.get<double>()))
      fail(std::string("'") + key + "' must be a number, got " + describe(v));
    return v.get<double>();
  }
  int64_t integer(const json& v, const char* key) const {
    if (!v.is_number_integer()) fail(std::string("'") + key + "' must be an integer, got " + describe(v));
    return v.get<int64_t>();
  }
  bool boolean(const json& v, const char* key) const {
    if (!v.is_boolean()) fail(std::string("'") + key + "' must be true or false, got " + describe(v));
    return v.get<bool>();
  }
  std::string string(const json& v, const char* key) const {
    if (!v.is_string()) fail(std::string("'") + key + "' must be a string, got " + describe(v));
    return v.get<std::string>();
  }
  Eigen::Vector3d vec3(const json& v, const char* key) const {
    if (!v.is_array() || v.size() != 3) fail(std::string("'") + key + "' must be [x, y, z], got " + describe(v));
    return {number(v[0], key), number(v[1], key), number(v[2], key)};
  }
  double number(const json& o, const char* key, double def) const { return o.contains(key) ? number(o[key], key) : def; }
  int64_t integer(const json& o, const char* key, int64_t def) const {
    return o.contains(key) ? integer(o[key], key) : def;
  }
};

}  // namespace

// ------------------------------------------------------ estimated objects --

EstObjects readEstObjects(const std::string& file) {
  if (fs::is_directory(file)) throw DataError(file + " is a folder, not an objects file");
  if (!fs::exists(file)) throw DataError("objects file not found: " + file);
  const json root = parseJsonFile(file);
  const At top{file, ""};
  if (!root.is_object()) top.fail("expected a JSON object {\"format\": \"dslam-objects\", ...}, got " + describe(root));
  if (!root.contains("format") && root.contains("scenario") && root.contains("objects"))
    top.fail("this is the ground-truth objects.json of the dslam synth scene '" +
             (root["scenario"].is_string() ? root["scenario"].get<std::string>() : root["scenario"].dump()) +
             "', not a run's object map (format \"dslam-objects\"): give the run folder (or its objects.json) "
             "first and the scene folder second");
  if (!root.contains("format") || root["format"] != "dslam-objects")
    top.fail("not a dslam object map: 'format' is " + (root.contains("format") ? describe(root["format"]) : "missing") +
             ", expected \"dslam-objects\" (written by dslam run --out)");
  const int64_t version = top.integer(top.need(root, "version"), "version");
  if (version != 1) top.fail("unsupported version " + std::to_string(version) + " (this dslam reads version 1)");
  EstObjects out;
  out.file = file;
  out.map = static_cast<int>(top.integer(top.need(root, "map"), "map"));
  const json& objs = top.need(root, "objects");
  if (!objs.is_array()) top.fail("'objects' must be a list, got " + describe(objs));
  for (size_t i = 0; i < objs.size(); i++) {
    const json& o = objs[i];
    At at{file, "objects[" + std::to_string(i) + "]"};
    if (!o.is_object()) at.fail("expected an object, got " + describe(o));
    EstObject e;
    e.id = at.integer(at.need(o, "id"), "id");
    at.where += " (id " + std::to_string(e.id) + ")";
    e.map = static_cast<int>(at.integer(o, "map", out.map));
    if (o.contains("class_id")) {
      e.class_id = static_cast<int>(at.integer(o["class_id"], "class_id"));
      if (!coco::find(e.class_id))
        at.fail("unknown class id " + std::to_string(e.class_id) + " (not a COCO category id, see dslam/core/coco.h)");
      if (o.contains("class")) {
        const std::string name = at.string(o["class"], "class");
        if (name != coco::name(e.class_id))
          at.fail("class '" + name + "' is not the name of class id " + std::to_string(e.class_id) + " ('" +
                  coco::name(e.class_id) + "')");
      }
    } else if (o.contains("class")) {
      const std::string name = at.string(o["class"], "class");
      e.class_id = coco::idFromName(name);
      if (e.class_id < 0) at.fail("unknown class '" + name + "' (not a COCO category name)");
    } else {
      at.fail("missing 'class_id'");
    }
    e.centroid = at.vec3(at.need(o, "centroid"), "centroid");
    e.box_min = o.contains("box_min") ? at.vec3(o["box_min"], "box_min") : e.centroid;
    e.box_max = o.contains("box_max") ? at.vec3(o["box_max"], "box_max") : e.centroid;
    e.active = at.boolean(at.need(o, "active"), "active");
    e.dormant = o.contains("dormant") && at.boolean(o["dormant"], "dormant");
    e.points = static_cast<int>(at.integer(o, "points", 0));
    e.belief = at.number(o, "belief", e.active ? 1.0 : 0.0);
    e.first_seen_kf = at.integer(o, "first_seen_kf", -1);
    e.last_seen_kf = at.integer(o, "last_seen_kf", -1);
    e.first_seen_t = at.number(o, "first_seen_t", 0.0);
    e.last_seen_t = at.number(o, "last_seen_t", 0.0);
    e.sightings = static_cast<int>(at.integer(o, "sightings", -1));
    for (int k = 0; k < 3; k++)
      if (e.box_min[k] > e.box_max[k])
        at.fail("box_min is above box_max on axis " + std::string(1, "xyz"[k]) + " (" + std::to_string(e.box_min[k]) +
                " > " + std::to_string(e.box_max[k]) + ")");
    if (e.points < 0) at.fail("'points' must be >= 0, got " + std::to_string(e.points));
    for (const auto& prev : out.objects)
      if (prev.id == e.id && prev.map == e.map)
        at.fail("id " + std::to_string(e.id) + " appears twice in map " + std::to_string(e.map));
    out.objects.push_back(e);
  }
  return out;
}

// --------------------------------------------------------- scene truth --

bool SceneObject::presentAt(int frame) const {
  for (const auto& r : present)
    if (frame >= r.first && frame <= r.second) return true;
  return false;
}

SE3 SceneObject::poseAt(int frame) const {
  if (track.empty()) return SE3();
  SE3 T = track.front().second;
  for (const auto& [f, P] : track)
    if (f <= frame) T = P;
  return T;
}

int64_t SceneObject::visibleIn(int first, int last) const {
  int64_t s = 0;
  for (int f = std::max(0, first); f <= last && f < static_cast<int>(visible_pixels.size()); f++)
    s += visible_pixels[static_cast<size_t>(f)];
  return s;
}

const SceneObject* Scene::find(const std::string& n) const {
  for (const auto& o : objects)
    if (o.name == n) return &o;
  return nullptr;
}

namespace {

/** Intrinsics, depth factor and depth.txt of a scene (SceneDepth); left
 *  empty when any is missing (older scenes). A depth.txt whose lines are not
 *  "timestamp path", or that lists another number of frames, is an error. */
void readSceneDepth(const std::string& dir, const json& root, const At& top, Scene& s) {
  const std::string list = (fs::path(dir) / "depth.txt").string();
  if (!fs::exists(list) || !root.contains("intrinsics") || !root.contains("depth_factor")) return;
  const json& k = root["intrinsics"];
  if (!k.is_object()) top.fail("'intrinsics' must be {fx, fy, cx, cy}");
  SceneDepth d;
  d.fx = top.number(top.need(k, "fx"), "intrinsics.fx");
  d.fy = top.number(top.need(k, "fy"), "intrinsics.fy");
  d.cx = top.number(top.need(k, "cx"), "intrinsics.cx");
  d.cy = top.number(top.need(k, "cy"), "intrinsics.cy");
  d.depth_factor = top.number(root["depth_factor"], "depth_factor");
  if (!(d.fx > 0) || !(d.fy > 0) || !(d.depth_factor > 0)) top.fail("intrinsics and depth_factor must be positive");
  std::ifstream in(list);
  std::string line;
  for (int n = 1; std::getline(in, line); n++) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    double t = 0;
    std::string path;
    if (!(ls >> t >> path)) throw DataError(list + ":" + std::to_string(n) + ": expected 'timestamp path', got '" + line + "'");
    d.files.push_back(path);
  }
  if (static_cast<int>(d.files.size()) != s.frames)
    throw DataError(list + ": " + std::to_string(d.files.size()) + " depth maps for the " + std::to_string(s.frames) +
                    " frames of objects.json");
  s.depth = std::move(d);
}

}  // namespace

Scene readScene(const std::string& dir) {
  if (!fs::exists(dir)) throw DataError("scene folder not found: " + dir);
  if (!fs::is_directory(dir))
    throw DataError(dir + " is not a scene folder (give the folder written by dslam synth ... --out DIR)");
  const std::string file = (fs::path(dir) / "objects.json").string();
  const std::string gt_file = (fs::path(dir) / "groundtruth.txt").string();
  if (!fs::exists(file))
    throw DataError(dir + ": no objects.json (the scene ground truth written by dslam synth; is this a scene folder?)");
  const json root = parseJsonFile(file);
  const At top{file, ""};
  if (!root.is_object()) top.fail("expected a JSON object, got " + describe(root));
  if (root.contains("format") && root["format"] == "dslam-objects")
    top.fail("this is a run's object map (\"dslam-objects\"), not a scene's ground truth: give the run first and the "
             "scene folder (written by dslam synth) second");
  if (!fs::exists(gt_file)) throw DataError(dir + ": no groundtruth.txt (the camera ground truth of the scene)");
  Scene s;
  s.dir = dir;
  s.name = root.contains("scenario") && root["scenario"].is_string() ? root["scenario"].get<std::string>() : "";
  s.frames = static_cast<int>(top.integer(top.need(root, "frames"), "frames"));
  const json& objs = top.need(root, "objects");
  if (!objs.is_array()) top.fail("'objects' must be a list, got " + describe(objs));
  for (size_t i = 0; i < objs.size(); i++) {
    const json& o = objs[i];
    At at{file, "objects[" + std::to_string(i) + "]"};
    if (!o.is_object()) at.fail("expected an object, got " + describe(o));
    SceneObject so;
    so.instance_id = static_cast<int>(at.integer(at.need(o, "instance_id"), "instance_id"));
    so.name = at.string(at.need(o, "name"), "name");
    at.where += " ('" + so.name + "')";
    so.type = o.contains("type") ? at.string(o["type"], "type") : "";
    so.cls = at.string(at.need(o, "class"), "class");
    so.category_id = static_cast<int>(at.integer(at.need(o, "category_id"), "category_id"));
    so.labelled = at.boolean(at.need(o, "labelled"), "labelled");
    so.moving = o.contains("moving") && at.boolean(o["moving"], "moving");
    so.size = at.vec3(at.need(o, "size"), "size");
    for (const json& r : at.need(o, "present")) {
      if (!r.is_array() || r.size() != 2) at.fail("'present' must be a list of [first, last] frame ranges");
      so.present.emplace_back(static_cast<int>(at.integer(r[0], "present")), static_cast<int>(at.integer(r[1], "present")));
    }
    for (const json& t : at.need(o, "track")) {
      if (!t.is_array() || t.size() != 8) at.fail("'track' entries must be [frame, tx, ty, tz, qx, qy, qz, qw]");
      const Eigen::Quaterniond q(at.number(t[7], "track"), at.number(t[4], "track"), at.number(t[5], "track"),
                                 at.number(t[6], "track"));
      if (q.norm() < 1e-9) at.fail("'track' has a zero quaternion");
      so.track.emplace_back(static_cast<int>(at.integer(t[0], "track")),
                            SE3(q, Eigen::Vector3d(at.number(t[1], "track"), at.number(t[2], "track"),
                                                   at.number(t[3], "track"))));
    }
    const json& vis = at.need(o, "visible_pixels");
    if (!vis.is_array()) at.fail("'visible_pixels' must be a list");
    for (const json& v : vis) so.visible_pixels.push_back(static_cast<int>(at.integer(v, "visible_pixels")));
    s.objects.push_back(std::move(so));
  }
  if (root.contains("events")) {
    const json& evs = root["events"];
    if (!evs.is_array()) top.fail("'events' must be a list");
    for (size_t i = 0; i < evs.size(); i++) {
      const json& e = evs[i];
      At at{file, "events[" + std::to_string(i) + "]"};
      SceneEvent ev;
      ev.type = at.string(at.need(e, "type"), "type");
      ev.object = at.string(at.need(e, "object"), "object");
      if (e.contains("by")) ev.by = at.string(e["by"], "by");
      const json& fr = at.need(e, "frames");
      const json& ts = at.need(e, "timestamps");
      if (!fr.is_array() || fr.size() != 2 || !ts.is_array() || ts.size() != 2)
        at.fail("'frames' and 'timestamps' must be [first, last]");
      ev.first = static_cast<int>(at.integer(fr[0], "frames"));
      ev.last = static_cast<int>(at.integer(fr[1], "frames"));
      ev.t_first = at.number(ts[0], "timestamps");
      ev.t_last = at.number(ts[1], "timestamps");
      if (!s.find(ev.object)) at.fail("unknown object '" + ev.object + "'");
      s.events.push_back(ev);
    }
  }
  s.gt = traj::readTum(gt_file);
  if (s.gt.empty()) throw DataError(gt_file + ": no poses");
  readSceneDepth(dir, root, top, s);
  return s;
}

// ---------------------------------------------------------- evaluation --

const char* toString(Fate f) {
  switch (f) {
    case Fate::Static: return "static";
    case Fate::Moved: return "moved";
    case Fate::Added: return "added";
    case Fate::Removed: return "removed";
    case Fate::Replaced: return "replaced";
    case Fate::Other: return "other";
  }
  return "?";
}

const char* toString(Verdict v) {
  switch (v) {
    case Verdict::Match: return "match";
    case Verdict::DontCare: return "dont-care";
    case Verdict::Stale: return "stale";
    case Verdict::False: return "false";
    case Verdict::Inactive: return "inactive";
    case Verdict::Ignored: return "ignored";
  }
  return "?";
}

namespace {

/** Classes of the evaluation: COCO things other than person. */
bool evaluatedClass(int id) { return id != coco::kPerson && coco::isThing(id); }

/** First frame of the stay that contains `frame` (at the pose it has then). */
int residenceStart(const SceneObject& o, int frame) {
  int start = 0;
  for (const auto& r : o.present)
    if (frame >= r.first && frame <= r.second) start = r.first;
  for (const auto& [f, T] : o.track)
    if (f <= frame) start = std::max(start, f);
  return start;
}

double rmse(const std::vector<double>& e) {
  if (e.empty()) return 0;
  double s = 0;
  for (double v : e) s += v * v;
  return std::sqrt(s / static_cast<double>(e.size()));
}

void alignRun(const Scene& scene, const Trajectory& traj, const ObjectEvalOptions& opt, ObjectEvalResult& r) {
  r.align_until = std::isnan(opt.align_until) ? std::numeric_limits<double>::infinity() : opt.align_until;
  if (std::isnan(opt.align_until))
    for (const auto& e : scene.events) r.align_until = std::min(r.align_until, e.t_first);
  r.alignment.method = opt.align;
  if (traj.empty()) {
    if (opt.align != Align::None)
      throw DataError(opt.run_name + ": no trajectory to align the objects with (use --align none if they are already "
                                     "in the ground-truth frame)");
    return;
  }
  const std::string gt_name = (fs::path(scene.dir) / "groundtruth.txt").string();
  const std::string mismatch = "the run and the scene do not match: ";
  Association a;
  try {
    a = associate(scene.gt, traj, opt.max_dt, gt_name, r.traj_file);
  } catch (const DataError& e) {
    throw DataError(mismatch + e.what());
  }
  r.traj_poses = traj.size();
  r.assoc_pairs = a.size();
  if (2 * a.size() < traj.size())
    throw DataError(mismatch + "only " + std::to_string(a.size()) + " of the " + std::to_string(traj.size()) +
                    " poses of " + r.traj_file + " have a ground-truth pose of " + gt_name + " within " +
                    formatNumber("%g", opt.max_dt) + " s");
  std::vector<Eigen::Vector3d> est_p, gt_p;
  for (const auto& [gi, ei] : a.pairs)
    if (scene.gt.stamps[gi] < r.align_until) {
      est_p.push_back(traj.poses[ei].translation());
      gt_p.push_back(scene.gt.poses[gi].translation());
    }
  r.align_pairs = est_p.size();
  if (opt.align != Align::None && est_p.size() < 3)
    throw DataError(r.traj_file + ": only " + std::to_string(est_p.size()) + " trajectory poses before " +
                    formatNumber("%.3f", r.align_until) +
                    " s (the first change event) to align on, 3 needed (set --align-until or --align none)");
  r.alignment = alignPoints(est_p, gt_p, opt.align);
  std::vector<double> ea, eall;
  for (const auto& [gi, ei] : a.pairs) {
    const double d = (r.alignment.apply(traj.poses[ei].translation()) - scene.gt.poses[gi].translation()).norm();
    eall.push_back(d);
    if (scene.gt.stamps[gi] < r.align_until) ea.push_back(d);
  }
  r.align_ate = rmse(ea);
  r.ate = rmse(eall);
  if (r.align_ate > opt.max_ate)
    throw DataError(mismatch + "ATE rmse " + formatNumber("%.3f", r.align_ate) + " m on " + std::to_string(ea.size()) +
                    " poses of " + r.traj_file + " after " + toString(opt.align) + " alignment to " + gt_name +
                    " (more than --max-ate " + formatNumber("%g", opt.max_ate) + " m)");
}

/** Fills OldPlace::seen_after from the scene's ground-truth depth maps (one
 *  read per frame after the first departure); false (left at -1) when the
 *  scene has no depth or its ground truth is not one pose per frame. */
bool placesSeenAfter(const Scene& scene, std::vector<GtObjectResult>& gt) {
  const SceneDepth& d = scene.depth;
  if (d.files.empty() || static_cast<int>(scene.gt.size()) != scene.frames) return false;
  struct Samples {
    GtObjectResult::OldPlace* place;
    std::vector<Eigen::Vector3d> Xw;
  };
  std::vector<Samples> places;
  int first = scene.frames;
  for (auto& g : gt)
    for (auto& p : g.old_places) {
      Samples s{&p, {}};
      for (int i = 0; i < 5; i++)
        for (int j = 0; j < 5; j++)
          for (int k = 0; k < 5; k++)  // the box: size around (0, 0, size.z / 2) in the object frame
            s.Xw.push_back(p.box.T_wo * Eigen::Vector3d((i - 2) * 0.2 * p.box.size.x(), (j - 2) * 0.2 * p.box.size.y(),
                                                        (0.1 + 0.2 * k) * p.box.size.z()));
      p.seen_after = 0;
      first = std::min(first, p.left_at + 1);
      places.push_back(std::move(s));
    }
  for (int f = first; f < scene.frames && !places.empty(); f++) {
    const std::string file = (fs::path(scene.dir) / d.files[static_cast<size_t>(f)]).string();
    std::string damage;
    const cv::Mat depth = readImageFile(file, cv::IMREAD_UNCHANGED, &damage);
    if (depth.empty() || depth.type() != CV_16UC1)
      throw DataError(file + ": " + (damage.empty() ? std::string("not a 16-bit depth map") : damage) +
                      " (depth.txt of the scene, frame " + std::to_string(f) + ")");
    const SE3 T_cw = scene.gt.poses[static_cast<size_t>(f)].inverse();
    for (Samples& s : places) {
      if (f <= s.place->left_at) continue;
      int seen = 0;
      for (const Eigen::Vector3d& X : s.Xw) {
        const Eigen::Vector3d Xc = T_cw * X;
        if (Xc.z() < 0.1) continue;
        const int u = static_cast<int>(std::lround(d.fx * Xc.x() / Xc.z() + d.cx));
        const int v = static_cast<int>(std::lround(d.fy * Xc.y() / Xc.z() + d.cy));
        if (u < 0 || v < 0 || u >= depth.cols || v >= depth.rows) continue;
        const double z = depth.at<uint16_t>(v, u) / d.depth_factor;
        seen += z > 0 && z >= Xc.z() - 0.1;
      }
      s.place->seen_after = std::max(s.place->seen_after, seen / static_cast<double>(s.Xw.size()));
    }
  }
  return true;
}

}  // namespace

ObjectEvalResult evaluateObjects(const Scene& scene, const EstObjects& est, const Trajectory& traj,
                                 const ObjectEvalOptions& opt) {
  ObjectEvalResult r;
  r.options = opt;
  r.run_file = est.file;
  r.scene_dir = scene.dir;
  r.map = est.map;
  r.traj_file = opt.traj_name;
  if (!(opt.match_radius > 0)) throw ConfigError("match radius must be positive");
  if (!(opt.on_object_margin >= 0)) throw ConfigError("on-object margin must not be negative");
  alignRun(scene, traj, opt, r);

  // Ground truth.
  const int last = scene.frames - 1;
  for (const SceneObject& o : scene.objects) {
    GtObjectResult g;
    g.instance_id = o.instance_id;
    g.name = o.name;
    g.cls = o.cls;
    g.category_id = o.category_id;
    g.at_end = o.presentAt(last);
    std::vector<const SceneEvent*> evs;
    for (const auto& e : scene.events)
      if (e.object == o.name || e.by == o.name) evs.push_back(&e);
    std::stable_sort(evs.begin(), evs.end(), [](auto* a, auto* b) { return a->first < b->first; });
    const bool evaluated = o.labelled && evaluatedClass(o.category_id) && !o.moving && !o.track.empty();
    if (!evaluated) {
      g.fate = Fate::Other;
    } else if (g.at_end) {
      g.fate = o.presentAt(0) ? Fate::Static : Fate::Added;
      for (const SceneEvent* e : evs)
        if (e->type == "moved" && g.fate == Fate::Static) g.fate = Fate::Moved;
    } else {
      g.fate = Fate::Removed;
      for (const SceneEvent* e : evs)
        if (e->object == o.name && e->type == "replaced") g.fate = Fate::Replaced;
    }
    if (g.at_end) {
      g.box = {o.poseAt(last), o.size};
      g.seen_at_end = o.visibleIn(residenceStart(o, last), last);
      g.counted = g.fate != Fate::Other && g.seen_at_end >= opt.min_visible_pixels;
    }
    if (evaluated)
      for (const SceneEvent* e : evs) {
        if (e->object != o.name || (e->type != "moved" && e->type != "removed" && e->type != "replaced")) continue;
        const int f = e->first - 1;
        if (f < 0 || !o.presentAt(f)) continue;
        GtObjectResult::OldPlace p;
        p.box = {o.poseAt(f), o.size};
        p.frame = f;
        p.seen = o.visibleIn(residenceStart(o, f), f);
        p.counted = p.seen >= opt.min_visible_pixels;
        p.left_at = e->last;
        p.left_t = e->t_last;
        g.old_places.push_back(p);
      }
    r.gt.push_back(std::move(g));
  }

  if (opt.place_seen_fraction > 0) r.place_visibility = placesSeenAfter(scene, r.gt);

  // Estimated objects of the map, in the ground-truth frame.
  r.est_in_file = est.objects.size();
  for (const EstObject& e0 : est.objects) {
    if (e0.map != est.map) {
      r.est_other_maps++;
      continue;
    }
    if (e0.points < opt.min_points) {
      r.est_too_few_points++;
      continue;
    }
    if (opt.min_sightings > 1) {
      if (e0.sightings < 0)
        throw DataError(est.file + ": object " + std::to_string(e0.id) +
                        " has no 'sightings' (--min-sightings needs them; leave it out for this file)");
      if (!objectConfirmed(e0.sightings, static_cast<size_t>(std::max(0, e0.points)), opt.min_sightings,
                           static_cast<size_t>(std::max(0, opt.confirm_points)))) {
        r.est_too_few_sightings++;
        continue;
      }
    }
    EstObjectResult e;
    e.obj = e0;
    e.obj.centroid = r.alignment.apply(e0.centroid);
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
    for (int c = 0; c < 8; c++) {
      const Eigen::Vector3d p((c & 1 ? e0.box_max : e0.box_min).x(), (c & 2 ? e0.box_max : e0.box_min).y(),
                              (c & 4 ? e0.box_max : e0.box_min).z());
      lo = lo.cwiseMin(r.alignment.apply(p));
      hi = hi.cwiseMax(r.alignment.apply(p));
    }
    e.obj.box_min = lo;
    e.obj.box_max = hi;
    if (!evaluatedClass(e0.class_id)) e.note = "class " + coco::name(e0.class_id) + " is not evaluated";
    r.est.push_back(std::move(e));
  }
  for (const auto& e : r.est)
    if (e.note.empty()) r.est_evaluated++;

  // Old places by class.
  struct Place {
    size_t g, p;
  };
  auto oldPlaces = [&](int cls) {
    std::vector<Place> out;
    for (size_t gi = 0; gi < r.gt.size(); gi++)
      if (r.gt[gi].category_id == cls)
        for (size_t pi = 0; pi < r.gt[gi].old_places.size(); pi++) out.push_back({gi, pi});
    return out;
  };
  // The place a same-class object left that is nearest to e (g == npos:
  // none). Places left before e was first seen do not count: an estimate
  // made of what the camera saw there after the object had gone is no
  // memory of it (a wrong class on what is there now: false, not stale).
  auto nearestOld = [&](const EstObjectResult& e, double& d_out) {
    Place best{std::string::npos, 0};
    d_out = std::numeric_limits<double>::infinity();
    for (const Place& p : oldPlaces(e.obj.class_id)) {
      if (e.obj.first_seen_t > r.gt[p.g].old_places[p.p].left_t) continue;
      const double d = r.gt[p.g].old_places[p.p].box.distance(e.obj.centroid);
      if (d < d_out) {
        d_out = d;
        best = p;
      }
    }
    return best;
  };

  // Matching: active estimated objects to objects present at the end.
  struct Cand {
    double d, dc;
    size_t g, e;
  };
  std::vector<Cand> cands;
  for (size_t ei = 0; ei < r.est.size(); ei++) {
    const EstObjectResult& e = r.est[ei];
    if (!e.note.empty() || !e.obj.active) continue;
    double d_old = 0;
    nearestOld(e, d_old);
    for (size_t gi = 0; gi < r.gt.size(); gi++) {
      const GtObjectResult& g = r.gt[gi];
      if (!g.at_end || g.category_id != e.obj.class_id) continue;
      const double d = g.box.distance(e.obj.centroid);
      if (d <= opt.match_radius && (d <= d_old || d <= opt.on_object_margin))
        cands.push_back({d, (g.box.centre() - e.obj.centroid).norm(), gi, ei});
    }
  }
  std::sort(cands.begin(), cands.end(), [](const Cand& a, const Cand& b) {
    if (a.d != b.d) return a.d < b.d;
    if (a.dc != b.dc) return a.dc < b.dc;
    if (a.g != b.g) return a.g < b.g;
    return a.e < b.e;
  });
  std::vector<char> est_used(r.est.size(), 0);
  for (const Cand& c : cands) {
    GtObjectResult& g = r.gt[c.g];
    if (g.match >= 0 || est_used[c.e]) continue;
    est_used[c.e] = 1;
    EstObjectResult& e = r.est[c.e];
    g.match = e.obj.id;
    g.box_dist = c.d;
    g.centre_dist = c.dc;
    e.verdict = g.counted ? Verdict::Match : Verdict::DontCare;
    e.gt_instance = g.instance_id;
    e.box_dist = c.d;
  }

  // The others: stale, false, inactive, ignored.
  for (size_t ei = 0; ei < r.est.size(); ei++) {
    EstObjectResult& e = r.est[ei];
    if (est_used[ei]) continue;
    if (!e.note.empty()) {
      e.verdict = Verdict::Ignored;
      continue;
    }
    double d_old = 0;
    const Place p = nearestOld(e, d_old);
    // Nearest present object of the class (stale test, and the note).
    double best = std::numeric_limits<double>::infinity();
    const GtObjectResult* near = nullptr;
    for (const auto& g : r.gt)
      if (g.at_end && g.category_id == e.obj.class_id && g.box.distance(e.obj.centroid) < best) {
        best = g.box.distance(e.obj.centroid);
        near = &g;
      }
    // Stale: nearer to a place an object of its class left than to any
    // object of its class present there now. An estimate inside both, or
    // within on_object_margin of the present one (an object moved by less
    // than its size: the places overlap), is on the object, a duplicate, not
    // stale.
    if (p.g != std::string::npos && d_old <= opt.match_radius && d_old < best && best > opt.on_object_margin) {
      GtObjectResult& g = r.gt[p.g];
      g.old_places[p.p].est.push_back(e.obj.id);
      e.gt_instance = g.instance_id;
      e.box_dist = d_old;
      e.verdict = e.obj.active ? Verdict::Stale : Verdict::Inactive;
      r.stale_seen += e.verdict == Verdict::Stale && g.old_places[p.p].seenSince(opt.place_seen_fraction);
      e.note = "at the place " + g.name + " left (frame " + std::to_string(g.old_places[p.p].frame) + ")";
      continue;
    }
    e.verdict = e.obj.active ? Verdict::False : Verdict::Inactive;
    if (near && best <= opt.match_radius) {
      e.gt_instance = near->instance_id;
      e.box_dist = best;
      e.note = std::string(e.obj.active ? "duplicate of " : "inactive at ") + near->name + " (matched to #" +
               std::to_string(near->match) + ")";
      if (!e.obj.active && near->match < 0) e.note = "inactive at " + near->name + " (which is still there)";
    } else {
      e.note = "no " + coco::name(e.obj.class_id) + " within " + formatNumber("%g", opt.match_radius) + " m";
    }
  }
  for (auto& g : r.gt)
    for (auto& p : g.old_places) {
      bool active = false;
      for (int64_t id : p.est)
        for (const auto& e : r.est)
          if (e.obj.id == id && e.obj.active) active = true;
      p.state = p.est.empty() ? "not mapped" : (active ? "active" : "inactive");
    }

  // Headline.
  for (const auto& g : r.gt) {
    if (g.counted && g.fate == Fate::Static) {
      r.static_total++;
      r.static_found += g.match >= 0;
    }
    if (g.counted && g.fate == Fate::Moved) {
      r.moved_total++;
      if (g.match >= 0) {
        r.moved_found++;
        r.moved_errors.push_back(g.box_dist);
        r.moved_centre_errors.push_back(g.centre_dist);
      }
    }
    if (g.counted && g.fate == Fate::Added) {
      r.added_total++;
      r.added_found += g.match >= 0;
    }
    if ((g.fate == Fate::Removed || g.fate == Fate::Replaced) && !g.old_places.empty() &&
        g.old_places.back().counted) {
      r.gone_total++;
      r.gone_inactive += g.old_places.back().state == "inactive";
      r.gone_unmapped += g.old_places.back().state == "not mapped";
    }
  }
  for (const auto& e : r.est) {
    r.stale += e.verdict == Verdict::Stale;
    r.stale_dormant += e.verdict == Verdict::Stale && e.obj.dormant;
    r.false_objects += e.verdict == Verdict::False;
  }
  return r;
}

// ------------------------------------------------------------- reports --

namespace {

double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / static_cast<double>(v.size());
}
double maxOf(const std::vector<double>& v) { return v.empty() ? 0 : *std::max_element(v.begin(), v.end()); }

std::string pad(std::string s, size_t n) {
  if (s.size() < n) s.append(n - s.size(), ' ');
  return s;
}
std::string ratio(int a, int b) {
  return std::to_string(a) + "/" + std::to_string(b) + (b ? " = " + formatNumber("%.3f", double(a) / b) : "");
}

ojson num(double v) {
  if (!std::isfinite(v)) return nullptr;
  return v;
}
ojson vec(const Eigen::Vector3d& v) { return ojson::array({num(v.x()), num(v.y()), num(v.z())}); }

}  // namespace

std::string toText(const ObjectEvalResult& r) {
  std::ostringstream o;
  const auto& opt = r.options;
  o << "objects:   " << r.run_file << " (map " << r.map << ": " << r.est.size() << " objects";
  if (r.est_other_maps) o << "; " << r.est_other_maps << " of other maps not evaluated";
  if (r.est_too_few_points)
    o << "; " << r.est_too_few_points << " of fewer than " << opt.min_points << " points left out";
  if (r.est_too_few_sightings)
    o << "; " << r.est_too_few_sightings << " seen by fewer than " << opt.min_sightings << " keyframes"
      << (opt.confirm_points > 0 ? " (and of fewer than " + std::to_string(opt.confirm_points) + " points)" : "")
      << " left out";
  o << ")\n";
  o << "scene:     " << r.scene_dir << "\n";
  if (r.traj_poses) {
    o << "alignment: " << toString(r.alignment.method) << " on " << r.align_pairs << " poses";
    if (std::isfinite(r.align_until)) o << " before " << formatNumber("%.3f", r.align_until) << " s";
    o << " (ATE rmse " << formatNumber("%.4f", r.align_ate) << " m; all " << r.assoc_pairs << " poses: " << formatNumber("%.4f", r.ate)
      << " m)\n";
  } else {
    o << "alignment: none (no trajectory)\n";
  }
  o << "matching:  same class, centroid within " << formatNumber("%g", opt.match_radius)
    << " m of the box (on a present object within " << formatNumber("%g", opt.on_object_margin)
    << " m: not stale); objects seen >= " << opt.min_visible_pixels << " px\n\n";
  o << pad("ground truth", 24) << pad("class", 14) << pad("fate", 10) << pad("seen px", 10) << pad("estimate", 10)
    << pad("box d", 8) << pad("centre d", 10) << "result\n";
  for (const auto& g : r.gt) {
    if (g.fate == Fate::Other) continue;
    if (g.at_end) {
      std::string res = !g.counted ? "not counted (seen too little)" : (g.match >= 0 ? "found" : "missed");
      o << pad("  " + g.name + " (" + std::to_string(g.instance_id) + ")", 24) << pad(g.cls, 14)
        << pad(toString(g.fate), 10) << pad(std::to_string(g.seen_at_end), 10)
        << pad(g.match >= 0 ? "#" + std::to_string(g.match) : "-", 10)
        << pad(g.match >= 0 ? formatNumber("%.3f", g.box_dist) : "", 8) << pad(g.match >= 0 ? formatNumber("%.3f", g.centre_dist) : "", 10)
        << res << "\n";
    } else {
      o << pad("  " + g.name + " (" + std::to_string(g.instance_id) + ")", 24) << pad(g.cls, 14)
        << pad(toString(g.fate), 10) << "gone at the end\n";
    }
    for (const auto& p : g.old_places) {
      std::string ids;
      for (int64_t id : p.est) ids += (ids.empty() ? "#" : ",#") + std::to_string(id);
      o << pad("    left place @" + std::to_string(p.frame), 48) << pad(std::to_string(p.seen), 10)
        << pad(ids.empty() ? "-" : ids, 28) << (p.counted ? "" : "(seen too little) ") << "old object " << p.state
        << (p.state == "active" ? " (stale)" : "");
      if (r.place_visibility)
        o << "; place " << (p.seenSince(opt.place_seen_fraction) ? "seen" : "not seen") << " since (up to "
          << formatNumber("%.0f", 100 * p.seen_after) << " % in view)";
      o << "\n";
    }
  }
  bool header = false;
  for (const auto& e : r.est) {
    if (e.verdict == Verdict::Match || e.verdict == Verdict::DontCare) continue;
    if (!header) {
      o << "\nestimated objects not matched:\n";
      header = true;
    }
    o << pad("  #" + std::to_string(e.obj.id), 10) << pad(coco::name(e.obj.class_id), 14)
      << pad(e.obj.active ? "active" : "inactive", 10) << pad(toString(e.verdict), 10) << e.note << "\n";
  }
  o << "\n";
  o << "recall (static objects)   " << ratio(r.static_found, r.static_total) << "\n";
  o << "stale objects             " << r.stale << " (target 0)";
  if (r.place_visibility)
    o << "; " << r.stale_seen << " at places seen since the object left, " << r.stale - r.stale_seen
      << " at places never seen since";
  if (r.stale_dormant) o << "; " << r.stale_dormant << " dormant (not used to localise until seen again)";
  o << "\n";
  o << "moved objects found       " << ratio(r.moved_found, r.moved_total);
  if (!r.moved_errors.empty())
    o << "; centroid error (to box) mean " << formatNumber("%.3f", mean(r.moved_errors)) << " m, max "
      << formatNumber("%.3f", maxOf(r.moved_errors)) << " m (target <= 0.10 m); to box centre mean "
      << formatNumber("%.3f", mean(r.moved_centre_errors)) << " m";
  o << "\n";
  o << "gone objects inactive     " << ratio(r.gone_inactive, r.gone_total);
  if (r.gone_unmapped) o << " (" << r.gone_unmapped << " never mapped)";
  o << "\n";
  o << "added objects found       " << ratio(r.added_found, r.added_total) << "\n";
  o << "false objects             " << r.false_objects << "\n";
  return o.str();
}

std::string toJson(const ObjectEvalResult& r) {
  const auto& opt = r.options;
  ojson gts = ojson::array();
  for (const auto& g : r.gt) {
    if (g.fate == Fate::Other) continue;
    ojson j = {{"instance_id", g.instance_id}, {"name", g.name},       {"class", g.cls},
               {"class_id", g.category_id},    {"fate", toString(g.fate)}, {"at_end", g.at_end}};
    if (g.at_end) {
      j["centre"] = vec(g.box.centre());
      j["seen_pixels"] = g.seen_at_end;
      j["counted"] = g.counted;
      j["match"] = g.match >= 0 ? ojson(g.match) : ojson(nullptr);
      j["box_distance"] = g.match >= 0 ? num(g.box_dist) : ojson(nullptr);
      j["centre_distance"] = g.match >= 0 ? num(g.centre_dist) : ojson(nullptr);
    }
    ojson places = ojson::array();
    for (const auto& p : g.old_places)
      places.push_back({{"frame", p.frame},
                        {"left_at", p.left_at},
                        {"centre", vec(p.box.centre())},
                        {"seen_pixels", p.seen},
                        {"counted", p.counted},
                        {"seen_after", p.seen_after >= 0 ? num(p.seen_after) : ojson(nullptr)},
                        {"seen_since", r.place_visibility ? ojson(p.seenSince(opt.place_seen_fraction)) : ojson(nullptr)},
                        {"estimates", p.est},
                        {"state", p.state}});
    j["left_places"] = std::move(places);
    gts.push_back(std::move(j));
  }
  ojson ests = ojson::array();
  for (const auto& e : r.est)
    ests.push_back({{"id", e.obj.id},
                    {"class_id", e.obj.class_id},
                    {"class", coco::name(e.obj.class_id)},
                    {"active", e.obj.active},
                    {"centroid", vec(e.obj.centroid)},
                    {"verdict", toString(e.verdict)},
                    {"instance_id", e.gt_instance >= 0 ? ojson(e.gt_instance) : ojson(nullptr)},
                    {"box_distance", e.box_dist >= 0 ? num(e.box_dist) : ojson(nullptr)},
                    {"note", e.note}});
  ojson j = {{"metric", "objects"},
             {"objects_file", r.run_file},
             {"scene", r.scene_dir},
             {"map", r.map},
             {"align", toString(r.alignment.method)},
             {"align_until", num(r.align_until)},
             {"align_poses", r.align_pairs},
             {"align_ate_rmse", num(r.align_ate)},
             {"ate_rmse", num(r.ate)},
             {"match_radius", num(opt.match_radius)},
             {"on_object_margin", num(opt.on_object_margin)},
             {"min_visible_pixels", opt.min_visible_pixels},
             {"min_points", opt.min_points},
             {"estimated_too_few_points", r.est_too_few_points},
             {"min_sightings", opt.min_sightings},
             {"confirm_points", opt.confirm_points},
             {"estimated_too_few_sightings", r.est_too_few_sightings},
             {"estimated", r.est.size()},
             {"estimated_other_maps", r.est_other_maps},
             {"static_total", r.static_total},
             {"static_found", r.static_found},
             {"recall", num(r.recall())},
             {"stale", r.stale},
             {"stale_place_seen", r.place_visibility ? ojson(r.stale_seen) : ojson(nullptr)},
             {"stale_dormant", r.stale_dormant},
             {"moved_total", r.moved_total},
             {"moved_found", r.moved_found},
             {"moved_error_mean", r.moved_errors.empty() ? ojson(nullptr) : num(mean(r.moved_errors))},
             {"moved_error_max", r.moved_errors.empty() ? ojson(nullptr) : num(maxOf(r.moved_errors))},
             {"moved_centre_error_mean", r.moved_errors.empty() ? ojson(nullptr) : num(mean(r.moved_centre_errors))},
             {"gone_total", r.gone_total},
             {"gone_inactive", r.gone_inactive},
             {"gone_unmapped", r.gone_unmapped},
             {"added_total", r.added_total},
             {"added_found", r.added_found},
             {"false_objects", r.false_objects},
             {"ground_truth", std::move(gts)},
             {"estimates", std::move(ests)}};
  return layoutJson(j, 2);
}

}  // namespace dslam::eval
