#include "dslam/core/paths.h"

#include <dlfcn.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>

#include "dslam/core/error.h"

#ifndef DSLAM_DEFAULT_SHARED_DIR
#define DSLAM_DEFAULT_SHARED_DIR "../shared"
#endif

namespace fs = std::filesystem;

namespace dslam {

std::string sharedDir() {
  if (const char* e = std::getenv("DSLAM_SHARED_DIR"); e && *e) return e;
  return fs::path(DSLAM_DEFAULT_SHARED_DIR).lexically_normal().string();
}

std::string sharedPath(const std::string& rel) {
  const std::string p = (fs::path(sharedDir()) / rel).string();
  requireFile(p, "shared data file",
              "set DSLAM_SHARED_DIR to the shared folder (default ../shared beside the "
              "checkout) or fetch the upstream files with scripts/download_data.sh");
  return p;
}

std::string installDataDir() {
  static const std::string dir = [] {
    Dl_info info{};
    if (!dladdr(reinterpret_cast<void*>(&installDataDir), &info) || !info.dli_fname) return std::string();
    std::error_code ec;
    const fs::path lib = fs::weakly_canonical(info.dli_fname, ec);
    if (ec) return std::string();
    // <prefix>/lib/libdslam_core.so or <prefix>/lib/<multiarch>/libdslam_core.so
    for (fs::path p = lib.parent_path(); p.has_parent_path() && p != p.root_path(); p = p.parent_path()) {
      const fs::path cand = p.parent_path() / "share" / "dslam";
      if (fs::is_regular_file(cand / "dslam_install.txt", ec)) return cand.string();
      if (p.filename() == "lib" || p.filename() == "lib64") break;
    }
    return std::string();
  }();
  return dir;
}

std::string resolvePath(const std::string& p, const std::string& base_dir) {
  if (p.empty()) return p;
  if (p.rfind("~/", 0) == 0) {
    if (const char* h = std::getenv("HOME")) return (fs::path(h) / p.substr(2)).string();
  }
  fs::path pp(p);
  if (pp.is_absolute() || base_dir.empty()) return pp.lexically_normal().string();
  return (fs::path(base_dir) / pp).lexically_normal().string();
}

bool fileExists(const std::string& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

bool dirExists(const std::string& p) {
  std::error_code ec;
  return fs::is_directory(p, ec);
}

void requireFile(const std::string& p, const std::string& what, const std::string& hint) {
  if (!fileExists(p))
    throw DataError(what + " not found: " + p + (hint.empty() ? "" : " (" + hint + ")"));
}

bool isInside(const std::string& path, const std::string& dir) {
  std::error_code ec;
  const fs::path p = fs::weakly_canonical(path, ec), d = fs::weakly_canonical(dir, ec);
  const fs::path rel = p.lexically_relative(d);
  return !rel.empty() && *rel.begin() != "..";
}

std::string freeSpaceNote(const std::string& path) {
  std::error_code ec;
  const fs::path dir = fs::path(path).parent_path();
  const fs::space_info s = fs::space(dir.empty() ? fs::path(".") : dir, ec);
  if (ec) return "";
  return " (" + std::to_string(s.available >> 20) + " MB free on its disk)";
}

void requireDir(const std::string& p, const std::string& what, const std::string& hint) {
  if (!dirExists(p))
    throw DataError(what + " not found: " + p + (hint.empty() ? "" : " (" + hint + ")"));
}

void makeOutputDir(const std::string& p, const std::string& what) {
  std::error_code ec;
  if (fs::exists(p, ec) && !fs::is_directory(p, ec))
    throw DataError(what + " " + p + " is a file, not a folder");
  fs::create_directories(p, ec);
  if (ec) throw DataError("cannot create " + what + " " + p + ": " + ec.message());
  if (::access(p.c_str(), W_OK) != 0) throw DataError(what + " " + p + " is not writable");
}

}  // namespace dslam
