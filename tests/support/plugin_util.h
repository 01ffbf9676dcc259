#pragma once
// Built-in plug-ins for tests that link dslam::plugins: a configured dataset
// reader and a Ceres backend with default parameters.
#include <memory>
#include <stdexcept>
#include <string>

#include "dslam/core/backend.h"
#include "dslam/core/dataset.h"
#include "dslam/core/registry.h"

namespace dslam::test {

/** Creates and configures reader `type` from YAML parameter text. */
inline std::shared_ptr<DatasetSource> openDataset(const std::string& type, const std::string& yaml) {
  register_builtin_plugins();
  auto ds = create<DatasetSource>(type);
  if (!ds) throw std::runtime_error("no plugin " + type);
  ds->configure(Params::resolve(ds->paramSpecs(), yaml), PluginContext{});
  return ds;
}

/** The default backend of the shipped pipelines (dslam::SchurBackend), default parameters. */
inline std::shared_ptr<Backend> defaultBackend() {
  register_builtin_plugins();
  auto b = create<Backend>("dslam::SchurBackend");
  b->configure(Params::resolve(b->paramSpecs(), ""), PluginContext{});
  return b;
}

}  // namespace dslam::test
