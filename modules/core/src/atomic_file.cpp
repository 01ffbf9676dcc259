#include "dslam/core/atomic_file.h"

#include <unistd.h>

#include <cstdio>

#include "dslam/core/error.h"
#include "dslam/core/paths.h"

namespace dslam {

AtomicOfstream::AtomicOfstream(const std::string& path, std::ios::openmode mode)
    : path_(path), tmp_(path + ".tmp." + std::to_string(::getpid())) {
  f_.open(tmp_, mode | std::ios::out | std::ios::trunc);
  if (!f_) throw DataError("cannot write " + path_ + " (cannot create " + tmp_ + ")");
}

AtomicOfstream::~AtomicOfstream() {
  if (committed_) return;
  f_.close();
  std::remove(tmp_.c_str());
}

void AtomicOfstream::commit() {
  if (committed_) return;
  f_.flush();
  const bool ok = static_cast<bool>(f_);
  f_.close();
  if (!ok || f_.fail()) {
    std::remove(tmp_.c_str());
    committed_ = true;
    throw DataError("error writing " + path_ + " (disk full or not writable?)");
  }
  if (std::rename(tmp_.c_str(), path_.c_str()) != 0) {
    std::remove(tmp_.c_str());
    committed_ = true;
    throw DataError("cannot rename " + tmp_ + " to " + path_);
  }
  committed_ = true;
}

void writeTextFile(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  if (!f) throw DataError("cannot write " + path + freeSpaceNote(path));
  f << text;
  f.flush();
  if (!f) throw DataError("write failed: " + path + freeSpaceNote(path));
}

}  // namespace dslam
