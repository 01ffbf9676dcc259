// The one rotation-consistency check (matcher and classifiers): 12-degree
// bins, the three fullest kept, the 2nd/3rd only with >= 10% of the first.
#include <gtest/gtest.h>

#include "dslam/features/rotation_histogram.h"

using namespace dslam;

TEST(RotationHistogram, BinsAre360OverBinsDegreesWide) {
  EXPECT_EQ(rotationBin(0.f, 30), 0);
  EXPECT_EQ(rotationBin(5.9f, 30), 0);    // round(0.49)
  EXPECT_EQ(rotationBin(6.1f, 30), 1);    // round(0.51)
  EXPECT_EQ(rotationBin(24.f, 30), 2);
  EXPECT_EQ(rotationBin(359.f, 30), 0);   // round(29.9) = 30 wraps to 0
  EXPECT_EQ(rotationBin(-12.f, 30), 29);  // -12 = 348 degrees
  EXPECT_EQ(rotationBin(720.f + 24.f, 30), 2);
  EXPECT_EQ(rotationBin(90.f, 4), 1);     // other bin counts: 90-degree bins
}

TEST(RotationHistogram, KeepsTheThreeFullestBins) {
  std::vector<float> d;
  for (int i = 0; i < 20; i++) d.push_back(1.f);    // bin 0: 20
  for (int i = 0; i < 10; i++) d.push_back(13.f);   // bin 1: 10
  for (int i = 0; i < 5; i++) d.push_back(25.f);    // bin 2: 5
  for (int i = 0; i < 4; i++) d.push_back(180.f);   // bin 15: 4 (fourth)
  const auto keep = rotationConsistent(d);
  ASSERT_EQ(keep.size(), d.size());
  for (size_t k = 0; k < 35; k++) EXPECT_TRUE(keep[k]) << k;
  for (size_t k = 35; k < d.size(); k++) EXPECT_FALSE(keep[k]) << k;
}

TEST(RotationHistogram, SmallBinsBelowTenPercentAreDropped) {
  std::vector<float> d(100, 90.f);  // bin 8: 100
  d.push_back(200.f);               // 1% each: dropped
  d.push_back(300.f);
  const auto keep = rotationConsistent(d);
  for (size_t k = 0; k < 100; k++) EXPECT_TRUE(keep[k]);
  EXPECT_FALSE(keep[100]);
  EXPECT_FALSE(keep[101]);

  int i1, i2, i3;
  threeMaxima({{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11}, {1}, {}}, i1, i2, i3);
  EXPECT_EQ(i1, 0);
  EXPECT_EQ(i2, -1);  // 1 < 10% of 11
  EXPECT_EQ(i3, -1);
  threeMaxima({{1, 2, 3, 4, 5, 6, 7, 8, 9, 10}, {1}, {2, 3}}, i1, i2, i3);
  EXPECT_EQ(i1, 0);
  EXPECT_EQ(i2, 2);
  EXPECT_EQ(i3, 1);  // exactly 10% of the first is kept
}

TEST(RotationHistogram, EmptyInputKeepsNothingToDrop) {
  EXPECT_TRUE(rotationConsistent({}).empty());
  const auto keep = rotationConsistent({42.f});
  ASSERT_EQ(keep.size(), 1u);
  EXPECT_TRUE(keep[0]);
}
