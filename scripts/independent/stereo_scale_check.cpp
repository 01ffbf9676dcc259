// Independent stereo odometry on the KITTI clip (OpenCV only, no dslam code):
// the scale of the stereo reconstruction against the clip's poses.txt
// (docs/results.md, "KITTI").
//
// For each pair of consecutive frames: SGBM disparity of frame i, 3D points
// at GFTT corners (depth = bf / disparity, bf from calib.txt's P1), LK flow to
// frame i+1, solvePnPRansac. Prints the step lengths against the ground truth
// and writes the chained trajectory (TUM, t = i / 10) for an ATE check.
//
//   g++ -O2 -std=c++17 scripts/independent/stereo_scale_check.cpp -o /tmp/ssc $(pkg-config --cflags --libs opencv4)
//   /tmp/ssc ../shared/data/kitti-stereo-51 /tmp/ssc_traj.txt
//   scripts/independent/umeyama_ate.py ../shared/data/kitti-stereo-51/poses.txt /tmp/ssc_traj.txt
#include <opencv2/opencv.hpp>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: stereo_scale_check KITTI_FOLDER OUT_TRAJECTORY\n");
    return 2;
  }
  const std::string d = argv[1];
  // calib.txt: P0 and P1 (3x4, row-major), optionally prefixed "P0:".
  std::vector<std::vector<double>> P;
  {
    std::ifstream f(d + "/calib.txt");
    std::string line;
    while (std::getline(f, line) && P.size() < 2) {
      std::istringstream s(line);
      std::vector<double> v;
      std::string tok;
      while (s >> tok)
        if (tok.back() != ':') v.push_back(std::stod(tok));
      if (v.size() == 12) P.push_back(v);
    }
  }
  if (P.size() < 2) {
    std::fprintf(stderr, "cannot read P0/P1 from %s/calib.txt\n", d.c_str());
    return 1;
  }
  const double fx = P[0][0], cx = P[0][2], cy = P[0][6], bf = -P[1][3];
  const cv::Mat K = (cv::Mat_<double>(3, 3) << fx, 0, cx, 0, fx, cy, 0, 0, 1);
  std::vector<cv::Vec3d> gt;
  {
    std::ifstream f(d + "/poses.txt");
    double v[12];
    while (f >> v[0]) {
      for (int k = 1; k < 12; k++) f >> v[k];
      gt.push_back({v[3], v[7], v[11]});
    }
  }
  auto img = [&](const char* side, size_t i) {
    char b[64];
    std::snprintf(b, sizeof b, "/%s/%06zu.png", side, i);
    return cv::imread(d + b, cv::IMREAD_GRAYSCALE);
  };
  auto sgbm = cv::StereoSGBM::create(0, 128, 5, 8 * 25, 32 * 25, 1, 63, 10, 100, 32, cv::StereoSGBM::MODE_SGBM_3WAY);
  std::ofstream out(argv[2]);
  out << "0 0 0 0 0 0 0 1\n";
  cv::Mat Twc = cv::Mat::eye(4, 4, CV_64F);
  double est_len = 0, gt_len = 0;
  std::vector<double> ratios;
  for (size_t i = 0; i + 1 < gt.size(); i++) {
    const cv::Mat L = img("image_l", i), R = img("image_r", i), L2 = img("image_l", i + 1);
    cv::Mat disp16;
    sgbm->compute(L, R, disp16);
    std::vector<cv::Point2f> c, c2;
    cv::goodFeaturesToTrack(L, c, 3000, 0.01, 7);
    std::vector<uchar> st;
    std::vector<float> err;
    cv::calcOpticalFlowPyrLK(L, L2, c, c2, st, err, cv::Size(21, 21), 4);
    std::vector<cv::Point3f> X;
    std::vector<cv::Point2f> x2;
    for (size_t k = 0; k < c.size(); k++) {
      if (!st[k]) continue;
      const double disp = disp16.at<short>(cvRound(c[k].y), cvRound(c[k].x)) / 16.0;
      if (disp < 1.0) continue;
      const double z = bf / disp;
      if (z > 60) continue;
      X.push_back(cv::Point3f((c[k].x - cx) * z / fx, (c[k].y - cy) * z / fx, z));
      x2.push_back(c2[k]);
    }
    cv::Mat rvec, tvec, Rm;
    std::vector<int> inliers;
    cv::solvePnPRansac(X, x2, K, cv::Mat(), rvec, tvec, false, 300, 1.0, 0.999, inliers);
    cv::Rodrigues(rvec, Rm);
    cv::Mat T = cv::Mat::eye(4, 4, CV_64F);  // frame i -> frame i+1
    Rm.copyTo(T(cv::Rect(0, 0, 3, 3)));
    tvec.copyTo(T(cv::Rect(3, 0, 1, 3)));
    Twc = Twc * T.inv();
    out << (i + 1) * 0.1 << " " << Twc.at<double>(0, 3) << " " << Twc.at<double>(1, 3) << " " << Twc.at<double>(2, 3)
        << " 0 0 0 1\n";
    const double t = cv::norm(tvec), g = cv::norm(gt[i + 1] - gt[i]);
    est_len += t;
    gt_len += g;
    ratios.push_back(t / g);
    std::printf("step %2zu: stereo+PnP %.3f m, ground truth %.3f m, ratio %.3f (%zu inliers of %zu)\n", i, t, g, t / g,
                inliers.size(), X.size());
  }
  std::sort(ratios.begin(), ratios.end());
  std::printf("path: stereo+PnP %.2f m, ground truth %.2f m (ratio %.4f); median step ratio %.4f over %zu steps\n",
              est_len, gt_len, est_len / gt_len, ratios[ratios.size() / 2], ratios.size());
  return 0;
}
