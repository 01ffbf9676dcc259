#include "dslam/plugins/classifiers/depth_repopulation.h"

#include <algorithm>
#include <cmath>

#include "common.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"

IMPLEMENTS_MRPT_OBJECT(DepthRepopulation, KeypointClassifier, dslam)

namespace dslam {

std::string DepthRepopulation::description() const {
  return "Changing-SLAM depth repopulation: keypoints in boxes behind the object are kept, those on it dropped "
         "(person) or movable (other classes); unlabelled occluders drop the box";
}

std::vector<ParamSpec> DepthRepopulation::paramSpecs() const {
  return {
      P_list("classes", ParamType::IntList, "[]", "COCO ids of the boxes considered ([] = every detected class)"),
      P_list("dynamic_classes", ParamType::IntList, "[1]",
             "classes whose object keypoints are dynamic (Changing-SLAM: person); other classes are movable"),
      P_double("min_score", 0, "ignore boxes with a lower score", 0, 1),
      P_map("depth_margin", "{person: 0.5, default: 0.5}",
            "per-class depth (m) behind the object's nearest point still on the object (COCO names or ids; "
            "Changing-SLAM 4.1; paper value not confirmed, see docs/classifiers.md)"),
      P_double("min_percentile", 0,
               "object depth = this percentile of the box depths (0 = minimum, Changing-SLAM 4.1)", 0, 50),
      P_map("class_percentile", "{}",
            "per-class min_percentile (COCO names or ids; unlisted classes use min_percentile, or the entry "
            "'default' when given; e.g. {\"dining table\": 20}: a table's nearest point is the thin front edge "
            "of its top)"),
      P_double("center_fraction", 0.2, "size of the central window, fraction of the box width/height", 0.01, 1),
      P_double("max_center_std", 0.3,
               "depth std (m) of the central window above which the box counts as occluded (chosen default)", 0,
               100),
      P_enum("occlusion_check", "all", {"all", "dynamic", "none"},
             "boxes the unlabelled-occluder test applies to: all (default) = every box; dynamic = boxes of "
             "dynamic_classes only (see-through objects such as chairs and tables, whose centre is deeper than "
             "their front, keep their keypoints: a fuller object map, but an unlabelled thing in front of a "
             "labelled object is no longer caught: unknown_object ATE 0.12 -> 0.27 m); none"),
      P_double("occlusion_span", 0.8,
               "a box whose near layer (depths within depth_margin of the object depth) spans this fraction of its "
               "width and of its height is not occluded: the nearest surface is the object, seen through (chairs, "
               "tables); an unlabelled thing in front covers part of the box (chosen; 0 = off, every deep centre "
               "is an occluder)",
               0, 1),
      P_double("side_occluder_span", 0,
               "an occluded box (not of dynamic_classes) whose near layer spans less than this fraction of its "
               "width, with one surface at its centre (centre std <= max_center_std), has something standing in "
               "front of one side (another object's edge beyond its jittered box): its object is the surface at the "
               "centre, whose nearest depth within depth_margin of the centre depth is the object depth; the "
               "keypoints in front of it stay Dynamic (Occluded), those on it and behind it are labelled as usual "
               "(ours; 0 = off, the whole box Dynamic as in Changing-SLAM)",
               0, 1),
      P_list("see_through_classes", ParamType::IntList, "[]",
             "classes seen through under their top (tables: [67], COCO dining table): their near layer need only "
             "span occlusion_span of the box width, the top being a band across the box and the legs too thin to "
             "count ([] = off, every class needs width and height; [67] measured in docs/classifiers.md, not the "
             "default)"),
      P_double("overlap_dilation", 0.1,
               "other boxes are widened by this fraction of their width / height on each side before their overlap "
               "is left out (box jitter of real detectors; chosen, 0 = the boxes as detected)",
               0, 1),
      P_enum("overlap_class", "front", {"front", "first"},
             "class of a keypoint on the objects of two overlapping boxes: front (default) = not the class of a box "
             "whose object it is in front of (nearer than that box's object depth by more than front_margin: an "
             "occluder, e.g. a plant in front of a desk), else the box listed first; first = the box listed first "
             "(the earlier rule; measured in docs/classifiers.md)"),
      P_double("front_margin", 0.1, "overlap_class front: metres in front of a box's object depth (chosen)", 0, 100),
      P_bool("exclude_overlap", true, "leave pixels shared by overlapping boxes out of the statistics (Changing-SLAM 4.1)"),
      P_bool("overlap_fallback", false,
             "exclude_overlap: a box left with fewer than min_samples depth samples of its own (e.g. a small box "
             "inside a bigger one) takes its shared pixels back into its statistics, instead of keeping every "
             "keypoint in it on its object whatever its depth (ours; false = as Changing-SLAM, which does not say; "
             "docs/changing.md step 15)"),
      P_bool("fallback_skip_other_objects", false,
             "overlap_fallback: of the shared pixels taken back, those on the object of a box they are shared with "
             "(from front_margin in front of to its depth margin behind that box's object depth) stay out, so the "
             "small box's statistics are its own object and what is around it, not the bigger object's surface "
             "(ours; false = every shared pixel back in; docs/changing.md step 16)"),
      P_enum("support_check", "off", {"off", "no_statistics", "all"},
             "a keypoint put on a box's object (not of dynamic_classes) whose surface continues as one plane out of "
             "the box (along its row or column, to support_extension of the box size beyond the edge) lies on what "
             "the object stands on or against (the floor at its foot, a wall, a table top): Static, not on the "
             "object. no_statistics = only in boxes with fewer than min_samples depth samples of their own (a box "
             "inside another, whose keypoints are otherwise all put on its object whatever their depth, or judged by "
             "the shared pixels overlap_fallback took back); all = in every box (ours; off = as Changing-SLAM; "
             "docs/changing.md steps 17 and 18)"),
      P_double("support_extension", 0.25,
               "support_check: how far beyond the box edge the surface must continue, fraction of the box width "
               "(rows) or height (columns); more than the detector's box jitter, so that an object surface cut by "
               "a box too small ends within it",
               0.01, 10),
      P_double("support_tolerance", 0.004,
               "support_check: largest deviation of a depth sample (the mean inverse depth of three pixels across "
               "the walk) from the plane, in inverse depth (1/m; a plane's inverse depth is affine in the pixel "
               "coordinates; 0.004 = 2.5 cm at 2.5 m, about 5 sigma of a Kinect's noise of 1.425e-3 z^2; a floor "
               "seen from 1.2 m, f = 525 px, turning into an upright face is told apart within 3 px)",
               1e-5, 10),
      P_int("support_min_samples", 4, "support_check: valid depth samples beyond the box edge needed", 2, 10000),
      P_int("pixel_stride", 2, "sample every n-th depth pixel in x and y (speed; 1 = every pixel)", 1, 64),
      P_int("min_samples", 10, "fewer valid depth samples in a box: keypoints of the box stay on the object", 1,
            1000000),
  };
}

void DepthRepopulation::configure(const Params& p, const PluginContext& ctx) {
  KeypointClassifier::configure(p, ctx);
  classes_ = cls::cocoIdList(p, "classes");
  dynamic_classes_ = cls::cocoIdList(p, "dynamic_classes");
  min_score_ = p.getDouble("min_score");
  const cls::ClassValues m = cls::classValues(p, "depth_margin");
  margin_ = m.by_class;
  margin_default_ = m.fallback;
  const cls::ClassValues pc = cls::classValues(p, "class_percentile", false);
  percentile_ = pc.by_class;
  // 'default' in class_percentile: the unlisted classes' percentile.
  min_percentile_ = pc.has_default ? pc.fallback : p.getDouble("min_percentile");
  auto check = [&](double v) {
    if (v < 0 || v > 50) p.fail("class_percentile", "values must lie in [0, 50]");
  };
  for (const auto& [id, v] : percentile_) check(v);
  check(min_percentile_);  // min_percentile's own range, or the 'default' entry's
  center_fraction_ = p.getDouble("center_fraction");
  max_center_std_ = p.getDouble("max_center_std");
  occlusion_span_ = p.getDouble("occlusion_span");
  side_span_ = p.getDouble("side_occluder_span");
  see_through_classes_ = cls::cocoIdList(p, "see_through_classes");
  overlap_dilation_ = p.getDouble("overlap_dilation");
  exclude_overlap_ = p.getBool("exclude_overlap");
  overlap_fallback_ = p.getBool("overlap_fallback");
  fallback_skip_others_ = p.getBool("fallback_skip_other_objects");
  overlap_front_ = p.getString("overlap_class") == "front";
  front_margin_ = p.getDouble("front_margin");
  const std::string oc = p.getString("occlusion_check");
  occlusion_ = oc == "dynamic" ? Occlusion::Dynamic : oc == "none" ? Occlusion::None : Occlusion::All;
  stride_ = static_cast<int>(p.getInt("pixel_stride"));
  const std::string sc = p.getString("support_check");
  support_ = sc == "all" ? Support::All : sc == "no_statistics" ? Support::NoStatistics : Support::Off;
  support_extension_ = p.getDouble("support_extension");
  support_tolerance_ = p.getDouble("support_tolerance");
  support_min_samples_ = static_cast<int>(p.getInt("support_min_samples"));
  min_samples_ = static_cast<int>(p.getInt("min_samples"));
}

namespace {

struct Summary {
  int n = 0;
  float min = 0, max = 0, mean = 0, median = 0, stddev = 0, pct = 0;
};

// Summary of `v` (reordered); `pct` percentile in [0, 50].
Summary summarize(std::vector<float>& v, double pct) {
  Summary s;
  s.n = static_cast<int>(v.size());
  if (v.empty()) return s;
  double sum = 0, sum2 = 0;
  float mn = v[0], mx = v[0];
  for (float x : v) {
    sum += x;
    sum2 += static_cast<double>(x) * x;
    mn = std::min(mn, x);
    mx = std::max(mx, x);
  }
  s.min = mn;
  s.max = mx;
  s.mean = static_cast<float>(sum / s.n);
  s.stddev = static_cast<float>(std::sqrt(std::max(0.0, sum2 / s.n - (sum / s.n) * (sum / s.n))));
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  s.median = v[mid];
  if (pct <= 0) {
    s.pct = mn;
  } else {
    const size_t k = std::min(v.size() - 1, static_cast<size_t>(std::floor(pct / 100.0 * (v.size() - 1))));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    s.pct = v[k];
  }
  return s;
}

inline bool validDepth(float d) { return d > 0 && std::isfinite(d); }

/** Keypoint depth: Frame::depth, else the depth image at the keypoint. */
float keypointDepth(const Frame& frame, size_t i) {
  if (i < frame.depth.size() && validDepth(frame.depth[i])) return frame.depth[i];
  const cv::Mat& depth = frame.input.depth;
  if (!depth.empty()) {
    const int x = static_cast<int>(std::lround(frame.keypoints[i].pt.x));
    const int y = static_cast<int>(std::lround(frame.keypoints[i].pt.y));
    if (x >= 0 && y >= 0 && x < depth.cols && y < depth.rows) {
      const float d = depth.at<float>(y, x);
      if (validDepth(d)) return d;
    }
  }
  return 0.f;
}

inline bool inRect(const cv::Rect2f& r, float x, float y) {
  return x >= r.x && y >= r.y && x < r.x + r.width && y < r.y + r.height;
}

bool inAny(const std::vector<cv::Rect2f>& rects, float x, float y) {
  for (const auto& s : rects)
    if (inRect(s, x, y)) return true;
  return false;
}

/** The pixels (x, y) with r.x <= x < r.x + width, likewise y: those a
 *  keypoint at the pixel would be inside `r` for (cls::inBox). Rounding the
 *  box outwards instead takes in a row and a column of whatever borders it,
 *  e.g. the edge of an occluder next to the box, whose depth then becomes
 *  the box's minimum (its object depth). */
cv::Rect pixelRect(const cv::Rect2f& r, const cv::Mat& img) {
  return cv::Rect(cv::Point(static_cast<int>(std::ceil(r.x)), static_cast<int>(std::ceil(r.y))),
                  cv::Point(static_cast<int>(std::ceil(r.x + r.width)), static_cast<int>(std::ceil(r.y + r.height)))) &
         cv::Rect(0, 0, img.cols, img.rows);
}

/** Calls visit(x, y, depth) for the valid depths of `box` outside the
 *  `shared` overlaps: every `stride`-th pixel of the depth image, or, without
 *  one, every keypoint in the box with a depth. */
template <class Visit>
void forBoxDepths(const Frame& frame, const cv::Rect2f& box, const std::vector<cv::Rect2f>& shared, int stride,
                  Visit&& visit) {
  const cv::Mat& depth = frame.input.depth;
  if (depth.empty()) {
    for (size_t i = 0; i < frame.size(); i++) {
      const cv::Point2f& pt = frame.keypoints[i].pt;
      if (!cls::inBox(pt, box) || inAny(shared, pt.x, pt.y)) continue;
      const float d = keypointDepth(frame, i);
      if (validDepth(d)) visit(pt.x, pt.y, d);
    }
    return;
  }
  const cv::Rect r = pixelRect(box, depth);
  for (int y = r.y; y < r.y + r.height; y += stride) {
    const float* row = depth.ptr<float>(y);
    for (int x = r.x; x < r.x + r.width; x += stride) {
      const float d = row[x];
      if (!validDepth(d)) continue;
      const auto fx = static_cast<float>(x), fy = static_cast<float>(y);
      if (!shared.empty() && inAny(shared, fx, fy)) continue;
      visit(fx, fy, d);
    }
  }
}

/** Depth samples of a box (every `stride`-th pixel, outside the `shared`
 *  overlaps) into `buf` and of its central window (every pixel, also outside
 *  the overlaps: a labelled object in front is no unlabelled occluder) into
 *  `cbuf`; without a depth image, the depths of the keypoints inside. Only
 *  the samples keep(x, y, depth) accepts. */
template <class Keep>
void sampleBoxDepths(const Frame& frame, const cv::Rect2f& box, const cv::Rect2f& center,
                     const std::vector<cv::Rect2f>& shared, int stride, std::vector<float>& buf,
                     std::vector<float>& cbuf, Keep&& keep) {
  buf.clear();
  cbuf.clear();
  forBoxDepths(frame, box, shared, stride, [&](float x, float y, float d) {
    if (keep(x, y, d)) buf.push_back(d);
  });
  // Central window: every pixel (or its keypoints).
  forBoxDepths(frame, center, shared, 1, [&](float x, float y, float d) {
    if (keep(x, y, d)) cbuf.push_back(d);
  });
}

void sampleBoxDepths(const Frame& frame, const cv::Rect2f& box, const cv::Rect2f& center,
                     const std::vector<cv::Rect2f>& shared, int stride, std::vector<float>& buf,
                     std::vector<float>& cbuf) {
  sampleBoxDepths(frame, box, center, shared, stride, buf, cbuf, [](float, float, float) { return true; });
}

/** Extent of the box's near layer (depth in (0, max_depth]) as fractions
 *  of the box width and height: between the 2nd and 98th percentiles of the
 *  layer's pixel coordinates (a few stray pixels do not stretch it). Samples
 *  every `stride`-th pixel, outside the `shared` overlaps; without a depth
 *  image, the keypoints in the box. */
void nearLayerSpan(const Frame& frame, const cv::Rect2f& box, const std::vector<cv::Rect2f>& shared, int stride,
                   float max_depth, std::vector<float>& xs, std::vector<float>& ys, float& span_x, float& span_y) {
  xs.clear();
  ys.clear();
  forBoxDepths(frame, box, shared, stride, [&](float x, float y, float d) {
    if (d > max_depth) return;
    xs.push_back(x);
    ys.push_back(y);
  });
  auto extent = [](std::vector<float>& v) {
    if (v.size() < 2) return 0.f;
    const size_t lo = v.size() / 50, hi = v.size() - 1 - v.size() / 50;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(lo), v.end());
    const float a = v[lo];
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(hi), v.end());
    return v[hi] - a;
  };
  span_x = box.width > 0 ? extent(xs) / box.width : 0.f;
  span_y = box.height > 0 ? extent(ys) / box.height : 0.f;
}

/** Whether the surface at (x0, y0), depth d0, continues as one plane out of
 *  `box` along its row or its column: in one of the four directions, the
 *  inverse depths (each the mean of the valid pixels of three across the
 *  walk) from `ext` of the box size beyond the box edge back to the
 *  point lie on one line in inverse depth (a plane's inverse depth is affine
 *  in the pixel coordinates of a pinhole image) within `tol`. The line is
 *  fitted to the samples beyond the edge (at least `min_out`, all on it),
 *  then grown inwards sample by sample, each checked against it before it
 *  joins. A direction whose image ends within half of `ext` beyond the edge
 *  is no evidence. */
bool continuesOutOfBox(const cv::Mat& depth, const cv::Rect2f& box, float x0, float y0, float d0, int stride,
                       double ext, double tol, int min_out, std::vector<cv::Vec2d>& samples) {
  const int dirs[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  for (const auto& dir : dirs) {
    const int dx = dir[0], dy = dir[1];
    const double edge = dx > 0   ? box.x + box.width - x0
                        : dx < 0 ? x0 - box.x
                        : dy > 0 ? box.y + box.height - y0
                                 : y0 - box.y;
    const double far = edge + ext * (dx != 0 ? box.width : box.height);
    // Samples (t, 1/depth), t = pixels from the point, farthest first.
    samples.clear();
    int t_end = 0;  // last position inside the image
    for (int t = stride; t <= far; t += stride) {
      const int x = static_cast<int>(std::lround(x0 + dx * t)), y = static_cast<int>(std::lround(y0 + dy * t));
      if (x < 0 || y < 0 || x >= depth.cols || y >= depth.rows) break;
      t_end = t;
      // Inverse depth averaged over the three pixels across the walk.
      double sum = 0;
      int cnt = 0;
      for (int o = -1; o <= 1; o++) {
        const int xx = x + dy * o, yy = y + dx * o;
        if (xx < 0 || yy < 0 || xx >= depth.cols || yy >= depth.rows) continue;
        const float d = depth.at<float>(yy, xx);
        if (validDepth(d)) sum += 1.0 / d, cnt++;
      }
      if (cnt > 0) samples.push_back({static_cast<double>(t), sum / cnt});
    }
    if (t_end - edge < 0.5 * (far - edge)) continue;  // the image ends within half the extension
    std::reverse(samples.begin(), samples.end());
    // Least-squares line v = a + b t over the accepted samples.
    double n = 0, st = 0, sv = 0, stt = 0, stv = 0;
    auto add = [&](const cv::Vec2d& s) {
      n += 1, st += s[0], sv += s[1], stt += s[0] * s[0], stv += s[0] * s[1];
    };
    auto predict = [&](double t) {
      const double den = n * stt - st * st;
      const double b = den > 1e-12 ? (n * stv - st * sv) / den : 0.0;
      return (sv - b * st) / n + b * t;
    };
    size_t k = 0;
    for (; k < samples.size() && samples[k][0] > edge; k++) add(samples[k]);
    if (n < min_out) continue;
    bool on = true;
    for (size_t j = 0; j < k && on; j++) on = std::abs(samples[j][1] - predict(samples[j][0])) <= tol;
    for (; k < samples.size() && on; k++) {
      on = std::abs(samples[k][1] - predict(samples[k][0])) <= tol;
      add(samples[k]);
    }
    if (on && std::abs(1.0 / d0 - predict(0)) <= tol) return true;
  }
  return false;
}

}  // namespace

cv::Rect2f DepthRepopulation::centerWindow(const cv::Rect2f& box) const {
  const float cw = box.width * static_cast<float>(center_fraction_),
              ch = box.height * static_cast<float>(center_fraction_);
  return {box.x + 0.5f * (box.width - cw), box.y + 0.5f * (box.height - ch), cw, ch};
}

/** Statistics of box `b` (`box`, clipped to the image) from the samples in
 *  buf_ (the box) and cbuf_ (its central window); `shared`: the overlaps
 *  left out (for the near layer); `own_samples`: the box's samples outside
 *  the other boxes (before an overlap fallback). */
BoxDepthStats DepthRepopulation::boxStats(const Frame& frame, const BoundingBox& bb, int b, const cv::Rect2f& box,
                                          const std::vector<cv::Rect2f>& shared, int own_samples) {
  BoxDepthStats st;
  st.box = b;
  st.own_samples = own_samples;
  st.class_id = bb.class_id;
  auto mit = margin_.find(bb.class_id);
  st.margin = static_cast<float>(mit == margin_.end() ? margin_default_ : mit->second);
  const auto pit = percentile_.find(bb.class_id);
  const Summary s = summarize(buf_, pit == percentile_.end() ? min_percentile_ : pit->second);
  st.samples = s.n;
  st.min = s.min, st.max = s.max, st.mean = s.mean, st.median = s.median, st.stddev = s.stddev;
  st.object_depth = s.pct;
  const Summary c = summarize(cbuf_, 0);
  st.center_depth = c.n > 0 ? c.median : 0.f;
  st.center_std = c.stddev;
  const bool enough = s.n >= min_samples_;
  const bool dyn_class = cls::contains(dynamic_classes_, bb.class_id);
  const bool check = occlusion_ == Occlusion::All || (occlusion_ == Occlusion::Dynamic && dyn_class);
  if (check && enough && c.n > 0)
    st.occluded = st.center_depth > st.object_depth + st.margin || st.center_std > max_center_std_;
  if (st.occluded && occlusion_span_ > 0 && !dyn_class) {
    // The near layer across the whole box is the object, seen through.
    nearLayerSpan(frame, box, shared, stride_, st.object_depth + st.margin, xs_, ys_, st.near_span_x,
                  st.near_span_y);
    const bool table = cls::contains(see_through_classes_, bb.class_id);
    if (st.near_span_x >= occlusion_span_ && (table || st.near_span_y >= occlusion_span_)) st.occluded = false;
  }
  if (st.occluded && side_span_ > 0 && !dyn_class && st.center_std <= max_center_std_ &&
      st.near_span_x < side_span_) {
    // Something in front of one side only: the object is the surface at
    // the centre; its nearest depth within the margin of the centre depth.
    const float from = st.center_depth - st.margin;
    float nearest = st.center_depth;
    for (float d : buf_)
      if (d >= from && d < nearest) nearest = d;
    st.occluder_depth = st.object_depth;
    st.object_depth = nearest;
    st.occluded = false;
  }
  DSLAM_LOG(Trace, "DepthRepopulation frame " << frame.index() << " box class " << bb.class_id << " ["
                                               << box.x << ", " << box.y << ", " << box.width << " x " << box.height
                                               << "]: object depth " << st.object_depth << " m, centre "
                                               << st.center_depth << " m (std " << st.center_std
                                               << "), near layer " << st.near_span_x << " x " << st.near_span_y
                                               << (st.occluded ? ": occluded" : "")
                                               << (st.occluder_depth > 0 ? ": side occluder" : ""));
  return st;
}

void DepthRepopulation::classify(Frame& frame, const Detections& det, const ClassifierContext& ctx) {
  cls::ensureMeta(frame);
  stats_.clear();
  if (!det.valid || det.boxes.empty()) return;
  const cv::Mat& depth = frame.input.depth;
  if (!depth.empty() && depth.type() != CV_32F)
    throw DataError("frame " + std::to_string(frame.index()) + ": depth image must be CV_32F metres, got type " +
                    std::to_string(depth.type()));
  const cv::Size img = cls::imageSize(frame, ctx.camera, depth.size());

  std::vector<int> sel;
  for (size_t b = 0; b < det.boxes.size(); b++) {
    const auto& bb = det.boxes[b];
    if (bb.score < min_score_ || bb.box.width <= 0 || bb.box.height <= 0) continue;
    if (!classes_.empty() && !cls::contains(classes_, bb.class_id)) continue;
    sel.push_back(static_cast<int>(b));
  }
  if (sel.empty()) return;

  // Decided label per keypoint (max over the boxes containing it). Between
  // two boxes that both put a keypoint on their object, the first listed
  // wins, unless (overlap_class: front) it is in front of that box's object
  // and not of the other's.
  struct Decision {
    int8_t label = -1;
    bool in_front = false;
    int16_t class_id = -1;
    KpReason why = KpReason::None;
  };
  std::vector<Decision> dec(frame.size());
  auto decide = [&](size_t i, KpLabel l, KpReason r, int class_id, bool in_front = false) {
    Decision& x = dec[i];
    const bool behind_other = overlap_front_ && static_cast<int>(l) == x.label && class_id >= 0 && x.class_id >= 0 &&
                              x.in_front && !in_front;
    if (static_cast<int>(l) > x.label || behind_other)
      x = {static_cast<int8_t>(l), in_front, static_cast<int16_t>(class_id), r};
  };

  const cv::Rect2f full(0, 0, static_cast<float>(img.width), static_cast<float>(img.height));
  // Other boxes widened by overlap_dilation (detector boxes are not exact).
  auto dilated = [&](int o) {
    const cv::Rect2f& ob = det.boxes[o].box;
    const auto dil = static_cast<float>(overlap_dilation_);
    const float dx = ob.width * dil, dy = ob.height * dil;
    return cv::Rect2f(ob.x - dx, ob.y - dy, ob.width + 2 * dx, ob.height + 2 * dy);
  };
  // Statistics of each selected box (index in sel), then its keypoints'
  // labels in the order of sel. With fallback_skip_other_objects the boxes
  // short of samples of their own come last: their fallback needs the
  // object depths of the boxes they share pixels with.
  std::vector<BoxDepthStats> st_of(sel.size());
  std::vector<cv::Rect2f> rect_of(sel.size());
  std::vector<char> done(sel.size(), 0);
  std::vector<std::pair<size_t, int>> deferred;  // (index in sel, samples of its own)
  for (size_t k = 0; k < sel.size(); k++) {
    const int b = sel[k];
    const cv::Rect2f box = det.boxes[b].box & full;
    if (box.width <= 0 || box.height <= 0) continue;
    rect_of[k] = box;
    // Overlaps with the other considered boxes (left out of the statistics):
    // another labelled object in front is no unlabelled occluder.
    std::vector<cv::Rect2f> shared;
    if (exclude_overlap_)
      for (int o : sel)
        if (o != b) {
          const cv::Rect2f x = box & dilated(o);
          if (x.width > 0 && x.height > 0) shared.push_back(x);
        }
    sampleBoxDepths(frame, box, centerWindow(box), shared, stride_, buf_, cbuf_);
    const int own = static_cast<int>(buf_.size());
    if (overlap_fallback_ && !shared.empty() && own < min_samples_) {
      if (fallback_skip_others_) {
        deferred.emplace_back(k, own);
        continue;
      }
      shared.clear();  // too few pixels of its own: the shared ones back in
      sampleBoxDepths(frame, box, centerWindow(box), shared, stride_, buf_, cbuf_);
    }
    st_of[k] = boxStats(frame, det.boxes[b], b, box, shared, own);
    done[k] = 1;
  }
  for (const auto& [k, own] : deferred) {
    // The shared pixels back in, but not those on the object of a box they
    // are shared with (within front_margin in front of and that box's
    // depth margin behind its object depth).
    const cv::Rect2f& box = rect_of[k];
    struct Layer {
      cv::Rect2f rect;
      float from, to;
    };
    std::vector<Layer> layers;
    for (size_t o = 0; o < sel.size(); o++) {
      const BoxDepthStats& so = st_of[o];
      if (o == k || !done[o] || so.occluded || so.samples < min_samples_) continue;
      const cv::Rect2f x = box & dilated(sel[o]);
      if (x.width > 0 && x.height > 0)
        layers.push_back({x, so.object_depth - static_cast<float>(front_margin_), so.object_depth + so.margin});
    }
    sampleBoxDepths(frame, box, centerWindow(box), {}, stride_, buf_, cbuf_, [&](float x, float y, float d) {
      for (const Layer& l : layers)
        if (inRect(l.rect, x, y) && d >= l.from && d <= l.to) return false;
      return true;
    });
    st_of[k] = boxStats(frame, det.boxes[sel[k]], sel[k], box, {}, own);
    done[k] = 1;
  }

  for (size_t k = 0; k < sel.size(); k++) {
    if (!done[k]) continue;
    const int b = sel[k];
    const BoundingBox& bb = det.boxes[b];
    const cv::Rect2f& box = rect_of[k];
    const BoxDepthStats& st = st_of[k];
    stats_.push_back(st);
    const bool enough = st.samples >= min_samples_;
    const bool dyn_class = cls::contains(dynamic_classes_, bb.class_id);
    const KpLabel on_label = dyn_class ? KpLabel::Dynamic : KpLabel::Movable;
    const KpReason on_reason = dyn_class ? KpReason::InDynamicBox : KpReason::OnObject;
    // no_statistics: the boxes short of depth samples of their own, judged
    // by no statistics or by the overlap fallback's shared pixels.
    const bool check_support =
        !dyn_class && !depth.empty() &&
        (support_ == Support::All || (support_ == Support::NoStatistics && st.own_samples < min_samples_));
    for (size_t i = 0; i < frame.size(); i++) {
      if (!cls::inBox(frame.keypoints[i].pt, box)) continue;
      if (st.occluded) {
        decide(i, KpLabel::Dynamic, KpReason::Occluded, bb.class_id);
        continue;
      }
      const float d = keypointDepth(frame, i);
      if (st.occluder_depth > 0 && (!validDepth(d) || d < st.object_depth - front_margin_)) {
        decide(i, KpLabel::Dynamic, KpReason::Occluded, bb.class_id);  // on the occluder at the side
        continue;
      }
      const bool behind = enough && validDepth(d) && d > st.object_depth + st.margin;
      const bool support = !behind && check_support && validDepth(d) &&
                           continuesOutOfBox(depth, box, frame.keypoints[i].pt.x, frame.keypoints[i].pt.y, d,
                                             stride_, support_extension_, support_tolerance_,
                                             support_min_samples_, walk_);
      if (behind || support) {
        decide(i, KpLabel::Static, KpReason::BoxBackground, -2 - bb.class_id);  // not on the class
        stats_.back().support_points += support;
      } else {
        decide(i, on_label, on_reason, bb.class_id, enough && validDepth(d) && d < st.object_depth - front_margin_);
        stats_.back().object_points++;
      }
    }
    if (check_support)
      DSLAM_LOG(Trace, "DepthRepopulation frame " << frame.index() << " box class " << bb.class_id
                                                   << ": support check: " << stats_.back().support_points << " of "
                                                   << stats_.back().support_points + stats_.back().object_points
                                                   << " keypoints on the object continue out of the box");
  }

  for (size_t i = 0; i < frame.size(); i++) {
    const Decision& x = dec[i];
    if (x.label < 0) continue;
    KeypointMeta& m = frame.meta[i];
    const auto l = static_cast<KpLabel>(x.label);
    if (m.reason == KpReason::None || m.reason == KpReason::InDynamicBox) {
      m.label = l;  // repopulation: may return a box-filtered keypoint to Static
      m.reason = x.why;
    } else {
      cls::raise(m, l, x.why);
    }
    if (x.class_id >= 0)
      m.class_id = x.class_id;
    else if (x.class_id <= -2 && m.class_id == -2 - x.class_id)
      m.class_id = -1;  // background behind the box's object, not on it
  }
}

}  // namespace dslam
