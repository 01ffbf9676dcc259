// Vocabulary files: dslam binary, DBoW2/ORB-SLAM text (ORBvoc.txt, optionally
// gzip-compressed) and DBoW2/DBoW3 OpenCV YAML.
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

#include <opencv2/core/persistence.hpp>

#include "dslam/core/error.h"
#include "dslam/core/paths.h"
#include "dslam/place_recognition/vocabulary.h"

namespace dslam {

static_assert(std::endian::native == std::endian::little, "the binary vocabulary format is little-endian");

namespace {

constexpr char kMagic[8] = {'D', 'S', 'L', 'A', 'M', 'V', 'O', 'C'};
constexpr char kEndMagic[8] = {'D', 'S', 'L', 'A', 'M', 'E', 'N', 'D'};
constexpr uint32_t kVersion = 1;
constexpr size_t kHeaderBytes = 48;

const char* const kBinaryName = "dslam binary vocabulary ('DSLAMVOC' header, version 1)";
const char* const kTextName = "DBoW2/ORB-SLAM text vocabulary (ORBvoc.txt: first line 'k L scoring weighting', "
                              "then 'parent isLeaf d0 ... d31 weight' per node)";
const char* const kYamlName = "DBoW2/DBoW3 OpenCV YAML vocabulary (.yml/.yml.gz with a 'vocabulary:' map)";

bool endsWith(const std::string& s, const std::string& suf) {
  if (s.size() < suf.size()) return false;
  for (size_t i = 0; i < suf.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(s[s.size() - suf.size() + i])) != suf[i]) return false;
  return true;
}

struct FileCloser {
  void operator()(FILE* f) const {
    if (f) std::fclose(f);
  }
};
using FilePtr = std::unique_ptr<FILE, FileCloser>;

/** First `n` bytes of the file, decompressed if it is gzip. */
std::string peek(const std::string& path, size_t n, bool* gz) {
  FilePtr f(std::fopen(path.c_str(), "rb"));
  if (!f) throw DataError("vocabulary not found or not readable: " + path);
  unsigned char m[2] = {0, 0};
  const size_t got = std::fread(m, 1, 2, f.get());
  *gz = got == 2 && m[0] == 0x1f && m[1] == 0x8b;
  f.reset();
  std::string out(n, '\0');
  if (*gz) {
    gzFile g = gzopen(path.c_str(), "rb");
    if (!g) throw DataError("vocabulary not readable: " + path);
    const int r = gzread(g, out.data(), static_cast<unsigned>(n));
    gzclose(g);
    out.resize(r > 0 ? static_cast<size_t>(r) : 0);
  } else {
    FilePtr f2(std::fopen(path.c_str(), "rb"));
    out.resize(std::fread(out.data(), 1, n, f2.get()));
  }
  return out;
}

/** Whole file, decompressed if gzip. */
std::string slurp(const std::string& path, const char* format) {
  bool gz = false;
  peek(path, 2, &gz);
  std::string out;
  if (gz) {
    gzFile g = gzopen(path.c_str(), "rb");
    if (!g) throw DataError("vocabulary not readable: " + path);
    gzbuffer(g, 1 << 20);
    char buf[1 << 16];
    int r;
    while ((r = gzread(g, buf, sizeof buf)) > 0) out.append(buf, static_cast<size_t>(r));
    int err = 0;
    const char* msg = gzerror(g, &err);
    const bool bad = r < 0 || (err != Z_OK && err != Z_STREAM_END);
    const std::string m = msg ? msg : "";
    gzclose(g);
    if (bad) throw DataError(path + ": corrupt or truncated gzip data (" + m + ") in " + format);
  } else {
    FilePtr f(std::fopen(path.c_str(), "rb"));
    if (!f) throw DataError("vocabulary not readable: " + path);
    std::fseek(f.get(), 0, SEEK_END);
    const long sz = std::ftell(f.get());
    std::fseek(f.get(), 0, SEEK_SET);
    out.resize(sz > 0 ? static_cast<size_t>(sz) : 0);
    out.resize(std::fread(out.data(), 1, out.size(), f.get()));
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

void writeAll(FILE* f, const void* d, size_t n, const std::string& path) {
  if (n && std::fwrite(d, 1, n, f) != n) throw DataError("cannot write vocabulary " + path);
}

}  // namespace

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

/** Loaders and writers (friend of Vocabulary). */
struct VocabularyIo {
  // ---- dslam binary ---------------------------------------------------------
  /** Sequential sink / source over a plain or gzip file. */
  struct Out {
    FILE* f = nullptr;
    gzFile g = nullptr;
    std::string path;
    void write(const void* d, size_t n) {
      if (n == 0) return;
      const bool ok = g ? gzwrite(g, d, static_cast<unsigned>(n)) == static_cast<int>(n) : std::fwrite(d, 1, n, f) == n;
      if (!ok) throw DataError("cannot write vocabulary " + path);
    }
    template <class T>
    void writeVec(const std::vector<T>& v) {
      // gzwrite takes an unsigned length: write large arrays in chunks.
      const char* p = reinterpret_cast<const char*>(v.data());
      size_t n = v.size() * sizeof(T);
      while (n > 0) {
        const size_t c = std::min<size_t>(n, size_t(1) << 28);
        write(p, c);
        p += c;
        n -= c;
      }
    }
  };

  static void saveBinary(const Vocabulary& v, const std::string& path) {
    Out o;
    o.path = path;
    FilePtr f;
    if (endsWith(path, ".gz")) {
      o.g = gzopen(path.c_str(), "wb6");
      if (!o.g) throw DataError("cannot write vocabulary " + path);
    } else {
      f.reset(std::fopen(path.c_str(), "wb"));
      if (!f) throw DataError("cannot write vocabulary " + path);
      o.f = f.get();
    }
    try {
      const uint32_t hdr[6] = {kVersion, 32u, static_cast<uint32_t>(v.k_), static_cast<uint32_t>(v.L_),
                               static_cast<uint32_t>(v.weighting_), static_cast<uint32_t>(v.scoring_)};
      const uint64_t counts[2] = {v.parent_.size(), v.word_node_.size()};
      o.write(kMagic, 8);
      o.write(hdr, sizeof hdr);
      o.write(counts, sizeof counts);
      o.writeVec(v.parent_);
      o.writeVec(v.desc_);
      o.writeVec(v.word_node_);
      o.writeVec(v.word_weight_);
      o.write(kEndMagic, 8);
    } catch (...) {
      if (o.g) gzclose(o.g);
      throw;
    }
    if (o.g) {
      if (gzclose(o.g) != Z_OK) throw DataError("cannot write vocabulary " + path);
    } else if (std::fflush(o.f) != 0) {
      throw DataError("cannot write vocabulary " + path);
    }
  }

  /** Reads `n` bytes from a plain file or from a decompressed buffer. */
  struct In {
    FILE* f = nullptr;
    const std::string* buf = nullptr;
    size_t pos = 0;
    bool read(void* d, size_t n) {
      if (f) return std::fread(d, 1, n, f) == n;
      if (buf->size() - pos < n) return false;
      std::memcpy(d, buf->data() + pos, n);
      pos += n;
      return true;
    }
  };

  static Vocabulary loadBinary(const std::string& path) {
    const std::string what = path + " (" + kBinaryName + ")";
    bool gz = false;
    peek(path, 2, &gz);
    In in;
    FilePtr f;
    std::string buf;
    uint64_t size = 0;
    if (gz) {
      buf = slurp(path, kBinaryName);
      in.buf = &buf;
      size = buf.size();
    } else {
      f.reset(std::fopen(path.c_str(), "rb"));
      if (!f) throw DataError("vocabulary not found or not readable: " + path);
      std::fseek(f.get(), 0, SEEK_END);
      size = static_cast<uint64_t>(std::ftell(f.get()));
      std::fseek(f.get(), 0, SEEK_SET);
      in.f = f.get();
    }
    const char* kind = gz ? " (gzip-compressed)" : "";
    unsigned char head[kHeaderBytes] = {};
    const size_t got = std::min<uint64_t>(size, kHeaderBytes);
    in.read(head, got);
    if (got < 8 || std::memcmp(head, kMagic, 8) != 0)
      throw DataError(path + ": not a " + kBinaryName + kind + ": wrong magic (the data does not start with 'DSLAMVOC')");
    if (got < kHeaderBytes)
      throw DataError(path + ": truncated " + kBinaryName + kind + ": " + std::to_string(size) +
                      " bytes, shorter than the " + std::to_string(kHeaderBytes) + "-byte header");
    uint32_t hdr[6];
    uint64_t counts[2];
    std::memcpy(hdr, head + 8, sizeof hdr);
    std::memcpy(counts, head + 32, sizeof counts);
    if (hdr[0] != kVersion)
      throw DataError(path + ": " + kBinaryName + ": unsupported version " + std::to_string(hdr[0]));
    if (hdr[1] != 32)
      throw DataError(what + ": descriptor size " + std::to_string(hdr[1]) + " bytes, only 32 (ORB) is supported");
    const uint64_t n = counts[0], nw = counts[1];
    if (n < 2 || n > 0xFFFFFFF0ull || nw < 1 || nw >= n)
      throw DataError(what + ": bad node/word counts " + std::to_string(n) + " / " + std::to_string(nw));
    const uint64_t expected = kHeaderBytes + n * 36 + nw * 12 + 8;
    if (size < expected)
      throw DataError(path + ": truncated " + kBinaryName + kind + ": the header announces " + std::to_string(n) +
                      " nodes and " + std::to_string(nw) + " words (" + std::to_string(expected) +
                      " bytes), the data has " + std::to_string(size) + " bytes");
    if (size > expected)
      throw DataError(what + ": " + std::to_string(size - expected) + " unexpected bytes after the end of the data");
    Vocabulary v;
    if (hdr[2] < 2 || hdr[2] > 255) throw DataError(what + ": k = " + std::to_string(hdr[2]) + " out of range 2..255");
    if (hdr[3] < 1 || hdr[3] > 16) throw DataError(what + ": L = " + std::to_string(hdr[3]) + " out of range 1..16");
    v.k_ = static_cast<int>(hdr[2]);
    v.L_ = static_cast<int>(hdr[3]);
    try {
      v.weighting_ = weightingFromInt(static_cast<int>(hdr[4]));
      v.scoring_ = scoringFromInt(static_cast<int>(hdr[5]));
    } catch (const DataError& e) {
      throw DataError(what + ": " + e.what());
    }
    v.parent_.resize(n);
    v.desc_.resize(n);
    v.word_node_.resize(nw);
    v.word_weight_.resize(nw);
    char end[8];
    if (!in.read(v.parent_.data(), 4 * n) || !in.read(v.desc_.data(), 32 * n) || !in.read(v.word_node_.data(), 4 * nw) ||
        !in.read(v.word_weight_.data(), 8 * nw) || !in.read(end, 8))
      throw DataError(path + ": truncated " + kBinaryName + " (read error)");
    if (std::memcmp(end, kEndMagic, 8) != 0)
      throw DataError(what + ": missing end marker 'DSLAMEND' (corrupt file)");
    // Structure: breadth-first order (parents non-decreasing and before their children).
    if (v.parent_[0] != Vocabulary::kNoNode) throw DataError(what + ": node 0 is not the root");
    for (uint64_t i = 1; i < n; ++i) {
      const NodeId p = v.parent_[i];
      if (p >= i || (i > 1 && p < v.parent_[i - 1]))
        throw DataError(what + ": node " + std::to_string(i) + " has parent " + std::to_string(p) +
                        " (nodes must be in breadth-first order)");
    }
    for (uint64_t w = 0; w < nw; ++w)
      if (v.word_node_[w] == 0 || v.word_node_[w] >= n)
        throw DataError(what + ": word " + std::to_string(w) + " refers to node " + std::to_string(v.word_node_[w]));
    v.finalize();
    std::vector<uint8_t> seen(n, 0);
    for (uint64_t w = 0; w < nw; ++w) {
      const NodeId nn = v.word_node_[w];
      if (v.n_children_[nn] != 0) throw DataError(what + ": word " + std::to_string(w) + " is on an inner node");
      if (seen[nn]++) throw DataError(what + ": node " + std::to_string(nn) + " has two words");
    }
    for (uint64_t i = 1; i < n; ++i) {
      if (v.n_children_[i] == 0 && !seen[i]) throw DataError(what + ": leaf node " + std::to_string(i) + " has no word");
      if (v.n_children_[i] > v.k_ || v.depth_[i] > v.L_)
        throw DataError(what + ": node " + std::to_string(i) + " exceeds k or L");
    }
    if (v.n_children_[0] == 0 || v.n_children_[0] > v.k_) throw DataError(what + ": bad root");
    return v;
  }

  // ---- DBoW2 / ORB-SLAM text ------------------------------------------------
  static void saveText(const Vocabulary& v, const std::string& path) {
    std::string out;
    out.reserve(v.parent_.size() * 110 + 32);
    out += std::to_string(v.k_) + " " + std::to_string(v.L_) + " " + std::to_string(static_cast<int>(v.scoring_)) +
           " " + std::to_string(static_cast<int>(v.weighting_)) + "\n";
    char buf[64];
    for (size_t i = 1; i < v.parent_.size(); ++i) {
      out += std::to_string(v.parent_[i]);
      const bool leaf = v.n_children_[i] == 0;
      out += leaf ? " 1" : " 0";
      const uint8_t* d = v.descriptor(static_cast<NodeId>(i));
      for (int j = 0; j < 32; ++j) {
        out += ' ';
        out += std::to_string(d[j]);
      }
      const double w = leaf ? v.word_weight_[v.node_word_[i]] : 0.0;
      auto r = std::to_chars(buf, buf + sizeof buf, w);  // shortest exact representation
      out += ' ';
      out.append(buf, r.ptr);
      out += '\n';
    }
    if (endsWith(path, ".gz")) {
      gzFile g = gzopen(path.c_str(), "wb6");
      if (!g) throw DataError("cannot write vocabulary " + path);
      const bool ok = gzwrite(g, out.data(), static_cast<unsigned>(out.size())) == static_cast<int>(out.size());
      if (gzclose(g) != Z_OK || !ok) throw DataError("cannot write vocabulary " + path);
    } else {
      FilePtr f(std::fopen(path.c_str(), "wb"));
      if (!f) throw DataError("cannot write vocabulary " + path);
      writeAll(f.get(), out.data(), out.size(), path);
      if (std::fflush(f.get()) != 0) throw DataError("cannot write vocabulary " + path);
    }
  }

  static Vocabulary loadText(const std::string& path) {
    const std::string data = slurp(path, kTextName);
    const char* p = data.data();
    const char* const end = p + data.size();
    size_t line = 0;
    auto fail = [&](const std::string& msg) -> DataError {
      return DataError(path + ":" + std::to_string(line) + ": " + msg + " (expected a " + kTextName + ")");
    };
    auto nextLine = [&](const char*& b, const char*& e) {
      b = p;
      const void* nl = std::memchr(p, '\n', static_cast<size_t>(end - p));
      e = nl ? static_cast<const char*>(nl) : end;
      p = nl ? e + 1 : end;
      ++line;
      const char* ee = e;
      while (ee > b && (ee[-1] == '\r' || ee[-1] == ' ' || ee[-1] == '\t')) --ee;
      e = ee;
    };
    auto skipWs = [](const char*& q, const char* e) {
      while (q < e && (*q == ' ' || *q == '\t')) ++q;
    };
    const char *b, *e;
    if (data.empty()) {
      line = 1;
      throw fail("empty file");
    }
    nextLine(b, e);
    long hv[4];
    {
      const char* q = b;
      for (int i = 0; i < 4; ++i) {
        skipWs(q, e);
        auto r = std::from_chars(q, e, hv[i]);
        if (r.ec != std::errc()) throw fail("the first line must be 'k L scoring weighting' (four integers)");
        q = r.ptr;
      }
      skipWs(q, e);
      if (q != e) throw fail("the first line must be 'k L scoring weighting' (four integers), found more");
    }
    const int k = static_cast<int>(hv[0]), L = static_cast<int>(hv[1]);
    if (hv[0] < 2 || hv[0] > 255 || hv[1] < 1 || hv[1] > 16)
      throw fail("k = " + std::to_string(hv[0]) + ", L = " + std::to_string(hv[1]) + " out of range (k 2..255, L 1..16)");
    ScoringType st;
    WeightingType wt;
    try {
      st = scoringFromInt(static_cast<int>(hv[2]));
      wt = weightingFromInt(static_cast<int>(hv[3]));
    } catch (const DataError& ex) {
      throw fail(ex.what());
    }
    std::vector<NodeId> parents;
    std::vector<std::array<uint8_t, 32>> descs;
    std::vector<uint8_t> leaf_flag;
    std::vector<NodeId> words;
    std::vector<WordValue> weights;
    // Rough pre-size: ~100 bytes per line.
    parents.reserve(data.size() / 90 + 1);
    descs.reserve(data.size() / 90 + 1);
    while (p < end) {
      nextLine(b, e);
      const char* q = b;
      skipWs(q, e);
      if (q == e) {
        // Blank lines are only allowed at the end.
        while (p < end) {
          nextLine(b, e);
          const char* qq = b;
          skipWs(qq, e);
          if (qq != e) throw fail("blank line inside the node list");
        }
        break;
      }
      const NodeId id = static_cast<NodeId>(parents.size() + 1);
      unsigned long parent = 0;
      int is_leaf = 0;
      auto r = std::from_chars(q, e, parent);
      if (r.ec != std::errc()) throw fail("node " + std::to_string(id) + ": bad parent id");
      q = r.ptr;
      skipWs(q, e);
      r = std::from_chars(q, e, is_leaf);
      if (r.ec != std::errc() || (is_leaf != 0 && is_leaf != 1))
        throw fail("node " + std::to_string(id) + ": bad isLeaf flag (0 or 1)");
      q = r.ptr;
      std::array<uint8_t, 32> d;
      for (int j = 0; j < 32; ++j) {
        skipWs(q, e);
        int x = -1;
        r = std::from_chars(q, e, x);
        if (r.ec != std::errc() || x < 0 || x > 255)
          throw fail("node " + std::to_string(id) + ": descriptor byte " + std::to_string(j) +
                     " missing or not in 0..255 (truncated line?)");
        d[j] = static_cast<uint8_t>(x);
        q = r.ptr;
      }
      skipWs(q, e);
      double w = 0;
      auto rw = std::from_chars(q, e, w);
      if (rw.ec != std::errc()) throw fail("node " + std::to_string(id) + ": missing or bad weight (truncated line?)");
      q = rw.ptr;
      skipWs(q, e);
      if (q != e) throw fail("node " + std::to_string(id) + ": extra values after the weight");
      if (parent >= id)
        throw fail("node " + std::to_string(id) + ": parent " + std::to_string(parent) +
                   " must be an earlier node (0 = root)");
      parents.push_back(static_cast<NodeId>(parent));
      descs.push_back(d);
      leaf_flag.push_back(static_cast<uint8_t>(is_leaf));
      if (is_leaf) {
        words.push_back(id);
        weights.push_back(w);
      }
    }
    if (parents.empty()) {
      line = 1;
      throw fail("no nodes after the header line");
    }
    // isLeaf must agree with the tree.
    std::vector<uint8_t> has_child(parents.size() + 1, 0);
    for (NodeId pp : parents) has_child[pp] = 1;
    for (size_t i = 0; i < parents.size(); ++i)
      if (static_cast<bool>(leaf_flag[i]) == static_cast<bool>(has_child[i + 1])) {
        line = i + 2;
        throw fail("node " + std::to_string(i + 1) + (leaf_flag[i] ? " is marked leaf but has children"
                                                                     : " is marked inner but has no children"));
      }
    return Vocabulary::fromTree(k, L, wt, st, parents, descs, words, weights, path + " (" + kTextName + ")");
  }

  // ---- DBoW2 / DBoW3 YAML ---------------------------------------------------
  static bool parseDescriptor(const std::string& s, std::array<uint8_t, 32>& d) {
    std::vector<long> v;
    const char* p = s.data();
    const char* e = p + s.size();
    bool dbw3 = false;
    while (p < e) {
      while (p < e && std::isspace(static_cast<unsigned char>(*p))) ++p;
      if (p >= e) break;
      if (v.empty() && !dbw3 && e - p >= 4 && std::strncmp(p, "dbw3", 4) == 0) {
        dbw3 = true;
        p += 4;
        continue;
      }
      long x;
      auto r = std::from_chars(p, e, x);
      if (r.ec != std::errc()) return false;
      v.push_back(x);
      p = r.ptr;
    }
    size_t off = 0;
    if (dbw3 || v.size() == 34) {
      // DBoW3 text: "[dbw3] type cols d0 ... d31" with type CV_8UC1 (0).
      if (v.size() != 34 || v[0] != 0 || v[1] != 32) return false;
      off = 2;
    } else if (v.size() != 32) {
      return false;
    }
    for (size_t j = 0; j < 32; ++j) {
      if (v[off + j] < 0 || v[off + j] > 255) return false;
      d[j] = static_cast<uint8_t>(v[off + j]);
    }
    return true;
  }

  static Vocabulary loadYaml(const std::string& path) {
    const std::string what = path + " (" + kYamlName + ")";
    try {
      cv::FileStorage fs(path, cv::FileStorage::READ);
      if (!fs.isOpened()) throw DataError(what + ": cannot be opened or parsed");
      cv::FileNode voc = fs["vocabulary"];
      if (voc.empty() || !voc.isMap()) throw DataError(what + ": no 'vocabulary' map at the top level");
      auto intKey = [&](const char* key) {
        cv::FileNode n = voc[key];
        if (n.empty() || !n.isInt()) throw DataError(what + ": vocabulary." + key + " missing or not an integer");
        return static_cast<int>(n);
      };
      const int k = intKey("k"), L = intKey("L");
      ScoringType st;
      WeightingType wt;
      try {
        st = scoringFromInt(intKey("scoringType"));
        wt = weightingFromInt(intKey("weightingType"));
      } catch (const DataError& ex) {
        throw DataError(what + ": " + ex.what());
      }
      cv::FileNode nodes = voc["nodes"];
      cv::FileNode wordsn = voc["words"];
      if (nodes.empty() || !nodes.isSeq()) throw DataError(what + ": vocabulary.nodes missing or not a list");
      if (wordsn.empty() || !wordsn.isSeq()) throw DataError(what + ": vocabulary.words missing or not a list");
      const size_t nn = nodes.size();
      std::unordered_map<int64_t, NodeId> index;  // file node id -> 1..nn
      index.reserve(nn * 2);
      index[0] = 0;
      std::vector<int64_t> file_parent(nn);
      std::vector<std::array<uint8_t, 32>> descs(nn);
      std::vector<double> node_weight(nn);
      std::string ds;
      // Iterators: FileNode::operator[](int) walks the sequence from its start.
      cv::FileNodeIterator nit = nodes.begin();
      for (size_t i = 0; i < nn; ++i, ++nit) {
        const cv::FileNode n = *nit;
        auto where = [&] { return what + ": vocabulary.nodes[" + std::to_string(i) + "]"; };
        if (!n.isMap()) throw DataError(where() + " is not a map");
        cv::FileNode id = n["nodeId"], par = n["parentId"], w = n["weight"], d = n["descriptor"];
        if (id.empty() || !id.isInt() || par.empty() || !par.isInt())
          throw DataError(where() + ": nodeId / parentId missing or not integers");
        if (d.empty() || !d.isString()) throw DataError(where() + ": descriptor missing or not a string");
        const int64_t nid = static_cast<int>(id);
        if (nid <= 0) throw DataError(where() + ": nodeId " + std::to_string(nid) + " (must be > 0; 0 is the root)");
        if (!index.emplace(nid, static_cast<NodeId>(i + 1)).second)
          throw DataError(where() + ": nodeId " + std::to_string(nid) + " appears twice");
        file_parent[i] = static_cast<int>(par);
        node_weight[i] = w.empty() ? 0.0 : static_cast<double>(w);
        d >> ds;
        if (!parseDescriptor(ds, descs[i]))
          throw DataError(where() + " (nodeId " + std::to_string(nid) +
                          "): descriptor is not 32 bytes 0..255 (DBoW2) or 'type cols' + 32 bytes (DBoW3)");
      }
      std::vector<NodeId> parents(nn);
      for (size_t i = 0; i < nn; ++i) {
        auto it = index.find(file_parent[i]);
        if (it == index.end())
          throw DataError(what + ": vocabulary.nodes[" + std::to_string(i) + "]: parentId " +
                          std::to_string(file_parent[i]) + " is not a node");
        parents[i] = it->second;
      }
      const size_t nw = wordsn.size();
      std::vector<NodeId> words(nw, Vocabulary::kNoNode);
      std::vector<WordValue> weights(nw, 0.0);
      cv::FileNodeIterator wit = wordsn.begin();
      for (size_t i = 0; i < nw; ++i, ++wit) {
        const cv::FileNode n = *wit;
        auto where = [&] { return what + ": vocabulary.words[" + std::to_string(i) + "]"; };
        if (!n.isMap() || !n["wordId"].isInt() || !n["nodeId"].isInt())
          throw DataError(where() + ": expected {wordId, nodeId} integers");
        const int wid = static_cast<int>(n["wordId"]);
        const int nid = static_cast<int>(n["nodeId"]);
        if (wid < 0 || static_cast<size_t>(wid) >= nw)
          throw DataError(where() + ": wordId " + std::to_string(wid) + " out of range 0.." + std::to_string(nw - 1));
        if (words[wid] != Vocabulary::kNoNode) throw DataError(where() + ": wordId " + std::to_string(wid) + " appears twice");
        auto it = index.find(nid);
        if (it == index.end() || it->second == 0)
          throw DataError(where() + ": nodeId " + std::to_string(nid) + " is not a node");
        words[wid] = it->second;
        weights[wid] = node_weight[it->second - 1];
      }
      return Vocabulary::fromTree(k, L, wt, st, parents, descs, words, weights, what);
    } catch (const cv::Exception& e) {
      throw DataError(what + ": cannot be parsed: " + e.msg);
    }
  }

  static void saveYaml(const Vocabulary& v, const std::string& path) {
    try {
      cv::FileStorage fs(path, cv::FileStorage::WRITE | cv::FileStorage::FORMAT_YAML);
      if (!fs.isOpened()) throw DataError("cannot write vocabulary " + path);
      fs << "vocabulary" << "{";
      fs << "k" << v.k_ << "L" << v.L_ << "scoringType" << static_cast<int>(v.scoring_) << "weightingType"
         << static_cast<int>(v.weighting_);
      fs << "nodes" << "[";
      std::string d;
      for (size_t i = 1; i < v.parent_.size(); ++i) {
        const uint8_t* b = v.descriptor(static_cast<NodeId>(i));
        d.clear();
        for (int j = 0; j < 32; ++j) {
          d += std::to_string(b[j]);
          d += ' ';
        }
        const bool leaf = v.n_children_[i] == 0;
        fs << "{:" << "nodeId" << static_cast<int>(i) << "parentId" << static_cast<int>(v.parent_[i]) << "weight"
           << (leaf ? v.word_weight_[v.node_word_[i]] : 0.0) << "descriptor" << d << "}";
      }
      fs << "]";
      fs << "words" << "[";
      for (size_t w = 0; w < v.word_node_.size(); ++w)
        fs << "{:" << "wordId" << static_cast<int>(w) << "nodeId" << static_cast<int>(v.word_node_[w]) << "}";
      fs << "]";
      fs << "}";
      fs.release();
    } catch (const cv::Exception& e) {
      throw DataError("cannot write vocabulary " + path + ": " + e.msg);
    }
  }
};

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
