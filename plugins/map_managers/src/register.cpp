// Map managers. dslam::Atlas lives in modules/map (the System uses it by
// default); this family registers it as a plugin so pipelines can name it.
#include "dslam/core/registry.h"
#include "dslam/map/atlas.h"

namespace dslam {

void register_map_managers_plugins() { registerPlugin<Atlas>(); }

}  // namespace dslam
