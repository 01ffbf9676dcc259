#include "dslam/core/registry.h"
#include "dslam/plugins/datasets/tum.h"

namespace dslam {

void register_datasets_plugins() {
  registerPlugin<TumDataset>();
  registerPlugin<BonnDataset>();
}

}  // namespace dslam
