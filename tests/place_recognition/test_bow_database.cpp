// BowDatabase: inverted index bookkeeping, shared-word counts, scores equal
// to the direct ones, ORB-SLAM candidate selection, concurrent readers.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <random>
#include <thread>

#include "dslam/core/error.h"
#include "dslam/place_recognition/bow_database.h"
#include "dslam/place_recognition/vocabulary.h"
#include "vocab_test_util.h"

using namespace dslam;


TEST(BowDatabase, AddEraseAndInvertedFile) {
  BowDatabase db(ScoringType::L1, 10);
  const BowVector a({{1, 0.5}, {4, 0.5}});
  const BowVector b({{4, 0.25}, {7, 0.75}});
  const BowVector c({{20, 1.0}});  // beyond the pre-sized word range: grows
  db.add(10, a);
  db.add(-3, b);
  db.add(42, c);
  EXPECT_EQ(db.size(), 3u);
  EXPECT_THROW(db.add(10, b), Error);
  EXPECT_EQ(db.ids(), (std::vector<BowEntryId>{-3, 10, 42}));
  EXPECT_EQ(db.entriesWithWord(4), (std::vector<BowEntryId>{-3, 10}));
  EXPECT_EQ(db.entriesWithWord(20), (std::vector<BowEntryId>{42}));
  EXPECT_TRUE(db.entriesWithWord(999).empty());
  EXPECT_EQ(db.vector(-3), b);
  EXPECT_TRUE(db.erase(10));
  EXPECT_FALSE(db.erase(10));
  EXPECT_FALSE(db.contains(10));
  EXPECT_EQ(db.entriesWithWord(4), (std::vector<BowEntryId>{-3}));
  EXPECT_TRUE(db.entriesWithWord(1).empty());
  EXPECT_TRUE(db.vector(10).empty());
  EXPECT_THROW(db.score(a, 10), Error);
  db.add(11, a);  // reuses the freed slot
  EXPECT_EQ(db.entriesWithWord(1), (std::vector<BowEntryId>{11}));
  EXPECT_EQ(db.size(), 3u);
  db.clear();
  EXPECT_EQ(db.size(), 0u);
  EXPECT_TRUE(db.query(a).empty());
}

TEST(BowDatabase, QueryScoresEqualDirectScores) {
  std::mt19937 rng(7);
  for (ScoringType s : {ScoringType::L1, ScoringType::L2, ScoringType::ChiSquare, ScoringType::KL,
                        ScoringType::Bhattacharyya, ScoringType::DotProduct}) {
    BowDatabase db(s);
    std::vector<BowVector> vs;
    for (int i = 0; i < 60; ++i) {
      vs.push_back(test::randomVector(rng, 80, 600, normFor(s)));
      db.add(i, vs.back());
    }
    // Erase a few to exercise holes in the slot table.
    for (int i : {3, 17, 40}) db.erase(i);
    const BowVector q = test::randomVector(rng, 80, 600, normFor(s));
    const auto res = db.query(q);
    ASSERT_FALSE(res.empty());
    size_t sharing = 0;
    for (int i = 0; i < 60; ++i)
      if (i != 3 && i != 17 && i != 40 && commonWords(q, vs[i]) > 0) ++sharing;
    EXPECT_EQ(res.size(), sharing) << toString(s);
    for (size_t r = 0; r < res.size(); ++r) {
      const auto& m = res[r];
      EXPECT_EQ(m.score, bowScore(s, q, vs[static_cast<size_t>(m.id)])) << toString(s);  // bit-identical
      EXPECT_EQ(m.score, db.score(q, m.id));
      EXPECT_EQ(m.common_words, commonWords(q, vs[static_cast<size_t>(m.id)]));
      if (r) {
        EXPECT_TRUE(res[r - 1].score > m.score || (res[r - 1].score == m.score && res[r - 1].id < m.id));
      }
    }
    const auto top = db.query(q, 5);
    ASSERT_EQ(top.size(), 5u);
    for (size_t r = 0; r < 5; ++r) EXPECT_EQ(top[r].id, res[r].id);
  }
}

TEST(BowDatabase, SharedWordsAndFilter) {
  std::mt19937 rng(3);
  BowDatabase db;
  std::vector<BowVector> vs;
  for (int i = 0; i < 40; ++i) {
    vs.push_back(test::randomVector(rng, 30, 200, BowNorm::L1));
    db.add(100 + i, vs.back());
  }
  const BowVector q = test::randomVector(rng, 30, 200, BowNorm::L1);
  auto keep = [](BowEntryId id) { return id % 2 == 0; };
  const auto sw = db.sharedWords(q, keep);
  std::vector<BowSharedWords> expect;
  for (int i = 0; i < 40; ++i) {
    const int c = commonWords(q, vs[i]);
    if (c > 0 && (100 + i) % 2 == 0) expect.push_back({100 + i, c});
  }
  ASSERT_EQ(sw.size(), expect.size());
  for (size_t i = 0; i < sw.size(); ++i) {
    EXPECT_EQ(sw[i].id, expect[i].id);
    EXPECT_EQ(sw[i].common_words, expect[i].common_words);
  }
  for (const auto& m : db.query(q, 0, keep)) EXPECT_EQ(m.id % 2, 0);
}

TEST(BowDatabase, OrbSlamCandidateSelection) {
  // Query words 0..9. Entry e shares words 0..n_e-1 with it.
  BowDatabase db;
  const int shared[] = {10, 9, 8, 7, 3, 10};
  for (int e = 0; e < 6; ++e) {
    BowVector v;
    for (int w = 0; w < shared[e]; ++w) v.addWeight(static_cast<WordId>(w), 1.0);
    v.addWeight(static_cast<WordId>(100 + e), 1.0);  // one private word
    v.normalize(BowNorm::L1);
    db.add(e, v);
  }
  BowVector q;
  for (int w = 0; w < 10; ++w) q.addWeight(static_cast<WordId>(w), 1.0);
  q.normalize(BowNorm::L1);
  // Without entry 0 and 5 (the "connected keyframes"): max common = 9,
  // min common = int(0.8 * 9) = 7, kept: > 7 shared words -> entries 1 and 2.
  auto notConnected = [](BowEntryId id) { return id != 0 && id != 5; };
  BowCandidates c = db.candidates(q, BowCandidateParams{}, notConnected);
  EXPECT_EQ(c.max_common, 9);
  EXPECT_EQ(c.min_common, 7);
  ASSERT_EQ(c.matches.size(), 2u);
  EXPECT_EQ(c.matches[0].id, 1);
  EXPECT_EQ(c.matches[1].id, 2);
  EXPECT_EQ(c.matches[0].common_words, 9);
  EXPECT_DOUBLE_EQ(c.matches[0].score, bowScoreL1(q, db.vector(1)));
  ASSERT_NE(c.find(2), nullptr);
  EXPECT_EQ(c.find(3), nullptr);
  // min_score drops entry 2 (score 8/9 - ... lower than entry 1's).
  BowCandidateParams p;
  p.min_score = (c.matches[0].score + c.matches[1].score) / 2;
  c = db.candidates(q, p, notConnected);
  ASSERT_EQ(c.matches.size(), 1u);
  EXPECT_EQ(c.matches[0].id, 1);
  // No filter (relocalisation): max 10, min 8 -> entries 0, 1 and 5; ties by id.
  c = db.candidates(q);
  ASSERT_EQ(c.matches.size(), 3u);
  EXPECT_EQ(c.matches[0].id, 0);
  EXPECT_EQ(c.matches[1].id, 5);
  EXPECT_EQ(c.matches[2].id, 1);
}

TEST(BowDatabase, ConcurrentQueriesWhileAdding) {
  std::mt19937 rng(1);
  BowDatabase db;
  std::vector<BowVector> vs;
  for (int i = 0; i < 400; ++i) vs.push_back(test::randomVector(rng, 50, 2000, BowNorm::L1));
  for (int i = 0; i < 100; ++i) db.add(i, vs[i]);
  std::atomic<bool> stop{false};
  std::atomic<int> bad{0};
  std::thread reader([&] {
    size_t it = 0;
    while (!stop) {
      const auto& q = vs[it++ % 100];
      const auto r = db.query(q, 1);
      // The vector itself is always in the database and scores 1.
      if (r.empty() || r[0].score < 1.0 - 1e-12) ++bad;
    }
  });
  for (int i = 100; i < 400; ++i) db.add(i, vs[i]);
  for (int i = 200; i < 400; ++i) db.erase(i);
  stop = true;
  reader.join();
  EXPECT_EQ(bad, 0);
  EXPECT_EQ(db.size(), 200u);
}
