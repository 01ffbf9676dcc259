// dslam::register_builtin_plugins(): explicit registration of every
// built-in plugin family (self-registration would be dropped by the linker
// under --as-needed).
#include <mutex>

#include "dslam/core/registry.h"
#include "dslam/slam/system.h"

namespace dslam {
#define DSLAM_FAMILY(f) void register_##f##_plugins();
#ifdef DSLAM_HAVE_DATASETS
DSLAM_FAMILY(datasets)
#endif
#ifdef DSLAM_HAVE_BACKENDS
DSLAM_FAMILY(backends)
#endif
#ifdef DSLAM_HAVE_DETECTORS
DSLAM_FAMILY(detectors)
#endif
#ifdef DSLAM_HAVE_CLASSIFIERS
DSLAM_FAMILY(classifiers)
#endif
#ifdef DSLAM_HAVE_MAP_MANAGERS
DSLAM_FAMILY(map_managers)
#endif
#undef DSLAM_FAMILY

void register_builtin_plugins() {
  static std::once_flag once;
  std::call_once(once, [] {
    registerSlamSections();
#ifdef DSLAM_HAVE_DATASETS
    register_datasets_plugins();
#endif
#ifdef DSLAM_HAVE_BACKENDS
    register_backends_plugins();
#endif
#ifdef DSLAM_HAVE_DETECTORS
    register_detectors_plugins();
#endif
#ifdef DSLAM_HAVE_CLASSIFIERS
    register_classifiers_plugins();
#endif
#ifdef DSLAM_HAVE_MAP_MANAGERS
    register_map_managers_plugins();
#endif
  });
}

}  // namespace dslam
