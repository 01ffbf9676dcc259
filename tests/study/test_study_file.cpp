// Study files (docs/ablation.md): validation before anything runs (errors
// naming the study file, line and key), the plan of cells and the scene
// cache key.
#include <gtest/gtest.h>

#include <filesystem>

#include "dslam/config/pipeline.h"
#include "dslam/core/error.h"
#include "dslam/core/registry.h"
#include "dslam/study/runner.h"
#include "dslam/study/study.h"
#include "test_support.h"

using namespace dslam;
namespace fs = std::filesystem;

namespace {

class StudyFile : public ::testing::Test {
 protected:
  void SetUp() override {
    register_builtin_plugins();
    dir_ = test::tempDir("studyfile");
    fs::create_directories(dir_ + "/data");
    // A minimal TUM-layout folder: what `path:` datasets are checked for.
    test::writeFile(dir_ + "/data/tumlike/rgb.txt", "# timestamp filename\n");
  }
  std::string write(const std::string& text) {
    const std::string f = dir_ + "/study.yaml";
    test::writeFile(f, text);
    return f;
  }
  /** A valid study with the crowd_slam base and the given extra text. */
  std::string studyText(const std::string& variants, const std::string& datasets = "") const {
    return test::cat("name: t\n",                                                                      // 1
                     "bases:\n",                                                                      // 2
                     "  crowd: ", test::source("config/pipelines/synthetic/crowd_slam.yaml"), "\n",  // 3
                     "  baseline: ", test::source("config/pipelines/orbslam_baseline.yaml"), "\n",   // 4
                     "variants:\n",                                                                   // 5
                     variants,
                     "datasets:\n",
                     "  wx: {scenario: ", test::source("config/scenarios/walking_xyz.yaml"),
                     ", frames: 30, resolution: 160x120}\n",
                     datasets);
  }
  std::string error(const std::string& text) {
    const std::string f = write(text);
    try {
      study::loadStudy(f);
    } catch (const ConfigError& e) {
      return e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "expected ConfigError, got: " << e.what();
      return "";
    }
    ADD_FAILURE() << "no ConfigError for:\n" << text;
    return "";
  }
  std::string dir_;
};

TEST_F(StudyFile, PlanOfCells) {
  const std::string f = write(studyText(
      "  no_afc: {base: crowd, overlay: [{remove: feature_count}]}\n"
      "  more: {base: crowd, overlay: [{set: {features.n_features: 1500}}], datasets: [wx]}\n",
      "  tum: " + dir_ + "/data/tumlike\n"));
  const study::Study st = study::loadStudy(f);
  EXPECT_EQ(st.name, "t");
  ASSERT_EQ(st.variants.size(), 4u);
  EXPECT_EQ(st.variants[0].name, "crowd");
  EXPECT_TRUE(st.variants[0].is_base);
  EXPECT_EQ(st.variants[0].reference, "");
  EXPECT_EQ(st.variants[2].name, "no_afc");
  EXPECT_EQ(st.variants[2].reference, "crowd");  // a variant compares to its base
  ASSERT_EQ(st.datasets.size(), 2u);
  EXPECT_TRUE(st.datasets[0].isScenario());
  EXPECT_FALSE(st.datasets[1].isScenario());

  const auto cells = st.plan();
  std::vector<std::string> ids;
  for (const auto& c : cells) ids.push_back(c.id);
  EXPECT_EQ(ids, (std::vector<std::string>{"crowd.wx.r0", "crowd.tum.r0", "baseline.wx.r0", "baseline.tum.r0",
                                           "no_afc.wx.r0", "no_afc.tum.r0", "more.wx.r0"}));
  for (size_t i = 0; i < cells.size(); i++) EXPECT_EQ(cells[i].index, i);

  // Each cell's pipeline is the variant's, named after it.
  const auto no_afc = config::loadPipelineText(cells[4].config_yaml, dir_);
  EXPECT_EQ(no_afc.name, "no_afc");
  EXPECT_EQ(no_afc.modulesOf("KeypointClassifier").size(), 1u);
  EXPECT_EQ(config::loadPipelineText(cells[6].config_yaml, dir_).sections.at("features").getInt("n_features"), 1500);

  // Stable: the same file gives the same ids and input hashes; cells differ.
  const auto again = study::loadStudy(f).plan();
  for (size_t i = 0; i < cells.size(); i++) EXPECT_EQ(again[i].inputs_hash, cells[i].inputs_hash);
  EXPECT_NE(cells[0].inputs_hash, cells[4].inputs_hash);
}

TEST_F(StudyFile, RepeatsSeedsAndMode) {
  const std::string f = write(test::cat("repeats: 2\nseeds: [1, 5]\nmode: parallel\n",
                                        studyText("  v: {base: crowd}\n").substr(8)));  // drop "name: t\n"
  const study::Study st = study::loadStudy(f);
  EXPECT_EQ(st.name, "study");  // default: the file name
  const auto cells = st.plan();
  ASSERT_EQ(cells.size(), 3u * 1u * 2u * 2u);
  EXPECT_EQ(cells[0].id, "crowd.wx.s1.r0");
  EXPECT_EQ(cells[1].id, "crowd.wx.s1.r1");
  EXPECT_EQ(cells[2].id, "crowd.wx.s5.r0");
  const auto pc = config::loadPipelineText(cells[2].config_yaml, dir_);
  EXPECT_EQ(pc.seed, 5u);
  EXPECT_EQ(pc.mode, config::Mode::Parallel);
  // Repeats of a cell run the same pipeline; their ids differ.
  EXPECT_EQ(cells[0].config_yaml, cells[1].config_yaml);
  EXPECT_NE(cells[0].id, cells[1].id);
}

// A variant's seeds: one more variant per seed, named <variant>_seed<k>,
// the same overlay and pipeline.seed k; as if written out by hand.
TEST_F(StudyFile, VariantSeedsMakeOneVariantPerSeed) {
  const std::string f = write(studyText(
      "  more: {base: crowd, overlay: [{set: {features.n_features: 1500}}], seeds: [3, 1], datasets: [wx]}\n"
      "  last: {base: crowd}\n"));
  const study::Study st = study::loadStudy(f);
  std::vector<std::string> names;
  for (const auto& v : st.variants) names.push_back(v.name);
  EXPECT_EQ(names, (std::vector<std::string>{"crowd", "baseline", "more", "more_seed3", "more_seed1", "last"}));
  const auto cells = st.plan();
  std::vector<std::string> ids;
  for (const auto& c : cells) ids.push_back(c.id);
  EXPECT_EQ(ids, (std::vector<std::string>{"crowd.wx.r0", "baseline.wx.r0", "more.wx.r0", "more_seed3.wx.r0",
                                           "more_seed1.wx.r0", "last.wx.r0"}));
  const auto plain = config::loadPipelineText(cells[2].config_yaml, dir_);
  const auto s3 = config::loadPipelineText(cells[3].config_yaml, dir_);
  EXPECT_EQ(s3.seed, 3u);
  EXPECT_NE(plain.seed, 3u);
  EXPECT_EQ(s3.sections.at("features").getInt("n_features"), 1500);  // the variant's overlay too
  EXPECT_EQ(s3.name, "more_seed3");
  EXPECT_EQ(st.variants[3].base, "crowd");
  EXPECT_EQ(st.variants[3].reference, "crowd");
  // The same as the variant written out by hand.
  const std::string g = write(studyText(
      "  more_seed3: {base: crowd, overlay: [{set: {features.n_features: 1500, pipeline.seed: 3}}], datasets: [wx]}\n"));
  const auto by_hand = study::loadStudy(g).plan();
  ASSERT_EQ(by_hand.size(), 3u);
  EXPECT_EQ(by_hand[2].id, "more_seed3.wx.r0");
  EXPECT_EQ(by_hand[2].config_yaml, cells[3].config_yaml);
}

TEST_F(StudyFile, SceneCacheKeyFollowsResolvedTextAndOverrides) {
  const std::string scen = test::source("config/scenarios/walking_xyz.yaml");
  auto key = [&](const std::string& extra) {
    const std::string f = write(test::cat("bases: {b: ", test::source("config/pipelines/orbslam_baseline.yaml"),
                                          "}\ndatasets:\n  d: {scenario: ", scen, extra, "}\n"));
    return study::loadStudy(f).datasets[0].cacheName();
  };
  const std::string k1 = key(", frames: 30");
  EXPECT_EQ(k1.rfind("walking_xyz-", 0), 0u) << k1;
  EXPECT_EQ(k1.size(), std::string("walking_xyz-").size() + 16);
  EXPECT_EQ(key(", frames: 30"), k1);
  EXPECT_NE(key(", frames: 31"), k1);
  EXPECT_NE(key(", frames: 30, resolution: [320, 240]"), k1);
  EXPECT_NE(key(", frames: 30, noise: false"), k1);
  EXPECT_NE(key(", frames: 30, seed: 3"), k1);
  // Resolved text: an include-identical copy elsewhere has the same key.
  fs::copy_file(scen, dir_ + "/walking_xyz.yaml");
  fs::create_directories(dir_ + "/common");
  for (const auto& e : fs::directory_iterator(test::source("config/scenarios/common")))
    fs::copy_file(e.path(), dir_ + "/common/" + e.path().filename().string());
  const std::string f = write(test::cat("bases: {b: ", test::source("config/pipelines/orbslam_baseline.yaml"),
                                        "}\ndatasets:\n  d: {scenario: walking_xyz.yaml, frames: 30}\n"));
  EXPECT_EQ(study::loadStudy(f).datasets[0].cacheName(), k1);
}

// A scene cache entry that is a link to a deleted folder (a study's scenes
// linked into a shared cache, then that study deleted) is rendered again in
// its place; something else in the way is an error naming it, not a cell
// that fails with "dataset not found".
TEST_F(StudyFile, SceneCacheRendersAgainOverADanglingLink) {
  const std::string f =
      write(test::cat("bases: {b: ", test::source("config/pipelines/orbslam_baseline.yaml"), "}\ndatasets:\n  d: {scenario: ",
                      test::source("config/scenarios/static_office.yaml"),
                      ", frames: 3, resolution: [160, 120], right: false, labels: false}\n"));
  const study::Dataset d = study::loadStudy(f).datasets[0];
  const fs::path cache = dir_ + "/cache", entry = cache / d.cacheName();
  fs::create_directories(cache);
  fs::create_directory_symlink(dir_ + "/deleted_study/scenes/x", entry);
  ASSERT_TRUE(fs::is_symlink(entry));
  EXPECT_EQ(study::prepareDataset(d, cache.string(), false), entry.string());
  EXPECT_FALSE(fs::is_symlink(entry));
  EXPECT_TRUE(fs::exists(entry / "groundtruth.txt"));
  EXPECT_TRUE(fs::exists(entry / "rgb.txt"));
  // Rendered: the entry is used as it is.
  EXPECT_EQ(study::prepareDataset(d, cache.string(), false), entry.string());
  // A file in the way.
  fs::remove_all(entry);
  test::writeFile(entry.string(), "not a scene\n");
  try {
    study::prepareDataset(d, cache.string(), false);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(entry.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("remove it"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(fs::is_regular_file(entry));  // not deleted: it is not ours
  for (const auto& e : fs::directory_iterator(cache))  // no temporary render left behind
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

// Every study and pipeline shipped in config/ loads and validates (bases,
// overlays, datasets, parameters): a renamed parameter or scene breaks here,
// not in a user's hour-long study.
TEST_F(StudyFile, EveryShippedStudyAndPipelineLoads) {
  size_t studies = 0, pipelines = 0;
  for (const auto& e : fs::directory_iterator(test::source("config/studies"))) {
    if (e.path().extension() != ".yaml") continue;
    SCOPED_TRACE(e.path().string());
    try {
      EXPECT_FALSE(study::loadStudy(e.path().string()).plan().empty());
    } catch (const std::exception& ex) {
      ADD_FAILURE() << ex.what();
    }
    studies++;
  }
  for (const auto& e : fs::recursive_directory_iterator(test::source("config/pipelines"))) {
    if (e.path().extension() != ".yaml") continue;
    SCOPED_TRACE(e.path().string());
    try {
      EXPECT_FALSE(config::loadPipeline(e.path().string()).name.empty());
    } catch (const std::exception& ex) {
      ADD_FAILURE() << ex.what();
    }
    pipelines++;
  }
  EXPECT_GE(studies, 14u);
  EXPECT_GE(pipelines, 16u);
}

TEST_F(StudyFile, ErrorsNameFileLineAndKey) {
  struct Case {
    std::string text;
    std::vector<std::string> want;
  };
  const std::string base = test::source("config/pipelines/synthetic/crowd_slam.yaml");
  const std::vector<Case> cases = {
      {studyText("  v: {base: crowd}\n") + "repets: 3\n", {"study.yaml:", "'repets'", "did you mean 'repeats'"}},
      {studyText("  v: {base: crowd, overlays: []}\n"), {"study.yaml:6:", "'variants.v.overlays'", "did you mean 'overlay'"}},
      {studyText("  v: {base: crowdd}\n"), {"study.yaml:6:", "'variants.v.base'", "unknown base 'crowdd'", "did you mean 'crowd'"}},
      {studyText("  v:\n    base: crowd\n    overlay:\n      - remove: feature_count\n      - remove: box_filtr\n"),
       {"study.yaml:10:", "'variants.v.overlay[1].remove'", "no module 'box_filtr'"}},
      {studyText("  v:\n    base: crowd\n    overlay:\n      - set: {modules.box_filter.params.min_scor: 1}\n"),
       {"study.yaml:9:", "'variants.v.overlay[0].set'", "no parameter 'min_scor'", "did you mean 'min_score'"}},
      {studyText("  v: {base: crowd}\n", "  gone: " + dir_ + "/data/nothing_here\n"),
       {"study.yaml:9:", "'datasets.gone'", "dataset not found", "nothing_here"}},
      {studyText("  v: {base: crowd}\n", "  notds: {path: " + dir_ + "/data}\n"),
       {"study.yaml:9:", "'datasets.notds.path'", "cannot tell the dataset type"}},
      {studyText("  v: {base: crowd}\n", "  sc: {scenario: nope.yaml}\n"),
       {"study.yaml:9:", "'datasets.sc.scenario'", "scenario file not found"}},
      {studyText("  v: {base: crowd}\n", "  sc: {scenario: " + test::source("config/scenarios/loop.yaml") +
                                          ", resolution: big}\n"),
       {"study.yaml:9:", "'datasets.sc.resolution'", "expected WxH"}},
      {studyText("  v: {base: crowd, datasets: [wx, kitti]}\n"), {"study.yaml:6:", "unknown dataset 'kitti'"}},
      {studyText("  crowd: {base: crowd}\n"), {"study.yaml:6:", "has the name of a base"}},
      {studyText("  v: {base: crowd, seeds: [1, -2]}\n"), {"study.yaml:6:", "'variants.v.seeds[1]'", "integers >= 0"}},
      {studyText("  v: {base: crowd, seeds: [1, 1]}\n"), {"study.yaml:6:", "seed 1 is listed twice"}},
      {studyText("  v: {base: crowd, seeds: [1]}\n  v_seed1: {base: crowd}\n"),
       {"study.yaml:7:", "variant 'v_seed1' is also made by the seeds of variant 'v'"}},
      {studyText("  v_seed1: {base: crowd}\n  v: {base: crowd, seeds: [1]}\n"),
       {"study.yaml:7:", "'variants.v.seeds'", "variant 'v_seed1' (seed 1) already exists"}},
      {studyText("  bad.name: {base: crowd}\n"), {"study.yaml:6:", "'variants.bad.name'", "letters, digits"}},
      {test::cat("bases: {b: ", dir_, "/missing.yaml}\ndatasets: {d: ", dir_, "/data/tumlike}\n"),
       {"study.yaml:1:", "'bases.b'", "pipeline file not found"}},
      {test::cat("bases: {b: ", base, "}\n"), {"study.yaml:", "missing required key 'datasets'"}},
  };
  for (const auto& c : cases) {
    const std::string e = error(c.text);
    for (const auto& w : c.want) EXPECT_NE(e.find(w), std::string::npos) << "study:\n" << c.text << "\nerror: " << e;
  }
}

TEST_F(StudyFile, InvalidBasePipelineNamesTheStudyAndThePipeline) {
  test::writeFile(dir_ + "/broken.yaml", "pipeline: {name: x, seeed: 1}\n");
  const std::string e = error(test::cat("bases:\n  b: ", dir_, "/broken.yaml\ndatasets: {d: ", dir_, "/data/tumlike}\n"));
  EXPECT_NE(e.find("study.yaml:2:"), std::string::npos) << e;
  EXPECT_NE(e.find("broken.yaml:1"), std::string::npos) << e;
  EXPECT_NE(e.find("seeed"), std::string::npos) << e;
}

}  // namespace
