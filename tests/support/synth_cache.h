#pragma once
/** \file synth_cache.h
 *  Renders synthetic scenes for tests once per build tree: the sequence is
 *  cached under <build>/test_data/<key> and reused by later tests (atomic
 *  rename, so parallel ctest jobs do not collide). Link dslam::synth. */
#include <filesystem>
#include <string>
#include <unistd.h>

#include "dslam/synth/writer.h"
#include "test_support.h"

namespace dslam::test {

inline std::string syntheticSequence(const std::string& scenario, int frames, int width, int height,
                                     bool noise = true, uint64_t seed = 0) {
  namespace fs = std::filesystem;
  // Bump kLayout when the synth output layout changes (cached folders are reused).
  constexpr int kLayout = 2;
  const std::string key = "v" + std::to_string(kLayout) + "_" + scenario + "_" + std::to_string(frames) + "_" + std::to_string(width) + "x" +
                          std::to_string(height) + (noise ? "" : "_nonoise") + (seed ? "_s" + std::to_string(seed) : "");
  const fs::path root = fs::path(DSLAM_TEST_BINARY_DIR) / "test_data";
  const fs::path dir = root / key;
  if (fs::exists(dir / "groundtruth.txt")) return dir.string();
  fs::create_directories(root);
  const fs::path tmp = root / (key + ".tmp" + std::to_string(::getpid()));
  synth::ScenarioOverrides ov;
  ov.frames = frames;
  ov.width = width;
  ov.height = height;
  ov.noise = noise;
  if (seed) ov.seed = seed;
  synth::WriteOptions wo;
  wo.overwrite = true;
  wo.progress = false;
  synth::renderToFolder(source("config/scenarios/" + scenario + ".yaml"), tmp.string(), ov, wo);
  std::error_code ec;
  fs::rename(tmp, dir, ec);  // another job may have won the race: then use its copy
  if (ec) fs::remove_all(tmp, ec);
  return dir.string();
}

}  // namespace dslam::test
