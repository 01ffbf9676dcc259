#pragma once
/** \file plugin.h
 *  Base class of every plugin. Plugins are MRPT RTTI classes
 *  (DEFINE_MRPT_OBJECT / IMPLEMENTS_MRPT_OBJECT) registered explicitly by
 *  dslam::register_builtin_plugins() (see registry.h). */
#include <cstdint>
#include <string>
#include <vector>

#include <mrpt/rtti/CObject.h>

#include "dslam/core/params.h"

namespace dslam {

struct CameraModel;

/** What a plugin gets besides its parameters. */
struct PluginContext {
  std::string instance_name;     ///< `name:` from the YAML modules list
  std::string config_dir;        ///< folder of the pipeline file (relative paths)
  std::string shared_dir;        ///< resolved DSLAM_SHARED_DIR
  uint64_t seed = 0;             ///< pipeline seed (deterministic runs)
  const CameraModel* camera = nullptr;
  std::string dataset_root;      ///< root folder of the dataset being run, if any
};

class Plugin : public mrpt::rtti::CObject {
  DEFINE_VIRTUAL_MRPT_OBJECT(Plugin)
 public:
  ~Plugin() override = default;
  /** Interface family name ("Detector", "DatasetSource", ...). */
  virtual const char* interfaceName() const = 0;
  /** One-line description for `dslam plugins`. */
  virtual std::string description() const = 0;
  /** Declared parameters (name, type, default, doc). */
  virtual std::vector<ParamSpec> paramSpecs() const { return {}; }
  /** Receives the validated parameters (defaults filled). May throw
   *  ConfigError / DataError (e.g. missing model file). */
  virtual void configure(const Params& params, const PluginContext& ctx) {
    params_ = params;
    ctx_ = ctx;
  }
  const Params& params() const { return params_; }
  const PluginContext& context() const { return ctx_; }

 protected:
  Params params_;
  PluginContext ctx_;
};

}  // namespace dslam
