// DBoW2 / ORB-SLAM text vocabulary (ORBvoc.txt, optionally gzip-compressed):
// 'k L scoring weighting', then 'parent isLeaf d0 ... d31 weight' per node.
#include <array>
#include <charconv>
#include <cstring>

#include "dslam/core/error.h"
#include "vocabulary_io_detail.h"

namespace dslam {

using namespace vocio;
// ---- DBoW2 / ORB-SLAM text ------------------------------------------------
void VocabularyIo::saveText(const Vocabulary& v, const std::string& path) {
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
  File f(path, "wb", endsWith(path, ".gz"));
  f.write(out.data(), out.size());
  f.close();
}

namespace {

/** Lines of an in-memory text with 1-based numbers, trailing blanks/CR cut. */
struct LineReader {
  const char* p;
  const char* end;
  size_t line = 0;
  bool next(const char*& b, const char*& e) {
    if (p >= end) return false;
    b = p;
    const void* nl = std::memchr(p, '\n', static_cast<size_t>(end - p));
    e = nl ? static_cast<const char*>(nl) : end;
    p = nl ? e + 1 : end;
    ++line;
    while (e > b && (e[-1] == '\r' || e[-1] == ' ' || e[-1] == '\t')) --e;
    return true;
  }
};

void skipWs(const char*& q, const char* e) {
  while (q < e && (*q == ' ' || *q == '\t')) ++q;
}

/** One node line 'parent isLeaf d0 ... d31 weight'; "" or what is wrong. */
struct TextNode {
  unsigned long parent = 0;
  int is_leaf = 0;
  std::array<uint8_t, 32> d{};
  double w = 0;
};

std::string parseNodeLine(const char* q, const char* e, NodeId id, TextNode& n) {
  const std::string node = "node " + std::to_string(id) + ": ";
  auto r = std::from_chars(q, e, n.parent);
  if (r.ec != std::errc()) return node + "bad parent id";
  q = r.ptr;
  skipWs(q, e);
  r = std::from_chars(q, e, n.is_leaf);
  if (r.ec != std::errc() || (n.is_leaf != 0 && n.is_leaf != 1)) return node + "bad isLeaf flag (0 or 1)";
  q = r.ptr;
  for (int j = 0; j < 32; ++j) {
    skipWs(q, e);
    int x = -1;
    r = std::from_chars(q, e, x);
    if (r.ec != std::errc() || x < 0 || x > 255)
      return node + "descriptor byte " + std::to_string(j) + " missing or not in 0..255 (truncated line?)";
    n.d[j] = static_cast<uint8_t>(x);
    q = r.ptr;
  }
  skipWs(q, e);
  auto rw = std::from_chars(q, e, n.w);
  if (rw.ec != std::errc()) return node + "missing or bad weight (truncated line?)";
  q = rw.ptr;
  skipWs(q, e);
  if (q != e) return node + "extra values after the weight";
  if (n.parent >= id)
    return node + "parent " + std::to_string(n.parent) + " must be an earlier node (0 = root)";
  return "";
}

/** First line 'k L scoring weighting': the four integers, or what is wrong. */
std::string parseHeaderLine(const char* q, const char* e, long hv[4]) {
  for (int i = 0; i < 4; ++i) {
    skipWs(q, e);
    auto r = std::from_chars(q, e, hv[i]);
    if (r.ec != std::errc()) return "the first line must be 'k L scoring weighting' (four integers)";
    q = r.ptr;
  }
  skipWs(q, e);
  if (q != e) return "the first line must be 'k L scoring weighting' (four integers), found more";
  if (hv[0] < 2 || hv[0] > 255 || hv[1] < 1 || hv[1] > 16)
    return "k = " + std::to_string(hv[0]) + ", L = " + std::to_string(hv[1]) + " out of range (k 2..255, L 1..16)";
  return "";
}

}  // namespace

Vocabulary VocabularyIo::loadText(const std::string& path) {
  const std::string data = slurp(path, kTextName);
  LineReader in{data.data(), data.data() + data.size()};
  auto fail = [&](const std::string& msg) -> DataError {
    return DataError(path + ":" + std::to_string(in.line) + ": " + msg + " (expected a " + kTextName + ")");
  };
  const char *b, *e;
  if (!in.next(b, e)) {
    in.line = 1;
    throw fail("empty file");
  }
  long hv[4];
  if (std::string err = parseHeaderLine(b, e, hv); !err.empty()) throw fail(err);
  ScoringType st;
  WeightingType wt;
  try {
    st = scoringFromInt(static_cast<int>(hv[2]));
    wt = weightingFromInt(static_cast<int>(hv[3]));
  } catch (const DataError& ex) {
    throw fail(ex.what());
  }
  std::vector<NodeId> parents, words;
  std::vector<std::array<uint8_t, 32>> descs;
  std::vector<uint8_t> leaf_flag;
  std::vector<WordValue> weights;
  parents.reserve(data.size() / 90 + 1);  // ~100 bytes per line
  descs.reserve(data.size() / 90 + 1);
  while (in.next(b, e)) {
    const char* q = b;
    skipWs(q, e);
    if (q == e) {  // blank lines are only allowed at the end
      while (in.next(b, e)) {
        const char* qq = b;
        skipWs(qq, e);
        if (qq != e) throw fail("blank line inside the node list");
      }
      break;
    }
    const NodeId id = static_cast<NodeId>(parents.size() + 1);
    TextNode n;
    if (std::string err = parseNodeLine(q, e, id, n); !err.empty()) throw fail(err);
    parents.push_back(static_cast<NodeId>(n.parent));
    descs.push_back(n.d);
    leaf_flag.push_back(static_cast<uint8_t>(n.is_leaf));
    if (n.is_leaf) {
      words.push_back(id);
      weights.push_back(n.w);
    }
  }
  if (parents.empty()) {
    in.line = 1;
    throw fail("no nodes after the header line");
  }
  // isLeaf must agree with the tree.
  std::vector<uint8_t> has_child(parents.size() + 1, 0);
  for (NodeId pp : parents) has_child[pp] = 1;
  for (size_t i = 0; i < parents.size(); ++i)
    if (static_cast<bool>(leaf_flag[i]) == static_cast<bool>(has_child[i + 1])) {
      in.line = i + 2;
      throw fail("node " + std::to_string(i + 1) + (leaf_flag[i] ? " is marked leaf but has children"
                                                                   : " is marked inner but has no children"));
    }
  return Vocabulary::fromTree(static_cast<int>(hv[0]), static_cast<int>(hv[1]), wt, st, parents, descs, words, weights, path + " (" + kTextName + ")");
}

}  // namespace dslam
