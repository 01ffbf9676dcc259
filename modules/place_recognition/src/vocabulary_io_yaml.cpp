// DBoW2 / DBoW3 vocabulary in OpenCV YAML (.yml / .yml.gz with a
// 'vocabulary:' map), read and written through cv::FileStorage.
#include <array>
#include <charconv>
#include <cstring>

#include <opencv2/core/persistence.hpp>

#include "dslam/core/error.h"
#include "vocabulary_io_detail.h"

namespace dslam {

using namespace vocio;
// ---- DBoW2 / DBoW3 YAML ---------------------------------------------------
namespace {

bool parseDescriptor(const std::string& s, std::array<uint8_t, 32>& d) {
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

}  // namespace

Vocabulary VocabularyIo::loadYaml(const std::string& path) {
  const std::string what = path + " (" + kYamlName + ")";
  try {
    // Read (and decompress) here, bounded by kMaxVocabularyBytes, rather than
    // let OpenCV inflate a .gz of any size.
    const std::string text = vocio::slurp(path, kYamlName);
    cv::FileStorage fs(text, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
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
  } catch (const DataError&) {
    throw;
  } catch (const std::exception& e) {  // OpenCV's YAML parser also throws std::length_error on some broken keys
    throw DataError(what + ": cannot be parsed (" + e.what() + ")");
  }
}

void VocabularyIo::saveYaml(const Vocabulary& v, const std::string& path) {
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

}  // namespace dslam
