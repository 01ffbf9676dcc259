// COCO panoptic categories (ids and names as in the COCO panoptic
// annotations, panoptic_coco_categories.json).
#include "dslam/core/coco.h"

#include <algorithm>
#include <iterator>

namespace dslam::coco {

namespace {

/** The table (id, name, isthing) in COCO panoptic order; constant-initialised,
 *  so it is usable during static initialisation of other files. */
constexpr Category kCategories[] = {
    {1, "person", true},
    {2, "bicycle", true},
    {3, "car", true},
    {4, "motorcycle", true},
    {5, "airplane", true},
    {6, "bus", true},
    {7, "train", true},
    {8, "truck", true},
    {9, "boat", true},
    {10, "traffic light", true},
    {11, "fire hydrant", true},
    {13, "stop sign", true},
    {14, "parking meter", true},
    {15, "bench", true},
    {16, "bird", true},
    {17, "cat", true},
    {18, "dog", true},
    {19, "horse", true},
    {20, "sheep", true},
    {21, "cow", true},
    {22, "elephant", true},
    {23, "bear", true},
    {24, "zebra", true},
    {25, "giraffe", true},
    {27, "backpack", true},
    {28, "umbrella", true},
    {31, "handbag", true},
    {32, "tie", true},
    {33, "suitcase", true},
    {34, "frisbee", true},
    {35, "skis", true},
    {36, "snowboard", true},
    {37, "sports ball", true},
    {38, "kite", true},
    {39, "baseball bat", true},
    {40, "baseball glove", true},
    {41, "skateboard", true},
    {42, "surfboard", true},
    {43, "tennis racket", true},
    {44, "bottle", true},
    {46, "wine glass", true},
    {47, "cup", true},
    {48, "fork", true},
    {49, "knife", true},
    {50, "spoon", true},
    {51, "bowl", true},
    {52, "banana", true},
    {53, "apple", true},
    {54, "sandwich", true},
    {55, "orange", true},
    {56, "broccoli", true},
    {57, "carrot", true},
    {58, "hot dog", true},
    {59, "pizza", true},
    {60, "donut", true},
    {61, "cake", true},
    {62, "chair", true},
    {63, "couch", true},
    {64, "potted plant", true},
    {65, "bed", true},
    {67, "dining table", true},
    {70, "toilet", true},
    {72, "tv", true},
    {73, "laptop", true},
    {74, "mouse", true},
    {75, "remote", true},
    {76, "keyboard", true},
    {77, "cell phone", true},
    {78, "microwave", true},
    {79, "oven", true},
    {80, "toaster", true},
    {81, "sink", true},
    {82, "refrigerator", true},
    {84, "book", true},
    {85, "clock", true},
    {86, "vase", true},
    {87, "scissors", true},
    {88, "teddy bear", true},
    {89, "hair drier", true},
    {90, "toothbrush", true},
    {92, "banner", false},
    {93, "blanket", false},
    {95, "bridge", false},
    {100, "cardboard", false},
    {107, "counter", false},
    {109, "curtain", false},
    {112, "door-stuff", false},
    {118, "floor-wood", false},
    {119, "flower", false},
    {122, "fruit", false},
    {125, "gravel", false},
    {128, "house", false},
    {130, "light", false},
    {133, "mirror-stuff", false},
    {138, "net", false},
    {141, "pillow", false},
    {144, "platform", false},
    {145, "playingfield", false},
    {147, "railroad", false},
    {148, "river", false},
    {149, "road", false},
    {151, "roof", false},
    {154, "sand", false},
    {155, "sea", false},
    {156, "shelf", false},
    {159, "snow", false},
    {161, "stairs", false},
    {166, "tent", false},
    {168, "towel", false},
    {171, "wall-brick", false},
    {175, "wall-stone", false},
    {176, "wall-tile", false},
    {177, "wall-wood", false},
    {178, "water-other", false},
    {180, "window-blind", false},
    {181, "window-other", false},
    {184, "tree-merged", false},
    {185, "fence-merged", false},
    {186, "ceiling-merged", false},
    {187, "sky-other-merged", false},
    {188, "cabinet-merged", false},
    {189, "table-merged", false},
    {190, "floor-other-merged", false},
    {191, "pavement-merged", false},
    {192, "mountain-merged", false},
    {193, "grass-merged", false},
    {194, "dirt-merged", false},
    {195, "paper-merged", false},
    {196, "food-other-merged", false},
    {197, "building-other-merged", false},
    {198, "rock-merged", false},
    {199, "wall-other-merged", false},
    {200, "rug-merged", false},
};

}  // namespace

const std::vector<Category>& categories() {
  static const std::vector<Category> cats(std::begin(kCategories), std::end(kCategories));
  return cats;
}

const Category* find(int id) {
  for (const auto& c : categories())
    if (c.id == id) return &c;
  return nullptr;
}

int idFromName(const std::string& name) {
  for (const auto& c : categories())
    if (name == c.name) return c.id;
  return -1;
}

int cocoIdFromIndex80(int idx) {
  const auto& cats = categories();
  if (idx < 0 || idx >= 80) return -1;
  return cats[static_cast<size_t>(idx)].id;
}

int index80FromCocoId(int id) {
  const auto& cats = categories();
  for (size_t i = 0; i < 80; i++)
    if (cats[i].id == id) return static_cast<int>(i);
  return -1;
}

std::string name(int id) {
  const Category* c = find(id);
  return c ? std::string(c->name) : "unknown(" + std::to_string(id) + ")";
}

bool isThing(int id) {
  const Category* c = find(id);
  return c && c->isthing;
}

}  // namespace dslam::coco
