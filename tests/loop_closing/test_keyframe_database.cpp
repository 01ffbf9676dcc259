// KeyFrameDatabase candidate selection (ORB-SLAM DetectLoopCandidates /
// DetectRelocalizationCandidates): the shared-word filter, the exclusion of
// connected keyframes and of other maps, and the covisibility grouping that
// returns one keyframe per strong group. Bag-of-words vectors are set by
// hand over a small trained vocabulary, so every score is known.
#include <gtest/gtest.h>

#include <set>

#include "dslam/loop_closing/keyframe_database.h"
#include "synth_map.h"

using namespace dslam;

namespace {

std::shared_ptr<const Vocabulary> smallVocabulary() {
  cv::RNG rng(5);
  std::vector<cv::Mat> images;
  for (int i = 0; i < 20; i++) {
    cv::Mat d(100, 32, CV_8U);
    rng.fill(d, cv::RNG::UNIFORM, 0, 256);
    images.push_back(d);
  }
  VocabularyTrainParams p;
  p.k = 10;
  p.levels = 2;
  return std::make_shared<const Vocabulary>(Vocabulary::train(images, p));
}

/** L1-normalised vector with weight 1 on each word. */
BowVector bowOf(const std::vector<WordId>& words) {
  BowVector v;
  for (WordId w : words) v.addWeight(w, 1.0);
  v.normalize(BowNorm::L1);
  return v;
}

/** Words 0..19 (the query) with the last `differ` replaced by 100 + i. */
BowVector likeQuery(int differ, int offset = 0) {
  std::vector<WordId> w;
  for (int i = 0; i < 20; i++) w.push_back(static_cast<WordId>(i < 20 - differ ? i : 20 + offset + i));
  return bowOf(w);
}

void connect(KeyFrame* a, KeyFrame* b, int weight) {
  a->addConnection(b, weight);
  b->addConnection(a, weight);
}

std::set<KeyFrame*> asSet(const std::vector<KeyFrame*>& v) { return {v.begin(), v.end()}; }

struct Scene {
  test::SynthWorld w{10};
  Map m{0}, other{1};
  KeyFramePtr q, n, g1, g2, g3, s, x, o;
  KeyFrameDatabase db;

  explicit Scene(std::shared_ptr<const Vocabulary> voc) : db(std::move(voc)) {
    auto kf = [&](Map& map) { return w.keyframe(map, test::poseAt({0, 0, 0}), 0); };
    q = kf(m);   // the query keyframe: words 0..19
    n = kf(m);   // connected to q, same words: never a loop candidate
    g1 = kf(m);  // a covisible group: 18, 19 and 18 of the query's words
    g2 = kf(m);
    g3 = kf(m);
    s = kf(m);   // alone, 19 words
    x = kf(m);   // 10 words: below 80 % of the best shared-word count
    o = kf(other);  // another map, same words as q
    q->bow = likeQuery(0);
    n->bow = likeQuery(0);
    g1->bow = likeQuery(2, 0);
    g2->bow = likeQuery(1, 10);
    g3->bow = likeQuery(2, 20);
    s->bow = likeQuery(1, 30);
    x->bow = likeQuery(10, 40);
    o->bow = likeQuery(0);
    connect(q.get(), n.get(), 50);
    connect(g1.get(), g2.get(), 30);
    connect(g2.get(), g3.get(), 30);
    connect(g1.get(), g3.get(), 30);
    for (auto& k : {n, g1, g2, g3, s, x, o}) db.add(k.get());
  }
};

}  // namespace

TEST(KeyFrameDatabase, LoopCandidatesAreTheBestOfEachStrongCovisibleGroup) {
  auto voc = smallVocabulary();
  ASSERT_GE(voc->size(), 80u);  // the words used below exist
  Scene sc(voc);
  EXPECT_EQ(sc.db.size(), 7u);
  sc.db.add(sc.g1.get());  // adding twice changes nothing
  EXPECT_EQ(sc.db.size(), 7u);
  // L1 scores: 19 shared words of 20 -> 0.95, 18 -> 0.9.
  EXPECT_NEAR(voc->score(sc.q->bow, sc.g2->bow), 0.95, 1e-12);
  EXPECT_NEAR(voc->score(sc.q->bow, sc.g1->bow), 0.9, 1e-12);

  // Group {g1, g2, g3} accumulates 0.9 + 0.95 + 0.9 = 2.75 and gives its best
  // member g2, once. s (0.95 alone) is below 75 % of 2.75; x shares too few
  // words; n is connected to q; o is in another map.
  EXPECT_EQ(asSet(sc.db.detectLoopCandidates(sc.q.get(), 0.0, true)), std::set<KeyFrame*>{sc.g2.get()});
  // min_score: a bar above every score leaves nothing.
  EXPECT_TRUE(sc.db.detectLoopCandidates(sc.q.get(), 0.96, true).empty());
  // Other maps only (merge candidates): o, identical to q.
  EXPECT_EQ(asSet(sc.db.detectLoopCandidates(sc.q.get(), 0.0, false)), std::set<KeyFrame*>{sc.o.get()});

  // Without g2 the group's members accumulate 1.8 each and each is its own
  // best (ties keep the member itself): g1 and g3. s (0.95 < 0.75 * 1.8) is
  // still out.
  sc.db.erase(sc.g2.get());
  EXPECT_EQ(asSet(sc.db.detectLoopCandidates(sc.q.get(), 0.0, true)), (std::set<KeyFrame*>{sc.g1.get(), sc.g3.get()}));
  // Bad keyframes are skipped.
  sc.g1->bad = true;
  sc.g3->bad = true;
  EXPECT_EQ(asSet(sc.db.detectLoopCandidates(sc.q.get(), 0.0, true)), std::set<KeyFrame*>{sc.s.get()});
}

TEST(KeyFrameDatabase, RelocalisationCandidatesKeepConnectedKeyFramesAndCanBeRestrictedToAMap) {
  auto voc = smallVocabulary();
  ASSERT_GE(voc->size(), 80u);
  Scene sc(voc);
  // n (1.0, no neighbour in the database) is below 75 % of the g-group's 2.75.
  EXPECT_EQ(asSet(sc.db.detectRelocalizationCandidates(sc.q->bow, &sc.m)), std::set<KeyFrame*>{sc.g2.get()});
  // Without g2: g1 and g3 accumulate 1.8 each, n 1.0 < 0.75 * 1.8.
  sc.db.erase(sc.g2.get());
  EXPECT_EQ(asSet(sc.db.detectRelocalizationCandidates(sc.q->bow, &sc.m)), (std::set<KeyFrame*>{sc.g1.get(), sc.g3.get()}));
  // With q in the database, q and its neighbour n accumulate 2.0 each and
  // both come back: unlike loop detection, relocalisation does not exclude
  // keyframes connected to anything.
  sc.db.add(sc.q.get());
  const std::set<KeyFrame*> four{sc.q.get(), sc.n.get(), sc.g1.get(), sc.g3.get()};
  EXPECT_EQ(asSet(sc.db.detectRelocalizationCandidates(sc.q->bow, &sc.m)), four);
  // Any map: o (1.0 alone) is below 0.75 * 2.0; restricted to its map, it is the one.
  EXPECT_EQ(asSet(sc.db.detectRelocalizationCandidates(sc.q->bow, nullptr)), four);
  EXPECT_EQ(asSet(sc.db.detectRelocalizationCandidates(sc.q->bow, &sc.other)), std::set<KeyFrame*>{sc.o.get()});
  sc.db.clear();
  EXPECT_EQ(sc.db.size(), 0u);
  EXPECT_TRUE(sc.db.detectRelocalizationCandidates(sc.q->bow, nullptr).empty());
}
