// RTTI implementation of the plugin interfaces (abstract MRPT classes).
#include "dslam/core/backend.h"
#include "dslam/core/dataset.h"
#include "dslam/core/detector.h"
#include "dslam/core/keypoint_classifier.h"
#include "dslam/core/map_manager.h"
#include "dslam/core/plugin.h"

IMPLEMENTS_VIRTUAL_MRPT_OBJECT(Plugin, mrpt::rtti::CObject, dslam)
IMPLEMENTS_VIRTUAL_MRPT_OBJECT(DatasetSource, Plugin, dslam)
IMPLEMENTS_VIRTUAL_MRPT_OBJECT(Detector, Plugin, dslam)
IMPLEMENTS_VIRTUAL_MRPT_OBJECT(KeypointClassifier, Plugin, dslam)
IMPLEMENTS_VIRTUAL_MRPT_OBJECT(MapManager, Plugin, dslam)
IMPLEMENTS_VIRTUAL_MRPT_OBJECT(Backend, Plugin, dslam)
