#include "dslam/core/registry.h"
#include "dslam/plugins/backends/ceres_backend.h"
#include "dslam/plugins/backends/mrpt_backend.h"
#include "dslam/plugins/backends/schur_backend.h"

namespace dslam {

void register_backends_plugins() {
  registerPlugin<CeresBackend>();
  registerPlugin<MrptBackend>();
  registerPlugin<SchurBackend>();
}

}  // namespace dslam
