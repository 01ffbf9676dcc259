// Vocabulary tree: structure, transform (descriptor -> word), properties.
#include "dslam/place_recognition/vocabulary.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <sstream>

#include "dslam/core/descriptor.h"
#include "dslam/core/error.h"
#include "dslam/core/paths.h"

#ifndef DSLAM_DEFAULT_VOCABULARY
#define DSLAM_DEFAULT_VOCABULARY ""
#endif

namespace dslam {

namespace {

/** Hamming distance of two descriptors stored as 4 x 64 bits. */
inline int dist(const uint64_t* a, const uint64_t* b) {
  return descriptorDistance(reinterpret_cast<const uint8_t*>(a), reinterpret_cast<const uint8_t*>(b));
}

void checkDescriptors(const cv::Mat& d) {
  if (d.empty()) return;
  if (d.type() != CV_8UC1 || d.cols != Vocabulary::kDescriptorBytes)
    throw DataError("vocabulary transform: expected ORB descriptors (CV_8UC1, 32 columns), got type " +
                    std::to_string(d.type()) + " with " + std::to_string(d.cols) + " columns");
}

}  // namespace

void VocabularyTrainParams::validate() const {
  if (k < 2 || k > 255) throw ConfigError("vocabulary k = " + std::to_string(k) + ": expected 2..255");
  if (levels < 1 || levels > 16) throw ConfigError("vocabulary levels = " + std::to_string(levels) + ": expected 1..16");
  if (max_iterations < 1) throw ConfigError("vocabulary max_iterations must be >= 1");
  if (threads < 0) throw ConfigError("vocabulary threads must be >= 0");
}

int Vocabulary::maxDepth() const {
  int m = 0;
  for (auto d : depth_) m = std::max<int>(m, d);
  return m;
}

std::string Vocabulary::summary() const {
  std::ostringstream o;
  o << "k=" << k_ << " L=" << L_ << " words=" << size() << " nodes=" << nodeCount()
    << " weighting=" << toString(weighting_) << " scoring=" << toString(scoring_);
  return o.str();
}

void Vocabulary::finalize() {
  const size_t n = parent_.size();
  first_child_.assign(n, kNoNode);
  n_children_.assign(n, 0);
  depth_.assign(n, 0);
  node_word_.assign(n, -1);
  for (size_t i = 1; i < n; ++i) {
    const NodeId p = parent_[i];
    if (first_child_[p] == kNoNode) first_child_[p] = static_cast<NodeId>(i);
    ++n_children_[p];
    depth_[i] = static_cast<uint8_t>(depth_[p] + 1);
  }
  for (size_t w = 0; w < word_node_.size(); ++w) node_word_[word_node_[w]] = static_cast<int32_t>(w);
}

void Vocabulary::checkWordWeights(const std::vector<WordValue>& weights, const std::string& what) {
  for (size_t w = 0; w < weights.size(); ++w)
    if (!std::isfinite(weights[w]) || weights[w] < 0)
      throw DataError(what + ": word " + std::to_string(w) + " has weight " + std::to_string(weights[w]) +
                      " (weights are finite and >= 0)");
}

Vocabulary Vocabulary::fromTree(int k, int L, WeightingType wt, ScoringType st, const std::vector<NodeId>& parents,
                                const std::vector<std::array<uint8_t, 32>>& descriptors,
                                const std::vector<NodeId>& words, const std::vector<WordValue>& weights,
                                const std::string& what) {
  if (k < 2 || k > 255) throw DataError(what + ": k = " + std::to_string(k) + " out of range 2..255");
  if (L < 1 || L > 16) throw DataError(what + ": L = " + std::to_string(L) + " out of range 1..16");
  const size_t n = parents.size() + 1;
  if (descriptors.size() != parents.size())
    throw DataError(what + ": " + std::to_string(parents.size()) + " parents but " +
                    std::to_string(descriptors.size()) + " descriptors");
  if (words.size() != weights.size()) throw DataError(what + ": word and weight counts differ");
  checkWordWeights(weights, what);
  if (n > 0xFFFFFFF0u) throw DataError(what + ": too many nodes");
  if (n < 2) throw DataError(what + ": the tree has no nodes");
  // Children lists (sibling order = input order) in CSR form.
  std::vector<uint32_t> cnt(n + 1, 0);
  for (size_t i = 0; i < parents.size(); ++i) {
    const NodeId p = parents[i];
    if (p >= n) throw DataError(what + ": node " + std::to_string(i + 1) + " has parent " + std::to_string(p) + " which does not exist");
    if (p == i + 1) throw DataError(what + ": node " + std::to_string(i + 1) + " is its own parent");
    ++cnt[p + 1];
  }
  for (size_t i = 0; i < n; ++i) cnt[i + 1] += cnt[i];
  std::vector<uint32_t> child(parents.size()), fill(cnt.begin(), cnt.end() - 1);
  for (size_t i = 0; i < parents.size(); ++i) child[fill[parents[i]]++] = static_cast<uint32_t>(i + 1);
  // Breadth-first renumbering.
  std::vector<NodeId> new_id(n, kNoNode), order;
  order.reserve(n);
  order.push_back(0);
  new_id[0] = 0;
  for (size_t h = 0; h < order.size(); ++h) {
    const NodeId o = order[h];
    const uint32_t nc = cnt[o + 1] - cnt[o];
    if (nc > static_cast<uint32_t>(k))
      throw DataError(what + ": node " + std::to_string(o) + " has " + std::to_string(nc) + " children, more than k = " +
                      std::to_string(k));
    for (uint32_t c = cnt[o]; c < cnt[o + 1]; ++c) {
      new_id[child[c]] = static_cast<NodeId>(order.size());
      order.push_back(child[c]);
    }
  }
  if (order.size() != n) {
    for (size_t i = 1; i < n; ++i)
      if (new_id[i] == kNoNode)
        throw DataError(what + ": node " + std::to_string(i) + " is not connected to the root (parent cycle)");
  }
  Vocabulary v;
  v.k_ = k;
  v.L_ = L;
  v.weighting_ = wt;
  v.scoring_ = st;
  v.parent_.resize(n);
  v.desc_.resize(n);
  v.parent_[0] = kNoNode;
  std::memset(&v.desc_[0], 0, sizeof(Desc));
  for (size_t i = 1; i < n; ++i) {
    const NodeId o = order[i];
    v.parent_[i] = new_id[parents[o - 1]];
    std::memcpy(&v.desc_[i], descriptors[o - 1].data(), 32);
  }
  v.word_node_.resize(words.size());
  v.word_weight_ = weights;
  for (size_t w = 0; w < words.size(); ++w) {
    if (words[w] >= n || words[w] == 0)
      throw DataError(what + ": word " + std::to_string(w) + " refers to node " + std::to_string(words[w]) +
                      " which is not a node of the tree");
    v.word_node_[w] = new_id[words[w]];
  }
  v.finalize();
  // Validation: every leaf is exactly one word, no word on an inner node, depth <= L.
  std::vector<uint8_t> seen(n, 0);
  for (size_t w = 0; w < words.size(); ++w) {
    const NodeId nn = v.word_node_[w];
    if (v.n_children_[nn] != 0)
      throw DataError(what + ": word " + std::to_string(w) + " is on inner node " + std::to_string(words[w]));
    if (seen[nn]++) throw DataError(what + ": node " + std::to_string(words[w]) + " has two words");
  }
  for (size_t i = 1; i < n; ++i) {
    if (v.n_children_[i] == 0 && !seen[i])
      throw DataError(what + ": leaf node " + std::to_string(order[i]) + " has no word");
    if (v.depth_[i] > L)
      throw DataError(what + ": node " + std::to_string(order[i]) + " is at depth " + std::to_string(v.depth_[i]) +
                      ", deeper than L = " + std::to_string(L));
  }
  return v;
}

NodeId Vocabulary::parentAtLevelsUp(WordId w, int levelsup) const {
  NodeId n = word_node_[w];
  const int target = levelOfInterest(levelsup);
  if (target <= 0) return kRoot;
  while (depth_[n] > target) n = parent_[n];
  return n;
}

WordId Vocabulary::transform(const uint8_t* d) const {
  WordValue w;
  NodeId n;
  return transform(d, w, n, 0);
}

WordId Vocabulary::transform(const uint8_t* d, WordValue& weight, NodeId& node_at_level, int levelsup) const {
  uint64_t q[4];
  std::memcpy(q, d, 32);
  const int target = levelOfInterest(levelsup);
  NodeId n = kRoot;
  node_at_level = kRoot;
  int depth = 0;
  while (n_children_[n] != 0) {
    const NodeId first = first_child_[n];
    const int nc = n_children_[n];
    const Desc* c = &desc_[first];
    int best = 0, best_d = dist(q, c[0].w);
    for (int j = 1; j < nc; ++j) {
      const int dd = dist(q, c[j].w);
      if (dd < best_d) {
        best_d = dd;
        best = j;
      }
    }
    n = first + best;
    if (++depth <= target) node_at_level = n;
  }
  const WordId w = static_cast<WordId>(node_word_[n]);
  weight = word_weight_[w];
  return w;
}

void Vocabulary::transform(const cv::Mat& descriptors, BowVector& bow) const {
  checkDescriptors(descriptors);
  if (descriptors.empty()) {
    bow.clear();
    return;
  }
  transform(descriptors.ptr<uint8_t>(), descriptors.rows, descriptors.step[0], bow, nullptr, 0);
}

void Vocabulary::transform(const cv::Mat& descriptors, BowVector& bow, FeatureVector& features, int levelsup) const {
  checkDescriptors(descriptors);
  if (descriptors.empty()) {
    bow.clear();
    features.clear();
    return;
  }
  transform(descriptors.ptr<uint8_t>(), descriptors.rows, descriptors.step[0], bow, &features, levelsup);
}

void Vocabulary::transform(const uint8_t* data, size_t n, size_t stride, BowVector& bow, FeatureVector* fv,
                           int levelsup, const std::vector<char>* use) const {
  if (empty()) throw DataError("vocabulary transform: the vocabulary is empty (load or train one first)");
  struct Item {
    WordId word;
    NodeId node;
    uint32_t idx;
    WordValue weight;
  };
  std::vector<Item> items;
  items.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    if (use && (i >= use->size() || !(*use)[i])) continue;
    Item it;
    it.idx = static_cast<uint32_t>(i);
    it.word = transform(data + i * stride, it.weight, it.node, levelsup);
    if (it.weight > 0) items.push_back(it);
  }
  // Bag of words: sum (tf, tf-idf) or first occurrence (idf, binary) per word.
  std::sort(items.begin(), items.end(),
            [](const Item& a, const Item& b) { return a.word != b.word ? a.word < b.word : a.idx < b.idx; });
  const bool sum = weighting_ == WeightingType::Tf || weighting_ == WeightingType::TfIdf;
  std::vector<BowEntry> e;
  e.reserve(items.size());
  for (const Item& it : items) {
    if (!e.empty() && e.back().word == it.word) {
      if (sum) e.back().weight += it.weight;
    } else {
      e.push_back({it.word, it.weight});
    }
  }
  const BowNorm norm = normFor(scoring_);
  if (sum && norm == BowNorm::None && !e.empty()) {
    // DBoW2: divided by the number of words when the vector is not normalised.
    const double nd = static_cast<double>(e.size());
    for (auto& x : e) x.weight /= nd;
  }
  bow = BowVector(std::move(e));
  bow.normalize(norm);
  if (fv) {
    std::sort(items.begin(), items.end(),
              [](const Item& a, const Item& b) { return a.node != b.node ? a.node < b.node : a.idx < b.idx; });
    std::vector<FeatureNode> nodes;
    for (const Item& it : items) {
      if (nodes.empty() || nodes.back().node != it.node) nodes.push_back(FeatureNode{it.node, {}});
      nodes.back().features.push_back(it.idx);
    }
    *fv = FeatureVector(std::move(nodes));
  }
}

bool Vocabulary::operator==(const Vocabulary& o) const {
  if (k_ != o.k_ || L_ != o.L_ || weighting_ != o.weighting_ || scoring_ != o.scoring_) return false;
  if (parent_ != o.parent_ || word_node_ != o.word_node_ || word_weight_ != o.word_weight_) return false;
  if (desc_.size() != o.desc_.size()) return false;
  return desc_.empty() || std::memcmp(desc_.data(), o.desc_.data(), desc_.size() * sizeof(Desc)) == 0;
}

std::string defaultVocabularyPath() {
  if (const char* e = std::getenv("DSLAM_VOCABULARY"); e && *e) return e;
  // An installed dslam ships the vocabulary in <prefix>/share/dslam.
  if (const std::string d = installDataDir(); !d.empty()) {
    const std::string p = d + "/" + std::filesystem::path(DSLAM_DEFAULT_VOCABULARY).filename().string();
    if (fileExists(p)) return p;
  }
  return DSLAM_DEFAULT_VOCABULARY;
}

}  // namespace dslam
