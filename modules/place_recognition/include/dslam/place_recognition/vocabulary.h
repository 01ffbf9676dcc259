#pragma once
/** \file vocabulary.h
 *  Hierarchical bag-of-binary-words vocabulary for 256-bit ORB descriptors
 *  (the design of DBoW2, Galvez-Lopez & Tardos 2012, used by ORB-SLAM):
 *  a tree of branching factor k and depth L built by hierarchical
 *  k-majority clustering (k-means++ seeding, majority-bit centroids), whose
 *  leaves are the words, with tf-idf word weights. A descriptor is turned
 *  into a word by descending the tree, choosing the child at the smallest
 *  Hamming distance at every level.
 *
 *  Files: our compact binary format (save(), plain or .gz, see
 *  docs/place_recognition.md), DBoW2 / ORB-SLAM text (ORBvoc.txt,
 *  saveText()) and DBoW2 / DBoW3 OpenCV YAML (.yml, .yml.gz, saveYaml());
 *  load() detects the format.
 *
 *  ORB-SLAM's grouping of the direct index (levelsup = 4 with L = 6, i.e.
 *  nodes at depth 2) is levelsup = levels() - 2 for any L. */
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "dslam/place_recognition/bow_vector.h"

namespace dslam {

/** Vocabulary file formats. */
enum class VocabularyFormat {
  Auto,    ///< load(): detect from the content; save: from the extension
  Binary,  ///< dslam binary ("DSLAMVOC" header), the fast one; plain or gzip-compressed
  Text,    ///< DBoW2 / ORB-SLAM text (ORBvoc.txt), plain or gzip-compressed
  Yaml,    ///< DBoW2 / DBoW3 OpenCV YAML (.yml, .yml.gz)
};
const char* toString(VocabularyFormat f);  ///< "binary", "text", "yaml", "auto"
/** "binary"/"bin"/"dvoc", "text"/"txt", "yaml"/"yml", "auto"; throws ConfigError. */
VocabularyFormat vocabularyFormatFromString(const std::string& s);
/** Format of an existing file from its first bytes (a gzip file is looked
 *  into): Binary, Text, Yaml, or Auto if unrecognised. Throws DataError if
 *  the file cannot be read. */
VocabularyFormat detectVocabularyFormat(const std::string& path);
/** Format implied by a file name: .txt/.txt.gz -> Text, .yml/.yaml(.gz) ->
 *  Yaml, anything else (.dvoc, .dvoc.gz) -> Binary. */
VocabularyFormat vocabularyFormatFromExtension(const std::string& path);

/** Parameters of Vocabulary::train(). */
struct VocabularyTrainParams {
  int k = 10;       ///< branching factor (2..255)
  int levels = 6;   ///< depth L of the tree (1..16); up to k^L words
  WeightingType weighting = WeightingType::TfIdf;
  ScoringType scoring = ScoringType::L1;
  uint64_t seed = 0;        ///< k-means++ seeding; the result depends only on the data and this
  int max_iterations = 25;  ///< k-majority iterations per node (stops earlier when stable)
  int threads = 1;          ///< subtrees trained in parallel (0 = all cores); result independent of it
  /** Called with (done, total) level-1 subtrees and a message; may be empty. */
  std::function<void(size_t done, size_t total, const std::string& what)> progress;

  /** Throws ConfigError naming the bad field. */
  void validate() const;
};

/** What train() did. */
struct VocabularyTrainStats {
  size_t images = 0, descriptors = 0, nodes = 0, words = 0;
  int max_depth = 0;
  double cluster_seconds = 0;  ///< hierarchical clustering
  double weight_seconds = 0;   ///< idf weights (transforming the training images)
};

/** A vocabulary tree. Immutable after construction except by train(),
 *  load() and setWordWeights(); const methods are thread safe. Copyable
 *  (deep copy) and movable. */
class Vocabulary {
 public:
  static constexpr int kDescriptorBytes = 32;  ///< ORB: 256 bits
  static constexpr NodeId kRoot = 0;
  static constexpr NodeId kNoNode = 0xFFFFFFFFu;

  Vocabulary() = default;

  // ---- construction --------------------------------------------------------
  /** Trains a vocabulary from the descriptors of a set of images (one
   *  CV_8U Mat of 32-byte rows per image; the images are the "documents"
   *  of the idf weights). Throws ConfigError for bad parameters and
   *  DataError for descriptors of the wrong type / width or no descriptors. */
  static Vocabulary train(const std::vector<cv::Mat>& image_descriptors, const VocabularyTrainParams& p,
                          VocabularyTrainStats* stats = nullptr);

  /** Loads a vocabulary file (format detected unless given). Throws
   *  DataError naming the file, the format expected and what is wrong
   *  (missing, wrong magic, truncated, bad line/node/key). */
  static Vocabulary load(const std::string& path, VocabularyFormat format = VocabularyFormat::Auto,
                         VocabularyFormat* detected = nullptr);

  /** Writes the dslam binary format, gzip-compressed if the name ends in
   *  ".gz" (load() reads both). Throws DataError if it cannot write. */
  void save(const std::string& path) const;
  /** Writes DBoW2 / ORB-SLAM text (ORBvoc.txt layout); gzip-compressed if
   *  the name ends in ".gz". Word ids of the reloaded vocabulary are its
   *  leaves in file (= our node) order, as DBoW2 assigns them. */
  void saveText(const std::string& path) const;
  /** Writes DBoW2 OpenCV YAML (readable by DBoW2 / DBoW3 and load());
   *  ".yml.gz" compresses. */
  void saveYaml(const std::string& path) const;
  /** save / saveText / saveYaml by `format` (Auto: from the extension). */
  void saveAs(const std::string& path, VocabularyFormat format = VocabularyFormat::Auto) const;

  /** Recomputes the word weights from a set of images (DBoW2
   *  setNodeWeights): idf = log(N / n_i), n_i = images containing word i
   *  (log N for a word in none); 1 for Tf / Binary weighting. */
  void setWordWeights(const std::vector<cv::Mat>& image_descriptors);

  // ---- properties ----------------------------------------------------------
  bool empty() const { return word_node_.empty(); }
  int branching() const { return k_; }  ///< k
  int levels() const { return L_; }     ///< L
  size_t size() const { return word_node_.size(); }  ///< number of words
  size_t nodeCount() const { return parent_.size(); } ///< including the root
  WeightingType weighting() const { return weighting_; }
  ScoringType scoring() const { return scoring_; }
  /** Changes the scoring used by score() and the normalisation of
   *  transform() (DBoW2 allows the same). */
  void setScoring(ScoringType s) { scoring_ = s; }
  /** Deepest leaf (<= levels()). */
  int maxDepth() const;
  /** One-line summary: "k=10 L=6 words=... weighting=tf-idf scoring=l1". */
  std::string summary() const;

  // ---- tree access -----------------------------------------------------------
  NodeId parent(NodeId n) const { return parent_[n]; }          ///< kNoNode for the root
  int depth(NodeId n) const { return depth_[n]; }               ///< root 0
  bool isLeaf(NodeId n) const { return n_children_[n] == 0; }
  /** Children of n are the nodes firstChild(n) .. firstChild(n) + childCount(n) - 1. */
  NodeId firstChild(NodeId n) const { return first_child_[n]; }
  int childCount(NodeId n) const { return n_children_[n]; }
  /** 32-byte centroid of a node (zeros for the root). */
  const uint8_t* descriptor(NodeId n) const { return reinterpret_cast<const uint8_t*>(&desc_[n]); }
  NodeId wordNode(WordId w) const { return word_node_[w]; }
  /** Word of a leaf, or -1 for an inner node. */
  int64_t nodeWord(NodeId n) const { return node_word_[n] < 0 ? -1 : node_word_[n]; }
  WordValue wordWeight(WordId w) const { return word_weight_[w]; }
  /** Ancestor of the leaf of `w` at depth `levels() - levelsup` (the leaf
   *  itself when it is shallower): the node transform() files `w`'s
   *  features under in the FeatureVector. */
  NodeId parentAtLevelsUp(WordId w, int levelsup) const;

  // ---- transform -------------------------------------------------------------
  /** Word of one 32-byte descriptor. */
  WordId transform(const uint8_t* descriptor) const;
  /** Word of one descriptor, with its weight and the node at depth
   *  levels() - levelsup on the way down (the leaf if shallower). */
  WordId transform(const uint8_t* descriptor, WordValue& weight, NodeId& node_at_level, int levelsup) const;

  /** Bag of words of a set of descriptors (CV_8U, one 32-byte row each),
   *  weighted by weighting() and normalised for scoring() (L1 for L1: the
   *  weights sum to 1). Words of weight 0 (in every training image) are
   *  left out, as in DBoW2. Throws DataError for a wrong Mat type/width or
   *  an empty vocabulary. */
  void transform(const cv::Mat& descriptors, BowVector& bow) const;
  BowVector transform(const cv::Mat& descriptors) const {
    BowVector v;
    transform(descriptors, v);
    return v;
  }
  /** Same, plus the direct index: features grouped by the node at depth
   *  levels() - levelsup (ORB-SLAM uses levelsup = 4 with L = 6). A feature
   *  whose word has weight 0 is in neither vector, as in DBoW2. */
  void transform(const cv::Mat& descriptors, BowVector& bow, FeatureVector& features, int levelsup) const;
  /** Raw-pointer variants: `n` descriptors of 32 bytes, `stride` bytes apart;
   *  with `use`, only descriptors i with use[i] != 0 count (feature indices
   *  stay those of the whole set). */
  void transform(const uint8_t* data, size_t n, size_t stride, BowVector& bow, FeatureVector* features,
                 int levelsup, const std::vector<char>* use = nullptr) const;

  /** Similarity of two bag-of-words vectors with scoring(). */
  double score(const BowVector& a, const BowVector& b) const { return bowScore(scoring_, a, b); }

  /** Same tree, words, weights and settings. */
  bool operator==(const Vocabulary& o) const;
  bool operator!=(const Vocabulary& o) const { return !(*this == o); }

  // ---- building blocks (used by the loaders and train()) -------------------
  /** Tree given by parent links in any order where children of a node keep
   *  their relative order. `parents[i]` is the parent of node i + 1 in
   *  node numbering 0 = root (so parents.size() = nodes - 1); `words[j]` is
   *  the node of word j; `weights[j]` its weight. Nodes are renumbered
   *  breadth first (children contiguous). Throws DataError (prefixed with
   *  `what`) for cycles, unreachable nodes, a word on an inner node, a leaf
   *  without a word or a repeated word. */
  static Vocabulary fromTree(int k, int L, WeightingType w, ScoringType s, const std::vector<NodeId>& parents,
                             const std::vector<std::array<uint8_t, 32>>& descriptors,
                             const std::vector<NodeId>& words, const std::vector<WordValue>& weights,
                             const std::string& what);

 private:
  /** DataError unless every word weight is finite and >= 0 (an inf weight
   *  scores every query nan). */
  static void checkWordWeights(const std::vector<WordValue>& weights, const std::string& what);
  struct Desc {
    uint64_t w[4];
  };
  friend struct VocabularyIo;
  friend struct VocabularyTrainer;

  void finalize();  ///< depth_, first_child_, n_children_, node_word_ from parent_ / word_node_
  int levelOfInterest(int levelsup) const { return L_ - levelsup; }

  int k_ = 0, L_ = 0;
  WeightingType weighting_ = WeightingType::TfIdf;
  ScoringType scoring_ = ScoringType::L1;
  // Nodes in breadth-first order: parent_[i] < i, children contiguous.
  std::vector<NodeId> parent_;
  std::vector<Desc> desc_;
  std::vector<NodeId> first_child_;
  std::vector<uint16_t> n_children_;
  std::vector<uint8_t> depth_;
  std::vector<int32_t> node_word_;   ///< -1 for inner nodes
  std::vector<NodeId> word_node_;
  std::vector<WordValue> word_weight_;
};

/** Path of the vocabulary shipped with dslam (k=10, L=5, gzip-compressed
 *  binary, trained by scripts/train_default_vocab.sh): $DSLAM_VOCABULARY if
 *  set, else the copy in the source tree. Does not check that it exists. */
std::string defaultVocabularyPath();

}  // namespace dslam
