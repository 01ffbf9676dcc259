#include "dslam/synth/renderer.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <map>
#include <thread>

#include "dslam/core/coco.h"
#include "dslam/core/error.h"
#include "dslam/synth/rng.h"
#include "texture.h"

namespace dslam::synth {

namespace {

using Kind = Primitive::Kind;
constexpr int kTile = 8;
constexpr double kTMin = 1e-4;
constexpr double kInf = std::numeric_limits<double>::infinity();

// Stuff categories of the room surfaces: walls -x,+x,-y,+y, floor, ceiling.
constexpr int kRoomCategory[6] = {199, 199, 199, 199, 190, 186};

/** Primitive prepared for one view (world->local rotation cached). */
struct Prep {
  const Primitive* p;
  Eigen::Matrix3d Rt;  // world -> local rotation
  Vec3 o_l;            // camera centre in the local frame
  Vec3 oc;             // bounding-sphere centre relative to the camera centre (world)
  double rho2;         // squared bounding radius
};

/** Half extents of a primitive's local bounding box. */
Vec3 localExtent(const Primitive& P) {
  switch (P.kind) {
    case Kind::Capsule: return Vec3(P.half.x(), P.half.x(), P.half.z() + P.half.x());
    case Kind::Quad: return Vec3(1e-3, P.half.y(), P.half.z());
    default: return P.half;
  }
}

struct Hit {
  double t = kInf;
  Vec3 n_l;  // local normal
  Vec3 p_l;  // local point
};

inline bool solveQuad(double a, double b, double c, double& t0, double& t1) {
  const double disc = b * b - 4 * a * c;
  if (disc < 0 || a <= 0) return false;
  const double s = std::sqrt(disc);
  const double q = b < 0 ? -0.5 * (b - s) : -0.5 * (b + s);
  t0 = q / a;
  t1 = c / q;
  if (t0 > t1) std::swap(t0, t1);
  return true;
}

/** Intersection in the local frame (o, d); returns true if t < h.t. */
bool intersect(const Primitive& P, const Vec3& o, const Vec3& d, Hit& h) {
  const Vec3& hs = P.half;
  switch (P.kind) {
    case Kind::Box: {
      double tn = -kInf, tf = kInf;
      int axis = 0;
      for (int a = 0; a < 3; a++) {
        if (std::abs(d[a]) < 1e-12) {
          if (std::abs(o[a]) > hs[a]) return false;
          continue;
        }
        double t1 = (-hs[a] - o[a]) / d[a], t2 = (hs[a] - o[a]) / d[a];
        if (t1 > t2) std::swap(t1, t2);
        if (t1 > tn) {
          tn = t1;
          axis = a;
        }
        tf = std::min(tf, t2);
      }
      if (tn > tf || tf < kTMin) return false;
      const double t = tn > kTMin ? tn : tf;
      if (t >= h.t) return false;
      h.t = t;
      h.p_l = o + t * d;
      h.n_l = Vec3::Zero();
      h.n_l[axis] = d[axis] > 0 ? -1 : 1;
      return true;
    }
    case Kind::Cylinder: {
      bool hit = false;
      const double ox = o.x() / hs.x(), oy = o.y() / hs.y(), dx = d.x() / hs.x(), dy = d.y() / hs.y();
      double t0, t1;
      if (solveQuad(dx * dx + dy * dy, 2 * (ox * dx + oy * dy), ox * ox + oy * oy - 1, t0, t1)) {
        for (double t : {t0, t1}) {
          if (t <= kTMin || t >= h.t) continue;
          const double z = o.z() + t * d.z();
          if (std::abs(z) > hs.z()) continue;
          h.t = t;
          h.p_l = o + t * d;
          h.n_l = Vec3(h.p_l.x() / (hs.x() * hs.x()), h.p_l.y() / (hs.y() * hs.y()), 0).normalized();
          hit = true;
          break;
        }
      }
      if (std::abs(d.z()) > 1e-12) {
        for (int sgn = -1; sgn <= 1; sgn += 2) {
          const double t = (sgn * hs.z() - o.z()) / d.z();
          if (t <= kTMin || t >= h.t) continue;
          const Vec3 p = o + t * d;
          if ((p.x() / hs.x()) * (p.x() / hs.x()) + (p.y() / hs.y()) * (p.y() / hs.y()) > 1) continue;
          h.t = t;
          h.p_l = p;
          h.n_l = Vec3(0, 0, sgn);
          hit = true;
        }
      }
      return hit;
    }
    case Kind::Ellipsoid: {
      const Vec3 O = o.cwiseQuotient(hs), D = d.cwiseQuotient(hs);
      double t0, t1;
      if (!solveQuad(D.squaredNorm(), 2 * O.dot(D), O.squaredNorm() - 1, t0, t1)) return false;
      const double t = t0 > kTMin ? t0 : t1;
      if (t <= kTMin || t >= h.t) return false;
      h.t = t;
      h.p_l = o + t * d;
      h.n_l = h.p_l.cwiseQuotient(hs.cwiseProduct(hs)).normalized();
      return true;
    }
    case Kind::Capsule: {
      const double r = hs.x(), L = hs.z();
      bool hit = false;
      double t0, t1;
      if (solveQuad(d.x() * d.x() + d.y() * d.y(), 2 * (o.x() * d.x() + o.y() * d.y()),
                    o.x() * o.x() + o.y() * o.y() - r * r, t0, t1)) {
        for (double t : {t0, t1}) {
          if (t <= kTMin || t >= h.t) continue;
          const double z = o.z() + t * d.z();
          if (std::abs(z) > L) continue;
          h.t = t;
          h.p_l = o + t * d;
          h.n_l = Vec3(h.p_l.x(), h.p_l.y(), 0).normalized();
          hit = true;
          break;
        }
      }
      for (int sgn = -1; sgn <= 1; sgn += 2) {
        const Vec3 oc = o - Vec3(0, 0, sgn * L);
        if (!solveQuad(d.squaredNorm(), 2 * oc.dot(d), oc.squaredNorm() - r * r, t0, t1)) continue;
        const double t = t0 > kTMin ? t0 : t1;
        if (t <= kTMin || t >= h.t) continue;
        const Vec3 p = o + t * d;
        if (sgn * p.z() < L) continue;  // that part of the sphere is inside the cylinder
        h.t = t;
        h.p_l = p;
        h.n_l = (p - Vec3(0, 0, sgn * L)).normalized();
        hit = true;
      }
      return hit;
    }
    case Kind::Quad: {
      if (std::abs(d.x()) < 1e-12) return false;
      const double t = -o.x() / d.x();
      if (t <= kTMin || t >= h.t) return false;
      const Vec3 p = o + t * d;
      if (std::abs(p.y()) > hs.y() || std::abs(p.z()) > hs.z()) return false;
      h.t = t;
      h.p_l = p;
      h.n_l = Vec3(d.x() > 0 ? -1 : 1, 0, 0);
      return true;
    }
  }
  return false;
}

/** Texture coordinates (metres) of a local hit. */
inline void uvOf(const Primitive& P, const Vec3& p, const Vec3& n, double& u, double& v) {
  const Vec3& hs = P.half;
  u = v = 0;
  switch (P.kind) {
    case Kind::Box: {
      if (std::abs(n.z()) > 0.5) {
        u = p.x() + hs.x() + (n.z() < 0 ? 2 * hs.x() : 0);
        v = 2 * hs.z() + p.y() + hs.y();
      } else if (n.x() > 0.5) {
        u = hs.y() + p.y();
        v = p.z() + hs.z();
      } else if (n.y() > 0.5) {
        u = 2 * hs.y() + hs.x() - p.x();
        v = p.z() + hs.z();
      } else if (n.x() < -0.5) {
        u = 2 * hs.y() + 2 * hs.x() + hs.y() - p.y();
        v = p.z() + hs.z();
      } else {
        u = 4 * hs.y() + 2 * hs.x() + p.x() + hs.x();
        v = p.z() + hs.z();
      }
      break;
    }
    case Kind::Cylinder: {
      const double rm = 0.5 * (hs.x() + hs.y());
      if (std::abs(n.z()) > 0.99) {
        u = p.x() + hs.x();
        v = 2 * hs.z() + p.y() + hs.y();
      } else {
        u = (std::atan2(p.y() / hs.y(), p.x() / hs.x()) + M_PI) * rm;
        v = p.z() + hs.z();
      }
      break;
    }
    case Kind::Ellipsoid: {
      const double rm = 0.5 * (hs.x() + hs.y());
      u = (std::atan2(p.y() / hs.y(), p.x() / hs.x()) + M_PI) * rm;
      v = p.z() + hs.z();
      break;
    }
    case Kind::Capsule:
      u = (std::atan2(p.y(), p.x()) + M_PI) * hs.x();
      v = p.z() + hs.z() + hs.x();
      break;
    case Kind::Quad:
      u = p.y() + hs.y();
      v = p.z() + hs.z();
      break;
  }
  u += P.uv_offset.x();
  v += P.uv_offset.y();
}

/** 65536 standard-normal samples (deterministic), indexed by hash bits. */
const std::vector<float>& gaussTable() {
  static const std::vector<float> t = [] {
    std::vector<float> v(65536);
    Rng r(0x6a055, 1);
    for (auto& x : v) x = static_cast<float>(r.gauss());
    return v;
  }();
  return t;
}

/** Runs `work` on `threads` threads (the calling one included) and waits
 *  for all of them; `work` takes its share of a common job counter. */
template <class F>
void onThreads(int threads, F& work) {
  std::vector<std::thread> pool;
  for (int i = 1; i < threads; i++) pool.emplace_back(work);
  work();
  for (auto& th : pool) th.join();
}

}  // namespace

int panopticId(const InstanceInfo& inst) {
  if (!inst.labelled || inst.category_id <= 0) return 0;
  return inst.isthing ? 1000 + inst.instance_id : inst.category_id;
}

struct Renderer::Impl {
  Scenario s;
  SceneModel scene;
  RenderOptions opt;
  std::vector<std::unique_ptr<Texture>> textures;
  Vec3 light = Vec3(0.4, 0.3, 0.85).normalized();
  int threads = 1;

  explicit Impl(const Scenario& sc, const RenderOptions& o) : s(sc), scene(s), opt(o) {
    // Texel density follows the focal length: about one texel per pixel at 1.5 m.
    const double tpm = std::clamp(s.intrinsics.fx / 1.5, 96.0, 400.0);
    threads = o.threads > 0 ? o.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    // Textures are independent (own seeds): build them in parallel.
    const auto& mats = scene.materials();
    textures.resize(mats.size());
    std::atomic<size_t> next{0};
    auto build = [&]() {
      for (size_t i = next++; i < mats.size(); i = next++)
        textures[i] = std::make_unique<Texture>(mats[i].spec, mats[i].width_m, mats[i].height_m, tpm);
    };
    onThreads(threads, build);
  }

  /** Primitives in view, prepared for ray casting, and binned into the
   *  kTile x kTile tiles their projected bound overlaps (`bins`: prep
   *  indices per tile, TW x TH tiles). */
  std::vector<Prep> binPrimitives(const SE3& T_wc, const std::vector<Primitive>& prims, int TW, int TH,
                                  std::vector<std::vector<int>>& bins) const {
    const auto& K = s.intrinsics;
    const Eigen::Matrix3d R = T_wc.rotation();
    const Vec3 o = T_wc.translation();
    bins.assign(static_cast<size_t>(TW * TH), {});
    std::vector<Prep> prep;
    prep.reserve(prims.size());
    for (const auto& P : prims) {
      const Vec3 c = R.transpose() * (P.T_wl.translation() - o);
      const double rho = P.bound_radius * 1.01 + 1e-3;
      if (c.z() + rho <= 0) continue;  // behind the camera
      int x0 = 0, x1 = TW - 1, y0 = 0, y1 = TH - 1;
      auto range = [&](double a, double z, double f, double cc, int& lo, int& hi) {
        const double L = std::hypot(a, z);
        if (L <= rho) return;
        const double al = std::asin(rho / L), be = std::atan2(a, z);
        const double mn = be - al, mx = be + al;
        const double umin = mn <= -M_PI / 2 ? -1e9 : f * std::tan(mn) + cc;
        const double umax = mx >= M_PI / 2 ? 1e9 : f * std::tan(mx) + cc;
        if (mn <= -M_PI / 2 && mx >= M_PI / 2) return;
        lo = std::max(lo, static_cast<int>(std::floor((umin - 1) / kTile)));
        hi = std::min(hi, static_cast<int>(std::floor((umax + 1) / kTile)));
      };
      // Tight bound: the projected corners of the local bounding box when all
      // are in front of the camera, else the bounding-sphere cone.
      const Vec3 e = localExtent(P);
      const Eigen::Matrix3d Rcl = R.transpose() * P.T_wl.rotation();
      double umin = 1e18, umax = -1e18, vmin = 1e18, vmax = -1e18;
      bool front = true;
      for (int k = 0; k < 8 && front; k++) {
        const Vec3 q = c + Rcl * Vec3(k & 1 ? e.x() : -e.x(), k & 2 ? e.y() : -e.y(), k & 4 ? e.z() : -e.z());
        if (q.z() < 0.02) {
          front = false;
          break;
        }
        const double u = K.fx * q.x() / q.z() + K.cx, v = K.fy * q.y() / q.z() + K.cy;
        umin = std::min(umin, u);
        umax = std::max(umax, u);
        vmin = std::min(vmin, v);
        vmax = std::max(vmax, v);
      }
      if (front) {
        x0 = std::max(x0, static_cast<int>(std::floor((umin - 1) / kTile)));
        x1 = std::min(x1, static_cast<int>(std::floor((umax + 1) / kTile)));
        y0 = std::max(y0, static_cast<int>(std::floor((vmin - 1) / kTile)));
        y1 = std::min(y1, static_cast<int>(std::floor((vmax + 1) / kTile)));
      } else {
        range(c.x(), c.z(), K.fx, K.cx, x0, x1);
        range(c.y(), c.z(), K.fy, K.cy, y0, y1);
      }
      if (x0 > x1 || y0 > y1) continue;
      const int idx = static_cast<int>(prep.size());
      const Eigen::Matrix3d Rt = P.T_wl.rotation().transpose();
      prep.push_back({&P, Rt, Rt * (o - P.T_wl.translation()), P.T_wl.translation() - o, rho * rho});
      for (int ty = y0; ty <= y1; ty++)
        for (int tx = x0; tx <= x1; tx++) bins[static_cast<size_t>(ty * TW + tx)].push_back(idx);
    }
    return prep;
  }

  /** Ray-casts one view into colour (CV_32FC3, BGR 0..255), z (CV_32F) and
   *  label code (CV_32S: >0 instance id, -1-surface for the room). */
  void view(const SE3& T_wc, const std::vector<Primitive>& prims, cv::Mat& color, cv::Mat& zbuf, cv::Mat& code) const {
    const int W = s.width, H = s.height;
    const auto& K = s.intrinsics;
    color.create(H, W, CV_32FC3);
    zbuf.create(H, W, CV_32F);
    code.create(H, W, CV_32S);
    const Eigen::Matrix3d R = T_wc.rotation();
    const Vec3 o = T_wc.translation();
    const int TW = (W + kTile - 1) / kTile, TH = (H + kTile - 1) / kTile;
    std::vector<std::vector<int>> bins;
    const std::vector<Prep> prep = binPrimitives(T_wc, prims, TW, TH, bins);
    const Vec3 half = s.room.size / 2;
    const Vec3 lo(-half.x(), -half.y(), 0), hi(half.x(), half.y(), s.room.size.z());
    std::atomic<int> next_row{0};
    auto work = [&]() {
      for (int ty = next_row++; ty < TH; ty = next_row++) {
        for (int y = ty * kTile; y < std::min(H, (ty + 1) * kTile); y++) {
          auto* crow = color.ptr<cv::Vec3f>(y);
          auto* zrow = zbuf.ptr<float>(y);
          auto* lrow = code.ptr<int>(y);
          for (int x = 0; x < W; x++) {
            const Vec3 dc((x - K.cx) / K.fx, (y - K.cy) / K.fy, 1.0);
            const Vec3 d = R * dc;
            // Room (always hit from inside).
            double t = kInf;
            int surf = 0;
            for (int a = 0; a < 3; a++) {
              if (std::abs(d[a]) < 1e-12) continue;
              const double ta = d[a] > 0 ? (hi[a] - o[a]) / d[a] : (lo[a] - o[a]) / d[a];
              if (ta < t) {
                t = ta;
                surf = a == 2 ? (d[a] > 0 ? 5 : 4) : 2 * a + (d[a] > 0 ? 1 : 0);
              }
            }
            Hit h;
            h.t = t;
            int best = -1;
            const double dd = d.squaredNorm();
            for (int idx : bins[static_cast<size_t>(ty * TW + x / kTile)]) {
              const Prep& pp = prep[static_cast<size_t>(idx)];
              // Cheap rejection by the bounding sphere (miss, or behind the current hit).
              const double tc = pp.oc.dot(d) / dd;
              const double m2 = (pp.oc - tc * d).squaredNorm();
              if (m2 > pp.rho2) continue;
              if ((tc - h.t) * (tc - h.t) * dd > pp.rho2 && tc > h.t) continue;
              if (intersect(*pp.p, pp.o_l, pp.Rt * d, h)) best = idx;
            }
            double u = 0, v = 0;
            Vec3 n;
            int mat;
            if (best >= 0) {
              const Prep& pp = prep[static_cast<size_t>(best)];
              uvOf(*pp.p, h.p_l, h.n_l, u, v);
              n = pp.p->T_wl.rotation() * h.n_l;
              mat = pp.p->material;
              lrow[x] = pp.p->instance_id;
            } else {
              const Vec3 p = o + t * d;
              n = Vec3::Zero();
              switch (surf) {
                case 0: n.x() = 1; u = p.y() + half.y(); v = p.z(); break;
                case 1: n.x() = -1; u = half.y() - p.y(); v = p.z(); break;
                case 2: n.y() = 1; u = half.x() - p.x(); v = p.z(); break;
                case 3: n.y() = -1; u = p.x() + half.x(); v = p.z(); break;
                case 4: n.z() = 1; u = p.x() + half.x(); v = p.y() + half.y(); break;
                default: n.z() = -1; u = p.x() + half.x(); v = p.y() + half.y(); break;
              }
              mat = scene.roomMaterial(surf);
              lrow[x] = -1 - surf;
            }
            const double z = h.t;
            zrow[x] = static_cast<float>(z);
            const double dn = dc.norm();
            const double cosv = std::abs(n.dot(d)) / d.norm();
            const double foot = z * dn / K.fx / std::sqrt(std::max(cosv, 0.05));
            float col[3];
            textures[static_cast<size_t>(mat)]->sample(u, v, foot, col);
            const float shade = static_cast<float>(0.72 + 0.28 * n.dot(light));
            crow[x] = cv::Vec3f(col[0] * shade, col[1] * shade, col[2] * shade);
          }
        }
      }
    };
    onThreads(threads, work);
  }

  /** Runs fn(y0, y1) over row bands on `threads` threads (bands are
   *  independent, so the result does not depend on the thread count). */
  template <class F>
  void parallelRows(int H, F&& fn) const {
    const int bands = std::min(H, 4 * threads);
    std::atomic<int> next{0};
    auto work = [&]() {
      for (int b = next++; b < bands; b = next++) fn(b * H / bands, (b + 1) * H / bands);
    };
    onThreads(threads, work);
  }

  /** Per-pixel random bits: one 64-bit hash per (frame, stream, pixel). */
  uint64_t pixelHash(int frame, uint64_t stream, int y, int x) const {
    return splitmix64(s.seed ^ splitmix64((static_cast<uint64_t>(frame) << 8) + stream) ^
                      (static_cast<uint64_t>(y) << 32 | static_cast<uint64_t>(x)));
  }

  /** Colour post-processing: lens blur, sensor noise, 8-bit. */
  cv::Mat finishColor(cv::Mat& color, int frame, uint64_t stream) const {
    if (s.noise.optics_blur > 0) cv::GaussianBlur(color, color, cv::Size(0, 0), s.noise.optics_blur);
    cv::Mat out(color.size(), CV_8UC3);
    const bool noisy = s.noise.enabled && s.noise.image_sigma > 0;
    const float sig = static_cast<float>(s.noise.image_sigma);
    const auto& G = gaussTable();
    parallelRows(color.rows, [&](int y0, int y1) {
      for (int y = y0; y < y1; y++) {
        const auto* c = color.ptr<cv::Vec3f>(y);
        auto* q = out.ptr<cv::Vec3b>(y);
        for (int x = 0; x < color.cols; x++) {
          const uint64_t h = noisy ? pixelHash(frame, stream, y, x) : 0;
          for (int k = 0; k < 3; k++) {
            float val = c[x][k];
            if (noisy) val += sig * G[(h >> (16 * k)) & 0xffff];
            q[x][k] = static_cast<uchar>(std::clamp(static_cast<int>(val + 0.5f), 0, 255));
          }
        }
      }
    });
    return out;
  }

  void renderColor(int frame, bool right, cv::Mat& color, cv::Mat& z, cv::Mat& code) const {
    const double t = s.time(frame);
    auto pose = [&](double tt) {
      SE3 T = scene.cameraPoseAt(tt);
      if (right) T = T * SE3(Eigen::Quaterniond::Identity(), Vec3(s.baseline, 0, 0));
      return T;
    };
    view(pose(t), scene.primitivesAt(frame, t), color, z, code);
    if (s.dark(frame)) {  // lights off: the depth camera still measures, the colour camera sees nothing
      color.setTo(0);
      return;
    }
    const int n = s.noise.blur_samples;
    if (s.noise.enabled && s.noise.motion_blur > 0 && n > 1) {
      cv::Mat acc = color.clone(), c2, z2, l2;
      int cnt = 1;
      for (int k = 0; k < n; k++) {
        const double tk = t + (k / double(n - 1) - 0.5) * s.noise.motion_blur / s.rate;
        if (std::abs(tk - t) < 1e-9) continue;
        view(pose(tk), scene.primitivesAt(frame, tk), c2, z2, l2);
        acc += c2;
        cnt++;
      }
      color = acc / cnt;
    }
  }

  cv::Mat sensorDepth(const cv::Mat& z, int frame) const {
    const auto& N = s.noise;
    const auto& G = gaussTable();
    cv::Mat d(z.size(), CV_16U, cv::Scalar(0));
    parallelRows(z.rows, [&](int y0, int y1) {
      for (int y = y0; y < y1; y++) {
        const float* zr = z.ptr<float>(y);
        auto* dr = d.ptr<uint16_t>(y);
        for (int x = 0; x < z.cols; x++) {
          double zz = zr[x];
          if (!(zz >= N.depth_min && zz <= N.depth_max)) continue;
          if (N.enabled) {
            const uint64_t h = pixelHash(frame, 7, y, x);
            // Depth edges: invalid with probability edge_dropout.
            if (N.edge_dropout > 0) {
              float mx = 0;
              if (x > 0) mx = std::max(mx, std::abs(zr[x - 1] - zr[x]));
              if (x + 1 < z.cols) mx = std::max(mx, std::abs(zr[x + 1] - zr[x]));
              if (y > 0) mx = std::max(mx, std::abs(z.ptr<float>(y - 1)[x] - zr[x]));
              if (y + 1 < z.rows) mx = std::max(mx, std::abs(z.ptr<float>(y + 1)[x] - zr[x]));
              if (mx > N.edge_threshold * zz && static_cast<double>(h >> 40) * (1.0 / 16777216.0) < N.edge_dropout) continue;
            }
            zz += N.depth_sigma * zz * zz * G[h & 0xffff];
          }
          const long v = std::lround(zz * 5000.0);
          dr[x] = static_cast<uint16_t>(std::clamp<long>(v, 1, 65535));
        }
      }
    });
    return d;
  }

  void labels(FrameRender& fr, const cv::Mat& code) const {
    const auto& inst = scene.instances();
    const int H = code.rows, W = code.cols;
    fr.semantic.create(H, W, CV_8U);
    fr.instance.create(H, W, CV_32S);
    fr.panoptic.create(H, W, CV_32S);
    // Lookups per label code: index 0..5 = room surfaces, 6 + i = instance i.
    const size_t NC = 6 + inst.size();
    std::vector<int> sem(NC), pan(NC), iid(NC);
    for (size_t c = 0; c < 6; c++) sem[c] = pan[c] = kRoomCategory[c];
    for (size_t i = 1; i < inst.size(); i++) {
      sem[6 + i] = inst[i].labelled && inst[i].category_id > 0 ? inst[i].category_id : coco::kNone;
      pan[6 + i] = panopticId(inst[i]);
      iid[6 + i] = static_cast<int>(i);
    }
    struct Acc {
      int x0 = 1 << 30, y0 = 1 << 30, x1 = -1, y1 = -1, area = 0;
    };
    std::vector<Acc> acc(NC);
    for (int y = 0; y < H; y++) {
      const int* c = code.ptr<int>(y);
      auto* se = fr.semantic.ptr<uchar>(y);
      auto* in = fr.instance.ptr<int>(y);
      auto* pa = fr.panoptic.ptr<int>(y);
      for (int x = 0; x < W; x++) {
        const size_t k = c[x] < 0 ? static_cast<size_t>(-1 - c[x]) : 6 + static_cast<size_t>(c[x]);
        se[x] = static_cast<uchar>(sem[k]);
        in[x] = iid[k];
        pa[x] = pan[k];
        Acc& a = acc[k];
        if (x < a.x0) a.x0 = x;
        if (x > a.x1) a.x1 = x;
        if (y < a.y0) a.y0 = y;
        a.y1 = y;
        a.area++;
      }
    }
    // Merge codes into panoptic segments (ordered by id: deterministic).
    std::map<int, Segment> segs;
    for (size_t k = 0; k < NC; k++) {
      const Acc& a = acc[k];
      if (a.area == 0 || pan[k] == 0) continue;
      auto it = segs.find(pan[k]);
      if (it == segs.end()) {
        Segment sg;
        sg.id = pan[k];
        sg.category_id = sem[k];
        sg.instance_id = pan[k] >= 1000 ? iid[k] : 0;
        sg.bbox = cv::Rect(a.x0, a.y0, a.x1 - a.x0 + 1, a.y1 - a.y0 + 1);
        sg.area = a.area;
        segs.emplace(pan[k], sg);
      } else {
        it->second.bbox |= cv::Rect(a.x0, a.y0, a.x1 - a.x0 + 1, a.y1 - a.y0 + 1);
        it->second.area += a.area;
      }
      if (pan[k] >= 1000) {
        Box2D b;
        b.category_id = sem[k];
        b.instance_id = iid[k];
        b.name = inst[static_cast<size_t>(iid[k])].name;
        b.box = cv::Rect2f(static_cast<float>(a.x0), static_cast<float>(a.y0), static_cast<float>(a.x1 - a.x0 + 1),
                           static_cast<float>(a.y1 - a.y0 + 1));
        b.area = a.area;
        fr.boxes.push_back(b);
      }
    }
    for (auto& [id, sg] : segs) fr.segments.push_back(sg);
  }
};

Renderer::Renderer(const Scenario& s, const RenderOptions& opt) : impl_(std::make_unique<Impl>(s, opt)) {}
Renderer::~Renderer() = default;

const Scenario& Renderer::scenario() const { return impl_->s; }
const SceneModel& Renderer::scene() const { return impl_->scene; }
const PinholeCamera& Renderer::intrinsics() const { return impl_->s.intrinsics; }
int Renderer::frames() const { return impl_->s.frames; }

CameraModel Renderer::cameraModel() const {
  CameraModel m;
  m.name = "synth_" + impl_->s.name;
  m.sensor = SensorType::RGBD;
  m.left = impl_->s.intrinsics;
  m.right = m.left;
  m.T_left_right = SE3(Eigen::Quaterniond::Identity(), Vec3(impl_->s.baseline, 0, 0));
  m.rectified = true;
  m.baseline = impl_->s.baseline;
  m.depth_factor = 5000.0;
  m.fps = impl_->s.rate;
  m.rgb_order = false;
  return m;
}

FrameRender Renderer::render(int frame) const {
  const Impl& I = *impl_;
  if (frame < 0 || frame >= I.s.frames)
    throw DataError("synth: frame " + std::to_string(frame) + " out of range [0, " + std::to_string(I.s.frames) + ")");
  FrameRender fr;
  fr.index = frame;
  fr.timestamp = I.s.stamp(frame);
  fr.T_wc = I.scene.cameraPose(frame);
  // Scratch buffers are reused across calls (fresh large allocations cost
  // page faults); every pixel is rewritten by each render.
  static thread_local cv::Mat color, code, c2, z2, l2;
  cv::Mat z;
  I.renderColor(frame, false, color, z, code);
  fr.rgb = I.finishColor(color, frame, 0);
  fr.depth_m = z;
  fr.depth = I.sensorDepth(z, frame);
  if (I.opt.right) {
    I.renderColor(frame, true, c2, z2, l2);
    fr.right = I.finishColor(c2, frame, 1);
  }
  I.labels(fr, code);
  if (!I.opt.labels) {
    fr.segments.clear();
    fr.boxes.clear();
  }
  return fr;
}

}  // namespace dslam::synth
