// TUM / Bonn reader: synthetic folders, association semantics, the real
// association lists in shared/data/tum-meta, bad inputs.
#include <cmath>
#include <fstream>

#include "dslam/plugins/datasets/tum.h"
#include "dslam/trajectory/io.h"
#include "ds_test_util.h"

namespace fs = std::filesystem;
using namespace dslam;
using namespace dslam::test;


TEST(TumDataset, AssociatesListsAndReadsFrames) {
  TinyTum t;
  auto ds = t.open();
  ASSERT_EQ(ds->size(), 4u);
  EXPECT_EQ(ds->sensor(), SensorType::RGBD);
  EXPECT_DOUBLE_EQ(ds->timestamp(0), 1.000);
  EXPECT_DOUBLE_EQ(ds->timestamp(1), 1.033);
  EXPECT_DOUBLE_EQ(ds->timestamp(2), 1.100);  // 1.066 dropped: no depth within 0.02 s
  EXPECT_DOUBLE_EQ(ds->timestamp(3), 1.133);
  auto* tum = dynamic_cast<TumDataset*>(ds.get());
  ASSERT_NE(tum, nullptr);
  EXPECT_DOUBLE_EQ(tum->depthTimestamp(2), 1.090);
  EXPECT_DOUBLE_EQ(tum->depthTimestamp(3), 1.150);
  EXPECT_EQ(fs::path(tum->depthPath(3)).filename().string(), "1.150000.png");

  const SensorFrame f = ds->read(2);
  EXPECT_EQ(f.index, 2);
  EXPECT_DOUBLE_EQ(f.timestamp, 1.100);
  EXPECT_EQ(f.image.type(), CV_8UC3);
  EXPECT_EQ(f.image.cols, 8);
  EXPECT_EQ(f.image.rows, 6);
  EXPECT_EQ(f.image.at<cv::Vec3b>(0, 0)[0], 30);  // third RGB image: B channel = 10*3
  ASSERT_EQ(f.depth.type(), CV_32F);
  EXPECT_FLOAT_EQ(f.depth.at<float>(0, 0), 0.0f);
  EXPECT_FLOAT_EQ(f.depth.at<float>(2, 2), 1.0f);
  EXPECT_FLOAT_EQ(f.depth.at<float>(1, 1), 65535.0f / 5000.0f);
  EXPECT_FLOAT_EQ(f.depth.at<float>(3, 3), 5002.0f / 5000.0f);  // depth image 2 (t=1.090)
}

TEST(TumDataset, CameraPresetFromFolderNameAndCameraYaml) {
  TinyTum t;
  auto ds = t.open();
  ASSERT_TRUE(ds->camera());
  EXPECT_DOUBLE_EQ(ds->camera()->left.fx, 520.908620);  // freiburg2 in the folder name
  EXPECT_DOUBLE_EQ(ds->camera()->depth_factor, 5000);

  TinyTum plain("plain_folder");
  EXPECT_DOUBLE_EQ(plain.open()->camera()->left.fx, 517.306408);  // default tum_fr1
  EXPECT_DOUBLE_EQ(plain.open("preset: tum_fr3\n")->camera()->left.fx, 535.4);
  EXPECT_DOUBLE_EQ(plain.open("", "dslam::BonnDataset")->camera()->left.fx, 542.822841);

  writeFile(plain.dir + "/camera.yaml",
            "camera:\n  sensor: rgbd\n  width: 8\n  height: 6\n  fx: 600\n  fy: 601\n  cx: 4\n  cy: 3\n"
            "  depth_factor: 1000\n");
  auto c = plain.open();
  EXPECT_DOUBLE_EQ(c->camera()->left.fx, 600);
  EXPECT_DOUBLE_EQ(c->camera()->depth_factor, 1000);
  EXPECT_FLOAT_EQ(c->read(0).depth.at<float>(2, 2), 5.0f);  // 5000 units / 1000
  EXPECT_DOUBLE_EQ(plain.open("preset: tum_fr3\n")->camera()->left.fx, 535.4);  // explicit preset wins
  EXPECT_FLOAT_EQ(plain.open("depth_factor: 5000\n")->read(0).depth.at<float>(2, 2), 1.0f);
}

TEST(TumDataset, GroundTruthAttachedWithin20ms) {
  TinyTum t;
  auto ds = t.open();
  ASSERT_EQ(ds->groundTruth().size(), 4u);
  auto f0 = ds->read(0), f1 = ds->read(1), f3 = ds->read(3);
  ASSERT_TRUE(f0.gt_T_wc);
  EXPECT_NEAR(f0.gt_T_wc->translation().x(), 0.0, 1e-12);
  ASSERT_TRUE(f1.gt_T_wc);  // 1.033 -> 1.034
  EXPECT_NEAR(f1.gt_T_wc->translation().x(), 0.1, 1e-12);
  EXPECT_FALSE(f3.gt_T_wc);  // 1.133: nearest pose 1.100 is 33 ms away
  EXPECT_TRUE(t.open("groundtruth: ''\n")->groundTruth().empty());
}

TEST(TumDataset, RgbOnlyIsMonocular) {
  TinyTum t;
  fs::remove(t.dir + "/depth.txt");
  auto ds = t.open();
  EXPECT_EQ(ds->size(), 5u);
  EXPECT_EQ(ds->sensor(), SensorType::Monocular);
  EXPECT_FALSE(ds->read(0).has_depth());
  TinyTum t2;
  EXPECT_EQ(t2.open("load_depth: false\n")->size(), 5u);
}

TEST(TumDataset, AssociationFileIsUsedWhenPresent) {
  TinyTum t;
  writeFile(t.dir + "/associations.txt",
            "1.000000 rgb/1.000000.png 1.005000 depth/1.005000.png\n"
            "1.066000 rgb/1.066000.png 1.090000 depth/1.090000.png\n");
  auto ds = t.open();
  ASSERT_EQ(ds->size(), 2u);
  EXPECT_DOUBLE_EQ(ds->timestamp(1), 1.066);
  EXPECT_FLOAT_EQ(ds->read(1).depth.at<float>(3, 3), 5002.0f / 5000.0f);
}

TEST(TumAssociation, GreedySmallestDifferenceFirst) {
  // Not nearest-neighbour per a: b0 is taken by a1 (5 ms) before a0 (10 ms)
  // can have it, and a1 is then used up for b1.
  auto m = associateStamps({0.000, 0.015}, {0.010, 0.024}, 0.02);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0], std::make_pair(size_t(1), size_t(0)));
  m = associateStamps({0.0, 0.010}, {0.008}, 0.02);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].first, 1u);
  EXPECT_TRUE(associateStamps({0.0}, {0.02}, 0.02).empty());  // strict |dt| < max_dt
  EXPECT_EQ(associateStamps({0.0}, {0.0199}, 0.02).size(), 1u);
  // Result sorted by the first list; one-to-one.
  m = associateStamps({1.0, 2.0, 3.0}, {2.001, 0.999, 3.015, 3.005}, 0.02);
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[0], std::make_pair(size_t(0), size_t(1)));
  EXPECT_EQ(m[1], std::make_pair(size_t(1), size_t(0)));
  EXPECT_EQ(m[2], std::make_pair(size_t(2), size_t(3)));
}

TEST(TumAssociation, RealAssociationListsParseAndReassociateIdentically) {
  const std::string dir = shared("data/tum-meta/associations");
  if (dir.empty()) GTEST_SKIP();
  const std::vector<std::pair<std::string, size_t>> expected = {
      {"fr1_desk.txt", 573},
      {"fr1_xyz.txt", 792},
      {"fr2_xyz.txt", 3615},
      {"fr3_sitting_halfsphere.txt", 1074},
      {"fr3_sitting_rpy.txt", 795},
      {"fr3_sitting_static.txt", 680},
      {"fr3_sitting_xyz.txt", 1219},
      {"fr3_walking_halfsphere.txt", 1021},
      {"fr3_walking_rpy.txt", 866},
      {"fr3_walking_static.txt", 717},
      {"fr3_walking_xyz.txt", 827},
      {"rgbd_bonn_balloon.txt", 438},
      {"rgbd_bonn_balloon_tracking.txt", 590},
      {"rgbd_bonn_kidnapping_box.txt", 1091},
      {"rgbd_bonn_kidnapping_box_2.txt", 1286},
      {"rgbd_bonn_placing_nonobstructing_box.txt", 720},
  };
  for (const auto& [name, n] : expected) {
    SCOPED_TRACE(name);
    const auto a = readTumAssociations(dir + "/" + name);
    ASSERT_EQ(a.size(), n);
    std::vector<double> ta, tb;
    for (const auto& e : a) {
      EXPECT_LT(std::abs(e.t_rgb - e.t_depth), 0.02);
      EXPECT_EQ(e.rgb.rfind("rgb/", 0), 0u);
      EXPECT_EQ(e.depth.rfind("depth/", 0), 0u);
      ta.push_back(e.t_rgb);
      tb.push_back(e.t_depth);
    }
    // associate.py on the full lists kept these pairs; greedy association of
    // the kept stamps alone must give back exactly the same pairs.
    const auto m = associateStamps(ta, tb, 0.02);
    ASSERT_EQ(m.size(), n);
    for (size_t k = 0; k < n; k++) ASSERT_EQ(m[k], std::make_pair(k, k)) << "pair " << k;
  }
  const auto w = readTumAssociations(dir + "/fr3_walking_xyz.txt");
  EXPECT_DOUBLE_EQ(w.front().t_rgb, 1341846313.592026);
  EXPECT_DOUBLE_EQ(w.back().t_rgb, 1341846342.416195);
  EXPECT_EQ(w.front().rgb, "rgb/1341846313.592026.png");
}

TEST(TumDataset, RealAssociationListDrivesTheReader) {
  const std::string list = shared("data/tum-meta/associations/rgbd_bonn_balloon.txt");
  if (list.empty()) GTEST_SKIP();
  const std::string dir = tempDir("tum_meta") + "/rgbd_bonn_balloon";
  mkdirs(dir);
  auto ds = openDataset("dslam::BonnDataset", "path: " + yq(dir) + "\nassociations: " + yq(list) + "\n");
  ASSERT_EQ(ds->size(), 438u);
  EXPECT_DOUBLE_EQ(ds->timestamp(0), 1548266469.886330);
  EXPECT_DOUBLE_EQ(ds->timestamp(437), 1548266484.531770);
  EXPECT_DOUBLE_EQ(ds->camera()->left.fx, 542.822841);
  // The images are not in shared/: reading names the frame and the file.
  const std::string e = dataError([&] { ds->read(0); });
  EXPECT_NE(e.find("frame 0"), std::string::npos) << e;
  EXPECT_NE(e.find(dir + "/rgb/1548266469.88633.png"), std::string::npos) << e;
  EXPECT_NE(e.find("missing"), std::string::npos) << e;
}

TEST(TumDataset, BadInputs) {
  // Missing folder.
  std::string e = dataError([] { openDataset("dslam::TumDataset", "path: /nonexistent/tum_folder\n"); });
  EXPECT_NE(e.find("/nonexistent/tum_folder"), std::string::npos) << e;
  EXPECT_NE(e.find("rgb.txt"), std::string::npos) << e;  // describes the layout

  // Missing rgb.txt.
  const std::string empty = tempDir("tum_empty");
  e = dataError([&] { openDataset("dslam::TumDataset", "path: " + yq(empty) + "\n"); });
  EXPECT_NE(e.find(empty + "/rgb.txt"), std::string::npos) << e;

  // Corrupt PNG (garbage bytes) -> DataError naming the frame and the path.
  {
    TinyTum t;
    auto ds = t.open();
    const std::string p = t.dir + "/rgb/1.100000.png";
    writeFile(p, "this is not a PNG file at all");
    e = dataError([&] { ds->read(2); });
    EXPECT_NE(e.find("frame 2"), std::string::npos) << e;
    EXPECT_NE(e.find(p), std::string::npos) << e;
    EXPECT_NE(e.find("corrupt"), std::string::npos) << e;
    EXPECT_NO_THROW(ds->read(1));
    // Missing depth image.
    fs::remove(t.dir + "/depth/1.150000.png");
    e = dataError([&] { ds->read(3); });
    EXPECT_NE(e.find("frame 3"), std::string::npos) << e;
    EXPECT_NE(e.find("depth/1.150000.png"), std::string::npos) << e;
    EXPECT_NE(e.find("missing"), std::string::npos) << e;
    // 8-bit depth image.
    writeImage(t.dir + "/depth/1.005000.png", cv::Mat(6, 8, CV_8UC1, cv::Scalar(3)));
    e = dataError([&] { ds->read(0); });
    EXPECT_NE(e.find("16-bit"), std::string::npos) << e;
    EXPECT_THROW(ds->read(4), DataError);  // out of range
  }
  // A first field that is not a number is garbage (associate.py fails on it too).
  {
    TinyTum t;
    expectOpenError(t.dir + "/rgb.txt", "1.0 rgb/1.000000.png\nabc rgb/1.100000.png\n", [&] { t.open(); },
                    {"rgb.txt:2", "timestamp path"});
    expectOpenError(t.dir + "/rgb.txt", "1.0 rgb/1.000000.png\nnan rgb/1.100000.png\n", [&] { t.open(); },
                    {"rgb.txt:2"});
  }
  // Association line with three fields / backwards association.
  {
    TinyTum t;
    expectOpenError(t.dir + "/associations.txt", "1.0 rgb/1.000000.png 1.005\n", [&] { t.open(); },
                    {"associations.txt:1"});
    expectOpenError(t.dir + "/associations.txt", "1.0 rgb/1.000000.png x.y depth/1.005000.png\n", [&] { t.open(); },
                    {"associations.txt:1"});
  }
  // No frame at all.
  {
    TinyTum t;
    expectOpenError(t.dir + "/rgb.txt", "# nothing\n", [&] { t.open(); }, {"no frames"});
  }
}

// Lists as the TUM tools read them (associate.py read_file_list: commas and
// tabs separate, a line with one field is skipped, a dict keyed by time: the
// last line of a repeated time wins, sorted by time), with one warning.
TEST(TumDataset, ListsAreReadAsTheTumToolsReadThem) {
  TinyTum t;
  writeFile(t.dir + "/rgb.txt",
            "# color images\r\n"
            "1.066 rgb/1.066000.png\r\n"             // out of order
            "\t1.0,rgb/1.000000.png extra columns\n"  // comma, tab, extra fields
            "   # an indented comment\n"
            "1.033e0 rgb/1.100000.png\n"             // scientific notation; repeated below
            "1.040\n"                                // a bare timestamp: skipped
            "1.033 rgb/1.033000.png   \n"            // the last line of 1.033 wins; trailing blanks
            "1.1 rgb/1.100000.png\n");
  testing::internal::CaptureStderr();
  const auto rgb = readTumList(t.dir + "/rgb.txt");
  const std::string log = testing::internal::GetCapturedStderr();
  ASSERT_EQ(rgb.size(), 4u);
  EXPECT_DOUBLE_EQ(rgb[0].stamp, 1.0);
  EXPECT_EQ(rgb[0].path, "rgb/1.000000.png");
  EXPECT_DOUBLE_EQ(rgb[1].stamp, 1.033);
  EXPECT_EQ(rgb[1].path, "rgb/1.033000.png");
  EXPECT_DOUBLE_EQ(rgb[2].stamp, 1.066);
  EXPECT_DOUBLE_EQ(rgb[3].stamp, 1.1);
  EXPECT_NE(log.find(t.dir + "/rgb.txt: 1 repeated timestamp(s)"), std::string::npos) << log;
  EXPECT_NE(log.find("1 line(s) without a file name skipped"), std::string::npos) << log;
  // Out of order: every line after 1.066 that is earlier than it (1.0, 1.033, 1.033).
  EXPECT_NE(log.find("3 out-of-order line(s)"), std::string::npos) << log;

  // A clean list: no warning at all.
  testing::internal::CaptureStderr();
  EXPECT_EQ(readTumList(t.dir + "/depth.txt").size(), 5u);
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
  // A UTF-8 byte-order mark before the first line (said "got '\xEF\xBB\xBF1.0 ...'").
  writeFile(t.dir + "/bom.txt", "\xEF\xBB\xBF" "1.0 rgb/1.000000.png\n1.1 rgb/1.100000.png\n");
  EXPECT_EQ(readTumList(t.dir + "/bom.txt").size(), 2u);

  // The dataset opens with these lists and reads frames in time order.
  writeFile(t.dir + "/associations.txt",
            "1.1 rgb/1.100000.png 1.09 depth/1.090000.png\n"
            "1.0 rgb/1.000000.png 1.005 depth/1.005000.png\n"
            "1.0 rgb/1.033000.png 1.040 depth/1.040000.png\n");
  testing::internal::CaptureStderr();
  auto ds = t.open();
  const std::string log2 = testing::internal::GetCapturedStderr();
  ASSERT_EQ(ds->size(), 2u);
  EXPECT_DOUBLE_EQ(ds->timestamp(0), 1.0);
  EXPECT_DOUBLE_EQ(dynamic_cast<TumDataset&>(*ds).depthTimestamp(0), 1.040);  // the last line of t = 1.0
  EXPECT_DOUBLE_EQ(ds->timestamp(1), 1.1);
  EXPECT_NO_THROW(ds->read(0));
  EXPECT_NE(log2.find("associations.txt: 1 repeated timestamp(s)"), std::string::npos) << log2;
}
