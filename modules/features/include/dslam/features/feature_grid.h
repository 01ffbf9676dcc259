#pragma once
/** \file feature_grid.h
 *  ORB-SLAM's keypoint grid (Frame::mGrid, 64 x 48 cells over the
 *  undistorted image bounds) for fast radius queries. */
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace dslam {

struct PinholeCamera;
struct Frame;

/** Area covered by the undistorted image (ORB-SLAM mnMinX, mnMaxX, mnMinY, mnMaxY). */
struct ImageBounds {
  float min_x = 0, max_x = 0, min_y = 0, max_y = 0;
  bool contains(float x, float y) const { return x >= min_x && x < max_x && y >= min_y && y < max_y; }
  bool valid() const { return max_x > min_x && max_y > min_y; }
};

/** Bounds of the undistorted image: the image rectangle when `cam` has no
 *  distortion, otherwise the extremes of its undistorted corners (ORB-SLAM2
 *  Frame::ComputeImageBounds). */
ImageBounds computeImageBounds(const PinholeCamera& cam);

class FeatureGrid {
 public:
  static constexpr int kCols = 64;  ///< ORB-SLAM FRAME_GRID_COLS
  static constexpr int kRows = 48;  ///< ORB-SLAM FRAME_GRID_ROWS

  FeatureGrid() = default;
  /** Builds the grid over `keypoints_un` (undistorted pixels). */
  FeatureGrid(const std::vector<cv::KeyPoint>& keypoints_un, const ImageBounds& bounds) {
    build(keypoints_un, bounds);
  }
  /** Builds the grid over `frame.keypoints_un`. */
  FeatureGrid(const Frame& frame, const ImageBounds& bounds);

  /** (Re)builds the grid. Keypoints outside `bounds` are not indexed.
   *  Throws ConfigError if the bounds are empty. */
  void build(const std::vector<cv::KeyPoint>& keypoints_un, const ImageBounds& bounds);

  /** Indices of the keypoints with |x_k - x| < r and |y_k - y| < r (a square,
   *  as ORB-SLAM's GetFeaturesInArea) and min_level <= octave <= max_level;
   *  min_level <= 0 / max_level < 0 disable the level checks. Ascending by
   *  cell (column-major), then by index. */
  std::vector<size_t> featuresInArea(float x, float y, float r, int min_level = -1, int max_level = -1) const;
  /** Same, appending into `out` (cleared first) to reuse its storage. */
  void featuresInArea(float x, float y, float r, int min_level, int max_level, std::vector<size_t>& out) const;

  /** Grid cell of a pixel; false if it falls outside the grid (ORB-SLAM PosInGrid). */
  bool posInGrid(float x, float y, int& cell_x, int& cell_y) const;
  /** Keypoint indices in cell (cx, cy). */
  std::vector<size_t> cell(int cx, int cy) const;

  const ImageBounds& bounds() const { return bounds_; }
  float cellWidthInv() const { return inv_w_; }
  float cellHeightInv() const { return inv_h_; }
  size_t size() const { return n_; }         ///< keypoints given to build()
  size_t indexed() const { return idx_.size(); }  ///< keypoints inside the grid
  bool empty() const { return idx_.empty(); }

 private:
  struct Entry {
    float x, y;
    int octave;
    uint32_t index;
  };
  ImageBounds bounds_;
  float inv_w_ = 0, inv_h_ = 0;
  size_t n_ = 0;
  std::vector<uint32_t> start_;  ///< kCols*kRows+1 offsets into idx_ (cell = cx*kRows + cy)
  std::vector<Entry> idx_;
};

}  // namespace dslam
