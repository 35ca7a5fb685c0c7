#include "flatscan/io/rig_file.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>

#include "flatscan/calibration/rectification.h"
#include "flatscan/io/atomic_output.h"
#include "flatscan/io/file_storage_limits.h"
#include "flatscan/util/error.h"
#include "flatscan/util/sha256.h"

namespace flatscan {
namespace fs = std::filesystem;

namespace {

constexpr double kRotationTolerance = 1e-6;
constexpr double kUnitNormalTolerance = 1e-6;
constexpr double kMinBaselineMm = 1.0;
// The largest matrix a rig or plane file holds: a plane file's N x 3 markers.
constexpr double kMaxMatrixElements = 30000;
constexpr const char* kExpectedFileStorage = "expected an OpenCV FileStorage YAML/XML file";

std::string ShapeOf(const cv::Mat& m) { return fmt::format("{}x{}", m.rows, m.cols); }

bool AllFinite(const cv::Mat& m) { return cv::checkRange(m, /*quiet=*/true); }

// What a FileStorage node holds, for "found ..." in messages about non-matrices.
std::string DescribeNode(const cv::FileNode& node) {
  if (node.isInt() || node.isReal()) return "a number";
  if (node.isString()) return "a string";
  if (node.isSeq()) return "a sequence";
  if (node.isMap()) return "a map that is not an OpenCV matrix";
  return "no value";
}

// Reads keys of one FileStorage file; every error names the file and the key.
class KeyReader {
 public:
  KeyReader(const fs::path& path, const char* kind) : name_(path.string()) {
    std::error_code ec;
    bool opened = false;
    if (fs::is_regular_file(path, ec)) {
      std::ifstream in(path, std::ios::binary);
      std::stringstream text;
      text << in.rdbuf();
      if (const auto why = FileStorageLimitExceeded(text.str()))
        ThrowInputError("{}: cannot open {} ({}): {}", name_, kind, kExpectedFileStorage, *why);
      try {
        opened = storage_.open(name_, cv::FileStorage::READ);
      } catch (const std::exception&) {  // cv::Exception, and std::length_error from OpenCV's
        opened = false;                  // YAML parser on some malformed files (fuzz/)
      }
    }
    // The keys are looked up in the top-level map; a file whose top level is a list or a
    // scalar makes cv::FileStorage::operator[] throw (found by fuzz/plane_file_fuzz.cc).
    if (opened && !storage_.root().isMap()) opened = false;
    if (!opened) ThrowInputError("{}: cannot open {} ({})", name_, kind, kExpectedFileStorage);
  }

  bool Has(const char* key) const { return !storage_[key].empty(); }
  cv::FileNode Get(const char* key) const { return storage_[key]; }

  template <typename... Args>
  [[noreturn]] void Fail(const char* key, fmt::format_string<Args...> format,
                         Args&&... args) const {
    ThrowInputError("{}: key '{}' {}", name_, key,
                    fmt::format(format, std::forward<Args>(args)...));
  }

  // An integer > 0. `meaning` completes "missing key 'K' (expected <meaning>)".
  int ReadPositiveInt(const char* key, const char* meaning) const {
    const cv::FileNode node = Node(key, meaning);
    if (node.isInt()) {
      const int value = static_cast<int>(node);
      if (value > 0) return value;
      Fail(key, "must be an integer > 0, found {}", value);
    }
    if (node.isReal()) Fail(key, "must be an integer > 0, found {}", static_cast<double>(node));
    Fail(key, "must be an integer > 0, found {}", DescribeNode(node));
  }

  // A single-channel OpenCV matrix converted to CV_64F, all elements finite.
  // `shape` completes "key 'K' must be <shape>, found ..." for a node that is no matrix.
  cv::Mat ReadMatrix(const char* key, const char* meaning, const std::string& shape) const {
    const cv::FileNode node = Node(key, meaning);
    cv::Mat m;
    bool ok = node.isMap();
    // OpenCV allocates rows x cols before it reads the data: a file claiming 100000 x
    // 100000 would take 80 GB (found by fuzz/rig_file_fuzz.cc). Our matrices are small.
    if (ok) {
      const cv::FileNode rows = node["rows"], cols = node["cols"];
      if (!rows.isInt() || !cols.isInt() || !node["dt"].isString())
        Fail(key, "must be {}, found a malformed OpenCV matrix (rows and cols must be integers, dt a type)", shape);
      const double elements = static_cast<double>(static_cast<int>(rows)) * static_cast<int>(cols);
      if (static_cast<int>(rows) < 0 || static_cast<int>(cols) < 0 || elements > kMaxMatrixElements)
        Fail(key, "must be {}, found a {}x{} matrix", shape, static_cast<int>(rows), static_cast<int>(cols));
    }
    if (ok) {
      try {
        node >> m;
      } catch (const std::exception&) {
        ok = false;
      }
    }
    if (!ok) {
      Fail(key, "must be {}, found {}", shape,
           node.isMap() ? "a malformed OpenCV matrix" : DescribeNode(node));
    }
    if (m.channels() != 1) Fail(key, "must be {}, found a {}-channel matrix", shape, m.channels());
    cv::Mat m64;
    m.convertTo(m64, CV_64F);
    if (!AllFinite(m64)) Fail(key, "must have finite elements, found NaN or infinity");
    return m64;
  }

  // A matrix of exactly rows x cols.
  cv::Mat ReadMatrix(const char* key, const char* meaning, int rows, int cols) const {
    const std::string shape = fmt::format("a {}x{} matrix", rows, cols);
    cv::Mat m = ReadMatrix(key, meaning, shape);
    if (m.rows != rows || m.cols != cols) Fail(key, "must be {}, found {}", shape, ShapeOf(m));
    return m;
  }

  // A 3-vector stored as 3x1 (or 1x3).
  Eigen::Vector3d ReadVector3(const char* key, const char* meaning) const {
    const std::string shape = "a 3x1 vector";
    const cv::Mat m = ReadMatrix(key, meaning, shape);
    if (m.total() != 3 || (m.rows != 1 && m.cols != 1))
      Fail(key, "must be {}, found {}", shape, ShapeOf(m));
    return {m.at<double>(0), m.at<double>(1), m.at<double>(2)};
  }

  const std::string& name() const { return name_; }

 private:
  cv::FileNode Node(const char* key, const char* meaning) const {
    const cv::FileNode node = storage_[key];
    if (node.empty()) ThrowInputError("{}: missing key '{}' (expected {})", name_, key, meaning);
    return node;
  }

  std::string name_;
  cv::FileStorage storage_;
};

// M1/M2: [fx 0 cx; 0 fy cy; 0 0 1] with fx, fy > 0 (the camera model has no skew).
cv::Mat ReadCameraMatrix(const KeyReader& in, const char* key, const char* meaning) {
  const cv::Mat m = in.ReadMatrix(key, meaning, 3, 3);
  const double fx = m.at<double>(0, 0), fy = m.at<double>(1, 1);
  if (!(fx > 0 && fy > 0))
    in.Fail(key, "must have positive focal lengths, found fx = {}, fy = {}", fx, fy);
  if (m.at<double>(2, 0) != 0 || m.at<double>(2, 1) != 0 || m.at<double>(2, 2) != 1) {
    in.Fail(key, "must have the form [fx 0 cx; 0 fy cy; 0 0 1], found last row ({}, {}, {})",
            m.at<double>(2, 0), m.at<double>(2, 1), m.at<double>(2, 2));
  }
  if (m.at<double>(0, 1) != 0 || m.at<double>(1, 0) != 0)
    in.Fail(key, "must have zero skew (the camera model has none), found M(0,1) = {}, M(1,0) = {}",
            m.at<double>(0, 1), m.at<double>(1, 0));
  return m;
}

// D1/D2: 1xN or Nx1 with N in {4, 5, 8, 12, 14}; the thin-prism and tilt terms of the
// 12- and 14-element forms must be zero (the camera model has k1 k2 p1 p2 k3 k4 k5 k6).
// Returns 1x8 or shorter.
cv::Mat ReadDistortion(const KeyReader& in, const char* key, const char* meaning) {
  const std::string shape = "a 1xN or Nx1 vector with N in {4, 5, 8, 12, 14}";
  const cv::Mat raw = in.ReadMatrix(key, meaning, shape);
  const int n = static_cast<int>(raw.total());
  if (!(raw.rows == 1 || raw.cols == 1) || !(n == 4 || n == 5 || n == 8 || n == 12 || n == 14))
    in.Fail(key, "must be {}, found {}", shape, ShapeOf(raw));
  const cv::Mat d = raw.reshape(1, 1);
  for (int i = 8; i < n; ++i) {
    if (d.at<double>(0, i) != 0)
      in.Fail(key,
              "has non-zero thin-prism or tilt coefficients (s1 s2 s3 s4 tauX tauY, elements 9-{}); "
              "only k1 k2 p1 p2 k3 k4 k5 k6 are supported",
              n);
  }
  return d.colRange(0, std::min(n, 8)).clone();
}

// R: 3x3 rotation (orthonormal, det +1).
Eigen::Matrix3d ReadRotation(const KeyReader& in, const char* key, const char* meaning) {
  const cv::Mat m = in.ReadMatrix(key, meaning, 3, 3);
  Eigen::Matrix3d r;
  cv::cv2eigen(m, r);
  const double orthonormality_error =
      (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  const double det = r.determinant();
  if (orthonormality_error > kRotationTolerance || std::abs(det - 1) > kRotationTolerance) {
    in.Fail(key,
            "must be a rotation matrix (orthonormal with determinant +1, tolerance {}), "
            "found max |R^T R - I| = {:.3g}, det = {:.6g}",
            kRotationTolerance, orthonormality_error, det);
  }
  return r;
}

Eigen::Vector3d ReadTranslation(const KeyReader& in, const char* key, const char* meaning) {
  const Eigen::Vector3d t = in.ReadVector3(key, meaning);
  if (t.isZero(0)) in.Fail(key, "must be non-zero (the baseline), found (0, 0, 0)");
  return t;
}

// The matching runs along rectified rows, which cv::stereoRectify lays along the
// baseline: the baseline must be at least 1 mm and run across the views (more along x
// than along y or the viewing axis z of camera 1). Else stereoRectify returns a
// degenerate rectification (a baseline along z sends the rectified rows to infinity:
// 16.8 GB of row crossings for T = [0, 0, 60]).
void CheckBaseline(const KeyReader& in, const StereoRig& rig) {
  // Camera 2's centre; adding 0 turns -0 into 0 for the message.
  const Eigen::Vector3d c2 = rig.cam2_from_cam1.Inverse().OriginOfSource() + Eigen::Vector3d::Zero();
  const std::string where = fmt::format("camera 2's centre is at ({:.4g}, {:.4g}, {:.4g}) mm in camera 1's frame",
                                        c2.x(), c2.y(), c2.z());
  if (c2.stableNorm() < kMinBaselineMm)
    in.Fail("T", "gives a baseline of {:.3g} mm ({}); a stereo rig needs at least {} mm (T is in mm)", c2.stableNorm(),
            where, kMinBaselineMm);
  const Eigen::Vector3d size = c2.cwiseAbs();
  if (size.z() >= size.x() && size.z() >= size.y())
    in.Fail("T", "puts the baseline along the viewing direction ({}): the cameras must stand side by side, the "
            "baseline across their views",
            where);
  if (size.y() >= size.x())
    in.Fail("T", "gives a vertical baseline ({}): flatscan matches along image rows, so the cameras must stand "
            "side by side along the image x axis (or rotate both images by 90 degrees)",
            where);
}

constexpr const char* kMeaningM1 = "3x3 camera matrix of camera 1 (left), pixels";
constexpr const char* kMeaningM2 = "3x3 camera matrix of camera 2 (right), pixels";
constexpr const char* kMeaningD1 =
    "distortion vector of camera 1, 1xN or Nx1 with N in {4, 5, 8, 12, 14}";
constexpr const char* kMeaningD2 =
    "distortion vector of camera 2, 1xN or Nx1 with N in {4, 5, 8, 12, 14}";
constexpr const char* kMeaningR = "3x3 rotation, X2 = R X1 + T";
constexpr const char* kMeaningT = "3x1 translation in mm, X2 = R X1 + T";

struct RectificationKey {
  const char* key;
  int rows, cols;
  const char* meaning;
};
constexpr std::array<RectificationKey, 5> kRectificationKeys{{
    {"R1", 3, 3, "3x3 rectifying rotation of camera 1"},
    {"R2", 3, 3, "3x3 rectifying rotation of camera 2"},
    {"P1", 3, 4, "3x4 rectified projection matrix of camera 1"},
    {"P2", 3, 4, "3x4 rectified projection matrix of camera 2"},
    {"Q", 4, 4, "4x4 disparity-to-depth matrix"},
}};

// Cameras and pose from M1 D1 M2 D2 (in `intrinsics`) and R T (in `extrinsics`).
StereoRig ReadRigCore(const KeyReader& intrinsics, const KeyReader& extrinsics, int width,
                      int height) {
  StereoRig rig;
  const cv::Mat m1 = ReadCameraMatrix(intrinsics, "M1", kMeaningM1);
  const cv::Mat d1 = ReadDistortion(intrinsics, "D1", kMeaningD1);
  const cv::Mat m2 = ReadCameraMatrix(intrinsics, "M2", kMeaningM2);
  const cv::Mat d2 = ReadDistortion(intrinsics, "D2", kMeaningD2);
  rig.left = Camera::FromOpenCv(m1, d1, width, height);
  rig.right = Camera::FromOpenCv(m2, d2, width, height);
  rig.cam2_from_cam1.rotation = ReadRotation(extrinsics, "R", kMeaningR);
  rig.cam2_from_cam1.translation = ReadTranslation(extrinsics, "T", kMeaningT);
  CheckBaseline(extrinsics, rig);
  return rig;
}

// Opens `tmp` for writing as YAML (or XML/JSON when the final name asks for it).
void OpenForWriting(cv::FileStorage& storage, const fs::path& final_path, const fs::path& tmp) {
  std::string ext = final_path.extension().string();
  if (ext == ".gz") ext = final_path.stem().extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const int format = (ext == ".xml" || ext == ".json") ? cv::FileStorage::FORMAT_AUTO
                                                        : cv::FileStorage::FORMAT_YAML;
  bool opened = false;
  try {
    opened = storage.open(tmp.string(), cv::FileStorage::WRITE | format);
  } catch (const cv::Exception& e) {
    ThrowInputError("cannot write '{}': {}", final_path.string(), e.msg);
  }
  if (!opened) ThrowInputError("cannot write '{}': cannot open it for writing", final_path.string());
}

cv::Mat ToCv(const Eigen::MatrixXd& m) {
  cv::Mat out;
  cv::eigen2cv(m, out);
  return out;
}

// The rig file's `replicates` (StereoRig::replicates): one row per replicate of
// kReplicateColumns values: fx1 fy1 cx1 cy1 k1..k6 p1 p2 in OpenCV's order (the 8
// distortion coefficients k1 k2 p1 p2 k3 k4 k5 k6) for camera 1, the same for camera 2,
// then R as a Rodrigues vector (rad) and T (mm).
constexpr int kReplicateColumns = 30;
constexpr const char* kReplicatesMeaning =
    "jackknife replicates of the calibration, one row each: fx1 fy1 cx1 cy1 D1 (8 values) fx2 fy2 cx2 cy2 D2 (8 "
    "values) R (Rodrigues vector, rad) T (mm)";

cv::Mat ReplicatesMatrix(const std::vector<RigReplicate>& replicates) {
  cv::Mat out(static_cast<int>(replicates.size()), kReplicateColumns, CV_64F);
  for (int i = 0; i < out.rows; ++i) {
    const RigReplicate& r = replicates[i];
    double* row = out.ptr<double>(i);
    int c = 0;
    for (const Camera* camera : {&r.left, &r.right}) {
      for (const double v : {camera->fx, camera->fy, camera->cx, camera->cy}) row[c++] = v;
      for (const double v : camera->dist) row[c++] = v;
    }
    const Eigen::AngleAxisd angle_axis(r.cam2_from_cam1.rotation);
    const Eigen::Vector3d rotation = angle_axis.angle() * angle_axis.axis();
    for (int k = 0; k < 3; ++k) row[c++] = rotation[k];
    for (int k = 0; k < 3; ++k) row[c++] = r.cam2_from_cam1.translation[k];
  }
  return out;
}

std::vector<RigReplicate> ReadReplicates(const KeyReader& in, int width, int height) {
  const std::string shape = fmt::format("an Nx{} matrix", kReplicateColumns);
  const cv::Mat m = in.ReadMatrix("replicates", kReplicatesMeaning, shape);
  if (m.cols != kReplicateColumns || m.rows < 1) in.Fail("replicates", "must be {}, found {}", shape, ShapeOf(m));
  std::vector<RigReplicate> out(m.rows);
  for (int i = 0; i < m.rows; ++i) {
    const double* row = m.ptr<double>(i);
    int c = 0;
    for (Camera* camera : {&out[i].left, &out[i].right}) {
      camera->width = width;
      camera->height = height;
      camera->fx = row[c++];
      camera->fy = row[c++];
      camera->cx = row[c++];
      camera->cy = row[c++];
      for (double& v : camera->dist) v = row[c++];
      if (!(camera->fx > 0 && camera->fy > 0))
        in.Fail("replicates", "row {} must have positive focal lengths, found fx = {}, fy = {}", i + 1, camera->fx,
                camera->fy);
    }
    const Eigen::Vector3d rotation(row[c], row[c + 1], row[c + 2]);
    const double angle = rotation.norm();
    out[i].cam2_from_cam1.rotation =
        angle > 0 ? Eigen::AngleAxisd(angle, rotation / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
    out[i].cam2_from_cam1.translation = Eigen::Vector3d(row[c + 3], row[c + 4], row[c + 5]);
    if (out[i].cam2_from_cam1.translation.norm() < kMinBaselineMm)
      in.Fail("replicates", "row {} has a baseline below {} mm", i + 1, kMinBaselineMm);
  }
  return out;
}

}  // namespace

StereoRig ReadRigFile(const fs::path& path) {
  const KeyReader in(path, "rig file");
  const int width = in.ReadPositiveInt("image_width", "image width in pixels, an integer > 0");
  const int height = in.ReadPositiveInt("image_height", "image height in pixels, an integer > 0");
  if (in.Has("units")) {
    const cv::FileNode units = in.Get("units");
    if (!units.isString() || static_cast<std::string>(units) != "mm")
      in.Fail("units", "must be \"mm\" (optional; translations are in millimetres)");
  }
  StereoRig rig = ReadRigCore(in, in, width, height);
  if (in.Has("replicates")) rig.replicates = ReadReplicates(in, width, height);

  int present = 0;
  for (const RectificationKey& k : kRectificationKeys) present += in.Has(k.key) ? 1 : 0;
  if (present == 0) {
    rig.ComputeRectification();
    return rig;
  }
  if (present != static_cast<int>(kRectificationKeys.size())) {
    const char* given = nullptr;
    const char* absent = nullptr;
    for (const RectificationKey& k : kRectificationKeys) {
      if (in.Has(k.key) && !given) given = k.key;
      if (!in.Has(k.key) && !absent) absent = k.key;
    }
    ThrowInputError(
        "{}: key '{}' is present but '{}' is missing (give all of R1 R2 P1 P2 Q, or none to "
        "have them recomputed)",
        in.name(), given, absent);
  }
  std::array<cv::Mat, 5> m;
  for (size_t i = 0; i < kRectificationKeys.size(); ++i) {
    const RectificationKey& k = kRectificationKeys[i];
    m[i] = in.ReadMatrix(k.key, k.meaning, k.rows, k.cols);
  }
  for (const int i : {2, 3}) {  // P1, P2: the sparse rectification relies on this form
    Eigen::Matrix3d k;
    cv::cv2eigen(cv::Mat(m[i](cv::Rect(0, 0, 3, 3))), k);
    if (!IsRectifiedCameraMatrix(k))
      in.Fail(kRectificationKeys[i].key,
              "must have cv::stereoRectify's form [f 0 cx tx; 0 f cy ty; 0 0 1 0] (one focal length f > 0, no "
              "skew); remove R1 R2 P1 P2 Q to have them recomputed");
  }
  const double f1 = m[2].at<double>(0, 0), f2 = m[3].at<double>(0, 0);
  if (std::abs(f1 - f2) > 1e-9 * f1)
    in.Fail("P2", "must have the focal length of P1 ({}; found {}): both rectified cameras share one; remove R1 R2 P1 "
            "P2 Q to have them recomputed", f1, f2);
  rig.rectification = {m[0], m[1], m[2], m[3], m[4]};
  return rig;
}

void WriteRigFile(const fs::path& path, const StereoRig& rig_in) {
  StereoRig rig = rig_in;
  if (rig.rectification.empty()) rig.ComputeRectification();
  const auto as64 = [](const cv::Mat& m) {
    cv::Mat out;
    m.convertTo(out, CV_64F);
    return out;
  };
  WriteFileAtomically(path, [&](const fs::path& tmp) {
    cv::FileStorage out;
    OpenForWriting(out, path, tmp);
    out << "image_width" << rig.left.width;
    out << "image_height" << rig.left.height;
    out << "M1" << rig.left.CameraMatrix() << "D1" << rig.left.DistortionVector();
    out << "M2" << rig.right.CameraMatrix() << "D2" << rig.right.DistortionVector();
    out << "R" << ToCv(rig.cam2_from_cam1.rotation);
    out << "T" << ToCv(rig.cam2_from_cam1.translation);
    const Rectification& r = rig.rectification;
    out << "R1" << as64(r.R1) << "R2" << as64(r.R2) << "P1" << as64(r.P1) << "P2" << as64(r.P2)
        << "Q" << as64(r.Q);
    out << "units" << "mm";
    if (!rig.replicates.empty()) out << "replicates" << ReplicatesMatrix(rig.replicates);
    out.release();
  });
}

StereoRig ImportOpenCvStereoCalib(const fs::path& intrinsics, const fs::path& extrinsics,
                                  int image_width, int image_height) {
  if (image_width <= 0 || image_height <= 0) {
    ThrowInputError("image size must be positive to import '{}', got {}x{}",
                    intrinsics.string(), image_width, image_height);
  }
  const KeyReader in(intrinsics, "intrinsics file");
  const KeyReader ex(extrinsics, "extrinsics file");
  StereoRig rig = ReadRigCore(in, ex, image_width, image_height);
  // stereo_calib rectifies with CALIB_ZERO_DISPARITY and alpha = 1; a StereoRig's
  // rectification is flags = 0, alpha = -1 (see stereo_rig.h), so it is recomputed
  // rather than taken from R1 R2 P1 P2 Q of extrinsics.yml.
  rig.ComputeRectification();
  return rig;
}

PlaneFile ReadPlaneFile(const fs::path& path) {
  const KeyReader in(path, "plane file");
  PlaneFile file;
  SupportPlane& plane = file.plane;
  plane.normal = in.ReadVector3(
      "normal", "3x1 unit normal of the support plane, camera-1 frame, toward the cameras");
  const double norm = plane.normal.norm();
  if (std::abs(norm - 1) > kUnitNormalTolerance)
    in.Fail("normal", "must be a unit vector (norm 1 within {}), found norm {}",
            kUnitNormalTolerance, norm);
  plane.point = in.ReadVector3("point", "3x1 point on the plane (marker centroid), mm");

  const std::string markers_shape = "an Nx3 matrix with N >= 3";
  const cv::Mat markers =
      in.ReadMatrix("markers", "Nx3 marker centres, camera-1 frame, mm", markers_shape);
  if (markers.cols != 3 || markers.rows < 3)
    in.Fail("markers", "must be {}, found {}", markers_shape, ShapeOf(markers));
  const int n = markers.rows;
  const std::string residuals_shape = fmt::format("a {}x1 vector (one per marker)", n);
  const cv::Mat residuals =
      in.ReadMatrix("residuals", "Nx1 marker distances to the plane, mm", residuals_shape);
  if (residuals.total() != static_cast<size_t>(n) || (residuals.rows != 1 && residuals.cols != 1))
    in.Fail("residuals", "must be {}, found {}", residuals_shape, ShapeOf(residuals));

  for (int i = 0; i < n; ++i) {
    plane.markers.emplace_back(markers.at<double>(i, 0), markers.at<double>(i, 1),
                               markers.at<double>(i, 2));
    plane.residuals_mm.push_back(residuals.at<double>(i));
  }
  if (in.Has("rig_sha256")) {
    const cv::FileNode node = in.Get("rig_sha256");
    file.rig_sha256 = node.isString() ? static_cast<std::string>(node) : "";
    if (!IsSha256Hex(file.rig_sha256))
      in.Fail("rig_sha256", "must be 64 lowercase hexadecimal digits (the SHA-256 of the rig file), found {}",
              node.isString() ? "'" + file.rig_sha256 + "'" : DescribeNode(node));
  }
  return file;
}

void WritePlaneFile(const fs::path& path, const SupportPlane& plane, const std::string& rig_sha256) {
  // A plane that ReadPlaneFile would reject is a programming error here.
  FLATSCAN_CHECK(plane.markers.size() >= 3);
  FLATSCAN_CHECK(plane.residuals_mm.size() == plane.markers.size());
  FLATSCAN_CHECK(std::abs(plane.normal.norm() - 1) <= kUnitNormalTolerance);
  FLATSCAN_CHECK(rig_sha256.empty() || IsSha256Hex(rig_sha256));

  const int n = static_cast<int>(plane.markers.size());
  cv::Mat markers(n, 3, CV_64F), residuals(n, 1, CV_64F);
  double sum_squares = 0;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < 3; ++j) markers.at<double>(i, j) = plane.markers[i][j];
    residuals.at<double>(i) = plane.residuals_mm[i];
    sum_squares += plane.residuals_mm[i] * plane.residuals_mm[i];
  }
  WriteFileAtomically(path, [&](const fs::path& tmp) {
    cv::FileStorage out;
    OpenForWriting(out, path, tmp);
    out << "normal" << ToCv(plane.normal);
    out << "point" << ToCv(plane.point);
    out << "markers" << markers;
    out << "residuals" << residuals;
    out << "residual_rms_mm" << std::sqrt(sum_squares / n);
    if (!rig_sha256.empty()) out << "rig_sha256" << rig_sha256;
    out.release();
  });
}

const char* PlaneRigMatchName(PlaneRigMatch match) {
  switch (match) {
    case PlaneRigMatch::kMatches: return "matches";
    case PlaneRigMatch::kForeign: return "foreign";
    case PlaneRigMatch::kUnknown: return "unknown";
  }
  return "unknown";
}

std::optional<PlaneRigMatch> ParsePlaneRigMatch(const std::string& name) {
  for (PlaneRigMatch m : {PlaneRigMatch::kMatches, PlaneRigMatch::kForeign, PlaneRigMatch::kUnknown})
    if (name == PlaneRigMatchName(m)) return m;
  return std::nullopt;
}

PlaneRigMatch CheckPlaneAgainstRig(const PlaneFile& plane_file, const fs::path& plane_path, const StereoRig& rig,
                                   const fs::path& rig_path, const std::string& rig_sha256, bool allow_foreign) {
  // Heights are normal . (p - point): with the normal reversed every height changes
  // sign, the rim's highest point becomes its lowest and a warped part can pass.
  const SupportPlane& plane = plane_file.plane;
  const Eigen::Vector3d centres[2] = {Eigen::Vector3d::Zero(), rig.cam2_from_cam1.Inverse().OriginOfSource()};
  for (int k = 0; k < 2; ++k) {
    const double height_mm = plane.Height(centres[k]);
    if (!(height_mm > 0))
      ThrowInputError(
          "{}: key 'normal' must point toward the cameras of '{}', but camera {} lies {:.1f} mm {} the plane: "
          "the normal is reversed or the plane belongs to another rig (recalibrate it with `flatscan "
          "calibrate-plane`)",
          plane_path.string(), rig_path.string(), k + 1, std::abs(height_mm), height_mm < 0 ? "behind" : "on");
  }
  if (plane_file.rig_sha256.empty()) return PlaneRigMatch::kUnknown;
  if (plane_file.rig_sha256 == rig_sha256) return PlaneRigMatch::kMatches;
  if (!allow_foreign)
    ThrowInputError(
        "{}: calibrated with another rig file (rig_sha256 {}) than '{}' (SHA-256 {}): recalibrate the plane with "
        "this rig, or give --allow-foreign-plane to measure anyway",
        plane_path.string(), plane_file.rig_sha256.substr(0, 12) + "...", rig_path.string(),
        rig_sha256.substr(0, 12) + "...");
  return PlaneRigMatch::kForeign;
}

}  // namespace flatscan
