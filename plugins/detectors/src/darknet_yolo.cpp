#include "dslam/plugins/detectors/darknet_yolo.h"

#include <opencv2/dnn.hpp>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <vector>

#include "common.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"

IMPLEMENTS_MRPT_OBJECT(DarknetYoloDetector, Detector, dslam)

namespace dslam {

namespace {
struct Preset {
  const char* name;
  const char* cfg;
  const char* weights;
  const char* names;
};
const Preset kPresets[] = {
    {"yolo-fastest-body", "models/yolo-fastest-body/yolo-fastest-1.1_body.cfg",
     "models/yolo-fastest-body/yolo-fastest-1.1_body.weights", "models/yolo-fastest-body/body.names"},
    {"yolo-fastest-coco", "models/yolo-fastest-coco/yolo-fastest-1.1.cfg",
     "models/yolo-fastest-coco/yolo-fastest-1.1.weights", "models/yolo-fastest-coco/coco.names"},
    {"yolo-fastest-xl", "models/yolo-fastest-coco/yolo-fastest-1.1-xl.cfg",
     "models/yolo-fastest-coco/yolo-fastest-1.1-xl.weights", "models/yolo-fastest-coco/coco.names"},
};
}  // namespace

std::string DarknetYoloDetector::description() const {
  return "Darknet YOLO (Yolo-Fastest, YOLOv3/v4-tiny, Crowd-SLAM CYTI) through OpenCV DNN: boxes with COCO ids";
}

std::vector<ParamSpec> DarknetYoloDetector::paramSpecs() const {
  return {
      P_enum("model", "yolo-fastest-body", {"yolo-fastest-body", "yolo-fastest-coco", "yolo-fastest-xl"},
             "model in ${DSLAM_SHARED_DIR}/models used for cfg/weights/names left ''"),
      P_path("cfg", "", "Darknet .cfg ('' = the `model` preset's)"),
      P_path("weights", "", "Darknet .weights ('' = the `model` preset's)"),
      P_path("names", "", "class-names file, one per line ('' = the `model` preset's)"),
      P_list("class_ids", ParamType::IntList, "[]",
             "COCO id of each model class, in model order (overrides the names mapping)"),
      P_int("input_width", 320, "network input width (multiple of 32)", 32, 4096),
      P_int("input_height", 320, "network input height (multiple of 32)", 32, 4096),
      P_double("confidence", 0.2, "minimum class score (Crowd-SLAM: 0.2; OpenCV's region layer zeroes scores < 0.2)", 0, 1),
      P_double("nms", 0.1, "NMS IoU threshold (Crowd-SLAM: 0.1)", 0, 1),
      P_bool("nms_per_class", true, "NMS within each class (false: across classes)"),
      P_list("classes", ParamType::IntList, "[]", "COCO ids to keep (empty = all)"),
      P_bool("swap_rb", true, "feed RGB (Darknet models are trained on RGB)"),
      P_double("scale", 1.0 / 255.0, "pixel scale factor", 0),
      P_bool("multiply_objectness", false,
             "score = objectness x class score (OpenCV's region layer already multiplies: keep false)"),
  };
}

namespace {

/** Number of weight values the network of Darknet `cfg` has (convolution
 *  kernels and biases, batch-norm scales, means and variances), or nothing
 *  for layer kinds this count does not know. OpenCV reads a truncated
 *  weights file, or the weights of another network, without a word: the
 *  detector then reports boxes of garbage (a file cut to 100 kB: 420 people
 *  on one photo). */
std::optional<size_t> darknetWeightCount(const std::string& cfg) {
  std::ifstream f(cfg);
  if (!f) return std::nullopt;
  std::vector<std::pair<std::string, std::map<std::string, std::string>>> sections;
  std::string line;
  while (std::getline(f, line)) {
    line = line.substr(0, line.find_first_of("#;"));
    line.erase(std::remove_if(line.begin(), line.end(), [](unsigned char c) { return std::isspace(c); }), line.end());
    if (line.empty()) continue;
    if (line.front() == '[' && line.back() == ']')
      sections.push_back({line.substr(1, line.size() - 2), {}});
    else if (const size_t eq = line.find('='); eq != std::string::npos && !sections.empty())
      sections.back().second[line.substr(0, eq)] = line.substr(eq + 1);
  }
  if (sections.empty() || (sections[0].first != "net" && sections[0].first != "network")) return std::nullopt;
  auto num = [](const std::map<std::string, std::string>& m, const char* k, long d) {
    const auto it = m.find(k);
    return it == m.end() ? d : std::strtol(it->second.c_str(), nullptr, 10);
  };
  long ch = num(sections[0].second, "channels", 3);
  std::vector<long> out;  // channels after each layer
  size_t n = 0;
  for (size_t i = 1; i < sections.size(); i++) {
    const auto& [type, m] = sections[i];
    if (type == "convolutional") {
      const long filters = num(m, "filters", 1), size = num(m, "size", 1), groups = std::max(1L, num(m, "groups", 1));
      if (filters < 1 || size < 1 || ch % groups) return std::nullopt;
      n += static_cast<size_t>(filters * (ch / groups) * size * size + filters * (num(m, "batch_normalize", 0) ? 4 : 1));
      ch = filters;
    } else if (type == "route") {
      const auto it = m.find("layers");
      if (it == m.end()) return std::nullopt;
      long sum = 0;
      std::stringstream ls(it->second);
      for (std::string t; std::getline(ls, t, ',');) {
        long l = std::strtol(t.c_str(), nullptr, 10);
        if (l < 0) l += static_cast<long>(out.size());
        if (l < 0 || l >= static_cast<long>(out.size())) return std::nullopt;
        sum += out[static_cast<size_t>(l)];
      }
      ch = sum / std::max(1L, num(m, "groups", 1));
    } else if (type != "shortcut" && type != "maxpool" && type != "upsample" && type != "yolo" &&
               type != "dropout" && type != "avgpool") {
      return std::nullopt;
    }
    out.push_back(ch);
  }
  return n;
}

/** The weights file must hold exactly what `cfg` needs after its header. */
void checkDarknetWeights(const std::string& cfg, const std::string& weights) {
  const auto need = darknetWeightCount(cfg);
  if (!need) return;
  std::ifstream f(weights, std::ios::binary);
  int32_t v[3] = {0, 0, 0};  // major, minor, revision; then "seen" (8 bytes from 0.2 on, else 4)
  if (!f.read(reinterpret_cast<char*>(v), sizeof v))
    throw DataError("Darknet weights " + weights + ": too short for even the header");
  f.seekg(0, std::ios::end);
  const size_t bytes = static_cast<size_t>(f.tellg());
  const size_t header = (v[0] * 10 + v[1] >= 2 && v[0] < 1000 && v[1] < 1000) ? 20 : 16;
  const size_t have = bytes >= header ? (bytes - header) / 4 : 0;
  if (bytes < header || (bytes - header) % 4 || have != *need)
    throw DataError("Darknet weights " + weights + " hold " + std::to_string(have) + " values, but " + cfg +
                    " needs " + std::to_string(*need) + " (a truncated file, or the weights of another network)");
}

}  // namespace

void DarknetYoloDetector::configure(const Params& p, const PluginContext& ctx) {
  Plugin::configure(p, ctx);
  const std::string model = p.getString("model");
  const Preset* pre = &kPresets[0];
  for (const auto& k : kPresets)
    if (model == k.name) pre = &k;
  const std::string cfg = det::modelFile(p.getString("cfg"), pre->cfg, "Darknet cfg");
  const std::string weights = det::modelFile(p.getString("weights"), pre->weights, "Darknet weights");
  const std::string names_file = det::modelFile(p.getString("names"), pre->names, "class-names file");
  const auto names = det::readNames(names_file);
  class_ids_ = det::cocoIdsForNames(names, p.getIntList("class_ids"), names_file);
  keep_ = det::classFilter(p);
  input_ = cv::Size(int(p.getInt("input_width")), int(p.getInt("input_height")));
  if (input_.width % 32 || input_.height % 32)
    throw ConfigError("DarknetYoloDetector: input_width/input_height must be multiples of 32, got " +
                      std::to_string(input_.width) + "x" + std::to_string(input_.height));
  conf_ = float(p.getDouble("confidence"));
  nms_ = float(p.getDouble("nms"));
  per_class_ = p.getBool("nms_per_class");
  swap_rb_ = p.getBool("swap_rb");
  scale_ = float(p.getDouble("scale"));
  mult_ = p.getBool("multiply_objectness");
  checkDarknetWeights(cfg, weights);
  try {
    net_ = cv::dnn::readNetFromDarknet(cfg, weights);
  } catch (const cv::Exception& e) {
    throw DataError("cannot load Darknet model " + cfg + " + " + weights + ": " + e.what());
  }
  if (net_.empty()) throw DataError("cannot load Darknet model " + cfg + " + " + weights);
  net_.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net_.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  out_names_ = net_.getUnconnectedOutLayersNames();
  DSLAM_LOG(Debug, "DarknetYoloDetector: " << cfg << ", " << names.size() << " classes, outputs "
                                           << out_names_.size() << ", input " << input_.width << "x" << input_.height);
}

Detections DarknetYoloDetector::detect(const SensorFrame& frame) {
  Detections d = det::emptyDetections(frame);
  const cv::Mat img = det::toBgr8(frame);
  cv::Mat blob = cv::dnn::blobFromImage(img, scale_, input_, cv::Scalar(), swap_rb_, false, CV_32F);
  net_.setInput(blob);
  const auto outs = det::forward(net_, out_names_, "Darknet YOLO", frame.index);
  std::vector<det::RawBox> raw;
  for (size_t i = 0; i < outs.size(); i++)
    det::decodeYoloRegion(outs[i], out_names_[i], int(class_ids_.size()), conf_, img.size(), mult_, raw);
  det::filterRaw(raw, class_ids_, keep_);
  d.boxes = det::toBoxes(det::nms(raw, conf_, nms_, per_class_), class_ids_, keep_, img.size());
  return d;
}

}  // namespace dslam
