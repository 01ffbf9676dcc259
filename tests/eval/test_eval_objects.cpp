// `dslam eval objects` / dslam::eval::evaluateObjects: a crafted scene (ground-truth
// objects.json + groundtruth.txt as `dslam synth` writes them) and crafted run
// object maps (objects.json "dslam-objects" + trajectory.txt): recall, stale,
// moved, gone, added and false objects, the alignment, and the bad inputs.
#include <cmath>
#include <filesystem>

#include <nlohmann/json.hpp>

#include <Eigen/Geometry>

#include <opencv2/imgcodecs.hpp>

#include "dslam/core/coco.h"
#include "dslam/core/error.h"
#include "dslam/eval/objects.h"
#include "dslam/trajectory/io.h"
#include "test_support.h"

using namespace dslam;
using dslam::test::runDslam;
using dslam::test::tempDir;
using dslam::test::writeFile;
using json = nlohmann::json;

namespace {

constexpr int kFrames = 20;
constexpr double kT0 = 100.0, kDt = 0.1;  // stamps kT0 + f * kDt
double stamp(int f) { return kT0 + f * kDt; }

SE3 yawPose(double x, double y, double z, double yaw_deg) {
  return SE3(Eigen::Quaterniond(Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitZ())),
             Eigen::Vector3d(x, y, z));
}

json trackEntry(int f, const SE3& T) {
  const auto& q = T.quaternion();
  const auto& t = T.translation();
  return json::array({f, t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()});
}

/** One object of a scene objects.json: present over `ranges`, poses `track`,
 *  `px` visible pixels in every frame it is present. */
json sceneObject(int id, const std::string& name, const std::string& cls, int cat, std::vector<double> size,
                 std::vector<std::pair<int, int>> ranges, std::vector<std::pair<int, SE3>> track, int px,
                 bool labelled = true) {
  json pr = json::array(), tr = json::array(), vis = json::array();
  for (auto [a, b] : ranges) pr.push_back({a, b});
  for (auto& [f, T] : track) tr.push_back(trackEntry(f, T));
  for (int f = 0; f < kFrames; f++) {
    bool on = false;
    for (auto [a, b] : ranges) on = on || (f >= a && f <= b);
    vis.push_back(on ? px : 0);
  }
  return {{"instance_id", id}, {"name", name}, {"kind", "object"},  {"type", "box"},
          {"class", cls},      {"category_id", cat}, {"labelled", labelled}, {"size", size},
          {"moving", false},   {"present", pr},  {"track", tr},      {"visible_pixels", vis}};
}

// The crafted scene: sizes and final poses.
const SE3 kChair = yawPose(2, 0, 0, 0);           // static chair 0.5 x 0.5 x 1.0
const SE3 kTv = yawPose(3, 1, 0.75, 90);          // static tv 0.2 x 0.6 x 0.4
const SE3 kSuitOld = yawPose(1, -1, 0, 0);        // suitcase 0.25 x 0.5 x 0.7, moved during frames 8..10
const SE3 kSuitNew = yawPose(1.35, -1.3, 0, 30);  // 0.19 m from the old centre
const SE3 kPlant = yawPose(0, -2, 0, 0);          // potted plant 0.5 x 0.5 x 1.1, removed at frame 10
const SE3 kBackpack = yawPose(0, 2, 0, 0);        // backpack 0.2 x 0.3 x 0.45, replaced at frame 10 by
const SE3 kChairNew = yawPose(0, 2, 0, 45);       // chair_new 0.5 x 0.5 x 0.9
const SE3 kCup = yawPose(-2, 0, 0.7, 0);          // cup never seen (0 px)

Eigen::Vector3d centre(const SE3& T, double h) { return T * Eigen::Vector3d(0, 0, h / 2); }

/** Camera path: not collinear (the alignment is determined before frame 8). */
Trajectory groundTruth() {
  Trajectory t;
  for (int f = 0; f < kFrames; f++)
    t.push_back(stamp(f), SE3(Eigen::Quaterniond(Eigen::AngleAxisd(0.05 * f, Eigen::Vector3d::UnitZ())),
                              Eigen::Vector3d(0.2 * f, 0.3 * std::sin(0.7 * f), 1.2 + 0.2 * std::cos(0.5 * f))));
  return t;
}

std::string writeScene(const std::string& dir) {
  std::filesystem::create_directories(dir);
  json objs = json::array();
  objs.push_back(sceneObject(1, "chair", "chair", 62, {0.5, 0.5, 1.0}, {{0, 19}}, {{0, kChair}}, 1000));
  objs.push_back(sceneObject(2, "tv", "tv", 72, {0.2, 0.6, 0.4}, {{0, 19}}, {{0, kTv}}, 1000));
  std::vector<std::pair<int, SE3>> suit = {{0, kSuitOld}};
  suit.push_back({9, yawPose(1.2, -1.15, 0, 15)});
  suit.push_back({10, kSuitNew});
  objs.push_back(sceneObject(3, "suitcase", "suitcase", 33, {0.25, 0.5, 0.7}, {{0, 19}}, suit, 500));
  objs.push_back(sceneObject(4, "plant", "potted plant", 64, {0.5, 0.5, 1.1}, {{0, 9}}, {{0, kPlant}}, 500));
  objs.push_back(sceneObject(5, "backpack", "backpack", 27, {0.2, 0.3, 0.45}, {{0, 9}}, {{0, kBackpack}}, 500));
  objs.push_back(sceneObject(6, "chair_new", "chair", 62, {0.5, 0.5, 0.9}, {{10, 19}}, {{10, kChairNew}}, 500));
  objs.push_back(sceneObject(7, "cup", "cup", 47, {0.1, 0.1, 0.1}, {{0, 19}}, {{0, kCup}}, 0));
  objs.push_back(sceneObject(8, "desk", "desk", 0, {0.8, 1.6, 0.75}, {{0, 19}}, {{0, yawPose(3, -1, 0, 0)}}, 5000,
                             false));
  json events = json::array();
  events.push_back({{"type", "moved"}, {"object", "suitcase"}, {"instance_id", 3}, {"frames", {8, 10}},
                    {"timestamps", {stamp(8), stamp(10)}}, {"to", {1.35, -1.3, 0}}});
  events.push_back({{"type", "removed"}, {"object", "plant"}, {"instance_id", 4}, {"frames", {10, 10}},
                    {"timestamps", {stamp(10), stamp(10)}}});
  events.push_back({{"type", "replaced"}, {"object", "backpack"}, {"instance_id", 5}, {"by", "chair_new"},
                    {"by_instance_id", 6}, {"frames", {10, 10}}, {"timestamps", {stamp(10), stamp(10)}}});
  const json root = {{"scenario", "crafted"}, {"frames", kFrames}, {"rate", 10},  {"start_time", kT0},
                     {"objects", objs},       {"people", json::array()}, {"events", events}};
  writeFile(dir + "/objects.json", root.dump(1));
  traj::writeTum(dir + "/groundtruth.txt", groundTruth(), "crafted");
  return dir;
}

json estObject(int64_t id, int cls, const Eigen::Vector3d& c, bool active, int map = 0) {
  return {{"id", id},
          {"map", map},
          {"class_id", cls},
          {"class", coco::name(cls)},
          {"centroid", {c.x(), c.y(), c.z()}},
          {"box_min", {c.x() - 0.1, c.y() - 0.1, c.z() - 0.1}},
          {"box_max", {c.x() + 0.1, c.y() + 0.1, c.z() + 0.1}},
          {"points", 40},
          {"belief", active ? 0.9 : 0.1},
          {"active", active},
          {"first_seen_kf", 1},
          {"last_seen_kf", 9},
          {"first_seen_t", 100.1},
          {"last_seen_t", 101.5},
          {"sightings", 5}};
}

/** A perfect object map in the world frame: every present object at its box
 *  centre, the objects that left inactive at their old places. */
std::vector<json> perfectMap() {
  return {estObject(1, 62, centre(kChair, 1.0), true),
          estObject(2, 72, centre(kTv, 0.4), true),
          estObject(3, 33, centre(kSuitNew, 0.7), true),
          estObject(4, 33, centre(kSuitOld, 0.7), false),
          estObject(5, 64, centre(kPlant, 1.1), false),
          estObject(6, 27, centre(kBackpack, 0.45), false),
          estObject(7, 62, centre(kChairNew, 0.9), true)};
}

/** A run folder: objects (positions in the world frame) and the trajectory,
 *  both expressed in the frame T_ew * world. */
std::string writeRun(const std::string& dir, const std::vector<json>& objects, const SE3& T_ew = SE3(),
                     int map = 0) {
  std::filesystem::create_directories(dir);
  json objs = json::array();
  for (json o : objects) {
    for (const char* k : {"centroid", "box_min", "box_max"}) {
      const Eigen::Vector3d p(o[k][0].get<double>(), o[k][1].get<double>(), o[k][2].get<double>());
      const Eigen::Vector3d q = T_ew * p;
      o[k] = {q.x(), q.y(), q.z()};
    }
    objs.push_back(o);
  }
  writeFile(dir + "/objects.json",
            json({{"format", "dslam-objects"}, {"version", 1}, {"map", map}, {"objects", objs}}).dump(1));
  Trajectory t = groundTruth();
  for (auto& p : t.poses) p = T_ew * p;
  traj::writeTum(dir + "/trajectory.txt", t, "crafted run");
  return dir;
}

eval::ObjectEvalResult evaluate(const std::string& run, const std::string& scene,
                                eval::Align align = eval::Align::SE3) {
  eval::ObjectEvalOptions o;
  o.align = align;
  const Trajectory t = align == eval::Align::None ? Trajectory() : traj::readTum(run + "/trajectory.txt");
  return eval::evaluateObjects(eval::readScene(scene), eval::readEstObjects(run + "/objects.json"), t, o);
}

const eval::GtObjectResult& gt(const eval::ObjectEvalResult& r, const std::string& name) {
  for (const auto& g : r.gt)
    if (g.name == name) return g;
  throw std::runtime_error("no ground-truth object " + name);
}

void expectPerfect(const eval::ObjectEvalResult& r) {
  EXPECT_EQ(r.static_total, 2);  // chair, tv (the cup was never seen, the desk is unlabelled)
  EXPECT_EQ(r.static_found, 2);
  EXPECT_DOUBLE_EQ(r.recall(), 1.0);
  EXPECT_EQ(r.stale, 0);
  EXPECT_EQ(r.moved_total, 1);
  EXPECT_EQ(r.moved_found, 1);
  ASSERT_EQ(r.moved_errors.size(), 1u);
  EXPECT_NEAR(r.moved_errors[0], 0, 1e-9);
  EXPECT_NEAR(r.moved_centre_errors[0], 0, 1e-6);
  EXPECT_EQ(r.gone_total, 2);  // plant, backpack
  EXPECT_EQ(r.gone_inactive, 2);
  EXPECT_EQ(r.added_total, 1);  // chair_new
  EXPECT_EQ(r.added_found, 1);
  EXPECT_EQ(r.false_objects, 0);
  EXPECT_EQ(gt(r, "suitcase").match, 3);
  EXPECT_EQ(gt(r, "chair_new").match, 7);
  EXPECT_EQ(gt(r, "cup").counted, false);
  ASSERT_EQ(gt(r, "suitcase").old_places.size(), 1u);
  EXPECT_EQ(gt(r, "suitcase").old_places[0].frame, 7);
  EXPECT_EQ(gt(r, "suitcase").old_places[0].state, "inactive");
}

}  // namespace

TEST(EvalObjects, BoxDistanceAndCentre) {
  eval::ObjectBox b{yawPose(1, 2, 0, 90), Eigen::Vector3d(0.4, 1.0, 0.6)};
  EXPECT_TRUE(b.centre().isApprox(Eigen::Vector3d(1, 2, 0.3)));
  EXPECT_DOUBLE_EQ(b.distance(Eigen::Vector3d(1, 2, 0.3)), 0);
  // Yaw 90: the box's x (0.4) is along world y, its y (1.0) along world x.
  EXPECT_NEAR(b.distance(Eigen::Vector3d(1.7, 2, 0.3)), 0.2, 1e-12);
  EXPECT_NEAR(b.distance(Eigen::Vector3d(1, 2.5, 0.3)), 0.3, 1e-12);
  EXPECT_NEAR(b.distance(Eigen::Vector3d(1, 2, 1.0)), 0.4, 1e-12);
}

TEST(EvalObjects, PerfectMapHasRecallOneAndNoStaleObject) {
  const std::string d = tempDir("evalobj");
  const std::string scene = writeScene(d + "/scene");
  expectPerfect(evaluate(writeRun(d + "/run", perfectMap()), scene));
}

TEST(EvalObjects, ObjectLeftAtItsOldPlaceIsStale) {
  const std::string d = tempDir("evalobj");
  const std::string scene = writeScene(d + "/scene");
  auto m = perfectMap();
  m[3]["active"] = true;  // the suitcase's old object is still active
  const auto r = evaluate(writeRun(d + "/run", m), scene);
  EXPECT_EQ(r.stale, 1);
  EXPECT_EQ(r.moved_found, 1);  // the new one still matches
  EXPECT_EQ(r.false_objects, 0);
  EXPECT_EQ(gt(r, "suitcase").old_places[0].state, "active");
  ASSERT_EQ(gt(r, "suitcase").old_places[0].est.size(), 1u);
  EXPECT_EQ(gt(r, "suitcase").old_places[0].est[0], 4);
  EXPECT_EQ(r.stale_dormant, 0);
  m[3]["dormant"] = true;  // in the map, not used to localise until seen again: still stale, and said so
  const auto rd = evaluate(writeRun(d + "/run_dormant", m), scene);
  EXPECT_EQ(rd.stale, 1);
  EXPECT_EQ(rd.stale_dormant, 1);
  m[3]["dormant"] = "yes";
  EXPECT_THROW(evaluate(writeRun(d + "/run_bad", m), scene), DataError);
  m[3].erase("dormant");

  // Only the old object (the map never noticed the move): its centroid is
  // within the match radius of the new box (0.19 m) but nearer the old place,
  // so it is not a match of the moved object: missed, and stale.
  m.erase(m.begin() + 2);
  const auto r2 = evaluate(writeRun(d + "/run2", m), scene);
  EXPECT_EQ(r2.stale, 1);
  EXPECT_EQ(r2.moved_found, 0);
  EXPECT_EQ(gt(r2, "suitcase").match, -1);
}

TEST(EvalObjects, DuplicateOnTheMovedObjectIsNotStale) {
  const std::string d = tempDir("evalobj");
  const std::string scene = writeScene(d + "/scene");
  auto m = perfectMap();
  // A second active suitcase on the moved suitcase (inside its new box), 0.23
  // m from the box it left: a duplicate of the present object, not an object
  // left at the old place.
  m.push_back(estObject(24, 33, centre(kSuitNew, 0.7) + Eigen::Vector3d(0.03, 0, 0), true));
  // And one inside the old box only: stale.
  m.push_back(estObject(25, 33, centre(kSuitOld, 0.7) + Eigen::Vector3d(-0.05, 0, 0), true));
  const auto r = evaluate(writeRun(d + "/run", m), scene);
  EXPECT_EQ(r.moved_found, 1);
  EXPECT_EQ(r.stale, 1);
  EXPECT_EQ(r.false_objects, 1);
  for (const auto& e : r.est) {
    if (e.obj.id == 24) {
      EXPECT_EQ(e.verdict, eval::Verdict::False);
      EXPECT_NE(e.note.find("duplicate of suitcase"), std::string::npos) << e.note;
    }
    if (e.obj.id == 25) {
      EXPECT_EQ(e.verdict, eval::Verdict::Stale);
    }
  }
}

TEST(EvalObjects, AnObjectFirstSeenAfterThePlaceWasLeftIsFalseNotStale) {
  // An estimate made only of what the camera saw at a place after the object
  // had left it (another object's surface given the class) is no memory of
  // the object: a false object, not a stale one. The suitcase left its place
  // over frames 8-10 (gone after stamp(10)), the plant at frame 10.
  const std::string d = tempDir("evalobj");
  const std::string scene = writeScene(d + "/scene");
  auto m = perfectMap();
  json late_suit = estObject(24, 33, centre(kSuitOld, 0.7) + Eigen::Vector3d(-0.05, 0, 0), true);
  late_suit["first_seen_t"] = stamp(10) + 0.05;
  json late_plant = estObject(25, 64, centre(kPlant, 1.1), true);
  late_plant["first_seen_t"] = stamp(12);
  m.push_back(late_suit);
  m.push_back(late_plant);
  const auto r = evaluate(writeRun(d + "/run", m), scene);
  EXPECT_EQ(r.stale, 0);
  EXPECT_EQ(r.false_objects, 2);
  EXPECT_EQ(r.moved_found, 1);
  EXPECT_EQ(r.gone_inactive, 2);  // the plant's own (old) object is inactive
  EXPECT_EQ(gt(r, "suitcase").old_places[0].state, "inactive");
  EXPECT_EQ(gt(r, "plant").old_places[0].state, "inactive");
  for (const auto& e : r.est) {
    if (e.obj.id == 24 || e.obj.id == 25) {
      EXPECT_EQ(e.verdict, eval::Verdict::False) << e.obj.id << " " << e.note;
    }
  }

  // First seen while the suitcase was still leaving (before stamp(10)): what
  // it saw may be the suitcase at its old place, so it is stale as before.
  m[7]["first_seen_t"] = stamp(10) - 0.05;
  const auto r2 = evaluate(writeRun(d + "/run2", m), scene);
  EXPECT_EQ(r2.stale, 1);
  EXPECT_EQ(r2.false_objects, 1);
  EXPECT_EQ(gt(r2, "suitcase").old_places[0].state, "active");
}

TEST(EvalObjects, AFragmentOfTheMovedObjectsSurfaceInsideTheOldPlaceIsNotStale) {
  // The suitcase moved by less than its size: the places overlap. A second
  // active suitcase 3 cm outside its new box (a fragment of its surface, the
  // centroid off by depth noise and the alignment) and inside the old box:
  // within on_object_margin (5 cm) of the present object, a duplicate of it.
  // With the margin 0 the nearer box decides: stale.
  const std::string d = tempDir("evalobj");
  const std::string scene = writeScene(d + "/scene");
  auto m = perfectMap();
  const Eigen::Vector3d c = kSuitNew * Eigen::Vector3d(-(0.125 + 0.03), 0.2, 0.35);
  m.push_back(estObject(26, 33, c, true));
  const std::string run = writeRun(d + "/run", m);
  const auto r = evaluate(run, scene);
  EXPECT_EQ(r.moved_found, 1);
  EXPECT_EQ(r.stale, 0);
  EXPECT_EQ(r.false_objects, 1);
  bool seen = false;
  for (const auto& e : r.est)
    if (e.obj.id == 26) {
      seen = true;
      EXPECT_EQ(e.verdict, eval::Verdict::False);
      EXPECT_NE(e.note.find("duplicate of suitcase"), std::string::npos) << e.note;
      EXPECT_NEAR(e.box_dist, 0.03, 1e-6);
    }
  EXPECT_TRUE(seen);
  eval::ObjectEvalOptions o;
  o.on_object_margin = 0;
  const auto r0 = eval::evaluateObjects(eval::readScene(scene), eval::readEstObjects(run + "/objects.json"),
                                        traj::readTum(run + "/trajectory.txt"), o);
  EXPECT_EQ(r0.stale, 1);
  EXPECT_EQ(r0.false_objects, 0);
  o.on_object_margin = -1;
  EXPECT_THROW(eval::evaluateObjects(eval::readScene(scene), eval::readEstObjects(run + "/objects.json"),
                                     traj::readTum(run + "/trajectory.txt"), o),
               ConfigError);
}

TEST(EvalObjects, VanishedAndReplacedObjectsStillActiveAreStale) {
  const std::string d = tempDir("evalobj");
  const std::string scene = writeScene(d + "/scene");
  auto m = perfectMap();
  m[4]["active"] = true;  // plant
  m[5]["active"] = true;  // backpack (replaced by a chair)
  const auto r = evaluate(writeRun(d + "/run", m), scene);
  EXPECT_EQ(r.stale, 2);
  EXPECT_EQ(r.gone_total, 2);
  EXPECT_EQ(r.gone_inactive, 0);
  EXPECT_EQ(r.added_found, 1);
  EXPECT_EQ(gt(r, "plant").old_places[0].state, "active");
}

TEST(EvalObjects, MovedObjectCentroidErrorIsTheDistanceToItsBox) {
  const std::string d = tempDir("evalobj");
  const std::string scene = writeScene(d + "/scene");
  auto m = perfectMap();
  // 7 cm outside the suitcase's new box along its x axis (half width 0.125).
  const Eigen::Vector3d c = kSuitNew * Eigen::Vector3d(0.125 + 0.07, 0, 0.35);
  m[2] = estObject(3, 33, c, true);
  const auto r = evaluate(writeRun(d + "/run", m), scene);
  EXPECT_EQ(r.moved_found, 1);
  ASSERT_EQ(r.moved_errors.size(), 1u);
  EXPECT_NEAR(r.moved_errors[0], 0.07, 1e-6);
  EXPECT_NEAR(r.moved_centre_errors[0], 0.195, 1e-6);
  EXPECT_EQ(r.stale, 0);
  // 0.6 m away: outside the match radius, a false object and a missed move.
  m[2] = estObject(3, 33, kSuitNew * Eigen::Vector3d(0.125 + 0.6, 0, 0.35), true);
  const auto r2 = evaluate(writeRun(d + "/run2", m), scene);
  EXPECT_EQ(r2.moved_found, 0);
  EXPECT_EQ(r2.false_objects, 1);
}

TEST(EvalObjects, FalseDuplicateOtherMapAndUnevaluatedClasses) {
  const std::string d = tempDir("evalobj");
  const std::string scene = writeScene(d + "/scene");
  auto m = perfectMap();
  m.push_back(estObject(20, 47, Eigen::Vector3d(-1, -1, 0.5), true));   // a cup where there is none
  m.push_back(estObject(21, 62, centre(kChair, 1.0) + Eigen::Vector3d(0.05, 0, 0), true));  // duplicate chair
  m.push_back(estObject(22, 62, Eigen::Vector3d(-1, 1, 0.5), true, 1));  // another map: not evaluated
  m.push_back(estObject(23, 1, Eigen::Vector3d(0, 0, 1), true));        // person: not evaluated
  const auto r = evaluate(writeRun(d + "/run", m), scene);
  EXPECT_EQ(r.false_objects, 2);
  EXPECT_EQ(r.est_other_maps, 1u);
  EXPECT_EQ(r.est.size(), m.size() - 1);
  EXPECT_EQ(r.static_found, 2);
  EXPECT_EQ(r.stale, 0);
  bool duplicate = false;
  for (const auto& e : r.est) {
    if (e.obj.id == 21) {
      EXPECT_EQ(e.verdict, eval::Verdict::False);
      duplicate = e.note.find("duplicate of chair") != std::string::npos;
    }
    if (e.obj.id == 23) {
      EXPECT_EQ(e.verdict, eval::Verdict::Ignored);
    }
  }
  EXPECT_TRUE(duplicate);
}

TEST(EvalObjects, MinPointsLeavesOutObjectsOfFewerPoints) {
  // A 3-point duplicate of the chair and a 4-point stale suitcase: with
  // min_points 5 they are as if not in the file, the rest is perfect.
  const std::string d = tempDir("evalobj");
  const std::string scene = writeScene(d + "/scene");
  auto m = perfectMap();
  m.push_back(estObject(21, 62, centre(kChair, 1.0) + Eigen::Vector3d(0.05, 0, 0), true));
  m.back()["points"] = 3;
  m[3]["active"] = true;  // the suitcase's old object is still active ...
  m[3]["points"] = 4;     // ... with 4 points
  const std::string run = writeRun(d + "/run", m);
  const auto all = evaluate(run, scene);
  EXPECT_EQ(all.false_objects, 1);
  EXPECT_EQ(all.stale, 1);
  EXPECT_EQ(all.est_too_few_points, 0u);
  eval::ObjectEvalOptions o;
  o.min_points = 5;
  const auto r = eval::evaluateObjects(eval::readScene(scene), eval::readEstObjects(run + "/objects.json"),
                                       traj::readTum(run + "/trajectory.txt"), o);
  EXPECT_EQ(r.est_too_few_points, 2u);
  EXPECT_EQ(r.est.size(), m.size() - 2);
  EXPECT_EQ(r.false_objects, 0);
  EXPECT_EQ(r.stale, 0);
  EXPECT_EQ(r.static_found, 2);
  EXPECT_EQ(r.moved_found, 1);
  EXPECT_NE(eval::toText(r).find("2 of fewer than 5 points left out"), std::string::npos);
}

TEST(EvalObjects, MinSightingsLeavesOutTentativeObjectsUnlessLarge) {
  // A duplicate of the chair seen by one keyframe, a stale suitcase seen by
  // one keyframe with 30 points, the rest seen by 4 keyframes.
  const std::string d = tempDir("evalobj");
  const std::string scene = writeScene(d + "/scene");
  auto m = perfectMap();
  for (auto& o : m) o["sightings"] = 4;
  m.push_back(estObject(21, 62, centre(kChair, 1.0) + Eigen::Vector3d(0.05, 0, 0), true));
  m.back()["sightings"] = 1;
  m.back()["points"] = 6;
  m[3]["active"] = true;  // the suitcase's old object is still active ...
  m[3]["sightings"] = 1;  // ... seen once ...
  m[3]["points"] = 30;    // ... with 30 points
  const std::string run = writeRun(d + "/run", m);
  auto eval = [&](int min_sightings, int confirm_points) {
    eval::ObjectEvalOptions o;
    o.min_sightings = min_sightings;
    o.confirm_points = confirm_points;
    return eval::evaluateObjects(eval::readScene(scene), eval::readEstObjects(run + "/objects.json"),
                                 traj::readTum(run + "/trajectory.txt"), o);
  };
  const auto all = eval(1, 0);
  EXPECT_EQ(all.false_objects, 1);
  EXPECT_EQ(all.stale, 1);
  EXPECT_EQ(all.est_too_few_sightings, 0u);
  const auto r = eval(2, 0);
  EXPECT_EQ(r.est_too_few_sightings, 2u);
  EXPECT_EQ(r.est.size(), m.size() - 2);
  EXPECT_EQ(r.false_objects, 0);
  EXPECT_EQ(r.stale, 0);
  EXPECT_EQ(r.static_found, 2);
  EXPECT_EQ(r.moved_found, 1);
  EXPECT_NE(eval::toText(r).find("2 seen by fewer than 2 keyframes left out"), std::string::npos);
  const auto big = eval(2, 20);  // 30 points: the suitcase is kept, the 6-point duplicate is not
  EXPECT_EQ(big.est_too_few_sightings, 1u);
  EXPECT_EQ(big.false_objects, 0);
  EXPECT_EQ(big.stale, 1);
  EXPECT_NE(eval::toText(big).find("(and of fewer than 20 points) left out"), std::string::npos);
}

TEST(EvalObjects, MinSightingsOnAFileWithoutSightingsNamesIt) {
  const std::string d = tempDir("evalobj");
  const std::string scene = writeScene(d + "/scene");
  auto m = perfectMap();
  for (auto& o : m) o.erase("sightings");
  const std::string run = writeRun(d + "/run", m);
  EXPECT_EQ(evaluate(run, scene).static_found, 2);  // without --min-sightings the file is fine
  eval::ObjectEvalOptions o;
  o.min_sightings = 2;
  try {
    eval::evaluateObjects(eval::readScene(scene), eval::readEstObjects(run + "/objects.json"),
                          traj::readTum(run + "/trajectory.txt"), o);
    FAIL() << "expected an error";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("objects.json: object 1 has no 'sightings'"), std::string::npos) << e.what();
  }
}

TEST(EvalObjects, AlignmentUndoesAKnownOffset) {
  const std::string d = tempDir("evalobj");
  const std::string scene = writeScene(d + "/scene");
  const SE3 T_ew(Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -0.3, 1).normalized())),
                 Eigen::Vector3d(30, -20, 5));
  const std::string run = writeRun(d + "/run", perfectMap(), T_ew);
  const auto r = evaluate(run, scene);
  expectPerfect(r);
  EXPECT_EQ(r.align_pairs, 8u);  // frames 0..7, before the first event (frame 8)
  EXPECT_NEAR(r.align_until, stamp(8), 1e-9);
  EXPECT_LT(r.align_ate, 1e-6);
  const SE3 back = T_ew.inverse();
  EXPECT_TRUE(r.alignment.T.translation().isApprox(back.translation(), 1e-6));
  EXPECT_LT(r.alignment.T.quaternion().angularDistance(back.quaternion()), 1e-6);
  // Without the alignment nothing is where it should be.
  const auto n = evaluate(run, scene, eval::Align::None);
  EXPECT_EQ(n.static_found, 0);
  EXPECT_GT(n.false_objects, 0);
}

TEST(EvalObjects, BadInputs) {
  using dslam::test::dataError;
  const std::string d = tempDir("evalobj");
  const std::string scene = writeScene(d + "/scene");
  const std::string run = writeRun(d + "/run", perfectMap());
  auto has = [](const std::string& msg, const std::string& part) {
    EXPECT_NE(msg.find(part), std::string::npos) << "'" << part << "' not in: " << msg;
  };
  has(dataError([&] { eval::readEstObjects(d + "/none.json"); }), "objects file not found");
  has(dataError([&] { eval::readEstObjects(scene + "/objects.json"); }), "ground-truth objects.json of the dslam synth");
  writeFile(d + "/other.json", R"({"format": "something", "version": 1})");
  has(dataError([&] { eval::readEstObjects(d + "/other.json"); }), "expected \"dslam-objects\"");
  writeFile(d + "/v2.json", R"({"format": "dslam-objects", "version": 2, "map": 0, "objects": []})");
  has(dataError([&] { eval::readEstObjects(d + "/v2.json"); }), "unsupported version 2");
  writeFile(d + "/syntax.json", "{\"format\": \"dslam-objects\",\n \"version\": 1,,}");
  has(dataError([&] { eval::readEstObjects(d + "/syntax.json"); }), "syntax.json:2:");
  auto one = [&](const std::string& obj) {
    writeFile(d + "/one.json", R"({"format": "dslam-objects", "version": 1, "map": 0, "objects": [)" + obj + "]}");
    return dataError([&] { eval::readEstObjects(d + "/one.json"); });
  };
  const std::string c = R"("centroid": [0, 0, 0], "active": true)";
  has(one(R"({"id": 4, "class_id": 300, )" + c + "}"), "objects[0] (id 4): unknown class id 300");
  has(one(R"({"id": 4, "class": "chiar", )" + c + "}"), "unknown class 'chiar'");
  has(one(R"({"id": 4, "class_id": 62, "class": "couch", )" + c + "}"), "class 'couch' is not the name of class id 62");
  has(one(R"({"id": 4, "class_id": 62, "active": true})"), "missing 'centroid'");
  has(one(R"({"id": 4, "class_id": 62, "centroid": [1, 2], "active": true})"), "'centroid' must be [x, y, z]");
  has(one(R"({"id": 4, "class_id": 62, "box_min": [0, 1, 0], "box_max": [1, 0, 1], )" + c + "}"),
      "box_min is above box_max on axis y");
  has(one(R"({"id": 4, "class_id": 62, "points": -3, )" + c + "}"), "'points' must be >= 0");
  has(one(R"({"id": 4, "class_id": 62, )" + c + R"(}, {"id": 4, "class_id": 56, )" + c + "}"),
      "objects[1] (id 4): id 4 appears twice in map 0");

  has(dataError([&] { eval::readScene(d + "/nothere"); }), "scene folder not found");
  std::filesystem::create_directories(d + "/empty");
  has(dataError([&] { eval::readScene(d + "/empty"); }), "no objects.json");
  std::filesystem::create_directories(d + "/nogt");
  std::filesystem::copy_file(scene + "/objects.json", d + "/nogt/objects.json");
  has(dataError([&] { eval::readScene(d + "/nogt"); }), "no groundtruth.txt");

  // Trajectory of another scene: other stamps; or the same stamps, another path.
  const auto sc = eval::readScene(scene);
  const auto est = eval::readEstObjects(run + "/objects.json");
  Trajectory far = groundTruth();
  for (auto& t : far.stamps) t += 1000;
  has(dataError([&] { eval::evaluateObjects(sc, est, far); }), "the run and the scene do not match");
  Trajectory other = groundTruth();
  for (size_t i = 0; i < other.size(); i++)
    other.poses[i] = SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(std::cos(0.9 * i), 2 * std::sin(1.3 * i), 0));
  const std::string m = dataError([&] { eval::evaluateObjects(sc, est, other); });
  has(m, "the run and the scene do not match: ATE rmse");
  // Too few poses before the first event.
  eval::ObjectEvalOptions o;
  o.align_until = stamp(2);
  has(dataError([&] { eval::evaluateObjects(sc, est, groundTruth(), o); }), "only 2 trajectory poses before");
}

namespace {

/** A scene whose place-visibility is known: a chair at (0, 0, 0) moved to
 *  (2, 0, 0) during frames 3-4, a camera 3 m in front of its old place
 *  looking at it (optical axis along world +x) in all 10 frames, and depth
 *  maps of a constant `depth_m` (10: a far wall, the place is seen through;
 *  1: something right in front of the camera hides it). */
std::string visibilityScene(const std::string& dir, double depth_m, bool with_depth = true) {
  std::filesystem::create_directories(dir + "/depth");
  constexpr int n = 10;
  json objs = json::array();
  json pr = json::array({json::array({0, n - 1})}), tr = json::array(), vis = json::array();
  tr.push_back(trackEntry(0, yawPose(0, 0, 0, 0)));
  tr.push_back(trackEntry(4, yawPose(2, 0, 0, 0)));
  for (int f = 0; f < n; f++) vis.push_back(5000);
  objs.push_back({{"instance_id", 1}, {"name", "chair"}, {"kind", "object"}, {"type", "box"}, {"class", "chair"},
                  {"category_id", 62}, {"labelled", true}, {"size", {0.5, 0.5, 1.0}}, {"moving", false},
                  {"present", pr}, {"track", tr}, {"visible_pixels", vis}});
  json events = json::array();
  events.push_back({{"type", "moved"}, {"object", "chair"}, {"instance_id", 1}, {"frames", {3, 4}},
                    {"timestamps", {stamp(3), stamp(4)}}, {"to", {2, 0, 0}}});
  json root = {{"scenario", "visibility"}, {"frames", n}, {"rate", 10}, {"start_time", kT0},
               {"objects", objs}, {"people", json::array()}, {"events", events}};
  if (with_depth) {
    root["intrinsics"] = {{"fx", 500.0}, {"fy", 500.0}, {"cx", 320.0}, {"cy", 240.0}};
    root["width"] = 640;
    root["height"] = 480;
    root["depth_factor"] = 5000;
  }
  writeFile(dir + "/objects.json", root.dump(1));
  // Optical frame: x_c = -y_w, y_c = -z_w, z_c = +x_w.
  Eigen::Matrix3d R_wc;
  R_wc << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  Trajectory t;
  std::string list = "# timestamp filename\n";
  for (int f = 0; f < n; f++) {
    t.push_back(stamp(f), SE3(Eigen::Quaterniond(R_wc), Eigen::Vector3d(-3, 0, 0.5)));
    const std::string name = "depth/" + std::to_string(f) + ".png";
    cv::imwrite(dir + "/" + name, cv::Mat(480, 640, CV_16UC1, cv::Scalar(depth_m * 5000)));
    list += std::to_string(stamp(f)) + " " + name + "\n";
  }
  writeFile(dir + "/depth.txt", list);
  traj::writeTum(dir + "/groundtruth.txt", t, "visibility");
  return dir;
}

/** A map that kept the chair's old object active (stale) and found the new one. */
eval::EstObjects staleChair() {
  eval::EstObjects est;
  est.file = "crafted";
  for (const auto& [id, x] : std::vector<std::pair<int, double>>{{1, 0.0}, {2, 2.0}}) {
    eval::EstObject o;
    o.id = id;
    o.class_id = 62;
    o.centroid = Eigen::Vector3d(x, 0, 0.5);
    o.box_min = o.centroid - Eigen::Vector3d::Constant(0.2);
    o.box_max = o.centroid + Eigen::Vector3d::Constant(0.2);
    o.points = 40;
    est.objects.push_back(o);
  }
  return est;
}

}  // namespace

TEST(EvalObjects, StaleObjectsAtPlacesSeenSinceTheObjectLeft) {
  const std::string d = tempDir("evalobj");
  eval::ObjectEvalOptions o;
  o.align = eval::Align::None;
  // Seen through after the move: the stale object stands at a place the camera saw.
  auto r = eval::evaluateObjects(eval::readScene(visibilityScene(d + "/far", 10.0)), staleChair(), {}, o);
  ASSERT_TRUE(r.place_visibility);
  EXPECT_EQ(r.stale, 1);
  EXPECT_EQ(r.stale_seen, 1);
  const auto& place = gt(r, "chair").old_places.at(0);
  EXPECT_EQ(place.left_at, 4);
  EXPECT_DOUBLE_EQ(place.seen_after, 1.0);  // all 125 samples in the image, nothing in front
  // Hidden behind something 1 m from the camera: stale, but never seen since.
  r = eval::evaluateObjects(eval::readScene(visibilityScene(d + "/near", 1.0)), staleChair(), {}, o);
  EXPECT_EQ(r.stale, 1);
  EXPECT_EQ(r.stale_seen, 0);
  EXPECT_DOUBLE_EQ(gt(r, "chair").old_places.at(0).seen_after, 0.0);
  EXPECT_NE(eval::toText(r).find("1 (target 0); 0 at places seen since the object left, 1 at places never seen since"),
            std::string::npos)
      << eval::toText(r);
  EXPECT_EQ(json::parse(eval::toJson(r))["stale_place_seen"].get<int>(), 0);
  // Off, or a scene without depth: unknown (null in the JSON).
  o.place_seen_fraction = 0;
  r = eval::evaluateObjects(eval::readScene(d + "/far"), staleChair(), {}, o);
  EXPECT_FALSE(r.place_visibility);
  EXPECT_EQ(gt(r, "chair").old_places.at(0).seen_after, -1);
  o.place_seen_fraction = 0.5;
  r = eval::evaluateObjects(eval::readScene(visibilityScene(d + "/nodepth", 10.0, false)), staleChair(), {}, o);
  EXPECT_FALSE(r.place_visibility);
  EXPECT_TRUE(json::parse(eval::toJson(r))["stale_place_seen"].is_null());
  EXPECT_EQ(r.stale, 1);

  // Bad depth lists and maps name the file.
  using dslam::test::dataError;
  auto has = [](const std::string& msg, const std::string& part) {
    EXPECT_NE(msg.find(part), std::string::npos) << "'" << part << "' not in: " << msg;
  };
  const std::string bad = visibilityScene(d + "/bad", 10.0);
  writeFile(bad + "/depth.txt", "# timestamp filename\n100.0\n");
  has(dataError([&] { eval::readScene(bad); }), "depth.txt:2: expected 'timestamp path'");
  writeFile(bad + "/depth.txt", "100.0 depth/0.png\n");
  has(dataError([&] { eval::readScene(bad); }), "1 depth maps for the 10 frames");
  visibilityScene(bad, 10.0);
  cv::imwrite(bad + "/depth/7.png", cv::Mat(480, 640, CV_8UC1, cv::Scalar(9)));
  has(dataError([&] { eval::evaluateObjects(eval::readScene(bad), staleChair(), {}, o); }),
      "depth/7.png: not a 16-bit depth map");
}

TEST(EvalObjects, SceneFolderGivenAsRunAndRunAsScene) {
  using dslam::test::dataError;
  const std::string d = tempDir("evalobj");
  const std::string scene = writeScene(d + "/scene");
  const std::string run = writeRun(d + "/run", perfectMap());
  std::filesystem::copy_file(scene + "/groundtruth.txt", run + "/groundtruth.txt");
  const std::string m = dataError([&] { eval::readScene(run); });
  EXPECT_NE(m.find("this is a run's object map"), std::string::npos) << m;
}

TEST(EvalObjectsCli, TextAndJson) {
  const std::string d = tempDir("evalobj");
  const std::string scene = writeScene(d + "/scene");
  auto m = perfectMap();
  m[3]["active"] = true;
  const std::string run = writeRun(d + "/run", m, yawPose(1, 2, 0, 30));
  const auto r = runDslam("eval objects '" + run + "' '" + scene + "' --json '" + d + "/out.json'");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("recall (static objects)   2/2 = 1.000"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("stale objects             1 (target 0)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("moved objects found       1/1"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("old object active (stale)"), std::string::npos) << r.out;
  const json j = json::parse(dslam::test::readFile(d + "/out.json"));
  EXPECT_EQ(j["metric"], "objects");
  EXPECT_EQ(j["recall"].get<double>(), 1.0);
  EXPECT_EQ(j["stale"].get<int>(), 1);
  EXPECT_EQ(j["align_poses"].get<int>(), 8);
  EXPECT_EQ(j["gone_inactive"].get<int>(), 2);
  // The objects file itself instead of the folder: the same.
  const auto r2 = runDslam("eval objects '" + run + "/objects.json' '" + scene + "'");
  EXPECT_EQ(r2.exit_code, 0) << r2.out;
  EXPECT_NE(r2.out.find("stale objects             1"), std::string::npos) << r2.out;
}

TEST(EvalObjectsCli, EmptyMapWarnsAndScoresZero) {
  const std::string d = tempDir("evalobj");
  const std::string scene = writeScene(d + "/scene");
  const std::string run = writeRun(d + "/run", {});
  const auto r = runDslam("eval objects '" + run + "' '" + scene + "' 2>&1");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("no objects in map 0"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("recall (static objects)   0/2 = 0.000"), std::string::npos) << r.out;
}

TEST(EvalObjectsCli, ErrorsExitNonZeroWithTheFile) {
  const std::string d = tempDir("evalobj");
  const std::string scene = writeScene(d + "/scene");
  // The scene folder as the run: its objects.json is the ground truth.
  auto r = runDslam("eval objects '" + scene + "' '" + scene + "' 2>&1");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("ground-truth objects.json of the dslam synth scene"), std::string::npos) << r.out;
  // A run folder without objects.json.
  std::filesystem::create_directories(d + "/run");
  r = runDslam("eval objects '" + d + "/run' '" + scene + "' 2>&1");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("has no objects.json"), std::string::npos) << r.out;
  // No trajectory next to the objects file.
  writeRun(d + "/run", perfectMap());
  std::filesystem::remove(d + "/run/trajectory.txt");
  r = runDslam("eval objects '" + d + "/run' '" + scene + "' 2>&1");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("no trajectory.txt next to"), std::string::npos) << r.out;
  // ... which --align none does not need.
  r = runDslam("eval objects '" + d + "/run' '" + scene + "' --align none 2>&1");
  EXPECT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("recall (static objects)   2/2"), std::string::npos) << r.out;
}
