// `dslam vocab train|info|convert|query`: ORB bag-of-words vocabularies
// (docs/place_recognition.md).
#include <mrpt/containers/yaml.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <set>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "command.h"
#include "dslam/config/pipeline.h"
#include "dslam/core/dataset.h"
#include "dslam/core/error.h"
#include "dslam/core/png.h"
#include "dslam/core/log.h"
#include "dslam/core/paths.h"
#include "dslam/core/registry.h"
#include "dslam/features/frontend.h"
#include "dslam/features/orb_extractor.h"
#include "dslam/place_recognition/bow_database.h"
#include "dslam/place_recognition/vocabulary.h"
#include "dslam/synth/renderer.h"
#include "dslam/synth/scenario.h"

namespace {

using namespace dslam;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

bool isImage(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  static const std::set<std::string> ext = {".png", ".jpg", ".jpeg", ".bmp", ".pgm", ".ppm", ".tif", ".tiff"};
  return ext.count(e) != 0;
}

/** Evenly spaced subset of 0..n-1 of at most `max` indices (all if max <= 0). */
std::vector<size_t> spread(size_t n, int max) {
  std::vector<size_t> idx;
  if (max <= 0 || n <= static_cast<size_t>(max)) {
    for (size_t i = 0; i < n; ++i) idx.push_back(i);
  } else {
    for (int i = 0; i < max; ++i) idx.push_back(static_cast<size_t>(i) * n / static_cast<size_t>(max));
  }
  return idx;
}

std::vector<std::string> listImages(const std::string& dir, bool recursive) {
  if (!dirExists(dir)) throw DataError("--images: folder not found: " + dir);
  std::vector<std::string> out;
  if (recursive) {
    for (const auto& e : fs::recursive_directory_iterator(dir))
      if (e.is_regular_file() && isImage(e.path())) out.push_back(e.path().string());
  } else {
    for (const auto& e : fs::directory_iterator(dir))
      if (e.is_regular_file() && isImage(e.path())) out.push_back(e.path().string());
  }
  std::sort(out.begin(), out.end());
  if (out.empty())
    throw DataError("--images: no image files (png, jpg, bmp, pgm, ppm, tif) in " + dir +
                    (recursive ? "" : " (use --recursive for sub-folders)"));
  return out;
}

/** 8-bit grey image; empty for a 16-bit or float file (a depth map) if
 *  `skip_non8bit`, an error otherwise. */
cv::Mat readGray(const std::string& path, bool skip_non8bit = false) {
  std::string damage;
  cv::Mat img = readImageFile(path, cv::IMREAD_UNCHANGED, &damage);
  if (img.empty()) throw DataError("cannot read image " + path + " (" + unreadableImageReason(damage) + ")");
  if (img.depth() != CV_8U) {
    if (skip_non8bit) return cv::Mat();
    throw DataError("image " + path + " is not 8-bit");
  }
  if (img.channels() == 1) return img;
  cv::Mat g;
  cv::cvtColor(img, g, img.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  return g;
}

struct TrainOpts {
  std::vector<std::string> images, datasets, scenarios;
  std::vector<long long> scenario_seeds;
  std::string type, out, format = "auto", weighting = "tf-idf", scoring = "l1";
  int k = 10, levels = 6, features = 1000, max_images = 0, scenario_frames = 30, iterations = 25, threads = 0;
  long long seed = 0;
  bool recursive = false, right = false;
};

void train(const TrainOpts& o) {
  if (o.images.empty() && o.datasets.empty() && o.scenarios.empty())
    throw ConfigError("vocab train: give at least one --images DIR, --dataset PATH or --scenario FILE");
  // The output must not replace a file of the training input (an image, a dataset file).
  std::error_code ec;
  if (fs::is_regular_file(o.out, ec)) {
    std::vector<std::string> inputs = o.images;
    inputs.insert(inputs.end(), o.datasets.begin(), o.datasets.end());
    for (const auto& in : inputs) {
      if (isInside(o.out, in))
        throw ConfigError("--out " + o.out + " is a file of the training input " + in +
                          ": it would be overwritten; choose another name");
    }
  }
  VocabularyTrainParams tp;
  tp.k = o.k;
  tp.levels = o.levels;
  tp.seed = static_cast<uint64_t>(o.seed);
  tp.max_iterations = o.iterations;
  tp.threads = o.threads;
  tp.weighting = weightingFromString(o.weighting);
  tp.scoring = scoringFromString(o.scoring);
  tp.validate();
  const VocabularyFormat fmt = vocabularyFormatFromString(o.format);
  if (o.features < 1) throw ConfigError("--features must be >= 1");
  OrbParams op;
  op.n_features = o.features;
  OrbExtractor orb(op);

  std::vector<cv::Mat> descs;
  size_t total = 0;
  double extract_s = 0;
  auto addImage = [&](const cv::Mat& gray) {
    std::vector<cv::KeyPoint> kps;
    cv::Mat d;
    const auto t = Clock::now();
    orb.extract(gray, kps, d);
    extract_s += secondsSince(t);
    total += static_cast<size_t>(d.rows);
    descs.push_back(d);
  };
  for (const std::string& dir : o.images) {
    const auto all = listImages(dir, o.recursive);
    const auto pick = spread(all.size(), o.max_images);
    log::Progress prog("ORB " + dir, pick.size(), 25);
    size_t used = 0, skipped = 0;
    for (size_t i = 0; i < pick.size(); ++i) {
      const cv::Mat g = readGray(all[pick[i]], true);
      if (g.empty()) {
        ++skipped;
        DSLAM_LOG(Debug, "skipping " << all[pick[i]] << " (not 8-bit: a depth map?)");
      } else {
        addImage(g);
        ++used;
      }
      prog.update(i + 1);
    }
    prog.finish();
    std::printf("%s: %zu images", dir.c_str(), used);
    if (skipped) std::printf(" (%zu 16-bit/float images skipped)", skipped);
    std::printf("\n");
  }
  for (const std::string& path : o.datasets) {
    if (!fileExists(path) && !dirExists(path)) throw DataError("--dataset: not found: " + path);
    std::string type = o.type.empty() ? config::detectDatasetType(path) : o.type;
    if (type.empty()) throw ConfigError("cannot tell the dataset type of " + path + "; give --type (e.g. dslam::TumDataset)");
    auto ds = create<DatasetSource>(type);
    mrpt::containers::yaml given = mrpt::containers::yaml::Map();
    given["path"] = path;  // a string node: no YAML text is built from the path
    ds->configure(Params::resolve(ds->paramSpecs(), &given, SourceLocation{}), PluginContext{});
    const auto cam = ds->camera();
    const bool rgb_order = cam ? cam->rgb_order : true;
    const auto pick = spread(ds->size(), o.max_images);
    log::Progress prog("ORB " + path, pick.size(), 25);
    for (size_t i = 0; i < pick.size(); ++i) {
      const SensorFrame f = ds->read(pick[i]);
      addImage(toGray(f.image, rgb_order));
      if (o.right && !f.image_right.empty()) addImage(toGray(f.image_right, rgb_order));
      prog.update(i + 1);
    }
    prog.finish();
    std::printf("%s (%s): %zu frames\n", path.c_str(), type.c_str(), pick.size());
  }
  std::vector<long long> seeds = o.scenario_seeds;
  if (seeds.empty()) seeds.push_back(-1);
  for (const std::string& file : o.scenarios) {
    for (long long seed : seeds) {
      synth::ScenarioOverrides ov;
      if (seed >= 0) ov.seed = static_cast<uint64_t>(seed);
      const synth::Scenario sc = synth::loadScenario(file, ov);
      synth::RenderOptions ro;
      ro.threads = o.threads;
      ro.right = false;
      ro.labels = false;
      synth::Renderer r(sc, ro);
      const auto pick = spread(static_cast<size_t>(r.frames()), o.scenario_frames);
      log::Progress prog("render+ORB " + sc.name, pick.size(), 10);
      const auto t = Clock::now();
      for (size_t i = 0; i < pick.size(); ++i) {
        addImage(toGray(r.render(static_cast<int>(pick[i])).rgb, true));
        prog.update(i + 1);
      }
      prog.finish();
      std::printf("%s (scenario %s, seed %llu): %zu rendered frames (%.1f s)\n", file.c_str(), sc.name.c_str(),
                  static_cast<unsigned long long>(sc.seed), pick.size(), secondsSince(t));
    }
  }
  if (descs.empty()) throw DataError("vocab train: no images");
  std::printf("extracted %zu descriptors from %zu images in %.1f s (%d features per image requested)\n", total,
              descs.size(), extract_s, o.features);
  std::fflush(stdout);

  tp.progress = [](size_t done, size_t n, const std::string& what) {
    if (n == 0)
      DSLAM_LOG(Info, what);
    else
      DSLAM_LOG(Info, "clustering: " << done << "/" << n << " level-1 subtrees (" << what << ")");
  };
  VocabularyTrainStats st;
  const Vocabulary voc = Vocabulary::train(descs, tp, &st);
  const auto t = Clock::now();
  const std::string parent = fs::path(o.out).parent_path().string();
  if (!parent.empty() && !dirExists(parent)) fs::create_directories(parent);
  voc.saveAs(o.out, fmt);
  const double save_s = secondsSince(t);
  std::printf("trained %s (max depth %d) from %zu descriptors of %zu images: clustering %.1f s, weights %.1f s\n",
              voc.summary().c_str(), st.max_depth, st.descriptors, st.images, st.cluster_seconds, st.weight_seconds);
  std::printf("wrote %s (%s, %.2f MB) in %.2f s\n", o.out.c_str(),
              toString(fmt == VocabularyFormat::Auto ? vocabularyFormatFromExtension(o.out) : fmt),
              static_cast<double>(fs::file_size(o.out)) / 1e6, save_s);
}

Vocabulary loadTimed(const std::string& path, const std::string& format, double& seconds, VocabularyFormat& detected) {
  const auto t = Clock::now();
  Vocabulary v = Vocabulary::load(path, vocabularyFormatFromString(format), &detected);
  seconds = secondsSince(t);
  return v;
}

void info(const std::string& path, const std::string& format) {
  double s = 0;
  VocabularyFormat f;
  const Vocabulary v = loadTimed(path, format, s, f);
  std::vector<size_t> per_depth(static_cast<size_t>(v.levels()) + 1, 0);
  for (WordId w = 0; w < v.size(); ++w) ++per_depth[static_cast<size_t>(v.depth(v.wordNode(w)))];
  size_t zero = 0;
  for (WordId w = 0; w < v.size(); ++w) zero += v.wordWeight(w) == 0;
  std::printf("file:       %s (%.2f MB)\n", path.c_str(), static_cast<double>(fs::file_size(path)) / 1e6);
  std::printf("format:     %s\n", toString(f));
  std::printf("k:          %d\n", v.branching());
  std::printf("L:          %d\n", v.levels());
  std::printf("words:      %zu (of at most %.0f)\n", v.size(), std::pow(static_cast<double>(v.branching()), v.levels()));
  std::printf("nodes:      %zu\n", v.nodeCount());
  std::printf("weighting:  %s\n", toString(v.weighting()));
  std::printf("scoring:    %s\n", toString(v.scoring()));
  std::printf("leaf depth:");
  for (size_t d = 1; d < per_depth.size(); ++d)
    if (per_depth[d]) std::printf(" %zu:%zu", d, per_depth[d]);
  std::printf("\nzero-weight words: %zu\n", zero);
  std::printf("load time:  %.3f s\n", s);
}

void convert(const std::string& in, const std::string& out, const std::string& in_format, const std::string& out_format) {
  double s = 0;
  VocabularyFormat f;
  const Vocabulary v = loadTimed(in, in_format, s, f);
  const auto t = Clock::now();
  v.saveAs(out, vocabularyFormatFromString(out_format));
  std::printf("%s (%s, %s, loaded in %.2f s) -> %s (%.2f MB, %.2f s)\n", in.c_str(), toString(f), v.summary().c_str(), s,
              out.c_str(), static_cast<double>(fs::file_size(out)) / 1e6, secondsSince(t));
}

struct QueryOpts {
  std::string vocab, query;
  std::vector<std::string> db;
  int features = 1000;
};

void query(const QueryOpts& o) {
  const std::string path = o.vocab.empty() ? defaultVocabularyPath() : o.vocab;
  const Vocabulary v = Vocabulary::load(path);
  OrbParams op;
  op.n_features = o.features;
  OrbExtractor orb(op);
  auto bow = [&](const std::string& img) {
    std::vector<cv::KeyPoint> kps;
    cv::Mat d;
    orb.extract(readGray(img), kps, d);
    return v.transform(d);
  };
  BowDatabase db(v);
  for (size_t i = 0; i < o.db.size(); ++i) db.add(static_cast<BowEntryId>(i), bow(o.db[i]));
  const BowVector q = bow(o.query);
  const auto res = db.query(q);
  std::printf("vocabulary %s (%s); query %s (%zu words)\n", path.c_str(), v.summary().c_str(), o.query.c_str(), q.size());
  std::vector<bool> listed(o.db.size(), false);
  for (const auto& m : res) {
    std::printf("%.6f  %5d common  %s\n", m.score, m.common_words, o.db[static_cast<size_t>(m.id)].c_str());
    listed[static_cast<size_t>(m.id)] = true;
  }
  for (size_t i = 0; i < o.db.size(); ++i)
    if (!listed[i]) std::printf("%.6f  %5d common  %s\n", 0.0, 0, o.db[i].c_str());
}

void setup(CLI::App& sub) {
  sub.require_subcommand(1);
  static TrainOpts t;
  auto* tr = sub.add_subcommand("train", "Train a vocabulary from ORB features of images or datasets");
  // Single-valued options: the last one given wins (scripts append overrides).
  auto one = [](CLI::Option* o) { return o->multi_option_policy(CLI::MultiOptionPolicy::TakeLast); };
  tr->add_option("--images", t.images, "folder of images (png, jpg, ...); repeatable");
  tr->add_option("--dataset", t.datasets, "dataset folder/file (TUM, KITTI, EuRoC, rawlog); repeatable");
  tr->add_option("--scenario", t.scenarios, "synthetic scenario YAML rendered on the fly (dslam synth); repeatable");
  tr->add_option("--scenario-seed", t.scenario_seeds,
                 "render every --scenario once per seed given (default: the scenario's seed); repeatable");
  one(tr->add_option("--type", t.type, "dataset reader for --dataset (default: detected), e.g. dslam::TumDataset"));
  one(tr->add_option("--out,-o", t.out, "output vocabulary (.dvoc binary, .txt ORBvoc text, .yml/.yml.gz DBoW2 YAML)"))
      ->required();
  one(tr->add_option("--k", t.k, "branching factor"))->capture_default_str();
  one(tr->add_option("--levels,-L", t.levels, "depth of the tree"))->capture_default_str();
  one(tr->add_option("--features", t.features, "ORB features per image"))->capture_default_str();
  one(tr->add_option("--max-images", t.max_images, "at most N evenly spaced images per --images / --dataset (0 = all)"))
      ->capture_default_str();
  one(tr->add_option("--scenario-frames", t.scenario_frames,
                     "evenly spaced frames rendered per --scenario and seed (0 = all)"))
      ->capture_default_str();
  one(tr->add_option("--seed", t.seed, "k-means++ seed"))->capture_default_str();
  one(tr->add_option("--iterations", t.iterations, "k-majority iterations per node"))->capture_default_str();
  one(tr->add_option("--threads", t.threads, "training/render threads (0 = all cores; the result does not depend on it)"))
      ->capture_default_str();
  one(tr->add_option("--weighting", t.weighting, "tf-idf | tf | idf | binary"))->capture_default_str();
  one(tr->add_option("--scoring", t.scoring, "l1 | l2 | chi-square | kl | bhattacharyya | dot-product"))
      ->capture_default_str();
  one(tr->add_option("--format", t.format, "output format: auto (from the extension) | binary | text | yaml"))
      ->capture_default_str();
  tr->add_flag("--recursive", t.recursive, "also take images in sub-folders of --images");
  tr->add_flag("--right", t.right, "also use the right images of stereo datasets");
  tr->callback([] { train(t); });

  static std::string info_path, info_format = "auto";
  auto* in = sub.add_subcommand("info", "Load a vocabulary and print k, L, words, weighting, scoring, load time");
  in->add_option("file", info_path, "vocabulary file (binary, ORBvoc.txt, DBoW2/DBoW3 .yml[.gz])")->required();
  in->add_option("--format", info_format, "auto | binary | text | yaml")->capture_default_str();
  in->callback([] { info(info_path, info_format); });

  static std::string cin, cout_, cin_format = "auto", cout_format = "auto";
  auto* cv = sub.add_subcommand("convert", "Convert between vocabulary formats (e.g. ORBvoc.txt -> binary)");
  cv->add_option("in", cin, "input vocabulary")->required();
  cv->add_option("out", cout_, "output vocabulary")->required();
  cv->add_option("--in-format", cin_format, "auto | binary | text | yaml")->capture_default_str();
  cv->add_option("--format", cout_format, "auto (from the extension) | binary | text | yaml")->capture_default_str();
  cv->callback([] { convert(cin, cout_, cin_format, cout_format); });

  static QueryOpts q;
  auto* qu = sub.add_subcommand("query", "Score one image against a set of images (bag-of-words similarity)");
  qu->add_option("--vocab", q.vocab, "vocabulary (default: the one shipped with dslam)");
  qu->add_option("--query", q.query, "query image")->required();
  qu->add_option("images", q.db, "database images")->required();
  qu->add_option("--features", q.features, "ORB features per image")->capture_default_str();
  qu->callback([] { query(q); });
}

}  // namespace

DSLAM_COMMAND(vocab, "Bag-of-words vocabularies: train, info, convert, query", setup);
