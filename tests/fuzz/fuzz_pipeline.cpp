// Fuzz target: the pipeline YAML loader and validator
// (config::loadPipelineText: $include / ${VAR}, every section, plugin
// parameter validation). Relative $include{} paths resolve against
// config/pipelines/ of the source tree, so the seeds' camera includes work.
#include "dslam/config/pipeline.h"
#include "dslam/core/registry.h"
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const bool init = [] {
    dslam::fuzz::scratchDir();
    dslam::register_builtin_plugins();
    return true;
  }();
  (void)init;
  const std::string text(reinterpret_cast<const char*>(data), size);
  dslam::fuzz::guarded([&] {
    auto cfg = dslam::config::loadPipelineText(text, DSLAM_FUZZ_SOURCE_DIR "/config/pipelines");
    (void)cfg.toYaml();
  });
  return 0;
}
