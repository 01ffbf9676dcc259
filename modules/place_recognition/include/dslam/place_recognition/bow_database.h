#pragma once
/** \file bow_database.h
 *  Inverted index of bag-of-words vectors (DBoW2 Database / ORB-SLAM
 *  KeyFrameDatabase) over plain integer ids: for every word, the entries
 *  that contain it and their weight. It answers the two questions ORB-SLAM's
 *  DetectLoopCandidates / DetectRelocalizationCandidates ask before their
 *  covisibility-group accumulation (which needs the map and stays with the
 *  caller): which entries share words with a query and how many, and their
 *  scores. */
#include <cstdint>
#include <functional>
#include <shared_mutex>
#include <unordered_map>
#include <vector>

#include "dslam/place_recognition/bow_vector.h"

namespace dslam {

class Vocabulary;

using BowEntryId = int64_t;  ///< caller's id (the SLAM engine uses keyframe ids)

/** Entry sharing words with a query. */
struct BowSharedWords {
  BowEntryId id = 0;
  int common_words = 0;
};

/** A scored entry. */
struct BowMatch {
  BowEntryId id = 0;
  int common_words = 0;
  double score = 0;
};

/** ORB-SLAM candidate selection (KeyFrameDatabase::Detect*Candidates,
 *  first two steps). */
struct BowCandidateParams {
  /** Entries must share more than int(min_common_ratio * max_common) words
   *  with the query, max_common being the largest count among the entries
   *  kept by the filter (ORB-SLAM: 0.8). */
  float min_common_ratio = 0.8f;
  /** Minimum score (ORB-SLAM loop detection: the lowest score between the
   *  keyframe and its covisible keyframes; relocalisation: 0). */
  double min_score = 0;
  /** At most this many, best scores first (0 = all). */
  size_t max_results = 0;
};

/** Result of BowDatabase::candidates(). */
struct BowCandidates {
  int max_common = 0;  ///< largest number of shared words among the filtered entries
  int min_common = 0;  ///< int(min_common_ratio * max_common); kept entries share more
  /** Entries sharing > min_common words and scoring >= min_score, by
   *  decreasing score (ties: increasing id). */
  std::vector<BowMatch> matches;
  /** Match of `id` or nullptr (linear search). */
  const BowMatch* find(BowEntryId id) const;
};

/** Inverted index. Readers (query, candidates, sharedWords, score, vector)
 *  may run concurrently with each other; add / erase / clear lock it
 *  exclusively (ORB-SLAM's tracking, local mapping and loop closing threads
 *  share one database). Filters are called with the index locked for
 *  reading: they must not modify the database. */
class BowDatabase {
 public:
  /** true = keep the entry. */
  using Filter = std::function<bool(BowEntryId)>;

  /** `scoring` must match the vectors' normalisation (Vocabulary::scoring());
   *  `n_words` pre-sizes the inverted file (it grows as needed). */
  explicit BowDatabase(ScoringType scoring = ScoringType::L1, size_t n_words = 0);
  /** Scoring and size of `voc`. */
  explicit BowDatabase(const Vocabulary& voc);
  ~BowDatabase();
  BowDatabase(const BowDatabase&) = delete;
  BowDatabase& operator=(const BowDatabase&) = delete;

  /** Adds an entry (a copy of `v` is kept). Throws Error if `id` is
   *  already in the database. */
  void add(BowEntryId id, const BowVector& v);
  /** Removes an entry; false if it was not there. */
  bool erase(BowEntryId id);
  void clear();

  size_t size() const;
  bool contains(BowEntryId id) const;
  /** Copy of the stored vector of `id`; empty if absent. */
  BowVector vector(BowEntryId id) const;
  /** Ids of all entries, ascending. */
  std::vector<BowEntryId> ids() const;
  /** Entries containing word `w` (ascending ids). */
  std::vector<BowEntryId> entriesWithWord(WordId w) const;
  ScoringType scoring() const { return scoring_; }

  /** Entries sharing at least one word with `v` (and kept by `keep`), with
   *  the number of shared words, by ascending id. */
  std::vector<BowSharedWords> sharedWords(const BowVector& v, const Filter& keep = {}) const;

  /** Score of `v` against entry `id` (same value as bowScore()); throws
   *  Error if absent. */
  double score(const BowVector& v, BowEntryId id) const;

  /** DBoW2 Database::query: scores of every entry sharing a word with `v`
   *  and kept by `keep`, accumulated through the inverted file, best first
   *  (ties: increasing id); at most `max_results` (0 = all). Scores equal
   *  bowScore(scoring(), v, stored vector). */
  std::vector<BowMatch> query(const BowVector& v, size_t max_results = 0, const Filter& keep = {}) const;

  /** ORB-SLAM candidate selection: shared-word counting, the min-common
   *  threshold, then scores (see BowCandidateParams). */
  BowCandidates candidates(const BowVector& v, const BowCandidateParams& p = {}, const Filter& keep = {}) const;

 private:
  struct Posting {
    uint32_t slot;
    WordValue weight;
  };
  struct Slot {
    BowEntryId id = 0;
    bool used = false;
    BowVector v;
  };
  /** Slots sharing words with a query: counts[slot] = shared words,
   *  sums[slot] = sum of the scoring's word terms (when asked). */
  struct Touched {
    std::vector<uint32_t> slots;  ///< kept by the filter, in first-touch order
    std::vector<int> counts;
    std::vector<double> sums;
  };
  Touched touch(const BowVector& v, bool scores, const Filter& keep) const;
  double finishScore(double sum, const BowVector& v, const Slot& s) const;

  ScoringType scoring_;
  mutable std::shared_mutex mutex_;
  std::vector<std::vector<Posting>> inv_;  ///< word -> postings
  std::vector<Slot> slots_;
  std::vector<uint32_t> free_;
  std::unordered_map<BowEntryId, uint32_t> index_;
};

}  // namespace dslam
