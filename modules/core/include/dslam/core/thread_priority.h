#pragma once
/** \file thread_priority.h
 *  Lowering the scheduling priority of one background thread, so that the
 *  tracking thread keeps a core when helper threads (the dense map, an
 *  asynchronous detector) compete for the same cores. */

namespace dslam {

/** Raises the calling thread's niceness by `nice` (at most to 19). On Linux
 *  setpriority() on the thread id applies to that thread only. `nice` <= 0
 *  does nothing; a failure (e.g. a sandbox without the permission) is logged
 *  at debug level naming `who`, and the thread runs at its old priority. */
void lowerThreadPriority(int nice, const char* who);

}  // namespace dslam
