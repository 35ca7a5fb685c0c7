#pragma once
// Rig and plane files: OpenCV FileStorage YAML (docs/conventions.md).
//
// Rig file keys: image_width, image_height (int); M1, D1, M2, D2 (camera matrices and
// distortion vectors, 1xN or Nx1 with N in {4, 5, 8}); R (3x3), T (3x1, mm) with
// X2 = R X1 + T; optionally R1 R2 P1 P2 Q (recomputed when absent). These are the
// names OpenCV's stereo_calib sample writes. Optionally `replicates` (written by
// calibrate-rig): the jackknife replicates of the calibration (StereoRig::replicates),
// an Nx30 matrix, one row each: fx1 fy1 cx1 cy1, D1 as 8 values (k1 k2 p1 p2 k3 k4 k5
// k6), the same for camera 2, R as a Rodrigues vector (rad), T (mm).
//
// Plane file keys: normal (3x1 unit, camera-1 frame, toward the cameras), point (3x1),
// markers (Nx3 marker centres), residuals (Nx1, mm), rig_sha256 (SHA-256 of the bytes of
// the rig file the plane was calibrated with; absent in files written before it existed).
//
// Readers throw InputError naming the file, the key and what was expected.
#include <filesystem>
#include <optional>
#include <string>

#include "flatscan/calibration/stereo_rig.h"
#include "flatscan/support_plane/support_plane.h"

namespace flatscan {

StereoRig ReadRigFile(const std::filesystem::path& path);
// Writes all keys including the rectification (computed first if empty); atomic.
void WriteRigFile(const std::filesystem::path& path, const StereoRig& rig);

// Builds a rig from OpenCV stereo_calib's intrinsics.yml (M1 D1 M2 D2) and
// extrinsics.yml (R T [R1 R2 P1 P2 Q]); the image size must be given since those
// files do not record it.
StereoRig ImportOpenCvStereoCalib(const std::filesystem::path& intrinsics,
                                  const std::filesystem::path& extrinsics, int image_width,
                                  int image_height);

// A plane file's contents: the plane and the rig it was calibrated with.
struct PlaneFile {
  SupportPlane plane;
  std::string rig_sha256;  // 64 lowercase hex digits; empty when the file does not say
};

PlaneFile ReadPlaneFile(const std::filesystem::path& path);
// `rig_sha256`: Sha256HexOfFile of the rig file used by the calibration (may be empty
// only for planes that belong to no rig file, e.g. in tests). Atomic.
void WritePlaneFile(const std::filesystem::path& path, const SupportPlane& plane,
                    const std::string& rig_sha256);

// Whether a plane file belongs to the rig it is used with (docs/conventions.md).
enum class PlaneRigMatch { kMatches, kForeign, kUnknown };
const char* PlaneRigMatchName(PlaneRigMatch match);  // "matches", "foreign", "unknown"
std::optional<PlaneRigMatch> ParsePlaneRigMatch(const std::string& name);

// Checks a plane file against the rig file it is about to be used with: the plane's
// normal must point toward both camera centres (else heights change sign and a warped
// part can pass), and its rig_sha256 must be `rig_sha256` (the hash of the rig file's
// bytes). Throws InputError naming both files on a reversed normal, and on a foreign rig
// unless `allow_foreign`; returns kForeign (allowed) or kUnknown (no rig_sha256 in the
// plane file) for the caller to warn about.
PlaneRigMatch CheckPlaneAgainstRig(const PlaneFile& plane_file, const std::filesystem::path& plane_path,
                                   const StereoRig& rig, const std::filesystem::path& rig_path,
                                   const std::string& rig_sha256, bool allow_foreign);

}  // namespace flatscan
