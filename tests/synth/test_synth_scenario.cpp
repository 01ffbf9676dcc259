// Scenario YAML: every shipped scenario loads; strict validation of bad input.
#include <filesystem>
#include <fstream>

#include "dslam/core/error.h"
#include "dslam/synth/scenario.h"
#include "dslam/synth/scene.h"
#include "test_support.h"

namespace fs = std::filesystem;
using namespace dslam::synth;

namespace {

const char* kBase = R"(
name: t
frames: 20
room: {size: [6, 5, 2.8]}
camera:
  trajectory: {type: static, center: [-2, 0, 1.4], look_at: [3, 0, 1.0]}
)";

/** Expects parseScenario(text) to throw ConfigError whose message contains
 *  every fragment. */
void expectError(const std::string& text, const std::vector<std::string>& fragments) {
  try {
    parseScenario(text, "bad.yaml");
    ADD_FAILURE() << "no error for:\n" << text;
  } catch (const dslam::ConfigError& e) {
    const std::string m = e.what();
    for (const auto& f : fragments) EXPECT_NE(m.find(f), std::string::npos) << "'" << f << "' not in: " << m;
  }
}

}  // namespace

TEST(SynthScenario, AllShippedScenariosLoad) {
  const std::vector<std::string> expected = {"static_office", "walking_xyz",  "walking_static", "walking_rpy",
                                             "walking_halfsphere", "sitting_xyz", "crowd", "close_person",
                                             "unknown_object", "one_chair", "vanishing", "replacing", "shift", "loop"};
  for (const auto& n : expected) {
    const std::string f = dslam::test::source("config/scenarios/" + n + ".yaml");
    SCOPED_TRACE(f);
    Scenario s;
    ASSERT_NO_THROW(s = loadScenario(f));
    EXPECT_EQ(s.name, n);
    EXPECT_EQ(s.width, 640);
    EXPECT_EQ(s.height, 480);
    EXPECT_DOUBLE_EQ(s.intrinsics.fx, 535.4);
    EXPECT_DOUBLE_EQ(s.intrinsics.cy, 247.6);
    EXPECT_DOUBLE_EQ(s.rate, 30.0);
    // Documented at the top: the first line is a comment naming the scenario.
    std::ifstream in(f);
    std::string first;
    std::getline(in, first);
    EXPECT_EQ(first.rfind("# " + n + ":", 0), 0u) << first;
    // Camera motion stays hand-held like: <= 0.5 m/s and <= 45 deg/s.
    SceneModel scene(s);
    double vmax = 0, wmax = 0;
    for (int i = 1; i < s.frames; i++) {
      const auto d = scene.cameraPose(i - 1).inverse() * scene.cameraPose(i);
      vmax = std::max(vmax, d.translation().norm() * s.rate);
      wmax = std::max(wmax, d.angle() * s.rate * 180 / M_PI);
    }
    EXPECT_LE(vmax, 0.5) << n;
    EXPECT_LE(wmax, 45.0) << n;
  }
  // Scenario families as the issue lists them.
  EXPECT_GE(loadScenario(dslam::test::source("config/scenarios/crowd.yaml")).people.size(), 10u);
  EXPECT_EQ(loadScenario(dslam::test::source("config/scenarios/walking_xyz.yaml")).people.size(), 2u);
  for (const char* n : {"one_chair", "vanishing", "replacing", "shift"})
    EXPECT_FALSE(loadScenario(dslam::test::source(std::string("config/scenarios/") + n + ".yaml")).events.empty()) << n;
}

TEST(SynthScenario, OverridesScaleIntrinsics) {
  ScenarioOverrides ov;
  ov.width = 320;
  ov.height = 240;
  ov.frames = 7;
  ov.seed = 99;
  ov.noise = false;
  const Scenario s = loadScenario(dslam::test::source("config/scenarios/static_office.yaml"), ov);
  EXPECT_EQ(s.width, 320);
  EXPECT_EQ(s.frames, 7);
  EXPECT_EQ(s.seed, 99u);
  EXPECT_FALSE(s.noise.enabled);
  EXPECT_DOUBLE_EQ(s.intrinsics.fx, 535.4 / 2);
  EXPECT_DOUBLE_EQ(s.intrinsics.fy, 539.2 / 2);
  EXPECT_DOUBLE_EQ(s.intrinsics.cx, (320.1 + 0.5) / 2 - 0.5);
  EXPECT_DOUBLE_EQ(s.intrinsics.cy, (247.6 + 0.5) / 2 - 0.5);
}

TEST(SynthScenario, MinimalScenarioDefaults) {
  const Scenario s = parseScenario(kBase);
  EXPECT_EQ(s.frames, 20);
  EXPECT_TRUE(s.noise.enabled);
  EXPECT_DOUBLE_EQ(s.noise.depth_sigma, 1.425e-3);
  EXPECT_DOUBLE_EQ(s.noise.depth_min, 0.4);
  EXPECT_DOUBLE_EQ(s.noise.depth_max, 8.0);
  EXPECT_DOUBLE_EQ(s.baseline, 0.1);
}

TEST(SynthScenario, UnknownKeyIsNamedWithLine) {
  expectError(std::string(kBase) + "objects:\n  - {name: a, type: box, class: chair, sise: [1, 1, 1], position: [0, 0, 0]}\n",
              {"bad.yaml:8", "objects[0].sise", "unknown key 'sise'", "did you mean 'size'"});
  expectError(std::string(kBase) + "nosie: {enabled: false}\n", {"unknown key 'nosie'", "did you mean 'noise'"});
  expectError(std::string(kBase) + "noise: {depth_sigm: 0.01}\n", {"noise.depth_sigm", "depth_sigma"});
}

TEST(SynthScenario, UnknownObjectTypeIsNamed) {
  expectError(std::string(kBase) + "objects:\n  - {name: s, type: sofa, class: couch, position: [1, 0, 0]}\n",
              {"objects[0].type", "unknown object type 'sofa'", "box"});
}

TEST(SynthScenario, UnknownClassNeedsLabelledFalse) {
  expectError(std::string(kBase) + "objects:\n  - {name: b, type: sphere, class: balloon, position: [1, 0, 0]}\n",
              {"objects[0].class", "unknown COCO class 'balloon'", "labelled: false"});
  EXPECT_NO_THROW(parseScenario(std::string(kBase) +
                                "objects:\n  - {name: b, type: sphere, class: balloon, labelled: false, position: [1, 0, 0]}\n"));
}

TEST(SynthScenario, CameraInsideObjectIsRejected) {
  expectError(std::string(kBase) + "objects:\n  - {name: crate, type: box, class: suitcase, size: [1, 1, 2], position: [-2, 0, 0]}\n",
              {"camera inside object 'crate'", "objects[0]", "frame 0"});
}

TEST(SynthScenario, CameraInsideWalkingPersonIsRejected) {
  expectError(std::string(kBase) + "people:\n  - {name: bob, path: {waypoints: [[-2, -0.3], [-2, 2]], speed: 1.0}}\n",
              {"camera inside person 'bob'", "people[0]"});
}

TEST(SynthScenario, PathOutsideRoomIsRejected) {
  expectError(std::string(kBase) + "people:\n  - {name: p, path: {waypoints: [[0, 0], [4.0, 0]]}}\n",
              {"people[0].path.waypoints[1]", "outside the room"});
  expectError(std::string(kBase) +
                  "objects:\n  - {name: b, type: box, class: suitcase, path: {waypoints: [[1, 0, 0], [1, 9, 0]]}}\n",
              {"objects[0].path.waypoints[1]", "outside the room"});
  expectError(std::string(kBase) + "objects:\n  - {name: b, type: box, class: suitcase, position: [7, 0, 0]}\n",
              {"objects[0].position", "outside the room"});
}

TEST(SynthScenario, CameraOutsideRoomOrTooFastIsRejected) {
  expectError(R"(
frames: 20
room: {size: [6, 5, 2.8]}
camera:
  trajectory: {type: static, center: [-4, 0, 1.4], look_at: [3, 0, 1.0]}
)",
              {"camera.trajectory", "outside the room"});
  expectError(R"(
frames: 60
room: {size: [6, 5, 2.8]}
camera:
  trajectory: {type: xyz, center: [0, 0, 1.4], look_at: [3, 0, 1.0], amplitude: 1.0, period: 2}
)",
              {"camera speed", "max_speed"});
}

TEST(SynthScenario, BadEventsAreRejected) {
  const std::string obj = std::string(kBase) + "objects:\n  - {name: c, type: chair, position: [1, 0, 0]}\n";
  expectError(obj + "events:\n  - {type: removed, object: nothing, frame: 5}\n", {"events[0].object", "no object named 'nothing'"});
  expectError(obj + "events:\n  - {type: exploded, object: c, frame: 5}\n", {"events[0].type", "unknown event type 'exploded'"});
  expectError(obj + "events:\n  - {type: removed, object: c, frame: 50}\n", {"events[0].frame", "out of range"});
  expectError(obj + "events:\n  - {type: moved, object: c, frames: [2, 4]}\n", {"events[0]", "position"});
  expectError(obj + "events:\n  - {type: removed, object: c, frames: [2, 4]}\n", {"instantaneous"});
}

TEST(SynthScenario, TypeErrorsAreNamed) {
  expectError(std::string(kBase) + "rate: fast\n", {"'rate'", "expected a number"});
  expectError(std::string(kBase) + "resolution: [640]\n", {"'resolution'", "[width, height]"});
  expectError("frames: 10\nroom: {size: [6, 5, 2.8]}\n", {"missing required key 'camera'"});
  expectError(R"(
frames: 20
room: {size: [6, 5, 2.8], floor: marble}
camera:
  trajectory: {type: static, center: [-2, 0, 1.4], look_at: [3, 0, 1.0]}
)",
              {"room.floor", "unknown texture kind 'marble'"});
}

TEST(SynthScenario, IncomingObjectsStartAbsent) {
  const Scenario s = parseScenario(std::string(kBase) + R"(
objects:
  - {name: c, type: chair, position: [1, 0, 0], yaw: 30}
  - {name: s, type: box, class: suitcase}
events:
  - {type: replaced, object: c, by: s, frame: 10}
)");
  const SceneModel scene(s);
  EXPECT_TRUE(scene.objectState(0, 9).present);
  EXPECT_FALSE(scene.objectState(0, 10).present);
  EXPECT_FALSE(scene.objectState(1, 9).present);
  ASSERT_TRUE(scene.objectState(1, 10).present);
  // The replacement takes the replaced object's place.
  EXPECT_NEAR((scene.objectState(1, 10).T_wo.translation() - Vec3(1, 0, 0)).norm(), 0, 1e-12);
}

TEST(SynthScenario, MissingFileIsDataError) {
  EXPECT_THROW(loadScenario("/nonexistent/scenario.yaml"), dslam::DataError);
}

// Fuzzing (tests/fuzz): validation work is frames x (objects + people); a
// small file could ask for hours of checks. Bounded, with a message.
TEST(SynthScenario, ValidationWorkIsBounded) {
  std::string many = "name: t\nframes: 100000\nroom: {size: [6, 5, 2.8]}\n"
                     "camera: {trajectory: {type: static, center: [0, 0, 1.4], look_at: [1, 0, 1.2]}}\nobjects:\n";
  for (int i = 0; i < 25; i++)
    many += "  - {name: b" + std::to_string(i) + ", type: box, class: book, size: [0.1, 0.1, 0.1], position: [" +
            std::to_string(-2.4 + 0.2 * i) + ", 2.0, 0]}\n";
  expectError(many, {"bad.yaml", "100000 frames x 25 objects and people", "more than 2000000"});
  // 80000 frames x 25 objects is allowed and quick (the camera is far from them).
  std::string ok = many;
  ok.replace(ok.find("100000"), 6, "80000");
  EXPECT_EQ(parseScenario(ok).frames, 80000);
}
