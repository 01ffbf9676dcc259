// `dslam dataset info PATH [--type dslam::X] [-p key=value]... [--check]`:
// what a dataset reader sees in a folder / file (docs/datasets.md).
#include <mrpt/containers/yaml.h>

#include <cmath>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "command.h"
#include "dslam/config/pipeline.h"
#include "dslam/core/dataset.h"
#include "dslam/core/error.h"
#include "dslam/core/paths.h"
#include "dslam/core/registry.h"
#include "dslam/plugins/datasets/euroc.h"
#include "dslam/plugins/datasets/rawlog.h"
#include "dslam/plugins/datasets/tum.h"

namespace {

std::string stamp(double t) {
  char b[64];
  std::snprintf(b, sizeof b, "%.6f", t);
  return b;
}

std::string matType(const cv::Mat& m) {
  std::string d = m.depth() == CV_8U ? "8-bit" : m.depth() == CV_16U ? "16-bit" : m.depth() == CV_32F ? "float" : "other";
  std::string c = m.channels() == 1 ? "grey" : m.channels() == 3 ? "colour" : std::to_string(m.channels()) + " channels";
  return std::to_string(m.cols) + "x" + std::to_string(m.rows) + " " + d + " " + c;
}

void printPinhole(std::ostream& o, const char* label, const dslam::PinholeCamera& c) {
  o << label << "fx=" << c.fx << " fy=" << c.fy << " cx=" << c.cx << " cy=" << c.cy << " (" << c.width << "x"
    << c.height << ")";
  if (c.hasDistortion())
    o << " dist=[" << c.dist[0] << ", " << c.dist[1] << ", " << c.dist[2] << ", " << c.dist[3] << ", " << c.dist[4]
      << "]";
  o << "\n";
}

struct Opts {
  std::string path, type;
  std::vector<std::string> params;
  bool check = false;
};

void info(const Opts& op) {
  using namespace dslam;
  if (!fileExists(op.path) && !dirExists(op.path)) throw DataError("dataset not found: " + op.path);
  std::string type = op.type;
  if (type.empty()) type = config::detectDatasetType(op.path);
  if (type.empty()) {
    std::string names;
    for (const auto& p : listPlugins("DatasetSource")) names += (names.empty() ? "" : ", ") + p.name;
    throw ConfigError("cannot tell the dataset type of " + op.path + "; give --type (" + names + ")");
  }
  auto ds = create<DatasetSource>(type);
  mrpt::containers::yaml given = mrpt::containers::yaml::Map();
  given["path"] = op.path;  // a string node: no YAML text is built from the path
  for (const auto& kv : op.params) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) throw ConfigError("--param expects KEY=VALUE, got '" + kv + "'");
    // The value is YAML (typed by the parameter); the key is taken as it is.
    given[kv.substr(0, eq).c_str()] = mrpt::containers::yaml::FromText(kv.substr(eq + 1));
  }
  SourceLocation where;
  where.file = "--param";
  where.node_lines = false;  // the values come from the command line, not a file
  ds->configure(Params::resolve(ds->paramSpecs(), &given, where), PluginContext{});

  auto& o = std::cout;
  o << std::setprecision(10);
  o << "path:         " << ds->root() << "\n";
  o << "type:         " << type << "\n";
  o << "sensor:       " << toString(ds->sensor()) << "\n";
  const size_t n = ds->size();
  o << "frames:       " << n << "\n";
  if (n > 0) {
    const double t0 = ds->timestamp(0), t1 = ds->timestamp(n - 1);
    o << "first stamp:  " << stamp(t0) << "\n";
    o << "last stamp:   " << stamp(t1) << "\n";
    o << "duration:     " << std::fixed << std::setprecision(3) << (t1 - t0) << " s\n";
    if (n > 1 && t1 > t0) o << "rate:         " << std::setprecision(2) << (n - 1) / (t1 - t0) << " Hz\n";
    o.unsetf(std::ios::floatfield);
    o << std::setprecision(10);
    const SensorFrame f = ds->read(0);
    o << "image:        " << matType(f.image) << "\n";
    if (!f.image_right.empty()) o << "right image:  " << matType(f.image_right) << "\n";
    if (f.has_depth()) {
      double mn = 0, mx = 0;
      cv::minMaxLoc(f.depth, &mn, &mx, nullptr, nullptr, f.depth > 0);
      o << "depth:        " << f.depth.cols << "x" << f.depth.rows << ", " << cv::countNonZero(f.depth > 0)
        << " valid pixels, " << mn << " - " << mx << " m (frame 0)\n";
    }
  }
  if (auto cam = ds->camera()) {
    o << "camera:       " << cam->name << ", " << toString(cam->sensor)
      << (cam->sensor == SensorType::Stereo ? (cam->rectified ? ", rectified" : ", unrectified") : "") << "\n";
    printPinhole(o, "  left:       ", cam->left);
    if (cam->sensor == SensorType::Stereo) {
      if (!cam->rectified) printPinhole(o, "  right:      ", cam->right);
      const auto& t = cam->T_left_right.translation();
      o << "  baseline:   " << cam->baseline << " m (bf=" << cam->bf() << "), T_left_right t=[" << t.x() << ", "
        << t.y() << ", " << t.z() << "], " << cam->T_left_right.angle() * 180 / M_PI << " deg\n";
    }
    if (cam->sensor == SensorType::RGBD) o << "  depth factor: " << cam->depth_factor << " units/m\n";
    o << "  fps:        " << cam->fps << "\n";
  } else {
    o << "camera:       none (give a camera: section)\n";
  }
  const auto& gt = ds->groundTruth();
  if (gt.empty()) {
    o << "ground truth: none\n";
  } else {
    o << "ground truth: " << gt.size() << " poses, " << stamp(gt.stamps.front()) << " - " << stamp(gt.stamps.back())
      << " (" << std::fixed << std::setprecision(3) << gt.stamps.back() - gt.stamps.front() << " s), path length "
      << gt.pathLength() << " m\n";
    o.unsetf(std::ios::floatfield);
    o << std::setprecision(10);
  }
  if (auto* e = dynamic_cast<EurocDataset*>(ds.get()); e && !e->groundTruthFile().empty())
    o << "  (from " << e->groundTruthFile() << ", body frame, converted to cam0 with T_BS)\n";
  if (auto* r = dynamic_cast<RawlogDataset*>(ds.get())) {
    o << "rawlog:       " << r->objectCount() << " objects, "
      << (r->sensoryFrameFormat() ? "sensory-frame format" : "observations format") << ", sensor '"
      << r->sensorLabel() << "'" << (r->registersDepth() ? ", depth registered to the intensity camera" : "") << "\n";
    for (const auto& l : r->labels()) o << "  label '" << l.label << "': " << l.obs_class << " x" << l.count << "\n";
  }
  if (op.check) {
    size_t bad = 0;
    for (size_t i = 0; i < n; i++) {
      try {
        ds->read(i);
      } catch (const DataError& e) {
        if (bad++ < 10) o << "bad frame:    " << e.what() << "\n";
      }
    }
    o << "check:        " << n - bad << " of " << n << " frames read" << (bad ? " (" + std::to_string(bad) + " bad)" : "")
      << "\n";
    if (bad) dslam::app::exitCode() = 1;
  }
}

void setup(CLI::App& sub) {
  sub.require_subcommand(1);
  static Opts op;
  auto* in = sub.add_subcommand("info", "Print what a dataset reader sees: frames, times, images, camera, ground truth");
  in->add_option("path", op.path, "dataset folder or file")->required();
  in->add_option("-t,--type", op.type, "reader (dslam::TumDataset, ...); default: detected from the path");
  in->add_option("-p,--param", op.params, "reader parameter KEY=VALUE (repeatable)");
  in->add_flag("--check", op.check, "read every frame and report the ones that fail (exit 1 if any)");
  in->callback([] { info(op); });
}

}  // namespace

DSLAM_COMMAND(dataset, "Inspect datasets (dslam dataset info PATH)", setup);
