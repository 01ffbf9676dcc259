// Vocabulary: training, weights, transform, direct index, file formats and
// their error messages.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "dslam/core/error.h"
#include "dslam/place_recognition/vocabulary.h"
#include "test_support.h"
#include "vocab_test_util.h"

using namespace dslam;
namespace fs = std::filesystem;

namespace {

struct Trained {
  std::vector<std::array<uint8_t, 32>> protos;
  std::vector<cv::Mat> images;
  Vocabulary voc;
};

/** k=5, L=3 vocabulary on 30 images of noisy copies of 100 prototypes. */
const Trained& trained() {
  static const Trained t = [] {
    Trained r;
    r.protos = test::prototypes(100, 11);
    r.images = test::clusteredImages(r.protos, 30, 200, 12, 12);
    VocabularyTrainParams p;
    p.k = 5;
    p.levels = 3;
    p.seed = 3;
    r.voc = Vocabulary::train(r.images, p);
    return r;
  }();
  return t;
}

cv::Mat rows(const std::vector<std::array<uint8_t, 32>>& d) {
  cv::Mat m(static_cast<int>(d.size()), 32, CV_8U);
  for (size_t i = 0; i < d.size(); ++i) std::memcpy(m.ptr<uint8_t>(static_cast<int>(i)), d[i].data(), 32);
  return m;
}

std::array<uint8_t, 32> fill(uint8_t v) {
  std::array<uint8_t, 32> d;
  d.fill(v);
  return d;
}

std::string descText(const std::array<uint8_t, 32>& d) {
  std::string s;
  for (uint8_t b : d) {
    s += ' ';
    s += std::to_string(b);
  }
  return s;
}

/** A hand-written ORBvoc.txt, k=2, L=2, nodes in DBoW2 creation order
 *  (depth first by sibling block, not breadth first). */
std::string tinyText() {
  auto a = fill(0x00), b = fill(0xFF);
  auto a2 = a;
  a2[0] = 0xFF;
  auto b2 = b;
  b2[0] = 0x00;
  std::string s = "2 2 0 0\n";
  s += "0 0" + descText(a) + " 0\n";     // node 1: inner, all zeros
  s += "1 1" + descText(a) + " 0.5\n";   // node 2: leaf -> word 0
  s += "1 1" + descText(a2) + " 1.5\n";  // node 3: leaf -> word 1
  s += "0 0" + descText(b) + " 0\n";     // node 4: inner, all ones
  s += "4 1" + descText(b) + " 2\n";     // node 5: leaf -> word 2
  s += "4 1" + descText(b2) + " 2.5\n";  // node 6: leaf -> word 3
  return s;
}

std::string writeTemp(const std::string& name, const std::string& content) {
  const std::string p = test::tempDir("voc") + "/" + name;
  test::writeFile(p, content);
  return p;
}

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const DataError& e) {
    return e.what();
  } catch (const std::exception& e) {
    return std::string("unexpected exception type: ") + e.what();
  }
  return "no error";
}

/** BowVector with words replaced by their node ids (comparison across
 *  vocabularies that number words differently). */
std::map<NodeId, double> byNode(const Vocabulary& v, const BowVector& b) {
  std::map<NodeId, double> m;
  for (const auto& e : b) m[v.wordNode(e.word)] = e.weight;
  return m;
}

}  // namespace

TEST(Vocabulary, TrainedTreeShape) {
  const Vocabulary& v = trained().voc;
  EXPECT_EQ(v.branching(), 5);
  EXPECT_EQ(v.levels(), 3);
  EXPECT_LE(v.nodeCount(), 1u + 5 + 25 + 125);
  EXPECT_LE(v.size(), 125u);
  EXPECT_GE(v.size(), 90u);  // 100 well separated clusters fill most of the 125 leaves
  EXPECT_EQ(v.maxDepth(), 3);
  EXPECT_EQ(v.childCount(Vocabulary::kRoot), 5);
  size_t leaves = 0;
  for (NodeId n = 0; n < v.nodeCount(); ++n) {
    if (v.isLeaf(n)) {
      ++leaves;
      ASSERT_GE(v.nodeWord(n), 0);
      EXPECT_EQ(v.wordNode(static_cast<WordId>(v.nodeWord(n))), n);
    } else {
      EXPECT_GE(v.childCount(n), 2);
      EXPECT_LE(v.childCount(n), 5);
      for (int c = 0; c < v.childCount(n); ++c) EXPECT_EQ(v.parent(v.firstChild(n) + c), n);
    }
    if (n > 0) {
      EXPECT_EQ(v.depth(n), v.depth(v.parent(n)) + 1);
    }
  }
  EXPECT_EQ(leaves, v.size());
  EXPECT_EQ(v.weighting(), WeightingType::TfIdf);
  EXPECT_EQ(v.scoring(), ScoringType::L1);
}

TEST(Vocabulary, TrainingIsDeterministicAndThreadIndependent) {
  const Trained& t = trained();
  VocabularyTrainParams p;
  p.k = 5;
  p.levels = 3;
  p.seed = 3;
  p.threads = 2;
  EXPECT_TRUE(Vocabulary::train(t.images, p) == t.voc);
  p.seed = 4;
  EXPECT_FALSE(Vocabulary::train(t.images, p) == t.voc);
}

TEST(Vocabulary, NoisyCopiesOfAPrototypeShareAWord) {
  const Trained& t = trained();
  std::mt19937 rng(99);
  std::set<WordId> majority_words;
  int total_in_majority = 0, total = 0;
  for (const auto& proto : t.protos) {
    std::map<WordId, int> c;
    for (int i = 0; i < 20; ++i) ++c[t.voc.transform(test::noisy(proto, 12, rng).data())];
    int best = 0;
    WordId bw = 0;
    for (auto& [w, n] : c)
      if (n > best) best = n, bw = w;
    total_in_majority += best;
    total += 20;
    majority_words.insert(bw);
  }
  // Fresh copies (not the training ones) land in their prototype's word.
  EXPECT_GE(total_in_majority, total * 95 / 100);
  // ...and different prototypes in different words.
  EXPECT_GE(majority_words.size(), 90u);
}

TEST(Vocabulary, IdfWeightsAndWeightingSchemes) {
  const auto A = fill(0x00), B = fill(0xFF);
  // Image 0: A A; image 1: A B; image 2: A.
  std::vector<cv::Mat> imgs = {rows({A, A}), rows({A, B}), rows({A})};
  VocabularyTrainParams p;
  p.k = 2;
  p.levels = 1;
  const Vocabulary v = Vocabulary::train(imgs, p);
  ASSERT_EQ(v.size(), 2u);
  const WordId wa = v.transform(A.data()), wb = v.transform(B.data());
  ASSERT_NE(wa, wb);
  EXPECT_DOUBLE_EQ(v.wordWeight(wa), 0.0);           // in all 3 images
  EXPECT_DOUBLE_EQ(v.wordWeight(wb), std::log(3.0));  // in 1 of 3
  // tf-idf: A has weight 0 and is left out, in both vectors.
  BowVector bow;
  FeatureVector fv;
  v.transform(rows({A, B, B}), bow, fv, 0);
  ASSERT_EQ(bow.size(), 1u);
  EXPECT_EQ(bow[0].word, wb);
  EXPECT_DOUBLE_EQ(bow[0].weight, 1.0);
  ASSERT_EQ(fv.size(), 1u);
  EXPECT_EQ(fv[0].features, (std::vector<uint32_t>{1, 2}));

  p.weighting = WeightingType::Tf;
  const Vocabulary vt = Vocabulary::train(imgs, p);
  vt.transform(rows({A, B, B, B}), bow);
  EXPECT_DOUBLE_EQ(bow.weight(vt.transform(A.data())), 0.25);
  EXPECT_DOUBLE_EQ(bow.weight(vt.transform(B.data())), 0.75);
  p.weighting = WeightingType::Binary;
  const Vocabulary vb = Vocabulary::train(imgs, p);
  vb.transform(rows({A, B, B, B}), bow);
  EXPECT_DOUBLE_EQ(bow.weight(vb.transform(A.data())), 0.5);
  EXPECT_DOUBLE_EQ(bow.weight(vb.transform(B.data())), 0.5);
  p.weighting = WeightingType::Idf;
  p.scoring = ScoringType::DotProduct;  // no normalisation: raw weights
  const Vocabulary vi = Vocabulary::train(imgs, p);
  vi.transform(rows({B, B, B}), bow);
  ASSERT_EQ(bow.size(), 1u);
  EXPECT_DOUBLE_EQ(bow[0].weight, std::log(3.0));  // counted once
}

TEST(Vocabulary, TfIdfTransformSumsWeightsAndNormalises) {
  const Trained& t = trained();
  const cv::Mat d = t.images[3];
  std::map<WordId, double> expect;
  double sum = 0;
  for (int r = 0; r < d.rows; ++r) {
    const WordId w = t.voc.transform(d.ptr<uint8_t>(r));
    const double x = t.voc.wordWeight(w);
    if (x > 0) expect[w] += x, sum += x;
  }
  const BowVector bow = t.voc.transform(d);
  ASSERT_EQ(bow.size(), expect.size());
  double total = 0;
  for (const auto& e : bow) {
    EXPECT_NEAR(e.weight, expect[e.word] / sum, 1e-12);
    total += e.weight;
  }
  EXPECT_NEAR(total, 1.0, 1e-12);
  EXPECT_NEAR(t.voc.score(bow, bow), 1.0, 1e-12);
}

TEST(Vocabulary, FeatureVectorGroupsFeaturesUnderTheirAncestor) {
  const Trained& t = trained();
  const cv::Mat d = t.images[5];
  for (int levelsup : {0, 1, 2, 3, 5}) {
    BowVector bow;
    FeatureVector fv;
    t.voc.transform(d, bow, fv, levelsup);
    EXPECT_EQ(bow, t.voc.transform(d));
    std::vector<int> seen(static_cast<size_t>(d.rows), 0);
    NodeId prev = 0;
    bool first = true;
    for (const auto& fn : fv) {
      if (!first) {
        EXPECT_GT(fn.node, prev);
      }
      first = false;
      prev = fn.node;
      EXPECT_LE(t.voc.depth(fn.node), std::max(0, 3 - levelsup));
      for (size_t i = 0; i < fn.features.size(); ++i) {
        const uint32_t f = fn.features[i];
        if (i) {
          EXPECT_GT(f, fn.features[i - 1]);
        }
        ++seen[f];
        const WordId w = t.voc.transform(d.ptr<uint8_t>(static_cast<int>(f)));
        EXPECT_EQ(t.voc.parentAtLevelsUp(w, levelsup), fn.node);
      }
    }
    for (int r = 0; r < d.rows; ++r) {
      const WordId w = t.voc.transform(d.ptr<uint8_t>(r));
      EXPECT_EQ(seen[static_cast<size_t>(r)], t.voc.wordWeight(w) > 0 ? 1 : 0);
    }
    if (levelsup >= 3) {
      ASSERT_EQ(fv.size(), 1u);
      EXPECT_EQ(fv[0].node, Vocabulary::kRoot);
    }
  }
}

TEST(Vocabulary, TransformRejectsWrongDescriptors) {
  const Vocabulary& v = trained().voc;
  EXPECT_THROW(v.transform(cv::Mat(10, 64, CV_8U, cv::Scalar(0))), DataError);
  EXPECT_THROW(v.transform(cv::Mat(10, 32, CV_32F, cv::Scalar(0))), DataError);
  EXPECT_TRUE(v.transform(cv::Mat()).empty());
  EXPECT_THROW(Vocabulary().transform(cv::Mat(1, 32, CV_8U, cv::Scalar(0))), DataError);
  VocabularyTrainParams p;
  p.k = 1;
  EXPECT_THROW(Vocabulary::train(trained().images, p), ConfigError);
  EXPECT_THROW(Vocabulary::train({cv::Mat()}, VocabularyTrainParams()), DataError);
}

TEST(VocabularyFiles, BinaryRoundTrip) {
  const Trained& t = trained();
  const std::string p = test::tempDir("voc") + "/v.dvoc";
  t.voc.save(p);
  EXPECT_EQ(detectVocabularyFormat(p), VocabularyFormat::Binary);
  VocabularyFormat f;
  const Vocabulary v = Vocabulary::load(p, VocabularyFormat::Auto, &f);
  EXPECT_EQ(f, VocabularyFormat::Binary);
  EXPECT_TRUE(v == t.voc);
  for (const auto& img : t.images) {
    BowVector b1, b2;
    FeatureVector f1, f2;
    t.voc.transform(img, b1, f1, 1);
    v.transform(img, b2, f2, 1);
    EXPECT_EQ(b1, b2);
    EXPECT_EQ(f1, f2);
  }
  // 48-byte header + 36 bytes per node + 12 per word + 8-byte end marker.
  EXPECT_EQ(fs::file_size(p), 48 + 36 * t.voc.nodeCount() + 12 * t.voc.size() + 8);
  // gzip-compressed variant.
  const std::string pz = p + ".gz";
  t.voc.save(pz);
  EXPECT_LT(fs::file_size(pz), fs::file_size(p));
  EXPECT_EQ(detectVocabularyFormat(pz), VocabularyFormat::Binary);
  EXPECT_TRUE(Vocabulary::load(pz) == t.voc);
}

TEST(VocabularyFiles, TextAndYamlRoundTrip) {
  const Trained& t = trained();
  const std::string dir = test::tempDir("voc");
  for (const std::string name : {"v.txt", "v.txt.gz", "v.yml", "v.yml.gz"}) {
    const std::string p = dir + "/" + name;
    t.voc.saveAs(p);
    VocabularyFormat f;
    const Vocabulary v = Vocabulary::load(p, VocabularyFormat::Auto, &f);
    EXPECT_EQ(f, name.find("txt") != std::string::npos ? VocabularyFormat::Text : VocabularyFormat::Yaml) << name;
    EXPECT_TRUE(v == t.voc) << name;
    for (const auto& img : t.images) EXPECT_EQ(v.transform(img), t.voc.transform(img)) << name;
  }
}

TEST(VocabularyFiles, HandWrittenOrbVocText) {
  const std::string p = writeTemp("tiny_ORBvoc.txt", tinyText());
  EXPECT_EQ(detectVocabularyFormat(p), VocabularyFormat::Text);
  const Vocabulary v = Vocabulary::load(p);
  EXPECT_EQ(v.branching(), 2);
  EXPECT_EQ(v.levels(), 2);
  EXPECT_EQ(v.nodeCount(), 7u);
  ASSERT_EQ(v.size(), 4u);
  // Word ids follow the leaves in file order (as DBoW2 / ORB-SLAM assign them).
  EXPECT_DOUBLE_EQ(v.wordWeight(0), 0.5);
  EXPECT_DOUBLE_EQ(v.wordWeight(1), 1.5);
  EXPECT_DOUBLE_EQ(v.wordWeight(2), 2.0);
  EXPECT_DOUBLE_EQ(v.wordWeight(3), 2.5);
  auto q0 = fill(0x00), q1 = fill(0x00), q2 = fill(0xFF), q3 = fill(0xFF);
  q1[0] = 0xFF;
  q3[0] = 0x00;
  q3[1] = 0x00;  // 16 bits from node 5, 8 from node 6
  EXPECT_EQ(v.transform(q0.data()), 0u);
  EXPECT_EQ(v.transform(q1.data()), 1u);
  EXPECT_EQ(v.transform(q2.data()), 2u);
  EXPECT_EQ(v.transform(q3.data()), 3u);
  // Breadth-first node ids: root 0, inner nodes 1-2, leaves 3-6.
  EXPECT_EQ(v.parentAtLevelsUp(3, 1), 2u);
  EXPECT_EQ(v.parentAtLevelsUp(0, 1), 1u);
  BowVector bow;
  FeatureVector fv;
  v.transform(rows({q0, q1, q2, q3}), bow, fv, 1);
  ASSERT_EQ(bow.size(), 4u);
  EXPECT_DOUBLE_EQ(bow.weight(3), 2.5 / 6.5);
  ASSERT_EQ(fv.size(), 2u);
  EXPECT_EQ(fv[0].node, 1u);
  EXPECT_EQ(fv[0].features, (std::vector<uint32_t>{0, 1}));
  EXPECT_EQ(fv[1].features, (std::vector<uint32_t>{2, 3}));
  // Export -> load gives the same vocabulary.
  const std::string p2 = test::tempDir("voc") + "/tiny_export.txt";
  v.saveText(p2);
  EXPECT_TRUE(Vocabulary::load(p2) == v);
}

TEST(VocabularyFiles, WrongFormatNamesTheExpectedOne) {
  const Trained& t = trained();
  const std::string dir = test::tempDir("voc");
  const std::string text = writeTemp("t.txt", tinyText());
  const std::string bin = dir + "/b.dvoc";
  t.voc.save(bin);
  std::string e = errorOf([&] { Vocabulary::load(text, VocabularyFormat::Binary); });
  EXPECT_NE(e.find("DSLAMVOC"), std::string::npos) << e;
  EXPECT_NE(e.find("wrong magic"), std::string::npos) << e;
  e = errorOf([&] { Vocabulary::load(bin, VocabularyFormat::Text); });
  EXPECT_NE(e.find("ORBvoc.txt"), std::string::npos) << e;
  EXPECT_NE(e.find(":1:"), std::string::npos) << e;  // line number
  e = errorOf([&] { Vocabulary::load(text, VocabularyFormat::Yaml); });
  EXPECT_NE(e.find("YAML"), std::string::npos) << e;
  const std::string junk = writeTemp("junk.bin", "hello world, this is not a vocabulary\n");
  e = errorOf([&] { Vocabulary::load(junk); });
  EXPECT_NE(e.find("unrecognised vocabulary"), std::string::npos) << e;
  EXPECT_NE(e.find("DSLAMVOC"), std::string::npos) << e;
  EXPECT_NE(e.find("ORBvoc.txt"), std::string::npos) << e;
  EXPECT_NE(e.find("YAML"), std::string::npos) << e;
  e = errorOf([&] { Vocabulary::load(dir + "/missing.dvoc"); });
  EXPECT_NE(e.find("not found"), std::string::npos) << e;
  const std::string noyaml = writeTemp("x.yml", "%YAML:1.0\nsomething: 3\n");
  e = errorOf([&] { Vocabulary::load(noyaml); });
  EXPECT_NE(e.find("no 'vocabulary' map"), std::string::npos) << e;
}

TEST(VocabularyFiles, TruncatedFilesAreReported) {
  const Trained& t = trained();
  const std::string dir = test::tempDir("voc");
  const std::string bin = dir + "/b.dvoc";
  t.voc.save(bin);
  const std::string data = test::readFile(bin);
  for (size_t cut : {size_t(5), size_t(30), size_t(200), data.size() / 2, data.size() - 1}) {
    const std::string p = writeTemp("cut.dvoc", data.substr(0, cut));
    const std::string e = errorOf([&] { Vocabulary::load(p, VocabularyFormat::Binary); });
    EXPECT_NE(e.find("dslam binary vocabulary"), std::string::npos) << cut << ": " << e;
    if (cut >= 8) {
      EXPECT_NE(e.find("truncated"), std::string::npos) << cut << ": " << e;
    }
  }
  // Truncated gzip-compressed binary.
  const std::string gzp = dir + "/b.dvoc.gz";
  t.voc.save(gzp);
  const std::string gzdata = test::readFile(gzp);
  const std::string pgz = writeTemp("cut.dvoc.gz", gzdata.substr(0, gzdata.size() * 2 / 3));
  std::string eg = errorOf([&] { Vocabulary::load(pgz); });
  EXPECT_NE(eg.find("dslam binary vocabulary"), std::string::npos) << eg;
  EXPECT_NE(eg.find("truncated"), std::string::npos) << eg;
  // Corrupt structure: a parent pointing forward.
  std::string bad = data;
  const uint32_t forward = 5;
  std::memcpy(&bad[48 + 4 * 2], &forward, 4);
  const std::string pb = writeTemp("bad.dvoc", bad);
  std::string e = errorOf([&] { Vocabulary::load(pb); });
  EXPECT_NE(e.find("breadth-first"), std::string::npos) << e;

  const std::string text = tinyText();
  const std::string pt = writeTemp("cut.txt", text.substr(0, text.size() - 40));
  e = errorOf([&] { Vocabulary::load(pt); });
  EXPECT_NE(e.find("ORBvoc.txt"), std::string::npos) << e;
  EXPECT_NE(e.find("cut.txt:7"), std::string::npos) << e;
  EXPECT_NE(e.find("truncated line"), std::string::npos) << e;

  const std::string yml = dir + "/v.yml.gz";
  t.voc.saveYaml(yml);
  const std::string gz = test::readFile(yml);
  const std::string py = writeTemp("cut.yml.gz", gz.substr(0, gz.size() / 2));
  e = errorOf([&] { Vocabulary::load(py); });
  EXPECT_NE(e.find("YAML"), std::string::npos) << e;
}

TEST(VocabularyFiles, TextStructureErrors) {
  std::string s = tinyText();
  // Node 2 claims parent 9 (later node).
  std::string bad = s;
  bad.replace(bad.find("\n1 1") + 1, 1, "9");
  std::string e = errorOf([&] { Vocabulary::load(writeTemp("p.txt", bad)); });
  EXPECT_NE(e.find("p.txt:3"), std::string::npos) << e;
  EXPECT_NE(e.find("earlier node"), std::string::npos) << e;
  // A leaf flag on an inner node.
  bad = s;
  bad.replace(bad.find("\n0 0") + 1, 3, "0 1");
  e = errorOf([&] { Vocabulary::load(writeTemp("l.txt", bad)); });
  EXPECT_NE(e.find("marked leaf but has children"), std::string::npos) << e;
  e = errorOf([&] { Vocabulary::load(writeTemp("h.txt", "10 6 0 9\n")); });
  EXPECT_NE(e.find("weighting type 9"), std::string::npos) << e;
  // A word weight that is not a finite number >= 0 (inf scored every query nan).
  for (const char* w : {" inf\n", " nan\n", " -1\n"}) {
    bad = s;
    bad.replace(bad.find(" 2.5\n"), 5, w);
    e = errorOf([&] { Vocabulary::load(writeTemp("w.txt", bad)); });
    EXPECT_NE(e.find("word 3 has weight"), std::string::npos) << w << e;
  }
}

TEST(VocabularyFiles, SharedDbow3Yaml) {
  const std::string p = test::shared("data/vocab/dbow3_k10l5_slambook.yml.gz");
  if (p.empty()) GTEST_SKIP();
  VocabularyFormat f;
  const Vocabulary v = Vocabulary::load(p, VocabularyFormat::Auto, &f);
  EXPECT_EQ(f, VocabularyFormat::Yaml);
  EXPECT_EQ(v.branching(), 10);
  EXPECT_EQ(v.levels(), 5);
  EXPECT_EQ(v.size(), 4983u);
  EXPECT_EQ(v.nodeCount(), 6163u);
  EXPECT_EQ(v.weighting(), WeightingType::TfIdf);
  EXPECT_EQ(v.scoring(), ScoringType::L1);
  // Trained on 10 images: idf values are log(10 / n).
  EXPECT_NEAR(v.wordWeight(4982), std::log(10.0), 1e-12);
  // Binary conversion is exact; text conversion renumbers words but keeps
  // the tree, so bag-of-words vectors agree node by node.
  const std::string dir = test::tempDir("voc");
  v.save(dir + "/s.dvoc");
  const Vocabulary vb = Vocabulary::load(dir + "/s.dvoc");
  EXPECT_TRUE(vb == v);
  v.saveText(dir + "/s.txt");
  const Vocabulary vt = Vocabulary::load(dir + "/s.txt");
  EXPECT_EQ(vt.size(), v.size());
  const cv::Mat d = test::orbDescriptors(test::shared("data/tum-frames/loop-10/1.png"));
  ASSERT_GT(d.rows, 900);
  // Same words and weights up to the rounding of the normalisation (summed in another order).
  const auto n1 = byNode(v, v.transform(d)), n2 = byNode(vt, vt.transform(d));
  ASSERT_EQ(n1.size(), n2.size());
  for (auto i = n1.begin(), j = n2.begin(); i != n1.end(); ++i, ++j) {
    EXPECT_EQ(i->first, j->first);
    EXPECT_NEAR(i->second, j->second, 1e-15);
  }
  EXPECT_EQ(v.transform(d), vb.transform(d));
}

TEST(VocabularyFiles, SharedDbow2Yaml) {
  const std::string p = test::shared("data/vocab/dbow2_k9l3_kimera.yml.gz");
  if (p.empty()) GTEST_SKIP();
  const Vocabulary v = Vocabulary::load(p);
  EXPECT_EQ(v.branching(), 9);
  EXPECT_EQ(v.levels(), 3);
  EXPECT_EQ(v.size(), 692u);
  EXPECT_EQ(v.nodeCount(), 782u);
  // Our ORB descriptors fall near the centroids of this vocabulary (a wrong
  // byte or bit order would put them ~128 bits away).
  const cv::Mat d = test::orbDescriptors(test::shared("data/tum-frames/loop-10/5.png"));
  double mean = 0;
  for (int r = 0; r < d.rows; ++r) {
    const WordId w = v.transform(d.ptr<uint8_t>(r));
    const uint8_t* c = v.descriptor(v.wordNode(w));
    int dd = 0;
    for (int j = 0; j < 32; ++j) dd += __builtin_popcount(static_cast<unsigned>(c[j] ^ d.ptr<uint8_t>(r)[j]));
    mean += dd;
  }
  mean /= d.rows;
  EXPECT_LT(mean, 75.0);
  std::cout << "mean Hamming distance to the word centroid (kimera k9L3): " << mean << "\n";
}
