#pragma once
/** \file fuzz_common.h
 *  Shared by the fuzz harnesses (tests/fuzz/README.md). Each harness defines
 *  LLVMFuzzerTestOneInput; it is linked either with libFuzzer (clang,
 *  DSLAM_BUILD_FUZZERS) or with regression_main.cpp (the normal build, runs
 *  the committed corpora under ctest).
 *
 *  Verdicts: a dslam::Error (DataError / ConfigError, the errors that name
 *  the file) is the expected way to refuse a bad input. Anything else is a
 *  finding and aborts, so that libFuzzer records it and the regression test
 *  fails: std::bad_alloc / std::length_error (a size read from the file
 *  drove an allocation), any other std::exception (the CLI would print it,
 *  but without naming the file: "stod", "vector::_M_range_check"), crashes,
 *  sanitizer reports. */
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <new>
#include <string>
#include <typeinfo>

#include <unistd.h>

#include "dslam/core/error.h"
#include "dslam/core/log.h"

namespace dslam::fuzz {

/** Folder of this process's scratch files (/dev/shm when available). */
inline const std::filesystem::path& scratchDir() {
  static const std::filesystem::path dir = [] {
    std::filesystem::path base = std::filesystem::exists("/dev/shm") ? "/dev/shm" : std::filesystem::temp_directory_path();
    auto d = base / ("dslam_fuzz_" + std::to_string(static_cast<long>(::getpid())));
    std::filesystem::create_directories(d);
    // Quiet: loaders warn about oddities of the inputs; the fuzzer does not need it.
    dslam::log::setLevel(dslam::log::Level::Error);
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(scratchDir(), ec);
    });
    return d;
  }();
  return dir;
}

/** Writes `n` bytes to `<scratch>/<name>` (sub-folders created) and returns the path. */
inline std::string writeFile(const std::string& name, const uint8_t* data, size_t n) {
  const auto p = scratchDir() / name;
  std::filesystem::create_directories(p.parent_path());
  std::ofstream f(p, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(n));
  f.close();
  if (!f) {
    std::fprintf(stderr, "fuzz harness: cannot write %s\n", p.c_str());
    std::abort();
  }
  return p.string();
}
inline std::string writeFile(const std::string& name, const std::string& s) {
  return writeFile(name, reinterpret_cast<const uint8_t*>(s.data()), s.size());
}

[[noreturn]] inline void finding(const char* kind, const char* what) {
  std::fprintf(stderr, "\n==== dslam fuzz finding: %s: %s\n", kind, what);
  std::fflush(stderr);
  std::abort();
}

/** Runs `f`, accepting dslam::Error; anything else is a finding. */
template <class F>
void guarded(F&& f) {
  try {
    f();
  } catch (const dslam::Error& e) {
    // the clean refusal; DSLAM_FUZZ_VERBOSE=1 prints it (checking what an input reaches)
    static const bool verbose = std::getenv("DSLAM_FUZZ_VERBOSE") != nullptr;
    if (verbose) std::fprintf(stderr, "dslam::Error: %s\n", e.what());
  } catch (const std::bad_alloc& e) {
    finding("std::bad_alloc (unbounded allocation)", e.what());
  } catch (const std::length_error& e) {
    finding("std::length_error (unbounded allocation)", e.what());
  } catch (const std::exception& e) {
    finding(typeid(e).name(), e.what());
  }
}

/** The input split into a selector byte (which reader / variant) and the file
 *  content. Empty inputs select mode 0 with no content. */
struct Selected {
  unsigned mode = 0;
  const uint8_t* data = nullptr;
  size_t size = 0;
  std::string text() const { return std::string(reinterpret_cast<const char*>(data), size); }
};
inline Selected select(const uint8_t* data, size_t size, unsigned modes) {
  if (size == 0) return {0, data, 0};
  return {static_cast<unsigned>(data[0]) % modes, data + 1, size - 1};
}

}  // namespace dslam::fuzz
