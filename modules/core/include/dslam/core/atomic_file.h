#pragma once
/** \file atomic_file.h
 *  Output files that appear under their name only when complete, so that a
 *  failed or killed run never leaves a truncated file that looks finished. */
#include <fstream>
#include <string>

namespace dslam {

/** Writes to "<path>.tmp.<pid>" in the same folder; commit() flushes, checks
 *  the stream and renames it over `path` (atomic on POSIX file systems).
 *  Destroyed without commit() (an exception, a failed write) it removes the
 *  temporary file and leaves an earlier `path` as it was. */
class AtomicOfstream {
 public:
  explicit AtomicOfstream(const std::string& path, std::ios::openmode mode = std::ios::out);
  ~AtomicOfstream();
  AtomicOfstream(const AtomicOfstream&) = delete;
  AtomicOfstream& operator=(const AtomicOfstream&) = delete;

  std::ofstream& stream() { return f_; }
  template <class T>
  AtomicOfstream& operator<<(const T& v) {
    f_ << v;
    return *this;
  }
  /** Flushes and renames; throws DataError naming the file on a write error. */
  void commit();
  const std::string& path() const { return path_; }

 private:
  std::string path_, tmp_;
  std::ofstream f_;
  bool committed_ = false;
};

/** Writes `text` to `path` in place (no temporary file: for files written
 *  once per frame, where a rename each would cost). Throws DataError naming
 *  the file, with the free space when the disk is full (freeSpaceNote). */
void writeTextFile(const std::string& path, const std::string& text);

}  // namespace dslam
