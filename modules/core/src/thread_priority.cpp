#include "dslam/core/thread_priority.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "dslam/core/log.h"

namespace dslam {

void lowerThreadPriority(int nice, const char* who) {
  if (nice <= 0) return;
  const auto tid = static_cast<id_t>(syscall(SYS_gettid));
  errno = 0;
  const int now = getpriority(PRIO_PROCESS, tid);
  if (errno == 0 && setpriority(PRIO_PROCESS, tid, std::min(19, now + nice)) == 0) return;
  DSLAM_LOG(Debug, who << ": could not lower the priority of its thread: " << std::strerror(errno));
}

}  // namespace dslam
