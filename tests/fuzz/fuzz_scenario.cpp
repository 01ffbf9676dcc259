// Fuzz target: the synthetic scenario parser and validator
// (synth::parseScenario: YAML, objects, people, events, trajectory, the
// geometric validation). $include{} resolves against config/scenarios/.
#include "dslam/synth/scenario.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  dslam::fuzz::scratchDir();
  const std::string text(reinterpret_cast<const char*>(data), size);
  // At most 120 frames are validated (the --frames override of `dslam synth`):
  // per-frame validation runs ~150x slower under ASan at -O1, and a long but
  // legal scenario (crowd.yaml: 600 frames, 7 s) would read as a hang. The
  // frames x objects limit itself is a unit test (SynthScenario tests).
  dslam::synth::ScenarioOverrides ov;
  ov.frames = 120;
  dslam::fuzz::guarded([&] {
    (void)dslam::synth::parseScenario(text, "<fuzz scenario>", DSLAM_FUZZ_SOURCE_DIR "/config/scenarios", ov);
  });
  return 0;
}
