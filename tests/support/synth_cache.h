#pragma once
/** \file synth_cache.h
 *  Renders synthetic scenes for tests once per build tree: the sequence is
 *  cached under <build>/test_data/<key> and reused by later tests (atomic
 *  rename, so parallel ctest jobs do not collide). Link dslam::synth.
 *
 *  Only stereo tests get right/ images and calib.txt (`stereo`): the right
 *  images are a third of a scene's bytes, and the rendered scenes of the
 *  whole suite are several gigabytes on the CI disk. */
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <unistd.h>

#include "dslam/synth/writer.h"
#include "test_support.h"

namespace dslam::test {

inline std::string syntheticSequence(const std::string& scenario, int frames, int width, int height,
                                     bool stereo = false) {
  namespace fs = std::filesystem;
  // Bump kLayout when the synth output layout changes (cached folders are
  // reused); the key also hashes the scenario file, so edited scenes re-render.
  constexpr int kLayout = 4;
  const std::string yaml = source("config/scenarios/" + scenario + ".yaml");
  std::ifstream in(yaml, std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  uint64_t h = 1469598103934665603ull;  // FNV-1a
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  std::ostringstream k;
  k << "v" << kLayout << "_" << scenario << "_" << frames << "_" << width << "x" << height << (stereo ? "_stereo" : "");
  k << "_" << std::hex << (h & 0xffffffffu);
  const std::string key = k.str();
  const fs::path root = fs::path(DSLAM_TEST_BINARY_DIR) / "test_data";
  const fs::path dir = root / key;
  if (fs::exists(dir / "groundtruth.txt")) return dir.string();
  fs::create_directories(root);
  const fs::path tmp = root / (key + ".tmp" + std::to_string(::getpid()));
  synth::ScenarioOverrides ov;
  ov.frames = frames;
  ov.width = width;
  ov.height = height;
  synth::WriteOptions wo;
  wo.overwrite = true;
  wo.progress = false;
  wo.right = stereo;
  synth::renderToFolder(yaml, tmp.string(), ov, wo);
  std::error_code ec;
  fs::rename(tmp, dir, ec);  // another job may have won the race: then use its copy
  if (ec) fs::remove_all(tmp, ec);
  return dir.string();
}

}  // namespace dslam::test
