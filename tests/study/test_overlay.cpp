// Overlay semantics of ablation studies (docs/ablation.md): set, add, remove,
// replace on a resolved pipeline, their order, paths, and the errors naming
// the study file, line and key.
#include <gtest/gtest.h>

#include "dslam/config/pipeline.h"
#include "dslam/core/error.h"
#include "dslam/core/registry.h"
#include "dslam/core/yaml_util.h"
#include "dslam/study/study.h"
#include "test_support.h"

using namespace dslam;

namespace {

/** Crowd-SLAM on synthetic scenes, resolved (every default filled in). */
const char* kBase = R"(
pipeline: {name: crowd, mode: sequential, seed: 42}
features: {n_features: 1000}
modules:
  - name: people
    type: dslam::GroundTruthDetector
    params: {miss_rate: 0.1, jitter: 0.05}
  - name: box_filter
    type: dslam::BoxFilter
    inputs: [people]
    params: {classes: [1]}
  - name: feature_count
    type: dslam::AdaptiveFeatureCount
    inputs: [people]
  - name: backend
    type: dslam::CeresBackend
)";

class Overlay : public ::testing::Test {
 protected:
  void SetUp() override {
    register_builtin_plugins();
    dir_ = test::tempDir("overlay");
    base_ = config::loadPipelineText(kBase, dir_).toYaml();
  }
  /** Applies the overlay written in YAML (as in a study file named study.yaml). */
  config::PipelineConfig apply(const std::string& overlay_yaml) {
    const auto ops = study::parseOverlay(overlay_yaml, dir_ + "/study.yaml");
    return config::loadPipelineText(study::applyOverlay(base_, dir_, ops), dir_);
  }
  std::string error(const std::string& overlay_yaml) {
    try {
      apply(overlay_yaml);
    } catch (const ConfigError& e) {
      return e.what();
    }
    ADD_FAILURE() << "no ConfigError for overlay:\n" << overlay_yaml;
    return "";
  }
  static std::vector<std::string> names(const config::PipelineConfig& pc) {
    std::vector<std::string> v;
    for (const auto& m : pc.modules) v.push_back(m.name);
    return v;
  }
  static const config::ModuleConfig& mod(const config::PipelineConfig& pc, const std::string& n) {
    for (const auto& m : pc.modules)
      if (m.name == n) return m;
    throw std::runtime_error("no module " + n);
  }
  std::string dir_, base_;
};

TEST_F(Overlay, EmptyOverlayKeepsThePipeline) {
  const auto pc = apply("[]");
  EXPECT_EQ(pc.toYaml(), config::loadPipelineText(base_, dir_).toYaml());
}

TEST_F(Overlay, SetSectionParameter) {
  const auto pc = apply("- set: {features.n_features: 2000, pipeline.seed: 7}\n");
  EXPECT_EQ(pc.sections.at("features").getInt("n_features"), 2000);
  EXPECT_EQ(pc.seed, 7u);
  // Everything else stays: the other features parameters keep their defaults.
  const auto base = config::loadPipelineText(base_, dir_);
  EXPECT_EQ(pc.sections.at("features").getDouble("scale_factor"), base.sections.at("features").getDouble("scale_factor"));
  EXPECT_EQ(names(pc), names(base));
}

TEST_F(Overlay, SetModuleParameterAndEnabled) {
  const auto pc = apply(
      "- set: {modules.box_filter.params.min_score: 0.3, modules.box_filter.params.classes: [1, 3]}\n"
      "- set: {modules.feature_count.enabled: false}\n");
  EXPECT_DOUBLE_EQ(mod(pc, "box_filter").params.getDouble("min_score"), 0.3);
  EXPECT_EQ(mod(pc, "box_filter").params.getIntList("classes"), (std::vector<int>{1, 3}));
  EXPECT_FALSE(mod(pc, "feature_count").enabled);
  EXPECT_TRUE(pc.modulesOf("KeypointClassifier").size() == 1);  // disabled modules do not run
}

TEST_F(Overlay, SetInsideAMapParameterMayAddAKey) {
  const auto pc = apply(
      "- add: {name: repop, type: dslam::DepthRepopulation, inputs: [people]}\n"
      "- set: {modules.repop.params.depth_margin.chair: 0.25}\n");
  const auto m = mod(pc, "repop").params.getDoubleMap("depth_margin");
  EXPECT_DOUBLE_EQ(m.at("chair"), 0.25);
  EXPECT_DOUBLE_EQ(m.at("person"), 0.5);  // the default entries stay
}

TEST_F(Overlay, SetPathParameterResolvesAgainstTheStudyFile) {
  const auto pc = apply("- set: {modules.people.params.dir: labels}\n");
  EXPECT_EQ(mod(pc, "people").params.getString("dir"), dir_ + "/labels");
}

TEST_F(Overlay, AddAtTheEndAfterAndBefore) {
  const auto end = apply("- add: {name: sem, type: dslam::SemanticFilter, inputs: [people]}\n");
  EXPECT_EQ(names(end), (std::vector<std::string>{"people", "box_filter", "feature_count", "backend", "sem"}));
  const auto after = apply("- add: {name: sem, type: dslam::SemanticFilter, after: people}\n");
  EXPECT_EQ(names(after), (std::vector<std::string>{"people", "sem", "box_filter", "feature_count", "backend"}));
  const auto before = apply(
      "- add:\n"
      "    name: repop\n"
      "    type: dslam::DepthRepopulation\n"
      "    inputs: [people]\n"
      "    params: {min_samples: 20}\n"
      "    before: box_filter\n");
  EXPECT_EQ(names(before), (std::vector<std::string>{"people", "repop", "box_filter", "feature_count", "backend"}));
  EXPECT_EQ(mod(before, "repop").params.getInt("min_samples"), 20);
  EXPECT_EQ(mod(before, "repop").inputs, (std::vector<std::string>{"people"}));
  EXPECT_EQ(mod(before, "repop").interface_name, "KeypointClassifier");
  // The classifier chain runs in list order.
  const auto chain = before.modulesOf("KeypointClassifier");
  ASSERT_EQ(chain.size(), 3u);
  EXPECT_EQ(chain[0]->name, "repop");
}

TEST_F(Overlay, RemoveOneOrSeveral) {
  EXPECT_EQ(names(apply("- remove: feature_count\n")), (std::vector<std::string>{"people", "box_filter", "backend"}));
  EXPECT_EQ(names(apply("- remove: [feature_count, box_filter]\n")), (std::vector<std::string>{"people", "backend"}));
}

TEST_F(Overlay, ReplaceKeepsNamePositionAndInputs) {
  const auto pc = apply("- replace: {module: box_filter, with: {type: dslam::SemanticFilter, params: {classes: [1, 2]}}}\n");
  EXPECT_EQ(names(pc), (std::vector<std::string>{"people", "box_filter", "feature_count", "backend"}));
  const auto& m = mod(pc, "box_filter");
  EXPECT_EQ(m.type, "dslam::SemanticFilter");
  EXPECT_EQ(m.inputs, (std::vector<std::string>{"people"}));
  EXPECT_EQ(m.params.getIntList("classes"), (std::vector<int>{1, 2}));
  EXPECT_FALSE(m.params.has("margin"));  // BoxFilter's parameters are gone
}

TEST_F(Overlay, OperationsApplyInOrder) {
  // A set after an add reaches the added module (its defaults were filled in).
  const auto pc = apply(
      "- add: {name: repop, type: dslam::DepthRepopulation, inputs: [people]}\n"
      "- set: {modules.repop.params.min_samples: 33}\n"
      "- remove: feature_count\n");
  EXPECT_EQ(mod(pc, "repop").params.getInt("min_samples"), 33);
  EXPECT_EQ(names(pc), (std::vector<std::string>{"people", "box_filter", "backend", "repop"}));
  // ... and a set before it cannot.
  const std::string e = error(
      "- set: {modules.repop.params.min_samples: 33}\n"
      "- add: {name: repop, type: dslam::DepthRepopulation}\n");
  EXPECT_NE(e.find("study.yaml:1:"), std::string::npos) << e;
  EXPECT_NE(e.find("no module 'repop'"), std::string::npos) << e;
}

TEST_F(Overlay, ErrorsNameFileLineAndKey) {
  struct Case {
    const char* overlay;
    std::vector<const char*> want;
  };
  const std::vector<Case> cases = {
      {"- set: {features.n_featurs: 2000}\n",
       {"study.yaml:1:", "'[0].set'", "'features.n_featurs'", "no parameter 'n_featurs'", "did you mean 'n_features'"}},
      {"- set: {modules.box_filtr.params.min_score: 0.3}\n",
       {"study.yaml:1:", "no module 'box_filtr'", "did you mean 'box_filter'", "modules: people, box_filter"}},
      {"- remove: feature_count\n- set: {modules.feature_count.enabled: false}\n",
       {"study.yaml:2:", "'[1].set'", "no module 'feature_count'"}},
      {"- set: {modules.box_filter.params.min_scor: 0.3}\n",
       {"study.yaml:1:", "no parameter 'min_scor' in module 'box_filter'", "did you mean 'min_score'"}},
      {"- set: {featurs.n_features: 2000}\n", {"study.yaml:1:", "no section 'featurs'", "did you mean 'features'"}},
      {"- set: {features.n_features: many}\n", {"study.yaml:1:", "after this 'set' is invalid", "n_features"}},
      {"- remove: [box_filter, nothing]\n", {"study.yaml:1:", "'[0].remove'", "no module 'nothing'"}},
      {"- remove: people\n", {"study.yaml:1:", "is invalid", "unknown module 'people'"}},
      {"- add: {name: box_filter, type: dslam::BoxFilter}\n", {"study.yaml:1:", "already has a module 'box_filter'"}},
      {"- add: {name: x, type: dslam::NoSuchClassifier}\n", {"study.yaml:1:", "dslam::NoSuchClassifier"}},
      {"- add: {name: x, type: dslam::BoxFilter, params: {marginn: 3}}\n",
       {"study.yaml:1:", "no parameter 'marginn' in dslam::BoxFilter", "did you mean 'margin'"}},
      {"- add: {name: x, type: dslam::BoxFilter, after: nobody}\n", {"study.yaml:1:", "no module 'nobody'"}},
      {"- add: {name: x, typ: dslam::BoxFilter}\n", {"study.yaml:1:", "unknown key 'typ'", "did you mean 'type'"}},
      {"- replace: {module: ghost, with: {type: dslam::BoxFilter}}\n", {"study.yaml:1:", "no module 'ghost'"}},
      {"- replace: {module: box_filter, with: {type: dslam::BoxFilter, name: other}}\n",
       {"study.yaml:1:", "keeps the name 'box_filter'"}},
      {"- sett: {features.n_features: 1}\n", {"study.yaml:1:", "unknown operation 'sett'", "did you mean 'set'"}},
  };
  for (const auto& c : cases) {
    const std::string e = error(c.overlay);
    for (const char* w : c.want) EXPECT_NE(e.find(w), std::string::npos) << "overlay:\n" << c.overlay << "error: " << e;
  }
}

TEST(YamlText, WriterRoundTripsValuesMrptsPrinterBreaks) {
  // Overlays edit YAML trees and write them back as text: every value must
  // survive (MRPT's own printer writes `b: x: y` and drops empty lists).
  const std::string src =
      "a: ''\nb: 'x: y'\nc: [1, 2]\nd: {person: 0.5, default: 0.5}\ne: dslam::Foo\nf: '#hash'\ng: []\nh: {}\n"
      "i: ~\nj: '  spaced'\nk: \"two\\nlines\"\nl: '-'\nm: [{name: x, params: {v: [3]}}, {name: 'a, b'}]\n";
  const auto y = mrpt::containers::yaml::FromText(src);
  const std::string text = yamlu::toYamlText(y);
  const auto y2 = mrpt::containers::yaml::FromText(text);
  EXPECT_EQ(yamlu::toYamlText(y2), text) << text;
  const auto& n = y2.node();
  auto str = [&](const char* k) { return yamlu::scalarText(*yamlu::findValue(n, k)).value_or("<none>"); };
  EXPECT_EQ(str("a"), "");
  EXPECT_EQ(str("b"), "x: y");
  EXPECT_EQ(str("f"), "#hash");
  EXPECT_EQ(str("j"), "  spaced");
  EXPECT_EQ(str("k"), "two\nlines");
  EXPECT_EQ(str("l"), "-");
  EXPECT_TRUE(yamlu::findValue(n, "g")->isSequence());
  EXPECT_TRUE(yamlu::findValue(n, "h")->isMap());
  EXPECT_TRUE(yamlu::findValue(n, "i")->isNullNode());
  const auto& m = yamlu::findValue(n, "m")->asSequence();
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(yamlu::scalarText(*yamlu::findValue(m[1], "name")).value_or(""), "a, b");
  EXPECT_EQ(yamlu::keysInOrder(n).front(), "a");  // file order kept
}

}  // namespace
