#pragma once
// Private to the vocabulary file sources: vocabulary_io.cpp (format
// detection, dispatch, shared helpers), vocabulary_io_binary.cpp (dslam
// binary), vocabulary_io_text.cpp (DBoW2/ORB-SLAM text), vocabulary_io_yaml.cpp
// (DBoW2/DBoW3 OpenCV YAML).
#include <zlib.h>

#include <cstdint>
#include <cstdio>
#include <string>

#include "dslam/place_recognition/vocabulary.h"

namespace dslam {
namespace vocio {

inline constexpr char kMagic[8] = {'D', 'S', 'L', 'A', 'M', 'V', 'O', 'C'};
inline constexpr char kEndMagic[8] = {'D', 'S', 'L', 'A', 'M', 'E', 'N', 'D'};
inline constexpr uint32_t kVersion = 1;
inline constexpr size_t kHeaderBytes = 48;

inline const char* const kBinaryName = "dslam binary vocabulary ('DSLAMVOC' header, version 1)";
inline const char* const kTextName =
    "DBoW2/ORB-SLAM text vocabulary (ORBvoc.txt: first line 'k L scoring weighting', then 'parent isLeaf d0 ... d31 "
    "weight' per node)";
inline const char* const kYamlName = "DBoW2/DBoW3 OpenCV YAML vocabulary (.yml/.yml.gz with a 'vocabulary:' map)";

/** Case-insensitive suffix test (`suf` in lower case). */
bool endsWith(const std::string& s, const std::string& suf);

/** A plain or gzip-compressed file: the one RAII wrapper of FILE* and gzFile
 *  of the vocabulary code. Closed by close() (which reports write errors) or
 *  by the destructor (errors ignored). */
class File {
 public:
  /** mode "rb" or "wb"; gzip: through zlib (level 6 when writing). Throws
   *  DataError naming the file when it cannot be opened. */
  File(const std::string& path, const char* mode, bool gzip);
  ~File();
  File(const File&) = delete;
  File& operator=(const File&) = delete;

  bool gzip() const { return g_ != nullptr; }
  /** Reads up to n bytes; returns how many. DataError on a gzip data error. */
  size_t read(void* d, size_t n);
  void write(const void* d, size_t n);
  /** Size in bytes (plain files). */
  uint64_t size();
  /** Flushes and closes; DataError when a write did not reach the file. */
  void close();

 private:
  FILE* f_ = nullptr;
  gzFile g_ = nullptr;
  std::string path_;
  bool writing_ = false;
};

/** True if the file starts with the gzip magic bytes. */
bool isGzip(const std::string& path);
/** First `n` bytes of the file, decompressed if it is gzip. */
std::string peek(const std::string& path, size_t n, bool* gz);
/** Largest vocabulary data read into memory (after decompression): k=10
 *  L=6 ORBvoc.txt is ~145 MB, its binary form ~40 MB. */
constexpr uint64_t kMaxVocabularyBytes = uint64_t(512) << 20;
/** Whole file, decompressed if gzip; `format` names it in errors. Throws
 *  DataError beyond kMaxVocabularyBytes. */
std::string slurp(const std::string& path, const char* format);
/** The first line holds four integers (ORBvoc.txt header). */
bool looksLikeText(const std::string& head);

}  // namespace vocio

/** Loaders and writers (friend of Vocabulary). */
struct VocabularyIo {
  static void saveBinary(const Vocabulary& v, const std::string& path);
  static Vocabulary loadBinary(const std::string& path);
  static void saveText(const Vocabulary& v, const std::string& path);
  static Vocabulary loadText(const std::string& path);
  static void saveYaml(const Vocabulary& v, const std::string& path);
  static Vocabulary loadYaml(const std::string& path);
};

}  // namespace dslam
