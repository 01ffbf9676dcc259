// Bag-of-words place recognition: vocabulary load time, transform time and
// loop-detection query time with a 1M-word vocabulary (k=10, L=6).
//
// The 1M-word vocabulary is trained once on 2M random descriptors (descent
// cost depends on k and L, not on what the centroids look like) and cached
// next to this executable (bench_vocab_k10l6.dvoc; delete it to retrain).
// Two keyframe databases of 500 entries:
//  - "sim": a simulated sequence, each keyframe observing 1000 landmarks of a
//    sliding window over a 60000-landmark world with per-observation bit
//    noise (consecutive keyframes share most of their words, as in a map);
//    queried with the next keyframe (no loop: few candidates) and with a
//    re-observation of keyframe 100 (a loop: many candidates);
//  - "real": ORB descriptors (1000) of the real images of the shared folder
//    (KITTI, EuRoC, TUM, photos), each also mirrored and scaled by 0.75 to
//    reach 500 entries; queried with loop-10/10.png.
// Single thread.
//
// Medians: --benchmark_repetitions=9 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <random>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dslam/core/paths.h"
#include "dslam/features/orb_extractor.h"
#include "dslam/place_recognition/bow_database.h"
#include "dslam/place_recognition/vocabulary.h"

using namespace dslam;
namespace fs = std::filesystem;

namespace {

std::string cachePath() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ((ec ? fs::temp_directory_path() : exe.parent_path()) / "bench_vocab_k10l6.dvoc").string();
}

cv::Mat randomDescriptors(int n, std::mt19937_64& rng) {
  cv::Mat m(n, 32, CV_8U);
  for (int r = 0; r < n; ++r) {
    auto* p = m.ptr<uint64_t>(r);
    for (int j = 0; j < 4; ++j) p[j] = rng();
  }
  return m;
}

const Vocabulary& bigVocabulary() {
  static const Vocabulary v = [] {
    const std::string p = cachePath();
    if (fs::exists(p)) {
      try {
        return Vocabulary::load(p);
      } catch (const std::exception& e) {
        std::cerr << "bench_vocab: " << e.what() << ": retraining\n";
      }
    }
    std::cerr << "bench_vocab: training the k=10 L=6 benchmark vocabulary on 2M random descriptors (once; cached in "
              << p << ")...\n";
    std::mt19937_64 rng(1);
    std::vector<cv::Mat> imgs;
    for (int i = 0; i < 2000; ++i) imgs.push_back(randomDescriptors(1000, rng));
    VocabularyTrainParams tp;
    tp.k = 10;
    tp.levels = 6;
    tp.max_iterations = 8;
    tp.threads = 2;
    const auto t0 = std::chrono::steady_clock::now();
    VocabularyTrainStats st;
    Vocabulary voc = Vocabulary::train(imgs, tp, &st);
    std::cerr << "bench_vocab: " << voc.summary() << " trained in "
              << std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() << " s\n";
    voc.save(p);
    return voc;
  }();
  return v;
}

/** ORB descriptors (1000 features) of a real TUM frame. */
const cv::Mat& realDescriptors() {
  static const cv::Mat d = [] {
    const std::string path = sharedDir() + "/data/tum-frames/rgbd-pair/1.png";
    const cv::Mat g = cv::imread(path, cv::IMREAD_GRAYSCALE);
    if (g.empty()) {
      std::cerr << "bench_vocab: missing " << path << "\n";
      std::exit(1);
    }
    OrbExtractor ex;
    std::vector<cv::KeyPoint> kps;
    cv::Mat desc;
    ex.extract(g, kps, desc);
    return desc;
  }();
  return d;
}

/** Simulated keyframe sequence (see the file comment). */
struct Sequence {
  std::vector<BowVector> bows;
  std::vector<FeatureVector> fvs;
  BowVector revisit;  ///< keyframe 100's landmarks observed again
};

const Sequence& sequence() {
  static const Sequence s = [] {
    const Vocabulary& voc = bigVocabulary();
    std::mt19937_64 rng(7);
    const int world = 60000, per_kf = 1000, n_kf = 501, step = 110;
    const cv::Mat landmarks = randomDescriptors(world, rng);
    Sequence seq;
    for (int k = 0; k <= n_kf; ++k) {
      const int base = k < n_kf ? k : 100;
      cv::Mat d(per_kf, 32, CV_8U);
      for (int i = 0; i < per_kf; ++i) {
        const int l = (base * step + i) % world;
        std::memcpy(d.ptr(i), landmarks.ptr(l), 32);
        for (int f = 0; f < 6; ++f) {  // observation noise: a few bit flips
          const int bit = static_cast<int>(rng() % 256);
          d.ptr(i)[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
        }
      }
      BowVector b;
      FeatureVector fv;
      voc.transform(d, b, fv, 4);
      if (k == n_kf) {
        seq.revisit = std::move(b);
        break;
      }
      seq.bows.push_back(std::move(b));
      seq.fvs.push_back(std::move(fv));
    }
    return seq;
  }();
  return s;
}

void BM_LoadBinary_1M(benchmark::State& st) {
  bigVocabulary();
  const std::string p = cachePath();
  size_t words = 0;
  for (auto _ : st) {
    Vocabulary v = Vocabulary::load(p, VocabularyFormat::Binary);
    words = v.size();
    benchmark::DoNotOptimize(v);
  }
  st.counters["words"] = static_cast<double>(words);
  st.counters["MB"] = static_cast<double>(fs::file_size(p)) / 1e6;
}
BENCHMARK(BM_LoadBinary_1M)->Unit(benchmark::kMillisecond)->Iterations(3);

/** BoW vector and direct index of the 1000 real descriptors, `levelsup`
 *  levels above the words. */
void transformLoop(benchmark::State& st, const Vocabulary& voc, int levelsup) {
  const cv::Mat& d = realDescriptors();
  BowVector b;
  FeatureVector fv;
  for (auto _ : st) {
    voc.transform(d, b, fv, levelsup);
    benchmark::DoNotOptimize(b);
  }
  st.counters["descriptors"] = d.rows;
  st.counters["words"] = static_cast<double>(b.size());
  st.counters["vocabulary_words"] = static_cast<double>(voc.size());
}

void BM_Transform1000_1M(benchmark::State& st) { transformLoop(st, bigVocabulary(), 4); }
BENCHMARK(BM_Transform1000_1M)->Unit(benchmark::kMillisecond);

void BM_TransformBowOnly1000_1M(benchmark::State& st) {
  const Vocabulary& voc = bigVocabulary();
  const cv::Mat& d = realDescriptors();
  BowVector b;
  for (auto _ : st) {
    voc.transform(d, b);
    benchmark::DoNotOptimize(b);
  }
}
BENCHMARK(BM_TransformBowOnly1000_1M)->Unit(benchmark::kMillisecond);

/** The shipped default vocabulary (loaded once), or nullptr after marking
 *  the benchmark skipped when it is missing. */
const Vocabulary* defaultVocabulary(benchmark::State& st) {
  const std::string p = defaultVocabularyPath();
  if (!fs::exists(p)) {
    st.SkipWithError(("default vocabulary missing: " + p).c_str());
    return nullptr;
  }
  static const Vocabulary voc = Vocabulary::load(p);
  return &voc;
}

void BM_Transform1000_Default(benchmark::State& st) {
  if (const Vocabulary* voc = defaultVocabulary(st)) transformLoop(st, *voc, 2);
}
BENCHMARK(BM_Transform1000_Default)->Unit(benchmark::kMillisecond);

/** Database of keyframes 0..499; the query is keyframe 500, which follows
 *  499 (ORB-SLAM: its covisible keyframes 485..499 are excluded). */
struct Db {
  BowDatabase db;
  Db() : db(bigVocabulary()) {
    const Sequence& s = sequence();
    for (int k = 0; k < 500; ++k) db.add(k, s.bows[static_cast<size_t>(k)]);
  }
};
Db& database() {
  static Db d;
  return d;
}

void BM_LoopCandidates_500kf_1M(benchmark::State& st) {
  Db& d = database();
  const BowVector& q = sequence().bows[500];
  auto notConnected = [](BowEntryId id) { return id < 485; };
  BowCandidateParams p;
  p.min_score = 0.0;
  size_t n = 0;
  int maxc = 0;
  for (auto _ : st) {
    const BowCandidates c = d.db.candidates(q, p, notConnected);
    n = c.matches.size();
    maxc = c.max_common;
    benchmark::DoNotOptimize(c);
  }
  st.counters["candidates"] = static_cast<double>(n);
  st.counters["max_common"] = maxc;
  st.counters["query_words"] = static_cast<double>(q.size());
}
BENCHMARK(BM_LoopCandidates_500kf_1M)->Unit(benchmark::kMicrosecond);

void BM_LoopCandidatesRevisit_500kf_1M(benchmark::State& st) {
  Db& d = database();
  const BowVector& q = sequence().revisit;
  auto notConnected = [](BowEntryId id) { return id < 485; };
  size_t n = 0;
  int maxc = 0;
  for (auto _ : st) {
    const BowCandidates c = d.db.candidates(q, {}, notConnected);
    n = c.matches.size();
    maxc = c.max_common;
    benchmark::DoNotOptimize(c);
  }
  st.counters["candidates"] = static_cast<double>(n);
  st.counters["max_common"] = maxc;
}
BENCHMARK(BM_LoopCandidatesRevisit_500kf_1M)->Unit(benchmark::kMicrosecond);

void BM_RelocCandidates_500kf_1M(benchmark::State& st) {
  Db& d = database();
  const BowVector& q = sequence().bows[500];
  for (auto _ : st) {
    const BowCandidates c = d.db.candidates(q);
    benchmark::DoNotOptimize(c);
  }
}
BENCHMARK(BM_RelocCandidates_500kf_1M)->Unit(benchmark::kMicrosecond);

void BM_QueryAllScores_500kf_1M(benchmark::State& st) {
  Db& d = database();
  const BowVector& q = sequence().bows[500];
  size_t n = 0;
  for (auto _ : st) {
    const auto r = d.db.query(q, 10);
    n = r.size();
    benchmark::DoNotOptimize(r);
  }
  st.counters["results"] = static_cast<double>(n);
}
BENCHMARK(BM_QueryAllScores_500kf_1M)->Unit(benchmark::kMicrosecond);

/** Whole per-keyframe cost: transform 1000 descriptors + candidate query. */
void BM_TransformAndLoopQuery_500kf_1M(benchmark::State& st) {
  Db& d = database();
  const Vocabulary& voc = bigVocabulary();
  const cv::Mat& desc = realDescriptors();
  auto notConnected = [](BowEntryId id) { return id < 485; };
  BowVector b;
  FeatureVector fv;
  for (auto _ : st) {
    voc.transform(desc, b, fv, 4);
    const BowCandidates c = d.db.candidates(b, {}, notConnected);
    benchmark::DoNotOptimize(c);
  }
}
BENCHMARK(BM_TransformAndLoopQuery_500kf_1M)->Unit(benchmark::kMillisecond);

/** ORB descriptors of the real shared images, 3 variants each, 500 in all. */
const std::vector<cv::Mat>& realKeyframes() {
  static const std::vector<cv::Mat> kfs = [] {
    const std::string s = sharedDir() + "/data/";
    std::vector<std::string> files;
    for (const char* dir : {"kitti-stereo-51/image_l", "kitti-stereo-51/image_r", "euroc-v101-micro/mav0/cam0/data",
                            "euroc-v101-micro/mav0/cam1/data", "images"}) {
      std::vector<std::string> f;
      for (const auto& e : fs::directory_iterator(s + dir)) f.push_back(e.path().string());
      std::sort(f.begin(), f.end());
      files.insert(files.end(), f.begin(), f.end());
    }
    for (int i = 1; i <= 9; ++i) files.push_back(s + "tum-frames/loop-10/" + std::to_string(i) + ".png");
    OrbExtractor ex;
    std::vector<cv::Mat> out;
    for (int variant = 0; variant < 3 && out.size() < 500; ++variant) {
      for (const auto& f : files) {
        if (out.size() >= 500) break;
        cv::Mat g = cv::imread(f, cv::IMREAD_GRAYSCALE), v;
        if (g.empty()) continue;
        if (variant == 1)
          cv::flip(g, v, 1);
        else if (variant == 2)
          cv::resize(g, v, cv::Size(), 0.75, 0.75, cv::INTER_AREA);
        else
          v = g;
        std::vector<cv::KeyPoint> kps;
        cv::Mat d;
        ex.extract(v, kps, d);
        out.push_back(d);
      }
    }
    return out;
  }();
  return kfs;
}

void realQuery(benchmark::State& st, const Vocabulary& voc) {
  const auto& kfs = realKeyframes();
  BowDatabase db(voc);
  for (size_t i = 0; i < kfs.size(); ++i) db.add(static_cast<BowEntryId>(i), voc.transform(kfs[i]));
  OrbExtractor ex;
  std::vector<cv::KeyPoint> kps;
  cv::Mat qd;
  ex.extract(cv::imread(sharedDir() + "/data/tum-frames/loop-10/10.png", cv::IMREAD_GRAYSCALE), kps, qd);
  const BowVector q = voc.transform(qd);
  auto notConnected = [](BowEntryId id) { return id < 485; };
  size_t n = 0;
  int maxc = 0;
  for (auto _ : st) {
    const BowCandidates c = db.candidates(q, {}, notConnected);
    n = c.matches.size();
    maxc = c.max_common;
    benchmark::DoNotOptimize(c);
  }
  size_t postings = 0;
  for (const auto& e : q) postings += db.entriesWithWord(e.word).size();
  st.counters["entries"] = static_cast<double>(db.size());
  st.counters["candidates"] = static_cast<double>(n);
  st.counters["max_common"] = maxc;
  st.counters["postings"] = static_cast<double>(postings);
}

void BM_LoopCandidates_500kfReal_1M(benchmark::State& st) { realQuery(st, bigVocabulary()); }
BENCHMARK(BM_LoopCandidates_500kfReal_1M)->Unit(benchmark::kMicrosecond);

void BM_LoopCandidates_500kfReal_Default(benchmark::State& st) {
  if (const Vocabulary* voc = defaultVocabulary(st)) realQuery(st, *voc);
}
BENCHMARK(BM_LoopCandidates_500kfReal_Default)->Unit(benchmark::kMicrosecond);

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
