#include <gtest/gtest.h>

#include <cstdlib>

#include "dslam/core/dataset.h"
#include "dslam/core/detector.h"
#include "dslam/core/error.h"
#include "dslam/core/keypoint_classifier.h"
#include "dslam/core/registry.h"

using namespace dslam;

TEST(Registry, CreatesTypedPluginByName) {
  register_builtin_plugins();
  auto ds = create<DatasetSource>("dslam::TumDataset");
  ASSERT_TRUE(ds);
  EXPECT_STREQ(ds->interfaceName(), "DatasetSource");
  EXPECT_FALSE(ds->paramSpecs().empty());
}

TEST(Registry, UnknownNameListsValidOnesForThatInterface) {
  register_builtin_plugins();
  try {
    create<DatasetSource>("dslam::TumDatset");
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("unknown plugin type 'dslam::TumDatset'"), std::string::npos) << m;
    EXPECT_NE(m.find("did you mean 'dslam::TumDataset'"), std::string::npos) << m;
    EXPECT_NE(m.find("valid DatasetSource plugins:"), std::string::npos) << m;
    EXPECT_NE(m.find("dslam::BonnDataset"), std::string::npos) << m;
  }
}

TEST(Registry, WrongInterfaceIsRejected) {
  register_builtin_plugins();
  try {
    create<Detector>("dslam::TumDataset");
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("is not a Detector"), std::string::npos) << e.what();
  }
}

TEST(Registry, ListIsSortedAndHasParams) {
  register_builtin_plugins();
  const auto all = listPlugins();
  ASSERT_FALSE(all.empty());
  for (size_t i = 1; i < all.size(); i++)
    EXPECT_LE(std::tie(all[i - 1].interface_name, all[i - 1].name), std::tie(all[i].interface_name, all[i].name));
  const auto ds = listPlugins("DatasetSource");
  ASSERT_FALSE(ds.empty());
  for (const auto& p : ds) EXPECT_EQ(p.interface_name, "DatasetSource");
}

TEST(Registry, LoadsExternalPluginLibrary) {
  register_builtin_plugins();
  EXPECT_THROW(create<KeypointClassifier>("dslam_ext::MarkAllDynamic"), ConfigError);
  EXPECT_EQ(loadExternalPlugins({DSLAM_TEST_EXT_PLUGIN_DIR}), 1u);
  EXPECT_EQ(loadExternalPlugins({DSLAM_TEST_EXT_PLUGIN_DIR}), 0u);  // already loaded
  auto c = create<KeypointClassifier>("dslam_ext::MarkAllDynamic");
  ASSERT_TRUE(c);
  Frame f;
  f.keypoints.resize(3);
  f.resetMeta();
  c->classify(f, Detections{}, ClassifierContext{});
  EXPECT_EQ(f.countLabel(KpLabel::Dynamic), 3u);
  EXPECT_FALSE(f.usable(0));
}

TEST(Registry, MissingPluginDirIsAnError) {
  EXPECT_THROW(loadExternalPlugins({"/nonexistent/dslam/plugins"}), DataError);
}
