#include "dslam/plugins/datasets/rawlog.h"

#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/lazy_load_path.h>
#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/obs/CObservationStereoImages.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/poses/CPose3DQuat.h>
#include <mrpt/serialization/CArchive.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>

#include "common.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/core/paths.h"
#include "dslam/trajectory/io.h"
#include "rawlog_util.h"

IMPLEMENTS_MRPT_OBJECT(RawlogDataset, DatasetSource, dslam)

namespace fs = std::filesystem;
using namespace mrpt::obs;

namespace dslam {

static const char* kRawlogLayout =
    "expected an MRPT rawlog file (observations or sensory-frame format, optionally gzip-compressed) with "
    "CObservation3DRangeScan, CObservationImage or CObservationStereoImages observations; external images in "
    "<rawlog name>_Images/";


// ---------------------------------------------------------------------------

namespace {

enum class Kind { None, RGBD, Mono, Stereo };

Kind kindOf(const CObservation& o) {
  if (dynamic_cast<const CObservation3DRangeScan*>(&o)) return Kind::RGBD;
  if (dynamic_cast<const CObservationStereoImages*>(&o)) return Kind::Stereo;
  if (dynamic_cast<const CObservationImage*>(&o)) return Kind::Mono;
  return Kind::None;
}

/** A bool member that MRPT deserialised: MRPT reads the file's byte
 *  straight into the bool, so it can hold any value (33, ...), and loading
 *  such a bool is undefined behaviour. Read its byte instead. */
bool flag(const bool& b) {
  unsigned char byte = 0;
  std::memcpy(&byte, &b, 1);
  return byte != 0;
}

struct FrameRef {
  size_t obj = 0;  ///< top-level object index in the file
  int sub = -1;    ///< index inside a CSensoryFrame, -1 = the object itself
  double t = 0;
};

struct LabelScan {
  Kind kind = Kind::None;
  std::string cls;
  std::vector<FrameRef> frames;
  CameraModel camera;
  bool needs_registration = false;
};

}  // namespace

struct RawlogDataset::Impl {
  std::string file, images_dir, label;
  bool sf_format = false, register_depth = true, do_register = false;
  size_t n_objects = 0;
  std::map<std::string, LabelScan> scans;
  LabelScan* sel = nullptr;
  // Streaming state.
  std::unique_ptr<mrpt::io::CFileGZInputStream> in;
  size_t next_obj = 0;
  mrpt::serialization::CSerializable::Ptr cached;
  size_t cached_idx = static_cast<size_t>(-1);

  /** Reads the whole file once: frames and camera of every sensor label. */
  void scan();
  /** Selects the label to read ('' = the only one) and checks its frames. */
  void select(const std::string& wanted);

  void open() {
    in = std::make_unique<mrpt::io::CFileGZInputStream>();
    if (!in->open(file)) throw DataError("cannot open rawlog " + file + " (" + kRawlogLayout + ")");
    next_obj = 0;
    cached.reset();
    cached_idx = static_cast<size_t>(-1);
  }

  /** Next top-level object or nullptr at EOF. */
  mrpt::serialization::CSerializable::Ptr readNext() {
    auto ar = mrpt::serialization::archiveFrom(*in);
    try {
      auto o = ar.ReadObject();
      next_obj++;
      return o;
    } catch (const mrpt::serialization::CExceptionEOF&) {
      return nullptr;
    } catch (const std::exception& e) {
      std::string msg = e.what();
      if (msg.find("EOF") != std::string::npos && msg.find("Cannot read object") != std::string::npos) return nullptr;
      throw DataError("rawlog " + file + ": cannot read object " + std::to_string(next_obj) +
                      " (corrupt or truncated file): " + exceptionSummary(e));
    }
  }

  mrpt::serialization::CSerializable::Ptr object(size_t idx) {
    if (cached && cached_idx == idx) return cached;
    if (!in || idx < next_obj) open();
    while (next_obj <= idx) {
      auto o = readNext();
      if (!o) throw DataError("rawlog " + file + ": ended before object " + std::to_string(idx) + " (file changed?)");
      cached = o;
      cached_idx = next_obj - 1;
    }
    return cached;
  }

  CObservation::Ptr observation(const FrameRef& r) {
    auto o = object(r.obj);
    if (r.sub >= 0) {
      auto sf = std::dynamic_pointer_cast<CSensoryFrame>(o);
      if (!sf || static_cast<size_t>(r.sub) >= sf->size())
        throw DataError("rawlog " + file + ": object " + std::to_string(r.obj) + " is not the expected sensory frame");
      return sf->getObservationByIndex(r.sub);
    }
    auto obs = std::dynamic_pointer_cast<CObservation>(o);
    if (!obs) throw DataError("rawlog " + file + ": object " + std::to_string(r.obj) + " is not an observation");
    return obs;
  }
};

RawlogDataset::RawlogDataset() : impl_(std::make_shared<Impl>()) {}

std::string RawlogDataset::description() const {
  return "MRPT rawlog: CObservation3DRangeScan (RGB-D), CObservationImage (monocular) or CObservationStereoImages "
         "(stereo) of one sensor label";
}

std::vector<ParamSpec> RawlogDataset::paramSpecs() const {
  return {
      P_required("path", ParamType::Path, "the .rawlog file"),
      P_string("sensor_label", "", "sensor label to read; '' = the only camera-like label in the file"),
      P_string("images_dir", "", "folder of externally stored images; '' = <rawlog without extension>_Images"),
      P_bool("register_depth", true,
             "RGB-D: reproject depth into the intensity camera when the two cameras differ"),
      P_string("groundtruth", "", "ground-truth trajectory (TUM/KITTI/EuRoC file, T_wc) relative to the rawlog folder; '' = none"),
  };
}

size_t RawlogDataset::size() const { return impl_->sel ? impl_->sel->frames.size() : 0; }
double RawlogDataset::timestamp(size_t i) const { return impl_->sel->frames.at(i).t; }
std::string RawlogDataset::root() const { return impl_->file; }
std::string RawlogDataset::sensorLabel() const { return impl_->label; }
bool RawlogDataset::sensoryFrameFormat() const { return impl_->sf_format; }
size_t RawlogDataset::objectCount() const { return impl_->n_objects; }
bool RawlogDataset::registersDepth() const { return impl_->do_register; }
std::string RawlogDataset::imagesDir() const { return impl_->images_dir; }

SensorType RawlogDataset::sensor() const {
  if (!impl_->sel) return SensorType::RGBD;
  return impl_->sel->camera.sensor;
}

std::optional<CameraModel> RawlogDataset::camera() const {
  if (!impl_->sel) return std::nullopt;
  return impl_->sel->camera;
}

std::vector<RawlogDataset::LabelInfo> RawlogDataset::labels() const {
  std::vector<LabelInfo> out;
  for (const auto& [l, s] : impl_->scans) out.push_back({l, s.cls, s.frames.size()});
  return out;
}

namespace {

/** Camera of the first observation of a label (kind k), as dslam reads it. */
CameraModel cameraOfObservation(Kind k, const CObservation& o, const std::string& what, bool& needs_registration) {
  CameraModel c;
  c.name = "rawlog:" + o.sensorLabel;
  if (k == Kind::RGBD) {
    const auto& r = dynamic_cast<const CObservation3DRangeScan&>(o);
    c.sensor = SensorType::RGBD;
    c.left = rawlog::fromTCamera(r.cameraParamsIntensity, what);
    const double f = 1.0 / static_cast<double>(r.rangeUnits);
    c.depth_factor = std::abs(f - std::round(f)) < 1e-3 * f ? std::round(f) : f;
    c.baseline = 40.0 / c.left.fx;  // virtual stereo as ORB-SLAM2's TUM yamls (bf = 40)
    c.depth_threshold = 40.0;
    needs_registration = rawlog::needsRegistration(r);
  } else if (k == Kind::Mono) {
    const auto& m = dynamic_cast<const CObservationImage&>(o);
    c.sensor = SensorType::Monocular;
    c.left = rawlog::fromTCamera(m.cameraParams, what);
  } else {
    const auto& st = dynamic_cast<const CObservationStereoImages&>(o);
    c.sensor = flag(st.hasImageRight) ? SensorType::Stereo : SensorType::Monocular;
    c.left = rawlog::fromTCamera(st.leftCamera, what);
    c.right = rawlog::fromTCamera(st.rightCamera, what);
    c.T_left_right = rawlog::toSE3(mrpt::poses::CPose3D(st.rightCameraPose));
    const auto& t = c.T_left_right.translation();
    const bool pure_x = c.T_left_right.angle() < 1e-9 && std::abs(t.y()) < 1e-9 && std::abs(t.z()) < 1e-9;
    const bool same_k =
        c.left.fx == c.right.fx && c.left.fy == c.right.fy && c.left.cx == c.right.cx && c.left.cy == c.right.cy;
    c.rectified = pure_x && same_k && !c.left.hasDistortion() && !c.right.hasDistortion();
    c.baseline = t.norm();
    c.depth_threshold = 35.0;
  }
  return c;
}

}  // namespace

void RawlogDataset::Impl::scan() {
  // One pass over the file: frame indices per label, camera of the first observation.
  std::map<std::string, size_t> other;  // class counts of unsupported objects
  open();
  auto consider = [&](const CObservation::Ptr& o, size_t obj, int sub) {
    const Kind k = kindOf(*o);
    if (k == Kind::None) {
      other[o->GetRuntimeClass()->className]++;
      return;
    }
    LabelScan& s = scans[o->sensorLabel];
    if (s.kind == Kind::None) {
      s.kind = k;
      s.cls = o->GetRuntimeClass()->className;
      s.camera = cameraOfObservation(k, *o, "rawlog " + file + ": " + rawlog::describeObs(*o), s.needs_registration);
    } else if (s.kind != k) {
      throw DataError("rawlog " + file + ": sensor label '" + o->sensorLabel + "' has both " + s.cls + " and " +
                      o->GetRuntimeClass()->className + " observations; cannot read it as one sequence");
    }
    s.frames.push_back({obj, sub, mrpt::Clock::toDouble(o->timestamp)});
  };
  bool any_sf = false, any_obs = false;
  for (size_t obj = 0;; obj++) {
    auto o = readNext();
    if (!o) break;
    if (auto sf = std::dynamic_pointer_cast<CSensoryFrame>(o)) {
      any_sf = true;
      for (size_t k = 0; k < sf->size(); k++) consider(sf->getObservationByIndex(k), obj, static_cast<int>(k));
    } else if (auto ob = std::dynamic_pointer_cast<CObservation>(o)) {
      any_obs = true;
      consider(ob, obj, -1);
    } else {
      other[o->GetRuntimeClass()->className]++;
    }
    n_objects = obj + 1;
  }
  in.reset();
  sf_format = any_sf && !any_obs;
  if (scans.empty()) {
    std::string oth;
    for (const auto& [c, n] : other) oth += (oth.empty() ? "" : ", ") + c + " x" + std::to_string(n);
    throw DataError("rawlog " + file + ": no camera observations (" + std::to_string(n_objects) + " objects" +
                    (oth.empty() ? std::string() : ": " + oth) + "; " + kRawlogLayout + ")");
  }
}

void RawlogDataset::Impl::select(const std::string& wanted) {
  std::string found;
  for (const auto& [l, s] : scans) found += (found.empty() ? "" : ", ") + ("'" + l + "' (" + s.cls + " x" + std::to_string(s.frames.size()) + ")");
  label = wanted;
  if (label.empty()) {
    if (scans.size() > 1)
      throw ConfigError("rawlog " + file + " has several camera sensor labels: " + found +
                        "; choose one with the parameter sensor_label");
    label = scans.begin()->first;
  } else if (!scans.count(label)) {
    throw ConfigError("rawlog " + file + " has no camera observations with sensor label '" + label +
                      "'; labels: " + found);
  }
  sel = &scans[label];
  std::vector<double> stamps;
  for (const auto& f : sel->frames) stamps.push_back(f.t);
  ds::requireIncreasing(stamps, "rawlog " + file + " (sensor '" + label + "')");
  do_register = sel->kind == Kind::RGBD && sel->needs_registration && register_depth;
  if (sel->kind == Kind::RGBD && sel->needs_registration && !register_depth)
    DSLAM_LOG(Warn, "rawlog " << file << ": depth and intensity cameras differ but register_depth is false; "
                               "depth pixels will not line up with the image");
  if (stamps.size() > 1 && stamps.back() > stamps.front())
    sel->camera.fps = (stamps.size() - 1) / (stamps.back() - stamps.front());
  else
    sel->camera.fps = 30.0;
}

void RawlogDataset::configure(const Params& p, const PluginContext& ctx) {
  Plugin::configure(p, ctx);
  auto& I = *impl_;
  I = Impl();
  I.file = p.getString("path");
  if (dirExists(I.file)) throw DataError("rawlog path is a folder, not a file: " + I.file + " (" + kRawlogLayout + ")");
  requireFile(I.file, "rawlog file", kRawlogLayout);
  I.images_dir = p.getString("images_dir");
  if (I.images_dir.empty()) {
    fs::path f(I.file);
    I.images_dir = (f.parent_path() / (f.stem().string() + "_Images")).string();
  } else {
    I.images_dir = resolvePath(I.images_dir, fs::path(I.file).parent_path().string());
  }
  I.register_depth = p.getBool("register_depth");
  I.scan();
  I.select(p.getString("sensor_label"));

  gt_.clear();
  const std::string g = p.getString("groundtruth");
  if (!g.empty()) {
    const std::string gf = resolvePath(g, fs::path(I.file).parent_path().string());
    requireFile(gf, "ground-truth file", "parameter groundtruth of the rawlog reader");
    gt_ = traj::read(gf);
  }
}

SensorFrame RawlogDataset::read(size_t i) { return readRaw(i, nullptr, nullptr); }

SensorFrame RawlogDataset::readRaw(size_t i, cv::Mat* depth_raw, double* units) {
  auto& I = *impl_;
  if (!I.sel) throw DataError("RawlogDataset: read() before configure()");
  ds::requireFrameIndex(i, I.sel->frames.size());
  if (depth_raw) depth_raw->release();
  const FrameRef& ref = I.sel->frames[i];
  CObservation::Ptr o = I.observation(ref);
  const std::string where = "frame " + std::to_string(i) + " (rawlog " + I.file + ", object " + std::to_string(ref.obj) + ")";

  // External images: check the files first for a clear message.
  auto checkExternal = [&](const mrpt::img::CImage& im, const char* what) {
    if (im.isExternallyStored()) {
      const std::string path = im.getExternalStorageFileAbsolutePath();
      if (!fileExists(path))
        throw DataError("frame " + std::to_string(i) + ": external " + what + " " + path + " is missing (rawlog " +
                        I.file + ", images folder " + I.images_dir + ")");
    }
  };
  auto toMat = [&](const mrpt::img::CImage& im, const char* what) {
    cv::Mat m;
    try {
      m = im.asCvMat<cv::Mat>(mrpt::img::DEEP_COPY);
    } catch (const std::exception& e) {
      throw DataError(where + ": cannot load " + what + ": " + std::string(e.what()).substr(0, 300));
    }
    if (m.empty()) throw DataError(where + ": " + what + " is empty");
    return m;
  };

  mrpt::io::setLazyLoadPathBase(I.images_dir);
  SensorFrame f;
  f.index = static_cast<int>(i);
  f.timestamp = ref.t;
  f.image_path = I.file;
  if (auto r = std::dynamic_pointer_cast<CObservation3DRangeScan>(o)) {
    if (!flag(r->hasIntensityImage)) throw DataError(where + ": 3D range scan without intensity image");
    if (!flag(r->hasRangeImage)) throw DataError(where + ": 3D range scan without range image");
    checkExternal(r->intensityImage, "intensity image");
    if (r->rangeImage_isExternallyStored()) {
      const std::string path = r->rangeImage_getExternalStorageFileAbsolutePath("");
      if (!fileExists(path))
        throw DataError("frame " + std::to_string(i) + ": external range image " + path + " is missing (rawlog " +
                        I.file + ")");
    }
    try {
      r->load();
    } catch (const std::exception& e) {
      throw DataError(where + ": cannot load external data: " + std::string(e.what()).substr(0, 300));
    }
    f.image = toMat(r->intensityImage, "intensity image");
    f.depth_path = I.file;
    const cv::Mat raw = rawlog::rangeToMat(r->rangeImage);
    cv::Mat depth;
    raw.convertTo(depth, CV_32F, static_cast<double>(r->rangeUnits));
    const PinholeCamera kd = rawlog::fromTCamera(r->cameraParams, where);
    if (!flag(r->range_is_depth)) {  // range along the ray -> depth along the optical axis
      for (int y = 0; y < depth.rows; y++) {
        float* d = depth.ptr<float>(y);
        for (int x = 0; x < depth.cols; x++) {
          const double a = (x - kd.cx) / kd.fx, b = (y - kd.cy) / kd.fy;
          d[x] = static_cast<float>(d[x] / std::sqrt(1 + a * a + b * b));
        }
      }
    }
    if (I.do_register) {
      PinholeCamera ki = I.sel->camera.left;
      ki.width = f.image.cols;
      ki.height = f.image.rows;
      f.depth = rawlog::registerDepth(depth, kd, ki, rawlog::intensityFromDepth(*r));
    } else {
      if (depth.size() != f.image.size())
        throw DataError(where + ": range image " + std::to_string(depth.cols) + "x" + std::to_string(depth.rows) +
                        " and intensity image " + std::to_string(f.image.cols) + "x" + std::to_string(f.image.rows) +
                        " differ in size and register_depth is false");
      f.depth = depth;
      if (depth_raw && flag(r->range_is_depth)) *depth_raw = raw;
    }
    if (units) *units = static_cast<double>(r->rangeUnits);
    r->unload();
  } else if (auto st = std::dynamic_pointer_cast<CObservationStereoImages>(o)) {
    checkExternal(st->imageLeft, "left image");
    if (flag(st->hasImageRight)) checkExternal(st->imageRight, "right image");
    f.image = toMat(st->imageLeft, "left image");
    if (flag(st->hasImageRight)) {
      f.image_right = toMat(st->imageRight, "right image");
      f.image_right_path = I.file;
    }
    st->unload();
  } else if (auto im = std::dynamic_pointer_cast<CObservationImage>(o)) {
    checkExternal(im->image, "image");
    f.image = toMat(im->image, "image");
    im->unload();
  } else {
    throw DataError(where + ": unexpected " + rawlog::describeObs(*o));
  }
  f.gt_T_wc = ds::nearestPose(gt_, f.timestamp);
  return f;
}

}  // namespace dslam
