// Written sequences: `dslam synth` CLI, TUM reader compatibility, label file
// formats, objects.json events, byte-identical determinism.
#include <opencv2/imgcodecs.hpp>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "dslam/core/dataset.h"
#include "dslam/core/params.h"
#include "dslam/core/registry.h"
#include "dslam/synth/writer.h"
#include "test_support.h"

namespace fs = std::filesystem;
using namespace dslam::synth;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::shared_ptr<dslam::DatasetSource> openTum(const std::string& dir) {
  dslam::register_builtin_plugins();
  auto ds = dslam::create<dslam::DatasetSource>("dslam::TumDataset");
  ds->configure(dslam::Params::resolve(ds->paramSpecs(), "path: " + dir + "\npreset: tum_fr3\n"), dslam::PluginContext{});
  return ds;
}

}  // namespace

// Acceptance: `dslam synth walking_xyz --out DIR` then the TUM reader loads
// it; known wall points projected with the ground truth read back from the
// folder land on pixels with the expected depth.
TEST(SynthSequence, CliOutputIsReadByTumReader) {
  const std::string out = dslam::test::tempDir("synth_cli") + "/wx";
  const auto r = dslam::test::runDslam("synth " + dslam::test::source("config/scenarios/walking_xyz.yaml") + " --out " + out +
                                       " --frames 12 --resolution 320x240 --no-noise");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("frames/s"), std::string::npos) << r.out;
  for (const char* f : {"rgb.txt", "depth.txt", "associations.txt", "groundtruth.txt", "calib.txt", "times.txt",
                        "panoptic.json", "objects.json", "camera.yaml"})
    EXPECT_TRUE(fs::is_regular_file(fs::path(out) / f)) << f;
  for (const char* d : {"rgb", "depth", "right", "boxes", "semantic", "panoptic"}) {
    size_t n = 0;
    for (auto& e : fs::directory_iterator(fs::path(out) / d)) n += e.is_regular_file();
    EXPECT_EQ(n, 12u) << d;
  }
  auto ds = openTum(out);
  ASSERT_EQ(ds->size(), 12u);
  ASSERT_EQ(ds->groundTruth().size(), 12u);
  const auto cam = ds->camera();
  ASSERT_TRUE(cam.has_value());
  // Intrinsics at 320x240 (scaled fr3).
  const double fx = 535.4 / 2, fy = 539.2 / 2, cx = (320.1 + 0.5) / 2 - 0.5, cy = (247.6 + 0.5) / 2 - 0.5;
  int checked = 0;
  for (size_t i : {size_t(0), size_t(6), size_t(11)}) {
    const dslam::SensorFrame f = ds->read(i);
    ASSERT_EQ(f.image.cols, 320);
    ASSERT_EQ(f.depth.type(), CV_32F);
    EXPECT_NEAR(ds->groundTruth().stamps[i], f.timestamp, 1e-6);
    const dslam::SE3 T = ds->groundTruth().poses[i];
    const cv::Mat sem = cv::imread(out + "/semantic/" + fs::path(f.image_path).filename().string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(sem.type(), CV_8U);
    for (double y = -2.7; y <= 2.7; y += 0.3)
      for (double z = 0.3; z <= 2.6; z += 0.3) {
        const Vec3 P(3.5, y, z);  // the desk wall (x = +3.5)
        const Vec3 pc = T.inverse() * P;
        const int u = static_cast<int>(std::lround(fx * pc.x() / pc.z() + cx));
        const int v = static_cast<int>(std::lround(fy * pc.y() / pc.z() + cy));
        if (u < 1 || v < 1 || u >= 319 || v >= 239) continue;
        bool wall = true;
        for (int dv = -1; dv <= 1; dv++)
          for (int du = -1; du <= 1; du++) wall = wall && sem.at<uchar>(v + dv, u + du) == 199;
        if (!wall) continue;
        // Exact depth of the pixel-centre ray on the plane x = 3.5.
        const Vec3 d = T.rotation() * Vec3((u - cx) / fx, (v - cy) / fy, 1.0);
        const double zexp = (3.5 - T.translation().x()) / d.x();
        EXPECT_NEAR(f.depth.at<float>(v, u), zexp, 1.0 / 5000 + 1e-6) << "frame " << i << " pixel " << u << "," << v;
        EXPECT_NEAR(pc.z(), zexp, 0.02 * zexp);
        checked++;
      }
  }
  EXPECT_GT(checked, 60);
  // KITTI-style calib.txt: P1 = [fx 0 cx -fx*b; ...].
  std::istringstream calib(slurp(fs::path(out) / "calib.txt"));
  std::string tag;
  double p[12];
  calib >> tag;
  for (double& x : p) calib >> x;
  EXPECT_EQ(tag, "P0:");
  EXPECT_NEAR(p[0], fx, 1e-9);
  calib >> tag;
  for (double& x : p) calib >> x;
  EXPECT_EQ(tag, "P1:");
  EXPECT_NEAR(p[3], -fx * 0.1, 1e-9);
}

TEST(SynthSequence, CliRefusesExistingFolderWithoutOverwrite) {
  const std::string out = dslam::test::tempDir("synth_ow") + "/seq";
  const std::string base = "synth " + dslam::test::source("config/scenarios/static_office.yaml") + " --out " + out +
                           " --frames 2 --resolution 64x48";
  ASSERT_EQ(dslam::test::runDslam(base).exit_code, 0);
  const auto again = dslam::test::runDslam(base);
  EXPECT_EQ(again.exit_code, 1);
  EXPECT_NE(again.out.find("already exists"), std::string::npos) << again.out;
  EXPECT_NE(again.out.find("--overwrite"), std::string::npos) << again.out;
  EXPECT_EQ(dslam::test::runDslam(base + " --overwrite").exit_code, 0);
  // A folder that is not a synth output is never deleted.
  const std::string other = dslam::test::tempDir("synth_other");
  dslam::test::writeFile(other + "/precious.txt", "keep");
  const auto r = dslam::test::runDslam("synth " + dslam::test::source("config/scenarios/static_office.yaml") + " --out " +
                                       other + " --frames 2 --resolution 64x48 --overwrite");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.out.find("refusing"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(other + "/precious.txt"));
}

TEST(SynthSequence, CliReportsBadScenario) {
  const std::string dir = dslam::test::tempDir("synth_bad");
  dslam::test::writeFile(dir + "/bad.yaml", "frames: 5\nroom: {size: [6, 5, 2.8]}\ncamera:\n  trajectory: {type: static}\n"
                                            "objects:\n  - {name: x, type: pyramid, class: chair, position: [0, 0, 0]}\n");
  const auto r = dslam::test::runDslam("synth " + dir + "/bad.yaml --out " + dir + "/o");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.out.find("error:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("bad.yaml:6"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("objects[0].type"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("pyramid"), std::string::npos) << r.out;
  const auto r2 = dslam::test::runDslam("synth " + dir + "/bad.yaml --out " + dir + "/o --resolution 64by48");
  EXPECT_EQ(r2.exit_code, 1);
  EXPECT_NE(r2.out.find("--resolution"), std::string::npos) << r2.out;
}

// A small changing scene written to disk: objects.json events, the semantic
// and panoptic PNGs and boxes/ agree with what happens.
TEST(SynthSequence, LabelFilesAndEventsMatchTheFrames) {
  const std::string yaml = R"(
name: events
frames: 24
seed: 3
resolution: [160, 120]
room: {size: [6, 5, 2.8]}
camera:
  trajectory: {type: static, center: [-2, 0, 1.4], look_at: [3, 0, 0.8], jitter_position: 0, jitter_rotation: 0}
objects:
  - {name: case, type: box, class: suitcase, size: [0.3, 0.5, 0.7], position: [0.5, -0.8, 0]}
  - {name: chair, type: chair, position: [0.8, 0.6, 0], yaw: 180}
  - {name: plant, type: plant}
  - {name: ball, type: sphere, class: balloon, labelled: false, size: [0.4, 0.4, 0.4], position: [1.5, 0.0, 1.0]}
people:
  - {name: bob, action: stand, position: [1.8, 1.2], yaw: 180}
events:
  - {type: removed, object: case, frame: 8}
  - {type: replaced, object: chair, by: plant, frame: 12}
  - {type: moved, object: ball, frames: [14, 20], position: [1.5, -1.2, 1.0]}
)";
  const std::string out = dslam::test::tempDir("synth_ev") + "/seq";
  writeSequence(parseScenario(yaml, "events.yaml"), out, WriteOptions{false, 0, false});
  const auto oj = nlohmann::json::parse(dslam::test::readFile(out + "/objects.json"));
  ASSERT_EQ(oj["events"].size(), 3u);
  EXPECT_EQ(oj["events"][0]["type"].get<std::string>(), "removed");
  EXPECT_EQ(oj["events"][0]["frames"][0].get<int>(), 8);
  EXPECT_TRUE(oj["events"][0]["in_view"].get<bool>());
  EXPECT_EQ(oj["events"][1]["by"].get<std::string>(), "plant");
  EXPECT_EQ(oj["events"][2]["frames"][1].get<int>(), 20);
  // Presence ranges.
  EXPECT_EQ(oj["objects"][0]["present"][0][1].get<int>(), 7);
  EXPECT_EQ(oj["objects"][2]["present"][0][0].get<int>(), 12);
  EXPECT_EQ(oj["objects"][3]["category_id"].get<int>(), 0);
  EXPECT_FALSE(oj["objects"][3]["labelled"].get<bool>());
  // The ball's track has a pose per frame of the move and none after.
  const auto& track = oj["objects"][3]["track"];
  EXPECT_EQ(track[track.size() - 1][0].get<int>(), 20);
  EXPECT_NEAR(track[track.size() - 1][2].get<double>(), -1.2, 1e-9);
  EXPECT_EQ(oj["people"][0]["category_id"].get<int>(), 1);

  std::vector<std::string> stamps;
  {
    std::ifstream f(out + "/rgb.txt");
    std::string line;
    while (std::getline(f, line))
      if (!line.empty() && line[0] != '#') stamps.push_back(line.substr(0, line.find(' ')));
  }
  ASSERT_EQ(stamps.size(), 24u);
  auto sem = [&](int f) { return cv::imread(out + "/semantic/" + stamps[static_cast<size_t>(f)] + ".png", cv::IMREAD_UNCHANGED); };
  EXPECT_GT(cv::countNonZero(sem(7) == 33), 100);   // suitcase before removal
  EXPECT_EQ(cv::countNonZero(sem(8) == 33), 0);     // gone after
  EXPECT_GT(cv::countNonZero(sem(11) == 62), 100);  // chair before replacement
  EXPECT_EQ(cv::countNonZero(sem(12) == 62), 0);
  EXPECT_GT(cv::countNonZero(sem(12) == 64), 100);  // potted plant after

  // panoptic.json: COCO panoptic format, ids encoded as R + 256 G + 256^2 B.
  const auto pj = nlohmann::json::parse(dslam::test::readFile(out + "/panoptic.json"));
  ASSERT_EQ(pj["annotations"].size(), 24u);
  EXPECT_EQ(pj["categories"].size(), 133u);
  for (int f : {0, 13}) {
    const auto& ann = pj["annotations"][static_cast<size_t>(f)];
    EXPECT_EQ(ann["file_name"].get<std::string>(), stamps[static_cast<size_t>(f)] + ".png");
    const cv::Mat png = cv::imread(out + "/panoptic/" + ann["file_name"].get<std::string>(), cv::IMREAD_COLOR);
    ASSERT_EQ(png.type(), CV_8UC3);
    std::map<int, int> area;
    for (int y = 0; y < png.rows; y++)
      for (int x = 0; x < png.cols; x++) {
        const cv::Vec3b c = png.at<cv::Vec3b>(y, x);  // BGR
        area[c[2] + 256 * c[1] + 65536 * c[0]]++;
      }
    const auto& segs = ann["segments_info"];
    std::set<int> cats;
    for (size_t i = 0; i < segs.size(); i++) {
      EXPECT_EQ(segs[i]["area"].get<int>(), area[segs[i]["id"].get<int>()]);
      EXPECT_EQ(segs[i]["iscrowd"].get<int>(), 0);
      EXPECT_EQ(segs[i]["bbox"].size(), 4u);
      cats.insert(segs[i]["category_id"].get<int>());
    }
    EXPECT_TRUE(cats.count(199) && cats.count(190) && cats.count(1));  // wall, floor, person
    EXPECT_GT(area[0], 100);  // the unlabelled ball is void
  }
  // boxes/: person and suitcase boxes with score 1.
  const auto boxes = readBoxes(out + "/boxes/" + stamps[0] + ".json");
  std::set<int> cats;
  for (const auto& b : boxes) {
    cats.insert(b.category_id);
    EXPECT_FLOAT_EQ(b.score, 1.0f);
    EXPECT_GT(b.box.area(), 0);
  }
  EXPECT_TRUE(cats.count(1) && cats.count(33) && cats.count(62));
  EXPECT_FALSE(cats.count(0));
}

// Two renders with one seed are byte-identical (whatever the thread count);
// another seed changes the images.
TEST(SynthSequence, SameSeedGivesByteIdenticalOutput) {
  ScenarioOverrides ov;
  ov.frames = 6;
  ov.width = 160;
  ov.height = 120;
  const Scenario s = loadScenario(dslam::test::source("config/scenarios/walking_xyz.yaml"), ov);
  const std::string a = dslam::test::tempDir("synth_det") + "/a", b = dslam::test::tempDir("synth_det") + "/b",
                    c = dslam::test::tempDir("synth_det") + "/c";
  WriteOptions o1{false, 1, false}, o2{false, 2, false};
  writeSequence(s, a, o1);
  writeSequence(s, b, o2);
  size_t files = 0;
  for (auto& e : fs::recursive_directory_iterator(a)) {
    if (!e.is_regular_file()) continue;
    const fs::path rel = fs::relative(e.path(), a);
    ASSERT_TRUE(fs::exists(fs::path(b) / rel)) << rel;
    EXPECT_TRUE(slurp(e.path()) == slurp(fs::path(b) / rel)) << rel << " differs";
    files++;
  }
  size_t files_b = 0;
  for (auto& e : fs::recursive_directory_iterator(b)) files_b += e.is_regular_file();
  EXPECT_EQ(files, files_b);
  EXPECT_GT(files, 6u * 7u);
  Scenario s2 = s;
  s2.seed = 12345;
  writeSequence(s2, c, o1);
  const std::string first = fs::path(a).string() + "/rgb/" + fs::directory_iterator(fs::path(a) / "rgb")->path().filename().string();
  EXPECT_FALSE(slurp(first) == slurp(fs::path(c) / "rgb" / fs::path(first).filename()));
}
