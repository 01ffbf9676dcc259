#pragma once
/** \file registry.h
 *  Plugin registry on top of MRPT's class registry.
 *
 *  Built-in plugins are registered by an explicit call to
 *  dslam::register_builtin_plugins() (static self-registration would be
 *  dropped by the linker under Debian's --as-needed). External plugins are
 *  shared libraries exporting `extern "C" void dslam_register_plugins()`,
 *  loaded from $DSLAM_PLUGIN_PATH (colon separated) or a pipeline's
 *  `plugin_dirs:` list. */
#include <memory>
#include <string>
#include <vector>

#include "dslam/core/plugin.h"

namespace dslam {

/** Registers every built-in plugin (idempotent). Defined in dslam_plugins. */
void register_builtin_plugins();

/** Registers one plugin class T (a DEFINE_MRPT_OBJECT class). */
template <class T>
void registerPlugin() {
  mrpt::rtti::registerClass(CLASS_ID(T));
}

struct PluginInfo {
  std::string name;            ///< "dslam::TumDataset"
  std::string interface_name;  ///< "DatasetSource"
  std::string description;
  std::vector<ParamSpec> params;
};

/** Every registered plugin (optionally of one interface), sorted by interface then name. */
std::vector<PluginInfo> listPlugins(const std::string& interface_name = "");

/** Names of the registered plugins implementing `iface`. */
std::vector<std::string> pluginNames(const mrpt::rtti::TRuntimeClassId* iface);

/** Creates plugin `name` checked against interface `iface`; throws
 *  ConfigError listing the valid names for that interface. */
std::shared_ptr<Plugin> createPlugin(const std::string& name, const mrpt::rtti::TRuntimeClassId* iface);

/** Typed creation: dslam::create<Detector>("dslam::DarknetYoloDetector"). */
template <class I>
std::shared_ptr<I> create(const std::string& name) {
  return std::dynamic_pointer_cast<I>(createPlugin(name, CLASS_ID(I)));
}

/** Loads external plugin libraries (lib*.so) from the given folders and
 *  from $DSLAM_PLUGIN_PATH. Returns the number of libraries loaded. Throws
 *  Error if a library cannot be loaded or lacks dslam_register_plugins. */
size_t loadExternalPlugins(const std::vector<std::string>& dirs);

}  // namespace dslam
