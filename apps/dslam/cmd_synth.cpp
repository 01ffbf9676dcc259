// `dslam synth SCENARIO.yaml --out DIR`: renders a synthetic sequence (TUM
// RGB-D layout + stereo + labels + object ground truth), see docs/scenarios.md.
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <regex>

#include "command.h"
#include "dslam/core/error.h"
#include "dslam/synth/writer.h"

namespace {

struct Opts {
  std::string scenario, out, resolution;
  long long seed = -1;
  int frames = 0;
  bool overwrite = false, no_noise = false, no_right = false, no_labels = false;
  int threads = 0;
};

void setup(CLI::App& sub) {
  static Opts o;
  sub.add_option("scenario", o.scenario, "scenario YAML (config/scenarios/*.yaml)")->required();
  sub.add_option("--out,-o", o.out, "output folder (TUM RGB-D layout)")->required();
  sub.add_option("--seed", o.seed, "random seed (default: the scenario's)");
  sub.add_option("--frames", o.frames, "number of frames (default: the scenario's)")->check(dslam::app::kPositive);
  sub.add_option("--resolution", o.resolution, "image size WxH, e.g. 320x240 (intrinsics are scaled)");
  sub.add_flag("--overwrite", o.overwrite, "replace an existing output folder");
  sub.add_flag("--no-noise", o.no_noise, "exact depth and images (no sensor noise, no depth-edge dropout)");
  sub.add_flag("--no-right", o.no_right, "do not render the stereo right image");
  sub.add_flag("--no-labels", o.no_labels, "do not write boxes/, semantic/, panoptic/");
  sub.add_option("--threads", o.threads, "render threads (default: all cores; output does not depend on it)");
  sub.callback([] {
    dslam::synth::ScenarioOverrides ov;
    ov.frames = o.frames;
    if (o.seed >= 0) ov.seed = static_cast<uint64_t>(o.seed);
    if (!o.resolution.empty()) {
      std::smatch m;
      static const std::regex re(R"(^(\d+)[xX](\d+)$)");
      if (!std::regex_match(o.resolution, m, re))
        throw dslam::ConfigError("--resolution: expected WxH (e.g. 640x480), got '" + o.resolution + "'");
      ov.width = std::stoi(m[1].str());
      ov.height = std::stoi(m[2].str());
      if (ov.width <= 0 || ov.height <= 0)
        throw dslam::ConfigError("--resolution: width and height must be greater than 0, got '" + o.resolution + "'");
    }
    if (o.no_noise) ov.noise = false;
    dslam::synth::WriteOptions wo;
    wo.overwrite = o.overwrite;
    wo.threads = o.threads;
    wo.right = !o.no_right;
    wo.labels = !o.no_labels;
    const auto s = dslam::synth::loadScenario(o.scenario, ov);
    dslam::synth::WriteStats st;
    dslam::synth::writeSequence(s, o.out, wo, &st);
    std::printf("%s: %d frames %dx%d -> %s (render %.1f frames/s, total %.1f s)\n", s.name.c_str(), st.frames, s.width,
                s.height, o.out.c_str(), st.frames / std::max(1e-9, st.render_seconds), st.total_seconds);
  });
}

}  // namespace

DSLAM_COMMAND(synth, "Render a synthetic RGB-D/stereo sequence with exact ground truth from a scenario YAML", setup);
