#pragma once
/** \file bow_vector.h
 *  Bag-of-words vectors, direct-index feature vectors and the similarity
 *  scores of DBoW2 (Galvez-Lopez & Tardos 2012), as used by ORB-SLAM for
 *  place recognition and BoW-guided matching. */
#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

namespace dslam {

using WordId = uint32_t;   ///< leaf of the vocabulary tree
using NodeId = uint32_t;   ///< any node of the vocabulary tree (0 = root)
using WordValue = double;  ///< weight of a word in a BowVector

/** Word weighting (DBoW2 WeightingType, same numbering as its files). */
enum class WeightingType : int {
  TfIdf = 0,   ///< term frequency x inverse document frequency (ORB-SLAM)
  Tf = 1,      ///< term frequency
  Idf = 2,     ///< inverse document frequency, each word counted once
  Binary = 3,  ///< 1 if the word is present
};

/** Similarity score (DBoW2 ScoringType, same numbering as its files). */
enum class ScoringType : int {
  L1 = 0,             ///< 1 - 0.5 |v - w|_1 of L1-normalised vectors (ORB-SLAM)
  L2 = 1,             ///< 1 - sqrt(1 - v.w) of L2-normalised vectors
  ChiSquare = 2,      ///< 2 sum v_i w_i / (v_i + w_i), L1-normalised
  KL = 3,             ///< Kullback-Leibler divergence sum v_i log(v_i / w_i), L1-normalised
  Bhattacharyya = 4,  ///< sum sqrt(v_i w_i), L1-normalised
  DotProduct = 5,     ///< sum v_i w_i, not normalised
};

const char* toString(WeightingType w);  ///< "tf-idf", "tf", "idf", "binary"
const char* toString(ScoringType s);    ///< "l1", "l2", "chi-square", "kl", "bhattacharyya", "dot-product"
/** Parses the names of toString() (case-insensitive, '_' = '-', "tfidf" too).
 *  Throws ConfigError listing the accepted names. */
WeightingType weightingFromString(const std::string& s);
ScoringType scoringFromString(const std::string& s);
/** From the integer stored in DBoW2 files; throws DataError if out of range. */
WeightingType weightingFromInt(int v);
ScoringType scoringFromInt(int v);

/** Norm a scoring expects its vectors to have. */
enum class BowNorm { None, L1, L2 };
BowNorm normFor(ScoringType s);

struct BowEntry {
  WordId word = 0;
  WordValue weight = 0;
  bool operator==(const BowEntry& o) const { return word == o.word && weight == o.weight; }
};

/** Sparse bag-of-words vector: (word, weight) entries sorted by word, each
 *  word once (DBoW2 BowVector, a std::map there). */
class BowVector {
 public:
  using const_iterator = std::vector<BowEntry>::const_iterator;

  BowVector() = default;
  /** Takes entries sorted by word with unique words (not checked). */
  explicit BowVector(std::vector<BowEntry> sorted_entries) : e_(std::move(sorted_entries)) {}

  size_t size() const { return e_.size(); }
  bool empty() const { return e_.empty(); }
  void clear() { e_.clear(); }
  const_iterator begin() const { return e_.begin(); }
  const_iterator end() const { return e_.end(); }
  const BowEntry& operator[](size_t i) const { return e_[i]; }
  const std::vector<BowEntry>& entries() const { return e_; }

  /** Entry of `w` or nullptr (binary search). */
  const BowEntry* find(WordId w) const {
    auto it = std::lower_bound(e_.begin(), e_.end(), w, [](const BowEntry& a, WordId b) { return a.word < b; });
    return it != e_.end() && it->word == w ? &*it : nullptr;
  }
  /** Weight of `w` (0 if absent). */
  WordValue weight(WordId w) const {
    const BowEntry* e = find(w);
    return e ? e->weight : 0.0;
  }
  /** Adds `v` to the weight of `w`, inserting it if absent. O(size) for an
   *  insertion in the middle; transform() builds vectors without it. */
  void addWeight(WordId w, WordValue v);
  /** Scales to unit norm (no-op for BowNorm::None or a zero vector). */
  void normalize(BowNorm n);

  bool operator==(const BowVector& o) const { return e_ == o.e_; }
  bool operator!=(const BowVector& o) const { return !(*this == o); }

 private:
  std::vector<BowEntry> e_;
};

/** Features of one frame that fell under a vocabulary node. */
struct FeatureNode {
  NodeId node = 0;
  std::vector<uint32_t> features;  ///< indices into the frame's descriptors, ascending
  bool operator==(const FeatureNode& o) const { return node == o.node && features == o.features; }
};

/** Direct index (DBoW2 FeatureVector): for each vocabulary node at a chosen
 *  level, the features below it, sorted by node. ORB-SLAM's SearchByBoW
 *  walks two of these in lockstep and only compares descriptors under the
 *  same node. */
class FeatureVector {
 public:
  using const_iterator = std::vector<FeatureNode>::const_iterator;

  FeatureVector() = default;
  /** Takes nodes sorted by node id, each once (not checked). */
  explicit FeatureVector(std::vector<FeatureNode> sorted_nodes) : n_(std::move(sorted_nodes)) {}

  size_t size() const { return n_.size(); }  ///< number of nodes
  bool empty() const { return n_.empty(); }
  void clear() { n_.clear(); }
  const_iterator begin() const { return n_.begin(); }
  const_iterator end() const { return n_.end(); }
  const FeatureNode& operator[](size_t i) const { return n_[i]; }
  const std::vector<FeatureNode>& nodes() const { return n_; }
  /** Node entry or nullptr (binary search). */
  const FeatureNode* find(NodeId n) const {
    auto it = std::lower_bound(n_.begin(), n_.end(), n, [](const FeatureNode& a, NodeId b) { return a.node < b; });
    return it != n_.end() && it->node == n ? &*it : nullptr;
  }
  /** Total number of features over all nodes. */
  size_t featureCount() const;
  /** ORB-SLAM's SearchByBoW walk: for every node present in both vectors,
 *  in node order, calls fn(features_here, features_there). */
  template <class Fn>
  void forEachSharedNode(const FeatureVector& other, Fn&& fn) const {
    auto it1 = n_.begin(), it2 = other.n_.begin();
    while (it1 != n_.end() && it2 != other.n_.end()) {
      if (it1->node < it2->node) {
        ++it1;
      } else if (it2->node < it1->node) {
        ++it2;
      } else {
        fn(it1->features, it2->features);
        ++it1;
        ++it2;
      }
    }
  }

  bool operator==(const FeatureVector& o) const { return n_ == o.n_; }
  bool operator!=(const FeatureVector& o) const { return !(*this == o); }

 private:
  std::vector<FeatureNode> n_;
};

/** Similarity of two vectors normalised as normFor(s) requires, as DBoW2
 *  computes it: in [0, 1] for L1, L2, chi-square and Bhattacharyya (1 =
 *  identical); KL is a divergence (0 = identical); dot product unbounded. */
double bowScore(ScoringType s, const BowVector& a, const BowVector& b);
/** DBoW2 L1 score 1 - 0.5 |a - b|_1 of L1-normalised vectors, computed over
 *  the common words only: -0.5 sum (|a_i - b_i| - |a_i| - |b_i|). */
double bowScoreL1(const BowVector& a, const BowVector& b);

/** Number of words present in both vectors. */
int commonWords(const BowVector& a, const BowVector& b);

}  // namespace dslam
