// Writes small synthetic seed inputs for the fuzz targets with dslam's own
// writers (tests/fuzz/README.md, "Seeds"): a tiny vocabulary in the three
// formats, a tiny atlas, tiny rawlogs of each supported observation class,
// label files. Each seed carries the selector byte its harness expects.
// Usage: fuzz_make_seeds OUT_DIR   (writes OUT_DIR/<target>/<name>)
#include <mrpt/io/CFileOutputStream.h>
#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/obs/CObservationStereoImages.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/poses/CPose3DQuat.h>
#include <mrpt/serialization/CArchive.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>

#include <opencv2/core.hpp>

#include "dslam/map/atlas.h"
#include "dslam/map/keyframe.h"
#include "dslam/map/map_point.h"
#include "dslam/place_recognition/vocabulary.h"
#include "dslam/plugins/detectors/label_io.h"
#include "mrpt_camera.h"

using dslam::test::tcam;

namespace fs = std::filesystem;
using namespace dslam;

namespace {

fs::path g_out;

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}

/** Writes OUT/<target>/<name> = selector byte (if >= 0) + the bytes of `file`. */
void seed(const std::string& target, const std::string& name, int selector, const fs::path& file) {
  fs::create_directories(g_out / target);
  std::ofstream o(g_out / target / name, std::ios::binary);
  if (selector >= 0) o.put(static_cast<char>(selector));
  o << slurp(file);
}

void vocabularies(const fs::path& tmp) {
  std::mt19937 rng(7);
  std::vector<cv::Mat> images;
  for (int i = 0; i < 3; i++) {
    cv::Mat d(12, 32, CV_8U);
    for (int k = 0; k < d.rows * d.cols; k++) d.data[k] = static_cast<uint8_t>(rng());
    images.push_back(d);
  }
  VocabularyTrainParams p;
  p.k = 3;
  p.levels = 2;
  const Vocabulary v = Vocabulary::train(images, p);
  v.save((tmp / "v.dvoc").string());
  v.saveText((tmp / "v.txt").string());
  v.saveYaml((tmp / "v.yml").string());
  // Selectors of fuzz_vocabulary: 0 auto, 1 binary, 2 text, 3 yaml; +4 = gzip.
  seed("vocabulary", "tiny_binary", 1, tmp / "v.dvoc");
  seed("vocabulary", "tiny_text", 2, tmp / "v.txt");
  seed("vocabulary", "tiny_yaml", 3, tmp / "v.yml");
  seed("vocabulary", "tiny_text_gz", 6, tmp / "v.txt");
  seed("vocabulary", "tiny_yaml_gz", 7, tmp / "v.yml");
  seed("vocabulary", "tiny_auto_binary_gz", 4, tmp / "v.dvoc");
}

void atlas(const fs::path& tmp) {
  Atlas a;
  auto m = a.createMap();
  auto scale = std::make_shared<const ScaleLevels>(ScaleLevels::make(2, 1.2f));
  CameraIntrinsics c;
  c.fx = c.fy = 100;
  c.cx = 20;
  c.cy = 15;
  c.invfx = c.invfy = 0.01f;
  c.bf = 4;
  c.close_depth = 3;
  c.bounds = {0, 40, 0, 30};
  std::vector<KeyFramePtr> kfs;
  for (int k = 0; k < 2; k++) {
    Frame f;
    f.input.index = k;
    f.input.timestamp = 1.0 + k;
    for (int i = 0; i < 3; i++) f.keypoints_un.emplace_back(5.f + 10 * i, 7.f + 5 * i, 31.f, 0.f, 1.f, i % 2);
    f.keypoints = f.keypoints_un;
    f.descriptors = cv::Mat(3, 32, CV_8U, cv::Scalar(17 * (k + 1)));
    f.depth = {1.f, 1.5f, -1.f};
    f.u_right = {3.f, 8.f, -1.f};
    f.resetMeta();
    f.meta[1].label = KpLabel::Dynamic;
    f.meta[1].class_id = 1;
    SE3 T;
    auto kf = std::make_shared<KeyFrame>(k, f, T, c, scale, m.get());
    m->addKeyFrame(kf);
    kfs.push_back(kf);
  }
  for (int i = 0; i < 2; i++) {
    auto mp = std::make_shared<MapPoint>(i, Eigen::Vector3d(0.1 * i, 0.2, 1.0 + i), kfs[0].get(), m.get());
    for (auto& kf : kfs) {
      mp->addObservation(kf.get(), i);
      kf->points[i] = mp;
    }
    mp->updateNormalAndDepth();
    m->addPoint(mp);
  }
  for (auto& kf : kfs) kf->updateConnections();
  a.save((tmp / "a.atlas").string());
  seed("atlas", "tiny_atlas", -1, tmp / "a.atlas");
}

void writeObjs(const fs::path& file, const std::vector<mrpt::serialization::CSerializable::Ptr>& objs) {
  mrpt::io::CFileOutputStream out(file.string());
  auto ar = mrpt::serialization::archiveFrom(out);
  for (const auto& o : objs) ar << *o;
}

void rawlogs(const fs::path& tmp) {
  using namespace mrpt::obs;
  std::vector<mrpt::serialization::CSerializable::Ptr> mono, stereo, rgbd, sf;
  for (int i = 0; i < 2; i++) {
    auto o = CObservationImage::Create();
    o->sensorLabel = "CAM";
    o->timestamp = mrpt::Clock::fromDouble(10.0 + i);
    o->cameraParams = tcam(10, 4, 3);
    o->image = mrpt::img::CImage(cv::Mat(3, 4, CV_8UC1, cv::Scalar(40 * i)), mrpt::img::DEEP_COPY);
    mono.push_back(o);

    auto s = CObservationStereoImages::Create();
    s->sensorLabel = "STEREO";
    s->timestamp = mrpt::Clock::fromDouble(10.0 + i);
    s->leftCamera = s->rightCamera = tcam(20, 4, 3);
    s->rightCameraPose = mrpt::poses::CPose3DQuat(mrpt::poses::CPose3D(0.12, 0, 0, 0, 0, 0));
    s->imageLeft = mrpt::img::CImage(cv::Mat(3, 4, CV_8UC1, cv::Scalar(1)), mrpt::img::DEEP_COPY);
    s->imageRight = mrpt::img::CImage(cv::Mat(3, 4, CV_8UC1, cv::Scalar(2)), mrpt::img::DEEP_COPY);
    s->hasImageRight = true;
    stereo.push_back(s);

    auto r = CObservation3DRangeScan::Create();
    r->sensorLabel = "RGBD";
    r->timestamp = mrpt::Clock::fromDouble(10.0 + i);
    r->hasRangeImage = true;
    r->range_is_depth = (i == 0);
    r->rangeUnits = 0.001f;
    r->rangeImage_setSize(3, 4);
    for (int v = 0; v < 3; v++)
      for (int u = 0; u < 4; u++) r->rangeImage(v, u) = static_cast<uint16_t>(1000 + 10 * u);
    r->hasIntensityImage = true;
    r->intensityImage = mrpt::img::CImage(cv::Mat(3, 4, CV_8UC3, cv::Scalar(1, 2, 3)), mrpt::img::DEEP_COPY);
    r->cameraParams = r->cameraParamsIntensity = tcam(5, 4, 3);
    if (i == 1) r->cameraParamsIntensity = tcam(6, 4, 3);  // needs registration
    rgbd.push_back(r);

    auto frame = CSensoryFrame::Create();
    frame->insert(o);
    sf.push_back(frame);
  }
  writeObjs(tmp / "mono.rawlog", mono);
  writeObjs(tmp / "stereo.rawlog", stereo);
  writeObjs(tmp / "rgbd.rawlog", rgbd);
  writeObjs(tmp / "sf.rawlog", sf);
  for (const char* n : {"mono", "stereo", "rgbd", "sf"}) seed("rawlog", std::string("tiny_") + n, -1, tmp / (std::string(n) + ".rawlog"));
}

void labelFiles(const fs::path& tmp) {
  std::vector<BoundingBox> boxes(2);
  boxes[0].class_id = 1;
  boxes[0].box = cv::Rect2f(1, 2, 3, 4);
  boxes[0].score = 0.9f;
  boxes[0].instance_id = 3;
  boxes[1].class_id = 62;
  boxes[1].box = cv::Rect2f(0, 0, 8, 6);
  labels::writeBoxJson((tmp / "b.json").string(), boxes, cv::Size(8, 6), "000001.png");
  seed("labels", "box_json", 0, tmp / "b.json");
  seed("labels", "box_json_index80", 1, tmp / "b.json");

  std::vector<labels::PanopticAnnotation> anns(1);
  anns[0].file_name = "000001.png";
  anns[0].image_id = "1";
  PanopticSegment s;
  s.id = 1;
  s.category_id = 1;
  s.bbox = cv::Rect(0, 0, 2, 2);
  s.area = 4;
  s.instance_id = 7;
  anns[0].segments.push_back(s);
  s.id = 2;
  s.category_id = 184;  // stuff
  s.instance_id = -1;
  anns[0].segments.push_back(s);
  labels::writePanopticJson((tmp / "p.json").string(), anns, labels::cocoPanopticCategories());
  seed("labels", "panoptic_json", 2, tmp / "p.json");
  labels::writePanopticJson((tmp / "p_small.json").string(), anns, {{1, "person", true}, {184, "tree", false}});
  seed("labels", "panoptic_json_small", 2, tmp / "p_small.json");

  cv::Mat sem(6, 8, CV_8U, cv::Scalar(255));
  sem(cv::Rect(1, 1, 3, 3)).setTo(1);
  labels::writeSemanticPng((tmp / "s.png").string(), sem);
  seed("labels", "semantic_png", 3, tmp / "s.png");
  cv::Mat ids(6, 8, CV_32S, cv::Scalar(0));
  ids(cv::Rect(0, 0, 2, 2)).setTo(1);
  ids(cv::Rect(4, 2, 3, 3)).setTo(2);
  labels::writePanopticPng((tmp / "p.png").string(), ids);
  seed("labels", "panoptic_png", 4, tmp / "p.png");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s OUT_DIR\n", argv[0]);
    return 2;
  }
  g_out = argv[1];
  const fs::path tmp = g_out / ".tmp";
  fs::create_directories(tmp);
  vocabularies(tmp);
  atlas(tmp);
  rawlogs(tmp);
  labelFiles(tmp);
  fs::remove_all(tmp);
  std::printf("seeds written to %s\n", argv[1]);
  return 0;
}
