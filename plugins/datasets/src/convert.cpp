#include "dslam/plugins/datasets/convert.h"

#include <mrpt/containers/yaml.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/serialization/CArchive.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>

#include "common.h"
#include "dslam/config/camera_yaml.h"
#include "dslam/core/camera_presets.h"
#include "dslam/core/png.h"
#include "dslam/core/error.h"
#include "dslam/core/format.h"
#include "dslam/core/log.h"
#include "dslam/core/params.h"
#include "dslam/core/paths.h"
#include "dslam/plugins/datasets/rawlog.h"
#include "dslam/plugins/datasets/tum.h"
#include "rawlog_util.h"

namespace fs = std::filesystem;

namespace dslam {

namespace {

/** Resolves a reader's parameters from string values given as YAML string
 *  nodes (no YAML text is built from paths or labels). */
Params readerParams(const std::vector<ParamSpec>& specs, const std::vector<std::pair<std::string, std::string>>& kv) {
  mrpt::containers::yaml given = mrpt::containers::yaml::Map();
  for (const auto& [k, v] : kv)
    if (!v.empty()) given[k.c_str()] = v;
  SourceLocation where;
  where.node_lines = false;  // options of dslam convert, not lines of a file
  return Params::resolve(specs, &given, where);
}

/** Restores CImage's global JPEG flag on scope exit. */
struct NoJpeg {
  bool prev;
  NoJpeg() : prev(mrpt::img::CImage::DISABLE_JPEG_COMPRESSION()) { mrpt::img::CImage::DISABLE_JPEG_COMPRESSION(true); }
  ~NoJpeg() { mrpt::img::CImage::DISABLE_JPEG_COMPRESSION(prev); }
};

}  // namespace

ConvertReport convertTumToRawlog(const std::string& in_dir, const std::string& out_rawlog,
                                 const TumToRawlogOptions& opt) {
  // never write over the dataset's own files (rgb.txt, groundtruth.txt, images), also through a symlink
  std::error_code ec;
  if (fs::exists(out_rawlog) && isInside(out_rawlog, in_dir) &&
      fs::weakly_canonical(out_rawlog, ec).extension() != ".rawlog")
    throw DataError("output " + out_rawlog + " is a file of the dataset folder " + in_dir +
                    "; refusing to overwrite it (the output is a new .rawlog file)");
  TumDataset tum;
  tum.configure(readerParams(tum.paramSpecs(), {{"path", in_dir},
                                                {"associations", opt.associations},
                                                {"max_dt", std::to_string(opt.max_dt)}}),
                PluginContext{});

  ConvertReport rep;
  CameraModel cam;
  if (!opt.camera_file.empty()) {
    requireFile(opt.camera_file, "camera file");
    cam = config::loadCameraFile(opt.camera_file);
    rep.camera = opt.camera_file;
  } else if (!opt.preset.empty()) {
    auto c = cameraPreset(opt.preset);
    if (!c) {
      std::string names;
      for (const auto& n : cameraPresetNames()) names += (names.empty() ? "" : ", ") + n;
      throw ConfigError("unknown camera preset '" + opt.preset + "' (presets: " + names + ")");
    }
    cam = *c;
    rep.camera = "preset " + opt.preset;
  } else {
    if (!tum.camera()) throw DataError(in_dir + ": no camera for this folder; give a camera file or a preset");
    cam = *tum.camera();
    rep.camera = tum.cameraSource();
  }
  if (!(cam.depth_factor > 0)) throw ConfigError(rep.camera + ": depth_factor must be > 0");
  if (!(cam.left.fx > 0) || !(cam.left.fy > 0)) throw ConfigError(rep.camera + ": camera has no focal length");
  rep.depth_factor = cam.depth_factor;
  if (tum.depthPath(0).empty())
    throw DataError(in_dir + ": no depth images (depth.txt or associations.txt); tum2rawlog writes RGB-D observations");

  const NoJpeg no_jpeg;
  mrpt::io::CFileGZOutputStream out;
  if (!out.open(out_rawlog, std::clamp(opt.compression, 0, 9)))
    throw DataError("cannot write rawlog " + out_rawlog);
  auto ar = mrpt::serialization::archiveFrom(out);
  const float units = static_cast<float>(1.0 / cam.depth_factor);
  log::Progress prog("tum2rawlog", tum.size());
  for (size_t i = 0; i < tum.size(); i++) {
    cv::Mat rgb = ds::readCameraImage(tum.rgbPath(i), i, "image");
    if (rgb.channels() == 4) cv::cvtColor(rgb, rgb, cv::COLOR_BGRA2BGR);
    const cv::Mat depth = ds::readDepthImage(tum.depthPath(i), i);
    if (depth.size() != rgb.size())
      throw DataError("frame " + std::to_string(i) + ": depth image " + tum.depthPath(i) + " size differs from " +
                      tum.rgbPath(i));
    auto obs = mrpt::obs::CObservation3DRangeScan::Create();
    obs->sensorLabel = opt.sensor_label;
    obs->timestamp = mrpt::Clock::fromDouble(tum.timestamp(i));
    obs->hasRangeImage = true;
    obs->range_is_depth = true;
    obs->rangeUnits = units;
    obs->rangeImage_setSize(depth.rows, depth.cols);
    for (int r = 0; r < depth.rows; r++) {
      const auto* row = depth.ptr<uint16_t>(r);
      for (int c = 0; c < depth.cols; c++) obs->rangeImage(r, c) = row[c];
    }
    obs->maxRange = 65535.0f * units;
    obs->hasIntensityImage = true;
    obs->intensityImage = mrpt::img::CImage(rgb, mrpt::img::DEEP_COPY);
    obs->intensityImageChannel = mrpt::obs::CObservation3DRangeScan::CH_VISIBLE;
    PinholeCamera k = cam.left;
    k.width = rgb.cols;
    k.height = rgb.rows;
    if (!k.principalPointInside())
      throw DataError(rep.camera + ": its principal point (" + formatNumber("%g", k.cx) + ", " +
                      formatNumber("%g", k.cy) + ") lies outside the " + std::to_string(k.width) + "x" +
                      std::to_string(k.height) + " images of " + in_dir +
                      ": not the camera of these images (give --camera FILE)");
    obs->cameraParamsIntensity = rawlog::toTCamera(k, cam.name.empty() ? "rgbd" : cam.name);
    obs->cameraParams = obs->cameraParamsIntensity;  // TUM depth is registered to the RGB camera
    obs->relativePoseIntensityWRTDepth = mrpt::poses::CPose3D(0, 0, 0, mrpt::DEG2RAD(-90.0), 0, mrpt::DEG2RAD(-90.0));
    obs->hasPoints3D = false;
    obs->hasConfidenceImage = false;
    ar << *obs;
    prog.update(i + 1);
  }
  prog.finish();
  out.close();
  rep.frames = tum.size();
  return rep;
}

ConvertReport convertRawlogToTum(const std::string& in_rawlog, const std::string& out_dir,
                                 const RawlogToTumOptions& opt) {
  RawlogDataset rl;
  rl.configure(readerParams(rl.paramSpecs(),
                            {{"path", in_rawlog}, {"sensor_label", opt.sensor_label}, {"images_dir", opt.images_dir}}),
               PluginContext{});
  if (rl.sensor() == SensorType::Stereo)
    throw DataError("rawlog2tum: sensor '" + rl.sensorLabel() + "' of " + in_rawlog +
                    " is stereo; the TUM layout holds RGB-D or monocular sequences");
  const bool rgbd = rl.sensor() == SensorType::RGBD;
  if (fileExists(out_dir + "/rgb.txt") && !opt.overwrite)
    throw DataError(out_dir + " already holds a TUM sequence (rgb.txt); use --overwrite or another folder");
  std::error_code ec;
  fs::create_directories(out_dir + "/rgb", ec);
  if (rgbd) fs::create_directories(out_dir + "/depth", ec);
  if (ec || !dirExists(out_dir + "/rgb")) throw DataError("cannot create " + out_dir + "/rgb: " + ec.message());

  CameraModel cam = *rl.camera();
  ConvertReport rep;
  rep.camera = "rawlog " + in_rawlog + " (sensor '" + rl.sensorLabel() + "')";
  const double factor = opt.depth_factor > 0 ? opt.depth_factor : cam.depth_factor;
  rep.depth_factor = rgbd ? factor : 0;
  const std::string src = "# converted by dslam convert rawlog2tum from " + in_rawlog + " (sensor '" + rl.sensorLabel() + "')\n";
  std::ofstream frgb(out_dir + "/rgb.txt"), fdep, fass;
  frgb << "# color images\n" << src << "# timestamp filename\n";
  if (rgbd) {
    fdep.open(out_dir + "/depth.txt");
    fass.open(out_dir + "/associations.txt");
    fdep << "# depth maps\n" << src << "# timestamp filename\n";
  }
  std::string prev;
  log::Progress prog("rawlog2tum", rl.size());
  for (size_t i = 0; i < rl.size(); i++) {
    cv::Mat raw;
    double units = 0;
    const SensorFrame f = rl.readRaw(i, &raw, &units);
    const std::string ts = ds::fmtStamp(f.timestamp);
    if (ts == prev)
      throw DataError("frame " + std::to_string(i) + ": timestamp " + ts + " repeats at microsecond resolution");
    prev = ts;
    const std::string rn = "rgb/" + ts + ".png";
    writeImageFile(out_dir + "/" + rn, f.image);
    frgb << ts << " " << rn << "\n";
    if (!rgbd) continue;
    cv::Mat d16;
    if (!raw.empty() && std::abs(1.0 / units - factor) <= 1e-4 * factor) {
      d16 = raw;  // bit-exact
    } else {
      rep.depth_exact = false;
      d16.create(f.depth.size(), CV_16UC1);
      for (int r = 0; r < d16.rows; r++) {
        const float* s = f.depth.ptr<float>(r);
        auto* o = d16.ptr<uint16_t>(r);
        for (int c = 0; c < d16.cols; c++) {
          const double v = std::round(static_cast<double>(s[c]) * factor);
          if (!(v > 0)) {
            if (s[c] > 0) rep.depth_zeroed++;  // a valid depth rounded to "no depth"
            o[c] = 0;
          } else if (v > 65535) {
            o[c] = 0;
            rep.depth_clipped++;
          } else {
            o[c] = static_cast<uint16_t>(v);
          }
        }
      }
    }
    const std::string dn = "depth/" + ts + ".png";
    writeImageFile(out_dir + "/" + dn, d16);
    fdep << ts << " " << dn << "\n";
    fass << ts << " " << rn << " " << ts << " " << dn << "\n";
    prog.update(i + 1);
  }
  prog.finish();
  if (rep.depth_clipped)
    DSLAM_LOG(Warn, "rawlog2tum: " << rep.depth_clipped << " depth pixels beyond 65535 / " << factor
                                   << " m set to 0 (invalid); use a smaller --depth-factor");
  if (rep.depth_zeroed)
    DSLAM_LOG(Warn, "rawlog2tum: " << rep.depth_zeroed << " valid depth pixels closer than 0.5 / " << factor
                                   << " m rounded to 0 (invalid); use a larger --depth-factor");
  cam.depth_factor = rgbd ? factor : cam.depth_factor;
  std::ofstream fc(out_dir + "/camera.yaml");
  fc << "# camera of " << in_rawlog << " (sensor '" << rl.sensorLabel() << "'), written by dslam convert rawlog2tum\n"
     << config::cameraToYaml(cam);
  if (!frgb || !fc) throw DataError("cannot write the lists in " + out_dir);
  rep.frames = rl.size();
  return rep;
}

}  // namespace dslam
