// Fuzz target: the synthetic scenario parser and validator
// (synth::parseScenario: YAML, objects, people, events, trajectory, the
// geometric validation). $include{} resolves against config/scenarios/.
#include "dslam/synth/scenario.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  dslam::fuzz::scratchDir();
  const std::string text(reinterpret_cast<const char*>(data), size);
  dslam::fuzz::guarded([&] {
    (void)dslam::synth::parseScenario(text, "<fuzz scenario>", DSLAM_FUZZ_SOURCE_DIR "/config/scenarios");
  });
  return 0;
}
