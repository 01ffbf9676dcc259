#include <gtest/gtest.h>

#include <fstream>

#include "dslam/core/timing.h"
#include "test_support.h"

using namespace dslam;

TEST(Timing, MedianOddEvenEmpty) {
  EXPECT_DOUBLE_EQ(median({}), 0.0);
  EXPECT_DOUBLE_EQ(median({3, 1, 2}), 2.0);
  EXPECT_DOUBLE_EQ(median({4, 1, 3, 2}), 2.5);
}

TEST(Timing, StatsAndCsv) {
  StageTimer t;
  t.add("orb", 0, 5.0);
  t.add("orb", 1, 7.0);
  t.add("orb", 2, 6.0);
  t.add("track", 1, 2.0);
  t.add("track", 1, 1.0);  // same frame twice: summed in the CSV
  const StageStats s = t.stats("orb");
  EXPECT_EQ(s.count, 3u);
  EXPECT_DOUBLE_EQ(s.median_ms, 6.0);
  EXPECT_DOUBLE_EQ(s.mean_ms, 6.0);
  EXPECT_DOUBLE_EQ(s.max_ms, 7.0);
  EXPECT_EQ(t.stages(), std::vector<std::string>({"orb", "track"}));
  const std::string f = test::tempDir("timing") + "/t.csv";
  t.writeCsv(f);
  const std::string csv = test::readFile(f);
  EXPECT_NE(csv.find("frame,orb_ms,track_ms\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find("0,5.0000,\n"), std::string::npos) << csv;
  EXPECT_NE(csv.find("1,7.0000,3.0000\n"), std::string::npos) << csv;
}
