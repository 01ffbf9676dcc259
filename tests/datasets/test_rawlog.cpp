// MRPT rawlog reader and the TUM <-> rawlog converters.
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/obs/CObservationStereoImages.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/serialization/CArchive.h>

#include <cmath>
#include <fstream>

#include "dslam/plugins/datasets/convert.h"
#include "dslam/plugins/datasets/rawlog.h"
#include "dslam/plugins/datasets/tum.h"
#include "ds_test_util.h"
#include "mrpt_camera.h"

namespace fs = std::filesystem;
using namespace dslam;
using namespace dslam::test;
using namespace mrpt::obs;

namespace {

std::shared_ptr<RawlogDataset> openRawlog(const std::string& file, const std::string& extra = "") {
  return std::dynamic_pointer_cast<RawlogDataset>(openDataset("dslam::RawlogDataset", "path: " + yq(file) + "\n" + extra));
}

void writeRawlog(const std::string& file, const std::vector<mrpt::serialization::CSerializable::Ptr>& objs) {
  mrpt::io::CFileGZOutputStream out(file);
  auto ar = mrpt::serialization::archiveFrom(out);
  for (const auto& o : objs) ar << *o;
}

CObservationImage::Ptr monoObs(const std::string& label, double t, int value) {
  auto o = CObservationImage::Create();
  o->sensorLabel = label;
  o->timestamp = mrpt::Clock::fromDouble(t);
  o->cameraParams = tcam(100, 20, 10);
  o->image = mrpt::img::CImage(cv::Mat(10, 20, CV_8UC1, cv::Scalar(value)), mrpt::img::DEEP_COPY);
  return o;
}

CObservationStereoImages::Ptr stereoObs(double t) {
  auto o = CObservationStereoImages::Create();
  o->sensorLabel = "STEREO";
  o->timestamp = mrpt::Clock::fromDouble(t);
  o->leftCamera = o->rightCamera = tcam(200, 20, 10);
  o->rightCameraPose = mrpt::poses::CPose3DQuat(mrpt::poses::CPose3D(0.12, 0, 0, 0, 0, 0));
  o->imageLeft = mrpt::img::CImage(cv::Mat(10, 20, CV_8UC1, cv::Scalar(1)), mrpt::img::DEEP_COPY);
  o->imageRight = mrpt::img::CImage(cv::Mat(10, 20, CV_8UC1, cv::Scalar(2)), mrpt::img::DEEP_COPY);
  o->hasImageRight = true;
  return o;
}

}  // namespace

TEST(RawlogDataset, SharedRgbdRawlog) {
  const std::string file = shared("data/mrpt/tests_rgbd.rawlog");
  if (file.empty()) GTEST_SKIP();
  auto ds = openRawlog(file);
  ASSERT_EQ(ds->size(), 1u);
  EXPECT_EQ(ds->sensor(), SensorType::RGBD);
  EXPECT_EQ(ds->sensorLabel(), "OPENNI2");
  EXPECT_EQ(ds->objectCount(), 1u);
  EXPECT_FALSE(ds->sensoryFrameFormat());
  ASSERT_EQ(ds->labels().size(), 1u);
  EXPECT_EQ(ds->labels()[0].obs_class, "mrpt::obs::CObservation3DRangeScan");
  EXPECT_NEAR(ds->timestamp(0), 1462879443.617188, 1e-6);
  // Depth camera (fx 572.9) and RGB camera (fx 521.2) differ: depth is registered.
  EXPECT_TRUE(ds->registersDepth());
  const auto cam = *ds->camera();
  EXPECT_EQ(cam.sensor, SensorType::RGBD);
  EXPECT_NEAR(cam.left.fx, 521.17923, 1e-4);
  EXPECT_NEAR(cam.left.fy, 493.03303, 1e-4);
  EXPECT_NEAR(cam.left.cx, 322.51599, 1e-4);
  EXPECT_NEAR(cam.left.cy, 259.05597, 1e-4);
  EXPECT_NEAR(cam.left.dist[0], 5.858325e-02, 1e-7);
  EXPECT_EQ(cam.left.width, 640);
  EXPECT_EQ(cam.left.height, 480);
  EXPECT_DOUBLE_EQ(cam.depth_factor, 1000);  // rangeUnits 0.001

  const SensorFrame f = ds->read(0);
  EXPECT_EQ(f.image.type(), CV_8UC3);
  EXPECT_EQ(f.image.size(), cv::Size(640, 480));
  ASSERT_EQ(f.depth.type(), CV_32F);
  ASSERT_EQ(f.depth.size(), cv::Size(640, 480));

  // Independent check of the registration against the stored range image:
  // each registered pixel, back-projected with the RGB intrinsics and moved
  // into the depth camera, lands on a raw depth of the same value.
  mrpt::io::CFileGZInputStream in(file);
  auto ar = mrpt::serialization::archiveFrom(in);
  auto obs = std::dynamic_pointer_cast<CObservation3DRangeScan>(ar.ReadObject());
  ASSERT_TRUE(obs);
  const auto& kd = obs->cameraParams;
  // depth optical -> intensity optical = relPose^-1 * R0 (MRPT's X-forward scan frame).
  const mrpt::poses::CPose3D R0(0, 0, 0, mrpt::DEG2RAD(-90.0), 0, mrpt::DEG2RAD(-90.0));
  const mrpt::poses::CPose3D T_d_i = (-R0) + obs->relativePoseIntensityWRTDepth;  // intensity -> depth optical
  size_t valid = 0, checked = 0, agree = 0;
  for (int v = 0; v < 480; v++)
    for (int u = 0; u < 640; u++) {
      const float z = f.depth.at<float>(v, u);
      if (z <= 0) continue;
      valid++;
      if ((u % 7) || (v % 7)) continue;
      const mrpt::math::TPoint3D Pi((u - cam.left.cx) / cam.left.fx * z, (v - cam.left.cy) / cam.left.fy * z, z);
      const auto Pd = T_d_i.composePoint(Pi);
      const int ud = static_cast<int>(std::lround(kd.fx() * Pd.x / Pd.z + kd.cx()));
      const int vd = static_cast<int>(std::lround(kd.fy() * Pd.y / Pd.z + kd.cy()));
      if (ud < 1 || vd < 1 || ud >= 639 || vd >= 479) continue;
      checked++;
      bool ok = false;
      for (int dv = -1; dv <= 1 && !ok; dv++)
        for (int du = -1; du <= 1 && !ok; du++)
          ok = std::abs(obs->rangeImage(vd + dv, ud + du) * 0.001 - Pd.z) < 0.01 * Pd.z;
      agree += ok;
    }
  EXPECT_GT(valid, 200000u);  // raw image: 273225 valid pixels
  EXPECT_LT(valid, 330000u);
  ASSERT_GT(checked, 3000u);
  EXPECT_GT(static_cast<double>(agree) / checked, 0.97) << agree << " of " << checked;

  // Without registration the raw range image comes out unchanged.
  auto raw = openRawlog(file, "register_depth: false\n");
  EXPECT_FALSE(raw->registersDepth());
  cv::Mat r16;
  double units = 0;
  const auto g = raw->readRaw(0, &r16, &units);
  ASSERT_EQ(r16.type(), CV_16UC1);
  EXPECT_EQ(cv::countNonZero(r16), 273225);
  EXPECT_NEAR(units, 0.001, 1e-9);
  EXPECT_FLOAT_EQ(g.depth.at<float>(240, 320), r16.at<uint16_t>(240, 320) * 0.001f);
}

TEST(RawlogDataset, RegistrationGeometry) {
  // Depth camera and RGB camera with the same intrinsics, the RGB camera
  // 0.1 m to the right (+x optical = -Y in MRPT's X-forward scan frame).
  // A wall at 2 m with a 1 m-deep square: in the RGB image the wall shifts
  // by fx*0.1/2 = 25 px to the left, the square by 50 px, leaving an
  // occlusion shadow to the right of the square.
  const std::string dir = tempDir("rawlog_reg");
  auto o = CObservation3DRangeScan::Create();
  o->sensorLabel = "KINECT";
  o->timestamp = mrpt::Clock::fromDouble(100.0);
  o->hasRangeImage = true;
  o->rangeUnits = 0.001f;
  o->rangeImage_setSize(240, 320);
  for (int v = 0; v < 240; v++)
    for (int u = 0; u < 320; u++) o->rangeImage(v, u) = (u >= 150 && u < 190 && v >= 100 && v < 140) ? 1000 : 2000;
  o->hasIntensityImage = true;
  o->intensityImage = mrpt::img::CImage(cv::Mat(240, 320, CV_8UC3, cv::Scalar(1, 2, 3)), mrpt::img::DEEP_COPY);
  o->cameraParams = o->cameraParamsIntensity = tcam(500, 320, 240);
  o->relativePoseIntensityWRTDepth = mrpt::poses::CPose3D(0, -0.1, 0, mrpt::DEG2RAD(-90.0), 0, mrpt::DEG2RAD(-90.0));
  writeRawlog(dir + "/reg.rawlog", {o});
  auto ds = openRawlog(dir + "/reg.rawlog");
  EXPECT_TRUE(ds->registersDepth());
  const cv::Mat d = ds->read(0).depth;
  const int v = 120;
  EXPECT_FLOAT_EQ(d.at<float>(v, 60), 2.0f);    // wall, depth pixel 85
  EXPECT_FLOAT_EQ(d.at<float>(v, 110), 1.0f);   // square (depth 150..189) -> 100..139
  EXPECT_FLOAT_EQ(d.at<float>(v, 138), 1.0f);
  EXPECT_FLOAT_EQ(d.at<float>(v, 145), 0.0f);   // shadow: wall behind the square, unseen by the depth camera
  EXPECT_FLOAT_EQ(d.at<float>(v, 160), 0.0f);
  EXPECT_FLOAT_EQ(d.at<float>(v, 170), 2.0f);   // wall again (depth pixel 195)
  EXPECT_FLOAT_EQ(d.at<float>(v, 300), 0.0f);   // right border: beyond the depth camera's view
  EXPECT_FLOAT_EQ(d.at<float>(v, 290), 2.0f);
  EXPECT_FLOAT_EQ(d.at<float>(20, 110), 2.0f);  // above the square
}

TEST(RawlogDataset, RangesAlongRaysBecomeDepth) {
  const std::string dir = tempDir("rawlog_rays");
  auto o = CObservation3DRangeScan::Create();
  o->sensorLabel = "TOF";
  o->hasRangeImage = true;
  o->range_is_depth = false;
  o->rangeUnits = 0.0001f;
  o->rangeImage_setSize(24, 32);
  o->cameraParams = o->cameraParamsIntensity = tcam(30, 32, 24);
  for (int v = 0; v < 24; v++)
    for (int u = 0; u < 32; u++) {
      const double a = (u - 15.5) / 30, b = (v - 11.5) / 30;
      o->rangeImage(v, u) = static_cast<uint16_t>(std::lround(2.0 * std::sqrt(1 + a * a + b * b) / 0.0001));
    }
  o->hasIntensityImage = true;
  o->intensityImage = mrpt::img::CImage(cv::Mat(24, 32, CV_8UC1, cv::Scalar(9)), mrpt::img::DEEP_COPY);
  writeRawlog(dir + "/tof.rawlog", {o});
  auto ds = openRawlog(dir + "/tof.rawlog");
  EXPECT_FALSE(ds->registersDepth());
  const cv::Mat d = ds->read(0).depth;
  double mn, mx;
  cv::minMaxLoc(d, &mn, &mx);
  EXPECT_NEAR(mn, 2.0, 1e-4);
  EXPECT_NEAR(mx, 2.0, 1e-4);
}

TEST(RawlogDataset, SensoryFramesSeveralLabelsMonoAndStereo) {
  const std::string dir = tempDir("rawlog_sf");
  std::vector<mrpt::serialization::CSerializable::Ptr> objs;
  for (int i = 0; i < 3; i++) {
    objs.push_back(CActionCollection::Create());
    auto sf = CSensoryFrame::Create();
    sf->insert(monoObs("CAM", 10.0 + i, 50 + i));
    if (i < 2) sf->insert(stereoObs(10.01 + i));
    objs.push_back(sf);
  }
  const std::string file = dir + "/multi.rawlog";
  writeRawlog(file, objs);

  std::string e = anyErrorOf([&] { openRawlog(file); });
  EXPECT_NE(e.find("several camera sensor labels"), std::string::npos) << e;
  EXPECT_NE(e.find("'CAM'"), std::string::npos) << e;
  EXPECT_NE(e.find("'STEREO'"), std::string::npos) << e;
  e = anyErrorOf([&] { openRawlog(file, "sensor_label: LIDAR\n"); });
  EXPECT_NE(e.find("LIDAR"), std::string::npos) << e;
  EXPECT_NE(e.find("'CAM'"), std::string::npos) << e;

  auto mono = openRawlog(file, "sensor_label: CAM\n");
  EXPECT_TRUE(mono->sensoryFrameFormat());
  EXPECT_EQ(mono->objectCount(), 6u);
  ASSERT_EQ(mono->size(), 3u);
  EXPECT_EQ(mono->sensor(), SensorType::Monocular);
  EXPECT_DOUBLE_EQ(mono->camera()->left.fx, 100);
  EXPECT_NEAR(mono->timestamp(2), 12.0, 1e-6);
  // Random access in any order (the reader reopens the file to go back).
  EXPECT_EQ(mono->read(2).image.at<uint8_t>(0, 0), 52);
  EXPECT_EQ(mono->read(0).image.at<uint8_t>(0, 0), 50);
  EXPECT_EQ(mono->read(1).image.at<uint8_t>(0, 0), 51);
  EXPECT_EQ(mono->read(1).image.at<uint8_t>(0, 0), 51);

  auto st = openRawlog(file, "sensor_label: STEREO\n");
  ASSERT_EQ(st->size(), 2u);
  EXPECT_EQ(st->sensor(), SensorType::Stereo);
  const auto cam = *st->camera();
  EXPECT_TRUE(cam.rectified);
  EXPECT_NEAR(cam.baseline, 0.12, 1e-9);
  EXPECT_NEAR(cam.bf(), 24.0, 1e-7);
  const auto f = st->read(1);
  EXPECT_EQ(f.image.at<uint8_t>(0, 0), 1);
  EXPECT_EQ(f.image_right.at<uint8_t>(0, 0), 2);
  EXPECT_NEAR(f.timestamp, 11.01, 1e-6);
}

TEST(RawlogDataset, ExternalImagesAndBadInputs) {
  const std::string dir = tempDir("rawlog_ext");
  mkdirs(dir + "/seq_Images");
  std::vector<mrpt::serialization::CSerializable::Ptr> objs;
  for (int i = 0; i < 3; i++) {
    const std::string name = "img_" + std::to_string(i) + ".png";
    writeImage(dir + "/seq_Images/" + name, cv::Mat(10, 20, CV_8UC1, cv::Scalar(70 + i)));
    auto o = monoObs("CAM", 5.0 + i, 0);
    o->image.setExternalStorage(name);
    objs.push_back(o);
  }
  writeRawlog(dir + "/seq.rawlog", objs);
  auto ds = openRawlog(dir + "/seq.rawlog");
  EXPECT_EQ(ds->imagesDir(), dir + "/seq_Images");
  ASSERT_EQ(ds->size(), 3u);
  EXPECT_EQ(ds->read(2).image.at<uint8_t>(3, 3), 72);
  fs::remove(dir + "/seq_Images/img_1.png");
  std::string e = dataError([&] { ds->read(1); });
  EXPECT_NE(e.find("frame 1"), std::string::npos) << e;
  EXPECT_NE(e.find(dir + "/seq_Images/img_1.png"), std::string::npos) << e;
  EXPECT_NE(e.find("missing"), std::string::npos) << e;
  // Another images folder.
  fs::rename(dir + "/seq_Images", dir + "/elsewhere");
  EXPECT_EQ(openRawlog(dir + "/seq.rawlog", "images_dir: " + yq(dir + "/elsewhere") + "\n")->read(0).image.at<uint8_t>(0, 0), 70);

  // Timestamps going backwards.
  writeRawlog(dir + "/back.rawlog", {monoObs("CAM", 2.0, 1), monoObs("CAM", 3.0, 1), monoObs("CAM", 2.5, 1)});
  e = dataError([&] { openRawlog(dir + "/back.rawlog"); });
  EXPECT_NE(e.find("back.rawlog"), std::string::npos) << e;
  EXPECT_NE(e.find("must increase"), std::string::npos) << e;
  EXPECT_NE(e.find("frame 2"), std::string::npos) << e;

  // Missing file, folder instead of file, garbage, truncated file, no camera observations.
  e = dataError([&] { openRawlog(dir + "/none.rawlog"); });
  EXPECT_NE(e.find(dir + "/none.rawlog"), std::string::npos) << e;
  e = dataError([&] { openRawlog(dir); });
  EXPECT_NE(e.find("folder"), std::string::npos) << e;
  writeFile(dir + "/garbage.rawlog", std::string(300, 'x'));
  e = dataError([&] { openRawlog(dir + "/garbage.rawlog"); });
  EXPECT_NE(e.find("garbage.rawlog"), std::string::npos) << e;
  {
    writeRawlog(dir + "/full.rawlog", {monoObs("CAM", 1.0, 1), monoObs("CAM", 2.0, 1)});
    mrpt::io::CFileGZInputStream in(dir + "/full.rawlog");
    std::string bytes(1 << 16, '\0');
    bytes.resize(in.Read(bytes.data(), bytes.size()));
    std::ofstream(dir + "/cut.rawlog", std::ios::binary).write(bytes.data(), bytes.size() - 100);
    e = dataError([&] { openRawlog(dir + "/cut.rawlog"); });
    EXPECT_NE(e.find("cut.rawlog"), std::string::npos) << e;
    EXPECT_NE(e.find("object 1"), std::string::npos) << e;
  }
  writeRawlog(dir + "/acts.rawlog", {CActionCollection::Create(), CSensoryFrame::Create()});
  e = dataError([&] { openRawlog(dir + "/acts.rawlog"); });
  EXPECT_NE(e.find("no camera observations"), std::string::npos) << e;
}

TEST(RawlogConvert, TumRoundTripIsBitExact) {
  TinyTum t("rgbd_dataset_freiburg2_tiny", {640, 480});
  const std::string dir = tempDir("convert");
  const std::string rl = dir + "/tiny.rawlog";
  const auto r1 = convertTumToRawlog(t.dir, rl);
  EXPECT_EQ(r1.frames, 4u);
  EXPECT_DOUBLE_EQ(r1.depth_factor, 5000);
  EXPECT_EQ(r1.camera, "preset tum_fr2");

  // What MRPT stored.
  {
    mrpt::io::CFileGZInputStream in(rl);
    auto ar = mrpt::serialization::archiveFrom(in);
    auto o = std::dynamic_pointer_cast<CObservation3DRangeScan>(ar.ReadObject());
    ASSERT_TRUE(o);
    EXPECT_EQ(o->sensorLabel, "RGBD");
    EXPECT_FLOAT_EQ(o->rangeUnits, 1.0f / 5000);
    EXPECT_EQ(o->rangeImage(1, 1), 65535);
    EXPECT_EQ(o->rangeImage(0, 0), 0);
    EXPECT_EQ(o->rangeImage(3, 3), 5000);
    EXPECT_FALSE(o->intensityImage.isExternallyStored());
    EXPECT_TRUE(o->intensityImage.isColor());
    EXPECT_DOUBLE_EQ(o->cameraParamsIntensity.fx(), 520.908620);
    EXPECT_EQ(o->cameraParamsIntensity.ncols, 640u);
    EXPECT_TRUE(o->doDepthAndIntensityCamerasCoincide());
    EXPECT_NEAR(mrpt::Clock::toDouble(o->timestamp), 1.0, 1e-6);
  }
  auto rd = openRawlog(rl);
  ASSERT_EQ(rd->size(), 4u);
  EXPECT_FALSE(rd->registersDepth());
  EXPECT_NEAR(rd->timestamp(2), 1.1, 1e-6);
  EXPECT_NEAR(rd->camera()->left.fx, 520.908620, 1e-9);
  EXPECT_DOUBLE_EQ(rd->camera()->depth_factor, 5000);
  EXPECT_FLOAT_EQ(rd->read(0).depth.at<float>(2, 2), 1.0f);

  const std::string out = dir + "/back";
  const auto r2 = convertRawlogToTum(rl, out);
  EXPECT_EQ(r2.frames, 4u);
  EXPECT_TRUE(r2.depth_exact);
  EXPECT_EQ(r2.depth_clipped, 0u);

  auto a = t.open();
  auto b = openDataset("dslam::TumDataset", "path: " + yq(out) + "\n");
  ASSERT_EQ(b->size(), 4u);
  auto* ta = dynamic_cast<TumDataset*>(a.get());
  auto* tb = dynamic_cast<TumDataset*>(b.get());
  EXPECT_EQ(tb->cameraSource(), out + "/camera.yaml");
  EXPECT_NEAR(b->camera()->left.fx, 520.908620, 1e-9);
  EXPECT_DOUBLE_EQ(b->camera()->depth_factor, 5000);
  for (size_t i = 0; i < 4; i++) {
    SCOPED_TRACE(i);
    EXPECT_NEAR(b->timestamp(i), a->timestamp(i), 1e-9);
    const cv::Mat d0 = cv::imread(ta->depthPath(i), cv::IMREAD_ANYDEPTH);
    const cv::Mat d1 = cv::imread(tb->depthPath(i), cv::IMREAD_ANYDEPTH);
    ASSERT_EQ(d1.type(), CV_16UC1);
    ASSERT_EQ(d1.size(), d0.size());
    EXPECT_EQ(cv::countNonZero(d0 != d1), 0);
    const cv::Mat c0 = cv::imread(ta->rgbPath(i), cv::IMREAD_UNCHANGED);
    const cv::Mat c1 = cv::imread(tb->rgbPath(i), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(c1.type(), CV_8UC3);
    EXPECT_EQ(cv::norm(c0, c1, cv::NORM_INF), 0.0);
  }
  // Large and zero values survive.
  const cv::Mat d = cv::imread(tb->depthPath(0), cv::IMREAD_ANYDEPTH);
  EXPECT_EQ(d.at<uint16_t>(1, 1), 65535);
  EXPECT_EQ(d.at<uint16_t>(0, 0), 0);
  EXPECT_NE(test::readFile(out + "/associations.txt").find("1.100000 rgb/1.100000.png 1.100000 depth/1.100000.png\n"),
            std::string::npos);

  // The output folder is not overwritten silently.
  EXPECT_THROW(convertRawlogToTum(rl, out), DataError);
  RawlogToTumOptions o;
  o.overwrite = true;
  o.depth_factor = 1000;  // requantise: raw/5 rounded
  const auto r3 = convertRawlogToTum(rl, out, o);
  EXPECT_FALSE(r3.depth_exact);
  const cv::Mat q = cv::imread(tb->depthPath(0), cv::IMREAD_ANYDEPTH);
  EXPECT_EQ(q.at<uint16_t>(2, 2), 1000);
  EXPECT_EQ(q.at<uint16_t>(1, 1), 13107);  // 65535 / 5
  EXPECT_NE(test::readFile(out + "/camera.yaml").find("depth_factor: 1000"), std::string::npos);
}

TEST(RawlogConvert, CameraFileAndMissingDepth) {
  TinyTum t("plain", {640, 480});
  const std::string dir = tempDir("convert2");
  writeFile(dir + "/cam.yaml", "camera:\n  preset: tum_fr3\n  depth_factor: 1000\n");
  TumToRawlogOptions o;
  o.camera_file = dir + "/cam.yaml";
  o.sensor_label = "XTION";
  const auto r = convertTumToRawlog(t.dir, dir + "/x.rawlog", o);
  EXPECT_DOUBLE_EQ(r.depth_factor, 1000);
  auto rd = openRawlog(dir + "/x.rawlog");
  EXPECT_EQ(rd->sensorLabel(), "XTION");
  EXPECT_DOUBLE_EQ(rd->camera()->left.fx, 535.4);
  EXPECT_FLOAT_EQ(rd->read(0).depth.at<float>(2, 2), 5.0f);  // 5000 units at 1000/m

  o = {};
  o.preset = "nope";
  EXPECT_THROW(convertTumToRawlog(t.dir, dir + "/y.rawlog", o), ConfigError);
  // The 640x480 camera of tum_fr1 (cy 255.3) on 320x240 images.
  TinyTum half("half", {320, 240});
  o.preset = "tum_fr1";
  const std::string k = dataError([&] { convertTumToRawlog(half.dir, dir + "/k.rawlog", o); });
  EXPECT_NE(k.find("preset tum_fr1: its principal point (318.643, 255.314) lies outside the 320x240 images"),
            std::string::npos)
      << k;
  o = {};
  fs::remove(t.dir + "/depth.txt");
  const std::string e = dataError([&] { convertTumToRawlog(t.dir, dir + "/z.rawlog"); });
  EXPECT_NE(e.find("no depth"), std::string::npos) << e;
}

TEST(RawlogConvert, SharedRawlogToTum) {
  const std::string file = shared("data/mrpt/tests_rgbd.rawlog");
  if (file.empty()) GTEST_SKIP();
  const std::string out = tempDir("convert_real") + "/openni";
  const auto r = convertRawlogToTum(file, out);
  EXPECT_EQ(r.frames, 1u);
  EXPECT_DOUBLE_EQ(r.depth_factor, 1000);
  EXPECT_FALSE(r.depth_exact);  // registered into the RGB camera, then quantised to mm
  auto src = openRawlog(file);
  auto tum = openDataset("dslam::TumDataset", "path: " + yq(out) + "\n");
  ASSERT_EQ(tum->size(), 1u);
  EXPECT_NEAR(tum->timestamp(0), src->timestamp(0), 1e-6);
  EXPECT_NEAR(tum->camera()->left.fx, 521.17923, 1e-4);
  const auto a = src->read(0), b = tum->read(0);
  EXPECT_EQ(cv::norm(a.image, b.image, cv::NORM_INF), 0.0);
  double maxerr = 0;
  cv::minMaxLoc(cv::abs(a.depth - b.depth), nullptr, &maxerr);
  EXPECT_LE(maxerr, 0.0005 + 1e-6);
}

TEST(RawlogConvert, RawlogEditReadsOurRawlog) {
  if (!fs::exists("/usr/bin/rawlog-edit")) GTEST_SKIP() << "rawlog-edit not installed";
  TinyTum t("rgbd_dataset_freiburg2_tiny", {640, 480});
  const std::string rl = tempDir("convert_re") + "/tiny.rawlog";
  convertTumToRawlog(t.dir, rl);
  const auto r = run("/usr/bin/rawlog-edit --info -i " + rl);
  EXPECT_EQ(r.exit_code, 0) << r.out;
  EXPECT_NE(r.out.find("Overall number of objects         : 4"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("Observations format               : Yes"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("RGBD /      4"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("Earliest timestamp                : 1.000000"), std::string::npos) << r.out;
}
