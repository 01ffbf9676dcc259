// dslam binary vocabulary: 'DSLAMVOC' header, node and word arrays,
// 'DSLAMEND' (optionally gzip-compressed). Little-endian.
#include <bit>
#include <cstring>
#include <memory>

#include "dslam/core/error.h"
#include "vocabulary_io_detail.h"

namespace dslam {

static_assert(std::endian::native == std::endian::little, "the binary vocabulary format is little-endian");

using namespace vocio;
// ---- dslam binary ---------------------------------------------------------
void VocabularyIo::saveBinary(const Vocabulary& v, const std::string& path) {
  File o(path, "wb", endsWith(path, ".gz"));
  const uint32_t hdr[6] = {kVersion, 32u, static_cast<uint32_t>(v.k_), static_cast<uint32_t>(v.L_),
                           static_cast<uint32_t>(v.weighting_), static_cast<uint32_t>(v.scoring_)};
  const uint64_t counts[2] = {v.parent_.size(), v.word_node_.size()};
  auto vec = [&o](const auto& x) { o.write(x.data(), x.size() * sizeof(x[0])); };
  o.write(kMagic, 8);
  o.write(hdr, sizeof hdr);
  o.write(counts, sizeof counts);
  vec(v.parent_);
  vec(v.desc_);
  vec(v.word_node_);
  vec(v.word_weight_);
  o.write(kEndMagic, 8);
  o.close();
}

namespace {

/** Reads `n` bytes from a plain file or from a decompressed buffer. */
struct In {
  File* f = nullptr;
  const std::string* buf = nullptr;
  size_t pos = 0;
  bool read(void* d, size_t n) {
    if (f) return f->read(d, n) == n;
    if (buf->size() - pos < n) return false;
    std::memcpy(d, buf->data() + pos, n);
    pos += n;
    return true;
  }
};

}  // namespace


Vocabulary VocabularyIo::loadBinary(const std::string& path) {
  const std::string what = path + " (" + kBinaryName + ")";
  const bool gz = isGzip(path);
  In in;
  std::unique_ptr<File> f;
  std::string buf;
  uint64_t size = 0;
  if (gz) {
    buf = slurp(path, kBinaryName);
    in.buf = &buf;
    size = buf.size();
  } else {
    f = std::make_unique<File>(path, "rb", false);
    size = f->size();
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
  Vocabulary::checkWordWeights(v.word_weight_, what);
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

}  // namespace dslam
