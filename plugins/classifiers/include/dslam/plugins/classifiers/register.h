#pragma once
/** \file register.h
 *  Registration of the keypoint-classifier family alone (tests and tools
 *  that do not link dslam::plugins); dslam::register_builtin_plugins()
 *  calls it too. */

namespace dslam {

/** Registers every keypoint classifier of this family (idempotent). The
 *  list is src/register.cpp; `dslam plugins -i KeypointClassifier` prints
 *  it, and tests/apps/test_docs.cpp checks that every classifier class is
 *  registered and named in docs/architecture.md. */
void register_classifiers_plugins();

}  // namespace dslam
