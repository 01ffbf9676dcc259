// Camera files and the camera section (config/camera_yaml.h): presets,
// overrides, errors.
#include <gtest/gtest.h>

#include <filesystem>

#include "dslam/config/camera_yaml.h"
#include "dslam/core/camera_presets.h"
#include "dslam/core/error.h"
#include "test_support.h"

using namespace dslam;

TEST(Camera, PresetFilesAgreeWithCodePresets) {
  for (const auto& name : cameraPresetNames()) {
    const std::string f = test::source("config/cameras/" + name + ".yaml");
    ASSERT_TRUE(std::filesystem::exists(f)) << f;
    const CameraModel a = config::loadCameraFile(f);
    const CameraModel b = *cameraPreset(name);
    EXPECT_EQ(a.sensor, b.sensor) << name;
    EXPECT_EQ(a.left.width, b.left.width) << name;
    EXPECT_EQ(a.left.height, b.left.height) << name;
    EXPECT_DOUBLE_EQ(a.left.fx, b.left.fx) << name;
    EXPECT_DOUBLE_EQ(a.left.fy, b.left.fy) << name;
    EXPECT_DOUBLE_EQ(a.left.cx, b.left.cx) << name;
    EXPECT_DOUBLE_EQ(a.left.cy, b.left.cy) << name;
    for (int i = 0; i < 5; i++) EXPECT_DOUBLE_EQ(a.left.dist[i], b.left.dist[i]) << name;
    EXPECT_NEAR(a.bf(), b.bf(), 1e-9) << name;
    EXPECT_DOUBLE_EQ(a.depth_threshold, b.depth_threshold) << name;
    EXPECT_DOUBLE_EQ(a.fps, b.fps) << name;
  }
}

TEST(Camera, MissingIntrinsicsIsAClearError) {
  const std::string d = test::tempDir("cam");
  test::writeFile(d + "/c.yaml", "sensor: rgbd\nwidth: 640\nheight: 480\nfx: 500\n");
  try {
    config::loadCameraFile(d + "/c.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("missing required key 'fy'"), std::string::npos) << e.what();
  }
  test::writeFile(d + "/s.yaml", "sensor: stereo\nwidth: 640\nheight: 480\nfx: 500\nfy: 500\ncx: 320\ncy: 240\n");
  EXPECT_THROW(config::loadCameraFile(d + "/s.yaml"), ConfigError);  // stereo without baseline
  test::writeFile(d + "/d.yaml", "preset: tum_fr3\ndist: [0.1, 0.2, 0.3]\n");
  EXPECT_THROW(config::loadCameraFile(d + "/d.yaml"), ConfigError);  // 3 distortion values
}

TEST(Camera, ZeroIntrinsicsAndNonRotationsAreClearErrors) {
  // fx: 0 / width: 0 passed and failed mid-run without the file; depth_factor: 0
  // became 5000; a T_body_cam scaled by 2 was silently normalised.
  const std::string d = test::tempDir("cam");
  const std::string base = "sensor: rgbd\nwidth: 640\nheight: 480\nfx: 500\nfy: 500\ncx: 320\ncy: 240\n";
  auto errorOf = [&](const std::string& text) {
    test::writeFile(d + "/c.yaml", text);
    try {
      config::loadCameraFile(d + "/c.yaml");
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(errorOf(base), "");
  EXPECT_NE(errorOf(base + "depth_factor: 0\n").find("'depth_factor' must be greater than 0"), std::string::npos);
  std::string t = base;
  EXPECT_NE(errorOf(t.replace(t.find("fx: 500"), 7, "fx: 0")).find("'fx' must be greater than 0, got 0"),
            std::string::npos);
  t = base;
  EXPECT_NE(errorOf(t.replace(t.find("width: 640"), 10, "width: 0")).find("'width' must be greater than 0"),
            std::string::npos);
  t = base;
  EXPECT_NE(errorOf(t.replace(t.find("fx: 500"), 7, "fx: .inf")).find("expected a finite number"), std::string::npos);
  // A principal point outside the image (here cx and width swapped).
  t = base;
  EXPECT_NE(errorOf(t.replace(t.find("cx: 320"), 7, "cx: 640.5"))
                .find("'cx' (640.5) lies outside the image: the principal point must be within 0..width (640)"),
            std::string::npos);
  t = base;
  EXPECT_NE(errorOf(t.replace(t.find("cy: 240"), 7, "cy: -1")).find("'cy' (-1) lies outside the image"),
            std::string::npos);
  t = base;
  EXPECT_EQ(errorOf(t.replace(t.find("cx: 320"), 7, "cx: 640")), "");  // on the border: allowed
  EXPECT_NE(errorOf(base + "T_body_cam: [2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1]\n")
                .find("T_body_cam: the 3x3 block is not a rotation"),
            std::string::npos);
  EXPECT_EQ(errorOf(base + "T_body_cam: [0, -1, 0, 0.1, 1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]\n"), "");
}

TEST(Camera, PresetOverride) {
  const std::string d = test::tempDir("cam");
  test::writeFile(d + "/c.yaml", "camera:\n  preset: tum_fr3\n  fx: 600\n  width: 752\n");
  const CameraModel c = config::loadCameraFile(d + "/c.yaml");
  EXPECT_DOUBLE_EQ(c.left.fx, 600);
  EXPECT_EQ(c.left.width, 752);
  EXPECT_DOUBLE_EQ(c.left.fy, 539.2);  // kept from the preset
  EXPECT_NEAR(c.bf(), 40.0 * 600 / 535.4, 1e-9);  // baseline of the preset, new fx
  // Half the width with the preset's principal point (320.1): not this image.
  test::writeFile(d + "/c.yaml", "camera:\n  preset: tum_fr3\n  width: 320\n");
  try {
    config::loadCameraFile(d + "/c.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("'cx' (320.1, from the preset) lies outside the image"), std::string::npos)
        << e.what();
  }
}
