// Trajectory file I/O: bad inputs give DataError naming file:line; write/read
// round trips for TUM, KITTI (13 columns, 12 + times file, 12 + rate) and EuRoC.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "dslam/core/error.h"
#include "dslam/trajectory/io.h"
#include "test_support.h"

using namespace dslam;
using dslam::test::tempDir;
using dslam::test::writeFile;
using dslam::test::writeKittiTimes;

namespace {


traj::ReadOptions fmt(traj::Format f) {
  traj::ReadOptions o;
  o.format = f;
  return o;
}

const char* kTumOk =
    "# timestamp tx ty tz qx qy qz qw\n"
    "1.0 0 0 0 0 0 0 1\n"
    "1.1 0.1 0 0 0 0 0 1\n";

Trajectory randomTrajectory(size_t n, double t0, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  Trajectory t;
  for (size_t i = 0; i < n; i++) {
    const Eigen::Quaterniond q = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized();
    t.push_back(t0 + 0.05 * static_cast<double>(i) + 0.001 * u(rng), SE3(q, {5 * u(rng), 5 * u(rng), 5 * u(rng)}));
  }
  return t;
}

void expectSame(const Trajectory& a, const Trajectory& b, double stamp_tol, double pos_tol, double ang_tol) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); i++) {
    EXPECT_NEAR(a.stamps[i], b.stamps[i], stamp_tol) << "pose " << i;
    EXPECT_LT((a.poses[i].translation() - b.poses[i].translation()).norm(), pos_tol) << "pose " << i;
    EXPECT_LT(a.poses[i].quaternion().angularDistance(b.poses[i].quaternion()), ang_tol) << "pose " << i;
  }
}

}  // namespace

TEST(TrajectoryIo, ReadsTumWithComments) {
  const std::string f = tempDir("trajio") + "/ok.txt";
  writeFile(f, std::string(kTumOk) + "\n   \n# trailing comment\r\n1.2 0.2 0 0 0 0 0.7071067811865476 0.7071067811865476\r\n");
  const Trajectory t = traj::read(f);
  ASSERT_EQ(t.size(), 3u);
  EXPECT_DOUBLE_EQ(t.stamps[1], 1.1);
  EXPECT_DOUBLE_EQ(t.poses[1].translation().x(), 0.1);
  EXPECT_NEAR(t.poses[2].angle(), M_PI / 2, 1e-12);
  EXPECT_EQ(traj::detectFormat(f), traj::Format::Tum);
  writeFile(f, "\xEF\xBB\xBF" + std::string(kTumOk));  // a UTF-8 byte-order mark
  EXPECT_EQ(traj::read(f).size(), 2u);
}

TEST(TrajectoryIo, NanIsRejectedWithFileAndLine) {
  const std::string f = tempDir("trajio") + "/nan.txt";
  writeFile(f, std::string(kTumOk) + "1.2 0.2 nan 0 0 0 0 1\n");
  const std::string m = test::dataError([&] { traj::read(f); });
  EXPECT_NE(m.find(f + ":4:"), std::string::npos) << m;
  EXPECT_NE(m.find("field 3 is not finite"), std::string::npos) << m;
}

TEST(TrajectoryIo, InfIsRejected) {
  const std::string f = tempDir("trajio") + "/inf.txt";
  writeFile(f, std::string(kTumOk) + "1.2 0.2 0 inf 0 0 0 1\n");
  const std::string m = test::dataError([&] { traj::readTum(f); });
  EXPECT_NE(m.find(f + ":4: field 4 is not finite"), std::string::npos) << m;
}

TEST(TrajectoryIo, ShortLineIsRejectedWithFileAndLine) {
  const std::string f = tempDir("trajio") + "/short.txt";
  writeFile(f, std::string(kTumOk) + "1.2 0.2 0 0 0 0 1\n");
  const std::string m = test::dataError([&] { traj::read(f, fmt(traj::Format::Tum)); });
  EXPECT_NE(m.find(f + ":4: expected 8 values"), std::string::npos) << m;
  EXPECT_NE(m.find("got 7"), std::string::npos) << m;
}

TEST(TrajectoryIo, NonNumericFieldIsRejected) {
  const std::string f = tempDir("trajio") + "/text.txt";
  writeFile(f, std::string(kTumOk) + "1.2 0.2 0 0 zero 0 0 1\n");
  const std::string m = test::dataError([&] { traj::read(f); });
  EXPECT_NE(m.find(f + ":4: field 5 is not a number: 'zero'"), std::string::npos) << m;
  // A number with trailing garbage is not a number either.
  writeFile(f, std::string(kTumOk) + "1.2 0.2m 0 0 0 0 0 1\n");
  const std::string m2 = test::dataError([&] { traj::read(f); });
  EXPECT_NE(m2.find(f + ":4: field 2 is not a number: '0.2m'"), std::string::npos) << m2;
}

TEST(TrajectoryIo, RepeatedTimestampsKeepTheLastPoseAsTheTumToolsDo) {
  // evaluate_ate.py reads a file into a dict keyed by time: the last line wins.
  const std::string f = tempDir("trajio") + "/rep.txt";
  writeFile(f, std::string(kTumOk) + "1.1 0.7 0 0 0 0 0 1\n1.2 0.3 0 0 0 0 0 1\n");
  testing::internal::CaptureStderr();
  const Trajectory t = traj::read(f);
  const std::string log = testing::internal::GetCapturedStderr();
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t.stamps, (std::vector<double>{1.0, 1.1, 1.2}));
  EXPECT_DOUBLE_EQ(t.poses[1].translation().x(), 0.7);  // the later of the two 1.1 lines
  EXPECT_NE(log.find(f + ": 1 repeated timestamp(s)"), std::string::npos) << log;
  EXPECT_EQ(std::count(log.begin(), log.end(), '\n'), 1) << "one warning per file: " << log;
}

TEST(TrajectoryIo, OutOfOrderLinesAreSortedByTime) {
  const std::string f = tempDir("trajio") + "/back.txt";
  writeFile(f, std::string(kTumOk) + "1.05 0.2 0 0 0 0 0 1\n0.5 0.9 0 0 0 0 0 1\n");
  const Trajectory t = traj::read(f);
  EXPECT_EQ(t.stamps, (std::vector<double>{0.5, 1.0, 1.05, 1.1}));
  EXPECT_DOUBLE_EQ(t.poses[0].translation().x(), 0.9);
  EXPECT_DOUBLE_EQ(t.poses[2].translation().x(), 0.2);
  Trajectory copy = t;
  const auto fix = traj::normalizeTimestamps(copy);
  EXPECT_EQ(fix.repeated + fix.reordered, 0u);  // already normal: unchanged

  // File order, as it is, when asked for.
  traj::ReadOptions ro;
  ro.normalize_timestamps = false;
  const Trajectory raw = traj::read(f, ro);
  EXPECT_EQ(raw.stamps, (std::vector<double>{1.0, 1.1, 1.05, 0.5}));
  Trajectory n = raw;
  const auto fix2 = traj::normalizeTimestamps(n);
  EXPECT_EQ(fix2.reordered, 2u);
  EXPECT_EQ(fix2.repeated, 0u);
}

TEST(TrajectoryIo, FileQuirksOfRealBenchmarksAreRead) {
  // CRLF, trailing blanks, tabs, comments at the end of a line and between
  // lines, scientific notation, extra columns: all as TUM's tools read them.
  const std::string f = tempDir("trajio") + "/quirks.txt";
  writeFile(f,
            "# ground truth\r\n"
            "1.0\t0 0 0 0 0 0 1   \r\n"
            "  # a comment between lines\r\n"
            "1.1e0 1.5e-1 0 0 0 0 0 1 # inline comment\r\n"
            "1.2 0.2 0 0 0 0 0 1 0.99 extra\r\n"
            "\r\n");
  EXPECT_EQ(traj::detectFormat(f), traj::Format::Tum);
  const Trajectory t = traj::read(f);
  ASSERT_EQ(t.size(), 3u);
  EXPECT_DOUBLE_EQ(t.stamps[1], 1.1);
  EXPECT_DOUBLE_EQ(t.poses[1].translation().x(), 0.15);
  EXPECT_DOUBLE_EQ(t.poses[2].translation().x(), 0.2);
}

TEST(TrajectoryIo, GenuineTumGroundTruthFilesAreRead) {
  // fr2_xyz and fr2_desk repeat timestamps (e.g. fr2_xyz line 4622).
  for (const char* name : {"fr1_xyz", "fr1_desk", "fr2_xyz", "fr2_desk"}) {
    const std::string f = test::shared(std::string("data/tum-meta/groundtruth/") + name + ".txt");
    traj::ReadOptions ro;
    ro.normalize_timestamps = false;
    Trajectory raw = traj::read(f, ro);
    const size_t n_raw = raw.size();
    const auto fix = traj::normalizeTimestamps(raw);
    const Trajectory t = traj::read(f);
    EXPECT_EQ(t.size(), n_raw - fix.repeated) << name;
    for (size_t i = 1; i < t.size(); i++) ASSERT_GT(t.stamps[i], t.stamps[i - 1]) << name << " pose " << i;
    if (std::string(name) == "fr2_xyz") {
      EXPECT_GE(fix.repeated, 1u);
    }
  }
}

TEST(TrajectoryIo, EmptyAndCommentOnlyFilesAreRejected) {
  const std::string d = tempDir("trajio");
  writeFile(d + "/empty.txt", "");
  std::string m = test::dataError([&] { traj::read(d + "/empty.txt"); });
  EXPECT_NE(m.find(d + "/empty.txt"), std::string::npos) << m;
  EXPECT_NE(m.find("no data lines"), std::string::npos) << m;

  writeFile(d + "/comments.txt", "# timestamp tx ty tz qx qy qz qw\n\n# nothing\n");
  m = test::dataError([&] { traj::read(d + "/comments.txt", fmt(traj::Format::Tum)); });
  EXPECT_NE(m.find("no poses: " + d + "/comments.txt"), std::string::npos) << m;

  m = test::dataError([&] { traj::read(d + "/missing.txt"); });
  EXPECT_NE(m.find("not found: " + d + "/missing.txt"), std::string::npos) << m;
}

TEST(TrajectoryIo, ZeroQuaternionIsRejected) {
  const std::string f = tempDir("trajio") + "/zq.txt";
  writeFile(f, std::string(kTumOk) + "1.2 0 0 0 0 0 0 0\n");
  EXPECT_NE(test::dataError([&] { traj::read(f); }).find(f + ":4: zero quaternion"), std::string::npos);
}

TEST(TrajectoryIo, UnknownColumnCountIsRejected) {
  const std::string f = tempDir("trajio") + "/five.txt";
  writeFile(f, "# c\n1 2 3 4 5\n");
  const std::string m = test::dataError([&] { traj::read(f); });
  EXPECT_NE(m.find(f + ":2: cannot tell the trajectory format from 5 columns"), std::string::npos) << m;
}

TEST(TrajectoryIo, DetectsFormats) {
  const std::string d = tempDir("trajio");
  writeFile(d + "/a.txt", kTumOk);
  writeFile(d + "/k12.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n");
  writeFile(d + "/k13.txt", "0.5 1 0 0 0 0 1 0 0 0 0 1 0\n");
  writeFile(d + "/e.csv", "#timestamp [ns],x,y,z,qw,qx,qy,qz\n1000000000,0,0,0,1,0,0,0\n");
  EXPECT_EQ(traj::detectFormat(d + "/a.txt"), traj::Format::Tum);
  EXPECT_EQ(traj::detectFormat(d + "/k12.txt"), traj::Format::Kitti);
  EXPECT_EQ(traj::detectFormat(d + "/k13.txt"), traj::Format::Kitti);
  EXPECT_EQ(traj::detectFormat(d + "/e.csv"), traj::Format::Euroc);
  EXPECT_EQ(traj::formatFromString("euroc"), traj::Format::Euroc);
  EXPECT_THROW(traj::formatFromString("bag"), ConfigError);

  const Trajectory k13 = traj::read(d + "/k13.txt");
  ASSERT_EQ(k13.size(), 1u);
  EXPECT_DOUBLE_EQ(k13.stamps[0], 0.5);
  const Trajectory e = traj::read(d + "/e.csv");
  ASSERT_EQ(e.size(), 1u);
  EXPECT_DOUBLE_EQ(e.stamps[0], 1.0);
}

TEST(TrajectoryIo, KittiBadInputs) {
  const std::string d = tempDir("trajio");
  writeFile(d + "/k.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1 0 1 0 0 0 0 1\n");
  std::string m = test::dataError([&] { traj::read(d + "/k.txt", fmt(traj::Format::Kitti)); });
  EXPECT_NE(m.find(d + "/k.txt:2: expected 12 values"), std::string::npos) << m;

  writeFile(d + "/k.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1 0 1 0 nan 0 0 1 0\n");
  m = test::dataError([&] { traj::read(d + "/k.txt"); });
  EXPECT_NE(m.find(d + "/k.txt:2: field 8 is not finite"), std::string::npos) << m;

  // Reflection (det < 0).
  writeFile(d + "/k.txt", "-1 0 0 0 0 1 0 0 0 0 1 0\n");
  m = test::dataError([&] { traj::read(d + "/k.txt"); });
  EXPECT_NE(m.find(d + "/k.txt:1: rotation has determinant < 0"), std::string::npos) << m;

  // Not a rotation: all zeros (scored rotational RPE as if it were one), scaled by 2.
  for (const char* rot : {"0 0 0 0 0 0 0 0 0 0 0 0\n", "2 0 0 0 0 2 0 0 0 0 2 0\n"}) {
    writeFile(d + "/k.txt", std::string("1 0 0 0 0 1 0 0 0 0 1 0\n") + rot);
    m = test::dataError([&] { traj::read(d + "/k.txt"); });
    EXPECT_NE(m.find(d + "/k.txt:2: the 3x3 block is not a rotation"), std::string::npos) << m;
  }

  // Times file shorter / longer than the poses file, non-numeric, empty.
  writeFile(d + "/k.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1 0 1 0 0 0 0 1 0\n");
  writeFile(d + "/t1.txt", "0.0\n");
  m = test::dataError([&] { traj::readKitti(d + "/k.txt", d + "/t1.txt"); });
  EXPECT_NE(m.find(d + "/t1.txt: has 1 times but " + d + "/k.txt has more poses"), std::string::npos) << m;
  writeFile(d + "/t3.txt", "0.0\n0.1\n0.2\n");
  m = test::dataError([&] { traj::readKitti(d + "/k.txt", d + "/t3.txt"); });
  EXPECT_NE(m.find(d + "/t3.txt: has 3 times but " + d + "/k.txt has 2 poses"), std::string::npos) << m;
  writeFile(d + "/tx.txt", "0.0\nabc\n");
  m = test::dataError([&] { traj::readKitti(d + "/k.txt", d + "/tx.txt"); });
  EXPECT_NE(m.find(d + "/tx.txt:2: field 1 is not a number: 'abc'"), std::string::npos) << m;
  writeFile(d + "/t0.txt", "# no times\n");
  m = test::dataError([&] { traj::readKitti(d + "/k.txt", d + "/t0.txt"); });
  EXPECT_NE(m.find("times file has no times: " + d + "/t0.txt"), std::string::npos) << m;
  writeFile(d + "/tb.txt", "0.2\n0.1\n");  // backwards times: sorted, as for TUM files
  const Trajectory kb = traj::readKitti(d + "/k.txt", d + "/tb.txt");
  EXPECT_EQ(kb.stamps, (std::vector<double>{0.1, 0.2}));
}

TEST(TrajectoryIo, EurocBadInputs) {
  const std::string d = tempDir("trajio");
  writeFile(d + "/e.csv", "#timestamp [ns],x,y,z,qw,qx,qy,qz\n1000000000,0,0,0,1,0,0,0\n2000000000,0,0,0,1,0,0\n");
  std::string m = test::dataError([&] { traj::read(d + "/e.csv"); });
  EXPECT_NE(m.find(d + "/e.csv:3: expected 8 values"), std::string::npos) << m;
  writeFile(d + "/e.csv", "#timestamp [ns],x,y,z,qw,qx,qy,qz\n2000000000,0,0,0,1,0,0,0\n1000000000,1,0,0,1,0,0,0\n");
  const Trajectory e = traj::read(d + "/e.csv");  // sorted by time
  EXPECT_EQ(e.stamps, (std::vector<double>{1.0, 2.0}));
  EXPECT_DOUBLE_EQ(e.poses[0].translation().x(), 1.0);
}

TEST(TrajectoryIo, RoundTripTum) {
  const std::string d = tempDir("trajio");
  const Trajectory t = randomTrajectory(50, 1305031102.0, 1);
  traj::write(d + "/t.txt", t, {traj::Format::Tum, false, "made by a test\nsecond line"});
  const std::string text = dslam::test::readFile(d + "/t.txt");
  EXPECT_EQ(text.rfind("# made by a test\n# second line\n", 0), 0u) << text.substr(0, 80);
  expectSame(traj::read(d + "/t.txt"), t, 1e-6, 1e-8, 1e-8);
  // Small stamps keep all 9 decimals.
  const Trajectory s = randomTrajectory(50, 0.0, 2);
  traj::writeTum(d + "/s.txt", s);
  expectSame(traj::readTum(d + "/s.txt"), s, 1e-9, 1e-8, 1e-8);
}

TEST(TrajectoryIo, RoundTripKitti) {
  const std::string d = tempDir("trajio");
  const Trajectory t = randomTrajectory(50, 100.0, 3);

  traj::WriteOptions wo;
  wo.format = traj::Format::Kitti;
  wo.kitti_with_times = true;
  traj::write(d + "/k13.txt", t, wo);
  EXPECT_EQ(traj::detectFormat(d + "/k13.txt"), traj::Format::Kitti);
  expectSame(traj::read(d + "/k13.txt"), t, 1e-9, 1e-10, 1e-10);

  wo.kitti_with_times = false;
  traj::write(d + "/k12.txt", t, wo);
  writeKittiTimes(d + "/times.txt", t.stamps, 9);
  traj::ReadOptions ro;
  ro.kitti_times = d + "/times.txt";
  expectSame(traj::read(d + "/k12.txt", ro), t, 1e-9, 1e-10, 1e-10);

  // No times: t = i / rate.
  ro.kitti_times.clear();
  ro.kitti_rate = 20;
  const Trajectory r = traj::read(d + "/k12.txt", ro);
  ASSERT_EQ(r.size(), t.size());
  EXPECT_DOUBLE_EQ(r.stamps[0], 0.0);
  EXPECT_DOUBLE_EQ(r.stamps[7], 7 / 20.0);
  EXPECT_LT((r.poses[7].translation() - t.poses[7].translation()).norm(), 1e-10);
}

TEST(TrajectoryIo, RoundTripEuroc) {
  const std::string d = tempDir("trajio");
  const Trajectory t = randomTrajectory(50, 1403636579.0, 4);
  traj::write(d + "/e.csv", t, {traj::Format::Euroc, false, ""});
  const std::string text = dslam::test::readFile(d + "/e.csv");
  EXPECT_EQ(text.rfind("#timestamp [ns]", 0), 0u);
  // Nanosecond stamps of ~1.4e9 s are exact to ~0.25 us in a double.
  expectSame(traj::read(d + "/e.csv"), t, 1e-6, 1e-8, 1e-8);
  const Trajectory s = randomTrajectory(50, 0.0, 5);
  traj::write(d + "/s.csv", s, {traj::Format::Euroc, false, ""});
  expectSame(traj::read(d + "/s.csv", fmt(traj::Format::Euroc)), s, 1e-9, 1e-8, 1e-8);
}
