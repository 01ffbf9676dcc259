// Vocabulary files: format detection, load/save dispatch and the helpers
// shared by the three formats (vocabulary_io_detail.h).
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstring>

#include "dslam/core/error.h"
#include "dslam/core/paths.h"
#include "vocabulary_io_detail.h"

namespace dslam {

namespace vocio {

bool endsWith(const std::string& s, const std::string& suf) {
  if (s.size() < suf.size()) return false;
  for (size_t i = 0; i < suf.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(s[s.size() - suf.size() + i])) != suf[i]) return false;
  return true;
}

File::File(const std::string& path, const char* mode, bool gzip) : path_(path), writing_(mode[0] == 'w') {
  if (gzip) {
    g_ = gzopen(path.c_str(), writing_ ? "wb6" : "rb");
    if (g_ && !writing_) gzbuffer(g_, 1 << 20);
  } else {
    f_ = std::fopen(path.c_str(), mode);
  }
  if (!f_ && !g_)
    throw DataError(writing_ ? "cannot write vocabulary " + path : "vocabulary not found or not readable: " + path);
}

File::~File() {
  if (g_) gzclose(g_);
  if (f_) std::fclose(f_);
}

size_t File::read(void* d, size_t n) {
  if (f_) return std::fread(d, 1, n, f_);
  size_t got = 0;
  auto* p = static_cast<char*>(d);
  while (got < n) {
    const unsigned chunk = static_cast<unsigned>(std::min<size_t>(n - got, size_t(1) << 30));
    const int r = gzread(g_, p + got, chunk);
    if (r < 0) {
      int err = 0;
      const char* msg = gzerror(g_, &err);
      throw DataError(path_ + ": corrupt or truncated gzip data (" + std::string(msg ? msg : "") + ")");
    }
    if (r == 0) {
      int err = 0;
      const char* msg = gzerror(g_, &err);
      if (err != Z_OK && err != Z_STREAM_END)  // e.g. a truncated stream
        throw DataError(path_ + ": corrupt or truncated gzip data (" + std::string(msg ? msg : "") + ")");
      break;
    }
    got += static_cast<size_t>(r);
  }
  return got;
}

void File::write(const void* d, size_t n) {
  const char* p = static_cast<const char*>(d);
  while (n > 0) {  // gzwrite takes an unsigned length: large arrays in chunks
    const size_t c = std::min<size_t>(n, size_t(1) << 28);
    const bool ok = g_ ? gzwrite(g_, p, static_cast<unsigned>(c)) == static_cast<int>(c) : std::fwrite(p, 1, c, f_) == c;
    if (!ok) throw DataError("cannot write vocabulary " + path_);
    p += c;
    n -= c;
  }
}

uint64_t File::size() {
  if (!f_) return 0;
  const long pos = std::ftell(f_);
  std::fseek(f_, 0, SEEK_END);
  const long sz = std::ftell(f_);
  std::fseek(f_, pos, SEEK_SET);
  return sz > 0 ? static_cast<uint64_t>(sz) : 0;
}

void File::close() {
  bool ok = true;
  if (g_) ok = gzclose(g_) == Z_OK;
  if (f_) ok = std::fclose(f_) == 0 && ok;
  g_ = nullptr;
  f_ = nullptr;
  if (!ok && writing_) throw DataError("cannot write vocabulary " + path_);
}

bool isGzip(const std::string& path) {
  File f(path, "rb", false);
  unsigned char m[2] = {0, 0};
  return f.read(m, 2) == 2 && m[0] == 0x1f && m[1] == 0x8b;
}

std::string peek(const std::string& path, size_t n, bool* gz) {
  *gz = isGzip(path);
  File f(path, "rb", *gz);
  std::string out(n, '\0');
  try {
    out.resize(f.read(out.data(), n));
  } catch (const DataError&) {
    out.clear();  // a damaged gzip stream: the loader reports it
  }
  return out;
}

std::string slurp(const std::string& path, const char* format) {
  const bool gz = isGzip(path);
  File f(path, "rb", gz);
  std::string out;
  if (gz) {
    char buf[1 << 16];
    try {
      size_t r;
      while ((r = f.read(buf, sizeof buf)) > 0) {
        out.append(buf, r);
        if (out.size() > kMaxVocabularyBytes)  // a gzip bomb, not a vocabulary
          throw DataError(path + ": more than " + std::to_string(kMaxVocabularyBytes >> 20) +
                          " MiB of data after decompression, larger than any vocabulary (ORBvoc.txt is ~145 MB)");
      }
    } catch (const DataError& e) {
      throw DataError(std::string(e.what()) + " in " + format);
    }
  } else {
    if (f.size() > kMaxVocabularyBytes)
      throw DataError(path + ": " + std::to_string(f.size() >> 20) + " MiB, larger than any vocabulary (limit " +
                      std::to_string(kMaxVocabularyBytes >> 20) + " MiB; ORBvoc.txt is ~145 MB) in " + format);
    out.resize(f.size());
    out.resize(f.read(out.data(), out.size()));
  }
  return out;
}

bool looksLikeText(const std::string& head) {
  // First line: four integers.
  const size_t eol = head.find('\n');
  const std::string line = head.substr(0, eol);
  int vals = 0;
  const char* p = line.data();
  const char* e = p + line.size();
  while (p < e) {
    while (p < e && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
    if (p >= e) break;
    long v;
    auto r = std::from_chars(p, e, v);
    if (r.ec != std::errc()) return false;
    p = r.ptr;
    ++vals;
  }
  return vals == 4;
}

}  // namespace vocio

using namespace vocio;

const char* toString(VocabularyFormat f) {
  switch (f) {
    case VocabularyFormat::Auto: return "auto";
    case VocabularyFormat::Binary: return "binary";
    case VocabularyFormat::Text: return "text";
    case VocabularyFormat::Yaml: return "yaml";
  }
  return "?";
}

VocabularyFormat vocabularyFormatFromString(const std::string& s) {
  std::string c;
  for (char ch : s) c += static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  if (c == "auto") return VocabularyFormat::Auto;
  if (c == "binary" || c == "bin" || c == "dvoc") return VocabularyFormat::Binary;
  if (c == "text" || c == "txt") return VocabularyFormat::Text;
  if (c == "yaml" || c == "yml") return VocabularyFormat::Yaml;
  throw ConfigError("unknown vocabulary format '" + s + "' (expected auto, binary, text or yaml)");
}

VocabularyFormat vocabularyFormatFromExtension(const std::string& path) {
  // Anything else, including .dvoc and .dvoc.gz, is the binary format.
  if (endsWith(path, ".txt") || endsWith(path, ".txt.gz")) return VocabularyFormat::Text;
  if (endsWith(path, ".yml") || endsWith(path, ".yaml") || endsWith(path, ".yml.gz") || endsWith(path, ".yaml.gz"))
    return VocabularyFormat::Yaml;
  return VocabularyFormat::Binary;
}

VocabularyFormat detectVocabularyFormat(const std::string& path) {
  bool gz = false;
  const std::string head = peek(path, 256, &gz);
  if (head.size() >= 8 && std::memcmp(head.data(), kMagic, 8) == 0) return VocabularyFormat::Binary;
  size_t i = 0;
  while (i < head.size() && std::isspace(static_cast<unsigned char>(head[i]))) ++i;
  const std::string h = head.substr(i);
  if (h.rfind("%YAML", 0) == 0 || h.rfind("vocabulary:", 0) == 0 || h.rfind("---", 0) == 0)
    return VocabularyFormat::Yaml;
  if (looksLikeText(h)) return VocabularyFormat::Text;
  return VocabularyFormat::Auto;
}

Vocabulary Vocabulary::load(const std::string& path, VocabularyFormat format, VocabularyFormat* detected) {
  if (!fileExists(path)) throw DataError("vocabulary not found: " + path);
  const VocabularyFormat content = detectVocabularyFormat(path);
  VocabularyFormat f = format;
  if (f == VocabularyFormat::Auto) {
    f = content;
    if (f == VocabularyFormat::Auto)
      throw DataError(path + ": unrecognised vocabulary file: expected a " + std::string(kBinaryName) + ", a " +
                      kTextName + " or a " + kYamlName);
  }
  if (detected) *detected = f;
  switch (f) {
    case VocabularyFormat::Binary: return VocabularyIo::loadBinary(path);
    case VocabularyFormat::Text: return VocabularyIo::loadText(path);
    case VocabularyFormat::Yaml: return VocabularyIo::loadYaml(path);
    case VocabularyFormat::Auto: break;
  }
  return {};
}

void Vocabulary::save(const std::string& path) const {
  if (empty()) throw DataError("cannot save an empty vocabulary to " + path);
  VocabularyIo::saveBinary(*this, path);
}

void Vocabulary::saveText(const std::string& path) const {
  if (empty()) throw DataError("cannot save an empty vocabulary to " + path);
  VocabularyIo::saveText(*this, path);
}

void Vocabulary::saveYaml(const std::string& path) const {
  if (empty()) throw DataError("cannot save an empty vocabulary to " + path);
  VocabularyIo::saveYaml(*this, path);
}

void Vocabulary::saveAs(const std::string& path, VocabularyFormat format) const {
  if (format == VocabularyFormat::Auto) format = vocabularyFormatFromExtension(path);
  switch (format) {
    case VocabularyFormat::Text: saveText(path); break;
    case VocabularyFormat::Yaml: saveYaml(path); break;
    default: save(path); break;
  }
}

}  // namespace dslam
