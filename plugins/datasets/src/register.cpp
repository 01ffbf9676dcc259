#include "dslam/core/registry.h"
#include "dslam/plugins/datasets/euroc.h"
#include "dslam/plugins/datasets/kitti.h"
#include "dslam/plugins/datasets/rawlog.h"
#include "dslam/plugins/datasets/tum.h"

namespace dslam {

void register_datasets_plugins() {
  registerPlugin<TumDataset>();
  registerPlugin<BonnDataset>();
  registerPlugin<KittiDataset>();
  registerPlugin<EurocDataset>();
  registerPlugin<RawlogDataset>();
}

}  // namespace dslam
