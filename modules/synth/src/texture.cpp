#include "texture.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <string>

#include "dslam/synth/rng.h"

namespace dslam::synth {

namespace {

using cv::Mat;
using cv::Point;
using cv::Scalar;

/** RGB [0,1] -> BGR scalar [0,255]. */
Scalar bgr(const Vec3& c) { return Scalar(255 * c.z(), 255 * c.y(), 255 * c.x()); }
Vec3 clamp01(const Vec3& c) { return c.cwiseMax(0.0).cwiseMin(1.0); }
Vec3 jitter(Rng& r, const Vec3& c, double a) {
  return clamp01(c + Vec3(r.uniform(-a, a), r.uniform(-a, a), r.uniform(-a, a)));
}
Vec3 randomColor(Rng& r, double lo = 0.05, double hi = 0.95) {
  return Vec3(r.uniform(lo, hi), r.uniform(lo, hi), r.uniform(lo, hi));
}
/** A palette colour with strong contrast. */
Vec3 vivid(Rng& r) {
  static const Vec3 pal[] = {{0.85, 0.1, 0.1},  {0.1, 0.3, 0.8},  {0.95, 0.8, 0.1},  {0.1, 0.6, 0.25},
                             {0.05, 0.05, 0.05}, {0.95, 0.95, 0.95}, {0.9, 0.45, 0.05}, {0.5, 0.15, 0.6},
                             {0.2, 0.7, 0.8},   {0.6, 0.4, 0.25}};
  return jitter(r, pal[r.integer(0, 9)], 0.06);
}

struct Ctx {
  Mat img;     // CV_8UC3
  double tpm;  // texels per metre
  Rng rng;
  const TextureSpec& spec;
  int px(double metres) const { return std::max(1, static_cast<int>(std::lround(metres * tpm * spec.scale))); }
};

/** Adds a grey field to the image: a gw x gh grid of uniform values in
 *  [-amp, amp] (drawn row by row) resized to the image with `interp`. */
void addField(Ctx& c, int gw, int gh, double amp, int interp) {
  Mat g(gh, gw, CV_32F);
  for (int y = 0; y < gh; y++)
    for (int x = 0; x < gw; x++) g.at<float>(y, x) = static_cast<float>(c.rng.uniform(-amp, amp));
  Mat big;
  cv::resize(g, big, c.img.size(), 0, 0, interp);
  Mat f;
  c.img.convertTo(f, CV_32FC3);
  Mat big3;
  cv::merge(std::vector<Mat>{big, big, big}, big3);
  f += big3;
  f.convertTo(c.img, CV_8UC3);
}

/** Adds low-frequency mottling of amplitude `amp` (grey levels). */
void mottle(Ctx& c, double amp, double cell_m) {
  const int gw = std::max(2, c.img.cols / std::max(1, c.px(cell_m))), gh = std::max(2, c.img.rows / std::max(1, c.px(cell_m)));
  addField(c, gw, gh, amp, cv::INTER_CUBIC);
}

/** Per-texel noise of amplitude amp (grey levels). */
void grain(Ctx& c, double amp) {
  for (int y = 0; y < c.img.rows; y++) {
    auto* p = c.img.ptr<cv::Vec3b>(y);
    for (int x = 0; x < c.img.cols; x++) {
      const int d = static_cast<int>(std::lround(c.rng.uniform(-amp, amp)));
      for (int k = 0; k < 3; k++) p[x][k] = cv::saturate_cast<uchar>(p[x][k] + d);
    }
  }
}

/** Small random marks (dots, short strokes) in [x0,x1]x[y0,y1] texels. */
void speckles(Ctx& c, int count, double size_m, const Vec3& base, double contrast, cv::Rect area = {}) {
  if (area.area() == 0) area = cv::Rect(0, 0, c.img.cols, c.img.rows);
  for (int i = 0; i < count; i++) {
    const Point p(area.x + c.rng.integer(0, area.width - 1), area.y + c.rng.integer(0, area.height - 1));
    const int r = std::max(1, static_cast<int>(c.px(size_m) * c.rng.uniform(0.4, 1.2)));
    const double sgn = c.rng.uniform() < 0.7 ? -1 : 1;
    const Vec3 col = clamp01(base + sgn * contrast * Vec3(1, 1, 1) + Vec3(c.rng.uniform(-0.1, 0.1), 0, 0));
    if (c.rng.uniform() < 0.5)
      cv::circle(c.img, p, r, bgr(col), cv::FILLED, cv::LINE_AA);
    else
      cv::line(c.img, p, p + Point(c.rng.integer(-3 * r, 3 * r), c.rng.integer(-3 * r, 3 * r)), bgr(col),
               std::max(1, r / 2), cv::LINE_AA);
  }
}

/** Text-like lines ("words") in a rectangle. */
void textBlock(Ctx& c, cv::Rect r, const Vec3& ink, double line_m) {
  const int lh = std::max(3, c.px(line_m));
  const int th = std::max(1, lh / 2);
  for (int y = r.y + lh; y + th < r.y + r.height; y += lh) {
    int x = r.x + c.rng.integer(0, lh);
    const int xend = r.x + r.width - c.rng.integer(0, r.width / 3 + 1);
    while (x < xend) {
      const int w = c.rng.integer(lh, 4 * lh);
      if (x + w > xend) break;
      cv::rectangle(c.img, cv::Rect(x, y - th, w, th), bgr(ink), cv::FILLED);
      x += w + c.rng.integer(th, lh);
    }
  }
}

void mondrian(Ctx& c, cv::Rect r, int n, double min_m, double max_m, bool vivid_colors) {
  for (int i = 0; i < n; i++) {
    const int w = c.rng.integer(c.px(min_m), c.px(max_m)), h = c.rng.integer(c.px(min_m), c.px(max_m));
    const int x = r.x + c.rng.integer(-w / 2, std::max(0, r.width - w / 2));
    const int y = r.y + c.rng.integer(-h / 2, std::max(0, r.height - h / 2));
    cv::Rect rr = cv::Rect(x, y, w, h) & r;
    if (rr.area() == 0) continue;
    cv::rectangle(c.img, rr, bgr(vivid_colors ? vivid(c.rng) : randomColor(c.rng)), cv::FILLED);
  }
}

void blobsIn(Ctx& c, cv::Rect r, int n, double min_m, double max_m) {
  for (int i = 0; i < n; i++) {
    const Point p(r.x + c.rng.integer(0, r.width - 1), r.y + c.rng.integer(0, r.height - 1));
    const cv::Size ax(c.rng.integer(c.px(min_m), c.px(max_m)), c.rng.integer(c.px(min_m), c.px(max_m)));
    cv::ellipse(c.img, p, ax, c.rng.uniform(0, 180), 0, 360, bgr(vivid(c.rng)), cv::FILLED, cv::LINE_AA);
  }
}

/** One poster / picture / whiteboard / calendar in rectangle r. */
void poster(Ctx& c, cv::Rect r) {
  const int kind = c.rng.integer(0, 6);
  const int border = std::max(2, c.px(0.015));
  cv::rectangle(c.img, r, bgr(c.rng.uniform() < 0.5 ? Vec3(0.08, 0.08, 0.08) : Vec3(0.55, 0.4, 0.25)), cv::FILLED);
  cv::Rect in(r.x + border, r.y + border, r.width - 2 * border, r.height - 2 * border);
  if (in.width < 4 || in.height < 4) return;
  Mat roi = c.img(in);
  switch (kind) {
    case 0:  // Mondrian art print
      roi.setTo(bgr(Vec3(0.95, 0.94, 0.9)));
      mondrian(c, in, 14, 0.04, 0.3, true);
      break;
    case 1: {  // text document / notice board
      roi.setTo(bgr(Vec3(0.96, 0.96, 0.93)));
      const int title = std::max(4, c.px(0.05));
      cv::rectangle(c.img, cv::Rect(in.x + title / 2, in.y + title / 2, in.width * 2 / 3, title), bgr(vivid(c.rng)),
                    cv::FILLED);
      textBlock(c, cv::Rect(in.x + title / 2, in.y + 2 * title, in.width - title, in.height - 2 * title),
                Vec3(0.1, 0.1, 0.15), 0.025);
      break;
    }
    case 2:  // photo-like: sky/ground with shapes
      roi.setTo(bgr(jitter(c.rng, Vec3(0.5, 0.7, 0.9), 0.15)));
      cv::rectangle(c.img, cv::Rect(in.x, in.y + in.height / 2, in.width, in.height - in.height / 2),
                    bgr(jitter(c.rng, Vec3(0.3, 0.5, 0.2), 0.15)), cv::FILLED);
      blobsIn(c, in, 12, 0.02, 0.12);
      mondrian(c, in, 5, 0.03, 0.12, true);
      break;
    case 3: {  // bar chart
      roi.setTo(bgr(Vec3(0.97, 0.97, 0.97)));
      const int nb = c.rng.integer(5, 10);
      const int bw = in.width / (nb + 1);
      for (int i = 0; i < nb; i++) {
        const int h = c.rng.integer(in.height / 8, in.height * 3 / 4);
        cv::rectangle(c.img, cv::Rect(in.x + bw / 2 + i * bw, in.y + in.height - h - 4, bw * 2 / 3, h), bgr(vivid(c.rng)),
                      cv::FILLED);
      }
      textBlock(c, cv::Rect(in.x, in.y, in.width, in.height / 5), Vec3(0.2, 0.2, 0.2), 0.02);
      break;
    }
    case 4: {  // calendar grid
      roi.setTo(bgr(Vec3(0.98, 0.98, 0.95)));
      const int cols = 7, rows = 5;
      const int cw = in.width / cols, ch = in.height / (rows + 1);
      cv::rectangle(c.img, cv::Rect(in.x, in.y, in.width, ch), bgr(vivid(c.rng)), cv::FILLED);
      for (int y = 0; y < rows; y++)
        for (int x = 0; x < cols; x++) {
          cv::Rect cell(in.x + x * cw, in.y + (y + 1) * ch, cw, ch);
          cv::rectangle(c.img, cell, bgr(Vec3(0.3, 0.3, 0.3)), 1);
          if (c.rng.uniform() < 0.35)
            cv::rectangle(c.img, cv::Rect(cell.x + cw / 5, cell.y + ch / 4, cw / 2, ch / 3), bgr(vivid(c.rng)), cv::FILLED);
          cv::circle(c.img, Point(cell.x + cw / 6, cell.y + ch / 5), std::max(1, ch / 10), bgr(Vec3(0.1, 0.1, 0.1)),
                     cv::FILLED);
        }
      break;
    }
    case 5: {  // whiteboard with scribbles
      roi.setTo(bgr(Vec3(0.97, 0.97, 0.98)));
      for (int i = 0; i < 25; i++) {
        std::vector<Point> pts;
        Point p(in.x + c.rng.integer(0, in.width - 1), in.y + c.rng.integer(0, in.height - 1));
        for (int k = 0; k < 6; k++) {
          pts.push_back(p);
          p += Point(c.rng.integer(-c.px(0.08), c.px(0.08)), c.rng.integer(-c.px(0.05), c.px(0.05)));
        }
        cv::polylines(c.img, pts, false, bgr(c.rng.uniform() < 0.5 ? Vec3(0.1, 0.1, 0.5) : Vec3(0.7, 0.1, 0.1)),
                      std::max(1, c.px(0.005)), cv::LINE_AA);
      }
      textBlock(c, cv::Rect(in.x + in.width / 10, in.y + in.height / 10, in.width / 2, in.height / 2),
                Vec3(0.1, 0.3, 0.1), 0.035);
      break;
    }
    default:  // geometric print
      roi.setTo(bgr(vivid(c.rng)));
      for (int i = 0; i < 10; i++) {
        const Point p(in.x + c.rng.integer(0, in.width - 1), in.y + c.rng.integer(0, in.height - 1));
        const int rad = c.rng.integer(c.px(0.02), c.px(0.1));
        if (c.rng.uniform() < 0.5)
          cv::circle(c.img, p, rad, bgr(vivid(c.rng)), cv::FILLED, cv::LINE_AA);
        else
          cv::rectangle(c.img, cv::Rect(p.x - rad, p.y - rad, 2 * rad, rad), bgr(vivid(c.rng)), cv::FILLED);
      }
      textBlock(c, cv::Rect(in.x, in.y + in.height * 3 / 4, in.width, in.height / 4), Vec3(0.02, 0.02, 0.02), 0.03);
  }
}

void genPosters(Ctx& c) {
  const Vec3 base = c.spec.has_color ? c.spec.color : jitter(c.rng, Vec3(0.86, 0.84, 0.78), 0.05);
  c.img.setTo(bgr(base));
  mottle(c, 10, 0.4);
  speckles(c, static_cast<int>(c.img.total() / 1500), 0.004, base, 0.25);
  const int H = c.img.rows, W = c.img.cols;
  // Skirting board and a picture rail.
  cv::rectangle(c.img, cv::Rect(0, H - c.px(0.09), W, c.px(0.09)), bgr(Vec3(0.3, 0.25, 0.2)), cv::FILLED);
  // Posters on a jittered grid between 0.25 m and 2.5 m (rows from the bottom).
  const int y_top = std::max(0, H - c.px(2.55)), y_bot = H - c.px(0.25);
  const int cell = c.px(0.75);
  for (int gy = y_top; gy + cell / 3 < y_bot; gy += cell) {
    for (int gx = 0; gx + cell / 3 < W; gx += cell) {
      if (c.rng.uniform() < 0.12) {  // bare patch with sockets / switches
        const Point p(gx + c.rng.integer(0, cell / 2), gy + c.rng.integer(cell / 3, cell - 1));
        cv::rectangle(c.img, cv::Rect(p.x, p.y, c.px(0.08), c.px(0.08)), bgr(Vec3(0.97, 0.97, 0.97)), cv::FILLED);
        cv::rectangle(c.img, cv::Rect(p.x, p.y, c.px(0.08), c.px(0.08)), bgr(Vec3(0.5, 0.5, 0.5)), 1);
        cv::circle(c.img, p + Point(c.px(0.025), c.px(0.04)), std::max(1, c.px(0.006)), bgr(Vec3(0.1, 0.1, 0.1)),
                   cv::FILLED);
        cv::circle(c.img, p + Point(c.px(0.055), c.px(0.04)), std::max(1, c.px(0.006)), bgr(Vec3(0.1, 0.1, 0.1)),
                   cv::FILLED);
        continue;
      }
      const int w = c.rng.integer(cell * 5 / 10, cell * 9 / 10), h = c.rng.integer(cell * 5 / 10, cell * 9 / 10);
      const int x = gx + c.rng.integer(0, cell - w), y = gy + c.rng.integer(0, cell - h);
      cv::Rect r = cv::Rect(x, y, w, h) & cv::Rect(0, 0, W, H);
      if (r.width > 8 && r.height > 8) poster(c, r);
    }
  }
}

void genTiles(Ctx& c) {
  const Vec3 base = c.spec.has_color ? c.spec.color : Vec3(0.62, 0.58, 0.52);
  c.img.setTo(bgr(base));
  const int t = c.px(0.4);
  const int grout = std::max(2, c.px(0.008));
  for (int y = 0; y < c.img.rows; y += t)
    for (int x = 0; x < c.img.cols; x += t) {
      const Vec3 tc = jitter(c.rng, base * c.rng.uniform(0.85, 1.12), 0.025);
      cv::Rect r(x + grout / 2, y + grout / 2, t - grout, t - grout);
      r &= cv::Rect(0, 0, c.img.cols, c.img.rows);
      cv::rectangle(c.img, r, bgr(tc), cv::FILLED);
      // Terrazzo chips.
      for (int k = 0; k < 70; k++) {
        const Point p(r.x + c.rng.integer(0, std::max(0, r.width - 1)), r.y + c.rng.integer(0, std::max(0, r.height - 1)));
        const int rad = std::max(1, static_cast<int>(c.px(0.012) * c.rng.uniform(0.3, 1.4)));
        const Vec3 cc = c.rng.uniform() < 0.5 ? clamp01(tc * c.rng.uniform(0.35, 0.6)) : clamp01(tc * 1.35 + Vec3(0.1, 0.1, 0.1));
        std::vector<Point> poly;
        const int nv = c.rng.integer(3, 6);
        for (int v = 0; v < nv; v++) {
          const double a = 2 * M_PI * v / nv + c.rng.uniform(0, 0.8);
          poly.push_back(p + Point(static_cast<int>(rad * std::cos(a)), static_cast<int>(rad * std::sin(a))));
        }
        cv::fillConvexPoly(c.img, poly, bgr(cc), cv::LINE_AA);
      }
    }
  // Grout lines.
  for (int y = 0; y < c.img.rows; y += t) cv::rectangle(c.img, cv::Rect(0, y - grout / 2, c.img.cols, grout), bgr(base * 0.4), cv::FILLED);
  for (int x = 0; x < c.img.cols; x += t) cv::rectangle(c.img, cv::Rect(x - grout / 2, 0, grout, c.img.rows), bgr(base * 0.4), cv::FILLED);
  mottle(c, 8, 0.8);
}

void genWood(Ctx& c) {
  const Vec3 base = c.spec.has_color ? c.spec.color : Vec3(0.55, 0.38, 0.22);
  // Grain: noise stretched along x.
  const int gw = std::max(4, c.img.cols / std::max(1, c.px(0.2))), gh = std::max(4, c.img.rows / std::max(1, c.px(0.004)));
  Mat g(gh, gw, CV_32F);
  for (int y = 0; y < gh; y++)
    for (int x = 0; x < gw; x++) g.at<float>(y, x) = static_cast<float>(c.rng.uniform(-1, 1));
  Mat big;
  cv::resize(g, big, c.img.size(), 0, 0, cv::INTER_LINEAR);
  const int plank = c.px(0.12);
  for (int y = 0; y < c.img.rows; y++) {
    auto* p = c.img.ptr<cv::Vec3b>(y);
    const float* q = big.ptr<float>(y);
    const int pi = y / plank;
    const double pf = 0.85 + 0.3 * hashUniform(c.spec.seed, 7, pi, 0);
    for (int x = 0; x < c.img.cols; x++) {
      const double v = pf * (1.0 + 0.22 * q[x]);
      const Vec3 col = clamp01(base * v);
      p[x] = cv::Vec3b(cv::saturate_cast<uchar>(255 * col.z()), cv::saturate_cast<uchar>(255 * col.y()),
                       cv::saturate_cast<uchar>(255 * col.x()));
    }
  }
  for (int y = 0; y < c.img.rows; y += plank) {
    cv::line(c.img, Point(0, y), Point(c.img.cols, y), bgr(base * 0.35), std::max(1, c.px(0.004)));
    // Staggered butt joints.
    for (int x = c.rng.integer(0, c.px(0.6)); x < c.img.cols; x += c.px(c.rng.uniform(0.6, 1.4)))
      cv::line(c.img, Point(x, y), Point(x, y + plank), bgr(base * 0.35), std::max(1, c.px(0.004)));
  }
  for (int k = 0; k < static_cast<int>(c.img.total() / 40000) + 2; k++) {
    const Point p(c.rng.integer(0, c.img.cols - 1), c.rng.integer(0, c.img.rows - 1));
    cv::ellipse(c.img, p, cv::Size(c.px(0.025), c.px(0.01)), 0, 0, 360, bgr(base * 0.45), cv::FILLED, cv::LINE_AA);
    cv::ellipse(c.img, p, cv::Size(c.px(0.04), c.px(0.018)), 0, 0, 360, bgr(base * 0.6), 1, cv::LINE_AA);
  }
  // Objects on wood surfaces: papers, notes.
  for (int k = 0; k < static_cast<int>(c.img.total() / 60000) + 1; k++) {
    const cv::Rect r(c.rng.integer(0, c.img.cols - 1), c.rng.integer(0, c.img.rows - 1), c.px(c.rng.uniform(0.08, 0.25)),
                     c.px(c.rng.uniform(0.08, 0.3)));
    const cv::Rect rr = r & cv::Rect(0, 0, c.img.cols, c.img.rows);
    if (rr.area() < 16) continue;
    c.img(rr).setTo(bgr(c.rng.uniform() < 0.5 ? Vec3(0.95, 0.95, 0.92) : Vec3(0.95, 0.9, 0.3)));
    textBlock(c, rr, Vec3(0.1, 0.1, 0.2), 0.015);
  }
}

void genStripes(Ctx& c, bool checks) {
  const Vec3 base = c.spec.has_color ? c.spec.color : vivid(c.rng);
  const Vec3 a = clamp01(base * 0.45), b = clamp01(base * 1.3 + Vec3(0.15, 0.15, 0.15));
  c.img.setTo(bgr(base));
  int y = 0;
  while (y < c.img.rows) {
    const int w = c.px(c.rng.uniform(0.008, 0.035));
    cv::rectangle(c.img, cv::Rect(0, y, c.img.cols, w), bgr(c.rng.uniform() < 0.5 ? a : b), cv::FILLED);
    y += w + c.px(c.rng.uniform(0.01, 0.05));
  }
  if (checks) {
    Mat over = c.img.clone();
    int x = 0;
    while (x < c.img.cols) {
      const int w = c.px(c.rng.uniform(0.008, 0.035));
      cv::rectangle(over, cv::Rect(x, 0, w, c.img.rows), bgr(c.rng.uniform() < 0.5 ? a : b), cv::FILLED);
      x += w + c.px(c.rng.uniform(0.01, 0.05));
    }
    cv::addWeighted(c.img, 0.5, over, 0.5, 0, c.img);
  }
  // Buttons, pockets, logos: a few sharp marks.
  for (int k = 0; k < 14; k++) {
    const Point p(c.rng.integer(0, c.img.cols - 1), c.rng.integer(0, c.img.rows - 1));
    cv::circle(c.img, p, std::max(1, c.px(0.008)), bgr(c.rng.uniform() < 0.5 ? Vec3(0.05, 0.05, 0.05) : Vec3(0.95, 0.95, 0.95)),
               cv::FILLED, cv::LINE_AA);
  }
  grain(c, 6);
}

void genPrint(Ctx& c) {
  const Vec3 base = c.spec.has_color ? c.spec.color : vivid(c.rng);
  c.img.setTo(bgr(base));
  cv::Rect r(0, 0, c.img.cols, c.img.rows);
  blobsIn(c, r, 10, 0.02, 0.07);
  mondrian(c, r, 10, 0.02, 0.08, true);
  textBlock(c, cv::Rect(c.img.cols / 8, c.img.rows / 3, c.img.cols / 4, c.img.rows / 4), Vec3(0.02, 0.02, 0.02), 0.03);
  grain(c, 6);
}

void genBlobs(Ctx& c) {
  c.img.setTo(bgr(c.spec.has_color ? c.spec.color : Vec3(0.7, 0.7, 0.7)));
  blobsIn(c, cv::Rect(0, 0, c.img.cols, c.img.rows), static_cast<int>(c.img.total() / 3000) + 10, 0.01, 0.08);
}

void genRects(Ctx& c) {
  c.img.setTo(bgr(c.spec.has_color ? c.spec.color : Vec3(0.6, 0.5, 0.4)));
  mondrian(c, cv::Rect(0, 0, c.img.cols, c.img.rows), static_cast<int>(c.img.total() / 2500) + 10, 0.02, 0.12, true);
  grain(c, 4);
}

void genConcrete(Ctx& c) {
  const Vec3 base = c.spec.has_color ? c.spec.color : Vec3(0.6, 0.6, 0.58);
  c.img.setTo(bgr(base));
  mottle(c, 25, 0.3);
  mottle(c, 12, 0.05);
  speckles(c, static_cast<int>(c.img.total() / 300), 0.005, base, 0.3);
  grain(c, 8);
}

void genCeiling(Ctx& c) {
  const Vec3 base = c.spec.has_color ? c.spec.color : Vec3(0.9, 0.9, 0.88);
  c.img.setTo(bgr(base));
  const int t = c.px(0.6);
  for (int y = 0; y < c.img.rows; y += t)
    for (int x = 0; x < c.img.cols; x += t) {
      cv::Rect r(x, y, t, t);
      if (c.rng.uniform() < 0.12) {  // light panel
        c.img(r & cv::Rect(0, 0, c.img.cols, c.img.rows)).setTo(Scalar(250, 250, 250));
        for (int k = 1; k < 4; k++)
          cv::line(c.img, Point(x + k * t / 4, y), Point(x + k * t / 4, y + t), bgr(Vec3(0.7, 0.7, 0.72)), 2);
        continue;
      }
      speckles(c, 60, 0.006, base, 0.35, r & cv::Rect(0, 0, c.img.cols, c.img.rows));
    }
  for (int y = 0; y < c.img.rows; y += t) cv::line(c.img, Point(0, y), Point(c.img.cols, y), bgr(Vec3(0.5, 0.5, 0.5)), std::max(2, c.px(0.012)));
  for (int x = 0; x < c.img.cols; x += t) cv::line(c.img, Point(x, 0), Point(x, c.img.rows), bgr(Vec3(0.5, 0.5, 0.5)), std::max(2, c.px(0.012)));
}

void genBooks(Ctx& c) {
  const Vec3 wood = c.spec.has_color ? c.spec.color : Vec3(0.5, 0.35, 0.2);
  c.img.setTo(bgr(wood * 0.4));
  const int shelf = c.px(0.36), board = c.px(0.025);
  for (int y = 0; y < c.img.rows; y += shelf) {
    cv::rectangle(c.img, cv::Rect(0, y, c.img.cols, board), bgr(wood), cv::FILLED);
    int x = c.rng.integer(0, c.px(0.05));
    while (x < c.img.cols) {
      const int w = c.px(c.rng.uniform(0.02, 0.06));
      const int h = c.px(c.rng.uniform(0.18, 0.31));
      if (c.rng.uniform() < 0.08) {
        x += c.px(0.08);
        continue;
      }
      const Vec3 bc = vivid(c.rng);
      const cv::Rect r(x, y + shelf - h, w, h);
      cv::rectangle(c.img, r, bgr(bc), cv::FILLED);
      cv::rectangle(c.img, cv::Rect(x, y + shelf - h + h / 5, w, std::max(1, h / 12)), bgr(clamp01(Vec3(1, 1, 1) - bc)), cv::FILLED);
      cv::rectangle(c.img, cv::Rect(x + w / 4, y + shelf - h / 2, std::max(1, w / 2), h / 4), bgr(bc * 0.4), cv::FILLED);
      x += w + 1;
    }
  }
}

void genCarpet(Ctx& c) {
  const Vec3 base = c.spec.has_color ? c.spec.color : Vec3(0.3, 0.3, 0.45);
  c.img.setTo(bgr(base));
  const int t = c.px(0.06);
  for (int y = 0; y < c.img.rows; y += t)
    for (int x = 0; x < c.img.cols; x += t)
      if (((x / t) + (y / t)) % 2 == 0)
        cv::rectangle(c.img, cv::Rect(x + t / 4, y + t / 4, t / 2, t / 2), bgr(clamp01(base * 1.6 + Vec3(0.1, 0.1, 0.1))), cv::FILLED);
      else
        cv::circle(c.img, Point(x + t / 2, y + t / 2), std::max(1, t / 5), bgr(base * 0.4), cv::FILLED);
  grain(c, 10);
}

void genDenim(Ctx& c) {
  const Vec3 base = c.spec.has_color ? c.spec.color : Vec3(0.15, 0.2, 0.35);
  c.img.setTo(bgr(base));
  const int s = std::max(2, c.px(0.004));
  for (int k = -c.img.rows; k < c.img.cols; k += 2 * s)
    cv::line(c.img, Point(k, c.img.rows), Point(k + c.img.rows, 0), bgr(clamp01(base * 1.35)), std::max(1, s / 2));
  // Seams, pockets, belt.
  for (int k = 0; k < 8; k++) {
    const cv::Rect r(c.rng.integer(0, c.img.cols - 1), c.rng.integer(0, c.img.rows - 1), c.px(0.12), c.px(0.1));
    cv::rectangle(c.img, r, bgr(Vec3(0.8, 0.6, 0.3)), std::max(1, c.px(0.004)));
    cv::circle(c.img, Point(r.x, r.y), std::max(1, c.px(0.007)), bgr(Vec3(0.85, 0.75, 0.4)), cv::FILLED);
  }
  grain(c, 12);
}

void genLeaves(Ctx& c) {
  const Vec3 base = c.spec.has_color ? c.spec.color : Vec3(0.2, 0.45, 0.2);
  c.img.setTo(bgr(base * 0.3));
  for (int k = 0; k < static_cast<int>(c.img.total() / 250) + 20; k++) {
    const Point p(c.rng.integer(0, c.img.cols - 1), c.rng.integer(0, c.img.rows - 1));
    const cv::Size ax(c.px(c.rng.uniform(0.02, 0.05)), c.px(c.rng.uniform(0.006, 0.015)));
    cv::ellipse(c.img, p, ax, c.rng.uniform(0, 180), 0, 360, bgr(clamp01(base * c.rng.uniform(0.6, 1.6))), cv::FILLED,
                cv::LINE_AA);
  }
}

void genScreen(Ctx& c) {
  c.img.setTo(bgr(c.spec.has_color ? c.spec.color : Vec3(0.1, 0.1, 0.12)));
  // Bezel is dark; the screen area (upper part of the box unwrap) shows windows.
  const cv::Rect all(0, 0, c.img.cols, c.img.rows);
  for (int k = 0; k < 8; k++) {
    const cv::Rect r(c.rng.integer(0, c.img.cols - 1), c.rng.integer(0, c.img.rows - 1), c.px(c.rng.uniform(0.1, 0.3)),
                     c.px(c.rng.uniform(0.08, 0.2)));
    const cv::Rect rr = r & all;
    if (rr.area() < 16) continue;
    c.img(rr).setTo(bgr(c.rng.uniform() < 0.6 ? Vec3(0.92, 0.92, 0.95) : vivid(c.rng)));
    cv::rectangle(c.img, cv::Rect(rr.x, rr.y, rr.width, std::max(2, c.px(0.012))), bgr(Vec3(0.2, 0.3, 0.6)), cv::FILLED);
    textBlock(c, rr, Vec3(0.1, 0.1, 0.1), 0.012);
  }
}

void genPlain(Ctx& c, double noise) {
  c.img.setTo(bgr(c.spec.color));
  mottle(c, noise * 2, 0.1);
  grain(c, noise);
}

void genMetal(Ctx& c) {
  const Vec3 base = c.spec.has_color ? c.spec.color : Vec3(0.6, 0.62, 0.65);
  c.img.setTo(bgr(base));
  addField(c, 8, c.img.rows, 20, cv::INTER_LINEAR);  // brushed: 8 columns stretched across
  speckles(c, static_cast<int>(c.img.total() / 2000) + 5, 0.006, base, 0.4);
}

}  // namespace

Texture::Texture(const TextureSpec& spec, double width_m, double height_m, double tpm) : tpm_(tpm) {
  // Sizes are multiples of 64 so that 6 mip levels halve exactly.
  auto dim = [&](double m) { return std::max(64, static_cast<int>(std::ceil(m * tpm / 64.0)) * 64); };
  const int W = dim(width_m), H = dim(height_m);
  Ctx c{Mat(H, W, CV_8UC3, Scalar(128, 128, 128)), tpm, Rng(spec.seed, 0x7e47), spec};
  const std::string& k = spec.kind;
  if (k == "posters") genPosters(c);
  else if (k == "tiles") genTiles(c);
  else if (k == "wood") genWood(c);
  else if (k == "stripes") genStripes(c, false);
  else if (k == "checks") genStripes(c, true);
  else if (k == "print") genPrint(c);
  else if (k == "blobs") genBlobs(c);
  else if (k == "rects") genRects(c);
  else if (k == "concrete") genConcrete(c);
  else if (k == "ceiling") genCeiling(c);
  else if (k == "books") genBooks(c);
  else if (k == "carpet") genCarpet(c);
  else if (k == "denim") genDenim(c);
  else if (k == "leaves") genLeaves(c);
  else if (k == "screen") genScreen(c);
  else if (k == "skin") genPlain(c, 3);
  else if (k == "metal") genMetal(c);
  else genPlain(c, 2);
  // Level 0 is lightly pre-filtered so that drawn edges are not aliased.
  cv::GaussianBlur(c.img, c.img, cv::Size(3, 3), 0.6, 0.6, cv::BORDER_REFLECT);
  mips_.push_back(c.img);
  while (mips_.back().cols % 2 == 0 && mips_.back().rows % 2 == 0 && mips_.back().cols >= 16 && mips_.back().rows >= 16) {
    Mat d;
    cv::pyrDown(mips_.back(), d);
    mips_.push_back(d);
  }
}

}  // namespace dslam::synth
