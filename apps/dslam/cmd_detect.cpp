// `dslam detect CONFIG_OR_TYPE IMAGE... [--param k=v]... [--out FILE|DIR]
// [--json] [--repeat N]`: runs one detector on images and prints its
// detections and latency.
#include <mrpt/containers/yaml.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>

#include <nlohmann/json.hpp>

#include "command.h"
#include "dslam/config/pipeline.h"
#include "dslam/core/coco.h"
#include "dslam/core/detector.h"
#include "dslam/core/error.h"
#include "dslam/core/png.h"
#include "dslam/core/paths.h"
#include "dslam/core/registry.h"
#include "dslam/core/timing.h"
#include "dslam/core/yaml_util.h"
#include "dslam/plugins/detectors/label_io.h"

namespace fs = std::filesystem;

namespace {

struct Opts {
  std::string what;
  std::vector<std::string> images;
  std::vector<std::string> params;
  std::string out;
  bool json = false;
  int repeat = 1;
  long long seed = 42;
};

cv::Scalar classColor(int id) {
  uint32_t h = uint32_t(id) * 2654435761u;
  return cv::Scalar(60 + (h & 0x7f) + 60 * (id == 1), 60 + ((h >> 8) & 0x7f), 60 + ((h >> 16) & 0x7f));
}

cv::Mat annotate(const cv::Mat& image, const dslam::Detections& d) {
  cv::Mat out;
  if (image.channels() == 1) cv::cvtColor(image, out, cv::COLOR_GRAY2BGR);
  else if (image.channels() == 4) cv::cvtColor(image, out, cv::COLOR_BGRA2BGR);
  else out = image.clone();
  if (!d.semantic.empty() && d.semantic.size() == out.size()) {
    cv::Mat color(out.size(), CV_8UC3);
    for (int r = 0; r < out.rows; r++)
      for (int c = 0; c < out.cols; c++) {
        const int l = d.semantic.at<uint8_t>(r, c);
        const cv::Scalar s = l == dslam::coco::kNone ? cv::Scalar(0, 0, 0) : classColor(l);
        color.at<cv::Vec3b>(r, c) = cv::Vec3b(uint8_t(s[0]), uint8_t(s[1]), uint8_t(s[2]));
      }
    cv::Mat blended;
    cv::addWeighted(out, 0.5, color, 0.5, 0, blended);
    blended.copyTo(out, d.semantic != dslam::coco::kNone);
  }
  for (const auto& b : d.boxes) {
    const cv::Scalar col = classColor(b.class_id);
    cv::rectangle(out, cv::Rect(b.box), col, 2);
    char txt[96];
    std::snprintf(txt, sizeof txt, "%s %.2f", dslam::coco::name(b.class_id).c_str(), double(b.score));
    int base = 0;
    const cv::Size ts = cv::getTextSize(txt, cv::FONT_HERSHEY_SIMPLEX, 0.45, 1, &base);
    const cv::Point org(int(b.box.x), std::max(ts.height + 2, int(b.box.y) - 3));
    cv::rectangle(out, cv::Rect(org.x, org.y - ts.height - 2, ts.width + 4, ts.height + base + 2), col, cv::FILLED);
    cv::putText(out, txt, cv::Point(org.x + 2, org.y), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(255, 255, 255), 1);
  }
  return out;
}

/** Creates and configures the detector from a type name or a pipeline file. */
std::shared_ptr<dslam::Detector> makeDetector(const Opts& o) {
  using namespace dslam;
  using mrpt::containers::yaml;
  std::string type;
  yaml given = yaml::Map();
  PluginContext ctx;
  ctx.shared_dir = sharedDir();
  ctx.seed = uint64_t(o.seed);
  std::string base = fs::current_path().string();
  ctx.config_dir = base;
  if (fileExists(o.what)) {
    const auto pc = config::loadPipeline(o.what);
    const auto mods = pc.modulesOf("Detector");
    if (mods.empty()) throw ConfigError(o.what + ": no enabled Detector module");
    type = mods.front()->type;
    given = yaml::FromText(mods.front()->params.toYamlText());
    ctx.instance_name = mods.front()->name;
    ctx.seed = pc.seed;
    ctx.config_dir = pc.dir;
    base = pc.dir;
    if (pc.dataset && pc.dataset->params.has("path")) ctx.dataset_root = pc.dataset->params.getString("path");
  } else {
    type = o.what.find("::") == std::string::npos ? "dslam::" + o.what : o.what;
  }
  for (const auto& kv : o.params) {
    const size_t eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) throw ConfigError("--param expects key=value, got '" + kv + "'");
    const yaml v = yaml::FromText("v: " + kv.substr(eq + 1));
    given[kv.substr(0, eq)] = v["v"];
  }
  auto det = create<Detector>(type);
  const auto specs = det->paramSpecs();
  std::vector<std::string> valid;
  for (const auto& s : specs) valid.push_back(s.name);
  for (const auto& kv : o.params) {
    const std::string k = kv.substr(0, kv.find('='));
    if (std::find(valid.begin(), valid.end(), k) == valid.end())
      throw ConfigError("--param " + k + ": unknown parameter of " + type + yamlu::didYouMean(k, valid) +
                        " (valid: " + yamlu::join(valid) + ")");
  }
  SourceLocation where;
  where.file = "dslam detect";
  where.key_path = type;
  const Params p = Params::resolve(specs, &given, where, base);
  det->configure(p, ctx);
  return det;
}

void setup(CLI::App& sub) {
  static Opts o;
  sub.add_option("detector", o.what,
                 "detector type (DarknetYoloDetector, YoloxOnnxDetector, HogPeopleDetector, DnnSemanticSegmenter, "
                 "FileDetector, GroundTruthDetector) or a pipeline YAML (its first Detector module)")
      ->required();
  sub.add_option("images", o.images, "image files")->required();
  sub.add_option("-p,--param", o.params, "parameter override key=value (YAML value), repeatable");
  sub.add_option("-o,--out", o.out, "annotated image (one input) or folder (several inputs: <stem>_det.png)");
  sub.add_flag("--json", o.json, "one JSON object per image instead of text");
  sub.add_option("--repeat", o.repeat, "run N times per image and report the median latency")->check(CLI::Range(1, 10000));
  sub.add_option("--seed", o.seed, "pipeline seed given to the detector (GroundTruthDetector)");
  sub.callback([] {
    using namespace dslam;
    auto det = makeDetector(o);
    const bool out_dir = !o.out.empty() && o.images.size() > 1;
    if (!o.out.empty() && !out_dir && !cv::haveImageWriter(o.out))
      throw ConfigError("--out " + o.out + ": OpenCV writes no image format with the extension '" +
                        fs::path(o.out).extension().string() + "' (use .png or .jpg)");
    if (out_dir) {
      // <stem>_det.png per input: two inputs of one name would share it.
      std::map<std::string, std::string> stems;
      for (const auto& im : o.images)
        if (auto [it, fresh] = stems.emplace(fs::path(im).stem().string(), im); !fresh)
          throw ConfigError("--out " + o.out + ": " + it->second + " and " + im + " would both be written to " +
                            (fs::path(o.out) / (it->first + "_det.png")).string() +
                            "; detect them in two calls (or with different --out)");
      fs::create_directories(o.out);
    }
    for (size_t i = 0; i < o.images.size(); i++) {
      SensorFrame f;
      f.index = int(i);
      f.image_path = o.images[i];
      std::string damage;
      f.image = readImageFile(f.image_path, cv::IMREAD_COLOR, &damage);
      if (f.image.empty())
        throw DataError("cannot read image " + f.image_path +
                        (fs::exists(f.image_path) ? " (" + unreadableImageReason(damage) + ")" : " (missing)"));
      std::vector<double> ms;
      Detections d;
      for (int r = 0; r < o.repeat; r++) {
        const double t0 = nowSeconds();
        d = det->detect(f);
        ms.push_back((nowSeconds() - t0) * 1e3);
      }
      const double lat = median(ms);
      if (o.json) {
        const nlohmann::ordered_json j = {{"image", f.image_path},
                                          {"latency_ms", lat},
                                          {"detections", nlohmann::ordered_json::parse(labels::detectionsJsonText(d))}};
        std::cout << j.dump() << "\n";
      } else {
        std::printf("%s: %zu boxes, %.1f ms%s\n", f.image_path.c_str(), d.boxes.size(), lat,
                    o.repeat > 1 ? (" (median of " + std::to_string(o.repeat) + ")").c_str() : "");
        for (const auto& b : d.boxes)
          std::printf("  %-14s %.3f  [x %.0f, y %.0f, w %.0f, h %.0f]%s\n", coco::name(b.class_id).c_str(),
                      double(b.score), double(b.box.x), double(b.box.y), double(b.box.width), double(b.box.height),
                      b.instance_id >= 0 ? (" instance " + std::to_string(b.instance_id)).c_str() : "");
        if (!d.semantic.empty()) {
          std::map<int, int> hist;
          for (int r = 0; r < d.semantic.rows; r++)
            for (int c = 0; c < d.semantic.cols; c++) hist[d.semantic.at<uint8_t>(r, c)]++;
          std::printf("  semantic %dx%d:", d.semantic.cols, d.semantic.rows);
          for (const auto& [k, v] : hist)
            std::printf(" %s=%d", k == coco::kNone ? "none" : coco::name(k).c_str(), v);
          std::printf("\n");
        }
        if (!d.panoptic.empty()) {
          std::printf("  panoptic: %zu segments\n", d.segments.size());
          for (const auto& s : d.segments)
            std::printf("    id %d %s %s area %d\n", s.id, toString(s.kind), coco::name(s.category_id).c_str(), s.area);
        }
        if (!d.valid) std::printf("  (no output for this frame: valid = false)\n");
      }
      if (!o.out.empty()) {
        const std::string path =
            out_dir ? (fs::path(o.out) / (fs::path(f.image_path).stem().string() + "_det.png")).string() : o.out;
        writeImageFile(path, annotate(f.image, d));
      }
    }
  });
}

}  // namespace

DSLAM_COMMAND(detect, "Run a detector on images: print detections and latency, draw them", setup);
