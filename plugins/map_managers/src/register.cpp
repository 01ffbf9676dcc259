// Map managers: dslam::Atlas (modules/map; the System's default) and the
// persistence filters that wrap it (changing environments, issue 12).
#include "dslam/core/registry.h"
#include "dslam/map/atlas.h"
#include "dslam/plugins/map_managers/persistence_filters.h"

namespace dslam {

void register_map_managers_plugins() {
  registerPlugin<Atlas>();
  registerPlugin<ObjectPersistenceFilter>();
  registerPlugin<PointPersistenceFilter>();
}

}  // namespace dslam
