// Vocabulary training: hierarchical k-majority clustering of binary
// descriptors (k-means++ seeding, majority-bit centroids) and idf weights.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>
#include <mutex>
#include <thread>

#include "dslam/core/descriptor.h"
#include "dslam/core/error.h"
#include "dslam/core/splitmix.h"
#include "dslam/place_recognition/vocabulary.h"

namespace dslam {

namespace {

struct D {
  uint64_t w[4];
};

/** DataError unless the descriptors of image i are ORB rows (CV_8UC1, 32 columns). */
void requireOrbDescriptors(const cv::Mat& m, size_t i, const char* who) {
  if (m.type() != CV_8UC1 || m.cols != Vocabulary::kDescriptorBytes)
    throw DataError(std::string(who) + ": descriptors of image " + std::to_string(i) +
                    " are not ORB descriptors (CV_8UC1, 32 columns)");
}

inline int dist(const D& a, const D& b) {
  return descriptorDistance(reinterpret_cast<const uint8_t*>(a.w), reinterpret_cast<const uint8_t*>(b.w));
}

/** Small deterministic generator (splitmix64 stream): identical output on
 *  every platform, unlike std:: distributions. */
struct Rng {
  uint64_t s;
  uint64_t next() { return splitmix64(s++); }
  /** Uniform in [0, n) (n > 0). */
  uint64_t below(uint64_t n) {
    // Rejection sampling for an unbiased result.
    const uint64_t lim = UINT64_MAX - UINT64_MAX % n;
    uint64_t r;
    do r = next();
    while (r >= lim);
    return r % n;
  }
};

/** Lookup table spreading the 8 bits of a byte over 8 byte lanes. */
struct Spread {
  uint64_t t[256];
  Spread() {
    for (int v = 0; v < 256; ++v) {
      uint64_t x = 0;
      for (int b = 0; b < 8; ++b)
        if (v & (1 << b)) x |= 1ull << (8 * b);
      t[v] = x;
    }
  }
};
const Spread& spread() {
  static const Spread s;
  return s;
}

/** Per-bit counters of a set of descriptors; centroid() = majority bits. */
struct BitCounter {
  uint32_t cnt[256] = {};
  uint64_t lanes[32] = {};
  uint32_t pending = 0, n = 0;
  void add(const D& d) {
    const auto& t = spread().t;
    const uint8_t* b = reinterpret_cast<const uint8_t*>(d.w);
    for (int j = 0; j < 32; ++j) lanes[j] += t[b[j]];
    ++n;
    if (++pending == 255) flush();
  }
  void flush() {
    for (int j = 0; j < 32; ++j) {
      uint64_t x = lanes[j];
      for (int b = 0; b < 8; ++b) cnt[j * 8 + b] += static_cast<uint32_t>((x >> (8 * b)) & 0xFF);
      lanes[j] = 0;
    }
    pending = 0;
  }
  D centroid() {
    flush();
    D c{};
    uint8_t* b = reinterpret_cast<uint8_t*>(c.w);
    for (int i = 0; i < 256; ++i)
      if (2 * cnt[i] > n) b[i / 8] |= static_cast<uint8_t>(1u << (i % 8));
    return c;
  }
};

struct TNode {
  D d{};
  std::vector<std::unique_ptr<TNode>> children;
};

}  // namespace

struct VocabularyTrainer {
  const std::vector<D>& data;
  const VocabularyTrainParams& p;

  /** k-majority on data[idx]; returns the non-empty clusters (centre and
   *  members). Fewer than k when there are fewer distinct descriptors. */
  void cluster(const std::vector<uint32_t>& idx, uint64_t seed, std::vector<D>& centres,
               std::vector<std::vector<uint32_t>>& members) const {
    const size_t n = idx.size();
    const int k = p.k;
    centres.clear();
    members.clear();
    if (n <= static_cast<size_t>(k)) {
      // One cluster per distinct descriptor.
      for (uint32_t i : idx) {
        bool dup = false;
        for (size_t c = 0; c < centres.size() && !dup; ++c) {
          if (dist(centres[c], data[i]) == 0) {
            members[c].push_back(i);
            dup = true;
          }
        }
        if (!dup) {
          centres.push_back(data[i]);
          members.push_back({i});
        }
      }
      return;
    }
    // k-means++ seeding: next centre drawn with probability ~ D(x)^2.
    Rng rng{seed};
    std::vector<uint64_t> d2(n);
    centres.push_back(data[idx[rng.below(n)]]);
    for (size_t i = 0; i < n; ++i) {
      const uint64_t d = static_cast<uint64_t>(dist(data[idx[i]], centres[0]));
      d2[i] = d * d;
    }
    while (centres.size() < static_cast<size_t>(k)) {
      uint64_t total = 0;
      for (uint64_t v : d2) total += v;
      if (total == 0) break;  // all remaining descriptors coincide with a centre
      uint64_t r = rng.below(total);
      size_t pick = 0;
      for (; pick < n; ++pick) {
        if (r < d2[pick]) break;
        r -= d2[pick];
      }
      centres.push_back(data[idx[pick]]);
      const D& c = centres.back();
      for (size_t i = 0; i < n; ++i) {
        const uint64_t d = static_cast<uint64_t>(dist(data[idx[i]], c));
        d2[i] = std::min(d2[i], d * d);
      }
    }
    const int kc = static_cast<int>(centres.size());
    std::vector<int> assign(n, -1), next(n);
    std::vector<BitCounter> counters(kc);
    for (int it = 0; it < p.max_iterations; ++it) {
      for (size_t i = 0; i < n; ++i) {
        const D& x = data[idx[i]];
        int best = 0, bd = dist(x, centres[0]);
        for (int c = 1; c < kc; ++c) {
          const int dd = dist(x, centres[c]);
          if (dd < bd) {
            bd = dd;
            best = c;
          }
        }
        next[i] = best;
      }
      if (next == assign) break;
      assign.swap(next);
      for (auto& bc : counters) bc = BitCounter();
      for (size_t i = 0; i < n; ++i) counters[assign[i]].add(data[idx[i]]);
      for (int c = 0; c < kc; ++c)
        if (counters[c].n > 0) centres[c] = counters[c].centroid();  // an empty cluster keeps its centre
    }
    std::vector<std::vector<uint32_t>> m(kc);
    for (size_t i = 0; i < n; ++i) m[assign[i]].push_back(idx[i]);
    std::vector<D> cs;
    for (int c = 0; c < kc; ++c) {
      if (m[c].empty()) continue;
      cs.push_back(centres[c]);
      members.push_back(std::move(m[c]));
    }
    centres.swap(cs);
  }

  /** Splits `node` (holding `idx`, at `depth`) recursively. */
  void build(TNode& node, std::vector<uint32_t> idx, int depth, uint64_t seed) const {
    if (depth >= p.levels || idx.size() <= 1) return;
    std::vector<D> centres;
    std::vector<std::vector<uint32_t>> members;
    cluster(idx, seed, centres, members);
    idx.clear();
    idx.shrink_to_fit();
    if (centres.size() <= 1) return;  // nothing to split: the node stays a leaf
    node.children.resize(centres.size());
    for (size_t c = 0; c < centres.size(); ++c) {
      node.children[c] = std::make_unique<TNode>();
      node.children[c]->d = centres[c];
    }
    for (size_t c = 0; c < centres.size(); ++c)
      build(*node.children[c], std::move(members[c]), depth + 1, splitmix64(seed ^ (0xA0761D6478BD642Full * (c + 1))));
  }
};

Vocabulary Vocabulary::train(const std::vector<cv::Mat>& images, const VocabularyTrainParams& p,
                             VocabularyTrainStats* stats) {
  p.validate();
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  std::vector<D> data;
  size_t total = 0;
  for (size_t i = 0; i < images.size(); ++i) {
    const cv::Mat& m = images[i];
    if (m.empty()) continue;
    requireOrbDescriptors(m, i, "vocabulary training");
    total += static_cast<size_t>(m.rows);
  }
  if (total == 0) throw DataError("vocabulary training: no descriptors");
  if (total > 0xFFFFFFF0ull) throw DataError("vocabulary training: too many descriptors");
  data.resize(total);
  {
    size_t o = 0;
    for (const cv::Mat& m : images)
      for (int r = 0; r < m.rows; ++r) std::memcpy(&data[o++], m.ptr<uint8_t>(r), 32);
  }
  VocabularyTrainer tr{data, p};
  TNode root;
  const uint64_t root_seed = splitmix64(p.seed);
  // Level 1 on the calling thread, then the level-1 subtrees in parallel.
  std::vector<uint32_t> all(total);
  for (size_t i = 0; i < total; ++i) all[i] = static_cast<uint32_t>(i);
  std::vector<D> centres;
  std::vector<std::vector<uint32_t>> members;
  if (p.progress) p.progress(0, 0, "clustering " + std::to_string(total) + " descriptors (level 1)");
  if (total > 1) tr.cluster(all, root_seed, centres, members);
  all.clear();
  all.shrink_to_fit();
  if (centres.size() > 1) {
    root.children.resize(centres.size());
    for (size_t c = 0; c < centres.size(); ++c) {
      root.children[c] = std::make_unique<TNode>();
      root.children[c]->d = centres[c];
    }
  } else {
    // A single distinct descriptor: one word.
    root.children.push_back(std::make_unique<TNode>());
    root.children[0]->d = data[0];
    members.assign(1, {});
  }
  const size_t nsub = root.children.size();
  unsigned nthreads = p.threads > 0 ? static_cast<unsigned>(p.threads) : std::max(1u, std::thread::hardware_concurrency());
  nthreads = static_cast<unsigned>(std::min<size_t>(nthreads, nsub));
  std::atomic<size_t> next{0}, done{0};
  std::mutex progress_mutex;
  std::exception_ptr error;
  auto worker = [&] {
    try {
      for (size_t c; (c = next.fetch_add(1)) < nsub;) {
        tr.build(*root.children[c], std::move(members[c]), 1,
                 splitmix64(root_seed ^ (0xA0761D6478BD642Full * (c + 1))));
        const size_t d = done.fetch_add(1) + 1;
        if (p.progress) {
          std::lock_guard<std::mutex> lk(progress_mutex);
          p.progress(d, nsub, "subtree " + std::to_string(c + 1) + " done");
        }
      }
    } catch (...) {
      std::lock_guard<std::mutex> lk(progress_mutex);
      if (!error) error = std::current_exception();
      next = nsub;
    }
  };
  if (nthreads <= 1) {
    worker();
  } else {
    std::vector<std::thread> th;
    for (unsigned t = 0; t < nthreads; ++t) th.emplace_back(worker);
    for (auto& t : th) t.join();
  }
  if (error) std::rethrow_exception(error);
  const auto t1 = Clock::now();

  // Breadth-first flattening: children contiguous, words = leaves in node order.
  Vocabulary v;
  v.k_ = p.k;
  v.L_ = p.levels;
  v.weighting_ = p.weighting;
  v.scoring_ = p.scoring;
  std::vector<const TNode*> order{&root};
  v.parent_.push_back(kNoNode);
  v.desc_.push_back(Desc{});
  for (size_t h = 0; h < order.size(); ++h) {
    for (const auto& c : order[h]->children) {
      order.push_back(c.get());
      v.parent_.push_back(static_cast<NodeId>(h));
      Desc d;
      std::memcpy(&d, &c->d, 32);
      v.desc_.push_back(d);
    }
  }
  for (size_t i = 1; i < order.size(); ++i)
    if (order[i]->children.empty()) v.word_node_.push_back(static_cast<NodeId>(i));
  v.word_weight_.assign(v.word_node_.size(), 1.0);
  v.finalize();
  v.setWordWeights(images);
  const auto t2 = Clock::now();
  if (stats) {
    stats->images = images.size();
    stats->descriptors = total;
    stats->nodes = v.nodeCount();
    stats->words = v.size();
    stats->max_depth = v.maxDepth();
    stats->cluster_seconds = std::chrono::duration<double>(t1 - t0).count();
    stats->weight_seconds = std::chrono::duration<double>(t2 - t1).count();
  }
  return v;
}

void Vocabulary::setWordWeights(const std::vector<cv::Mat>& images) {
  if (empty()) throw DataError("setWordWeights: the vocabulary is empty");
  const size_t nw = size();
  if (weighting_ == WeightingType::Tf || weighting_ == WeightingType::Binary) {
    word_weight_.assign(nw, 1.0);
    return;
  }
  std::vector<uint32_t> ni(nw, 0), last(nw, UINT32_MAX);
  uint32_t ndocs = 0;
  for (size_t i = 0; i < images.size(); ++i) {
    const cv::Mat& m = images[i];
    if (m.empty()) continue;
    requireOrbDescriptors(m, i, "setWordWeights");
    for (int r = 0; r < m.rows; ++r) {
      const WordId w = transform(m.ptr<uint8_t>(r));
      if (last[w] != i) {
        last[w] = static_cast<uint32_t>(i);
        ++ni[w];
      }
    }
    ++ndocs;
  }
  if (ndocs == 0) throw DataError("setWordWeights: no descriptors");
  const double N = ndocs;
  word_weight_.resize(nw);
  for (size_t w = 0; w < nw; ++w) word_weight_[w] = std::log(N / std::max<uint32_t>(ni[w], 1));
}

}  // namespace dslam
