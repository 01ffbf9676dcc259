#include <gtest/gtest.h>

#include "dslam/core/error.h"
#include "dslam/core/params.h"

using namespace dslam;

namespace {
std::vector<ParamSpec> specs() {
  return {P_double("confidence", 0.2, "score threshold", 0.0, 1.0),
          P_int("input_size", 320, "network input", 32),
          P_bool("swap_rb", true, "swap channels"),
          P_enum("mode", "boxes", {"boxes", "masks"}, "output"),
          P_list("classes", ParamType::IntList, "[1]", "COCO ids"),
          P_map("sigma_a", "{person: 0.5, chair: 0.02}", "per-class noise"),
          P_required("model", ParamType::Path, "weights file")};
}
std::string errorOf(const std::string& yaml) {
  try {
    Params::resolve(specs(), yaml, "/base");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(Params, DefaultsFilledAndGivenValuesKept) {
  const Params p = Params::resolve(specs(), "model: m.weights\nconfidence: 0.35\n", "/base");
  EXPECT_DOUBLE_EQ(p.getDouble("confidence"), 0.35);
  EXPECT_EQ(p.getInt("input_size"), 320);
  EXPECT_TRUE(p.getBool("swap_rb"));
  EXPECT_EQ(p.getString("mode"), "boxes");
  EXPECT_EQ(p.getIntList("classes"), std::vector<int>({1}));
  EXPECT_DOUBLE_EQ(p.getDoubleMap("sigma_a").at("chair"), 0.02);
  EXPECT_EQ(p.getString("model"), "/base/m.weights");  // paths resolve against the config folder
  EXPECT_TRUE(p.isGiven("confidence"));
  EXPECT_FALSE(p.isGiven("input_size"));
}

TEST(Params, UnknownKeyNamesTheValidOnes) {
  const std::string e = errorOf("model: x\nconfidnce: 0.3\n");
  EXPECT_NE(e.find("confidnce"), std::string::npos) << e;
  EXPECT_NE(e.find("did you mean 'confidence'"), std::string::npos) << e;
  EXPECT_NE(e.find("valid: confidence, input_size, swap_rb, mode, classes, sigma_a, model"), std::string::npos) << e;
  EXPECT_NE(e.find(":2:"), std::string::npos) << "line number expected: " << e;
}

TEST(Params, WrongTypesAndRangesAreErrors) {
  EXPECT_NE(errorOf("model: x\ninput_size: 3.5\n").find("expected an integer"), std::string::npos);
  EXPECT_NE(errorOf("model: x\nconfidence: high\n").find("expected a number"), std::string::npos);
  EXPECT_NE(errorOf("model: x\nconfidence: 1.5\n").find("out of range"), std::string::npos);
  EXPECT_NE(errorOf("model: x\nswap_rb: maybe\n").find("expected bool"), std::string::npos);
  EXPECT_NE(errorOf("model: x\nmode: polygons\n").find("valid: boxes, masks"), std::string::npos);
  EXPECT_NE(errorOf("model: x\nclasses: [1, two]\n").find("element 1"), std::string::npos);
  EXPECT_NE(errorOf("model: x\nsigma_a: {person: fast}\n").find("entry 'person'"), std::string::npos);
  EXPECT_NE(errorOf("model: [a, b]\n").find("expected string"), std::string::npos);
}

TEST(Params, MissingRequiredKey) {
  const std::string e = errorOf("confidence: 0.3\n");
  EXPECT_NE(e.find("missing required parameter"), std::string::npos) << e;
  EXPECT_NE(e.find("'model'"), std::string::npos) << e;
}

TEST(Params, YamlTextKeepsDeclarationOrderAndReparses) {
  const Params p = Params::resolve(specs(), "model: m\n", "");
  const std::string t = p.toYamlText();
  EXPECT_LT(t.find("confidence"), t.find("input_size"));
  EXPECT_LT(t.find("input_size"), t.find("model"));
  const Params q = Params::resolve(specs(), t, "");
  EXPECT_EQ(q.toYamlText(), t);
}

TEST(Params, SetOverridesValue) {
  Params p = Params::resolve(specs(), "model: m\n", "");
  p.set("confidence", "0.9");
  EXPECT_DOUBLE_EQ(p.getDouble("confidence"), 0.9);
  EXPECT_THROW(p.getDouble("not_declared"), ConfigError);
}
