#include "dslam/core/registry.h"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <set>
#include <sstream>

#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/core/yaml_util.h"

namespace fs = std::filesystem;

namespace dslam {

namespace {
/** Interfaces (direct children of Plugin) a concrete plugin may implement. */
const mrpt::rtti::TRuntimeClassId* interfaceOf(const mrpt::rtti::TRuntimeClassId* c) {
  const auto* plugin = CLASS_ID(Plugin);
  while (c && c->getBaseClass && c->getBaseClass() && c->getBaseClass() != plugin) c = c->getBaseClass();
  return (c && c->getBaseClass && c->getBaseClass() == plugin) ? c : nullptr;
}
std::string shortName(const char* full) {
  std::string s(full);
  auto p = s.rfind("::");
  return p == std::string::npos ? s : s.substr(p + 2);
}
}  // namespace

std::vector<std::string> pluginNames(const mrpt::rtti::TRuntimeClassId* iface) {
  std::vector<std::string> names;
  for (const auto* c : mrpt::rtti::getAllRegisteredClassesChildrenOf(iface))
    if (c->ptrCreateObject) names.push_back(c->className);
  std::sort(names.begin(), names.end());
  names.erase(std::unique(names.begin(), names.end()), names.end());
  return names;
}

std::shared_ptr<Plugin> createPlugin(const std::string& name, const mrpt::rtti::TRuntimeClassId* iface) {
  const std::string ifname = shortName(iface->className);
  const auto valid = pluginNames(iface);
  auto fail = [&](const std::string& why) -> std::shared_ptr<Plugin> {
    throw ConfigError(why + yamlu::didYouMean(name, valid) + " (valid " + ifname + " plugins: " +
                      (valid.empty() ? std::string("none registered; was dslam::register_builtin_plugins() called?")
                                     : yamlu::join(valid)) +
                      ")");
  };
  const mrpt::rtti::TRuntimeClassId* cls = mrpt::rtti::findRegisteredClass(name, false);
  if (!cls && name.find("::") == std::string::npos) cls = mrpt::rtti::findRegisteredClass("dslam::" + name, false);
  if (!cls || !cls->ptrCreateObject) return fail("unknown plugin type '" + name + "'");
  if (!cls->derivedFrom(iface)) return fail("plugin '" + name + "' is not a " + ifname);
  auto obj = std::dynamic_pointer_cast<Plugin>(cls->createObject());
  if (!obj) return fail("plugin '" + name + "' could not be created");
  return obj;
}

std::vector<PluginInfo> listPlugins(const std::string& interface_name) {
  std::vector<PluginInfo> out;
  std::set<std::string> seen;
  for (const auto* c : mrpt::rtti::getAllRegisteredClassesChildrenOf(CLASS_ID(Plugin))) {
    if (!c->ptrCreateObject || !seen.insert(c->className).second) continue;
    const auto* iface = interfaceOf(c);
    if (!iface) continue;
    const std::string ifname = shortName(iface->className);
    if (!interface_name.empty() && ifname != interface_name) continue;
    auto obj = std::dynamic_pointer_cast<Plugin>(c->createObject());
    if (!obj) continue;
    out.push_back({c->className, ifname, obj->description(), obj->paramSpecs()});
  }
  std::sort(out.begin(), out.end(), [](const PluginInfo& a, const PluginInfo& b) {
    return std::tie(a.interface_name, a.name) < std::tie(b.interface_name, b.name);
  });
  return out;
}

size_t loadExternalPlugins(const std::vector<std::string>& dirs_in) {
  static std::mutex mtx;
  static std::set<std::string> loaded;
  std::lock_guard<std::mutex> lk(mtx);
  std::vector<std::string> dirs = dirs_in;
  if (const char* e = std::getenv("DSLAM_PLUGIN_PATH"); e && *e) {
    std::stringstream ss(e);
    std::string d;
    while (std::getline(ss, d, ':'))
      if (!d.empty()) dirs.push_back(d);
  }
  size_t n = 0;
  for (const auto& d : dirs) {
    std::error_code ec;
    if (!fs::is_directory(d, ec)) throw DataError("plugin directory not found: " + d);
    std::vector<fs::path> libs;
    for (const auto& ent : fs::directory_iterator(d)) {
      const auto fn = ent.path().filename().string();
      if (ent.is_regular_file() && fn.rfind("lib", 0) == 0 && ent.path().extension() == ".so") libs.push_back(ent.path());
    }
    std::sort(libs.begin(), libs.end());
    for (const auto& lib : libs) {
      const std::string p = fs::canonical(lib).string();
      if (loaded.count(p)) continue;
      void* h = dlopen(p.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (!h) throw Error(std::string("cannot load plugin library ") + p + ": " + dlerror());
      using RegFn = void (*)();
      auto fn = reinterpret_cast<RegFn>(dlsym(h, "dslam_register_plugins"));
      if (!fn) {
        dlclose(h);
        throw Error("plugin library " + p + " does not export extern \"C\" void dslam_register_plugins()");
      }
      fn();
      loaded.insert(p);
      DSLAM_LOG(Debug, "loaded plugin library " << p);
      n++;
    }
  }
  return n;
}

}  // namespace dslam
