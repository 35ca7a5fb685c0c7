#pragma once
// Rig and plane files: OpenCV FileStorage YAML (docs/conventions.md).
//
// Rig file keys: image_width, image_height (int); M1, D1, M2, D2 (camera matrices and
// distortion vectors, 1xN or Nx1 with N in {4, 5, 8}); R (3x3), T (3x1, mm) with
// X2 = R X1 + T; optionally R1 R2 P1 P2 Q (recomputed when absent). These are the
// names OpenCV's stereo_calib sample writes.
//
// Plane file keys: normal (3x1 unit, camera-1 frame, toward the cameras), point (3x1),
// markers (Nx3 marker centres), residuals (Nx1, mm).
//
// Readers throw InputError naming the file, the key and what was expected.
#include <filesystem>

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

SupportPlane ReadPlaneFile(const std::filesystem::path& path);
void WritePlaneFile(const std::filesystem::path& path, const SupportPlane& plane);

}  // namespace flatscan
