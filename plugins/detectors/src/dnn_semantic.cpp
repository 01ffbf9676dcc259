#include "dslam/plugins/detectors/dnn_semantic.h"

#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <set>

#include "common.h"
#include "dslam/core/coco.h"
#include "dslam/core/error.h"
#include "dslam/core/log.h"
#include "dslam/core/paths.h"

IMPLEMENTS_MRPT_OBJECT(DnnSemanticSegmenter, Detector, dslam)

namespace dslam {

std::string DnnSemanticSegmenter::description() const {
  return "semantic segmentation through OpenCV DNN (default ENet Cityscapes): COCO label image, boxes per thing "
         "component";
}

std::vector<ParamSpec> DnnSemanticSegmenter::paramSpecs() const {
  return {
      P_path("model", "", "network file for cv::dnn::readNet ('' = ${DSLAM_SHARED_DIR}/models/enet-cityscapes/enet-model.net)"),
      P_path("config", "", "network config file if the framework needs one (Caffe prototxt, TF pbtxt)"),
      P_path("labels", "", "label names, one per output channel ('' = ${DSLAM_SHARED_DIR}/models/enet-cityscapes/enet-classes.txt)"),
      P_map("class_map",
            "{Person: 1, Rider: 1, Car: 3, Truck: 8, Bus: 6, Train: 7, Motorcycle: 4, Bicycle: 2, TrafficLight: 10, "
            "Road: 149, Sidewalk: 191, Building: 197, Wall: 199, Fence: 185, Vegetation: 184, Terrain: 193, Sky: 187}",
            "model label name -> COCO id (labels not listed, or 255, are 'none'); replaces the ENet default map"),
      P_int("input_width", 1024, "network input width (ENet Cityscapes: 1024)", 16, 8192),
      P_int("input_height", 512, "network input height (ENet Cityscapes: 512)", 16, 8192),
      P_double("scale", 1.0 / 255.0, "pixel scale factor", 0),
      P_list("mean", ParamType::DoubleList, "[]", "per-channel mean subtracted before scaling (empty = none)"),
      P_bool("swap_rb", true, "feed RGB"),
      P_bool("boxes", true, "also output one box per connected component of each thing class"),
      P_int("min_box_area", 100, "minimum component area for a box, frame pixels", 1),
  };
}

void DnnSemanticSegmenter::configure(const Params& p, const PluginContext& ctx) {
  Plugin::configure(p, ctx);
  const std::string model =
      det::modelFile(p.getString("model"), "models/enet-cityscapes/enet-model.net", "segmentation model");
  const std::string config = p.getString("config");
  if (!config.empty()) requireFile(config, "segmentation model config", det::kModelHint);
  const std::string lf = det::modelFile(p.getString("labels"), "models/enet-cityscapes/enet-classes.txt", "label-names file");
  labels_ = det::readNames(lf);
  lut_.assign(labels_.size(), uint8_t(coco::kNone));
  for (const auto& [name, v] : p.getDoubleMap("class_map")) {
    size_t k = 0;
    while (k < labels_.size() && labels_[k] != name) k++;
    if (k == labels_.size())
      p.fail("class_map", "'" + name + "' is not a label of " + lf + " (labels: " + [&] {
        std::string s;
        for (auto& l : labels_) s += (s.empty() ? "" : ", ") + l;
        return s;
      }() + ")");
    const int id = int(v);
    if (v != std::floor(v) || (id != coco::kNone && !coco::find(id)))
      p.fail("class_map", "'" + name + "': " + std::to_string(v) + " is not a COCO category id (or 255 = none)");
    lut_[k] = uint8_t(id);
  }
  input_ = cv::Size(int(p.getInt("input_width")), int(p.getInt("input_height")));
  scale_ = p.getDouble("scale");
  swap_rb_ = p.getBool("swap_rb");
  boxes_ = p.getBool("boxes");
  min_box_area_ = int(p.getInt("min_box_area"));
  const auto mean = p.getDoubleList("mean");
  if (!mean.empty() && mean.size() != 3) p.fail("mean", "expected 3 values or []");
  mean_ = mean.empty() ? cv::Scalar() : cv::Scalar(mean[0], mean[1], mean[2]);
  net_ = det::loadNet("segmentation model", model, config);
  net_.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net_.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  const auto outs = net_.getUnconnectedOutLayersNames();
  if (outs.empty()) throw DataError(model + ": network has no output layer");
  out_name_ = outs.back();
}

Detections DnnSemanticSegmenter::detect(const SensorFrame& frame) {
  Detections d = det::emptyDetections(frame);
  const cv::Mat img = det::toBgr8(frame);
  cv::Mat blob = cv::dnn::blobFromImage(img, scale_, input_, mean_, swap_rb_, false, CV_32F);
  net_.setInput(blob);
  const auto outs = det::forward(net_, {out_name_}, "segmentation", frame.index);
  const cv::Mat& o = outs.at(0);
  const int K = int(labels_.size());
  if (o.dims != 4 || o.size[0] != 1 || o.size[1] != K || o.depth() != CV_32F)
    throw DataError("output layer '" + out_name_ + "' has unexpected shape " + det::shapeString(o) + " (expected [1x" +
                    std::to_string(K) + "xHxW] class scores, one channel per label of the label file)");
  const int H = o.size[2], W = o.size[3];
  const size_t plane = size_t(H) * size_t(W);
  cv::Mat best(H, W, CV_32F), lab(H, W, CV_8U, cv::Scalar(0));
  const float* base = o.ptr<float>();
  std::copy(base, base + plane, best.ptr<float>());
  float* bp = best.ptr<float>();
  uint8_t* lp = lab.ptr<uint8_t>();
  for (int k = 1; k < K; k++) {
    const float* c = base + size_t(k) * plane;
    for (size_t i = 0; i < plane; i++)
      if (c[i] > bp[i]) {
        bp[i] = c[i];
        lp[i] = uint8_t(k);
      }
  }
  cv::Mat coco_lab;
  cv::Mat lut(1, 256, CV_8U, cv::Scalar(coco::kNone));
  for (int k = 0; k < K; k++) lut.at<uint8_t>(k) = lut_[size_t(k)];
  cv::LUT(lab, lut, coco_lab);
  cv::resize(coco_lab, d.semantic, img.size(), 0, 0, cv::INTER_NEAREST);
  if (boxes_) {
    std::set<int> things;
    for (uint8_t v : lut_)
      if (v != coco::kNone && coco::isThing(v)) things.insert(v);
    for (int id : things) {
      cv::Mat mask = d.semantic == id;
      cv::Mat cc, stats, centroids;
      const int n = cv::connectedComponentsWithStats(mask, cc, stats, centroids, 8, CV_32S);
      for (int i = 1; i < n; i++) {
        const int area = stats.at<int>(i, cv::CC_STAT_AREA);
        if (area < min_box_area_) continue;
        BoundingBox b;
        b.box = cv::Rect2f(float(stats.at<int>(i, cv::CC_STAT_LEFT)), float(stats.at<int>(i, cv::CC_STAT_TOP)),
                           float(stats.at<int>(i, cv::CC_STAT_WIDTH)), float(stats.at<int>(i, cv::CC_STAT_HEIGHT)));
        b.class_id = id;
        b.score = 1.f;
        d.boxes.push_back(b);
      }
    }
  }
  return d;
}

}  // namespace dslam
