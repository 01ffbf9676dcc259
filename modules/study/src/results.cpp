// Aggregation of a study's runs and its result tables (docs/ablation.md).
#include "dslam/study/results.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#include "dslam/core/error.h"
#include "dslam/core/format.h"

using json = nlohmann::ordered_json;

namespace dslam::study {

namespace {

template <class T>
json opt(const std::optional<T>& v) {
  return v ? json(*v) : json(nullptr);
}
std::optional<double> optD(const json& j, const char* k) {
  if (!j.contains(k) || j[k].is_null()) return std::nullopt;
  return j[k].get<double>();
}
std::string csvField(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += (c == '"' ? std::string("\"\"") : std::string(1, c));
  return q + "\"";
}
/** Markdown table cell: no '|' or newline. */
std::string mdCell(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  std::string o;
  for (char c : s) o += (c == '|' ? std::string("\\|") : std::string(1, c));
  return o;
}
json spreadJson(const std::optional<Spread>& s) {
  if (!s) return nullptr;
  return json{{"n", s->n}, {"median", s->median}, {"min", s->min}, {"max", s->max}};
}

}  // namespace

std::string CellResult::toJson() const {
  json j;
  j["cell"] = cell;
  j["variant"] = variant;
  j["base"] = base;
  j["dataset"] = dataset;
  j["seed"] = opt(seed);
  j["repeat"] = repeat;
  j["status"] = status;
  j["error"] = error;
  j["exit_code"] = exit_code;
  j["ate_rmse"] = opt(ate_rmse);
  j["ate_scale"] = opt(ate_scale);
  j["rpe_trans_rmse"] = opt(rpe_trans);
  j["rpe_rot_rmse_deg"] = opt(rpe_rot);
  j["frames"] = frames;
  j["tracked"] = tracked;
  j["keyframes"] = keyframes;
  j["min_usable_keypoints"] = opt(min_usable_keypoints);
  j["max_feature_count"] = opt(max_feature_count);
  j["median_ms"] = median_ms;
  j["fps"] = fps;
  j["wall_s"] = wall_s;
  j["peak_mb"] = peak_mb;
  j["inputs_hash"] = inputs_hash;
  return j.dump(2) + "\n";
}

CellResult CellResult::fromJson(const std::string& text, const std::string& source) {
  CellResult r;
  try {
    const json j = json::parse(text);
    r.cell = j.at("cell").get<std::string>();
    r.variant = j.at("variant").get<std::string>();
    r.base = j.value("base", r.variant);
    r.dataset = j.at("dataset").get<std::string>();
    if (j.contains("seed") && !j["seed"].is_null()) r.seed = j["seed"].get<uint64_t>();
    r.repeat = j.value("repeat", 0);
    r.status = j.at("status").get<std::string>();
    r.error = j.value("error", "");
    r.exit_code = j.value("exit_code", 0);
    r.ate_rmse = optD(j, "ate_rmse");
    r.ate_scale = optD(j, "ate_scale");
    r.rpe_trans = optD(j, "rpe_trans_rmse");
    r.rpe_rot = optD(j, "rpe_rot_rmse_deg");
    r.frames = j.value("frames", size_t{0});
    r.tracked = j.value("tracked", size_t{0});
    r.keyframes = j.value("keyframes", size_t{0});
    r.min_usable_keypoints = optD(j, "min_usable_keypoints");
    r.max_feature_count = optD(j, "max_feature_count");
    r.median_ms = j.value("median_ms", 0.0);
    r.fps = j.value("fps", 0.0);
    r.wall_s = j.value("wall_s", 0.0);
    r.peak_mb = j.value("peak_mb", 0.0);
    r.inputs_hash = j.value("inputs_hash", "");
  } catch (const json::exception& e) {
    throw DataError(source + ": not a cell result: " + e.what());
  }
  return r;
}

std::optional<Spread> spread(const std::vector<double>& v) {
  if (v.empty()) return std::nullopt;
  std::vector<double> w = v;
  std::sort(w.begin(), w.end());
  Spread s;
  s.n = w.size();
  s.min = w.front();
  s.max = w.back();
  const size_t h = w.size() / 2;
  s.median = w.size() % 2 ? w[h] : 0.5 * (w[h - 1] + w[h]);
  return s;
}

std::vector<GroupSummary> summarize(const Study& st, const std::vector<CellResult>& results) {
  std::vector<GroupSummary> groups;
  for (const auto& v : st.variants)
    for (const auto& d : st.datasets) {
      if (!v.datasets.empty() && std::find(v.datasets.begin(), v.datasets.end(), d.name) == v.datasets.end()) continue;
      GroupSummary g;
      g.variant = v.name;
      g.dataset = d.name;
      g.reference = v.reference;
      std::vector<double> ate, rt, tr, kf, ms, fps, mem, usable, feat;
      for (const auto& r : results) {
        if (r.variant != v.name || r.dataset != d.name) continue;
        g.runs++;
        if (!r.ok()) {
          g.failed++;
          continue;
        }
        if (r.ate_rmse) ate.push_back(*r.ate_rmse);
        if (r.rpe_trans) rt.push_back(*r.rpe_trans);
        tr.push_back(r.trackedPercent());
        kf.push_back(static_cast<double>(r.keyframes));
        ms.push_back(r.median_ms);
        fps.push_back(r.fps);
        mem.push_back(r.peak_mb);
        if (r.min_usable_keypoints) usable.push_back(*r.min_usable_keypoints);
        if (r.max_feature_count) feat.push_back(*r.max_feature_count);
      }
      g.ate = spread(ate);
      g.rpe_trans = spread(rt);
      g.tracked_pct = spread(tr);
      g.keyframes = spread(kf);
      g.median_ms = spread(ms);
      g.fps = spread(fps);
      g.peak_mb = spread(mem);
      g.min_usable_keypoints = spread(usable);
      g.max_feature_count = spread(feat);
      groups.push_back(std::move(g));
    }
  for (auto& g : groups) {
    if (g.reference.empty() || !g.ate) continue;
    for (const auto& r : groups)
      if (r.variant == g.reference && r.dataset == g.dataset && r.ate && r.ate->median > 0)
        g.ratio = g.ate->median / r.ate->median;
  }
  return groups;
}

std::optional<double> meanRatio(const std::vector<GroupSummary>& groups, const std::string& variant) {
  double s = 0;
  size_t n = 0;
  for (const auto& g : groups)
    if (g.variant == variant && g.ratio && *g.ratio > 0) {
      s += std::log(*g.ratio);
      n++;
    }
  if (!n) return std::nullopt;
  return std::exp(s / static_cast<double>(n));
}

std::string resultsCsv(const Study& st, const std::vector<CellResult>& results) {
  std::ostringstream o;
  o << "study,variant,base,dataset,seed,repeat,cell,status,ate_rmse_m,rpe_trans_rmse_m,rpe_rot_rmse_deg,tracked_pct,"
       "frames,keyframes,min_usable_keypoints,max_feature_count,median_ms,fps,peak_mb,wall_s,error\n";
  auto num = [](const std::optional<double>& v, const char* f) { return v ? formatNumber(f, *v) : std::string(); };
  for (const auto& r : results) {
    o << csvField(st.name) << "," << csvField(r.variant) << "," << csvField(r.base) << "," << csvField(r.dataset) << ","
      << (r.seed ? std::to_string(*r.seed) : "") << "," << r.repeat << "," << csvField(r.cell) << "," << r.status << ","
      << num(r.ate_rmse, "%.6f") << "," << num(r.rpe_trans, "%.6f") << "," << num(r.rpe_rot, "%.4f") << ","
      << (r.ok() ? formatNumber("%.2f", r.trackedPercent()) : "") << "," << r.frames << "," << r.keyframes << ","
      << num(r.min_usable_keypoints, "%.0f") << "," << num(r.max_feature_count, "%.0f") << ","
      << formatNumber("%.2f", r.median_ms) << "," << formatNumber("%.2f", r.fps) << "," << formatNumber("%.1f", r.peak_mb) << ","
      << formatNumber("%.2f", r.wall_s) << "," << csvField(r.error) << "\n";
  }
  return o.str();
}

namespace {

const GroupSummary* findGroup(const std::vector<GroupSummary>& g, const std::string& v, const std::string& d) {
  for (const auto& x : g)
    if (x.variant == v && x.dataset == d) return &x;
  return nullptr;
}

std::string ateCell(const GroupSummary* g) {
  if (!g) return "";
  if (!g->runs) return "not run";
  if (!g->ate) return g->failed == g->runs ? "failed" : "n/a";
  std::string s = formatNumber("%.4f", g->ate->median);
  if (g->ate->n > 1) s += " [" + formatNumber("%.4f", g->ate->min) + "-" + formatNumber("%.4f", g->ate->max) + "]";
  if (g->ratio) s += " (" + formatNumber("%.2f", *g->ratio) + "x)";
  if (g->failed) s += " (" + std::to_string(g->failed) + " failed)";
  return s;
}

std::string med(const std::optional<Spread>& s, const char* f) { return s ? formatNumber(f, s->median) : std::string("-"); }

}  // namespace

std::string resultsMarkdown(const Study& st, const std::vector<CellResult>& results, const Provenance& prov) {
  const auto groups = summarize(st, results);
  size_t ok = 0, failed = 0, runs_max = 0;
  for (const auto& r : results) (r.ok() ? ok : failed)++;
  for (const auto& g : groups) runs_max = std::max(runs_max, g.runs);
  std::ostringstream o;
  o << "# Study `" << st.name << "`\n\n";
  if (!st.description.empty()) o << st.description << "\n\n";
  o << "Produced by " << prov.tool << " from `" << prov.study_file << "`: " << ok + failed << " of " << prov.planned
    << " runs finished";
  if (failed) o << " (" << failed << " failed)";
  o << ". Regenerate: `dslam ablate " << prov.study_file << " --out DIR`.\n\n";

  const char* align = eval::toString(st.evaluation.align);
  o << "## ATE RMSE [m]\n\n";
  o << "Median over the runs of each cell (" << align << " alignment)";
  if (runs_max > 1) o << ", [min-max] over the runs";
  o << "; (ratio) = median ATE / that of the reference variant on the same dataset. " << prov.tool << ".\n\n";
  o << "| variant | reference |";
  for (const auto& d : st.datasets) o << " " << mdCell(d.name) << " |";
  o << " ratio (geometric mean) |\n|---|---|";
  for (size_t i = 0; i < st.datasets.size(); i++) o << "---|";
  o << "---|\n";
  for (const auto& v : st.variants) {
    o << "| " << mdCell(v.name) << " | " << mdCell(v.reference) << " |";
    for (const auto& d : st.datasets) o << " " << ateCell(findGroup(groups, v.name, d.name)) << " |";
    const auto mr = meanRatio(groups, v.name);
    o << " " << (mr ? formatNumber("%.2fx", *mr) : std::string()) << " |\n";
  }

  o << "\n## Tracking, speed and memory\n\n";
  o << "Medians over the successful runs. tracked: % of frames; fewest usable: the fewest keypoints left in a "
       "frame after the classifiers; max features: the largest ORB feature count used; ms: median tracking time "
       "per frame; peak MB: peak resident memory of the run. "
    << prov.tool << ".\n\n";
  o << "| variant | dataset | runs | tracked % | keyframes | fewest usable | max features | RPE trans. RMSE [m] | median ms "
       "| frames/s | peak MB |\n";
  o << "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& g : groups) {
    if (!g.runs) continue;
    o << "| " << mdCell(g.variant) << " | " << mdCell(g.dataset) << " | " << g.runs - g.failed << "/" << g.runs
      << " | " << med(g.tracked_pct, "%.1f") << " | " << med(g.keyframes, "%.0f") << " | "
      << med(g.min_usable_keypoints, "%.0f") << " | " << med(g.max_feature_count, "%.0f") << " | "
      << med(g.rpe_trans, "%.4f") << " | " << med(g.median_ms, "%.1f") << " | " << med(g.fps, "%.1f") << " | "
      << med(g.peak_mb, "%.0f") << " |\n";
  }
  if (failed) {
    o << "\n## Failed runs\n\n| cell | error |\n|---|---|\n";
    for (const auto& r : results)
      if (!r.ok()) o << "| " << mdCell(r.cell) << " | " << mdCell(r.error) << " |\n";
  }
  return o.str();
}

std::string resultsJson(const Study& st, const std::vector<CellResult>& results, const Provenance& prov) {
  json j;
  j["study"] = st.name;
  j["description"] = st.description;
  j["study_file"] = prov.study_file;
  j["tool"] = prov.tool;
  j["planned"] = prov.planned;
  j["finished"] = results.size();
  j["evaluation"] = json{{"align", eval::toString(st.evaluation.align)},
                         {"max_dt", st.evaluation.max_dt},
                         {"rpe_delta", st.evaluation.rpe_delta},
                         {"rpe_unit", eval::toString(st.evaluation.rpe_unit)}};
  json runs = json::array();
  for (const auto& r : results) runs.push_back(json::parse(r.toJson()));
  j["runs"] = runs;
  json gs = json::array();
  for (const auto& g : summarize(st, results)) {
    gs.push_back(json{{"variant", g.variant},
                      {"dataset", g.dataset},
                      {"reference", g.reference},
                      {"runs", g.runs},
                      {"failed", g.failed},
                      {"ate_rmse", spreadJson(g.ate)},
                      {"ratio_to_reference", opt(g.ratio)},
                      {"rpe_trans_rmse", spreadJson(g.rpe_trans)},
                      {"tracked_pct", spreadJson(g.tracked_pct)},
                      {"keyframes", spreadJson(g.keyframes)},
                      {"min_usable_keypoints", spreadJson(g.min_usable_keypoints)},
                      {"max_feature_count", spreadJson(g.max_feature_count)},
                      {"median_ms", spreadJson(g.median_ms)},
                      {"fps", spreadJson(g.fps)},
                      {"peak_mb", spreadJson(g.peak_mb)}});
  }
  j["groups"] = gs;
  return j.dump(2) + "\n";
}

}  // namespace dslam::study
