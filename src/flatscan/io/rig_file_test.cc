#include "flatscan/io/rig_file.h"

#include <unistd.h>

#include <cmath>
#include <fstream>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include <Eigen/Geometry>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>

#include "flatscan/io/atomic_output.h"
#include "flatscan/util/error.h"

namespace flatscan {
namespace {
namespace fs = std::filesystem;

// A rig like the reference one (docs/design.md section 4): convergent, baseline 60 mm; camera 1
// with the rational model, camera 2 with five coefficients.
StereoRig ReferenceRig() {
  StereoRig rig;
  rig.left.width = rig.right.width = 2592;
  rig.left.height = rig.right.height = 1944;
  rig.left.fx = 11364.25;
  rig.left.fy = 11366.5;
  rig.left.cx = 1301.7;
  rig.left.cy = 967.3;
  rig.left.dist = {-0.081, 0.41, 0.0007, -0.0003, -1.2, 0.02, 0.15, -0.9};
  rig.right.fx = 11359.1;
  rig.right.fy = 11360.9;
  rig.right.cx = 1288.4;
  rig.right.cy = 979.6;
  rig.right.dist = {-0.093, 0.52, -0.0004, 0.0002, -2.1, 0, 0, 0};
  const Eigen::Matrix3d rotation =
      (Eigen::AngleAxisd(-0.30, Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(0.004, Eigen::Vector3d::UnitX()) *
       Eigen::AngleAxisd(-0.002, Eigen::Vector3d::UnitZ()))
          .toRotationMatrix();
  rig.cam2_from_cam1.rotation = rotation;
  // Camera 2 centre 60 mm to the right of camera 1: C2 = -R^T T.
  rig.cam2_from_cam1.translation = -rotation * Eigen::Vector3d(60.0, 0.3, -0.5);
  return rig;
}

void ExpectMatNear(const cv::Mat& actual, const cv::Mat& expected, double tolerance,
                   const std::string& what) {
  ASSERT_EQ(actual.rows, expected.rows) << what;
  ASSERT_EQ(actual.cols, expected.cols) << what;
  cv::Mat a, e;
  actual.convertTo(a, CV_64F);
  expected.convertTo(e, CV_64F);
  EXPECT_LE(cv::norm(a, e, cv::NORM_INF), tolerance) << what << "\n" << a << "\n" << e;
}

void ExpectCameraNear(const Camera& actual, const Camera& expected, const std::string& what) {
  EXPECT_EQ(actual.width, expected.width) << what;
  EXPECT_EQ(actual.height, expected.height) << what;
  EXPECT_NEAR(actual.fx, expected.fx, 1e-12) << what;
  EXPECT_NEAR(actual.fy, expected.fy, 1e-12) << what;
  EXPECT_NEAR(actual.cx, expected.cx, 1e-12) << what;
  EXPECT_NEAR(actual.cy, expected.cy, 1e-12) << what;
  for (int i = 0; i < 8; ++i) EXPECT_NEAR(actual.dist[i], expected.dist[i], 1e-12) << what << i;
}

void ExpectRigNear(const StereoRig& actual, const StereoRig& expected) {
  ExpectCameraNear(actual.left, expected.left, "left");
  ExpectCameraNear(actual.right, expected.right, "right");
  EXPECT_LE((actual.cam2_from_cam1.rotation - expected.cam2_from_cam1.rotation).cwiseAbs().maxCoeff(),
            1e-12);
  EXPECT_LE(
      (actual.cam2_from_cam1.translation - expected.cam2_from_cam1.translation).cwiseAbs().maxCoeff(),
      1e-12);
  ASSERT_FALSE(actual.rectification.empty());
  ASSERT_FALSE(expected.rectification.empty());
  ExpectMatNear(actual.rectification.R1, expected.rectification.R1, 1e-12, "R1");
  ExpectMatNear(actual.rectification.R2, expected.rectification.R2, 1e-12, "R2");
  ExpectMatNear(actual.rectification.P1, expected.rectification.P1, 1e-12, "P1");
  ExpectMatNear(actual.rectification.P2, expected.rectification.P2, 1e-12, "P2");
  ExpectMatNear(actual.rectification.Q, expected.rectification.Q, 1e-12, "Q");
}

cv::Mat ToCv(const Eigen::MatrixXd& m) {
  cv::Mat out;
  cv::eigen2cv(m, out);
  return out;
}

// A FileStorage file written key by key with plain OpenCV, so that tests can drop or
// corrupt single keys.
class RawFile {
 public:
  using Value = std::variant<int, double, std::string, cv::Mat>;

  RawFile& Set(const std::string& key, Value value) {
    for (auto& [k, v] : entries_) {
      if (k == key) {
        v = std::move(value);
        return *this;
      }
    }
    entries_.emplace_back(key, std::move(value));
    return *this;
  }
  RawFile& Remove(const std::string& key) {
    std::erase_if(entries_, [&](const auto& e) { return e.first == key; });
    return *this;
  }
  void Write(const fs::path& path) const {
    cv::FileStorage out(path.string(), cv::FileStorage::WRITE);
    ASSERT_TRUE(out.isOpened()) << path;
    for (const auto& [key, value] : entries_) {
      out << key;
      std::visit([&](const auto& v) { out << v; }, value);
    }
  }

 private:
  std::vector<std::pair<std::string, Value>> entries_;
};

// The keys of a rig file as docs/conventions.md lists them.
RawFile RigKeys(const StereoRig& rig, bool with_rectification) {
  RawFile f;
  f.Set("image_width", rig.left.width).Set("image_height", rig.left.height);
  f.Set("M1", rig.left.CameraMatrix()).Set("D1", rig.left.DistortionVector());
  f.Set("M2", rig.right.CameraMatrix()).Set("D2", rig.right.DistortionVector());
  f.Set("R", ToCv(rig.cam2_from_cam1.rotation)).Set("T", ToCv(rig.cam2_from_cam1.translation));
  if (with_rectification) {
    f.Set("R1", rig.rectification.R1).Set("R2", rig.rectification.R2);
    f.Set("P1", rig.rectification.P1).Set("P2", rig.rectification.P2);
    f.Set("Q", rig.rectification.Q);
  }
  return f;
}

template <typename F>
std::optional<std::string> InputErrorOf(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return std::string(e.what());
  }
  return std::nullopt;
}

class TempDirTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / fmt::format("flatscan_{}_{}_{}", info->test_suite_name(),
                                                   static_cast<long>(::getpid()), info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }
  fs::path dir_;
};

class RigFile : public TempDirTest {
 protected:
  // Writes `file` to rig.yml and returns the message ReadRigFile throws for it.
  std::optional<std::string> ReadError(const RawFile& file) {
    file.Write(path_);
    return InputErrorOf([&] { ReadRigFile(path_); });
  }
  std::string Expected(const std::string& rest) const { return path_.string() + ": " + rest; }

  void SetUp() override {
    TempDirTest::SetUp();
    path_ = dir_ / "rig.yml";
    rig_ = ReferenceRig();
    rig_.ComputeRectification();
  }
  fs::path path_;
  StereoRig rig_;
};

TEST_F(RigFile, RoundTrip) {
  WriteRigFile(path_, rig_);
  const StereoRig read = ReadRigFile(path_);
  ExpectRigNear(read, rig_);
  // Nothing but the file itself is left in the folder.
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_)) ++entries;
  EXPECT_EQ(entries, 1);
}

// The jackknife replicates (StereoRig::replicates) round-trip through `replicates`, one
// row of 30 values each; a wrong shape or a replicate without a baseline is named.
TEST_F(RigFile, ReplicatesRoundTripAndBadOnesAreNamed) {
  StereoRig with = rig_;
  for (int i = 0; i < 3; ++i) {
    RigReplicate r{rig_.left, rig_.right, rig_.cam2_from_cam1};
    r.left.fx += i;
    r.right.dist[1] += 0.001 * i;
    r.cam2_from_cam1.rotation = Eigen::AngleAxisd(1e-4 * i, Eigen::Vector3d::UnitY()) * r.cam2_from_cam1.rotation;
    r.cam2_from_cam1.translation.x() += 0.01 * i;
    with.replicates.push_back(r);
  }
  WriteRigFile(path_, with);
  const StereoRig read = ReadRigFile(path_);
  ASSERT_EQ(read.replicates.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    const RigReplicate &a = read.replicates[i], &b = with.replicates[i];
    EXPECT_EQ(a.left.fx, b.left.fx);
    EXPECT_EQ(a.right.dist, b.right.dist);
    EXPECT_EQ(a.left.width, rig_.left.width);
    EXPECT_LT((a.cam2_from_cam1.rotation - b.cam2_from_cam1.rotation).cwiseAbs().maxCoeff(), 1e-15);
    EXPECT_EQ(a.cam2_from_cam1.translation, b.cam2_from_cam1.translation);
  }
  EXPECT_TRUE(ReadRigFile((WriteRigFile(path_, rig_), path_)).replicates.empty());  // optional
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("replicates", cv::Mat(cv::Mat::ones(2, 29, CV_64F)))),
            Expected("key 'replicates' must be an Nx30 matrix, found 2x29"));
  cv::Mat no_baseline = cv::Mat::ones(1, 30, CV_64F);
  no_baseline.colRange(27, 30) = 0.0;
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("replicates", no_baseline)),
            Expected("key 'replicates' row 1 has a baseline below 1 mm"));
}

TEST_F(RigFile, WriteComputesMissingRectification) {
  StereoRig rig = ReferenceRig();
  ASSERT_TRUE(rig.rectification.empty());
  WriteRigFile(path_, rig);
  ExpectRigNear(ReadRigFile(path_), rig_);
}

TEST_F(RigFile, WrittenFileHasOpenCvNames) {
  WriteRigFile(path_, rig_);
  cv::FileStorage in(path_.string(), cv::FileStorage::READ);
  ASSERT_TRUE(in.isOpened());
  EXPECT_EQ(static_cast<int>(in["image_width"]), 2592);
  EXPECT_EQ(static_cast<int>(in["image_height"]), 1944);
  EXPECT_EQ(static_cast<std::string>(in["units"]), "mm");
  const std::vector<std::pair<const char*, cv::Mat>> expected = {
      {"M1", rig_.left.CameraMatrix()},        {"D1", rig_.left.DistortionVector()},
      {"M2", rig_.right.CameraMatrix()},       {"D2", rig_.right.DistortionVector()},
      {"R", ToCv(rig_.cam2_from_cam1.rotation)}, {"T", ToCv(rig_.cam2_from_cam1.translation)},
      {"R1", rig_.rectification.R1},           {"R2", rig_.rectification.R2},
      {"P1", rig_.rectification.P1},           {"P2", rig_.rectification.P2},
      {"Q", rig_.rectification.Q}};
  for (const auto& [key, value] : expected) {
    cv::Mat m;
    in[key] >> m;
    EXPECT_EQ(m.type(), CV_64F) << key;
    ExpectMatNear(m, value, 0, key);
  }
  EXPECT_EQ(rig_.left.DistortionVector().cols, 8);
  EXPECT_EQ(rig_.right.DistortionVector().cols, 5);
}

TEST_F(RigFile, RecomputesRectificationWhenAbsent) {
  RigKeys(rig_, /*with_rectification=*/false).Write(path_);
  const StereoRig read = ReadRigFile(path_);
  StereoRig expected = read;
  expected.rectification = {};
  expected.ComputeRectification();
  ExpectRigNear(read, expected);
  ExpectRigNear(read, rig_);
}

TEST_F(RigFile, KeepsRectificationFromFile) {
  // A rectification that differs from the recomputed one is taken as written.
  StereoRig custom = rig_;
  cv::Mat P2 = custom.rectification.P2.clone();
  P2.at<double>(0, 2) += 100;
  custom.rectification.P2 = P2;
  RigKeys(custom, true).Write(path_);
  ExpectMatNear(ReadRigFile(path_).rectification.P2, P2, 0, "P2");
}

TEST_F(RigFile, AcceptsColumnDistortionAndFloatMatrices) {
  RawFile f = RigKeys(rig_, false);
  f.Set("D1", rig_.left.DistortionVector().t());  // 8x1
  cv::Mat d2_4 = rig_.right.DistortionVector().colRange(0, 4).clone();
  f.Set("D2", d2_4);
  f.Set("T", ToCv(rig_.cam2_from_cam1.translation).t());  // 1x3
  cv::Mat m1_float;
  rig_.left.CameraMatrix().convertTo(m1_float, CV_32F);
  f.Set("M1", m1_float);
  f.Write(path_);
  const StereoRig read = ReadRigFile(path_);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(read.left.dist[i], rig_.left.dist[i]);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(read.right.dist[i], rig_.right.dist[i]);
  EXPECT_EQ(read.right.dist[4], 0);
  EXPECT_NEAR(read.left.fx, rig_.left.fx, 1e-3);
  EXPECT_EQ(read.cam2_from_cam1.translation, rig_.cam2_from_cam1.translation);
}

TEST_F(RigFile, Accepts14ElementDistortionWithZeroTail) {
  cv::Mat d14 = cv::Mat::zeros(1, 14, CV_64F);
  rig_.left.DistortionVector().copyTo(d14.colRange(0, 8));
  RawFile f = RigKeys(rig_, false);
  f.Set("D1", d14);
  f.Set("D2", cv::Mat(cv::Mat::zeros(12, 1, CV_64F)));
  f.Write(path_);
  const StereoRig read = ReadRigFile(path_);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(read.left.dist[i], rig_.left.dist[i]);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(read.right.dist[i], 0);
}

TEST_F(RigFile, MissingFile) {
  const fs::path missing = dir_ / "nope.yml";
  EXPECT_EQ(InputErrorOf([&] { ReadRigFile(missing); }),
            missing.string() +
                ": cannot open rig file (expected an OpenCV FileStorage YAML/XML file)");
}

TEST_F(RigFile, NotAFileStorageFile) {
  std::ofstream(path_) << "image_width = 2592\n{{{ not yaml";
  EXPECT_EQ(InputErrorOf([&] { ReadRigFile(path_); }),
            Expected("cannot open rig file (expected an OpenCV FileStorage YAML/XML file)"));
  EXPECT_EQ(InputErrorOf([&] { ReadRigFile(dir_); }),
            dir_.string() + ": cannot open rig file (expected an OpenCV FileStorage YAML/XML file)");
}

TEST_F(RigFile, MissingKey) {
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Remove("T")),
            Expected("missing key 'T' (expected 3x1 translation in mm, X2 = R X1 + T)"));
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Remove("M2")),
            Expected("missing key 'M2' (expected 3x3 camera matrix of camera 2 (right), pixels)"));
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Remove("D1")),
            Expected("missing key 'D1' (expected distortion vector of camera 1, 1xN or Nx1 with N "
                     "in {4, 5, 8, 12, 14})"));
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Remove("R")),
            Expected("missing key 'R' (expected 3x3 rotation, X2 = R X1 + T)"));
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Remove("image_height")),
            Expected("missing key 'image_height' (expected image height in pixels, an integer > "
                     "0)"));
}

TEST_F(RigFile, ImageSize) {
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("image_width", 0)),
            Expected("key 'image_width' must be an integer > 0, found 0"));
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("image_width", 2592.5)),
            Expected("key 'image_width' must be an integer > 0, found 2592.5"));
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("image_height", std::string("big"))),
            Expected("key 'image_height' must be an integer > 0, found a string"));
}

TEST_F(RigFile, WrongShape) {
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("M1", rig_.left.CameraMatrix().colRange(0, 2).clone())),
            Expected("key 'M1' must be a 3x3 matrix, found 3x2"));
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("R", cv::Mat(cv::Mat::eye(4, 4, CV_64F)))),
            Expected("key 'R' must be a 3x3 matrix, found 4x4"));
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("T", cv::Mat(cv::Mat::ones(2, 1, CV_64F)))),
            Expected("key 'T' must be a 3x1 vector, found 2x1"));
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("P1", cv::Mat(cv::Mat::eye(3, 3, CV_64F)))),
            Expected("key 'P1' must be a 3x4 matrix, found 3x3"));
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("Q", cv::Mat(cv::Mat::eye(3, 4, CV_64F)))),
            Expected("key 'Q' must be a 4x4 matrix, found 3x4"));
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("M2", 5)),
            Expected("key 'M2' must be a 3x3 matrix, found a number"));
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("M2", cv::Mat(cv::Mat::eye(3, 3, CV_64FC2)))),
            Expected("key 'M2' must be a 3x3 matrix, found a 2-channel matrix"));
}

TEST_F(RigFile, DistortionWithSixElements) {
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("D1", cv::Mat(cv::Mat::zeros(1, 6, CV_64F)))),
            Expected("key 'D1' must be a 1xN or Nx1 vector with N in {4, 5, 8, 12, 14}, found "
                     "1x6"));
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("D2", cv::Mat(cv::Mat::zeros(2, 4, CV_64F)))),
            Expected("key 'D2' must be a 1xN or Nx1 vector with N in {4, 5, 8, 12, 14}, found "
                     "2x4"));
}

TEST_F(RigFile, DistortionWithThinPrismTerms) {
  cv::Mat d14 = cv::Mat::zeros(1, 14, CV_64F);
  d14.at<double>(0, 9) = 1e-4;  // s2
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("D2", d14)),
            Expected("key 'D2' has non-zero thin-prism or tilt coefficients (s1 s2 s3 s4 tauX "
                     "tauY, elements 9-14); only k1 k2 p1 p2 k3 k4 k5 k6 are supported"));
}

TEST_F(RigFile, BadCameraMatrix) {
  cv::Mat m = rig_.left.CameraMatrix();
  m.at<double>(0, 0) = -5;
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("M1", m)),
            Expected("key 'M1' must have positive focal lengths, found fx = -5, fy = 11366.5"));
  m = rig_.left.CameraMatrix();
  m.at<double>(0, 1) = 0.5;
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("M1", m)),
            Expected("key 'M1' must have zero skew (the camera model has none), found M(0,1) = "
                     "0.5, M(1,0) = 0"));
  m = rig_.left.CameraMatrix();
  m.at<double>(2, 2) = 2;
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("M1", m)),
            Expected("key 'M1' must have the form [fx 0 cx; 0 fy cy; 0 0 1], found last row (0, "
                     "0, 2)"));
}

TEST_F(RigFile, NonOrthonormalRotation) {
  cv::Mat r = ToCv(rig_.cam2_from_cam1.rotation);
  r *= 1.01;
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("R", r)),
            Expected(fmt::format("key 'R' must be a rotation matrix (orthonormal with determinant "
                                 "+1, tolerance 1e-06), found max |R^T R - I| = {:.3g}, det = "
                                 "{:.6g}",
                                 1.01 * 1.01 - 1, 1.01 * 1.01 * 1.01)));
  const cv::Mat reflection = (cv::Mat_<double>(3, 3) << 1, 0, 0, 0, 1, 0, 0, 0, -1);
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("R", reflection)),
            Expected("key 'R' must be a rotation matrix (orthonormal with determinant +1, "
                     "tolerance 1e-06), found max |R^T R - I| = 0, det = -1"));
}

TEST_F(RigFile, ZeroTranslation) {
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("T", cv::Mat(cv::Mat::zeros(3, 1, CV_64F)))),
            Expected("key 'T' must be non-zero (the baseline), found (0, 0, 0)"));
}

// Before: T = [0, 0, 60] took 16.8 GB and 103 s; a vertical or 1e-300 mm baseline gave an
// internal check or an OpenCV assertion.
TEST_F(RigFile, DegenerateBaselines) {
  const auto with_t = [&](const Eigen::Vector3d& c2) {  // camera 2's centre in camera 1's frame, R = I
    return ReadError(RigKeys(rig_, false)
                         .Set("R", ToCv(Eigen::Matrix3d::Identity()))
                         .Set("T", ToCv(Eigen::Vector3d(-c2))));
  };
  EXPECT_EQ(with_t({0, 0, 60}), Expected("key 'T' puts the baseline along the viewing direction (camera 2's centre "
                                         "is at (0, 0, 60) mm in camera 1's frame): the cameras must stand side "
                                         "by side, the baseline across their views"));
  for (const double x : {0.0, 0.5})  // x = 0 was "along the viewing direction" before
    EXPECT_EQ(with_t({x, 60, 0}),
              Expected(fmt::format("key 'T' gives a vertical baseline (camera 2's centre is at ({}, 60, 0) mm in "
                                   "camera 1's frame): flatscan matches along image rows, so the cameras must stand "
                                   "side by side along the image x axis (or rotate both images by 90 degrees)",
                                   x)));
  EXPECT_EQ(with_t({1e-300, 0, 0}), Expected("key 'T' gives a baseline of 1e-300 mm (camera 2's centre is at "
                                             "(1e-300, 0, 0) mm in camera 1's frame); a stereo rig needs at least "
                                             "1 mm (T is in mm)"));
}

// Found by fuzz/rig_file_fuzz.cc and fuzz/plane_file_fuzz.cc: OpenCV allocated rows x cols
// before reading the data (48 GB for one mutated file), and a file whose top level is
// not a map made cv::FileStorage::operator[] throw.
TEST_F(RigFile, HugeOrMalformedMatricesAndNonMapFiles) {
  const auto matrix_text = [](const std::string& rows, const std::string& cols) {
    return "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\nM1: !!opencv-matrix\n   rows: " + rows +
           "\n   cols: " + cols + "\n   dt: d\n   data: [ 1., 0., 0. ]\n";
  };
  const auto error = [&](const std::string& text) {
    std::ofstream(path_, std::ios::trunc) << text;
    return InputErrorOf([&] { ReadRigFile(path_); });
  };
  EXPECT_EQ(error(matrix_text("100000", "100000")), Expected("key 'M1' must be a 3x3 matrix, found a 100000x100000 matrix"));
  EXPECT_EQ(error(matrix_text("=3", "3")), Expected("key 'M1' must be a 3x3 matrix, found a malformed OpenCV matrix (rows "
                                                    "and cols must be integers, dt a type)"));
  EXPECT_EQ(error("%YAML:1.0\n---\n- 1\n- 2\n"),
            Expected("cannot open rig file (expected an OpenCV FileStorage YAML/XML file): line 3 starts with '-': "
                     "the file must be one YAML map, its keys at the start of a line and their values indented"));
  // In flow style too; an XML file is not checked as YAML.
  EXPECT_EQ(error("%YAML:1.0\n[1, 2]\n"),
            Expected("cannot open rig file (expected an OpenCV FileStorage YAML/XML file): line 2 starts with '[': "
                     "the file must be one YAML map, its keys at the start of a line and their values indented"));
  EXPECT_EQ(error("<?xml version=\"1.0\"?>\n<opencv_storage>\n<a>1</a>\n</opencv_storage>\n"),
            Expected("missing key 'image_width' (expected image width in pixels, an integer > 0)"));
}

TEST_F(RigFile, NonFiniteValue) {
  cv::Mat t = ToCv(rig_.cam2_from_cam1.translation);
  t.at<double>(1) = std::nan("");
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("T", t)),
            Expected("key 'T' must have finite elements, found NaN or infinity"));
}

TEST_F(RigFile, PartialRectification) {
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Remove("Q")),
            Expected("key 'R1' is present but 'Q' is missing (give all of R1 R2 P1 P2 Q, or none "
                     "to have them recomputed)"));
}

// The sparse rectification relies on cv::stereoRectify's form of P1 and P2.
TEST_F(RigFile, RectifiedProjectionsMustHaveStereoRectifysForm) {
  cv::Mat skewed = rig_.rectification.P1.clone();
  skewed.at<double>(0, 1) = 0.5;
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("P1", skewed)),
            Expected("key 'P1' must have cv::stereoRectify's form [f 0 cx tx; 0 f cy ty; 0 0 1 0] (one focal length "
                     "f > 0, no skew); remove R1 R2 P1 P2 Q to have them recomputed"));
  cv::Mat other_focal = rig_.rectification.P2.clone();
  other_focal.at<double>(0, 0) *= 1.01;
  other_focal.at<double>(1, 1) *= 1.01;
  const double f1 = rig_.rectification.P1.at<double>(0, 0);
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("P2", other_focal)),
            Expected(fmt::format("key 'P2' must have the focal length of P1 ({}; found {}): both rectified cameras "
                                 "share one; remove R1 R2 P1 P2 Q to have them recomputed",
                                 f1, other_focal.at<double>(0, 0))));
}

TEST_F(RigFile, WrongUnits) {
  EXPECT_EQ(ReadError(RigKeys(rig_, true).Set("units", std::string("m"))),
            Expected("key 'units' must be \"mm\" (optional; translations are in millimetres)"));
}

TEST_F(RigFile, WriteToUnwritablePlaceIsInputErrorNamingPath) {
  const fs::path file = dir_ / "plain.txt";
  std::ofstream(file) << "x";
  const fs::path path = file / "rig.yml";
  EXPECT_EQ(InputErrorOf([&] { WriteRigFile(path, rig_); }),
            fmt::format("cannot write '{}': '{}' is not a folder", path.string(), file.string()));
}

// OpenCV's samples/cpp/stereo_calib.cpp writes intrinsics.yml and extrinsics.yml like
// this (stereoCalibrate with CALIB_RATIONAL_MODEL returns 1x14 distortion vectors, and
// it rectifies with CALIB_ZERO_DISPARITY, alpha = 1).
void WriteLikeStereoCalib(const StereoRig& rig, const fs::path& intrinsics_path,
                          const fs::path& extrinsics_path) {
  cv::Mat cameraMatrix[2] = {rig.left.CameraMatrix(), rig.right.CameraMatrix()};
  cv::Mat distCoeffs[2];
  for (int k = 0; k < 2; ++k) {
    distCoeffs[k] = cv::Mat::zeros(1, 14, CV_64F);
    (k == 0 ? rig.left : rig.right).DistortionVector().copyTo(
        distCoeffs[k].colRange(0, (k == 0 ? rig.left : rig.right).DistortionVector().cols));
  }
  const cv::Mat R = ToCv(rig.cam2_from_cam1.rotation);
  const cv::Mat T = ToCv(rig.cam2_from_cam1.translation);
  const cv::Size imageSize(rig.left.width, rig.left.height);

  cv::FileStorage storage(intrinsics_path.string(), cv::FileStorage::WRITE);
  ASSERT_TRUE(storage.isOpened());
  storage << "M1" << cameraMatrix[0] << "D1" << distCoeffs[0] << "M2" << cameraMatrix[1] << "D2"
          << distCoeffs[1];
  storage.release();

  cv::Mat R1, R2, P1, P2, Q;
  cv::Rect validRoi[2];
  cv::stereoRectify(cameraMatrix[0], distCoeffs[0], cameraMatrix[1], distCoeffs[1], imageSize, R,
                    T, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, 1, imageSize, &validRoi[0],
                    &validRoi[1]);
  storage.open(extrinsics_path.string(), cv::FileStorage::WRITE);
  ASSERT_TRUE(storage.isOpened());
  storage << "R" << R << "T" << T << "R1" << R1 << "R2" << R2 << "P1" << P1 << "P2" << P2 << "Q"
          << Q;
  storage.release();
}

TEST_F(RigFile, ImportOpenCvStereoCalib) {
  const fs::path intrinsics = dir_ / "intrinsics.yml";
  const fs::path extrinsics = dir_ / "extrinsics.yml";
  WriteLikeStereoCalib(rig_, intrinsics, extrinsics);
  const StereoRig imported = ImportOpenCvStereoCalib(intrinsics, extrinsics, 2592, 1944);
  // Cameras and pose as written; the rectification is the rig's own (flags = 0,
  // alpha = -1), not stereo_calib's CALIB_ZERO_DISPARITY one.
  ExpectRigNear(imported, rig_);

  // And it can be saved as a rig file and read back.
  WriteRigFile(path_, imported);
  ExpectRigNear(ReadRigFile(path_), rig_);
}

TEST_F(RigFile, ImportOpenCvStereoCalibErrorsNameTheFile) {
  const fs::path intrinsics = dir_ / "intrinsics.yml";
  const fs::path extrinsics = dir_ / "extrinsics.yml";
  WriteLikeStereoCalib(rig_, intrinsics, extrinsics);
  EXPECT_EQ(InputErrorOf([&] { ImportOpenCvStereoCalib(intrinsics, dir_ / "x.yml", 2592, 1944); }),
            (dir_ / "x.yml").string() +
                ": cannot open extrinsics file (expected an OpenCV FileStorage YAML/XML file)");
  RawFile().Set("M1", rig_.left.CameraMatrix()).Set("D1", rig_.left.DistortionVector()).Write(
      intrinsics);
  EXPECT_EQ(InputErrorOf([&] { ImportOpenCvStereoCalib(intrinsics, extrinsics, 2592, 1944); }),
            intrinsics.string() +
                ": missing key 'M2' (expected 3x3 camera matrix of camera 2 (right), pixels)");
  EXPECT_EQ(InputErrorOf([&] { ImportOpenCvStereoCalib(intrinsics, extrinsics, 0, 1944); }),
            fmt::format("image size must be positive to import '{}', got 0x1944",
                        intrinsics.string()));
}

class PlaneFileTest : public TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    path_ = dir_ / "plane.yml";
    plane_.normal = Eigen::Vector3d(0.02, -0.05, -1).normalized();
    plane_.markers = {{-12.5, -9.25, 201.0},
                      {12.75, -9.5, 200.5},
                      {12.5, 9.0, 199.25},
                      {-12.25, 9.5, 199.75}};
    plane_.point = Eigen::Vector3d::Zero();
    for (const auto& m : plane_.markers) plane_.point += m / 4;
    plane_.residuals_mm = {0.0012, -0.0007, 0.0011, -0.0016};
  }
  RawFile PlaneKeys() const {
    cv::Mat markers(static_cast<int>(plane_.markers.size()), 3, CV_64F);
    cv::Mat residuals(static_cast<int>(plane_.markers.size()), 1, CV_64F);
    for (int i = 0; i < markers.rows; ++i) {
      for (int j = 0; j < 3; ++j) markers.at<double>(i, j) = plane_.markers[i][j];
      residuals.at<double>(i) = plane_.residuals_mm[i];
    }
    RawFile f;
    f.Set("normal", ToCv(plane_.normal)).Set("point", ToCv(plane_.point));
    f.Set("markers", markers).Set("residuals", residuals);
    return f;
  }
  std::optional<std::string> ReadError(const RawFile& file) {
    file.Write(path_);
    return InputErrorOf([&] { ReadPlaneFile(path_); });
  }
  std::string Expected(const std::string& rest) const { return path_.string() + ": " + rest; }

  static constexpr const char* kRigSha256 = "0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef";
  fs::path path_;
  SupportPlane plane_;
};

TEST_F(PlaneFileTest, RoundTrip) {
  WritePlaneFile(path_, plane_, kRigSha256);
  const flatscan::PlaneFile file = ReadPlaneFile(path_);
  EXPECT_EQ(file.rig_sha256, kRigSha256);
  const SupportPlane& read = file.plane;
  EXPECT_LE((read.normal - plane_.normal).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE((read.point - plane_.point).cwiseAbs().maxCoeff(), 1e-12);
  ASSERT_EQ(read.markers.size(), 4u);
  ASSERT_EQ(read.residuals_mm.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    EXPECT_LE((read.markers[i] - plane_.markers[i]).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_NEAR(read.residuals_mm[i], plane_.residuals_mm[i], 1e-12);
  }
  cv::FileStorage in(path_.string(), cv::FileStorage::READ);
  double rms = 0;
  for (double r : plane_.residuals_mm) rms += r * r / 4;
  EXPECT_NEAR(static_cast<double>(in["residual_rms_mm"]), std::sqrt(rms), 1e-15);
}

TEST_F(PlaneFileTest, MissingFile) {
  EXPECT_EQ(InputErrorOf([&] { ReadPlaneFile(path_); }),
            Expected("cannot open plane file (expected an OpenCV FileStorage YAML/XML file)"));
}

TEST_F(PlaneFileTest, NonUnitNormal) {
  const cv::Mat short_normal = (cv::Mat_<double>(3, 1) << 0, 0, -0.5);
  EXPECT_EQ(ReadError(PlaneKeys().Set("normal", short_normal)),
            Expected("key 'normal' must be a unit vector (norm 1 within 1e-06), found norm 0.5"));
}

TEST_F(PlaneFileTest, MissingKey) {
  EXPECT_EQ(ReadError(PlaneKeys().Remove("residuals")),
            Expected("missing key 'residuals' (expected Nx1 marker distances to the plane, mm)"));
  EXPECT_EQ(ReadError(PlaneKeys().Remove("point")),
            Expected("missing key 'point' (expected 3x1 point on the plane (marker centroid), "
                     "mm)"));
}

TEST_F(PlaneFileTest, WrongShape) {
  EXPECT_EQ(ReadError(PlaneKeys().Set("markers", cv::Mat(cv::Mat::ones(2, 3, CV_64F)))),
            Expected("key 'markers' must be an Nx3 matrix with N >= 3, found 2x3"));
  EXPECT_EQ(ReadError(PlaneKeys().Set("markers", cv::Mat(cv::Mat::ones(4, 2, CV_64F)))),
            Expected("key 'markers' must be an Nx3 matrix with N >= 3, found 4x2"));
  EXPECT_EQ(ReadError(PlaneKeys().Set("residuals", cv::Mat(cv::Mat::zeros(3, 1, CV_64F)))),
            Expected("key 'residuals' must be a 4x1 vector (one per marker), found 3x1"));
  EXPECT_EQ(ReadError(PlaneKeys().Set("point", cv::Mat(cv::Mat::zeros(4, 1, CV_64F)))),
            Expected("key 'point' must be a 3x1 vector, found 4x1"));
}

TEST_F(PlaneFileTest, NonFinite) {
  cv::Mat markers(4, 3, CV_64F, cv::Scalar(1.0));
  markers.at<double>(2, 1) = INFINITY;
  EXPECT_EQ(ReadError(PlaneKeys().Set("markers", markers)),
            Expected("key 'markers' must have finite elements, found NaN or infinity"));
}

TEST_F(PlaneFileTest, WriteToMissingFolderIsInputErrorNamingPath) {
  const fs::path path = dir_ / "no" / "plane.yml";
  EXPECT_EQ(InputErrorOf([&] { WritePlaneFile(path, plane_, kRigSha256); }),
            fmt::format("cannot write '{}': folder '{}' does not exist", path.string(),
                        (dir_ / "no").string()));
}

TEST_F(PlaneFileTest, RigSha256IsOptionalButMustBeAHash) {
  WritePlaneFile(path_, plane_, "");
  EXPECT_EQ(ReadPlaneFile(path_).rig_sha256, "");  // written before the key existed
  EXPECT_EQ(ReadError(PlaneKeys().Set("rig_sha256", std::string("abc"))),
            Expected("key 'rig_sha256' must be 64 lowercase hexadecimal digits (the SHA-256 of the rig file), "
                     "found 'abc'"));
  EXPECT_EQ(ReadError(PlaneKeys().Set("rig_sha256", 7)),
            Expected("key 'rig_sha256' must be 64 lowercase hexadecimal digits (the SHA-256 of the rig file), "
                     "found a number"));
}

// Heights are normal . (p - point): a reversed normal turns the rim's highest point into
// its lowest, and a warped part can pass. The check also catches a plane of another rig
// that lies behind this rig's cameras.
TEST_F(PlaneFileTest, NormalMustPointTowardBothCameras) {
  const StereoRig rig = ReferenceRig();
  const fs::path rig_path = dir_ / "rig.yml";
  EXPECT_EQ(CheckPlaneAgainstRig({plane_, kRigSha256}, path_, rig, rig_path, kRigSha256, false),
            PlaneRigMatch::kMatches);
  flatscan::PlaneFile reversed{plane_, kRigSha256};
  reversed.plane.normal = -plane_.normal;
  EXPECT_EQ(InputErrorOf([&] { CheckPlaneAgainstRig(reversed, path_, rig, rig_path, kRigSha256, true); }),
            Expected(fmt::format("key 'normal' must point toward the cameras of '{}', but camera 1 lies "
                                 "{:.1f} mm behind the plane: the normal is reversed or the plane belongs to "
                                 "another rig (recalibrate it with `flatscan calibrate-plane`)",
                                 rig_path.string(), -reversed.plane.Height(Eigen::Vector3d::Zero()))));
  // A plane between the two cameras: camera 2 is behind it.
  flatscan::PlaneFile between{plane_, kRigSha256};
  between.plane.normal = Eigen::Vector3d(-1, 0, 0);
  between.plane.point = Eigen::Vector3d(30, 0, 200);
  EXPECT_EQ(InputErrorOf([&] { CheckPlaneAgainstRig(between, path_, rig, rig_path, kRigSha256, true); }),
            Expected(fmt::format("key 'normal' must point toward the cameras of '{}', but camera 2 lies 30.0 mm "
                                 "behind the plane: the normal is reversed or the plane belongs to another rig "
                                 "(recalibrate it with `flatscan calibrate-plane`)",
                                 rig_path.string())));
}

TEST_F(PlaneFileTest, PlaneOfAnotherRigIsRefusedUnlessAllowed) {
  const StereoRig rig = ReferenceRig();
  const fs::path rig_path = dir_ / "rig.yml";
  const std::string other(64, 'f');
  EXPECT_EQ(InputErrorOf([&] { CheckPlaneAgainstRig({plane_, kRigSha256}, path_, rig, rig_path, other, false); }),
            Expected(fmt::format("calibrated with another rig file (rig_sha256 0123456789ab...) than '{}' (SHA-256 "
                                 "ffffffffffff...): recalibrate the plane with this rig, or give "
                                 "--allow-foreign-plane to measure anyway",
                                 rig_path.string())));
  EXPECT_EQ(CheckPlaneAgainstRig({plane_, kRigSha256}, path_, rig, rig_path, other, true), PlaneRigMatch::kForeign);
  EXPECT_EQ(CheckPlaneAgainstRig({plane_, ""}, path_, rig, rig_path, other, false), PlaneRigMatch::kUnknown);
}

}  // namespace
}  // namespace flatscan
