#include <gtest/gtest.h>

#include <mrpt/containers/yaml.h>

#include <cstdlib>

#include "dslam/config/pipeline.h"
#include "dslam/config/yaml_loader.h"
#include "dslam/core/error.h"
#include "dslam/core/paths.h"
#include "test_support.h"

using namespace dslam;

namespace {

/** The error of loading `text` as t.yaml; "" if it loads. */
std::string errorOf(const std::string& text) {
  try {
    config::loadYamlText(text, "t.yaml", "/tmp");
  } catch (const ConfigError& e) {
    return std::string(e.what());
  }
  return std::string();
}

}  // namespace

TEST(YamlLoader, EnvVariablesWithDefaults) {
  setenv("DSLAM_TEST_VAR", "from_env", 1);
  unsetenv("DSLAM_TEST_UNSET");
  const std::string t = config::expandVariables(
      "a: ${DSLAM_TEST_VAR}\nb: ${DSLAM_TEST_UNSET|fallback}\nc: x${DSLAM_TEST_VAR|d}y\n# ${NOT_EXPANDED}\n", "f.yaml");
  EXPECT_EQ(t, "a: from_env\nb: fallback\nc: xfrom_envy\n# ${NOT_EXPANDED}\n");
}

TEST(YamlLoader, UnsetVariableWithoutDefaultNamesFileAndLine) {
  unsetenv("DSLAM_TEST_UNSET");
  try {
    config::expandVariables("a: 1\nb: ${DSLAM_TEST_UNSET}\n", "cfg.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("cfg.yaml:2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("DSLAM_TEST_UNSET"), std::string::npos) << e.what();
  }
}

TEST(YamlLoader, VariablesCannotChangeTheStructure) {
  // Values are pasted into the text: a line break injected keys, " #" cut
  // the value silently, $include{} read any file into a value.
  auto errorOf = [](const char* value) {
    setenv("DSLAM_TEST_VALUE", value, 1);
    try {
      config::expandVariables("a: 1\nname: ${DSLAM_TEST_VALUE}\n", "cfg.yaml");
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(errorOf("x\nmode: parallel").find("cfg.yaml:2: environment variable 'DSLAM_TEST_VALUE' holds a line break"),
            std::string::npos);
  EXPECT_NE(errorOf("a # c").find("holds ' #'"), std::string::npos);
  EXPECT_NE(errorOf("$include{/etc/passwd}").find("holds $include{}"), std::string::npos);
  EXPECT_EQ(errorOf("/data/run#3, 10:30"), "");  // '#', ',' and ':' inside a plain value are fine
  unsetenv("DSLAM_TEST_VALUE");
}

TEST(YamlLoader, SharedDirBuiltinFollowsEnvironment) {
  setenv("DSLAM_SHARED_DIR", "/some/where", 1);
  EXPECT_EQ(config::expandVariables("p: ${DSLAM_SHARED_DIR}/x\n", "f"), "p: /some/where/x\n");
  unsetenv("DSLAM_SHARED_DIR");
  EXPECT_EQ(config::expandVariables("p: ${DSLAM_SHARED_DIR}\n", "f"), "p: " + sharedDir() + "\n");
}

TEST(YamlLoader, IncludesResolveRelativeAndRecursively) {
  const std::string d = test::tempDir("yaml");
  test::writeFile(d + "/main.yaml", "camera: $include{sub/cam.yaml}\nlist:\n  - $include{sub/item.yaml}\n");
  test::writeFile(d + "/sub/cam.yaml", "fx: 500\nextra: $include{more.yaml}\n");
  test::writeFile(d + "/sub/more.yaml", "deep: true\n");
  test::writeFile(d + "/sub/item.yaml", "name: it\n");
  const auto ly = config::loadYamlFile(d + "/main.yaml");
  const auto& r = *ly.root;
  EXPECT_EQ(r["camera"]["fx"].as<int>(), 500);
  EXPECT_EQ(r["camera"]["extra"]["deep"].as<std::string>(), "true");
  EXPECT_EQ(r["list"].asSequence().at(0).asMap().begin()->second.as<std::string>(), "it");
  EXPECT_EQ(ly.fileFor("camera.fx"), d + "/sub/cam.yaml");
  EXPECT_EQ(ly.fileFor("camera.extra.deep"), d + "/sub/more.yaml");
  EXPECT_EQ(ly.fileFor("other"), d + "/main.yaml");
}

TEST(YamlLoader, IncludeCycleAndMissingIncludeAreErrors) {
  const std::string d = test::tempDir("yaml");
  test::writeFile(d + "/a.yaml", "x: $include{b.yaml}\n");
  test::writeFile(d + "/b.yaml", "y: $include{a.yaml}\n");
  try {
    config::loadYamlFile(d + "/a.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("include cycle"), std::string::npos) << e.what();
  }
  test::writeFile(d + "/c.yaml", "a: 1\nz: $include{nope.yaml}\n");
  try {
    config::loadYamlFile(d + "/c.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("c.yaml:2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("nope.yaml"), std::string::npos) << e.what();
  }
  EXPECT_THROW(config::loadYamlFile(d + "/missing.yaml"), DataError);
}

TEST(YamlLoader, IncludeCycleBelowTheTopLevelIsAnError) {
  // top.yaml -> a.yaml -> b.yaml -> a.yaml: this recursed until the stack overflowed.
  const std::string d = test::tempDir("yaml");
  test::writeFile(d + "/a.yaml", "fx: $include{b.yaml}\n");
  test::writeFile(d + "/b.yaml", "fx: $include{a.yaml}\n");
  test::writeFile(d + "/top.yaml", "camera: $include{a.yaml}\n");
  try {
    config::loadYamlFile(d + "/top.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("include cycle: " + d + "/a.yaml includes itself"), std::string::npos)
        << e.what();
  }
}

TEST(YamlLoader, IncludeChainsAndFanOutAreBounded) {
  // 20,000 files each including the next overflowed the stack; 20 files
  // each including the next twice expanded 2^20 times (out of memory).
  auto errorOf = [](const std::string& top) {
    try {
      config::loadYamlFile(top);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string d = test::tempDir("yaml_chain");
  for (int i = 0; i < 100; i++) test::writeFile(d + "/c" + std::to_string(i) + ".yaml", "$include{c" + std::to_string(i + 1) + ".yaml}\n");
  test::writeFile(d + "/c100.yaml", "{fx: 500}\n");
  test::writeFile(d + "/top.yaml", "camera: $include{c0.yaml}\n");
  EXPECT_NE(errorOf(d + "/top.yaml").find("c63.yaml:1: key 'camera': $include{} nested more than 64 files deep"),
            std::string::npos);
  test::writeFile(d + "/top.yaml", "camera: $include{c60.yaml}\n");  // 41 deep: fine
  EXPECT_EQ(errorOf(d + "/top.yaml"), "");
  const std::string f = test::tempDir("yaml_fanout");
  for (int i = 0; i < 20; i++)
    test::writeFile(f + "/f" + std::to_string(i) + ".yaml", "a: $include{f" + std::to_string(i + 1) + ".yaml}\nb: $include{f" +
                                                                std::to_string(i + 1) + ".yaml}\n");
  test::writeFile(f + "/f20.yaml", "x: 1\n");
  test::writeFile(f + "/top.yaml", "camera: $include{f0.yaml}\n");
  EXPECT_NE(errorOf(f + "/top.yaml").find("more than 1000 $include{} expansions in all"), std::string::npos);
  test::writeFile(f + "/top.yaml", "camera: $include{f12.yaml}\n");  // 2^9 - 1 = 511 expansions: fine
  EXPECT_EQ(errorOf(f + "/top.yaml"), "");
}

TEST(YamlLoader, EmptyValuesAreNullAsInYaml) {
  // MRPT's parser rejects empty values ("Unexpected empty scalar", no line).
  const auto y = config::loadYamlText(
      "tracking:\n#  min_inliers: 20\nlist:\n-\n- 3\nnested:\n  - name: a\n    params:\ntext: |\n  a:\n  b:\n"
      "seq:\n- x\nlast:",
      "t.yaml", "/tmp");
  const auto& r = *y.root;
  EXPECT_TRUE(r["tracking"].isNullNode());
  EXPECT_TRUE(r["list"](0).isNullNode());
  EXPECT_EQ(r["list"](1).as<int>(), 3);
  EXPECT_TRUE(r["nested"](0)["params"].isNullNode());
  EXPECT_EQ(r["text"].as<std::string>(), "a:\nb:\n");  // a block scalar is left alone
  EXPECT_EQ(r["seq"](0).as<std::string>(), "x");   // a sequence at the key's indentation is its value
  EXPECT_TRUE(r["last"].isNullNode());
  // Where a null is not allowed, the error names file, line and key.
  try {
    config::loadPipelineText("pipeline: {name: x}\nmodules:\n  -\n", "/cfg");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(":3: key 'modules[0]'"), std::string::npos) << e.what();
  }
}

TEST(YamlLoader, AKeyTwiceInOneMapIsAnError) {
  // MRPT kept the last one silently: `pipeline:` twice ran the second.
  EXPECT_NE(errorOf("pipeline:\n  name: a\npipeline:\n  name: b\n")
                .find("t.yaml:3: key 'pipeline' appears twice in the same map (first on line 1)"),
            std::string::npos);
  EXPECT_NE(errorOf("f:\n  n: 1\n  # n: 2\n  m: 2\n  n: 3\n").find("t.yaml:5: key 'n'"), std::string::npos);
  EXPECT_NE(errorOf("modules:\n  - name: a\n    type: x\n    type: y\n").find("t.yaml:4: key 'type'"),
            std::string::npos);
  // The same key in sibling maps, in the items of a list, or in a block scalar is fine.
  EXPECT_EQ(errorOf("a:\n  n: 1\nb:\n  n: 1\nl:\n  - name: x\n    n: 1\n  - name: y\n    n: 2\n"
                    "t: |\n  n: 1\n  n: 2\n"),
            "");
  // Flow maps {...}, also over several lines and inside lists.
  EXPECT_NE(errorOf("params: {classes: [1], classes: [2]}\n")
                .find("t.yaml:1: key 'classes' appears twice in the same {...} map"),
            std::string::npos);
  EXPECT_NE(errorOf("p:\n  - {a: 1,\n     b: 2, \"a\": 3}\n").find("t.yaml:3: key 'a' appears twice in the same {...} map "
                                                              "(first on line 2)"),
            std::string::npos);
  EXPECT_NE(errorOf("p: [{a: 1}, {b: {c: 1, c: 2}}]\n").find("key 'c'"), std::string::npos);
  // Sibling flow maps, a comma or colon inside quotes, an apostrophe in a
  // plain scalar and ${ENV|default} values are fine.
  EXPECT_EQ(errorOf("p: [{a: 1}, {a: 2}]\nq: {a: {n: 1}, b: {n: 2}}\nr: {s: \"x, a: 2\", a: 1}\n"
                    "u: {s: don't, a: 1}\nv: {a: ${X|1}, b: ${X|1}}\nw: {a: 1,\n   b: 2}\nx: {a: 1}\n"),
            "");
}

TEST(YamlLoader, StructureTheParserDoesNotReport) {
  // NUL bytes cut the file silently, a second document was ignored,
  // anchors and non-scalar keys gave "==== MRPT exception ====", nesting
  // of about 10,000 levels overflowed the stack.
  EXPECT_NE(errorOf(std::string("a: 1\n\0b: 2\n", 12)).find("t.yaml:2: a NUL byte"), std::string::npos);
  EXPECT_NE(errorOf("a: 1\n---\nb: 2\n").find("t.yaml:2: a second YAML document"), std::string::npos);
  EXPECT_NE(errorOf("a: 1\n...\nb: 2\n").find("t.yaml:3: text after the end of the YAML document"), std::string::npos);
  EXPECT_NE(errorOf("a: &x 1\n").find("t.yaml:1: YAML anchors (&name)"), std::string::npos);
  EXPECT_NE(errorOf("a: 1\nb: [*x]\n").find("t.yaml:2: YAML aliases (*name)"), std::string::npos);
  EXPECT_NE(errorOf("a: {{b: 1}: 2}\n").find("a map key that is not a plain value"), std::string::npos);
  EXPECT_NE(errorOf("a: " + std::string(300, '[') + std::string(300, ']') + "\n").find("t.yaml:1: nested more than 256"),
            std::string::npos);
  std::string deep;  // block nesting
  for (int i = 0; i < 300; i++) deep += std::string(static_cast<size_t>(i), ' ') + "k:\n";
  EXPECT_NE(errorOf(deep).find("nested more than 256 levels deep"), std::string::npos);
  // Document markers around the one document, '&' and '*' inside values and quotes, 200 levels: fine.
  EXPECT_EQ(errorOf("---\na: 1\nb: \"&x *y\"\nc: a&b\nd: 2 * 3\nn: use *bold* & more\ne: " + std::string(200, '[') + std::string(200, ']') +
                    "\nt: |\n  ---\n  &z\n...\n"),
            "");
}

TEST(YamlLoader, NoShellExecution) {
  // $(...) and backticks are plain text: nothing is executed.
  const std::string d = test::tempDir("yaml");
  const std::string marker = d + "/executed";
  test::writeFile(d + "/a.yaml", "x: \"$(touch " + marker + ")\"\ny: \"`touch " + marker + "`\"\n");
  const auto ly = config::loadYamlFile(d + "/a.yaml");
  EXPECT_FALSE(fileExists(marker));
  EXPECT_EQ((*ly.root)["x"].as<std::string>(), "$(touch " + marker + ")");
}

TEST(YamlLoader, SyntaxErrorsNameFileLineAndColumn) {
  // libfyaml prints an unclosed flow sequence to stderr and returns a partial
  // document: the loader must still report it as a syntax error.
  const std::string d = test::tempDir("yaml");
  test::writeFile(d + "/open.yaml", "pipeline:\n  name: x\n  a: [\n");
  try {
    config::loadYamlFile(d + "/open.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(d + "/open.yaml:4:1: YAML syntax error: flow sequence without a closing bracket"),
              std::string::npos) << m;
  }
  test::writeFile(d + "/map.yaml", "a: {b: 1\nc: 2\n");
  try {
    config::loadYamlFile(d + "/map.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(d + "/map.yaml:"), std::string::npos) << m;
    EXPECT_NE(m.find("YAML syntax error"), std::string::npos) << m;
  }
}

TEST(YamlLoader, ErrorsQuoteAShortExcerptNotTheWholeValue) {
  // `camera: $include{/etc/passwd}` used to print the included file.
  const std::string d = test::tempDir("yaml");
  std::string big;
  for (int i = 0; i < 200; i++) big += "secret line " + std::to_string(i) + " with some text\n";
  test::writeFile(d + "/not_yaml.txt", big);
  test::writeFile(d + "/p.yaml", "pipeline:\n  name: x\ncamera: $include{not_yaml.txt}\n");
  try {
    config::loadPipeline(d + "/p.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_LT(m.size(), 400u) << m;
    EXPECT_EQ(m.find("secret line 5 "), std::string::npos) << m;
    EXPECT_NE(m.find("characters)"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
}

// Fuzzing (tests/fuzz): a long `$include{...}` scalar or `${VAR|default}`
// used to overflow the stack in std::regex; text that is not UTF-8 made
// libfyaml loop forever.
TEST(YamlLoader, LongIncludeAndVariableLinesDoNotOverflowTheStack) {
  unsetenv("DSLAM_TEST_UNSET");
  const std::string longs(400000, 'a');
  EXPECT_EQ(config::expandVariables("x: ${DSLAM_TEST_UNSET|" + longs + "}\n", "f.yaml"), "x: " + longs + "\n");
  EXPECT_EQ(config::expandVariables("x: ${" + longs, "f.yaml"), "x: ${" + longs + "\n");
  EXPECT_EQ(config::expandVariables("$ ${ ${1} $${DSLAM_TEST_UNSET|b}}\n", "f.yaml"), "$ ${ ${1} $b}\n");
  try {
    config::loadYamlText("camera: $include{" + longs + "}\n", "big.yaml", test::tempDir("yaml_long"));
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("included file not found"), std::string::npos) << std::string(e.what()).substr(0, 200);
  }
}

TEST(YamlLoader, InvalidUtf8IsRefusedBeforeParsing) {
  for (const std::string bad : {"%\x80\na: 1\n", "a: 1\nb: \xC0\xAF\n", "a: \xED\xA0\x80\n", "a: \xF4\x90\x80\x80\n", "a: \xE2\x82"}) {
    try {
      config::loadYamlText(bad, "bad.yaml", ".");
      FAIL() << bad;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("bad.yaml:"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("not valid UTF-8"), std::string::npos) << e.what();
    }
  }
  // Valid multi-byte text still loads.
  const auto ly = config::loadYamlText("name: \"caf\xC3\xA9 \xE2\x82\xAC \xF0\x9F\x98\x80\"\n", "ok.yaml", ".");
  EXPECT_TRUE(ly.root->isMap());
}
