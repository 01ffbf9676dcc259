#include "dslam/place_recognition/bow_database.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <mutex>

#include "bow_score.h"
#include "dslam/core/error.h"
#include "dslam/place_recognition/vocabulary.h"

namespace dslam {

const BowMatch* BowCandidates::find(BowEntryId id) const {
  for (const auto& m : matches)
    if (m.id == id) return &m;
  return nullptr;
}

BowDatabase::BowDatabase(ScoringType scoring, size_t n_words) : scoring_(scoring) { inv_.resize(n_words); }

BowDatabase::BowDatabase(const Vocabulary& voc) : BowDatabase(voc.scoring(), voc.size()) {}

BowDatabase::~BowDatabase() = default;

void BowDatabase::add(BowEntryId id, const BowVector& v) {
  std::unique_lock lk(mutex_);
  if (index_.count(id)) throw Error("BowDatabase::add: entry " + std::to_string(id) + " is already in the database");
  uint32_t slot;
  if (!free_.empty()) {
    slot = free_.back();
    free_.pop_back();
  } else {
    slot = static_cast<uint32_t>(slots_.size());
    slots_.emplace_back();
  }
  Slot& s = slots_[slot];
  s.id = id;
  s.used = true;
  s.v = v;
  index_.emplace(id, slot);
  if (!v.empty() && v.entries().back().word >= inv_.size()) inv_.resize(static_cast<size_t>(v.entries().back().word) + 1);
  for (const BowEntry& e : v) inv_[e.word].push_back(Posting{slot, e.weight});
}

bool BowDatabase::erase(BowEntryId id) {
  std::unique_lock lk(mutex_);
  auto it = index_.find(id);
  if (it == index_.end()) return false;
  const uint32_t slot = it->second;
  Slot& s = slots_[slot];
  for (const BowEntry& e : s.v) {
    auto& list = inv_[e.word];
    for (size_t i = 0; i < list.size(); ++i) {
      if (list[i].slot == slot) {
        list[i] = list.back();
        list.pop_back();
        break;
      }
    }
  }
  s.used = false;
  s.v.clear();
  index_.erase(it);
  free_.push_back(slot);
  return true;
}

void BowDatabase::clear() {
  std::unique_lock lk(mutex_);
  for (auto& l : inv_) l.clear();
  slots_.clear();
  free_.clear();
  index_.clear();
}

size_t BowDatabase::size() const {
  std::shared_lock lk(mutex_);
  return index_.size();
}

bool BowDatabase::contains(BowEntryId id) const {
  std::shared_lock lk(mutex_);
  return index_.count(id) != 0;
}

BowVector BowDatabase::vector(BowEntryId id) const {
  std::shared_lock lk(mutex_);
  auto it = index_.find(id);
  return it == index_.end() ? BowVector() : slots_[it->second].v;
}

std::vector<BowEntryId> BowDatabase::ids() const {
  std::shared_lock lk(mutex_);
  std::vector<BowEntryId> out;
  out.reserve(index_.size());
  for (const auto& kv : index_) out.push_back(kv.first);
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<BowEntryId> BowDatabase::entriesWithWord(WordId w) const {
  std::shared_lock lk(mutex_);
  std::vector<BowEntryId> out;
  if (w < inv_.size())
    for (const Posting& p : inv_[w]) out.push_back(slots_[p.slot].id);
  std::sort(out.begin(), out.end());
  return out;
}

BowDatabase::Touched BowDatabase::touch(const BowVector& v, bool scores, const Filter& keep) const {
  Touched t;
  t.counts.assign(slots_.size(), 0);
  if (scores) t.sums.assign(slots_.size(), 0.0);
  std::vector<uint32_t> touched;
  const ScoringType st = scoring_;
  for (const BowEntry& e : v) {
    if (e.word >= inv_.size()) continue;
    const double x = e.weight;
    for (const Posting& p : inv_[e.word]) {
      if (t.counts[p.slot]++ == 0) touched.push_back(p.slot);
      // Same per-word terms, in the same (ascending word) order, as bowScore().
      if (scores) t.sums[p.slot] += bowscore::wordTerm(st, x, p.weight);
    }
  }
  t.slots.reserve(touched.size());
  for (uint32_t slot : touched)
    if (!keep || keep(slots_[slot].id)) t.slots.push_back(slot);
  return t;
}

double BowDatabase::finishScore(double s, const BowVector& v, const Slot& slot) const {
  return scoring_ == ScoringType::KL ? bowScore(ScoringType::KL, v, slot.v) : bowscore::finish(scoring_, s);
}

std::vector<BowSharedWords> BowDatabase::sharedWords(const BowVector& v, const Filter& keep) const {
  std::shared_lock lk(mutex_);
  const Touched t = touch(v, false, keep);
  std::vector<BowSharedWords> out;
  out.reserve(t.slots.size());
  for (uint32_t s : t.slots) out.push_back({slots_[s].id, t.counts[s]});
  std::sort(out.begin(), out.end(), [](const BowSharedWords& a, const BowSharedWords& b) { return a.id < b.id; });
  return out;
}

double BowDatabase::score(const BowVector& v, BowEntryId id) const {
  std::shared_lock lk(mutex_);
  auto it = index_.find(id);
  if (it == index_.end()) throw Error("BowDatabase::score: entry " + std::to_string(id) + " is not in the database");
  return bowScore(scoring_, v, slots_[it->second].v);
}

namespace {

void sortMatches(std::vector<BowMatch>& m, size_t max_results) {
  auto better = [](const BowMatch& a, const BowMatch& b) { return a.score != b.score ? a.score > b.score : a.id < b.id; };
  if (max_results > 0 && m.size() > max_results) {
    std::partial_sort(m.begin(), m.begin() + static_cast<std::ptrdiff_t>(max_results), m.end(), better);
    m.resize(max_results);
  } else {
    std::sort(m.begin(), m.end(), better);
  }
}

}  // namespace

std::vector<BowMatch> BowDatabase::query(const BowVector& v, size_t max_results, const Filter& keep) const {
  std::shared_lock lk(mutex_);
  const Touched t = touch(v, true, keep);
  std::vector<BowMatch> out;
  out.reserve(t.slots.size());
  for (uint32_t s : t.slots) out.push_back({slots_[s].id, t.counts[s], finishScore(t.sums[s], v, slots_[s])});
  sortMatches(out, max_results);
  return out;
}

BowCandidates BowDatabase::candidates(const BowVector& v, const BowCandidateParams& p, const Filter& keep) const {
  std::shared_lock lk(mutex_);
  const Touched t = touch(v, true, keep);
  BowCandidates out;
  for (uint32_t s : t.slots) out.max_common = std::max(out.max_common, t.counts[s]);
  out.min_common = static_cast<int>(static_cast<float>(out.max_common) * p.min_common_ratio);
  for (uint32_t s : t.slots) {
    if (t.counts[s] <= out.min_common) continue;
    const double sc = finishScore(t.sums[s], v, slots_[s]);
    if (sc >= p.min_score) out.matches.push_back({slots_[s].id, t.counts[s], sc});
  }
  sortMatches(out.matches, p.max_results);
  return out;
}

}  // namespace dslam
