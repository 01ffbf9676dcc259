#pragma once
/** \file register.h
 *  Registration of the keypoint-classifier family alone (tests and tools
 *  that do not link dslam::plugins); dslam::register_builtin_plugins()
 *  calls it too. */

namespace dslam {

/** Registers BoxFilter, SemanticFilter, AdaptiveFeatureCount,
 *  DepthRepopulation, EpipolarConsistency, PanopticClassifier and
 *  EkfObjectTracker (idempotent). */
void register_classifiers_plugins();

}  // namespace dslam
