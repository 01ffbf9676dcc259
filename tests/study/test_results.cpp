// Aggregation of a study's runs (docs/ablation.md): median and range over
// repeats, failed runs, ratio to the reference variant, the tables.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <sstream>

#include "dslam/study/results.h"
#include "test_support.h"

using namespace dslam;
using study::CellResult;

namespace {

study::Study twoByTwo() {
  study::Study st;
  st.name = "agg";
  study::Variant b;
  b.name = b.base = "b";
  study::Variant v;
  v.name = "v";
  v.base = v.reference = "b";
  v.is_base = false;
  st.variants = {b, v};
  study::Dataset d1, d2;
  d1.name = "d1";
  d2.name = "d2";
  st.datasets = {d1, d2};
  return st;
}

CellResult run(const std::string& variant, const std::string& dataset, int repeat, std::optional<double> ate,
               bool ok = true) {
  CellResult r;
  r.variant = variant;
  r.base = "b";
  r.dataset = dataset;
  r.repeat = repeat;
  r.cell = variant + "." + dataset + ".r" + std::to_string(repeat);
  r.status = ok ? "ok" : "failed";
  if (!ok) r.error = "dslam run exit code 1: error: boom, really";
  r.ate_rmse = ok ? ate : std::nullopt;
  r.frames = 100;
  r.tracked = ok ? 90 + static_cast<size_t>(repeat) : 0;
  r.keyframes = 10;
  r.median_ms = 10 + repeat;
  r.fps = 30;
  r.peak_mb = 150;
  return r;
}

std::vector<CellResult> runs() {
  return {run("b", "d1", 0, 0.010), run("b", "d1", 1, 0.030), run("b", "d1", 2, 0.020),
          run("b", "d2", 0, 0.100),
          run("v", "d1", 0, 0.040), run("v", "d1", 1, 0.050), run("v", "d1", 2, std::nullopt, false),
          run("v", "d2", 0, 0.050)};
}

TEST(StudyResults, SpreadIsMedianMinMax) {
  auto s = study::spread({0.3, 0.1, 0.2});
  ASSERT_TRUE(s);
  EXPECT_EQ(s->n, 3u);
  EXPECT_DOUBLE_EQ(s->median, 0.2);
  EXPECT_DOUBLE_EQ(s->min, 0.1);
  EXPECT_DOUBLE_EQ(s->max, 0.3);
  EXPECT_DOUBLE_EQ(study::spread({4, 1, 3, 2})->median, 2.5);  // even count: mean of the middle two
  EXPECT_FALSE(study::spread({}));
}

TEST(StudyResults, MedianOverRepeatsAndRatioToTheBase) {
  const auto st = twoByTwo();
  const auto g = study::summarize(st, runs());
  ASSERT_EQ(g.size(), 4u);  // b x {d1, d2}, v x {d1, d2}
  EXPECT_EQ(g[0].variant, "b");
  EXPECT_EQ(g[0].dataset, "d1");
  EXPECT_EQ(g[0].runs, 3u);
  EXPECT_DOUBLE_EQ(g[0].ate->median, 0.020);
  EXPECT_DOUBLE_EQ(g[0].ate->min, 0.010);
  EXPECT_DOUBLE_EQ(g[0].ate->max, 0.030);
  EXPECT_FALSE(g[0].ratio);  // a base has no reference here
  // v on d1: two good runs (median 0.045) and a failed one, not counted in the median.
  EXPECT_EQ(g[2].variant, "v");
  EXPECT_EQ(g[2].runs, 3u);
  EXPECT_EQ(g[2].failed, 1u);
  EXPECT_EQ(g[2].ate->n, 2u);
  EXPECT_DOUBLE_EQ(g[2].ate->median, 0.045);
  ASSERT_TRUE(g[2].ratio);
  EXPECT_DOUBLE_EQ(*g[2].ratio, 0.045 / 0.020);
  ASSERT_TRUE(g[3].ratio);
  EXPECT_DOUBLE_EQ(*g[3].ratio, 0.5);
  EXPECT_NEAR(*study::meanRatio(g, "v"), std::sqrt(2.25 * 0.5), 1e-12);
  EXPECT_FALSE(study::meanRatio(g, "b"));
  EXPECT_DOUBLE_EQ(g[0].tracked_pct->median, 91.0);
}

TEST(StudyResults, ReferenceCanBeAnotherBase) {
  auto st = twoByTwo();
  st.variants[0].reference = "v";  // compare_to
  const auto g = study::summarize(st, runs());
  ASSERT_TRUE(g[0].ratio);
  EXPECT_DOUBLE_EQ(*g[0].ratio, 0.020 / 0.045);
}

TEST(StudyResults, MarkdownPivotTable) {
  const auto st = twoByTwo();
  study::Provenance prov{"dslam 0.1.0 (commit 0123456789ab)", "config/studies/agg.yaml", 9};
  const std::string md = study::resultsMarkdown(st, runs(), prov);
  EXPECT_NE(md.find("| variant | reference | d1 | d2 | ratio (geometric mean) |"), std::string::npos) << md;
  EXPECT_NE(md.find("| b |  | 0.0200 [0.0100-0.0300] | 0.1000 |  |"), std::string::npos) << md;
  EXPECT_NE(md.find("| v | b | 0.0450 [0.0400-0.0500] (2.25x) (1 failed) | 0.0500 (0.50x) | 1.06x |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("commit 0123456789ab"), std::string::npos);
  EXPECT_NE(md.find("8 of 9 runs finished (1 failed)"), std::string::npos) << md;
  EXPECT_NE(md.find("| v.d1.r2 | dslam run exit code 1: error: boom, really |"), std::string::npos) << md;
  EXPECT_NE(md.find("| v | d1 | 2/3 | 90.5 | 10 | - | - |"), std::string::npos) << md;
}

TEST(StudyResults, CsvOneRowPerRun) {
  const auto st = twoByTwo();
  const std::string csv = study::resultsCsv(st, runs());
  std::istringstream in(csv);
  std::string line;
  std::vector<std::string> lines;
  while (std::getline(in, line)) lines.push_back(line);
  ASSERT_EQ(lines.size(), 1u + 8u);
  EXPECT_EQ(lines[0].rfind("study,variant,base,dataset,seed,repeat,cell,status,ate_rmse_m,", 0), 0u);
  EXPECT_EQ(lines[1].rfind("agg,b,b,d1,,0,b.d1.r0,ok,0.010000,", 0), 0u) << lines[1];
  EXPECT_NE(lines[7].find(",failed,"), std::string::npos);
  EXPECT_NE(lines[7].find("\"dslam run exit code 1: error: boom, really\""), std::string::npos) << lines[7];
}

TEST(StudyResults, CellResultJsonRoundTrip) {
  CellResult r = run("v", "d1", 2, 0.0123);
  r.seed = 7;
  r.ate_scale = 0.95;
  r.min_usable_keypoints = 219;
  r.max_feature_count = 1500;
  r.rpe_trans = 0.001;
  r.rpe_rot = 0.05;
  r.wall_s = 3.5;
  r.inputs_hash = "00ff";
  const CellResult b = CellResult::fromJson(r.toJson());
  EXPECT_EQ(b.toJson(), r.toJson());
  EXPECT_EQ(*b.seed, 7u);
  EXPECT_DOUBLE_EQ(*b.ate_rmse, 0.0123);
  EXPECT_THROW(CellResult::fromJson("{\"cell\": 1}"), DataError);
}

TEST(StudyResults, JsonHasGroupsWithRatios) {
  const auto st = twoByTwo();
  const auto j = nlohmann::json::parse(study::resultsJson(st, runs(), {"dslam x", "s.yaml", 8}));
  EXPECT_EQ(j["runs"].size(), 8u);
  ASSERT_EQ(j["groups"].size(), 4u);
  EXPECT_DOUBLE_EQ(j["groups"][2]["ate_rmse"]["median"].get<double>(), 0.045);
  EXPECT_DOUBLE_EQ(j["groups"][2]["ratio_to_reference"].get<double>(), 2.25);
  EXPECT_TRUE(j["groups"][0]["ratio_to_reference"].is_null());
}

}  // namespace
