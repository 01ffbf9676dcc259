#include <string>

#include "dslam/config/pipeline.h"
#include "dslam/core/coco.h"
#include "dslam/dense/dense_map.h"

namespace dslam::dense {

std::vector<ParamSpec> DenseMapParams::specs() {
  const DenseMapParams d;
  return {
      P_double("resolution", d.resolution, "voxel edge of the OctoMap (m)", 0.005, 10),
      P_double("max_range", d.max_range,
               "depths farther than this are not integrated; their rays clear free space up to it (m)", 0.1, 1000),
      P_double("min_range", d.min_range, "nearer depths are ignored (m)", 0, 100),
      P_int("pixel_step", d.pixel_step, "integrate every n-th pixel in x and y (1 = every pixel)", 1, 64),
      P_enum("colour", d.colour, {"image", "height", "none"},
             "voxel colour in dense.ply: the image colour averaged per voxel, a height colour map, or none"),
      P_bool("mask", d.mask, "drop dynamic pixels (false: integrate everything, the comparison baseline)"),
      P_list("classes", ParamType::IntList, "[1]",
             "COCO ids whose pixels are always dropped: semantic pixels, panoptic segments, and boxes (pixels near "
             "the object's depth) of these classes"),
      P_bool("follow_classifiers", d.follow_classifiers,
             "also drop boxes and panoptic segments of any class whose keypoints the classifiers labelled dynamic "
             "(EKF-moving objects, epipolar-inconsistent segments)"),
      P_double("min_dynamic_fraction", d.min_dynamic_fraction,
               "follow_classifiers: fraction of a region's keypoints that must be dynamic", 0, 1),
      P_int("min_dynamic_keypoints", d.min_dynamic_keypoints,
            "follow_classifiers: dynamic keypoints a region needs at least", 1, 100000),
      P_int("keypoint_radius", d.keypoint_radius,
            "disk (px) dropped around every keypoint labelled dynamic: movers without a mask (epipolar outliers) "
            "(0 = none)",
            0, 1000),
      P_int("dilation", d.dilation, "the mask grows by this many pixels (object borders, depth edges)", 0, 200),
      P_double("depth_margin", d.depth_margin,
               "boxes without a mask: pixels whose depth is within this of the object's depth are the object (m; "
               "the depth-repopulation test)",
               0, 100),
      P_double("center_fraction", d.center_fraction,
               "boxes: the object's depth is the median depth of this central part of the box", 0.05, 1),
      P_double("prob_hit", d.prob_hit, "OctoMap hit probability (occupied update)", 0.5, 1),
      P_double("occupancy_threshold", d.occupancy_threshold,
               "OctoMap occupancy threshold: 0.65 with prob_hit 0.6 means two keyframes must see a voxel occupied "
               "(one more for every keyframe that saw through it); a dynamic object a detector missed in one "
               "keyframe leaves no voxel",
               0.5, 0.99),
      P_double("prob_miss", d.prob_miss, "OctoMap miss probability (free-space update)", 0, 0.5),
      P_int("num_disparities", d.num_disparities,
            "stereo: SGBM disparity range, a multiple of 16 (0 = enough for stereo_min_depth: bf / stereo_min_depth, "
            "at most a quarter of the image width)",
            0, 1024),
      P_double("stereo_min_depth", d.stereo_min_depth,
               "stereo: nearest depth (m) the automatic disparity range covers (nearer objects get no depth)", 0.05,
               100),
      P_int("block_size", d.block_size, "stereo: SGBM block size (odd)", 1, 31),
      P_int("uniqueness", d.uniqueness, "stereo: SGBM uniqueness ratio (%)", 0, 100),
      P_int("refine_window", d.refine_window,
            "stereo: half window (px) of the sub-pixel refinement of each SGBM disparity (SAD at the disparity and "
            "its neighbours, V-shaped fit; 0 = keep SGBM's parabola, which pulls towards whole pixels)",
            0, 15),
      P_int("worker_nice", d.worker_nice,
            "niceness of the dense map's thread (Linux, 0-19; 0 = as the other threads): when the cores are busy the "
            "tracking and mapping threads go first and the per-keyframe work (SGBM, mask) catches up in idle time "
            "and at the end of the run; results do not depend on it",
            0, 19),
      P_int("max_queued_keyframes", d.max_queued_keyframes,
            "keyframes (their images) waiting for the dense map's thread at most; with more the tracking thread "
            "waits: memory stays bounded when SGBM is slower than the keyframe rate (stereo street scenes)",
            1, 100000),
      P_int("view_size", d.view_size, "longest side of the top and side views (px)", 100, 8000),
      P_double("view_clip", d.view_clip,
               "top view: voxels higher than the highest camera plus this are left out (ceilings) (m)", -100, 100),
      P_double("side_half_width", d.side_half_width,
               "side view: only voxels within this distance (m) of the trajectory across the view direction", 0.1,
               1000),
  };
}

DenseMapParams DenseMapParams::fromParams(const Params& p) {
  DenseMapParams d;
  d.resolution = p.getDouble("resolution");
  d.max_range = p.getDouble("max_range");
  d.min_range = p.getDouble("min_range");
  d.pixel_step = static_cast<int>(p.getInt("pixel_step"));
  d.colour = p.getString("colour");
  d.mask = p.getBool("mask");
  d.classes = p.getIntList("classes");
  for (int id : d.classes)
    if (!coco::find(id))
      p.fail("classes", std::to_string(id) + " is not a COCO category id (person = 1, see dslam/core/coco.h)");
  d.follow_classifiers = p.getBool("follow_classifiers");
  d.min_dynamic_fraction = p.getDouble("min_dynamic_fraction");
  d.min_dynamic_keypoints = static_cast<int>(p.getInt("min_dynamic_keypoints"));
  d.keypoint_radius = static_cast<int>(p.getInt("keypoint_radius"));
  d.dilation = static_cast<int>(p.getInt("dilation"));
  d.depth_margin = p.getDouble("depth_margin");
  d.center_fraction = p.getDouble("center_fraction");
  d.prob_hit = p.getDouble("prob_hit");
  d.prob_miss = p.getDouble("prob_miss");
  d.occupancy_threshold = p.getDouble("occupancy_threshold");
  d.worker_nice = static_cast<int>(p.getInt("worker_nice"));
  d.max_queued_keyframes = static_cast<int>(p.getInt("max_queued_keyframes"));
  d.num_disparities = static_cast<int>(p.getInt("num_disparities"));
  if (d.num_disparities % 16 != 0)
    p.fail("num_disparities", std::to_string(d.num_disparities) + " is not a multiple of 16");
  d.stereo_min_depth = p.getDouble("stereo_min_depth");
  d.block_size = static_cast<int>(p.getInt("block_size"));
  if (d.block_size % 2 == 0)
    p.fail("block_size", std::to_string(d.block_size) + " is not odd");
  d.uniqueness = static_cast<int>(p.getInt("uniqueness"));
  d.refine_window = static_cast<int>(p.getInt("refine_window"));
  d.view_size = static_cast<int>(p.getInt("view_size"));
  d.view_clip = p.getDouble("view_clip");
  d.side_half_width = p.getDouble("side_half_width");
  if (d.min_range >= d.max_range)
    p.fail("min_range", "must be smaller than max_range");
  return d;
}

void registerDenseSection() {
  config::registerSection("dense_map", &DenseMapParams::specs,
                          "Dense OctoMap without dynamic objects (written when outputs.dense_map is true; "
                          "docs/dense_map.md): resolution, range, which pixels are dynamic, stereo SGBM, pictures.");
}

}  // namespace dslam::dense
