#include <gtest/gtest.h>

#include "dslam/core/coco.h"

using namespace dslam;

TEST(Coco, PanopticCategoryTable) {
  const auto& c = coco::categories();
  EXPECT_EQ(c.size(), 133u);
  size_t things = 0;
  for (const auto& x : c) things += x.isthing;
  EXPECT_EQ(things, 80u);
  EXPECT_EQ(coco::idFromName("person"), 1);
  EXPECT_EQ(coco::idFromName("chair"), 62);
  EXPECT_EQ(coco::idFromName("wall-other-merged"), 199);
  EXPECT_FALSE(coco::isThing(199));
  EXPECT_TRUE(coco::isThing(62));
}

TEST(Coco, Yolo80IndexMapping) {
  EXPECT_EQ(coco::cocoIdFromIndex80(0), 1);    // person
  EXPECT_EQ(coco::cocoIdFromIndex80(16), 18);  // dog
  EXPECT_EQ(coco::cocoIdFromIndex80(17), 19);  // horse
  EXPECT_EQ(coco::cocoIdFromIndex80(56), 62);  // chair
  EXPECT_EQ(coco::cocoIdFromIndex80(79), 90);  // toothbrush
  EXPECT_EQ(coco::cocoIdFromIndex80(80), -1);
  for (int i = 0; i < 80; i++) EXPECT_EQ(coco::index80FromCocoId(coco::cocoIdFromIndex80(i)), i);
  EXPECT_EQ(coco::index80FromCocoId(199), -1);
  EXPECT_EQ(coco::name(12), "unknown(12)");
}
