#pragma once
/** \file test_support.h
 *  Helpers for dslam's gtest suites. */
#include <gtest/gtest.h>

#include <exception>
#include <string>
#include <vector>

#include "dslam/core/error.h"

namespace dslam::test {

/** Path inside the shared data folder (DSLAM_SHARED_DIR, default ../shared).
 *  When it does not exist: "" and a non-fatal test failure (ADD_FAILURE), or
 *  with DSLAM_ALLOW_MISSING_SHARED=1 "" and a note on stderr. The caller must
 *  return on "" (DSLAM_REQUIRE_SHARED does, as a skip). */
std::string shared(const std::string& rel);
/** Source tree path (configs, scenarios): DSLAM_SOURCE_DIR if set, else the
 *  source folder the tests were built from. */
std::string source(const std::string& rel);
/** A fresh empty temporary directory, removed at process exit. */
std::string tempDir(const std::string& tag);
/** Path of the dslam executable: DSLAM_EXE if set in the environment, else
 *  the dslam built with the tests (its path is compiled into
 *  dslam_test_support; ctest sets nothing). */
std::string dslamExe();

struct CmdResult {
  int exit_code = -1;
  std::string out;  ///< stdout and stderr, merged
};
/** Runs a shell command line and captures its output. */
CmdResult run(const std::string& cmdline);
/** Runs `dslam <args>`. */
CmdResult runDslam(const std::string& args);
/** Starts args[0] with args in the background, stdout and stderr into
 *  `log`; returns its pid (waitpid it). */
int spawnLogged(std::vector<std::string> args, const std::string& log);
std::string readFile(const std::string& path);
/** Concatenation by append (GCC 12 reports false -Wrestrict warnings for
 *  chains of `"literal" + std::string + ...` in some inlined contexts). */
template <class... T>
std::string cat(const T&... parts) {
  std::string s;
  (s.append(parts), ...);
  return s;
}
void writeFile(const std::string& path, const std::string& content);
/** A KITTI times.txt: one stamp per line with `decimals` decimals. */
void writeKittiTimes(const std::string& path, const std::vector<double>& stamps, int decimals = 6);

/** Message of the DataError thrown by f; fails the test if f throws nothing
 *  or another exception. */
template <class F>
std::string dataError(F&& f) {
  try {
    f();
  } catch (const DataError& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected DataError, got: " << e.what();
    return "";
  }
  ADD_FAILURE() << "expected DataError, nothing thrown";
  return "";
}

}  // namespace dslam::test

/** Guard for tests that need shared data: returns from the test (as a skip)
 *  when `rel` is missing, after shared() recorded the failure (or only the
 *  note with DSLAM_ALLOW_MISSING_SHARED=1). */
#define DSLAM_REQUIRE_SHARED(rel)                          \
  do {                                                     \
    if (::dslam::test::shared(rel).empty()) GTEST_SKIP(); \
  } while (0)
