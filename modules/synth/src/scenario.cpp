#include "dslam/synth/scenario.h"

#include <mrpt/containers/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <sstream>

#include "dslam/config/yaml_loader.h"
#include "dslam/core/coco.h"
#include "dslam/core/error.h"
#include "dslam/core/yaml_util.h"
#include "dslam/synth/scene.h"

namespace fs = std::filesystem;

namespace dslam::synth {

const std::vector<std::string>& textureKinds() {
  static const std::vector<std::string> k = {"posters", "tiles",  "wood",   "stripes", "checks", "blobs",
                                             "rects",   "concrete", "ceiling", "books",  "carpet", "denim",
                                             "leaves",  "screen", "plain",  "skin",    "metal",  "print"};
  return k;
}

const ObjectSpec* Scenario::findObject(const std::string& n) const {
  for (const auto& o : objects)
    if (o.name == n) return &o;
  return nullptr;
}

namespace {

using node_t = mrpt::containers::yaml::node_t;
constexpr double kDeg = M_PI / 180.0;

const std::vector<std::string> kObjectTypes = {"box",   "cylinder", "sphere", "quad",
                                               "table", "chair",    "shelf",  "monitor", "plant"};

using N = yamlu::At;

/** The typed reader of dslam's YAML files (core/yaml_util.h) with the
 *  scenario's own value types. */
class Reader : public yamlu::TypedReader {
 public:
  explicit Reader(const config::LoadedYaml& ly)
      : yamlu::TypedReader([&ly](const std::string& key_path) { return ly.fileFor(key_path); }) {}

  Vec3 vec3(const N& v, bool allow2 = false, double z_default = 0) const {
    auto d = numbers(v, allow2 ? 2 : 3, 3);
    return {d[0], d[1], d.size() > 2 ? d[2] : z_default};
  }
  Vec3 color(const N& v) const {
    Vec3 c = vec3(v);
    if (c.maxCoeff() > 1.0) c /= 255.0;  // 0..255 accepted
    if (c.minCoeff() < 0 || c.maxCoeff() > 1.0) fail(v, "colour components must be in [0,1] or [0,255]");
    return c;
  }

  TextureSpec texture(const N& v, TextureSpec def) const {
    if (v.n->isMap()) {
      checkKeys(v, {"kind", "color", "scale", "seed"});
      def.kind = oneOf(v, "kind", def.kind, textureKinds(), "texture kind");
      if (auto c = child(v, "color")) {
        def.color = color(*c);
        def.has_color = true;
      }
      def.scale = positive(v, "scale", def.scale);
      def.seed = static_cast<uint64_t>(integer(v, "seed", static_cast<long long>(def.seed)));
      return def;
    }
    const std::string k = str(v);
    if (std::find(textureKinds().begin(), textureKinds().end(), k) == textureKinds().end())
      fail(v, "unknown texture kind '" + k + "'" + yamlu::didYouMean(k, textureKinds()) +
                  " (valid: " + yamlu::join(textureKinds()) + ")");
    def.kind = k;
    return def;
  }

  PathSpec path(const N& v, double default_speed) const {
    checkKeys(v, {"waypoints", "speed", "mode", "start"});
    PathSpec p;
    for (auto& w : list(required(v, "waypoints"))) p.waypoints.push_back(vec3(w, true));
    if (p.waypoints.size() < 2) fail(v, "a path needs at least 2 waypoints");
    p.speed = positive(v, "speed", default_speed);
    p.mode = oneOf(v, "mode", "pingpong", {"loop", "pingpong", "once"}, "path mode");
    p.start = num(v, "start", 0.0);
    return p;
  }

};

TextureSpec tex(const char* kind, Vec3 c = {0.8, 0.8, 0.8}) {
  TextureSpec t;
  t.kind = kind;
  t.color = c;
  return t;
}

void parseCamera(const Reader& r, const N& cam, Scenario& s) {
  r.checkKeys(cam, {"fx", "fy", "cx", "cy", "baseline", "trajectory"});
  s.intrinsics.fx = r.positive(cam, "fx", s.intrinsics.fx);
  s.intrinsics.fy = r.positive(cam, "fy", s.intrinsics.fy);
  s.intrinsics.cx = r.num(cam, "cx", s.intrinsics.cx);
  s.intrinsics.cy = r.num(cam, "cy", s.intrinsics.cy);
  s.baseline = r.positive(cam, "baseline", s.baseline);
  const N tr = r.required(cam, "trajectory");
  r.checkKeys(tr, {"type", "interpolation", "keyframes", "center", "look_at", "amplitude", "period", "radius",
                   "heading", "pitch", "jitter_position", "jitter_rotation"});
  auto& T = s.trajectory;
  T.type = r.oneOf(tr, "type", "keyframes", {"keyframes", "static", "xyz", "rpy", "halfsphere", "orbit"},
                   "trajectory type");
  T.interpolation = r.oneOf(tr, "interpolation", "spline", {"spline", "linear"}, "interpolation");
  if (auto c = r.child(tr, "center")) T.center = r.vec3(*c);
  if (auto c = r.child(tr, "look_at")) T.look_at = r.vec3(*c);
  T.amplitude = r.positive(tr, "amplitude", T.type == "rpy" ? 15.0 : T.amplitude, true);
  T.period = r.positive(tr, "period", T.period);
  T.radius = r.positive(tr, "radius", T.radius);
  T.heading = r.num(tr, "heading", T.heading);
  T.pitch = r.num(tr, "pitch", T.pitch);
  T.jitter_position = r.positive(tr, "jitter_position", T.jitter_position, true);
  T.jitter_rotation = r.positive(tr, "jitter_rotation", T.jitter_rotation, true);
  if (T.type == "keyframes") {
    const N kl = r.required(tr, "keyframes");
    for (auto& k : r.list(kl)) {
      r.checkKeys(k, {"t", "frame", "position", "look_at", "rpy"});
      CameraKeyframe kf;
      auto t = r.child(k, "t");
      auto f = r.child(k, "frame");
      if (t && f) r.fail(k, "give either 't' (seconds) or 'frame', not both");
      if (!t && !f) r.fail(k, "missing 't' (seconds) or 'frame'");
      kf.t = t ? r.num(*t) : static_cast<double>(r.integer(*f)) / s.rate;
      kf.position = r.vec3(r.required(k, "position"));
      auto la = r.child(k, "look_at");
      auto rpy = r.child(k, "rpy");
      if (la && rpy) r.fail(k, "give either 'look_at' or 'rpy', not both");
      if (!la && !rpy) r.fail(k, "missing 'look_at' or 'rpy'");
      if (la) kf.look_at = r.vec3(*la);
      if (rpy) kf.rpy = r.vec3(*rpy) * kDeg;
      if (kf.look_at && (*kf.look_at - kf.position).norm() < 1e-6) r.fail(*la, "look_at equals the position");
      if (!T.keyframes.empty() && kf.t <= T.keyframes.back().t)
        r.fail(k, "keyframe times must increase (" + std::to_string(kf.t) + " after " +
                      std::to_string(T.keyframes.back().t) + ")");
      T.keyframes.push_back(kf);
    }
    if (T.keyframes.empty()) r.fail(kl, "at least one keyframe is required");
  } else if (r.child(tr, "keyframes")) {
    r.fail(*r.child(tr, "keyframes"), "keyframes are only used with type: keyframes");
  }
}

void parseNoise(const Reader& r, const N& n, NoiseSpec& z) {
  r.checkKeys(n, {"enabled", "depth_sigma", "depth_min", "depth_max", "edge_dropout", "edge_threshold",
                  "image_sigma", "motion_blur", "blur_samples", "optics_blur"});
  z.enabled = r.boolean(n, "enabled", z.enabled);
  z.depth_sigma = r.positive(n, "depth_sigma", z.depth_sigma, true);
  z.depth_min = r.positive(n, "depth_min", z.depth_min, true);
  z.depth_max = r.positive(n, "depth_max", z.depth_max);
  if (z.depth_max <= z.depth_min) r.fail(r.child(n, "depth_max").value_or(n), "depth_max must exceed depth_min");
  z.edge_dropout = r.positive(n, "edge_dropout", z.edge_dropout, true);
  if (z.edge_dropout > 1) r.fail(*r.child(n, "edge_dropout"), "must be in [0, 1]");
  z.edge_threshold = r.positive(n, "edge_threshold", z.edge_threshold);
  z.image_sigma = r.positive(n, "image_sigma", z.image_sigma, true);
  z.motion_blur = r.positive(n, "motion_blur", z.motion_blur, true);
  if (z.motion_blur > 1) r.fail(*r.child(n, "motion_blur"), "must be in [0, 1] (fraction of the frame period)");
  z.blur_samples = static_cast<int>(r.integer(n, "blur_samples", z.blur_samples));
  if (z.blur_samples < 1 || z.blur_samples > 32) r.fail(*r.child(n, "blur_samples"), "must be in [1, 32]");
  z.optics_blur = r.positive(n, "optics_blur", z.optics_blur, true);
}

void parseRoom(const Reader& r, const N& n, RoomSpec& room) {
  r.checkKeys(n, {"size", "walls", "floor", "ceiling"});
  room.size = r.vec3(r.required(n, "size"));
  if (room.size.minCoeff() < 1.0) r.fail(*r.child(n, "size"), "room sides must be at least 1 m");
  if (auto w = r.child(n, "walls")) {
    if (w->n->isSequence()) {
      auto l = r.list(*w);
      if (l.size() != 4) r.fail(*w, "walls: give one texture or a list of 4 (-x, +x, -y, +y)");
      for (int i = 0; i < 4; i++) room.walls[i] = r.texture(l[i], room.walls[i]);
    } else {
      for (int i = 0; i < 4; i++) room.walls[i] = r.texture(*w, room.walls[i]);
    }
  }
  if (auto f = r.child(n, "floor")) room.floor = r.texture(*f, room.floor);
  if (auto c = r.child(n, "ceiling")) room.ceiling = r.texture(*c, room.ceiling);
}

std::string defaultClass(const std::string& type) {
  if (type == "table") return "dining table";
  if (type == "chair") return "chair";
  if (type == "monitor") return "tv";
  if (type == "plant") return "potted plant";
  if (type == "shelf") return "shelf";
  return "";
}

TextureSpec defaultTexture(const std::string& type) {
  if (type == "table") return tex("wood", {0.55, 0.38, 0.22});
  if (type == "chair") return tex("carpet", {0.25, 0.3, 0.45});
  if (type == "monitor") return tex("screen", {0.1, 0.1, 0.12});
  if (type == "plant") return tex("leaves", {0.2, 0.45, 0.2});
  if (type == "shelf") return tex("books", {0.5, 0.35, 0.2});
  return tex("rects", {0.6, 0.5, 0.4});
}

Vec3 defaultSize(const std::string& type) {
  if (type == "table") return {0.8, 1.6, 0.75};
  if (type == "chair") return {0.5, 0.5, 0.9};
  if (type == "monitor") return {0.2, 0.55, 0.45};
  if (type == "plant") return {0.4, 0.4, 0.9};
  if (type == "shelf") return {0.35, 1.0, 1.8};
  return {0.5, 0.5, 0.5};
}

void parseObject(const Reader& r, const N& o, ObjectSpec& ob, size_t idx) {
  r.checkKeys(o, {"name", "type", "class", "labelled", "size", "position", "yaw", "pitch", "texture", "present",
                  "path"});
  ob.key = o.path;
  ob.name = r.str(o, "name", "object" + std::to_string(idx));
  ob.type = r.oneOf(o, "type", "", kObjectTypes, "object type");
  if (ob.type.empty()) r.fail(o, "missing required key 'type' (one of " + yamlu::join(kObjectTypes) + ")");
  ob.labelled = r.boolean(o, "labelled", true);
  ob.class_name = r.str(o, "class", defaultClass(ob.type));
  if (ob.class_name.empty()) r.fail(o, "missing required key 'class' (a COCO category name, e.g. 'chair')");
  const int id = coco::idFromName(ob.class_name);
  if (ob.labelled) {
    if (id < 0)
      r.fail(r.child(o, "class").value_or(o),
             "unknown COCO class '" + ob.class_name +
                 "' (use a COCO name such as 'chair', 'dining table', 'wall-other-merged', or set labelled: false "
                 "for a class outside the label set)");
    ob.category_id = id;
  } else {
    ob.category_id = 0;
  }
  ob.size = defaultSize(ob.type);
  if (auto sz = r.child(o, "size")) {
    ob.size = r.vec3(*sz);
    if (ob.size.minCoeff() < 0 || (ob.type != "quad" && ob.size.minCoeff() <= 0))
      r.fail(*sz, "sizes must be > 0");
  }
  if (auto p = r.child(o, "position")) {
    ob.position = r.vec3(*p, true);
    ob.has_position = true;
  }
  ob.yaw = r.num(o, "yaw", 0.0) * kDeg;
  ob.pitch = r.num(o, "pitch", 0.0) * kDeg;
  ob.texture = defaultTexture(ob.type);
  if (auto t = r.child(o, "texture")) ob.texture = r.texture(*t, ob.texture);
  ob.present = r.boolean(o, "present", true);
  if (auto p = r.child(o, "path")) {
    ob.path = r.path(*p, 0.5);
    if (!ob.has_position) {
      ob.position = ob.path.waypoints[0];
      ob.has_position = true;
    }
  }
}

void parsePerson(const Reader& r, const N& o, PersonSpec& p, size_t idx) {
  r.checkKeys(o, {"name", "action", "path", "position", "yaw", "height", "seat_height", "enter", "leave", "shirt",
                  "pants", "skin", "hair", "chair"});
  p.key = o.path;
  p.name = r.str(o, "name", "person" + std::to_string(idx));
  p.action = r.oneOf(o, "action", "walk", {"walk", "sit", "stand"}, "person action");
  if (p.action == "walk") {
    p.path = r.path(r.required(o, "path"), 1.1);
    if (r.child(o, "position")) r.fail(*r.child(o, "position"), "a walking person follows 'path'; 'position' is for sit/stand");
  } else {
    if (r.child(o, "path")) r.fail(*r.child(o, "path"), "'path' is only for action: walk");
    p.chair = r.str(o, "chair", "");
    if (p.chair.empty()) p.position = r.vec3(r.required(o, "position"), true);
    else if (r.child(o, "position")) r.fail(*r.child(o, "position"), "give either 'chair' or 'position'");
    if (!p.chair.empty() && p.action != "sit") r.fail(*r.child(o, "chair"), "'chair' is only for action: sit");
  }
  p.yaw = r.num(o, "yaw", 0.0) * kDeg;
  p.height = r.positive(o, "height", p.height);
  if (p.height < 1.0 || p.height > 2.2) r.fail(*r.child(o, "height"), "height must be in [1.0, 2.2] m");
  p.seat_height = r.positive(o, "seat_height", p.seat_height);
  p.enter = r.num(o, "enter", -1.0);
  p.leave = r.num(o, "leave", -1.0);
  // Deterministic varied clothing from the index unless given.
  static const Vec3 shirts[] = {{0.7, 0.15, 0.15}, {0.15, 0.35, 0.7}, {0.2, 0.55, 0.25}, {0.8, 0.7, 0.2},
                                {0.5, 0.2, 0.55},  {0.9, 0.9, 0.88}, {0.2, 0.2, 0.22},  {0.9, 0.45, 0.1}};
  static const char* shirt_kinds[] = {"stripes", "checks", "print", "stripes", "checks", "print"};
  static const Vec3 pants[] = {{0.12, 0.15, 0.3}, {0.2, 0.2, 0.2}, {0.35, 0.28, 0.2}, {0.1, 0.1, 0.12}};
  static const Vec3 skins[] = {{0.87, 0.68, 0.55}, {0.62, 0.43, 0.3}, {0.95, 0.78, 0.66}, {0.42, 0.28, 0.2}};
  p.shirt = tex(shirt_kinds[idx % 6], shirts[idx % 8]);
  p.pants = tex("denim", pants[idx % 4]);
  p.skin = skins[idx % 4];
  p.hair = (idx % 3 == 0) ? Vec3(0.1, 0.07, 0.05) : (idx % 3 == 1 ? Vec3(0.35, 0.22, 0.1) : Vec3(0.05, 0.05, 0.05));
  if (auto t = r.child(o, "shirt")) p.shirt = r.texture(*t, p.shirt);
  if (auto t = r.child(o, "pants")) p.pants = r.texture(*t, p.pants);
  if (auto c = r.child(o, "skin")) p.skin = r.color(*c);
  if (auto c = r.child(o, "hair")) p.hair = r.color(*c);
}

void parseEvent(const Reader& r, const N& e, EventSpec& ev, const Scenario& s) {
  r.checkKeys(e, {"type", "object", "by", "frame", "frames", "position", "yaw"});
  ev.key = e.path;
  ev.type = r.oneOf(e, "type", "", {"moved", "removed", "added", "replaced"}, "event type");
  if (ev.type.empty()) r.fail(e, "missing required key 'type' (moved, removed, added, replaced)");
  const N on = r.required(e, "object");
  ev.object = r.str(on);
  if (!s.findObject(ev.object)) r.fail(on, "no object named '" + ev.object + "' in 'objects'");
  auto f = r.child(e, "frame");
  auto fs = r.child(e, "frames");
  if (f && fs) r.fail(e, "give either 'frame' or 'frames', not both");
  if (!f && !fs) r.fail(e, "missing 'frame' (instant change) or 'frames: [first, last]'");
  if (f) {
    ev.first = ev.last = static_cast<int>(r.integer(*f));
  } else {
    auto l = r.list(*fs);
    if (l.size() != 2) r.fail(*fs, "expected [first, last]");
    ev.first = static_cast<int>(r.integer(l[0]));
    ev.last = static_cast<int>(r.integer(l[1]));
    if (ev.last < ev.first) r.fail(*fs, "last frame before first frame");
    if (ev.type != "moved" && ev.last != ev.first)
      r.fail(*fs, "'" + ev.type + "' is instantaneous: use 'frame: N' (a frame range is for 'moved')");
  }
  if (ev.first < 0 || ev.last >= s.frames)
    r.fail(f ? *f : *fs, "frame out of range [0, " + std::to_string(s.frames - 1) + "]");
  if (ev.type == "moved") {
    ev.position = r.vec3(r.required(e, "position"), true);
    if (auto y = r.child(e, "yaw")) {
      ev.yaw = r.num(*y) * kDeg;
      ev.has_yaw = true;
    }
  } else {
    if (r.child(e, "position")) r.fail(*r.child(e, "position"), "'position' is only for 'moved' events");
    if (r.child(e, "yaw")) r.fail(*r.child(e, "yaw"), "'yaw' is only for 'moved' events");
  }
  if (ev.type == "replaced") {
    const N bn = r.required(e, "by");
    ev.by = r.str(bn);
    if (!s.findObject(ev.by)) r.fail(bn, "no object named '" + ev.by + "' in 'objects'");
    if (ev.by == ev.object) r.fail(bn, "an object cannot replace itself");
  } else if (r.child(e, "by")) {
    r.fail(*r.child(e, "by"), "'by' is only for 'replaced' events");
  }
}

Scenario parseLoaded(const config::LoadedYaml& ly, const ScenarioOverrides& ov) {
  Reader r(ly);
  const N root{&ly.root->node(), ""};
  if (!root.n->isMap()) r.fail(root, "a scenario file must be a YAML map");
  r.checkKeys(root, {"name", "description", "frames", "rate", "start_time", "seed", "resolution", "camera", "noise",
                     "limits", "room", "objects", "people", "events", "darkness"});
  Scenario s;
  s.file = ly.file;
  s.name = r.str(root, "name", fs::path(ly.file).stem().string());
  s.description = r.str(root, "description", "");
  s.frames = static_cast<int>(r.integer(root, "frames", s.frames));
  if (s.frames < 1 || s.frames > 100000) r.fail(*r.child(root, "frames"), "frames must be in [1, 100000]");
  s.rate = r.positive(root, "rate", s.rate);
  // Stamps are written with 6 decimals (TUM): frames closer than 10 us, or
  // times beyond the microseconds a double holds, would share one stamp
  // (and one image file).
  if (s.rate > 1e5) r.fail(*r.child(root, "rate"), "must be at most 100000 (frames/s; stamps have 1 us resolution)");
  s.start_time = r.num(root, "start_time", s.start_time);
  if (s.start_time < 0) r.fail(*r.child(root, "start_time"), "must be >= 0");
  if (s.start_time > 1e10)
    r.fail(*r.child(root, "start_time"), "must be at most 1e10 seconds (stamps have 1 us resolution)");
  s.seed = static_cast<uint64_t>(r.integer(root, "seed", 1));
  if (auto res = r.child(root, "resolution")) {
    auto l = r.list(*res);
    if (l.size() != 2) r.fail(*res, "expected [width, height]");
    s.width = static_cast<int>(r.integer(l[0]));
    s.height = static_cast<int>(r.integer(l[1]));
    if (s.width < 16 || s.height < 16 || s.width > 4096 || s.height > 4096)
      r.fail(*res, "resolution must be within 16..4096 pixels");
  }
  // TUM freiburg3 intrinsics, scaled to the resolution.
  auto& K = s.intrinsics;
  K.width = s.width;
  K.height = s.height;
  const double sx = s.width / 640.0, sy = s.height / 480.0;
  K.fx = 535.4 * sx;
  K.fy = 539.2 * sy;
  K.cx = (320.1 + 0.5) * sx - 0.5;
  K.cy = (247.6 + 0.5) * sy - 0.5;
  parseCamera(r, r.required(root, "camera"), s);
  if (auto n = r.child(root, "noise")) parseNoise(r, *n, s.noise);
  if (auto l = r.child(root, "limits")) {
    r.checkKeys(*l, {"max_speed", "max_rate"});
    s.max_speed = r.positive(*l, "max_speed", s.max_speed);
    s.max_rate = r.positive(*l, "max_rate", s.max_rate);
  }
  parseRoom(r, r.required(root, "room"), s.room);
  int next_id = 1;
  if (auto ol = r.child(root, "objects")) {
    size_t i = 0;
    for (auto& o : r.list(*ol)) {
      ObjectSpec ob;
      parseObject(r, o, ob, i++);
      if (s.findObject(ob.name)) r.fail(o, "duplicate object name '" + ob.name + "'");
      ob.instance_id = next_id++;
      s.objects.push_back(ob);
    }
  }
  if (auto pl = r.child(root, "people")) {
    size_t i = 0;
    for (auto& o : r.list(*pl)) {
      PersonSpec p;
      parsePerson(r, o, p, i++);
      for (auto& q : s.people)
        if (q.name == p.name) r.fail(o, "duplicate person name '" + p.name + "'");
      if (s.findObject(p.name)) r.fail(o, "person name '" + p.name + "' is also an object name");
      if (!p.chair.empty()) {
        const ObjectSpec* c = s.findObject(p.chair);
        if (!c) r.fail(*r.child(o, "chair"), "no object named '" + p.chair + "'");
        if (c->type != "chair") r.fail(*r.child(o, "chair"), "'" + p.chair + "' is a " + c->type + ", not a chair");
        // Sit on the seat, facing the chair's front (+x), pelvis over the seat centre.
        p.position = c->position + Eigen::AngleAxisd(c->yaw, Vec3::UnitZ()) * Vec3(0.02, 0, 0);
        p.position.z() = 0;
        p.yaw = c->yaw;
        p.seat_height = 0.46 * c->size.z() / 0.9;
      }
      p.instance_id = next_id++;
      s.people.push_back(p);
    }
  }
  if (auto dl = r.child(root, "darkness")) {
    for (auto& d : r.list(*dl)) {
      auto l = r.list(d);
      if (l.size() != 2) r.fail(d, "expected [first, last] (frames with the lights off)");
      const int a = static_cast<int>(r.integer(l[0])), b = static_cast<int>(r.integer(l[1]));
      if (b < a || a < 0 || b >= s.frames)
        r.fail(d, "darkness frames must satisfy 0 <= first <= last < " + std::to_string(s.frames));
      s.darkness.push_back({a, b});
    }
  }
  if (auto el = r.child(root, "events")) {
    for (auto& e : r.list(*el)) {
      EventSpec ev;
      parseEvent(r, e, ev, s);
      s.events.push_back(ev);
    }
  }
  // Objects brought in by an event start absent; objects given no position
  // (replacements) take the replaced object's place.
  for (auto& ev : s.events) {
    const std::string incoming = ev.type == "added" ? ev.object : (ev.type == "replaced" ? ev.by : "");
    if (incoming.empty()) continue;
    for (auto& o : s.objects) {
      if (o.name != incoming) continue;
      o.present = false;
      if (!o.has_position && ev.type == "replaced") {
        const ObjectSpec* a = s.findObject(ev.object);
        o.position = a->position;
        o.yaw = a->yaw;
        o.has_position = true;
      }
    }
  }
  for (auto& o : s.objects)
    if (!o.has_position) {
      throw ConfigError(ly.fileFor(o.key) + ": '" + o.key + "': missing required key 'position'");
    }
  applyOverrides(s, ov);
  return s;
}

}  // namespace

void applyOverrides(Scenario& s, const ScenarioOverrides& ov) {
  if (ov.frames > 0) {
    s.frames = ov.frames;
    // Events beyond the shortened sequence are dropped.
    s.events.erase(std::remove_if(s.events.begin(), s.events.end(), [&](const EventSpec& e) { return e.first >= s.frames; }),
                   s.events.end());
    for (auto& e : s.events) e.last = std::min(e.last, s.frames - 1);
    s.darkness.erase(std::remove_if(s.darkness.begin(), s.darkness.end(),
                                    [&](const std::pair<int, int>& d) { return d.first >= s.frames; }),
                     s.darkness.end());
    for (auto& d : s.darkness) d.second = std::min(d.second, s.frames - 1);
  }
  if (ov.width > 0 && ov.height > 0 && (ov.width != s.width || ov.height != s.height)) {
    if (ov.width < 16 || ov.height < 16 || ov.width > 4096 || ov.height > 4096)
      throw ConfigError("resolution override " + std::to_string(ov.width) + "x" + std::to_string(ov.height) +
                        " outside 16..4096");
    const double sx = double(ov.width) / s.width, sy = double(ov.height) / s.height;
    auto& K = s.intrinsics;
    K.fx *= sx;
    K.fy *= sy;
    K.cx = (K.cx + 0.5) * sx - 0.5;
    K.cy = (K.cy + 0.5) * sy - 0.5;
    s.width = K.width = ov.width;
    s.height = K.height = ov.height;
  }
  if (ov.seed) s.seed = *ov.seed;
  if (ov.noise) s.noise.enabled = *ov.noise;
  if (ov.baseline) s.baseline = *ov.baseline;
  s.intrinsics.width = s.width;
  s.intrinsics.height = s.height;
  validateScenario(s);
}

void validateScenario(const Scenario& s) {
  const std::string src = s.file.empty() ? std::string("<scenario>") : s.file;
  auto fail = [&](const std::string& key, const std::string& msg) {
    throw ConfigError(src + ": " + (key.empty() ? std::string() : "'" + key + "': ") + msg);
  };
  const Vec3 half = s.room.size / 2;
  auto inside = [&](const Vec3& p, double margin, bool check_z) {
    return std::abs(p.x()) <= half.x() - margin && std::abs(p.y()) <= half.y() - margin &&
           (!check_z || (p.z() >= margin && p.z() <= s.room.size.z() - margin));
  };
  auto fmt = [](const Vec3& p) {
    std::ostringstream o;
    o << "[" << p.x() << ", " << p.y() << ", " << p.z() << "]";
    return o.str();
  };
  // Validation (and rendering) work grows with frames x (objects + people)
  // x events: bounded, so that a small file cannot ask for hours of checks.
  const size_t n_ent = s.objects.size() + s.people.size();
  if (s.events.size() > kMaxEvents)
    fail("events", std::to_string(s.events.size()) + " events, at most " + std::to_string(kMaxEvents));
  if (static_cast<uint64_t>(s.frames) * n_ent > kMaxFrameEntities)
    fail("", std::to_string(s.frames) + " frames x " + std::to_string(n_ent) + " objects and people = " +
                 std::to_string(static_cast<uint64_t>(s.frames) * n_ent) + ", more than " +
                 std::to_string(kMaxFrameEntities) + " (fewer frames or fewer objects)");
  const std::string room_desc = "the room (x in +-" + std::to_string(half.x()).substr(0, 5) + ", y in +-" +
                                std::to_string(half.y()).substr(0, 5) + ")";
  for (const auto& o : s.objects) {
    if (!inside(o.position, 0.0, false))
      fail(o.key + ".position", "object '" + o.name + "' at " + fmt(o.position) + " is outside " + room_desc);
    for (size_t i = 0; i < o.path.waypoints.size(); i++)
      if (!inside(o.path.waypoints[i], 0.05, false) || o.path.waypoints[i].z() < 0 ||
          o.path.waypoints[i].z() + o.size.z() > s.room.size.z())
        fail(o.key + ".path.waypoints[" + std::to_string(i) + "]",
             "waypoint " + fmt(o.path.waypoints[i]) + " of object '" + o.name + "' is outside " + room_desc);
  }
  for (const auto& p : s.people) {
    if (p.action != "walk" && !inside(p.position, 0.2, false))
      fail(p.key + ".position", "person '" + p.name + "' at " + fmt(p.position) + " is outside " + room_desc);
    for (size_t i = 0; i < p.path.waypoints.size(); i++)
      if (!inside(p.path.waypoints[i], 0.25, false))
        fail(p.key + ".path.waypoints[" + std::to_string(i) + "]",
             "waypoint " + fmt(p.path.waypoints[i]) + " of person '" + p.name + "' is outside " + room_desc +
                 " (people keep 0.25 m from the walls)");
    if (p.height > s.room.size.z() - 0.1) fail(p.key + ".height", "person taller than the room");
  }
  for (const auto& e : s.events)
    if (e.type == "moved" && !inside(e.position, 0.0, false))
      fail(e.key + ".position", "target " + fmt(e.position) + " is outside " + room_desc);

  // Camera: inside the room, outside every object and person, speed limits.
  SceneModel scene(s);
  const std::string tkey = "camera.trajectory";
  SE3 prev;
  for (int f = 0; f < s.frames; f++) {
    const SE3 T = scene.cameraPose(f);
    const Vec3 c = T.translation();
    if (!inside(c, 0.1, true))
      fail(tkey, "camera at " + fmt(c) + " (frame " + std::to_string(f) + ") is outside " + room_desc +
                     " or closer than 0.1 m to a wall");
    // Primitives (articulated people especially) are costly to build: only
    // for the objects and people whose bounding sphere the camera is in.
    for (size_t i = 0; i < s.objects.size(); i++) {
      const ObjectState os = scene.objectStateAt(i, s.time(f), f);
      const Vec3& sz = s.objects[i].size;
      if (!os.present || (c - os.T_wo.translation()).norm() > 1.5 * std::hypot(sz.x(), sz.y(), sz.z()) + 0.1) continue;
      for (const auto& prim : scene.objectPrimitives(i, f, s.time(f)))
        if (signedDistance(prim, c) < 0.05)
          fail(s.objects[i].key, "camera inside object '" + s.objects[i].name + "' at frame " + std::to_string(f) +
                                     " (camera at " + fmt(c) + ")");
    }
    for (size_t i = 0; i < s.people.size(); i++) {
      if (!scene.personPresent(i, f) ||
          (c - scene.personRoot(i, s.time(f)).translation()).norm() > 1.5 * s.people[i].height + 0.1)
        continue;
      for (const auto& prim : scene.personPrimitives(i, f, s.time(f)))
        if (signedDistance(prim, c) < 0.05)
          fail(s.people[i].key, "camera inside person '" + s.people[i].name + "' at frame " + std::to_string(f) +
                                    " (camera at " + fmt(c) + ")");
    }
    if (f > 0) {
      const SE3 d = prev.inverse() * T;
      const double v = d.translation().norm() * s.rate;
      const double w = d.angle() * s.rate / kDeg;
      if (v > s.max_speed)
        fail(tkey, "camera speed " + std::to_string(v) + " m/s at frame " + std::to_string(f) + " exceeds limits.max_speed " +
                       std::to_string(s.max_speed));
      if (w > s.max_rate)
        fail(tkey, "camera rotation rate " + std::to_string(w) + " deg/s at frame " + std::to_string(f) +
                       " exceeds limits.max_rate " + std::to_string(s.max_rate));
    }
    prev = T;
  }
}

Scenario loadScenario(const std::string& file, const ScenarioOverrides& ov) {
  return parseLoaded(config::loadYamlFile(file), ov);
}

Scenario parseScenario(const std::string& yaml_text, const std::string& pseudo_file, const std::string& base_dir,
                       const ScenarioOverrides& ov) {
  return parseLoaded(config::loadYamlText(yaml_text, pseudo_file, base_dir), ov);
}

}  // namespace dslam::synth
