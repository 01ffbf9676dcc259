// Place recognition on real images: TUM fr2 desk frame 10 revisits the place
// of frame 1 (data/tum-frames/loop-10). With a vocabulary that never saw
// these frames, and with the two DBoW vocabularies of the shared folder,
// 1.png must be the best match of 10.png among 1..9. Also `dslam vocab`.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include "dslam/place_recognition/bow_database.h"
#include "dslam/place_recognition/vocabulary.h"
#include "test_support.h"
#include "vocab_test_util.h"

using namespace dslam;
namespace fs = std::filesystem;

namespace {

struct Ranking {
  std::vector<BowMatch> matches;  ///< best first, ids 1..9 = image numbers
  double revisit = 0;             ///< score of 1.png
  double best_other = 0;          ///< best score among 2..9.png
  double ratio() const { return revisit / best_other; }
};

/** Scores of 10.png against 1..9.png through a BowDatabase. */
Ranking rankLoop10(const Vocabulary& voc, bool pipeline_gray = true, int n_features = 1000) {
  BowDatabase db(voc);
  for (int i = 1; i <= 9; ++i) {
    const cv::Mat d = test::orbDescriptors(test::shared("data/tum-frames/loop-10/" + std::to_string(i) + ".png"),
                                           n_features, pipeline_gray);
    EXPECT_GT(d.rows, n_features * 9 / 10);
    db.add(i, voc.transform(d));
  }
  const cv::Mat q = test::orbDescriptors(test::shared("data/tum-frames/loop-10/10.png"), n_features, pipeline_gray);
  Ranking r;
  r.matches = db.query(voc.transform(q));
  for (const auto& m : r.matches) {
    if (m.id == 1)
      r.revisit = m.score;
    else
      r.best_other = std::max(r.best_other, m.score);
  }
  std::printf("  %s grey, %d features, 10.png:", pipeline_gray ? "cvtColor" : "imread", n_features);
  for (const auto& m : r.matches) std::printf(" %lld:%.4f", static_cast<long long>(m.id), m.score);
  std::printf("  (1.png / best other = %.3f)\n", r.ratio());
  return r;
}

bool haveLoop10() { return !test::shared("data/tum-frames/loop-10/10.png").empty(); }

}  // namespace

TEST(PlaceRecognitionReal, DefaultVocabularyFindsTheRevisit) {
  if (!haveLoop10()) GTEST_SKIP();
  const std::string p = defaultVocabularyPath();
  ASSERT_TRUE(fs::exists(p)) << "default vocabulary missing: " << p << " (scripts/train_default_vocab.sh)";
  const Vocabulary voc = Vocabulary::load(p);
  EXPECT_EQ(voc.branching(), 10);
  EXPECT_EQ(voc.levels(), 5);
  EXPECT_GT(voc.size(), 90000u);
  // With the front end's grey conversion and with imread's (+-1 grey level
  // on half the pixels), with 1000 and 2000 features: 1.png first with a
  // clear lead (measured ratios 1.22 / 1.35 / 1.23 / 1.25).
  for (bool pipeline_gray : {true, false}) {
    for (int n : {1000, 2000}) {
      const Ranking r = rankLoop10(voc, pipeline_gray, n);
      ASSERT_EQ(r.matches.size(), 9u);
      EXPECT_EQ(r.matches[0].id, 1);
      EXPECT_GT(r.ratio(), 1.12);
      EXPECT_GT(r.matches.back().score, 0.02);  // one room: every pair shares words
    }
  }
}

TEST(PlaceRecognitionReal, VocabularyTrainedOnOtherRealImagesFindsTheRevisit) {
  // Trained here on KITTI, EuRoC and the Darknet photos only (no TUM image).
  if (!haveLoop10()) GTEST_SKIP();
  std::vector<cv::Mat> imgs;
  for (const std::string dir : {"data/kitti-stereo-51/image_l", "data/kitti-stereo-51/image_r",
                                "data/euroc-v101-micro/mav0/cam0/data", "data/euroc-v101-micro/mav0/cam1/data",
                                "data/images"}) {
    const std::string d = test::shared(dir);
    if (d.empty()) GTEST_SKIP();
    std::vector<std::string> files;
    for (const auto& e : fs::directory_iterator(d)) files.push_back(e.path().string());
    std::sort(files.begin(), files.end());
    for (const auto& f : files) imgs.push_back(test::orbDescriptors(f));
  }
  VocabularyTrainParams p;
  p.k = 10;
  p.levels = 5;
  p.threads = 2;
  VocabularyTrainStats st;
  const Vocabulary voc = Vocabulary::train(imgs, p, &st);
  std::printf("  trained on %zu images, %zu descriptors in %.1f s: %s\n", st.images, st.descriptors,
              st.cluster_seconds + st.weight_seconds, voc.summary().c_str());
  EXPECT_EQ(st.images, 185u);
  const Ranking r = rankLoop10(voc);
  ASSERT_EQ(r.matches.size(), 9u);
  EXPECT_EQ(r.matches[0].id, 1);
  EXPECT_GT(r.ratio(), 1.12);  // measured 1.25
}

TEST(PlaceRecognitionReal, Dbow3SlambookVocabulary) {
  // DBoW3 k=10 L=5, trained (by slambook) on these ten frames with OpenCV's ORB.
  if (!haveLoop10()) GTEST_SKIP();
  const Vocabulary voc = Vocabulary::load(test::shared("data/vocab/dbow3_k10l5_slambook.yml.gz"));
  for (bool pipeline_gray : {true, false}) {
    const Ranking r = rankLoop10(voc, pipeline_gray);
    ASSERT_EQ(r.matches.size(), 9u);
    EXPECT_EQ(r.matches[0].id, 1);
    EXPECT_GT(r.ratio(), 1.03);  // measured 1.054 / 1.084
  }
}

TEST(PlaceRecognitionReal, Dbow2KimeraVocabulary) {
  // DBoW2 k=9 L=3: 692 words trained on 4 images (idf = log(4 / n)). Too
  // coarse to single out the revisit (docs/place_recognition.md): measured
  // 1.png third (cvtColor grey: 2 0.5659, 4 0.5633, 1 0.5592) or second
  // (imread grey: 2 0.5973, 1 0.5789). What it still shows: the revisit is
  // in the top third and above the median of the other frames.
  if (!haveLoop10()) GTEST_SKIP();
  const Vocabulary voc = Vocabulary::load(test::shared("data/vocab/dbow2_k9l3_kimera.yml.gz"));
  EXPECT_EQ(voc.size(), 692u);
  for (bool pipeline_gray : {true, false}) {
    const Ranking r = rankLoop10(voc, pipeline_gray);
    ASSERT_EQ(r.matches.size(), 9u);
    size_t pos = 0;
    while (pos < r.matches.size() && r.matches[pos].id != 1) ++pos;
    EXPECT_LT(pos, 3u);
    std::vector<double> others;
    for (const auto& m : r.matches)
      if (m.id != 1) others.push_back(m.score);
    std::sort(others.begin(), others.end());
    EXPECT_GT(r.revisit, (others[3] + others[4]) / 2 + 0.02);
  }
}

TEST(VocabCli, TrainInfoConvertQuery) {
  const std::string imgs = test::shared("data/images");
  const std::string pair = test::shared("data/tum-frames/rgbd-pair");
  if (imgs.empty() || pair.empty()) GTEST_SKIP();
  const std::string dir = test::tempDir("voccli");
  const std::string out = dir + "/v.dvoc";
  auto r = test::runDslam("vocab train --images " + imgs + " --images " + pair +
                          " --k 4 --levels 3 --features 300 --seed 5 --threads 1 --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("2 16-bit/float images skipped"), std::string::npos) << r.out;  // the depth maps
  EXPECT_NE(r.out.find("from 1500 descriptors of 5 images"), std::string::npos) << r.out;
  const Vocabulary v = Vocabulary::load(out);
  EXPECT_EQ(v.branching(), 4);
  EXPECT_EQ(v.levels(), 3);
  // Same seed, same data: the same file.
  const std::string out2 = dir + "/v2.dvoc";
  r = test::runDslam("vocab train --images " + imgs + " --images " + pair +
                     " --k 4 --levels 3 --features 300 --seed 5 --threads 2 --out " + out2);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_EQ(test::readFile(out), test::readFile(out2));

  r = test::runDslam("vocab info " + out);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("format:     binary"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("k:          4"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("words:      " + std::to_string(v.size())), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("load time:"), std::string::npos) << r.out;

  r = test::runDslam("vocab convert " + out + " " + dir + "/v.txt");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_TRUE(Vocabulary::load(dir + "/v.txt") == v);

  r = test::runDslam("vocab query --vocab " + out + " --query " + pair + "/1.png " + pair + "/1.png " + pair + "/2.png");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("1.000000"), std::string::npos) << r.out;  // an image against itself
}

TEST(VocabCli, InfoOnSharedYamlAndErrors) {
  const std::string yml = test::shared("data/vocab/dbow3_k10l5_slambook.yml.gz");
  if (yml.empty()) GTEST_SKIP();
  auto r = test::runDslam("vocab info " + yml);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("format:     yaml"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("L:          5"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("words:      4983"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("weighting:  tf-idf"), std::string::npos) << r.out;

  r = test::runDslam("vocab info " + yml + " --format binary");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("error:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("DSLAMVOC"), std::string::npos) << r.out;

  r = test::runDslam("vocab train --out /tmp/x.dvoc");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("--images"), std::string::npos) << r.out;
  r = test::runDslam("vocab train --images /nonexistent/dir --out /tmp/x.dvoc");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("folder not found: /nonexistent/dir"), std::string::npos) << r.out;
}

TEST(VocabCli, TrainFromDatasetsAndScenarios) {
  const std::string euroc = test::shared("data/euroc-v101-micro");
  if (euroc.empty()) GTEST_SKIP();
  const std::string out = test::tempDir("voccli") + "/d.dvoc.gz";
  const auto r = test::runDslam("vocab train --dataset " + euroc + " --right --max-images 3 --scenario " +
                                test::source("config/scenarios/static_office.yaml") +
                                " --scenario-frames 2 --k 4 --levels 2 --features 200 --threads 2 --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("(dslam::EurocDataset): 3 frames"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("scenario static_office"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("2 rendered frames"), std::string::npos) << r.out;
  // 3 stereo pairs + 2 renders.
  EXPECT_NE(r.out.find("descriptors of 8 images"), std::string::npos) << r.out;
  const Vocabulary v = Vocabulary::load(out);
  EXPECT_EQ(v.size(), 16u);
}
