#pragma once
/** \file scene.h
 *  The animated scene of a scenario: camera pose, object and people states
 *  at every frame, and the analytic primitives the renderer ray-casts. */
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "dslam/core/se3.h"
#include "dslam/synth/scenario.h"

namespace dslam::synth {

/** One analytic surface. Geometry is defined in a local frame T_wl (local to
 *  world); `half` gives the extents in that frame:
 *  - Box: half extents (x, y, z);
 *  - Cylinder: radii (x, y) and half height (z), axis = local z, capped;
 *  - Ellipsoid: radii (x, y, z);
 *  - Capsule: radius (x), half length of the axis segment (z), axis = local z;
 *  - Quad: half width (y), half height (z), zero thickness, normal = local x. */
struct Primitive {
  enum class Kind : uint8_t { Box, Cylinder, Ellipsoid, Capsule, Quad };
  Kind kind = Kind::Box;
  SE3 T_wl;
  Vec3 half{0.5, 0.5, 0.5};
  int instance_id = 0;   ///< object / person instance (1..N)
  int material = 0;      ///< texture index (renderer internal)
  Vec3 uv_offset{0, 0, 0};  ///< texture offset in metres (u, v)
  double bound_radius = 0;  ///< bounding sphere radius around T_wl.translation()
};

/** Signed distance (m) from world point p to the primitive surface
 *  (negative inside; ellipsoids approximately). */
double signedDistance(const Primitive& prim, const Vec3& p);

/** State of a rigid object at one frame. */
struct ObjectState {
  bool present = false;
  SE3 T_wo;  ///< object frame (bottom centre, yaw) to world
};

/** Which class a pixel belongs to (semantic/panoptic). */
struct InstanceInfo {
  int instance_id = 0;
  std::string name;        ///< object / person name
  std::string class_name;  ///< COCO name or the scenario's own name
  int category_id = 0;     ///< COCO id; 0 when not in the label set
  bool labelled = true;
  bool is_person = false;
  bool isthing = true;
};

class SceneModel {
 public:
  explicit SceneModel(const Scenario& s);
  const Scenario& scenario() const { return s_; }

  /** Camera pose T_wc at time t (seconds since frame 0) / at a frame. */
  SE3 cameraPoseAt(double t) const;
  SE3 cameraPose(int frame) const { return cameraPoseAt(s_.time(frame)); }
  /** Pose of the stereo right camera (baseline along camera +x). */
  SE3 rightCameraPose(int frame) const;

  ObjectState objectState(size_t object_index, int frame) const;
  ObjectState objectStateAt(size_t object_index, double t, int frame) const;
  bool personPresent(size_t person_index, int frame) const;
  /** Pelvis frame (x forward, z up) of a person at time t. */
  SE3 personRoot(size_t person_index, double t) const;

  /** All primitives present at frame (at time t for motion-blur samples). */
  std::vector<Primitive> primitives(int frame) const;
  std::vector<Primitive> primitivesAt(int frame, double t) const;
  /** Primitives of one object / person (empty if absent). */
  std::vector<Primitive> objectPrimitives(size_t object_index, int frame, double t) const;
  std::vector<Primitive> personPrimitives(size_t person_index, int frame, double t) const;

  /** Distance from world point p to the surface of instance `id` at frame
   *  (+inf if absent). */
  double distanceToInstance(int frame, int instance_id, const Vec3& p) const;

  /** Instance table, indexed by instance id (entry 0 = the room). */
  const std::vector<InstanceInfo>& instances() const { return instances_; }

  /** Materials: one per texture the renderer must build, in a fixed order. */
  struct Material {
    TextureSpec spec;
    double width_m = 1, height_m = 1;  ///< texture extent (wraps beyond)
  };
  const std::vector<Material>& materials() const { return materials_; }
  /** Material indices of the room: walls (-x, +x, -y, +y), floor, ceiling. */
  int roomMaterial(int surface) const { return room_mat_[surface]; }

 private:
  Scenario s_;
  std::vector<InstanceInfo> instances_;
  std::vector<Material> materials_;
  std::vector<int> object_mat_;              ///< per object
  std::vector<std::array<int, 5>> person_mat_;  ///< shirt, pants, skin, hair, shoes
  int room_mat_[6] = {0, 0, 0, 0, 0, 0};
  std::vector<Vec3> jit_freq_, jit_phase_;   ///< handheld shake
};

}  // namespace dslam::synth
