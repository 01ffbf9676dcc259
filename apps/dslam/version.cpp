// The version string of the dslam command (`dslam --version`, the results of
// `dslam ablate`): release and the git commit it was built from.
#include "command.h"
#include "dslam_commit.h"

#ifndef DSLAM_VERSION
#define DSLAM_VERSION "0.0.0"
#endif

namespace dslam::app {

std::string commit() { return std::string(DSLAM_GIT_COMMIT) + (DSLAM_GIT_DIRTY ? "-modified" : ""); }

std::string versionString() { return std::string("dslam ") + DSLAM_VERSION + " (commit " + commit() + ")"; }

}  // namespace dslam::app
