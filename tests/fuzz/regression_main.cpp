// Runs every file of the given corpus folders (or files) through the
// harness's LLVMFuzzerTestOneInput: the fuzz corpora as regression tests in
// the normal (gcc) build, no libFuzzer needed. A finding aborts the process
// (fuzz_common.h), which fails the ctest test.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <malloc.h>
#include <sys/resource.h>
#include <unistd.h>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  std::vector<fs::path> files;
  for (int i = 1; i < argc; i++) {
    const fs::path p(argv[i]);
    if (fs::is_directory(p)) {
      for (const auto& e : fs::recursive_directory_iterator(p))
        if (e.is_regular_file()) files.push_back(e.path());
    } else if (fs::is_regular_file(p)) {
      files.push_back(p);
    } else {
      std::fprintf(stderr, "error: no such corpus file or folder: %s\n", argv[i]);
      return 2;
    }
  }
  if (files.empty()) {
    std::fprintf(stderr, "error: no corpus inputs (usage: %s CORPUS_DIR_OR_FILE...)\n", argv[0]);
    return 2;
  }
  std::sort(files.begin(), files.end());
  // No input may make a reader allocate gigabytes: cap the address space at
  // what the process has now plus 2 GiB, so that such an allocation fails
  // (std::bad_alloc: a finding) instead of swapping the CI machine. libFuzzer
  // checks single allocations more tightly (-malloc_limit_mb=1024).
  mallopt(M_ARENA_MAX, 2);
  {
    std::ifstream statm("/proc/self/statm");
    unsigned long long pages = 0;
    if (statm >> pages) {
      const rlim_t lim = static_cast<rlim_t>(pages) * static_cast<rlim_t>(sysconf(_SC_PAGESIZE)) + (rlim_t(2) << 30);
      rlimit rl{lim, lim};
      setrlimit(RLIMIT_AS, &rl);
    }
  }
  const auto t0 = std::chrono::steady_clock::now();
  for (const auto& f : files) {
    std::ifstream in(f, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::fprintf(stderr, "%s\n", f.c_str());  // the culprit is the last line if it aborts
    LLVMFuzzerTestOneInput(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("%zu inputs passed in %.2f s\n", files.size(), s);
  return 0;
}
