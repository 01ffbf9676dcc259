// `dslam detect` end to end (needs the dslam executable and ../shared).
#include <gtest/gtest.h>

#include <filesystem>

#include <nlohmann/json.hpp>

#include <set>

#include "test_support.h"

using dslam::test::runDslam;

TEST(DetectCli, PrintsDetectionsAsTextAndJson) {
  const std::string img = dslam::test::shared("data/images/person.jpg");
  if (img.empty()) GTEST_SKIP();
  auto r = runDslam("detect YoloxOnnxDetector " + img);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("3 boxes"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("horse"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(" ms"), std::string::npos) << r.out;

  const std::string out = dslam::test::tempDir("detect_cli") + "/annotated.png";
  r = runDslam("detect dslam::DarknetYoloDetector " + img + " --json --param model=yolo-fastest-coco -p classes=[1] --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  // One JSON object per image on stdout (log lines go to stderr, merged here).
  const size_t brace = r.out.find("{\"image\"");
  ASSERT_NE(brace, std::string::npos) << r.out;
  const auto j = nlohmann::json::parse(r.out.substr(brace, r.out.find('\n', brace) - brace));
  EXPECT_GT(j.at("latency_ms").get<double>(), 0.0);
  std::set<int> cats;
  for (const auto& b : j.at("detections").at("boxes")) cats.insert(b.at("category_id").get<int>());
  EXPECT_TRUE(cats.count(1)) << r.out;
  EXPECT_FALSE(cats.count(18)) << r.out;  // filtered out
  EXPECT_TRUE(std::filesystem::exists(out));
}

TEST(DetectCli, ErrorsAreReported) {
  const std::string img = dslam::test::shared("data/images/person.jpg");
  if (img.empty()) GTEST_SKIP();
  auto r = runDslam("detect DarknetYoloDetector " + img + " --param weights=/nonexistent/x.weights");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("error: "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("/nonexistent/x.weights"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("download_models.sh"), std::string::npos) << r.out;
  r = runDslam("detect DarknetYoloDetector " + img + " --param confidnce=0.3");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("confidence"), std::string::npos) << r.out;  // did-you-mean
  r = runDslam("detect NoSuchDetector " + img);
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("DarknetYoloDetector"), std::string::npos) << r.out;  // lists valid names
  r = runDslam("detect HogPeopleDetector /nonexistent/img.png");
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_NE(r.out.find("/nonexistent/img.png"), std::string::npos) << r.out;
}
