#include "dslam/plugins/classifiers/register.h"

#include "dslam/core/registry.h"
#include "dslam/plugins/classifiers/adaptive_feature_count.h"
#include "dslam/plugins/classifiers/box_filter.h"
#include "dslam/plugins/classifiers/depth_repopulation.h"
#include "dslam/plugins/classifiers/ekf_object_tracker.h"
#include "dslam/plugins/classifiers/epipolar_consistency.h"
#include "dslam/plugins/classifiers/panoptic_classifier.h"
#include "dslam/plugins/classifiers/semantic_filter.h"

namespace dslam {

void register_classifiers_plugins() {
  registerPlugin<BoxFilter>();
  registerPlugin<SemanticFilter>();
  registerPlugin<AdaptiveFeatureCount>();
  registerPlugin<DepthRepopulation>();
  registerPlugin<EpipolarConsistency>();
  registerPlugin<PanopticClassifier>();
  registerPlugin<EkfObjectTracker>();
}

}  // namespace dslam
