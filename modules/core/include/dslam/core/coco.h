#pragma once
/** \file coco.h
 *  COCO label set. dslam uses the official COCO category ids everywhere
 *  (person = 1, chair = 62, ...), the ids of the COCO panoptic format
 *  (things 1..90, stuff 92..200). Darknet/YOLO models number the 80 thing
 *  classes 0..79: cocoIdFromIndex80() converts. */
#include <string>
#include <vector>

namespace dslam::coco {

struct Category {
  int id;
  const char* name;
  bool isthing;
};

constexpr int kPerson = 1;
constexpr int kNone = 255;  ///< "no class" in semantic label images

/** All 133 COCO panoptic categories (80 things + 53 stuff). */
const std::vector<Category>& categories();
/** Category by id, or nullptr. */
const Category* find(int id);
/** Category id by name (COCO spelling, e.g. "dining table"), or -1. */
int idFromName(const std::string& name);
/** 80-class contiguous index (YOLO order) to COCO id; -1 if out of range. */
int cocoIdFromIndex80(int idx);
/** COCO id to YOLO index, or -1 for stuff/unknown ids. */
int index80FromCocoId(int id);
std::string name(int id);  ///< "unknown(<id>)" if not a COCO id
bool isThing(int id);

}  // namespace dslam::coco
