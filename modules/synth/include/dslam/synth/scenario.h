#pragma once
/** \file scenario.h
 *  Synthetic scene description ("scenario"), loaded from YAML and strictly
 *  validated. The YAML format is documented in docs/scenarios.md.
 *
 *  World frame: z up, floor at z = 0; the room spans
 *  x in [-sx/2, sx/2], y in [-sy/2, sy/2], z in [0, sz]. Camera frame: OpenCV
 *  (x right, y down, z forward). Poses are T_wc (camera to world). */
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "dslam/core/camera.h"
#include "dslam/core/se3.h"

namespace dslam::synth {

using Vec3 = Eigen::Vector3d;

/** Procedural texture of a surface. */
struct TextureSpec {
  std::string kind = "posters";  ///< see textureKinds()
  Vec3 color{0.8, 0.8, 0.8};     ///< base colour, RGB in [0,1]
  bool has_color = false;        ///< colour given explicitly
  double scale = 1.0;            ///< pattern size multiplier
  uint64_t seed = 0;             ///< 0 = derived from the scenario seed and the surface
};

/** Names accepted by TextureSpec::kind. */
const std::vector<std::string>& textureKinds();

/** Linear motion along waypoints (objects and walking people). */
struct PathSpec {
  std::vector<Vec3> waypoints;  ///< world points (people: z ignored)
  double speed = 1.0;           ///< m/s
  std::string mode = "pingpong";  ///< loop | pingpong | once
  double start = 0.0;           ///< seconds after the first frame before moving
  bool empty() const { return waypoints.empty(); }
};

/** A rigid object. `position` is the centre of its bottom face, `yaw`
 *  rotates about the world z axis (degrees in YAML, radians here). */
struct ObjectSpec {
  std::string name;
  std::string type;        ///< box | cylinder | sphere | quad | table | chair | shelf | monitor | plant
  std::string class_name;  ///< COCO name, or any name when !labelled
  int category_id = 0;     ///< COCO id (0 when !labelled)
  bool labelled = true;    ///< false: class not in the detector label set (panoptic void)
  Vec3 size{0.5, 0.5, 0.5};  ///< x (width), y (depth), z (height) in the object frame, metres
  Vec3 position{0, 0, 0};
  bool has_position = false;
  double yaw = 0;          ///< radians
  double pitch = 0;        ///< radians (tilt about the object y axis)
  TextureSpec texture;
  bool present = true;     ///< false: absent until an `added`/`replaced` event
  PathSpec path;           ///< moving object (optional)
  int instance_id = 0;     ///< assigned 1..N in file order (objects, then people)
  std::string key;         ///< YAML key path, e.g. "objects[3]"
};

/** An articulated person. */
struct PersonSpec {
  std::string name;
  std::string action = "walk";  ///< walk | sit | stand
  PathSpec path;                ///< walk: floor waypoints
  Vec3 position{0, 0, 0};       ///< sit/stand: floor position (sit: under the pelvis)
  double yaw = 0;               ///< sit/stand: heading, radians
  std::string chair;            ///< sit: name of the chair (sets position and yaw)
  double height = 1.75;
  double seat_height = 0.46;
  double enter = -1;            ///< seconds; absent before (< 0: from the start)
  double leave = -1;            ///< seconds; absent from then on (< 0: never)
  TextureSpec shirt{"stripes", {0.2, 0.3, 0.7}, false, 1.0, 0};
  TextureSpec pants{"denim", {0.15, 0.18, 0.3}, false, 1.0, 0};
  Vec3 skin{0.85, 0.65, 0.52};
  Vec3 hair{0.15, 0.1, 0.06};
  int instance_id = 0;
  std::string key;
};

/** A change of the scene: moved / removed / added / replaced. */
struct EventSpec {
  std::string type;
  std::string object;      ///< name of the object concerned
  std::string by;          ///< replaced: the new object (absent before)
  int first = 0, last = 0; ///< frame range of the change (instantaneous: first == last)
  Vec3 position{0, 0, 0};  ///< moved: target position
  double yaw = 0;          ///< moved: target yaw (radians)
  bool has_yaw = false;
  std::string key;
};

/** Camera trajectory keyframe. Orientation from look_at (with world z up),
 *  or from rpy (degrees in YAML: roll about the optical axis, then pitch up,
 *  yaw about world z; yaw 0 looks along +x). */
struct CameraKeyframe {
  double t = 0;
  Vec3 position{0, 0, 1.5};
  std::optional<Vec3> look_at;
  Vec3 rpy{0, 0, 0};  ///< radians
};

struct TrajectorySpec {
  std::string type = "keyframes";  ///< keyframes | static | xyz | rpy | halfsphere | orbit
  std::string interpolation = "spline";  ///< keyframes: spline | linear
  std::vector<CameraKeyframe> keyframes;
  Vec3 center{0, 0, 1.4};
  Vec3 look_at{1, 0, 1.2};
  double amplitude = 0.25;   ///< xyz: metres; rpy: degrees (stored in degrees)
  double period = 6.0;       ///< seconds of one oscillation
  double radius = 0.5;       ///< halfsphere / orbit radius (m)
  double heading = 0.0;      ///< orbit: view direction from the tangent, degrees (+ = outward)
  double pitch = 0.0;        ///< orbit: degrees (+ = up)
  double jitter_position = 0.002;  ///< handheld shake, metres
  double jitter_rotation = 0.2;    ///< handheld shake, degrees
};

struct NoiseSpec {
  bool enabled = true;         ///< master switch (off: exact depth, no image noise)
  double depth_sigma = 1.425e-3;  ///< sigma = depth_sigma * z^2 (m)
  double depth_min = 0.4, depth_max = 8.0;
  double edge_dropout = 0.5;   ///< probability to invalidate a depth-edge pixel
  double edge_threshold = 0.06;  ///< relative depth jump counted as an edge
  double image_sigma = 1.5;    ///< grey levels
  double motion_blur = 0.0;    ///< exposure as a fraction of the frame period (0 = off)
  int blur_samples = 4;
  double optics_blur = 0.55;   ///< lens blur sigma in pixels (applied even without noise)
};

struct RoomSpec {
  Vec3 size{6, 5, 2.8};
  TextureSpec walls[4] = {{"posters"}, {"posters"}, {"posters"}, {"posters"}};  ///< -x, +x, -y, +y
  TextureSpec floor{"tiles", {0.6, 0.55, 0.5}, false, 1.0, 0};
  TextureSpec ceiling{"ceiling", {0.9, 0.9, 0.88}, false, 1.0, 0};
};

struct Scenario {
  std::string name;
  std::string file;          ///< source file ("" when parsed from text)
  std::string description;
  int frames = 300;
  double rate = 30.0;
  double start_time = 1000.0;  ///< timestamp of frame 0
  uint64_t seed = 1;
  int width = 640, height = 480;
  PinholeCamera intrinsics;    ///< at width x height
  double baseline = 0.1;       ///< stereo baseline (m)
  double max_speed = 1.0;      ///< validation limits (m/s, deg/s)
  double max_rate = 90.0;
  TrajectorySpec trajectory;
  NoiseSpec noise;
  RoomSpec room;
  std::vector<ObjectSpec> objects;
  std::vector<PersonSpec> people;
  std::vector<EventSpec> events;
  /** Frame ranges [first, last] with the lights off: black colour images
   *  (a depth camera still measures; labels are still written). */
  std::vector<std::pair<int, int>> darkness;

  bool dark(int frame) const {
    for (const auto& [a, b] : darkness)
      if (frame >= a && frame <= b) return true;
    return false;
  }
  double time(int frame) const { return frame / rate; }  ///< seconds since frame 0
  double stamp(int frame) const { return start_time + time(frame); }
  const ObjectSpec* findObject(const std::string& n) const;
};

/** Overrides applied after loading (0 / empty = keep). */
struct ScenarioOverrides {
  int frames = 0;
  int width = 0, height = 0;   ///< intrinsics are scaled to the new size
  std::optional<uint64_t> seed;
  std::optional<bool> noise;   ///< force noise on/off
  std::optional<double> baseline;
};

/** Loads and validates a scenario file (supports $include and ${VAR|def}).
 *  Throws ConfigError naming file, line and key path on any problem:
 *  unknown key, unknown object type or class, path outside the room, camera
 *  inside an object, camera too fast, bad event reference. */
Scenario loadScenario(const std::string& file, const ScenarioOverrides& ov = {});
/** Same from YAML text (`pseudo_file` is used in messages, includes resolve
 *  against `base_dir`). */
Scenario parseScenario(const std::string& yaml_text, const std::string& pseudo_file = "<scenario>",
                       const std::string& base_dir = ".", const ScenarioOverrides& ov = {});
/** Applies overrides (resolution scales intrinsics) and re-validates. */
void applyOverrides(Scenario& s, const ScenarioOverrides& ov);
/** Size limits checked by validateScenario(): events, and frames x (objects
 *  + people) (e.g. 100000 frames with 20 objects, 600 frames with 3000). */
constexpr size_t kMaxEvents = 256;
constexpr uint64_t kMaxFrameEntities = 2'000'000;
/** Geometric validation (camera inside objects / outside the room, speed
 *  limits); called by the loaders. */
void validateScenario(const Scenario& s);

}  // namespace dslam::synth
